//! Rouard's recursion for a layer stack (the module doc of [`super`] states the
//! conventions and formulas).

use nalgebra::Complex;

use super::Layer;

type C = Complex<f64>;

/// A linear polarisation relative to the plane of incidence.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Polarization {
    /// Electric field perpendicular to the plane of incidence.
    S,
    /// Electric field in the plane of incidence.
    P,
}

/// Amplitude coefficients and powers of a stack at one angle and wavelength.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Response {
    /// Amplitude reflection coefficient, s.
    pub rs: C,
    /// Amplitude reflection coefficient, p.
    pub rp: C,
    /// Amplitude transmission coefficient into the exit medium, s.
    pub ts: C,
    /// Amplitude transmission coefficient into the exit medium, p.
    pub tp: C,
    /// `T_s / |t_s|²`: the ratio of normal power fluxes (0 at grazing incidence).
    flux_s: f64,
    /// `T_p / |t_p|²`.
    flux_p: f64,
}

impl Response {
    /// Power reflectance, s.
    #[must_use]
    pub fn r_s(&self) -> f64 {
        self.rs.norm_sqr()
    }

    /// Power reflectance, p.
    #[must_use]
    pub fn r_p(&self) -> f64 {
        self.rp.norm_sqr()
    }

    /// Power transmittance into the exit medium, s.
    #[must_use]
    pub fn t_s(&self) -> f64 {
        self.ts.norm_sqr() * self.flux_s
    }

    /// Power transmittance into the exit medium, p.
    #[must_use]
    pub fn t_p(&self) -> f64 {
        self.tp.norm_sqr() * self.flux_p
    }

    /// Power absorbed in the layers, s: `1 − R_s − T_s`.
    #[must_use]
    pub fn a_s(&self) -> f64 {
        1.0 - self.r_s() - self.t_s()
    }

    /// Power absorbed in the layers, p: `1 − R_p − T_p`.
    #[must_use]
    pub fn a_p(&self) -> f64 {
        1.0 - self.r_p() - self.t_p()
    }

    /// Unpolarised reflectance `(R_s + R_p)/2`.
    #[must_use]
    pub fn r_unpolarized(&self) -> f64 {
        0.5 * (self.r_s() + self.r_p())
    }

    /// Unpolarised transmittance `(T_s + T_p)/2`.
    #[must_use]
    pub fn t_unpolarized(&self) -> f64 {
        0.5 * (self.t_s() + self.t_p())
    }

    /// `(r, t)` amplitudes of one polarisation.
    #[must_use]
    pub fn amplitudes(&self, pol: Polarization) -> (C, C) {
        match pol {
            Polarization::S => (self.rs, self.ts),
            Polarization::P => (self.rp, self.tp),
        }
    }
}

/// `q = N cos θ = sqrt(N² − s²)`, principal branch (the forward wave). `Im(N²) = 2nk ≥ 0`
/// is kept non-negative explicitly so that a lossless medium beyond the critical angle
/// gets `+i|q|` (decaying), never `−0` in the imaginary part.
fn normal_component(index: C, s2: f64) -> C {
    let n2 = index * index;
    C::new(n2.re - s2, n2.im.abs()).sqrt()
}

/// One interface, medium `a` (index `na`, normal component `qa`) to medium `b`:
/// `(r_s, t_s, r_p, t_p)`.
fn interface(na: C, qa: C, nb: C, qb: C) -> (C, C, C, C) {
    let ds = qa + qb;
    let rs = (qa - qb) / ds;
    let ts = 2.0 * qa / ds;
    let (na2, nb2) = (na * na, nb * nb);
    let dp = nb2 * qa + na2 * qb;
    let rp = (nb2 * qa - na2 * qb) / dp;
    let tp = 2.0 * na * nb * qa / dp;
    (rs, ts, rp, tp)
}

/// The response of validated inputs (see [`super::FilmStack::response`]): a real
/// ambient > 0, an exit index with `n > 0`, `k ≥ 0`, `cos_theta ∈ [0, 1]`, a finite
/// wavelength > 0.
pub(crate) fn response(
    layers: &[Layer],
    n_ambient: f64,
    n_exit: C,
    cos_theta: f64,
    wavelength_nm: f64,
) -> Response {
    let n0 = C::new(n_ambient, 0.0);
    let sin2 = (1.0 - cos_theta * cos_theta).max(0.0);
    let s2 = n_ambient * n_ambient * sin2;
    let q0 = C::new(n_ambient * cos_theta, 0.0);
    let q_exit = normal_component(n_exit, s2);
    // Start at the last interface (the last layer, or the ambient, to the exit medium).
    let (mut n_above, mut q_above) = match layers.last() {
        Some(l) => (l.index, normal_component(l.index, s2)),
        None => (n0, q0),
    };
    let (mut rs, mut ts, mut rp, mut tp) = interface(n_above, q_above, n_exit, q_exit);
    let k0 = 2.0 * std::f64::consts::PI / wavelength_nm;
    for j in (0..layers.len()).rev() {
        // Layer j (its index and q are `n_above`, `q_above`) under the medium above it.
        let (n_up, q_up) = if j == 0 {
            (n0, q0)
        } else {
            let l = layers[j - 1].index;
            (l, normal_component(l, s2))
        };
        let delta = q_above * (k0 * layers[j].thickness_nm);
        let e1 = (C::i() * delta).exp();
        let e2 = e1 * e1;
        let (r_s, t_s, r_p, t_p) = interface(n_up, q_up, n_above, q_above);
        let den_s = 1.0 + r_s * rs * e2;
        ts = t_s * ts * e1 / den_s;
        rs = (r_s + rs * e2) / den_s;
        let den_p = 1.0 + r_p * rp * e2;
        tp = t_p * tp * e1 / den_p;
        rp = (r_p + rp * e2) / den_p;
        n_above = n_up;
        q_above = q_up;
    }
    let (flux_s, flux_p) = if q0.re > 0.0 {
        (
            q_exit.re / q0.re,
            (n_exit * q_exit.conj() / n_exit.conj()).re / q0.re,
        )
    } else {
        (0.0, 0.0)
    };
    Response {
        rs,
        rp,
        ts,
        tp,
        flux_s,
        flux_p,
    }
}

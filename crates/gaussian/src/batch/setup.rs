//! The per-batch constants of the kernel: everything that depends only on the
//! incidence and the model's options (the parent module's docs say which factors are
//! gathered here and why the regrouping stays within a few ulp).

use flakescatter_optics::polarization::{Transmission, Weighting};

use crate::model::{DistributionModel, Incidence};

/// How the orientation distribution gives `p2` in the kernel.
#[derive(Debug, Clone, Copy)]
pub(super) enum Density {
    /// Gaussian: `p2 = norm · exp(k θ²)`, the exponential in the vector kernel and `norm`
    /// in [`Setup::p2_scale`].
    Gaussian { k: f64 },
    /// Tabulated: the scalar `atan2` and bin look-up per lane.
    Table,
}

/// Everything the kernel needs that does not depend on the exit direction.
#[derive(Debug, Clone, Copy)]
pub(super) struct Setup {
    pub(super) n: f64,
    pub(super) inv_n: f64,
    /// `n² − 1`.
    pub(super) n2m1: f64,
    pub(super) k1: [f64; 3],
    /// Normalised-free `s` of the incident direction and its squared length.
    pub(super) s0: [f64; 2],
    pub(super) rho_in2: f64,
    /// `p1 = k1 × s0`.
    pub(super) p1: [f64; 3],
    /// Perfect conductor: `(|rs|², |rp|², 2 Re(rs rp*))`.
    pub(super) flake: Option<(f64, f64, f64)>,
    /// `|rs|² = |rp|² = 1` and `2 Re(rs rp*) = ±2` exactly (the perfect conductor):
    /// `p1` times `∓1`, the sign with which pass 4 writes the two entries of the
    /// coherency product as squares (module docs); `None` for any other flake.
    pub(super) unit_flake: Option<[f64; 3]>,
    /// The `(s → ·)` and `(p → ·)` columns' weights times the squared entry amplitudes,
    /// `(w_s ts², w_p tp²)` with `(w_s, w_p)` = `(1, 1)` unpolarised, `(2, 0)` `s`,
    /// `(0, 2)` `p`; `None` for `paper`.
    pub(super) columns: Option<(f64, f64)>,
    pub(super) exit_fresnel: bool,
    pub(super) printed: bool,
    /// The direction-independent factors of pass 4's quotient in one (module docs):
    /// `0.5 k1_z / ⟨cos θn⟩ · p2_scale · ((2n)² with the exit Fresnel factor, else n)`
    /// over `k_in,z · |s0|² · 4 n² cos θt`.
    pub(super) num_k: f64,
    /// The factor of `p2` that the kernel applies last: the Gaussian's `norm`, 1 for a
    /// table.
    pub(super) p2_scale: f64,
    pub(super) density: Density,
}

impl DistributionModel {
    /// The per-batch constants (module docs).
    pub(super) fn batch_setup(&self, inc: &Incidence) -> Setup {
        let n = self.index();
        let options = self.options();
        let (ki, k1) = (inc.k_in, inc.k1);
        let (mut s0x, mut s0y, mut rho_in2) = (-ki.y, ki.x, ki.x * ki.x + ki.y * ki.y);
        if rho_in2 == 0.0 {
            (s0x, s0y, rho_in2) = (0.0, 1.0, 1.0);
        }
        let p1 = [-k1.z * s0y, k1.z * s0x, k1.x * s0y - k1.y * s0x];
        let (ts, tp) = (inc.amplitudes[2], inc.amplitudes[3]);
        let flake = options.flake.is_perfect().then(|| {
            let (rs, rp) = options.flake.amplitudes(1.0, n);
            (
                rs.norm_sqr(),
                rp.norm_sqr(),
                2.0 * (rs.re * rp.re + rs.im * rp.im),
            )
        });
        let weights = match options.transmission {
            Transmission::ExactUnpolarized => Some((1.0, 1.0)),
            Transmission::S => Some((2.0, 0.0)),
            Transmission::P => Some((0.0, 2.0)),
            Transmission::Paper => None,
        };
        let orientation = self.orientation();
        let (density, p2_scale) = match orientation.gaussian_width() {
            Some(w) => {
                // The same expressions as `Orientation::gaussian`, so `k` is its
                // `−1/(2s²)` to the bit; `p2(0) = norm · exp(−0) = norm` exactly.
                let sigma = w.sigma();
                let k = -0.5 / (sigma * sigma);
                (Density::Gaussian { k }, orientation.p2(0.0))
            }
            None => (Density::Table, 1.0),
        };
        let num_const = 0.5 * k1.z * self.inv_mean_cos();
        let den_const = ki.z * rho_in2 * (4.0 * n * n * inc.cos_t);
        let exit = if options.exit_fresnel {
            (2.0 * n) * (2.0 * n)
        } else {
            n
        };
        Setup {
            n,
            inv_n: 1.0 / n,
            n2m1: n * n - 1.0,
            k1: [k1.x, k1.y, k1.z],
            s0: [s0x, s0y],
            rho_in2,
            p1,
            flake,
            unit_flake: match flake {
                Some((a, b, x2)) if a == 1.0 && b == 1.0 && x2.abs() == 2.0 => {
                    let sign = -0.5 * x2;
                    Some(p1.map(|v| sign * v))
                }
                _ => None,
            },
            columns: weights.map(|(ws, wp)| ((ts * ts) * ws, (tp * tp) * wp)),
            exit_fresnel: options.exit_fresnel,
            printed: options.weighting == Weighting::PaperPrinted,
            num_k: num_const * p2_scale * exit / den_const,
            p2_scale,
            density,
        }
    }
}

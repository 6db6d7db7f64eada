//! Stokes vectors and Mueller matrices (physics.md §11), in SCATMECH's convention.
//!
//! # Conventions
//! * Stokes vectors are taken in the `(s, p)` basis of their direction
//!   ([`crate::jones`]): for a Jones vector `(E_s, E_p)`,
//!   `S0 = |E_s|² + |E_p|²`, `S1 = |E_s|² − |E_p|²`, `S2 = 2 Re(E_s* E_p)`,
//!   `S3 = 2 Im(E_s* E_p)`. So `(1, 1, 0, 0)` is s-polarised, `(1, −1, 0, 0)`
//!   p-polarised, `(1, 0, 1, 0)` linear along `s + p`, `(1, 0, 0, 1)` left circular
//!   (time dependence `exp(−iωt)`; SCATMECH's "Conventions" page).
//! * A Mueller matrix maps incident to outgoing Stokes vectors, `S_out = M S_in`. For a
//!   Jones matrix `J`, `m_ij = ½ tr(σ_i J σ_j J†)` with `σ0 = 1`, `σ1 = diag(1, −1)`,
//!   `σ2 = [[0, 1], [1, 0]]`, `σ3 = [[0, −i], [i, 0]]`, written out element by element
//!   in [`Mueller::from_jones`].
//! * Units are those of what it multiplies: a path's Mueller matrix is a fraction of
//!   the beam power (no unit), a Mueller BRDF is per steradian. `m00` is what an
//!   unpolarised beam gives with every polarisation detected.
//! * A non-depolarising Mueller matrix (one Jones matrix) satisfies
//!   `tr(MᵀM) = 4 m00²` (Gil and Bernabeu 1985); a physically realisable one (a sum of
//!   non-depolarising ones, e.g. an integral over a detector cone) has a positive
//!   semi-definite coherency matrix `H = ¼ Σ m_ij σ_i ⊗ σ_j*` (Cloude 1986), whose
//!   eigenvalues sum to `m00` ([`Mueller::coherency_eigenvalues`]).

use std::ops::{Add, AddAssign, Mul};

use nalgebra::{Complex, Matrix4};

pub use crate::stokes::{Analyzer, STOKES_TOL, Stokes};

/// A 4 × 4 Mueller matrix (module docs for the basis and the unit).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mueller(pub Matrix4<f64>);

impl Default for Mueller {
    fn default() -> Self {
        Self::ZERO
    }
}

impl Mueller {
    /// The zero matrix.
    pub const ZERO: Self = Self(Matrix4::new(
        0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    ));

    /// The identity (a non-polarising, lossless element).
    #[must_use]
    pub fn identity() -> Self {
        Self(Matrix4::identity())
    }

    /// From 16 elements in row-major order (`m00, m01, …, m33`).
    #[must_use]
    pub fn from_row_major(m: &[f64; 16]) -> Self {
        Self(Matrix4::from_row_slice(m))
    }

    /// The 16 elements in row-major order (`m00, m01, …, m33`).
    #[must_use]
    pub fn to_row_major(&self) -> [f64; 16] {
        let mut out = [0.0; 16];
        for (i, row) in out.chunks_exact_mut(4).enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = self.0[(i, j)];
            }
        }
        out
    }

    /// Element `m_ij` (row `i`, column `j`, both in `0..4`).
    #[must_use]
    #[inline]
    pub fn get(&self, i: usize, j: usize) -> f64 {
        self.0[(i, j)]
    }

    /// `m00`: the result for unpolarised light with every polarisation detected.
    #[must_use]
    #[inline]
    pub fn m00(&self) -> f64 {
        self.0[(0, 0)]
    }

    /// The same matrix with the outgoing Stokes vector expressed in a basis turned by
    /// `χ` about the direction of propagation, `s' = cos χ s + sin χ p`, given as
    /// `(c, d) = (cos χ, sin χ)` ([`crate::jones::exit_frame`]): `S1' = cos 2χ S1 +
    /// sin 2χ S2`, `S2' = −sin 2χ S1 + cos 2χ S2` (rows 1 and 2), the Mueller form of
    /// [`crate::jones::JonesMatrix::rotate_out`].
    #[must_use]
    #[inline]
    pub fn rotate_out(&self, (c, d): (f64, f64)) -> Self {
        let (c2, s2) = (c * c - d * d, 2.0 * c * d);
        let mut m = self.0;
        for k in 0..4 {
            let (a, b) = (m[(1, k)], m[(2, k)]);
            m[(1, k)] = c2 * a + s2 * b;
            m[(2, k)] = c2 * b - s2 * a;
        }
        Self(m)
    }

    /// The Stokes vector leaving for the incident Stokes vector `s`: `M s`.
    #[must_use]
    pub fn apply(&self, s: &Stokes) -> [f64; 4] {
        let v = self.0 * nalgebra::Vector4::from(s.parameters());
        [v[0], v[1], v[2], v[3]]
    }

    /// What a detector behind `analyzer` reads for the incident polarisation
    /// `incident` (normalised to unit power, `S0 = 1`): `a · M · s`, with `a` the
    /// analyser's row ([`Analyzer::row`]). In the unit of the matrix (a BRDF for a
    /// Mueller BRDF).
    #[must_use]
    pub fn detected(&self, incident: &Stokes, analyzer: &Analyzer) -> f64 {
        let out = self.apply(&incident.normalized());
        let a = analyzer.row();
        a[0] * out[0] + a[1] * out[1] + a[2] * out[2] + a[3] * out[3]
    }

    /// Degree of polarisation of the light leaving for unpolarised incident light,
    /// `sqrt(m10² + m20² + m30²) / m00` (the first column is the outgoing Stokes
    /// vector); NaN when `m00 = 0`.
    #[must_use]
    pub fn dop_unpolarized(&self) -> f64 {
        let m = &self.0;
        if m[(0, 0)] == 0.0 {
            return f64::NAN;
        }
        (m[(1, 0)] * m[(1, 0)] + m[(2, 0)] * m[(2, 0)] + m[(3, 0)] * m[(3, 0)]).sqrt() / m[(0, 0)]
    }

    /// `tr(MᵀM) / (4 m00²)`: 1 for a non-depolarising matrix (Gil–Bernabeu), between
    /// 1/4 (ideal depolariser) and 1 for a physically realisable one; NaN when
    /// `m00 = 0`.
    #[must_use]
    pub fn gil_bernabeu_ratio(&self) -> f64 {
        let m00 = self.0[(0, 0)];
        if m00 == 0.0 {
            return f64::NAN;
        }
        self.0.norm_squared() / (4.0 * m00 * m00)
    }

    /// Eigenvalues of the coherency matrix `H = ¼ Σ m_ij σ_i ⊗ σ_j*` (Cloude), in
    /// increasing order; they sum to `m00`. All `≥ 0` (to rounding) for a physically
    /// realisable matrix; one non-zero for a non-depolarising one.
    #[must_use]
    pub fn coherency_eigenvalues(&self) -> [f64; 4] {
        let sig = pauli();
        let mut h = Matrix4::<Complex<f64>>::zeros();
        for i in 0..4 {
            for j in 0..4 {
                let w = 0.25 * self.0[(i, j)];
                if w == 0.0 {
                    continue;
                }
                let a = &sig[i];
                let b = sig[j].map(|z| z.conj());
                for r in 0..4 {
                    for c in 0..4 {
                        h[(r, c)] += a[(r / 2, c / 2)] * b[(r % 2, c % 2)] * w;
                    }
                }
            }
        }
        // Hermitian to rounding; symmetrise before the eigen solver.
        let h = (h + h.adjoint()) * Complex::new(0.5, 0.0);
        let e = nalgebra::SymmetricEigen::new(h).eigenvalues;
        let mut out = [e[0], e[1], e[2], e[3]];
        out.sort_by(f64::total_cmp);
        out
    }
}

/// The Pauli matrices in the order of the Stokes parameters (module docs).
fn pauli() -> [nalgebra::Matrix2<Complex<f64>>; 4] {
    let z = Complex::new(0.0, 0.0);
    let o = Complex::new(1.0, 0.0);
    let i = Complex::new(0.0, 1.0);
    [
        nalgebra::Matrix2::new(o, z, z, o),
        nalgebra::Matrix2::new(o, z, z, -o),
        nalgebra::Matrix2::new(z, o, o, z),
        nalgebra::Matrix2::new(z, -i, i, z),
    ]
}

impl Add for Mueller {
    type Output = Self;
    #[inline]
    fn add(self, rhs: Self) -> Self {
        Self(self.0 + rhs.0)
    }
}

impl AddAssign for Mueller {
    #[inline]
    fn add_assign(&mut self, rhs: Self) {
        self.0 += rhs.0;
    }
}

impl Mul<f64> for Mueller {
    type Output = Self;
    #[inline]
    fn mul(self, k: f64) -> Self {
        Self(self.0 * k)
    }
}

/// Mueller matrices are integrated element by element on the same quadrature nodes (the
/// cone integrals of the distribution model).
impl flakescatter_numerics::quad::QuadValue for Mueller {
    #[inline]
    fn zero() -> Self {
        Self::ZERO
    }
    #[inline]
    fn plus(self, other: Self) -> Self {
        self + other
    }
    #[inline]
    fn times(self, k: f64) -> Self {
        self * k
    }
    #[inline]
    fn size(&self) -> f64 {
        self.m00().abs()
    }
    #[inline]
    fn distance(&self, other: &Self) -> f64 {
        (self.0 - other.0).amax()
    }
    const BASIS_DEPENDENT: bool = true;
    /// Under the mirror `y → −y` the `s` vectors of the incident and the exit basis
    /// turn into minus the mirror images of the old ones and the `p` vectors into their
    /// mirror images, so `J → diag(−1, 1) J diag(−1, 1)` and `M → D M D`. The same holds
    /// for an exit basis whose reference `s` lies in the xz-plane (a detector at the
    /// pole with azimuth ±90°): there `s → +mirror(s)`, `p → −mirror(p)`, `diag(1, −1)`,
    /// the same `D M D`. For any other reference the mirror does not apply
    /// ([`flakescatter_numerics::quad::QuadValue::BASIS_DEPENDENT`],
    /// [`crate::detector::Cone::mirror_keeps_basis`]).
    #[inline]
    fn mirrored(self) -> Self {
        let mut m = self.0;
        for i in 0..4 {
            for j in 0..4 {
                if (i >= 2) != (j >= 2) {
                    m[(i, j)] = -m[(i, j)];
                }
            }
        }
        Self(m)
    }
}

//! Non-negative least squares (Lawson & Hanson 1974, algorithm NNLS):
//! minimise `|A x − b|²` subject to `x ≥ 0`.
//!
//! The active-set method: variables enter the passive set by the largest gradient
//! component and leave it when a least-squares step (SVD solve) would make them
//! negative.

use nalgebra::{DMatrix, DVector};

/// Solve `min |A x − b|` with `x ≥ 0`. Returns `None` when the iteration limit
/// (`3 n` outer steps) is reached without satisfying the optimality conditions.
#[must_use]
pub fn nnls(a: &DMatrix<f64>, b: &DVector<f64>) -> Option<DVector<f64>> {
    let n = a.ncols();
    let mut x = DVector::<f64>::zeros(n);
    let mut passive = vec![false; n];
    let tol = 1e-12 * a.norm().max(1e-300) * b.norm().max(1e-300);
    for _ in 0..(3 * n + 10) {
        // Gradient of −½|Ax − b|²: w = Aᵀ(b − A x).
        let w = a.transpose() * (b - a * &x);
        // Most promising active variable.
        let candidate = (0..n)
            .filter(|&j| !passive[j])
            .max_by(|&i, &j| w[i].total_cmp(&w[j]));
        match candidate {
            Some(j) if w[j] > tol => passive[j] = true,
            _ => return Some(x),
        }
        // Inner loop: least squares on the passive set, stepping back to stay feasible.
        loop {
            let idx: Vec<usize> = (0..n).filter(|&j| passive[j]).collect();
            let sub = DMatrix::from_fn(a.nrows(), idx.len(), |r, c| a[(r, idx[c])]);
            let z_sub = sub.clone().svd(true, true).solve(b, 1e-14).ok()?;
            if z_sub.iter().all(|&v| v > 0.0) {
                x.fill(0.0);
                for (k, &j) in idx.iter().enumerate() {
                    x[j] = z_sub[k];
                }
                break;
            }
            // Step from x toward z as far as feasibility allows.
            let mut alpha = f64::INFINITY;
            for (k, &j) in idx.iter().enumerate() {
                if z_sub[k] <= 0.0 {
                    let step = x[j] / (x[j] - z_sub[k]);
                    alpha = alpha.min(step);
                }
            }
            for (k, &j) in idx.iter().enumerate() {
                x[j] += alpha * (z_sub[k] - x[j]);
                if x[j] <= 1e-15 * (1.0 + z_sub[k].abs()) {
                    x[j] = 0.0;
                    passive[j] = false;
                }
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_an_interior_solution() {
        // A x = b has an exact positive solution: NNLS must return it.
        let a = DMatrix::from_row_slice(
            4,
            3,
            &[1.0, 2.0, 0.5, 0.3, 1.0, 2.0, 2.0, 0.1, 1.0, 1.0, 1.0, 1.0],
        );
        let x_true = DVector::from_vec(vec![0.5, 1.5, 2.0]);
        let b = &a * &x_true;
        let x = nnls(&a, &b).unwrap();
        assert!((x - x_true).norm() < 1e-10);
    }

    #[test]
    fn satisfies_the_kkt_conditions_at_the_boundary() {
        // The unconstrained solution of this problem has a negative component
        // (x = (1, −1) solves it exactly), so the constrained one sits on x₂ = 0.
        let a = DMatrix::from_row_slice(3, 2, &[1.0, 0.0, 0.0, 1.0, 1.0, 1.0]);
        let b = DVector::from_vec(vec![1.0, -1.0, 0.0]);
        let x = nnls(&a, &b).unwrap();
        // KKT: x ≥ 0, w = Aᵀ(b − A x) ≤ 0, and w_j = 0 where x_j > 0.
        let w = a.transpose() * (&b - &a * &x);
        for j in 0..2 {
            assert!(x[j] >= 0.0);
            assert!(w[j] <= 1e-12);
            if x[j] > 0.0 {
                assert!(w[j].abs() < 1e-12);
            }
        }
        // Closed form on the face x₂ = 0: minimise (x₁−1)² + 1 + x₁² → x₁ = 1/2.
        assert!((x[0] - 0.5).abs() < 1e-12 && x[1] == 0.0);
    }
}

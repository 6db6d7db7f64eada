//! The cone quadrature against the independent Monte Carlo ray tracer: a chi-square test
//! over whole curves (fixed seeds), and the reproducibility of the estimator.

use flakescatter_gaussian::{ConeMethod, DistributionModel, ModelOptions, monte_carlo};
use flakescatter_optics::detector::Cone;
use flakescatter_optics::polarization::{Transmission, Weighting};
use flakescatter_stats::{GaussianWidth, Orientation};
use statrs::distribution::{ChiSquared, ContinuousCDF};

/// Chi-square of MC against quadrature over the cones, pooling cones with fewer than
/// `min_hits` rays into one cell. Returns (chi2, degrees of freedom).
fn chi_square(
    model: &DistributionModel,
    ti_deg: f64,
    cones: &[Cone],
    samples: u64,
    seed: u64,
) -> (f64, usize) {
    let inc = model.incidence(ti_deg.to_radians()).unwrap();
    let mc = monte_carlo(model, &inc, cones, samples, seed).unwrap();
    let (mut chi2, mut dof) = (0.0, 0);
    let (mut pool_mc, mut pool_q, mut pool_var, mut pool_hits) = (0.0, 0.0, 0.0, 0u64);
    for (est, cone) in mc.iter().zip(cones) {
        let q = model.collect(&inc, cone, ConeMethod::Exact);
        let rho = q.reflectance.unwrap();
        // The quadrature must be far more accurate than the MC.
        assert!(
            q.error < 0.05 * est.std_err.max(1e-15) || q.error < 1e-12,
            "quadrature error {}",
            q.error
        );
        if est.hits >= 50 {
            chi2 += ((est.reflectance - rho) / est.std_err).powi(2);
            dof += 1;
        } else {
            pool_mc += est.reflectance;
            pool_q += rho;
            pool_var += est.std_err * est.std_err;
            pool_hits += est.hits;
        }
    }
    if pool_hits >= 50 {
        chi2 += (pool_mc - pool_q).powi(2) / pool_var;
        dof += 1;
    }
    (chi2, dof)
}

fn in_plane_cones(alpha_deg: f64, step_deg: f64) -> Vec<Cone> {
    // Non-overlapping cones (step > 2α) so that the cells are independent.
    let mut v = Vec::new();
    let mut ts = -70.0;
    while ts <= 70.0 {
        v.push(Cone::in_plane(f64::to_radians(ts), alpha_deg.to_radians()).unwrap());
        ts += step_deg;
    }
    v
}

fn critical(dof: usize) -> f64 {
    ChiSquared::new(dof as f64).unwrap().inverse_cdf(0.999)
}

#[test]
fn quadrature_agrees_with_monte_carlo_over_whole_curves() {
    let cases = [
        (
            1.5,
            6.0,
            45.0,
            Transmission::ExactUnpolarized,
            Weighting::Physical,
            11u64,
        ),
        (
            1.5,
            10.0,
            60.0,
            Transmission::Paper,
            Weighting::Physical,
            12,
        ),
        (1.3, 3.0, 30.0, Transmission::S, Weighting::PaperPrinted, 13),
        (1.5, 6.0, 0.0, Transmission::P, Weighting::Physical, 14),
    ];
    let cones = in_plane_cones(1.5, 3.5);
    for (n, w, ti, transmission, weighting, seed) in cases {
        let o = Orientation::gaussian(GaussianWidth::Hwhm(f64::to_radians(w))).unwrap();
        let m = DistributionModel::new(
            o,
            n,
            ModelOptions {
                transmission,
                weighting,
                ..ModelOptions::default()
            },
        )
        .unwrap();
        let (chi2, dof) = chi_square(&m, ti, &cones, 2_000_000, seed);
        assert!(dof >= 10, "too few cells: {dof}");
        assert!(
            chi2 < critical(dof),
            "n={n} w={w} θi={ti}: chi2 {chi2} for {dof} dof (limit {})",
            critical(dof)
        );
    }
}

#[test]
fn out_of_plane_detectors_agree_with_monte_carlo() {
    let o = Orientation::gaussian(GaussianWidth::Hwhm(8f64.to_radians())).unwrap();
    let m = DistributionModel::new(o, 1.5, ModelOptions::default()).unwrap();
    let mut cones = Vec::new();
    for phi in [0.0, 20.0, 45.0, 90.0, 135.0] {
        for tr in [10.0, 30.0, 45.0, 60.0] {
            cones.push(
                Cone::out_of_plane(f64::to_radians(tr), f64::to_radians(phi), 3f64.to_radians())
                    .unwrap(),
            );
        }
    }
    let (chi2, dof) = chi_square(&m, 40.0, &cones, 2_000_000, 7);
    assert!(dof >= 8, "too few cells: {dof}");
    assert!(chi2 < critical(dof), "chi2 {chi2} for {dof} dof");
}

#[test]
fn monte_carlo_is_reproducible_and_seed_dependent() {
    let o = Orientation::gaussian(GaussianWidth::Hwhm(6f64.to_radians())).unwrap();
    let m = DistributionModel::new(o, 1.5, ModelOptions::default()).unwrap();
    let inc = m.incidence(0.5).unwrap();
    let cones = in_plane_cones(2.0, 10.0);
    let a = monte_carlo(&m, &inc, &cones, 300_000, 1).unwrap();
    let b = monte_carlo(&m, &inc, &cones, 300_000, 1).unwrap();
    let c = monte_carlo(&m, &inc, &cones, 300_000, 2).unwrap();
    assert_eq!(a, b);
    assert_ne!(a, c);
    // Same answer with one thread as with the default pool.
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let d = pool.install(|| monte_carlo(&m, &inc, &cones, 300_000, 1).unwrap());
    assert_eq!(a, d);
}

#[test]
fn zero_samples_is_an_error_not_a_nan() {
    let o = Orientation::gaussian(GaussianWidth::Hwhm(5f64.to_radians())).unwrap();
    let m = DistributionModel::new(o, 1.5, ModelOptions::default()).unwrap();
    let inc = m.incidence(0.3).unwrap();
    let cones = [Cone::in_plane(-0.3, 0.02).unwrap()];
    assert_eq!(
        monte_carlo(&m, &inc, &cones, 0, 1),
        Err(flakescatter_gaussian::ModelError::Empty(
            "Monte Carlo sample"
        ))
    );
}

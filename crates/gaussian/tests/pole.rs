//! A detector at the pole (`θr = 0`) takes the polarisation basis of its own azimuth
//! (issue 52, item 13): its Mueller matrix is the limit `θr → 0` at fixed `φr`.
//!
//! Two independent checks:
//! * **the limit**: the pole against `θr = 1e-6°` at the same `φr`, element by element.
//!   The elements are smooth in the direction, so they differ by `O(θr)`, about
//!   `2·10⁻⁸` of `m00` here; the tolerance is `10⁻⁶ m00` (a basis that ignores `φr`
//!   differs by `O(m00)`: `m11` changes sign at `φr = 90°`, the issue's example);
//! * **the rotation**: at the pole the axis is the same for every `φr`, so the
//!   matrices differ only by the basis of the outgoing light, `s(φ) = (−sin φ, cos φ, 0)
//!   = cos φ s(0) + sin φ p(0)` with `s(0) = y`, `p(0) = z × y = −x`: the outgoing
//!   Stokes vector turns by `2φ`, rows 1 and 2 becoming `cos 2φ r1 + sin 2φ r2` and
//!   `cos 2φ r2 − sin 2φ r1`, rows 0 and 3 unchanged (written out below, not taken from
//!   the code under test), to rounding for a point detector and to the quadrature's
//!   tolerance for a cone (its relative error estimate, `LIGHT_RULE_TOLERANCE`).
//!
//! SCATMECH's closed-form models write the Jones matrix in `θs, φs` (e.g.
//! `Facet_BRDF_Model::jones` in `facet.cpp`: `j[2] = −sin φs (…)`), so at `θs = 0` its
//! matrix turns with `φs` too; its vector helper `GetBasisVectorsSP` falls back to
//! `s = y` within 1e-10 of the pole, the old behaviour here, which agrees with the limit
//! only along `φ = 0°` and `180°`.

use flakescatter_gaussian::cone::LIGHT_RULE_TOLERANCE;
use flakescatter_gaussian::{ConeMethod, DistributionModel, ModelOptions};
use flakescatter_optics::detector::Cone;
use flakescatter_optics::flake::FlakeReflectance;
use flakescatter_optics::mueller::Mueller;
use flakescatter_stats::{GaussianWidth, Orientation};

const PHIS_DEG: [f64; 5] = [0.0, 30.0, 90.0, 135.0, 270.0];

fn model(clearcoat: bool) -> DistributionModel {
    let o = Orientation::gaussian(GaussianWidth::RmsTilt(12f64.to_radians())).unwrap();
    let options = ModelOptions {
        flake: FlakeReflectance::complex(0.96, 6.69).unwrap(),
        clearcoat,
        ..ModelOptions::default()
    };
    DistributionModel::new(o, 1.5, options).unwrap()
}

/// `M(φ)` from `M(0)` at the pole (module docs).
fn turned(m0: &Mueller, phi: f64) -> [[f64; 4]; 4] {
    let (c2, s2) = ((2.0 * phi).cos(), (2.0 * phi).sin());
    std::array::from_fn(|i| {
        std::array::from_fn(|k| match i {
            1 => c2 * m0.get(1, k) + s2 * m0.get(2, k),
            2 => c2 * m0.get(2, k) - s2 * m0.get(1, k),
            _ => m0.get(i, k),
        })
    })
}

fn collect(
    m: &DistributionModel,
    ti: f64,
    theta_deg: f64,
    phi_deg: f64,
    alpha_deg: f64,
    method: ConeMethod,
) -> Mueller {
    let inc = m.incidence(ti.to_radians()).unwrap();
    let cone = Cone::out_of_plane(
        theta_deg.to_radians(),
        phi_deg.to_radians(),
        alpha_deg.to_radians(),
    )
    .unwrap();
    let c = m.collect_mueller(&inc, &cone, method);
    c.brdf
}

#[test]
fn the_pole_is_the_limit_at_the_detectors_azimuth() {
    for (clearcoat, ti) in [(false, 30.0f64), (false, 0.0), (true, 0.0)] {
        let m = model(clearcoat);
        for (alpha, method) in [
            (0.0f64, ConeMethod::Exact),
            (1.5, ConeMethod::Exact),
            (1.5, ConeMethod::ConstantIntegrand),
        ] {
            if method == ConeMethod::ConstantIntegrand
                && m.check_method(
                    &m.incidence(ti.to_radians()).unwrap(),
                    alpha.to_radians(),
                    method,
                )
                .is_err()
            {
                continue;
            }
            let at0 = collect(&m, ti, 0.0, 0.0, alpha, method);
            assert!(at0.m00() > 0.0);
            for phi in PHIS_DEG {
                let pole = collect(&m, ti, 0.0, phi, alpha, method);
                let near = collect(&m, ti, 1e-6, phi, alpha, method);
                let want = turned(&at0, phi.to_radians());
                let scale = pole.m00();
                // Point detectors and the constant integrand evaluate the same
                // direction: the rotation holds to rounding, the limit to O(θr). Exact
                // cones off the mirror axes integrate over the full circle instead of
                // the mirrored half (the mirror does not keep their basis), on other
                // nodes: each rule is accepted at a relative error estimate of
                // LIGHT_RULE_TOLERANCE = 1e-6, so two of them agree to a few times that.
                let (lim_tol, rot_tol) = if alpha > 0.0 && method == ConeMethod::Exact {
                    (3.0 * LIGHT_RULE_TOLERANCE, 3.0 * LIGHT_RULE_TOLERANCE)
                } else {
                    (1e-6, 1e-12)
                };
                for (i, row) in want.iter().enumerate() {
                    for (k, &w) in row.iter().enumerate() {
                        let what = format!(
                            "θi {ti}°, clear coat {clearcoat}, α {alpha}° {method:?}, φ {phi}°: m{i}{k}"
                        );
                        let (p, n) = (pole.get(i, k), near.get(i, k));
                        assert!(
                            (p - n).abs() <= lim_tol * scale,
                            "{what}: pole {p} vs θr = 1e-6° {n}"
                        );
                        assert!(
                            (p - w).abs() <= rot_tol * scale,
                            "{what}: pole {p} vs M(0) turned by 2φ {w}"
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn the_issues_example_m11_changes_sign_at_ninety_degrees() {
    // Normal incidence on a perfect-conductor layer, point detector at the pole: the
    // light leaves as it came, s stays s in the basis of φ = 0 (m11 = m00), and in the
    // basis turned by 90° s becomes p (m11 = −m00).
    let o = Orientation::gaussian(GaussianWidth::RmsTilt(12f64.to_radians())).unwrap();
    let m = DistributionModel::new(o, 1.5, ModelOptions::default()).unwrap();
    let m0 = collect(&m, 0.0, 0.0, 0.0, 0.0, ConeMethod::Exact);
    let m90 = collect(&m, 0.0, 0.0, 90.0, 0.0, ConeMethod::Exact);
    assert!((m0.get(1, 1) / m0.m00() - 1.0).abs() < 1e-12, "{m0:?}");
    assert!((m90.get(1, 1) / m90.m00() + 1.0).abs() < 1e-12, "{m90:?}");
}

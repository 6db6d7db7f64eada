//! Jones and Mueller calculus of the optics layer (physics.md §11). Every expected value
//! comes from a definition or a closed form written next to the assertion: the trace
//! definition of the Mueller matrix, the vector form of mirror reflection by a perfect
//! conductor, the in-plane Fresnel power products (physics.md §2, verified before),
//! Malus's law, and the coherency eigenvalues of diagonal Mueller matrices.

// Matrix elements read best as m[i][k] over explicit index ranges.
#![allow(clippy::needless_range_loop)]

use std::f64::consts::PI;

use flakescatter_optics::flake::FlakeReflectance;
use flakescatter_optics::jones::{
    self, C64, JonesMatrix, PathAmplitudes, RayPath, clearcoat_jones, exit_amplitudes,
};
use flakescatter_optics::mueller::{Analyzer, Mueller, Stokes};
use flakescatter_optics::{OpticsError, Vec3, detector, fresnel, reflection, refraction};
use nalgebra::Matrix2;
use proptest::prelude::*;

/// The Pauli matrices in Stokes order: S_k = E† σ_k E with S1 = |Es|² − |Ep|²,
/// S2 = 2 Re(Es* Ep), S3 = 2 Im(Es* Ep).
fn pauli() -> [Matrix2<C64>; 4] {
    let z = C64::new(0.0, 0.0);
    let o = C64::new(1.0, 0.0);
    let i = C64::new(0.0, 1.0);
    [
        Matrix2::new(o, z, z, o),
        Matrix2::new(o, z, z, -o),
        Matrix2::new(z, o, o, z),
        Matrix2::new(z, -i, i, z),
    ]
}

/// The definition `m_ij = ½ tr(σ_i J σ_j J†)`.
fn mueller_by_trace(j: &JonesMatrix) -> [[f64; 4]; 4] {
    let jm = Matrix2::new(j.0[0][0], j.0[0][1], j.0[1][0], j.0[1][1]);
    let s = pauli();
    let mut out = [[0.0; 4]; 4];
    for (i, row) in out.iter_mut().enumerate() {
        for (k, v) in row.iter_mut().enumerate() {
            *v = 0.5 * (s[i] * jm * s[k] * jm.adjoint()).trace().re;
        }
    }
    out
}

fn complex() -> impl Strategy<Value = C64> {
    (-2.0..2.0f64, -2.0..2.0f64).prop_map(|(a, b)| C64::new(a, b))
}

/// A ray from `θi ∈ [0, 80°)` at index `n` off a flake tilted by up to 30°, kept only
/// when it leaves the coating.
fn ray(n: f64, theta_i: f64, tilt: f64, azimuth: f64) -> Option<RayPath> {
    let k_in = detector::incident_direction(theta_i);
    let k1 = refraction::into_coating(&k_in, n);
    let m = flakescatter_optics::UnitVec3::new_normalize(Vec3::new(
        tilt.sin() * azimuth.cos(),
        tilt.sin() * azimuth.sin(),
        tilt.cos(),
    ));
    if reflection::obliquity(&k1, &m) <= 0.0 {
        return None;
    }
    let k2 = reflection::reflect(&k1, &m);
    // Not grazing: k_out.z = sqrt(1 − n²(k2.x² + k2.y²)) loses digits there.
    if k2.z <= 0.05 {
        return None;
    }
    let k_out = refraction::out_of_coating(&k2, n)?;
    Some(RayPath {
        k_in: k_in.into_inner(),
        k1: k1.into_inner(),
        m: m.into_inner(),
        k2: k2.into_inner(),
        k_out: k_out.into_inner(),
    })
}

fn amplitudes(path: &RayPath, n: f64, flake: FlakeReflectance) -> PathAmplitudes {
    let theta_i = (-path.k_in.z).acos();
    let [_, _, ts, tp] = fresnel::amplitudes_air_to_coating(theta_i, n);
    let gamma = -path.k1.dot(&path.m);
    PathAmplitudes {
        entry: (ts, tp),
        flake: flake.amplitudes(gamma, n),
        exit: exit_amplitudes(path.k_out.z, path.k2.z, n),
    }
}

fn flake_of(kind: u8) -> FlakeReflectance {
    match kind {
        0 => FlakeReflectance::PerfectConductor,
        1 => FlakeReflectance::aluminium_550nm(),
        _ => FlakeReflectance::complex(0.2, 3.0).unwrap(),
    }
}

proptest! {
    #[test]
    fn mueller_from_jones_is_the_trace_definition(
        a in complex(), b in complex(), c in complex(), d in complex()
    ) {
        let j = JonesMatrix([[a, b], [c, d]]);
        let m = Mueller::from_jones(&j);
        let r = mueller_by_trace(&j);
        for i in 0..4 {
            for k in 0..4 {
                prop_assert!((m.get(i, k) - r[i][k]).abs() < 1e-12, "m{i}{k}: {} vs {}", m.get(i, k), r[i][k]);
            }
        }
    }

    #[test]
    fn rotating_the_outgoing_basis_commutes_with_the_mueller_matrix(
        a in complex(), b in complex(), c in complex(), d in complex(), chi in 0.0..6.3f64
    ) {
        // M(R J) = R_M M(J): the Jones frame rotation and its Mueller form agree.
        let j = JonesMatrix([[a, b], [c, d]]);
        let rot = (chi.cos(), chi.sin());
        let lhs = Mueller::from_jones(&j.rotate_out(rot));
        let rhs = Mueller::from_jones(&j).rotate_out(rot);
        for i in 0..4 {
            for k in 0..4 {
                prop_assert!((lhs.get(i, k) - rhs.get(i, k)).abs() < 1e-12);
            }
        }
        // Turning the basis by χ = π/4 toward p (s' = (s + p)/√2, p' = (p − s)/√2) puts
        // s light along s' − p': S2' = 2 Re(E's* E'p) = −1.
        let s = Mueller::identity().rotate_out(((0.25 * PI).cos(), (0.25 * PI).sin())).apply(&Stokes::S);
        prop_assert!((s[2] + 1.0).abs() < 1e-15 && s[1].abs() < 1e-15);
    }

    #[test]
    fn every_path_mueller_matrix_is_non_depolarising_and_realisable(
        n in 1.0..2.0f64, ti in 0.0..80f64, tilt in 0.0..30f64, az in 0.0..360f64, kind in 0u8..3
    ) {
        let Some(path) = ray(n, ti.to_radians(), tilt.to_radians(), az.to_radians()) else {
            return Ok(());
        };
        let amps = amplitudes(&path, n, flake_of(kind));
        let m = path.transfer(&amps).mueller();
        // The scalar models' shortcut (real arithmetic, no square root) is the same row.
        let (m00, m01) = path.first_row(&amps);
        prop_assert!((m00 - m.m00()).abs() < 1e-14 && (m01 - m.get(0, 1)).abs() < 1e-14);
        // Gil–Bernabeu: tr(MᵀM) = 4 m00² for one Jones matrix.
        prop_assert!((m.gil_bernabeu_ratio() - 1.0).abs() < 1e-12, "{}", m.gil_bernabeu_ratio());
        // Cloude: one eigenvalue m00, three zero (rank 1, positive semi-definite).
        let e = m.coherency_eigenvalues();
        let m00 = m.m00();
        prop_assert!(m00 > 0.0 && m00 <= 1.0 + 1e-12, "energy: m00 = {m00}");
        prop_assert!((e[3] - m00).abs() < 1e-12 * m00.max(1e-300) + 1e-15, "{e:?} vs {m00}");
        for v in &e[..3] {
            prop_assert!(v.abs() < 1e-12 * m00 + 1e-15, "{e:?}");
        }
        // No element exceeds m00.
        for i in 0..4 {
            for k in 0..4 {
                prop_assert!(m.get(i, k).abs() <= m00 * (1.0 + 1e-12));
            }
        }
    }

    #[test]
    fn n_1_and_a_perfect_conductor_give_the_vector_mirror(
        ti in 0.0..85f64, tilt in 0.0..40f64, az in 0.0..360f64
    ) {
        // Without a clear coat (n = 1, t = 1) a perfectly conducting mirror of normal m
        // reflects the field as E_out = 2 (m·E) m − E (tangential part reversed, normal
        // part kept). In the bases of the module docs, J_ab = e_a(out) · (2 m mᵀ − 1) e_b(in).
        let Some(path) = ray(1.0, ti.to_radians(), tilt.to_radians(), az.to_radians()) else {
            return Ok(());
        };
        let t = path.transfer(&amplitudes(&path, 1.0, FlakeReflectance::PerfectConductor));
        let (si, pi) = jones::sp_basis(&path.k_in);
        let (so, po) = jones::sp_basis(&path.k_out);
        let mirror = |e: &Vec3| path.m * (2.0 * path.m.dot(e)) - e;
        let expected = [[so.dot(&mirror(&si)), so.dot(&mirror(&pi))], [po.dot(&mirror(&si)), po.dot(&mirror(&pi))]];
        for a in 0..2 {
            for b in 0..2 {
                let got = t.jones.get(a, b);
                prop_assert!((got.re - expected[a][b]).abs() < 1e-12 && got.im.abs() < 1e-15, "J{a}{b} {got} vs {}", expected[a][b]);
            }
        }
        prop_assert!((t.power_scale - 1.0).abs() < 1e-12);
        // The Mueller matrix is a rotated mirror: m00 = 1, circular handedness reversed
        // (m33 = −1), the linear block an improper rotation [[cos 2χ, sin 2χ], [sin 2χ, −cos 2χ]].
        let m = t.mueller();
        prop_assert!((m.m00() - 1.0).abs() < 1e-12);
        prop_assert!((m.get(3, 3) + 1.0).abs() < 1e-12);
        prop_assert!((m.get(1, 1) + m.get(2, 2)).abs() < 1e-12);
        prop_assert!((m.get(1, 2) - m.get(2, 1)).abs() < 1e-12);
        prop_assert!((m.get(1, 1).powi(2) + m.get(1, 2).powi(2) - 1.0).abs() < 1e-12);
        for (i, k) in [(0, 1), (0, 2), (0, 3), (1, 0), (2, 0), (3, 0), (1, 3), (3, 1), (2, 3), (3, 2)] {
            prop_assert!(m.get(i, k).abs() < 1e-12, "m{i}{k} = {}", m.get(i, k));
        }
    }
}

#[test]
fn in_the_plane_the_path_gives_the_fresnel_power_products() {
    // In the plane of incidence s and p do not mix: m00 = ½(Ts Rs Ts' + Tp Rp Tp') and
    // m00 ± m01 = Ts Rs Ts', Tp Rp Tp' with the power coefficients of physics.md §2 (the
    // products the project verified before), for flakes tilted toward ±x.
    for n in [1.0, 1.3, 1.5, 1.7] {
        for ti in [0.0f64, 20.0, 45.0, 70.0] {
            for tilt in [-20.0f64, -5.0, 0.0, 3.0, 15.0] {
                for kind in 0..3 {
                    let flake = flake_of(kind);
                    let (tilt, az) = if tilt < 0.0 { (-tilt, PI) } else { (tilt, 0.0) };
                    let Some(path) = ray(n, ti.to_radians(), tilt.to_radians(), az) else {
                        continue;
                    };
                    let (m00, m01) = path
                        .transfer(&amplitudes(&path, n, flake.clone()))
                        .first_row();
                    let entry = fresnel::air_to_coating(ti.to_radians(), n);
                    let exit = fresnel::power_from_cosines(path.k_out.z, path.k2.z, n);
                    let (rs, rp) = flake.power(-path.k1.dot(&path.m), n);
                    let s = entry.ts * rs * exit.ts;
                    let p = entry.tp * rp * exit.tp;
                    assert!(
                        (m00 - 0.5 * (s + p)).abs() < 1e-13,
                        "n {n} θi {ti} tilt {tilt}: {m00} vs {}",
                        0.5 * (s + p)
                    );
                    assert!((m00 + m01 - s).abs() < 1e-13);
                    assert!((m00 - m01 - p).abs() < 1e-13);
                }
            }
        }
    }
}

#[test]
fn the_clear_coat_reflection_is_the_fresnel_diagonal() {
    // J = diag(rs, rp) with real amplitudes: m00 = (Rs + Rp)/2 = R_av, m01 = m10 =
    // (Rs − Rp)/2, m22 = m33 = rs rp, every other element 0. At normal incidence
    // rp = −rs, so m22 = m33 = −R: a mirror reverses the circular handedness.
    for n in [1.3, 1.5, 1.7] {
        for ti in [0.0f64, 30.0, 56.3, 80.0] {
            let (ci, st) = (ti.to_radians().cos(), ti.to_radians().sin() / n);
            let ct = (1.0 - st * st).sqrt();
            let rs = (ci - n * ct) / (ci + n * ct);
            let rp = (n * ci - ct) / (n * ci + ct);
            let m = Mueller::from_jones(&clearcoat_jones(rs, rp));
            let r = fresnel::air_to_coating(ti.to_radians(), n);
            assert!((m.m00() - r.r_av()).abs() < 1e-15);
            assert!((m.get(0, 1) - 0.5 * (rs * rs - rp * rp)).abs() < 1e-15);
            assert!((m.get(1, 0) - 0.5 * (rs * rs - rp * rp)).abs() < 1e-15);
            assert!((m.get(2, 2) - rs * rp).abs() < 1e-15);
            assert!((m.get(3, 3) - rs * rp).abs() < 1e-15);
            for (i, k) in [
                (0, 2),
                (0, 3),
                (1, 2),
                (1, 3),
                (2, 0),
                (2, 1),
                (2, 3),
                (3, 0),
                (3, 1),
                (3, 2),
            ] {
                assert_eq!(m.get(i, k), 0.0);
            }
        }
    }
    let m = Mueller::from_jones(&clearcoat_jones(-0.2, 0.2));
    assert!((m.get(3, 3) + 0.04).abs() < 1e-15);
}

#[test]
fn coherency_eigenvalues_of_diagonal_matrices_have_the_closed_form() {
    // For M = diag(1, a, b, c) the coherency matrix is diagonal in the Pauli basis with
    // eigenvalues ¼(1 + a + b + c), ¼(1 + a − b − c), ¼(1 − a + b − c), ¼(1 − a − b + c).
    for [a, b, c] in [
        [1.0, 1.0, 1.0],
        [0.0, 0.0, 0.0],
        [0.5, 0.5, 0.5],
        [1.0, 1.0, -1.0],
        [0.3, -0.2, 0.7],
        [-1.0 / 3.0, -1.0 / 3.0, -1.0 / 3.0],
    ] {
        let m = Mueller::from_row_major(&[
            1.0, 0.0, 0.0, 0.0, 0.0, a, 0.0, 0.0, 0.0, 0.0, b, 0.0, 0.0, 0.0, 0.0, c,
        ]);
        let mut want = [
            0.25 * (1.0 + a + b + c),
            0.25 * (1.0 + a - b - c),
            0.25 * (1.0 - a + b - c),
            0.25 * (1.0 - a - b + c),
        ];
        want.sort_by(f64::total_cmp);
        let got = m.coherency_eigenvalues();
        for (g, w) in got.iter().zip(&want) {
            assert!((g - w).abs() < 1e-14, "{a} {b} {c}: {got:?} vs {want:?}");
        }
    }
    // diag(1, 1, 1, −1) (complex conjugation of the field) is no physical element: one
    // eigenvalue is −½. The ideal depolariser diag(1, 0, 0, 0) has tr(MᵀM)/(4 m00²) = ¼.
    let conj = Mueller::from_row_major(&[
        1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0,
    ]);
    assert!((conj.coherency_eigenvalues()[0] + 0.5).abs() < 1e-14);
    let dep = Mueller::from_row_major(&[
        1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    ]);
    assert!((dep.gil_bernabeu_ratio() - 0.25).abs() < 1e-15);
}

#[test]
fn analysers_follow_malus_law() {
    // s-polarised light through a lossless element (identity) into a linear polariser
    // at angle χ from s: Stokes state (1, cos 2χ, sin 2χ, 0); Malus: I = cos² χ.
    let id = Mueller::identity();
    for chi in [0.0f64, 10.0, 45.0, 60.0, 90.0] {
        let c = chi.to_radians();
        let a =
            Analyzer::polarizer(Stokes::new([1.0, (2.0 * c).cos(), (2.0 * c).sin(), 0.0]).unwrap())
                .unwrap();
        let got = id.detected(&Stokes::S, &a);
        assert!((got - c.cos().powi(2)).abs() < 1e-15, "χ {chi}: {got}");
    }
    // Unpolarised light through any ideal polariser: half the power; no analyser: all.
    let lcp = Analyzer::polarizer(Stokes::new([2.0, 0.0, 0.0, 2.0]).unwrap()).unwrap();
    assert!((id.detected(&Stokes::UNPOLARIZED, &lcp) - 0.5).abs() < 1e-15);
    assert!(
        (id.detected(&Stokes::new([3.0, 0.0, 3.0, 0.0]).unwrap(), &Analyzer::None) - 1.0).abs()
            < 1e-15
    );
    // Crossed: p-polariser reads nothing of s light.
    assert_eq!(
        id.detected(&Stokes::S, &Analyzer::Polarizer(Stokes::P)),
        0.0
    );
    // Degree of polarisation for unpolarised light: 0 through the identity, 1 behind
    // a polariser (Mueller ½[[1, 1], [1, 1]] in the s/p block).
    assert_eq!(id.dop_unpolarized(), 0.0);
    let pol = Mueller::from_row_major(&[
        0.5, 0.5, 0.0, 0.0, 0.5, 0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    ]);
    assert!((pol.dop_unpolarized() - 1.0).abs() < 1e-15);
}

#[test]
fn invalid_stokes_vectors_and_analysers_are_refused() {
    for s in [
        [0.0, 0.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0, 0.0],
        [f64::NAN, 0.0, 0.0, 0.0],
        [1.0, f64::INFINITY, 0.0, 0.0],
    ] {
        let err = Stokes::new(s).unwrap_err();
        assert!(matches!(err, OpticsError::InvalidStokes { .. }), "{s:?}");
        assert!(err.to_string().contains("expected"), "{err}");
    }
    let err = Stokes::new([1.0, 1.0, 1.0, 0.0]).unwrap_err();
    assert!(
        matches!(err, OpticsError::OverPolarizedStokes { .. }),
        "{err:?}"
    );
    assert!(err.to_string().contains("1.414214, above 1"), "{err}");
    // Partially polarised: a beam, but not what an ideal polariser passes.
    let half = Stokes::new([1.0, 0.5, 0.0, 0.0]).unwrap();
    assert!((half.dop() - 0.5).abs() < 1e-15);
    let err = Analyzer::polarizer(half).unwrap_err();
    assert!(err.to_string().contains("fully polarised"), "{err}");
    assert!(Analyzer::polarizer(Stokes::UNPOLARIZED).is_err());
}

#[test]
fn the_bases_are_scatmechs() {
    // s = z × k/|z × k|, p = k × s (SCATMECH's GetBasisVectorsSP): for the incident
    // direction s = y, p = (cos θi, 0, sin θi); for the exit direction (θr, φr)
    // s = (−sin φr, cos φr, 0), p = (−cos θr cos φr, −cos θr sin φr, sin θr).
    let ti = 0.7f64;
    let (s, p) = jones::sp_basis(&detector::incident_direction(ti).into_inner());
    assert!((s - Vec3::y()).norm() < 1e-15);
    assert!((p - Vec3::new(ti.cos(), 0.0, ti.sin())).norm() < 1e-15);
    let (tr, pr) = (0.4f64, 2.2f64);
    let (s, p) = jones::sp_basis(&detector::out_of_plane_direction(tr, pr).into_inner());
    assert!((s - Vec3::new(-pr.sin(), pr.cos(), 0.0)).norm() < 1e-15);
    assert!((p - Vec3::new(-tr.cos() * pr.cos(), -tr.cos() * pr.sin(), tr.sin())).norm() < 1e-15);
    let (s, _) = jones::sp_basis(&Vec3::z());
    assert_eq!(s, Vec3::y());
}

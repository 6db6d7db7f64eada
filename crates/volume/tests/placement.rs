//! Placement: no two flakes intersect, every flake lies in the film, the realised
//! loading is within its stated tolerance of the request, and the diameter and
//! orientation distributions are those requested.
//!
//! Non-intersection is proved pair by pair with a separating-plane certificate,
//! independent of the placement's GJK test: two convex bodies are disjoint exactly when
//! some direction `d` has `max_{C1} d·x < min_{C2} d·x`. For a flake cylinder the
//! support function is closed form, `h(d) = c·d + (t/2)|m·d| + r |d − (m·d) m|`, so
//! `g(d) = h1(d) + h2(−d) < 0` certifies disjointness. `g` is convex and positively
//! homogeneous in `d`, so a projected subgradient descent on the unit sphere from a few
//! natural starting directions finds such a `d` whenever the gap is not tiny.

use flakescatter_optics::{UnitVec3, Vec3};
use flakescatter_stats::{GaussianWidth, Orientation};
use flakescatter_volume::{
    ALUMINIUM_DENSITY_G_CM3, Amount, Depth, Diameter, Flake, Layer, LayerParams, LayerSpec,
    VolumeError,
};

fn support_half(k: &Flake, d: &Vec3) -> f64 {
    let m = k.normal.into_inner();
    let s = m.dot(d);
    0.5 * k.thickness_um * s.abs() + k.radius_um * (d - s * m).norm()
}

/// `g(d) = (c1 − c2)·d + e1(d) + e2(d)`: negative iff `d` separates the flakes.
fn gap_function(a: &Flake, b: &Flake, b_centre: &Vec3, d: &Vec3) -> f64 {
    (a.centre - b_centre).dot(d) + support_half(a, d) + support_half(b, d)
}

/// A direction `d` with `g(d) < −1e-9` (a certificate of disjointness), or `None`.
fn separating_direction(a: &Flake, b: &Flake, b_centre: &Vec3) -> Option<Vec3> {
    let ma = a.normal.into_inner();
    let mb = b.normal.into_inner();
    let dc = b_centre - a.centre;
    let mut starts = vec![ma, -ma, mb, -mb, dc, ma.cross(&mb)];
    starts.push(dc - dc.dot(&ma) * ma);
    starts.push(dc - dc.dot(&mb) * mb);
    for s in starts {
        let Some(mut d) = s.try_normalize(1e-12) else {
            continue;
        };
        let mut step = 0.1;
        for _ in 0..400 {
            let g = gap_function(a, b, b_centre, &d);
            if g < -1e-9 {
                return Some(d);
            }
            // Subgradient of g at d.
            let mut grad = a.centre - b_centre;
            for k in [a, b] {
                let m = k.normal.into_inner();
                let sdm = m.dot(&d);
                grad += 0.5 * k.thickness_um * sdm.signum() * m;
                let perp = d - sdm * m;
                let pn = perp.norm();
                if pn > 1e-15 {
                    grad += k.radius_um * perp / pn;
                }
            }
            let gn = grad.norm();
            if gn == 0.0 {
                break;
            }
            d = (d - step * grad / gn).normalize();
            step *= 0.98;
        }
    }
    None
}

/// Every pair of flakes (with periodic images) is certified disjoint; returns how many
/// pairs were close enough to need a certificate beyond the bounding spheres.
fn certify_no_overlap(layer: &Layer) -> usize {
    let l = layer.tile_um();
    let f = layer.flakes();
    let mut close = 0;
    for i in 0..f.len() {
        for j in i + 1..f.len() {
            for sx in [-1.0, 0.0, 1.0] {
                for sy in [-1.0, 0.0, 1.0] {
                    let c = Vec3::new(
                        f[j].centre.x + sx * l,
                        f[j].centre.y + sy * l,
                        f[j].centre.z,
                    );
                    let reach = f[i].bounding_radius() + f[j].bounding_radius();
                    if (c - f[i].centre).norm() > reach {
                        continue;
                    }
                    close += 1;
                    assert!(
                        separating_direction(&f[i], &f[j], &c).is_some(),
                        "flakes {i} and {j} (image {sx}, {sy}) are not certified disjoint:\n{:?}\n{:?}",
                        f[i],
                        f[j]
                    );
                }
            }
        }
    }
    close
}

fn dense_spec(seed: u64) -> LayerSpec {
    let o = Orientation::gaussian(GaussianWidth::Hwhm(15f64.to_radians())).unwrap();
    let mut spec = LayerSpec::new(o, 120.0, seed);
    spec.film_um = 12.0;
    spec.diameter = Diameter::LogNormal {
        mean_um: 10.0,
        rel_sd: 0.3,
    };
    spec.thickness_um = 0.8;
    spec.amount = Amount::VolumeFraction(0.07);
    spec
}

#[test]
fn dense_layers_have_no_intersecting_flakes() {
    for seed in [1, 2, 3] {
        let spec = dense_spec(seed);
        let layer = Layer::generate(&LayerParams::new(spec.clone()).unwrap()).unwrap();
        let s = layer.stats();
        let close = certify_no_overlap(&layer);
        eprintln!(
            "seed {seed}: {} flakes, φ {:.4}, {} attempts, {close} close pairs certified",
            s.flakes, s.volume_fraction, s.attempts
        );
        // The loading is high enough that flakes crowd: many pairs need a certificate,
        // and placement had to reject positions.
        assert!(
            close > s.flakes,
            "{close} close pairs for {} flakes",
            s.flakes
        );
        assert!(s.attempts > s.flakes as u64);
        // Tolerance of the stopping rule: at least the request, less than one more
        // flake's volume (the largest possible flake: diameter 3 × 10 µm).
        let film_volume = 120.0 * 120.0 * 12.0;
        let v_max = std::f64::consts::PI * 15.0 * 15.0 * 0.8;
        assert!(s.volume_fraction >= 0.07);
        assert!(s.volume_fraction < 0.07 + v_max / film_volume);
        // Every flake wholly inside the film and centred on the tile.
        for k in layer.flakes() {
            let hz = k.half_extent(&Vec3::z());
            assert!(k.centre.z + hz <= 0.0 && k.centre.z - hz >= -12.0, "{k:?}");
            assert!((0.0..120.0).contains(&k.centre.x) && (0.0..120.0).contains(&k.centre.y));
        }
    }
}

#[test]
fn overlapping_flakes_are_detected() {
    // Two flakes crossing at 30°: the point p lies inside both (a certificate).
    let a = Flake {
        centre: Vec3::new(20.0, 20.0, -5.0),
        normal: UnitVec3::new_normalize(Vec3::z()),
        radius_um: 5.0,
        thickness_um: 0.5,
    };
    let tilt = 30f64.to_radians();
    let b = Flake {
        centre: Vec3::new(23.0, 20.0, -5.0),
        normal: UnitVec3::new_normalize(Vec3::new(tilt.sin(), 0.0, tilt.cos())),
        ..a
    };
    // The mid-planes cross along the line through b's centre parallel to y.
    let p = b.centre + Vec3::new(0.0, 0.0, 0.05);
    assert!(a.contains(&p) && b.contains(&p));
    assert_eq!(
        Layer::from_flakes(10.0, 40.0, vec![a, b]).unwrap_err(),
        VolumeError::Overlap {
            first: 0,
            second: 1
        }
    );
    // Two parallel flat flakes stacked 0.4 µm apart (centre to centre) with thickness
    // 0.5 overlap; 0.6 µm apart they do not (the plane z = −4.7 separates them).
    let mut c = a;
    c.centre.z += 0.4;
    c.centre.x += 9.0;
    assert!(Layer::from_flakes(10.0, 40.0, vec![a, c]).is_err());
    c.centre.z += 0.2;
    let layer = Layer::from_flakes(10.0, 40.0, vec![a, c]).unwrap();
    assert_eq!(certify_no_overlap(&layer), 1);
    // A tilted flake whose rim pokes into a flat one: found through the periodic image
    // (b sits across the tile's x = 0 edge from a copy of a).
    let mut a2 = a;
    a2.centre.x = 38.0;
    let mut b2 = b;
    b2.centre.x = 1.0;
    let q = b2.centre + Vec3::new(40.0, 0.0, 0.05);
    assert!(a2.contains(&q));
    assert!(b2.contains(&(q - Vec3::new(40.0, 0.0, 0.0))));
    assert!(matches!(
        Layer::from_flakes(10.0, 40.0, vec![a2, b2]),
        Err(VolumeError::Overlap { .. })
    ));
}

#[test]
fn placed_flakes_keep_the_requested_size_and_orientation_distributions() {
    let o = Orientation::gaussian(GaussianWidth::Hwhm(10f64.to_radians())).unwrap();
    let mut spec = LayerSpec::new(o.clone(), 400.0, 5);
    spec.film_um = 20.0;
    spec.diameter = Diameter::LogNormal {
        mean_um: 8.0,
        rel_sd: 0.25,
    };
    spec.thickness_um = 0.5;
    spec.amount = Amount::VolumeFraction(0.04);
    spec.depth = Depth::Uniform {
        top_um: 4.0,
        bottom_um: 16.0,
    };
    let layer = Layer::generate(&LayerParams::new(spec).unwrap()).unwrap();
    let f = layer.flakes();
    let nf = f.len() as f64;
    assert!(f.len() > 2000, "{} flakes", f.len());
    // Diameters: log-normal mean 8, sd 2 (truncation removes < 1e-7 of the mass).
    let mean_d = f.iter().map(Flake::diameter_um).sum::<f64>() / nf;
    let se_d = 2.0 / nf.sqrt();
    assert!((mean_d - 8.0).abs() < 4.0 * se_d, "mean diameter {mean_d}");
    // Orientations: ⟨cos θn⟩ against the distribution's exact value; its sd is bounded
    // by the sd of cos θn, estimated from the sample.
    let cos: Vec<f64> = f.iter().map(|k| k.normal.z).collect();
    let mean_cos = cos.iter().sum::<f64>() / nf;
    let sd_cos = (cos.iter().map(|c| (c - mean_cos).powi(2)).sum::<f64>() / (nf - 1.0)).sqrt();
    assert!(
        (mean_cos - o.mean_cos()).abs() < 4.0 * sd_cos / nf.sqrt(),
        "⟨cos⟩ {mean_cos} vs {}",
        o.mean_cos()
    );
    // Depths uniform in [4, 16] (all these flakes fit there): mean 10, sd 12/√12.
    let depths: Vec<f64> = f.iter().map(|k| -k.centre.z).collect();
    assert!(depths.iter().all(|d| (4.0..=16.0).contains(d)));
    let mean_depth = depths.iter().sum::<f64>() / nf;
    assert!((mean_depth - 10.0).abs() < 4.0 * (12.0 / 12f64.sqrt()) / nf.sqrt());
}

#[test]
fn mass_loading_converts_with_the_stated_densities() {
    // φ = (w/ρ_Al) / (w/ρ_Al + (1 − w)/ρ_b). The paper's 5 % at ρ_b = 1.2 g/cm³:
    // 0.05/2.7 = 0.0185185…, 0.95/1.2 = 0.7916666…, φ = 0.0185185/0.8101851 = 0.0228571.
    let a = Amount::MassLoading {
        fraction: 0.05,
        binder_density_g_cm3: 1.2,
    };
    assert!((a.volume_fraction().unwrap() - 0.022_857_142_857).abs() < 1e-11);
    // Equal densities: the mass fraction is the volume fraction.
    let b = Amount::MassLoading {
        fraction: 0.3,
        binder_density_g_cm3: ALUMINIUM_DENSITY_G_CM3,
    };
    assert!((b.volume_fraction().unwrap() - 0.3).abs() < 1e-15);
}

#[test]
fn placement_is_reproducible_from_the_seed() {
    let a = Layer::generate(&LayerParams::new(dense_spec(9)).unwrap()).unwrap();
    let b = Layer::generate(&LayerParams::new(dense_spec(9)).unwrap()).unwrap();
    let c = Layer::generate(&LayerParams::new(dense_spec(10)).unwrap()).unwrap();
    assert_eq!(a, b);
    assert_ne!(a.flakes()[0], c.flakes()[0]);
}

#[test]
fn too_high_a_loading_is_an_error_not_a_hang() {
    let mut spec = dense_spec(4);
    spec.amount = Amount::VolumeFraction(0.6);
    spec.max_attempts = 200;
    match Layer::generate(&LayerParams::new(spec).unwrap()) {
        Err(VolumeError::LoadingTooHigh {
            placed,
            volume_fraction,
            attempts,
        }) => {
            assert!(placed > 10 && volume_fraction < 0.6 && attempts == 200);
            let msg = VolumeError::LoadingTooHigh {
                placed,
                volume_fraction,
                attempts,
            }
            .to_string();
            assert!(msg.contains("loading too high"), "{msg}");
        }
        other => panic!("expected LoadingTooHigh, got {other:?}"),
    }
}

#[test]
fn depth_profile_is_sampled_as_given() {
    // Two bins, [2, 6] µm with weight 1 and [6, 10] µm with weight 3 (equal widths):
    // a centre falls in the deeper bin with probability 3/4, uniformly within each bin.
    // Flat thin flakes fit anywhere in [0.1, 11.9], so the profile is not restricted.
    let mut spec = LayerSpec::new(Orientation::flat(), 400.0, 8);
    spec.film_um = 12.0;
    spec.diameter = Diameter::Fixed(4.0);
    spec.thickness_um = 0.2;
    spec.amount = Amount::Count(4000);
    spec.depth = Depth::Profile {
        edges_um: vec![2.0, 6.0, 10.0],
        weights: vec![1.0, 3.0],
    };
    let layer = Layer::generate(&LayerParams::new(spec).unwrap()).unwrap();
    let depths: Vec<f64> = layer.flakes().iter().map(|k| -k.centre.z).collect();
    assert!(depths.iter().all(|d| (2.0..=10.0).contains(d)));
    let n = depths.len() as f64;
    let deep = depths.iter().filter(|&&d| d > 6.0).count() as f64 / n;
    let sd = (0.75 * 0.25 / n).sqrt();
    assert!((deep - 0.75).abs() < 4.0 * sd, "deep share {deep}");
    // Within the deep bin the mean is 8 (uniform), sd 4/√12.
    let in_deep: Vec<f64> = depths.iter().copied().filter(|&d| d > 6.0).collect();
    let m = in_deep.iter().sum::<f64>() / in_deep.len() as f64;
    assert!((m - 8.0).abs() < 4.0 * (4.0 / 12f64.sqrt()) / (in_deep.len() as f64).sqrt());
}

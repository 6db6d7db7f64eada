//! `flakescatter volume` end to end: the CSV and JSON are the facade's numbers (bit for
//! bit), the energy balance sums to 1, flags are honoured (checked against closed forms:
//! the mass-loading conversion, the first-surface reflection, an empty film over a black
//! or mirror substrate), results do not depend on the thread count, and bad flags exit
//! 2 naming the flag with nothing left behind.

mod common;

use std::path::PathBuf;

use common::s;

use flakescatter::stats::{GaussianWidth, Orientation};
use flakescatter::volume::{Amount, Depth, Diameter, RimRule, Substrate};
use flakescatter::{
    Coating, DetectorSet, Instrument, OrientationSource, VolumeSettings, volume_curves,
};

fn run_env(args: &[&str], threads: Option<&str>) -> (i32, String, String) {
    let mut cmd = common::bin();
    cmd.args(args);
    if let Some(t) = threads {
        cmd.env("RAYON_NUM_THREADS", t);
    }
    let out = cmd.output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn run(args: &[&str]) -> (i32, String, String) {
    run_env(args, None)
}

fn tmp(name: &str) -> PathBuf {
    common::scratch("volume", name)
}

/// A CSV as header and rows of numbers (empty cells are NaN).
fn table(text: &str) -> (Vec<String>, Vec<Vec<f64>>) {
    let mut lines = text.lines();
    let header = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_owned)
        .collect();
    let rows = lines
        .map(|l| {
            l.split(',')
                .map(|v| {
                    if v.is_empty() {
                        f64::NAN
                    } else {
                        v.parse().unwrap()
                    }
                })
                .collect()
        })
        .collect();
    (header, rows)
}

fn same(a: f64, b: f64) -> bool {
    (a.is_nan() && b.is_nan()) || a == b
}

/// Fresnel power transmittances (Ts, Tp) from air into index `n` at `theta_i` (closed
/// form, written out here).
fn fresnel_t(theta_i: f64, n: f64) -> (f64, f64) {
    let ci = theta_i.cos();
    let ct = (1.0 - (theta_i.sin() / n).powi(2)).sqrt();
    let rs = (ci - n * ct) / (ci + n * ct);
    let rp = (n * ci - ct) / (n * ci + ct);
    (1.0 - rs * rs, 1.0 - rp * rp)
}

const ENERGY: [&str; 6] = [
    "coat_reflected",
    "escaped_single",
    "escaped_multiple",
    "absorbed_substrate",
    "absorbed_flakes",
    "absorbed_other",
];

#[test]
fn the_cli_writes_the_facades_curves_energy_and_layer() {
    let dir = tmp("facade");
    let out = dir.join("v.csv");
    let plot = dir.join("v.svg");
    let (code, json, err) = run(&[
        "volume",
        "--theta-i",
        "21,49",
        "--theta-s",
        "-70:70:7",
        "--aperture",
        "2",
        "--hwhm",
        "8",
        "--tile-um",
        "300",
        "--rays",
        "12800",
        "--seed",
        "3",
        "--flake-index",
        "0.96,6.69",
        "--out",
        s(&out),
        "--plot",
        s(&plot),
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(
        err.contains("wrote") && err.contains("v.csv (42 rows)"),
        "{err}"
    );
    let (h, rows) = table(&std::fs::read_to_string(&out).unwrap());
    assert_eq!(
        h,
        [
            "theta_i_deg",
            "theta_s_deg",
            "phi_s_deg",
            "aperture_deg",
            "brdf_per_sr",
            "reflectance",
            "relative",
            "rays",
            "std_err_per_sr",
            "coat_brdf_per_sr",
            "single_bounce_brdf_per_sr",
            "single_bounce_std_err_per_sr",
            "multiple_bounce_brdf_per_sr",
            "multiple_bounce_std_err_per_sr",
            "ray_std_err_per_sr",
            "layer_std_err_per_sr",
            "ci95_per_sr"
        ]
    );
    assert!(std::fs::read_to_string(&plot).unwrap().starts_with("<svg"));

    let ts: Vec<f64> = (-10..=10).map(|k| f64::from(k * 7).to_radians()).collect();
    let alpha = 2f64.to_radians();
    let theta_i = [21f64.to_radians(), 49f64.to_radians()];
    let instrument =
        Instrument::new(theta_i.to_vec(), DetectorSet::InPlane(ts.clone()), alpha).unwrap();
    let coating = Coating {
        n: 1.5,
        flake: flakescatter::optics::flake::FlakeReflectance::complex(0.96, 6.69).unwrap(),
    };
    let settings = VolumeSettings {
        film_um: 38.0,
        diameter: Diameter::LogNormal {
            mean_um: 16.0,
            rel_sd: 0.25,
        },
        thickness_um: 1.0,
        amount: Amount::MassLoading {
            fraction: 0.05,
            binder_density_g_cm3: 1.2,
        },
        depth: Depth::WholeFilm,
        tile_um: 300.0,
        substrate: Substrate::Black,
        rims: RimRule::Absorb,
        rays: 12_800,
        seed: 3,
        ..VolumeSettings::default()
    };
    let source = OrientationSource::Distribution(
        Orientation::gaussian(GaussianWidth::Hwhm(8f64.to_radians())).unwrap(),
    );
    let f = volume_curves(&coating, &instrument, &settings, &source, &|_, _| {}).unwrap();
    assert_eq!(rows.len(), f.rows.len());
    let c = |name: &str| h.iter().position(|x| x == name).unwrap();
    for (row, fr) in rows.iter().zip(&f.rows) {
        for (name, want) in [
            ("brdf_per_sr", fr.brdf),
            ("reflectance", fr.reflectance),
            ("relative", fr.relative),
            ("rays", fr.rays as f64),
            ("coat_brdf_per_sr", fr.coat_brdf),
            ("single_bounce_brdf_per_sr", fr.single_bounce_brdf),
            ("multiple_bounce_brdf_per_sr", fr.multiple_bounce_brdf),
        ] {
            assert!(
                same(row[c(name)], want),
                "{name}: {} vs {want}",
                row[c(name)]
            );
        }
        let se = |x: f64| if fr.rays == 0 { f64::NAN } else { x };
        assert!(same(row[c("std_err_per_sr")], se(fr.std_err)));
        assert!(same(
            row[c("single_bounce_std_err_per_sr")],
            se(fr.single_bounce_std_err)
        ));
        assert!(same(
            row[c("multiple_bounce_std_err_per_sr")],
            se(fr.multiple_bounce_std_err)
        ));
        // The total is the sum of the three histories.
        let parts = row[c("coat_brdf_per_sr")]
            + row[c("single_bounce_brdf_per_sr")]
            + row[c("multiple_bounce_brdf_per_sr")];
        assert!((row[c("brdf_per_sr")] - parts).abs() <= 1e-12 * parts.max(1e-300));
        // The first surface reflects R_av(θi) = ½(Rs + Rp) into the specular cone only:
        // BRDF R_av / (cos θi π sin²α) there, 0 elsewhere.
        let ti = row[0].to_radians();
        if row[1] == -row[0] {
            let (tsp, tpp) = fresnel_t(ti, 1.5);
            let r_av = 1.0 - 0.5 * (tsp + tpp);
            let want = r_av / (ti.cos() * std::f64::consts::PI * alpha.sin().powi(2));
            assert!((row[c("coat_brdf_per_sr")] - want).abs() < 1e-9 * want);
            assert!((row[c("relative")] - 1.0).abs() < 1e-12);
        } else {
            assert_eq!(row[c("coat_brdf_per_sr")], 0.0);
        }
    }

    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(v["command"], "volume");
    assert_eq!(v["row_count"], 42);
    assert_eq!(v["seed"], 3);
    assert_eq!(v["rays_per_incidence"], 12_800);
    assert_eq!(v["segments"], f.segments);
    // 5 % aluminium (2.70 g/cm³) in a 1.2 g/cm³ binder: φ = (0.05/2.7)/(0.05/2.7 + 0.95/1.2).
    let phi = (0.05 / 2.7) / (0.05 / 2.7 + 0.95 / 1.2);
    let echoed = v["inputs"]["amount"]["volume_fraction"].as_f64().unwrap();
    assert!((echoed - phi).abs() < 1e-15, "{echoed} vs {phi}");
    assert_eq!(v["layer"]["flakes"], f.layer.flakes);
    // serde_json's default parser may miss the last bit of a float: 1e-15 relative.
    let close = |v: &serde_json::Value, x: f64| (v.as_f64().unwrap() - x).abs() <= 1e-15 * x.abs();
    assert!(close(
        &v["layer"]["volume_fraction"],
        f.layer.volume_fraction
    ));
    assert!(f.layer.volume_fraction >= phi);
    for (k, e) in v["energy"].as_array().unwrap().iter().enumerate() {
        let sum: f64 = ENERGY.iter().map(|n| e[*n].as_f64().unwrap()).sum();
        assert!((sum - 1.0).abs() < 1e-12, "θi {}: {sum}", e["theta_i_deg"]);
        assert!(close(
            &e["escaped_multiple"],
            f.energy[k].1.escaped_multiple
        ));
        assert!(close(&e["absorbed_flakes"], f.energy[k].1.absorbed_flakes));
        // Complex-index flakes absorb; rims absorb by default.
        assert!(e["absorbed_flakes"].as_f64().unwrap() > 0.0);
        assert!(e["absorbed_rims"].as_f64().unwrap() > 0.0);
        let (tsp, tpp) = fresnel_t(theta_i[k], 1.5);
        assert!((e["coat_reflected"].as_f64().unwrap() - (1.0 - 0.5 * (tsp + tpp))).abs() < 1e-12);
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn flags_are_honoured_empty_films_follow_the_closed_forms() {
    let energy = |extra: &[&str]| {
        let mut a = vec![
            "volume",
            "--theta-i",
            "30",
            "--theta-s",
            "-30",
            "--tile-um",
            "100",
            "--rays",
            "640",
            "--json",
        ];
        a.extend(extra);
        let (code, out, err) = run(&a);
        assert_eq!(code, 0, "{extra:?}: {err}");
        let v: serde_json::Value = serde_json::from_str(&out).unwrap();
        v["energy"][0].clone()
    };
    let (ts, tp) = fresnel_t(30f64.to_radians(), 1.5);
    // No flakes over a black substrate: everything that enters is absorbed there.
    let e = energy(&["--volume-fraction", "0"]);
    assert!((e["absorbed_substrate"].as_f64().unwrap() - 0.5 * (ts + tp)).abs() < 1e-12);
    assert_eq!(e["escaped_multiple"], 0.0);
    // No flakes over a mirror of reflectance R: each polarisation escapes
    // T·R·T Σ_k (R(1 − T))^k = T² R / (1 − R(1 − T)) (the interface's transmittance is
    // the same both ways, the ray returns at the same angle).
    let r = 0.5;
    let want = 0.5 * (ts * ts * r / (1.0 - r * (1.0 - ts)) + tp * tp * r / (1.0 - r * (1.0 - tp)));
    let e = energy(&[
        "--volume-fraction",
        "0",
        "--substrate-reflectance",
        "0.5",
        "--substrate",
        "mirror",
    ]);
    // Paths end when their weight falls below 1e-6 of the ray's power (physics.md §10),
    // the rest tallied as cut_off, so the series is reached from below within it.
    let got = e["escaped_multiple"].as_f64().unwrap();
    let cut = e["cut_off"].as_f64().unwrap();
    assert!(
        got <= want + 1e-15 && want - got <= cut && cut < 1e-6,
        "{got} vs {want}, cut off {cut}"
    );
    assert_eq!(e["escaped_via_substrate"], e["escaped_multiple"]);
    let absorbed = e["absorbed_substrate"].as_f64().unwrap();
    let all = e["coat_reflected"].as_f64().unwrap() + got + absorbed + cut;
    assert!((all - 1.0).abs() < 1e-12, "{all}");
    // Transparent rims absorb nothing; absorbing ones do.
    let e = energy(&["--rims", "ignore"]);
    assert_eq!(e["absorbed_rims"], 0.0);
    let e = energy(&[]);
    assert!(e["absorbed_rims"].as_f64().unwrap() > 0.0);
    // A Lambertian substrate returns light through the film.
    let e = energy(&["--substrate-reflectance", "0.8"]);
    assert!(e["escaped_via_substrate"].as_f64().unwrap() > 0.0);
}

#[test]
fn results_do_not_depend_on_the_thread_count_and_the_seed_is_honoured() {
    let args = [
        "volume",
        "--theta-i",
        "40",
        "--theta-s",
        "-60:0:3",
        "--tile-um",
        "200",
        "--rays",
        "6400",
        "--seed",
        "11",
    ];
    let (c1, one, e1) = run_env(&args, Some("1"));
    let (c2, two, e2) = run_env(&args, Some("2"));
    assert_eq!((c1, c2), (0, 0), "{e1}{e2}");
    assert_eq!(one, two);
    let mut other = args.to_vec();
    let last = other.len() - 1;
    other[last] = "12";
    let (c3, three, e3) = run(&other);
    assert_eq!(c3, 0, "{e3}");
    assert_ne!(one, three);
}

#[test]
fn bad_flags_exit_2_naming_the_flag_and_leave_nothing() {
    let dir = tmp("bad");
    let out = dir.join("v.csv");
    let plot = dir.join("v.png");
    for (args, needle) in [
        (
            vec!["--volume-fraction", "0.01", "--mass-loading", "0.05"],
            "--volume-fraction",
        ),
        (
            vec!["--volume-fraction", "0.9", "--tile-um", "100"],
            "--volume-fraction 0.9",
        ),
        (vec!["--volume-fraction", "1"], "--volume-fraction 1"),
        (vec!["--mass-loading", "-0.1"], "--mass-loading -0.1"),
        (
            vec!["--volume-fraction", "0.01", "--binder-density", "1.1"],
            "--binder-density 1.1",
        ),
        (vec!["--binder-density", "0"], "--binder-density 0"),
        (vec!["--thickness-um", "-1"], "--thickness-um -1"),
        (vec!["--thickness-um", "40"], "--thickness-um 40"),
        (vec!["--film-um", "0"], "--film-um 0"),
        (vec!["--diameter-um", "nan"], "--diameter-um NaN"),
        (vec!["--diameter-rel-sd", "2"], "--diameter-rel-sd 2"),
        (vec!["--depth-um", "10:50"], "--depth-um 10:50"),
        (vec!["--depth-um", "20:10"], "--depth-um 20:10"),
        (vec!["--depth-um", "5"], "--depth-um 5"),
        (
            vec!["--depth-um", "0:0", "--tile-um", "100"],
            "--depth-um 0:0",
        ),
        (vec!["--tile-um", "20"], "--tile-um 20"),
        (vec!["--rays", "0"], "--rays <N>"),
        (vec!["--rays", "-5"], "--rays"),
        (
            vec!["--layers", "0"],
            "'0' for '--layers <K>': expected a whole number of layers from 1 to 10000",
        ),
        (
            vec!["--layers", "10001"],
            "'10001' for '--layers <K>': expected a whole number of layers from 1 to 10000",
        ),
        (
            vec!["--layers", "-1"],
            "'-1' for '--layers <K>': expected a whole number of layers from 1 to 10000",
        ),
        (
            vec!["--layers", "2.5"],
            "'2.5' for '--layers <K>': expected a whole number of layers from 1 to 10000",
        ),
        (
            vec!["--layers", "1e20"],
            "'1e20' for '--layers <K>': expected a whole number of layers from 1 to 10000",
        ),
        (vec!["--seed", "1.5"], "--seed"),
        (vec!["--aperture", "0"], "--aperture 0"),
        (
            vec!["--substrate-reflectance", "1.5"],
            "--substrate-reflectance 1.5",
        ),
        (vec!["--rims", "reflect"], "--rims"),
        (vec!["--n", "0.5"], "--n 0.5"),
        (vec!["--hwhm", "-3"], "--hwhm -3"),
        (vec!["--theta-i", "95"], "--theta-i"),
        (vec!["--transmission", "s"], "--transmission"),
    ] {
        let mut a = vec!["volume", "--out", s(&out), "--plot", s(&plot)];
        if !args.contains(&"--rays") {
            a.extend(["--rays", "64"]);
        }
        a.extend(&args);
        let (code, _, err) = run(&a);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
        let left: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
        assert!(left.is_empty(), "{args:?} left {left:?}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Issue 52, item 18: a 6 µm film holds a typical flake (16 µm at 6°, about 2.6 µm
/// tall), so the run is placed, every flake taller than the film resized (normals kept)
/// and counted in the JSON with a warning; a film too thin for a typical flake is exit 2
/// naming the flags. Before, the first tail flake ended the run with exit 2.
#[test]
fn a_film_too_thin_for_tail_flakes_places_them_and_says_how_many() {
    let (code, out, err) = run(&[
        "volume",
        "--film-um",
        "6",
        "--tile-um",
        "600",
        "--rays",
        "640",
        "--theta-i",
        "30",
        "--theta-s",
        "-30",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let j: serde_json::Value = serde_json::from_str(&out).unwrap();
    let l = &j["layer"];
    let resized = l["flakes_resized"].as_u64().unwrap();
    assert!(
        resized > 0 && resized < l["flakes"].as_u64().unwrap(),
        "{l}"
    );
    assert_eq!(l["flakes_moved"], 0);
    let lost = l["resized_area_fraction"].as_f64().unwrap();
    assert!(lost > 0.0 && lost < 0.2, "{lost}");
    assert!(
        err.contains(&format!("{resized} of")) && err.contains("6 µm film"),
        "{err}"
    );
    assert_eq!(
        j["warnings"].as_array().unwrap().len(),
        err.matches("warning:").count()
    );
    // Too thin for a typical flake.
    let (code, _, err) = run(&["volume", "--film-um", "2", "--rays", "64"]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("--film-um 2") && err.contains("typical flake") && err.contains("median"),
        "{err}"
    );
}

/// Issue 52, item 19: `--layers K` draws K independent layers; every CSV row gives the
/// standard error over the layers with its ray and between-layer parts and the Student's
/// t interval, and the JSON says what each column is. Checked against the definitions:
/// total² = ray² + layer² where the spread exceeds the rays, ci95 = t_{0.975, K−1} ·
/// total (t_{0.975, 3} = 3.182446305284263 from tables), rays shared among the layers.
#[test]
fn layers_split_the_standard_error_and_one_layer_warns() {
    let dir = tmp("layers");
    let out = dir.join("v.csv");
    let args = |k: &'static str| {
        vec![
            "volume",
            "--theta-i",
            "30",
            "--theta-s",
            "-45:-15:3",
            "--aperture",
            "2.5",
            "--hwhm",
            "5",
            "--tile-um",
            "300",
            "--rays",
            "20000",
            "--layers",
            k,
            "--json",
        ]
    };
    let mut a = args("4");
    a.extend(["--out", s(&out)]);
    let (code, json, err) = run(&a);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    // 20000 rays over 4 layers: 5000 each, rounded up to whole batches of 64 (5056).
    assert_eq!(v["inputs"]["layers"], 4);
    assert_eq!(v["rays_per_layer"], 5056);
    assert_eq!(v["rays_per_incidence"], 4 * 5056);
    let t = v["t975"].as_f64().unwrap();
    assert!((t - 3.182_446_305_284_263).abs() < 1e-9, "{t}");
    let per = v["layer"]["per_layer"].as_array().unwrap();
    assert_eq!(per.len(), 4);
    let flakes: u64 = per.iter().map(|l| l["flakes"].as_u64().unwrap()).sum();
    assert_eq!(v["layer"]["flakes"], flakes);
    // Every CSV column is described in the JSON's units.
    let (h, rows) = table(&std::fs::read_to_string(&out).unwrap());
    for name in &h {
        assert!(v["units"]["columns"][name.as_str()].is_string(), "{name}");
    }
    let c = |name: &str| h.iter().position(|x| x == name).unwrap();
    let mut layered = 0;
    for row in rows.iter().filter(|r| r[c("rays")] > 0.0) {
        let (se, ray, layer, ci) = (
            row[c("std_err_per_sr")],
            row[c("ray_std_err_per_sr")],
            row[c("layer_std_err_per_sr")],
            row[c("ci95_per_sr")],
        );
        assert!((ci - t * se).abs() <= 1e-9 * ci, "{row:?}");
        if layer > 0.0 {
            layered += 1;
            assert!((se * se - ray * ray - layer * layer).abs() <= 1e-9 * se * se);
        } else {
            assert!(se <= ray * (1.0 + 1e-12), "{row:?}");
        }
    }
    // Off the specular cone a few flakes feed each detector: the layers differ.
    assert!(layered >= rows.len() / 2, "{layered} of {}", rows.len());
    assert!(!err.contains("--layers 1"), "{err}");

    // One layer: the rays' part only, said once on stderr and in the JSON; the
    // between-layer part and the interval are empty cells.
    let mut a = args("1");
    a.extend(["--out", s(&out)]);
    let (code, json, err) = run(&a);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert!(v["t975"].is_null());
    assert!(err.contains("warning: --layers 1"), "{err}");
    assert!(
        v["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .any(|w| w.as_str().unwrap().starts_with("--layers 1")),
        "{v}"
    );
    let text = std::fs::read_to_string(&out).unwrap();
    let (h, rows) = table(&text);
    let c = |name: &str| h.iter().position(|x| x == name).unwrap();
    for row in &rows {
        assert!(row[c("layer_std_err_per_sr")].is_nan());
        assert!(row[c("ci95_per_sr")].is_nan());
        assert!(same(row[c("std_err_per_sr")], row[c("ray_std_err_per_sr")]));
    }
    std::fs::remove_dir_all(&dir).ok();
}

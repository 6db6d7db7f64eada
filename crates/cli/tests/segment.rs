//! `flakescatter segment` and `stats --map` end to end: a synthetic layer written by
//! `flakescatter synth` (its truth table is the reference), exit codes, bad input.

mod common;

use common::{run, s, scratch};
use std::path::{Path, PathBuf};

/// A 512 × 512 layer at 0.18 µm with the paper's 0.3 µm z step and 30 nm noise.
fn synth(d: &Path) -> (PathBuf, PathBuf, PathBuf) {
    let (map, int, truth) = (d.join("h.x3p"), d.join("i.x3p"), d.join("truth.csv"));
    let o = run(&[
        "synth",
        "--size",
        "512",
        "--seed",
        "5",
        "--hwhm",
        "6",
        "--height-noise-um",
        "0.03",
        "--out",
        s(&map),
        "--intensity-out",
        s(&int),
        "--truth-out",
        s(&truth),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    (map, int, truth)
}

fn rows(text: &str) -> Vec<Vec<String>> {
    text.lines()
        .skip(1)
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect()
}

#[test]
fn segments_a_synthetic_layer_and_feeds_stats() {
    let d = scratch("segment", "ok");
    let (map, int, truth) = synth(&d);
    let table = d.join("flakes.csv");
    let o = run(&[
        "segment",
        s(&map),
        "--intensity",
        s(&int),
        "--cutoff",
        "0.49",
        "--out",
        s(&table),
        "--json",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["version"], env!("CARGO_PKG_VERSION"));
    assert_eq!(j["nx"], 512);
    assert_eq!(j["input"]["cutoff"], 0.49);
    let text = std::fs::read_to_string(&table).unwrap();
    let header = text.lines().next().unwrap();
    assert!(header.starts_with("x_um,y_um,nx,ny,nz,area_um2,theta_n_deg,phi_n_deg,"));
    assert!(header.contains("equivalent_diameter_um") && header.contains("quality"));
    let found = rows(&text);
    assert_eq!(j["flakes"], found.len());
    // The truth table lists every visible flake (including slivers below 100 pixels,
    // which are not looked for); the segmentation finds most of them.
    let truth_rows = rows(&std::fs::read_to_string(&truth).unwrap());
    let big = truth_rows
        .iter()
        .filter(|r| r[13].parse::<usize>().unwrap() >= 1000)
        .count();
    assert!(
        found.len() >= big,
        "{} found, {big} truth flakes >= 1000 px",
        found.len()
    );
    assert!(found.len() <= truth_rows.len());
    // Each row: unit normal; θn from nz (cos θn = nz); true area = projected / nz.
    for r in &found {
        let v: Vec<f64> = r[..12].iter().map(|x| x.parse().unwrap()).collect();
        let (nx, ny, nz) = (v[2], v[3], v[4]);
        assert!((nx * nx + ny * ny + nz * nz - 1.0).abs() < 1e-12);
        assert!((nz.acos().to_degrees() - v[6]).abs() < 1e-6);
        assert!((v[5] - v[8] / nz).abs() < 1e-9 * v[5]);
        assert!(matches!(r[14].as_str(), "true" | "false"));
    }

    // The table is a flake table for `stats --flakes`, and `stats --map` gives the same.
    let a = run(&["stats", "--flakes", s(&table), "--json"]);
    assert!(a.status.success(), "{}", String::from_utf8_lossy(&a.stderr));
    let b = run(&[
        "stats",
        "--map",
        s(&map),
        "--intensity",
        s(&int),
        "--cutoff",
        "0.49",
        "--json",
    ]);
    assert!(b.status.success(), "{}", String::from_utf8_lossy(&b.stderr));
    let (a, b): (serde_json::Value, serde_json::Value) = (
        serde_json::from_slice(&a.stdout).unwrap(),
        serde_json::from_slice(&b.stdout).unwrap(),
    );
    assert_eq!(a["flakes"], b["flakes"]);
    let (ha, hb) = (
        a["hwhm_deg"].as_f64().unwrap(),
        b["hwhm_deg"].as_f64().unwrap(),
    );
    // Same flakes; the table holds shortest round-trip decimals, so equal to rounding.
    assert!((ha - hb).abs() < 1e-9, "{ha} vs {hb}");
    // About 100 flakes of a 6° layer: the fitted width is near 6° (its 95 % interval
    // from the fit is about ±15 % here).
    assert!((ha / 6.0 - 1.0).abs() < 0.3, "hwhm {ha}");
    assert_eq!(b["input"]["map"], s(&map));
}

#[test]
fn bad_input_is_reported() {
    let d = scratch("segment", "bad");
    let (map, int, _) = synth(&d);
    // A cutoff above every intensity: a clear error, exit status 2.
    let o = run(&["segment", s(&map), "--intensity", s(&int), "--cutoff", "2"]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("--cutoff 2") && err.contains("leaves 0 of"),
        "{err}"
    );
    // --cutoff without --intensity is a usage error.
    let o = run(&["segment", s(&map), "--cutoff", "0.5"]);
    assert_eq!(o.status.code(), Some(2));
    // Bad thresholds name the flag.
    let o = run(&["segment", s(&map), "--z-step-um", "-1"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--z-step-um"));
    // A missing file is named.
    let o = run(&["segment", s(&d.join("nope.x3p"))]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("nope.x3p"));
    // An unwritable output is a failure (exit 1).
    let o = run(&["segment", s(&map), "--out", s(&d.join("no/such/dir.csv"))]);
    assert_eq!(
        o.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
}

#[test]
fn a_map_without_flakes_gives_an_empty_table_and_a_warning() {
    let d = scratch("segment", "empty");
    // A 30 × 30 checkerboard of 0 / 5 µm: every neighbour is a height jump.
    let mut text = String::new();
    for r in 0..30 {
        let row: Vec<&str> = (0..30)
            .map(|c| if (r + c) % 2 == 0 { "0" } else { "5" })
            .collect();
        text.push_str(&row.join(" "));
        text.push('\n');
    }
    let map = d.join("checker.txt");
    std::fs::write(&map, text).unwrap();
    let o = run(&["segment", s(&map), "--pixel-um", "0.2", "--z-unit", "um"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = String::from_utf8_lossy(&o.stdout);
    assert_eq!(out.lines().count(), 1, "{out}");
    assert!(out.starts_with("x_um,y_um,nx"));
    assert!(String::from_utf8_lossy(&o.stderr).contains("warning"));
    // `stats --map` on it has nothing to fit: exit 2 with a message.
    let o = run(&[
        "stats",
        "--map",
        s(&map),
        "--pixel-um",
        "0.2",
        "--z-unit",
        "um",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("no flake found"));
}

/// `segment --overlay`: a PNG per map, the map at one image pixel per map point with the
/// 170-pixel colour-bar strip to its right, and the pixels of each large flake carry the
/// colour of its tilt. Reference: the generator's truth table (θn of each flake, matched
/// to a segmented flake by its normal) and viridis, whose anchors the facade's unit test
/// `viridis_matches_matplotlib_between_anchors` checks against matplotlib. The overlay
/// blends the tilt colour c over the grey height g with α = 0.6 (overlay module docs);
/// the grey adds the same to every channel, so R − G = α (c_R − c_G) and
/// B − G = α (c_B − c_G) up to rounding (≤ 1 unit) whatever the height.
#[test]
fn overlay_pixels_carry_the_colour_of_the_true_tilt() {
    let d = scratch("segment", "overlay");
    let fx = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures");
    let map = fx.join("synth-hwhm6-rough.height.x3p");
    let (flakes, overlays) = (d.join("flakes.csv"), d.join("overlays"));
    let o = run(&[
        "segment",
        s(&map),
        "--intensity-suffix",
        ".intensity",
        "--cutoff",
        "0.49",
        "--out",
        s(&flakes),
        "--overlay",
        s(&overlays),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let png_path = overlays.join("synth-hwhm6-rough.png");
    let dec = png::Decoder::new(std::io::BufReader::new(
        std::fs::File::open(&png_path).unwrap(),
    ));
    let mut reader = dec.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!((info.width, info.height), (512 + 170, 512));
    assert_eq!(info.color_type, png::ColorType::Rgb);
    let px = |x: usize, y: usize| {
        let i = (y * info.width as usize + x) * 3;
        [buf[i], buf[i + 1], buf[i + 2]].map(f64::from)
    };

    let text = std::fs::read_to_string(&flakes).unwrap();
    let head: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let col = |n: &str| head.iter().position(|h| *h == n).unwrap();
    let truth_text = std::fs::read_to_string(fx.join("synth-hwhm6-rough.truth.csv")).unwrap();
    let th: Vec<&str> = truth_text.lines().next().unwrap().split(',').collect();
    let tcol = |n: &str| th.iter().position(|h| *h == n).unwrap();
    let truth: Vec<([f64; 3], f64)> = rows(&truth_text)
        .iter()
        .map(|r| {
            let f = |n: &str| r[tcol(n)].parse::<f64>().unwrap();
            ([f("nx"), f("ny"), f("nz")], f("theta_n_deg"))
        })
        .collect();
    let (alpha, max_deg, pitch) = (0.6, 20.0, 0.18);
    let mut checked = 0;
    for r in rows(&text) {
        let f = |n: &str| r[col(n)].parse::<f64>().unwrap();
        if f("pixels") < 3000.0 || r[col("touches_border")] == "true" {
            continue;
        }
        let n = [f("nx"), f("ny"), f("nz")];
        // The truth flake with the nearest normal, if it is unambiguous (within 0.3°).
        let ang = |m: &[f64; 3]| {
            (n[0] * m[0] + n[1] * m[1] + n[2] * m[2])
                .clamp(-1.0, 1.0)
                .acos()
                .to_degrees()
        };
        let Some((tn, theta_true)) = truth.iter().min_by(|a, b| ang(&a.0).total_cmp(&ang(&b.0)))
        else {
            continue;
        };
        if ang(tn) > 0.3 {
            continue;
        }
        // The fill's colour for tilts within the 0.3° of the match (the segmented flake's
        // tilt differs from the truth by at most that): per channel difference its range
        // over θ_true ± 0.3°, widened by 1.5 units for rounding.
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        for k in -30..=30 {
            let c = flakescatter::overlay::viridis((theta_true + 0.01 * f64::from(k)) / max_deg);
            for (i, v) in [alpha * (c[0] - c[1]), alpha * (c[2] - c[1])]
                .into_iter()
                .enumerate()
            {
                lo[i] = lo[i].min(v - 1.5);
                hi[i] = hi[i].max(v + 1.5);
            }
        }
        // The 21 × 21 pixels around the flake's centroid: most are its fill (the rest its
        // number, written at the centroid, or a neighbour's pixels).
        let (cx, cy) = (
            (f("x_um") / pitch).round() as usize,
            (f("y_um") / pitch).round() as usize,
        );
        let mut fill = 0;
        for y in cy.saturating_sub(10)..=(cy + 10).min(511) {
            for x in cx.saturating_sub(10)..=(cx + 10).min(511) {
                let p = px(x, y);
                let got = [p[0] - p[1], p[2] - p[1]];
                if (0..2).all(|i| lo[i] <= got[i] && got[i] <= hi[i]) {
                    fill += 1;
                }
            }
        }
        assert!(
            fill >= 13,
            "flake at ({cx}, {cy}), true θn {theta_true:.2}°: {fill} of 441 pixels carry its colour (R-G, B-G in {lo:?}..{hi:?}); centre {:?}",
            px(cx, cy)
        );
        checked += 1;
    }
    assert!(
        checked >= 10,
        "only {checked} large flakes matched the truth"
    );
    let _ = std::fs::remove_dir_all(&d);
}

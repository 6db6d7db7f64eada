//! Grids print as typed (issue 52, item 16): histogram bin edges of `stats --bin` and
//! `fit --nonparametric --bins`, and the angle ranges of `--theta-i`/`--theta-s`, are
//! the exact decimals `lo + i·width`, written as those decimals (`1.5`, `3`, `7.5`,
//! never `1.5000000000000002`, `3.0000000000000004`, `7.499999999999999`). The expected
//! strings are made here from integers (`i × 15` tenths written out), not by the code
//! under test.

mod common;

use common::run_text as run;

/// The decimal text of `n / 10^places` (shortest form, no trailing zeros), from integers.
fn decimal(n: i64, places: u32) -> String {
    let p = 10i64.pow(places);
    let sign = if n < 0 { "-" } else { "" };
    let (q, r) = (n.abs() / p, n.abs() % p);
    if r == 0 {
        format!("{sign}{q}")
    } else {
        let frac = format!("{r:0w$}", w = places as usize);
        format!("{sign}{q}.{}", frac.trim_end_matches('0'))
    }
}

/// Column `c` of a CSV, as text.
fn column(csv: &str, name: &str) -> Vec<String> {
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let c = header.iter().position(|h| *h == name).unwrap();
    lines
        .map(|l| l.split(',').nth(c).unwrap().to_owned())
        .collect()
}

/// The lower edges `0, w, 2w, …` below 90 and the upper edges up to 90, for a width of
/// `w_tenths / 10^places` degrees.
fn expected_edges(w: i64, places: u32) -> (Vec<String>, Vec<String>) {
    let ninety = 90 * 10i64.pow(places);
    let lo: Vec<i64> = (0..).map(|i| i * w).take_while(|&e| e < ninety).collect();
    let hi: Vec<i64> = lo.iter().skip(1).copied().chain([ninety]).collect();
    (
        lo.iter().map(|&e| decimal(e, places)).collect(),
        hi.iter().map(|&e| decimal(e, places)).collect(),
    )
}

#[test]
fn stats_bin_edges_are_the_decimals_of_the_width() {
    let dir = std::env::temp_dir().join(format!("fs-decimal-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let f = dir.join("tilts.csv");
    // θn = 2.5° and 7.4°, and 0.5° (θy = −0.5): on and off the edges.
    std::fs::write(
        &f,
        "theta_x_deg,theta_y_deg,area_um2\n2.5,0,1\n0,2.5,1\n-2.5,0,2\n0,-0.5,4\n7.4,0,1\n",
    )
    .unwrap();
    for (bin, w, places) in [
        ("1.5", 15, 1),
        ("2.5", 25, 1),
        ("0.1", 1, 1),
        ("0.7", 7, 1),
        ("1", 1, 0),
        ("0.25", 25, 2),
        ("7", 7, 0),
    ] {
        let (code, out, err) = run(&[
            "stats",
            "--flakes",
            f.to_str().unwrap(),
            "--bin",
            bin,
            "--out",
            "-",
        ]);
        assert_eq!(code, 0, "--bin {bin}: {err}");
        let (lo, hi) = expected_edges(w, places);
        assert_eq!(column(&out, "theta_lo_deg"), lo, "--bin {bin}");
        assert_eq!(column(&out, "theta_hi_deg"), hi, "--bin {bin}");
        // The flake at 2.5° lies on an edge for 0.1, 0.25 and 2.5: it counts in the bin
        // that starts there ([lo, hi)), the bin whose printed edges hold it.
        let frac = column(&out, "area_fraction");
        let k = lo.iter().position(|e| e == "2.5");
        if let Some(k) = k {
            assert_ne!(frac[k], "0", "--bin {bin}: the bin from 2.5");
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn nonparametric_bins_and_angle_ranges_print_as_typed() {
    let dir = std::env::temp_dir().join(format!("fs-decimal-fit-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // Angle ranges: −80:80:0.1 gives −80, −79.9, …, 80 exactly, and exponent notation is
    // a decimal like any other.
    let (code, out, err) = run(&[
        "model",
        "--theta-i",
        "1e-1:1:1e-1",
        "--theta-s",
        "-80:80:0.1",
        "--aperture",
        "0",
    ]);
    assert_eq!(code, 0, "{err}");
    let ts = column(&out, "theta_s_deg");
    let want_ts: Vec<String> = (-800..=800).map(|k| decimal(k, 1)).collect();
    assert_eq!(ts.len(), 10 * 1601);
    assert_eq!(ts[..1601], want_ts[..]);
    let mut ti = column(&out, "theta_i_deg");
    ti.dedup();
    let want_ti: Vec<String> = (1..=10).map(|k| decimal(k, 1)).collect();
    assert_eq!(ti, want_ti);
    // A measured curve made by the model, then the non-parametric estimate on
    // 0:30:1.5: CSV (--out), the table on stdout and the JSON all give the decimals.
    let measured = dir.join("m.csv");
    let (code, model, err) = run(&["model", "--theta-i", "30,60", "--theta-s", "-70:70:5"]);
    assert_eq!(code, 0, "{err}");
    let mut text = String::from("theta_i_deg,theta_s_deg,value\n");
    let cols = ["theta_i_deg", "theta_s_deg", "brdf_per_sr"].map(|c| column(&model, c));
    for ((ti, ts), v) in cols[0].iter().zip(&cols[1]).zip(&cols[2]) {
        text.push_str(&format!("{ti},{ts},{v}\n"));
    }
    std::fs::write(&measured, text).unwrap();
    let m = measured.to_str().unwrap();
    let lo: Vec<String> = (0..20).map(|i| decimal(15 * i, 1)).collect();
    let hi: Vec<String> = (1..=20).map(|i| decimal(15 * i, 1)).collect();
    let (code, out, err) = run(&[
        "fit",
        "--measured",
        m,
        "--nonparametric",
        "--bins",
        "0:30:1.5",
        "--out",
        "-",
    ]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(column(&out, "theta_lo_deg"), lo);
    assert_eq!(column(&out, "theta_hi_deg"), hi);
    let (code, out, err) = run(&[
        "fit",
        "--measured",
        m,
        "--nonparametric",
        "--bins",
        "0:30:1.5",
    ]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(column(&out, "theta_lo_deg"), lo);
    let (code, out, err) = run(&[
        "fit",
        "--measured",
        m,
        "--nonparametric",
        "--bins",
        "0:30:1.5",
        "--json",
    ]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let json_hi: Vec<String> = v["bins"]
        .as_array()
        .unwrap()
        .iter()
        .map(|b| format!("{}", b["theta_hi_deg"].as_f64().unwrap()))
        .collect();
    assert_eq!(json_hi, hi);
    std::fs::remove_dir_all(&dir).ok();
}

//! The table logic of `cargo xtask bench` on a synthetic criterion output directory
//! (written here in a temp dir, in criterion 0.8's `estimates.json` layout), so CI
//! exercises parsing, floor pairing and the met / not met decision without running any
//! bench. Expected numbers are worked out by hand in the comments.

use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime};

use xtask::bench::{
    ROWS, RowSpec, Target, Unit, build_rows, format_rate, format_time, read_median,
    render_document, render_table, utc_date,
};

/// A fresh, empty directory under the system temp dir.
fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("xtask-bench-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Writes `<dir>/<id>/new/estimates.json` as criterion 0.8 does, with the given median
/// (nanoseconds) and a deliberately different mean, so that reading the wrong field
/// would show.
fn write_estimate(dir: &Path, id: &str, median_ns: f64) {
    let d = dir.join(id).join("new");
    std::fs::create_dir_all(&d).unwrap();
    let est = |v: f64| {
        format!(
            r#"{{"confidence_interval":{{"confidence_level":0.95,"lower_bound":{},"upper_bound":{}}},"point_estimate":{v},"standard_error":1.0}}"#,
            v * 0.99,
            v * 1.01
        )
    };
    let json = format!(
        r#"{{"mean":{},"median":{},"median_abs_dev":{},"slope":{},"std_dev":{}}}"#,
        est(median_ns * 3.0),
        est(median_ns),
        est(1.0),
        est(median_ns * 3.0),
        est(2.0)
    );
    std::fs::write(d.join("estimates.json"), json).unwrap();
}

fn spec(id: &'static str, floor: Option<&'static str>, work: f64, unit: Unit) -> RowSpec {
    RowSpec {
        operation: "op",
        size: "n",
        id,
        floor,
        work,
        unit,
        target: None,
        target_note: "",
        quick: true,
    }
}

#[test]
fn medians_are_read_from_median_point_estimate_in_seconds() {
    let dir = temp_dir("median");
    write_estimate(&dir, "grp/fn/1024", 2.5e6);
    // 2.5e6 ns = 2.5 ms (the mean was written as 7.5 ms).
    let t = read_median(&dir, "grp/fn/1024", None).unwrap();
    assert!((t - 2.5e-3).abs() < 1e-15, "{t}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn missing_invalid_and_stale_estimates_give_messages_naming_the_file() {
    let dir = temp_dir("missing");
    let err = read_median(&dir, "nope/fn", None).unwrap_err();
    assert!(err.contains("not measured"), "{err}");
    assert!(
        err.contains(&dir.join("nope/fn/new/estimates.json").display().to_string()),
        "{err}"
    );

    let bad = dir.join("bad/fn/new");
    std::fs::create_dir_all(&bad).unwrap();
    std::fs::write(bad.join("estimates.json"), "{\"median\": ").unwrap();
    let err = read_median(&dir, "bad/fn", None).unwrap_err();
    assert!(err.contains("not valid JSON"), "{err}");

    std::fs::write(
        bad.join("estimates.json"),
        r#"{"mean":{"point_estimate":5.0}}"#,
    )
    .unwrap();
    let err = read_median(&dir, "bad/fn", None).unwrap_err();
    assert!(err.contains("median.point_estimate"), "{err}");

    std::fs::write(
        bad.join("estimates.json"),
        r#"{"median":{"point_estimate":-5.0}}"#,
    )
    .unwrap();
    let err = read_median(&dir, "bad/fn", None).unwrap_err();
    assert!(err.contains("not a positive time"), "{err}");

    // A file older than the start of the run is a stale result.
    write_estimate(&dir, "old/fn", 1000.0);
    let path = dir.join("old/fn/new/estimates.json");
    let an_hour_ago = SystemTime::now() - Duration::from_secs(3600);
    std::fs::File::options()
        .write(true)
        .open(&path)
        .unwrap()
        .set_modified(an_hour_ago)
        .unwrap();
    let since = SystemTime::now() - Duration::from_secs(60);
    let err = read_median(&dir, "old/fn", Some(since)).unwrap_err();
    assert!(err.contains("earlier run"), "{err}");
    // Without `since` (report only) it is accepted: 1000 ns = 1 µs.
    assert!((read_median(&dir, "old/fn", None).unwrap() - 1e-6).abs() < 1e-18);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn rows_pair_floors_compute_throughput_and_decide_targets() {
    let dir = temp_dir("rows");
    write_estimate(&dir, "g/default_set", 5e6); // 5 ms
    write_estimate(&dir, "g/slow/4096", 2e9); // 2 s
    write_estimate(&dir, "g/floor_4096", 4e7); // 40 ms
    write_estimate(&dir, "g/brdf_fast", 5e4); // 50 µs per 1000
    write_estimate(&dir, "g/brdf_slow", 2e5); // 200 µs per 1000
    write_estimate(&dir, "g/read", 5e8); // 0.5 s
    write_estimate(&dir, "g/mueller", 1.6e5); // 160 µs per 1000

    let specs = [
        RowSpec {
            target: Some(Target::MaxSeconds(0.020)),
            target_note: "< 20 ms",
            ..spec("g/default_set", None, 1405.0, Unit::Detectors)
        },
        RowSpec {
            target: Some(Target::MaxSeconds(1.5)),
            target_note: "< 1.5 s",
            ..spec("g/slow/4096", Some("g/floor_4096"), 1000.0, Unit::Rays)
        },
        RowSpec {
            target: Some(Target::MinPerSecond(1e7)),
            target_note: "> 10⁷ evaluations/s",
            ..spec("g/brdf_fast", None, 1000.0, Unit::Evaluations)
        },
        RowSpec {
            target: Some(Target::MinPerSecond(1e7)),
            target_note: "> 10⁷ evaluations/s",
            ..spec("g/brdf_slow", None, 1000.0, Unit::Evaluations)
        },
        spec(
            "g/read",
            Some("g/floor_missing"),
            134_217_728.0,
            Unit::Bytes,
        ),
        spec("g/not_run", Some("g/floor_4096"), 1.0, Unit::Pixels),
        RowSpec {
            target: Some(Target::MaxTimes {
                of: "g/brdf_fast",
                times: 3.0,
            }),
            target_note: "≤ 3×",
            ..spec("g/mueller", None, 1000.0, Unit::Evaluations)
        },
        RowSpec {
            target: Some(Target::MaxTimes {
                of: "g/brdf_slow",
                times: 3.0,
            }),
            target_note: "≤ 3×",
            ..spec("g/mueller", None, 1000.0, Unit::Evaluations)
        },
        RowSpec {
            target: Some(Target::MaxTimes {
                of: "g/not_run",
                times: 3.0,
            }),
            target_note: "≤ 3×",
            ..spec("g/mueller", None, 1000.0, Unit::Evaluations)
        },
    ];
    let rows = build_rows(&dir, &specs, None);

    // 5 ms ≤ 20 ms: met; 1405 detectors / 5 ms = 281 000 detectors/s.
    assert_eq!(rows[0].met(), Some(true));
    assert!((rows[0].per_second().unwrap() - 281_000.0).abs() < 1e-6);
    assert_eq!(rows[0].ratio(), None);
    // 2 s > 1.5 s: not met; floor 40 ms, ratio 2 / 0.04 = 50.
    assert_eq!(rows[1].met(), Some(false));
    assert!((rows[1].ratio().unwrap() - 50.0).abs() < 1e-9);
    // 1000 / 50 µs = 2e7 ≥ 1e7: met; 1000 / 200 µs = 5e6 < 1e7: not met.
    assert_eq!(rows[2].met(), Some(true));
    assert_eq!(rows[3].met(), Some(false));
    // No target: no decision; floor missing: no ratio, but the time is there.
    assert_eq!(rows[4].met(), None);
    assert_eq!(rows[4].ratio(), None);
    assert!(rows[4].median_s.is_ok());
    assert!(matches!(rows[4].floor_s, Some(Err(_))));
    // Not run: nothing, without a panic.
    assert!(rows[5].median_s.is_err());
    assert_eq!(rows[5].per_second(), None);
    assert_eq!(rows[5].met(), None);
    assert_eq!(rows[5].ratio(), None);
    // Relative targets: 160 µs > 3 × 50 µs: not met; 160 µs ≤ 3 × 200 µs: met; the
    // reference not measured: no decision.
    assert_eq!(rows[6].met(), Some(false));
    assert_eq!(rows[7].met(), Some(true));
    assert_eq!(rows[8].met(), None);
    assert!(matches!(rows[8].reference_s, Some(Err(_))));

    let table = render_table(&rows);
    let lines: Vec<&str> = table.lines().collect();
    assert!(lines[0].starts_with("| Operation | Size | Median time | Throughput | Target"));
    assert_eq!(
        lines[2],
        "| op | n | 5.00 ms | 281 k detectors/s | < 20 ms | yes | — | — | — |"
    );
    // 1000 rays / 2 s = 500 rays/s.
    assert_eq!(
        lines[3],
        "| op | n | 2.00 s | 500 rays/s | < 1.5 s | no | 40.0 ms | 50.0× | — |"
    );
    assert_eq!(
        lines[4],
        "| op | n | 50.0 µs | 20.0 M evaluations/s | > 10⁷ evaluations/s | yes | — | — | — |"
    );
    assert_eq!(
        lines[5],
        "| op | n | 200 µs | 5.00 M evaluations/s | > 10⁷ evaluations/s | no | — | — | — |"
    );
    // 134 217 728 B / 0.5 s = 268.4 MB/s.
    assert_eq!(
        lines[6],
        "| op | n | 500 ms | 268 MB/s | — | — | not measured | — | — |"
    );
    assert_eq!(
        lines[7],
        "| op | n | not measured | — | — | — | 40.0 ms | — | — |"
    );
    // The reasons are listed under the table, naming the ids.
    assert!(table.contains("\nNot measured:\n"));
    assert!(table.contains("floor `g/floor_missing`"));
    assert!(table.contains("`g/not_run`"));

    let doc = render_document(
        &rows,
        &[("CPU".to_owned(), "Test CPU @ 1 GHz".to_owned())],
        true,
    );
    assert!(doc.starts_with("# Benchmarks\n"));
    assert!(doc.contains("* CPU: Test CPU @ 1 GHz"));
    assert!(doc.contains("**Quick run**"));
    assert!(doc.contains(lines[3]));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn formatting_of_times_rates_and_dates() {
    assert_eq!(format_time(1.234), "1.23 s");
    assert_eq!(format_time(0.0064), "6.40 ms");
    assert_eq!(format_time(4.5647e-6), "4.56 µs");
    assert_eq!(format_time(3.2e-8), "32.0 ns");
    assert_eq!(
        format_rate(2.0e7, Unit::Evaluations),
        "20.0 M evaluations/s"
    );
    assert_eq!(format_rate(5.2e9, Unit::Pixels), "5.20 G pixels/s");
    assert_eq!(format_rate(1.5e6, Unit::Bytes), "1.50 MB/s");
    // Reference values from Python's datetime.utcfromtimestamp.
    let at = |s: u64| utc_date(SystemTime::UNIX_EPOCH + Duration::from_secs(s));
    assert_eq!(at(0), "1970-01-01 00:00");
    assert_eq!(at(951_782_400), "2000-02-29 00:00");
    assert_eq!(at(1_700_000_000), "2023-11-14 22:13");
    assert_eq!(at(4_102_444_799), "2099-12-31 23:59");
}

#[test]
fn the_real_table_is_consistent() {
    let mut ids: Vec<&str> = ROWS.iter().map(|r| r.id).collect();
    ids.sort_unstable();
    ids.dedup();
    assert_eq!(ids.len(), ROWS.len(), "duplicate bench ids in ROWS");
    for r in ROWS {
        // A floor is measured in the same bench group, on the same input.
        if let Some(f) = r.floor {
            let group = |id: &str| id.split('/').next().unwrap().to_owned();
            assert_eq!(group(f), group(r.id), "{}", r.id);
            assert!(f.rsplit('/').next().unwrap().starts_with("floor_"), "{f}");
        }
        assert_eq!(r.target.is_some(), !r.target_note.is_empty(), "{}", r.id);
        // Segments are counted by their bench and read from criterion's output.
        assert_eq!(r.work > 0.0, r.unit != Unit::Segments, "{}", r.id);
    }
    // A relative target refers to a row of the table (measured in the same run).
    for r in ROWS {
        if let Some(Target::MaxTimes { of, .. }) = r.target {
            assert!(ROWS.iter().any(|x| x.id == of), "{}: {of}", r.id);
        }
    }
    // The issue's targets are all present.
    let target = |id: &str| ROWS.iter().find(|r| r.id == id).unwrap().target;
    assert_eq!(
        target("topo/isotropic_5inc_281det/2048"),
        Some(Target::MaxTimes {
            of: "topo/run_5inc_281det/2048",
            times: 3.0
        })
    );
    assert_eq!(
        target("gaussian/default_set_5x281_exact_1thread"),
        Some(Target::MaxSeconds(0.002))
    );
    assert_eq!(
        target("gaussian/point_brdf_x1000"),
        Some(Target::MinPerSecond(1e7))
    );
    assert_eq!(
        target("topo/run_5inc_281det/4096"),
        Some(Target::MinPerSecond(2.5e8))
    );
    assert_eq!(
        target("topo/normals/4096"),
        Some(Target::MaxFloorRatio(15.0))
    );
    assert_eq!(
        target("gaussian/point_brdf_batch_x1000"),
        Some(Target::MinPerSecond(1.2e8))
    );
    assert_eq!(target("segment/2048x2048"), Some(Target::MaxSeconds(1.0)));
    assert_eq!(
        target("read_x3p/4096x4096_f64"),
        Some(Target::MinPerSecond(4e8))
    );
    assert_eq!(
        target("generate/2048_default"),
        Some(Target::MaxSeconds(2.0))
    );
    assert_eq!(
        target("volume/trace_1e5_flakes_cell_one_diameter"),
        Some(Target::MinPerSecond(1e7))
    );
    assert_eq!(
        target("gaussian/point_mueller_x1000"),
        Some(Target::MaxTimes {
            of: "gaussian/point_brdf_x1000",
            times: 3.0
        })
    );
    // A relative target refers to a row of the table.
    for r in ROWS {
        if let Some(Target::MaxTimes { of, .. }) = r.target {
            assert!(ROWS.iter().any(|o| o.id == of), "{}: {of}", r.id);
        }
    }
    // Rays of the 4096² topographic bench: (4096 − 4)² usable pixels × 5 incidences.
    let rays = ROWS
        .iter()
        .find(|r| r.id == "topo/run_5inc_281det/4096")
        .unwrap()
        .work;
    assert_eq!(rays, 83_722_320.0);
}

#[test]
fn segments_are_read_from_criterions_throughput() {
    // The volume bench gives criterion its segment count as `Throughput::Elements`;
    // criterion 0.8 writes it into `<id>/new/benchmark.json` as `"throughput":
    // {"Elements": n}`. 6e6 segments in a median of 0.5 s is 1.2e7 segments/s, above
    // the 1e7 target; 4e6 in 0.5 s (8e6/s) is below it.
    let dir = temp_dir("segments");
    let write_bench = |id: &str, n: u64| {
        let d = dir.join(id).join("new");
        std::fs::create_dir_all(&d).unwrap();
        let json = format!(
            r#"{{"group_id":"volume","function_id":"f","value_str":null,"throughput":{{"Elements":{n}}},"full_id":"{id}","directory_name":"{id}","title":"{id}"}}"#
        );
        std::fs::write(d.join("benchmark.json"), json).unwrap();
    };
    write_estimate(&dir, "volume/a", 5e8);
    write_bench("volume/a", 6_000_000);
    write_estimate(&dir, "volume/b", 5e8);
    write_bench("volume/b", 4_000_000);
    write_estimate(&dir, "volume/c", 5e8);
    let mut specs: Vec<RowSpec> = ["volume/a", "volume/b", "volume/c"]
        .iter()
        .map(|&id| spec(id, None, 0.0, Unit::Segments))
        .collect();
    for s in &mut specs {
        s.target = Some(Target::MinPerSecond(1e7));
        s.target_note = "≥ 10⁷ segments/s";
    }
    let rows = build_rows(&dir, &specs, None);
    assert!((rows[0].per_second().unwrap() - 1.2e7).abs() < 1e-3);
    assert_eq!(rows[0].met(), Some(true));
    assert_eq!(rows[1].met(), Some(false));
    // No benchmark.json: no rate and no verdict, and the table says why.
    assert_eq!(rows[2].per_second(), None);
    assert_eq!(rows[2].met(), None);
    let table = render_table(&rows);
    assert!(table.contains("12.0 M segments/s"), "{table}");
    assert!(table.contains("volume/c/new/benchmark.json"), "{table}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn floor_ratio_targets_and_compute_limits() {
    let dir = temp_dir("limits");
    write_estimate(&dir, "topo/normals/4096", 4e8); // 400 ms
    write_estimate(&dir, "topo/floor_4096", 2e7); // 20 ms: ratio 20
    write_estimate(&dir, "g/normals_fast", 2e8); // 200 ms: ratio 10
    write_estimate(&dir, "gaussian/point_brdf_batch_x1000", 8e3); // 8 µs per 1000
    let specs = [
        RowSpec {
            target: Some(Target::MaxFloorRatio(15.0)),
            target_note: "≤ 15×",
            ..spec(
                "topo/normals/4096",
                Some("topo/floor_4096"),
                1.0,
                Unit::Pixels,
            )
        },
        RowSpec {
            target: Some(Target::MaxFloorRatio(15.0)),
            target_note: "≤ 15×",
            ..spec("g/normals_fast", Some("topo/floor_4096"), 1.0, Unit::Pixels)
        },
        RowSpec {
            target: Some(Target::MaxFloorRatio(15.0)),
            target_note: "≤ 15×",
            ..spec("g/normals_fast", Some("g/floor_missing"), 1.0, Unit::Pixels)
        },
        spec(
            "gaussian/point_brdf_batch_x1000",
            None,
            1000.0,
            Unit::Evaluations,
        ),
    ];
    let rows = build_rows(&dir, &specs, None);
    // 400 / 20 = 20 > 15: not met; 200 / 20 = 10 ≤ 15: met; no floor: no decision.
    assert_eq!(rows[0].met(), Some(false));
    assert_eq!(rows[1].met(), Some(true));
    assert_eq!(rows[2].met(), None);
    // 1000 / 8 µs = 125 M/s against the limit of 173 M/s: 125 / 173 = 72.3 %.
    assert!(rows[3].limit().is_some() && rows[0].limit().is_none());
    let table = render_table(&rows);
    let last = table.lines().nth(5).unwrap();
    assert_eq!(
        last,
        "| op | n | 8.00 µs | 125 M evaluations/s | — | — | — | — | 173 M evaluations/s (vectorised C, AVX2; we reach 72 %) |"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn measured_compute_limit_is_the_rows_work_over_its_bench() {
    let dir = temp_dir("measured-limit");
    // 10⁸ bytes in 400 ms = 250 MB/s; the inflate alone in 200 ms = 500 MB/s: 50 %.
    write_estimate(&dir, "read_x3p/4096x4096_f64", 4e8);
    write_estimate(&dir, "read_x3p/inflate_4096x4096_f64", 2e8);
    let row = spec("read_x3p/4096x4096_f64", None, 1e8, Unit::Bytes);
    let rows = build_rows(&dir, &[row], None);
    assert_eq!(rows[0].limit_per_second(), Some(Ok(5e8)));
    let table = render_table(&rows);
    assert_eq!(
        table.lines().nth(2).unwrap(),
        "| op | n | 400 ms | 250 MB/s | — | — | — | — | 500 MB/s (the streaming inflate of \
         `data.bin` alone, measured; we reach 50 %) |"
    );
    // Without the limit's bench the cell says so, and the table lists what is missing.
    std::fs::remove_dir_all(dir.join("read_x3p/inflate_4096x4096_f64")).unwrap();
    let rows = build_rows(&dir, &[row], None);
    assert!(matches!(rows[0].limit_per_second(), Some(Err(_))));
    let table = render_table(&rows);
    assert!(
        table.lines().nth(2).unwrap().ends_with("| not measured |"),
        "{table}"
    );
    assert!(
        table.contains("limit `read_x3p/inflate_4096x4096_f64`"),
        "{table}"
    );
    // A row without a limit has none.
    let other = spec("read_x3p/floor_4096x4096_f64", None, 1e8, Unit::Bytes);
    assert_eq!(build_rows(&dir, &[other], None)[0].limit_per_second(), None);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn peak_memory_from_gnu_time_and_its_target() {
    use xtask::bench::memory::{MemoryRow, map_bytes, parse_time_v, render};
    // The lines GNU time 1.9 `-v` prints (tab-indented), KiB.
    let report = "\tCommand being timed: \"flakescatter info map.x3p\"\n\
                  \tUser time (seconds): 0.61\n\
                  \tMaximum resident set size (kbytes): 174048\n\
                  \tAverage resident set size (kbytes): 0\n";
    assert_eq!(parse_time_v(report), Some(174_048.0 * 1024.0));
    assert_eq!(parse_time_v("no such line"), None);
    // 4096² float64 = 134 217 728 B; the allowance 1.5 × that + 50 MB = 251.3 MB.
    assert_eq!(map_bytes(), 134_217_728.0);
    let rows = [
        MemoryRow {
            label: "info",
            command: "flakescatter info map.x3p".into(),
            peak_bytes: Ok(174_048.0 * 1024.0),
        },
        MemoryRow {
            label: "segment",
            command: "flakescatter segment map.x3p".into(),
            peak_bytes: Ok(389_208.0 * 1024.0),
        },
        MemoryRow {
            label: "topo",
            command: "flakescatter topo map.x3p".into(),
            peak_bytes: Err("/usr/bin/time (GNU time) not found".into()),
        },
    ];
    let s = render(&rows);
    // 174 048 KiB = 178.2 MB = 1.33× the map; 389 208 KiB = 398.5 MB = 2.97×.
    assert!(
        s.contains("| info (`flakescatter info map.x3p`) | 178 MB | 1.33× | ≤ 251 MB | yes |"),
        "{s}"
    );
    assert!(s.contains("| 399 MB | 2.97× | ≤ 251 MB | no |"), "{s}");
    assert!(
        s.contains("not measured (/usr/bin/time (GNU time) not found) | — |"),
        "{s}"
    );
}

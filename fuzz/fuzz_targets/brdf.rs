//! The BRDF-table reader (`fit --paint`, `compare --params`) on arbitrary bytes, with the
//! paint model's channel rule: a table whose every row and value passed its checks, or an
//! error naming the file, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let rule = |name: &str| {
        flakescatter_paint::Channel::parse(name)
            .map(|_| ())
            .map_err(|e| e.to_string())
    };
    match flakescatter_io::brdf::read_brdf_table_from(data, "fuzz.csv", &rule) {
        Ok(t) => {
            assert!(!t.rows.is_empty() && !t.channels.is_empty());
            for r in &t.rows {
                assert_eq!(r.values.len(), t.channels.len());
                assert!(r.values.iter().all(|v| *v > 0.0 && v.is_finite()));
                assert!((0.0..std::f64::consts::FRAC_PI_2).contains(&r.theta_i));
                assert!((0.0..std::f64::consts::FRAC_PI_2).contains(&r.theta_r));
            }
        }
        Err(e) => assert!(e.to_string().contains("fuzz.csv"), "{e}"),
    }
});

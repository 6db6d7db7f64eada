//! One rule and one message for the settings every front end checks
//! (`flakescatter::checks`): the command line and the `analyze` manifest refuse the
//! same bad values with the same words, each naming its own flag or key (the Python
//! keywords: `crates/python/tests/test_models.py::test_settings_share_the_cli_messages`).

mod common;

use std::fs;

use common::{fixtures, run, s, scratch, stderr};

const INDEX: &str = "0.5: the refractive index must be a finite number >= 1";
const WINDOW: &str = "4: the least-squares window must be an odd number of pixels >= 3";
const TILE: &str = "-2: the tile side must be a finite length > 0 µm";

#[test]
fn flags_and_manifest_keys_share_the_message() {
    let o = run(&["model", "--n", "0.5"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains(&format!("--n {INDEX}")),
        "{}",
        stderr(&o)
    );

    let map = fixtures().join("synth-hwhm3-smooth.height.x3p");
    let o = run(&["topo", s(&map), "--tile-um", "-2"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains(&format!("--tile-um {TILE}")),
        "{}",
        stderr(&o)
    );

    let d = scratch("checks", "manifest");
    for (section, want) in [
        ("[coating]\nn = 0.5\n", INDEX),
        ("[models]\nwindow = 4\nfit = false\n", WINDOW),
        ("[models]\ntile_um = -2.0\nfit = false\n", TILE),
    ] {
        let m = d.join("m.toml");
        fs::write(
            &m,
            format!(
                "[maps]\nfiles = [\"{}\"]\n{section}",
                map.display().to_string().replace('\\', "/")
            ),
        )
        .unwrap();
        let o = run(&["analyze", s(&m), "--out", s(&d.join("out")), "--no-preview"]);
        assert_eq!(o.status.code(), Some(2), "{section}");
        assert!(stderr(&o).contains(want), "{section}: {}", stderr(&o));
    }
}

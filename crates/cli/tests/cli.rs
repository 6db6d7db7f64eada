//! The binary's own surface: --help, --version, usage errors (exit status 2).

mod common;

use common::run_text as run;

#[test]
fn help_lists_the_subcommands_of_the_contract() {
    let (code, out, _) = run(&["--help"]);
    assert_eq!(code, 0);
    for sub in [
        "model", "topo", "compare", "fit", "stats", "segment", "info", "synth", "stack", "volume",
    ] {
        assert!(
            out.lines().any(|l| l.trim_start().starts_with(sub)),
            "--help lacks `{sub}`:\n{out}"
        );
    }
}

#[test]
fn version_is_the_package_version() {
    let (code, out, _) = run(&["--version"]);
    assert_eq!(code, 0);
    assert_eq!(
        out.trim(),
        format!("flakescatter {}", env!("CARGO_PKG_VERSION"))
    );
}

#[test]
fn usage_errors_exit_2_with_a_message() {
    for args in [&["frobnicate"][..], &["model", "--no-such-flag"], &[]] {
        let (code, _, err) = run(args);
        assert_eq!(code, 2, "{args:?}");
        assert!(
            err.contains("Usage") || err.contains("error"),
            "{args:?}: {err}"
        );
    }
}

#[test]
fn every_subcommand_has_help() {
    // clap checks each command's flag definitions (conflicts, groups) when it is built:
    // a wrong flag id would fail here rather than for a user.
    for sub in [
        "model",
        "topo",
        "compare",
        "fit",
        "stats",
        "segment",
        "info",
        "synth",
        "stack",
        "reproduce",
        "volume",
    ] {
        let (code, out, err) = run(&[sub, "--help"]);
        assert_eq!(code, 0, "{sub}: {err}");
        assert!(out.contains("Usage"), "{sub}: {out}");
    }
}

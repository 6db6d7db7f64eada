//! Every flag that takes a value takes a negative number as that value (issue 52, item
//! 23): `--wavelengths -550` reaches the flag's own check ("-550 nm is outside …") and
//! `volume --rays -1` the same message as `0`, instead of clap's "unexpected argument
//! '-5'". Applied to the whole command tree here, once, so that a new flag cannot forget
//! it:
//!
//! * flags whose values are not paths (numbers, lists, ranges, names) take any value
//!   that starts with `-` (`-550`, `-.5`, `-1e-3`, `-550,600`, `-70:70:5`); a typo that
//!   swallows the next flag (`--hwhm --json`) is then refused by the flag's own check;
//! * path flags take negative numbers only (a file named `-5`), so `--out --json` stays
//!   a missing value rather than a file named `--json`.

use std::any::TypeId;
use std::path::PathBuf;

use clap::{Arg, Command, CommandFactory};

/// Whether `arg`'s values are paths.
fn is_path(arg: &Arg) -> bool {
    arg.get_value_parser().type_id() == TypeId::of::<PathBuf>()
}

/// One argument with negative values allowed (module docs).
fn allow_negative(arg: Arg) -> Arg {
    if arg.get_long().is_none() || !arg.get_action().takes_values() {
        arg
    } else if is_path(&arg) {
        arg.allow_negative_numbers(true)
    } else {
        arg.allow_hyphen_values(true)
    }
}

/// The `flakescatter` command with negative values allowed on every value flag.
pub fn command() -> Command {
    crate::Cli::command().mut_subcommands(|sub| sub.mut_args(allow_negative))
}

#[cfg(test)]
mod tests {
    use clap::error::ErrorKind;

    /// Whether `--flag value` of `sub` is parsed as the flag's value (any other outcome,
    /// including an invalid value or a missing required argument, is the flag's own).
    fn taken(sub: &str, flag: &str, value: &str) -> bool {
        match super::command().try_get_matches_from(["flakescatter", sub, flag, value]) {
            Ok(_) => true,
            Err(e) => match e.kind() {
                ErrorKind::UnknownArgument => false,
                // `--out --json`: the next word was taken as a flag.
                ErrorKind::InvalidValue => !e.to_string().contains("a value is required"),
                _ => true,
            },
        }
    }

    #[test]
    fn every_value_flag_takes_a_negative_number() {
        let cmd = super::command();
        let mut refused = Vec::new();
        let (mut checked, mut paths) = (0, 0);
        for sub in cmd.get_subcommands() {
            for arg in sub.get_arguments() {
                let Some(long) = arg.get_long() else { continue };
                if !arg.get_action().takes_values() {
                    continue;
                }
                let flag = format!("--{long}");
                let values: &[&str] = if super::is_path(arg) {
                    paths += 1;
                    &["-5", "-0.5", "-1e20"]
                } else {
                    &[
                        "-5", "-0.5", "-.5", "-1e20", "-1e-3", "-550,600", "-70:70:5",
                    ]
                };
                for v in values {
                    checked += 1;
                    if !taken(sub.get_name(), &flag, v) {
                        refused.push(format!("{} {flag} {v}", sub.get_name()));
                    }
                }
            }
        }
        assert!(checked > 500 && paths > 30, "{checked} {paths}");
        assert!(
            refused.is_empty(),
            "not taken as the flag's value:\n{}",
            refused.join("\n")
        );
        // A flag that takes no value still refuses a stray negative number, a path flag
        // does not swallow the next flag, and an unknown flag stays unknown.
        assert!(!taken("model", "--json", "-5"));
        assert!(!taken("model", "--out", "--json"));
        assert!(!taken("model", "--no-such-flag", "1"));
    }
}

//! Flags that act only in some mode of their command, refused everywhere else (issue 52,
//! item 14; docs/cli.md "Flags that do not apply"): a flag is either honoured or refused,
//! never silently ignored.
//!
//! Clap's own `requires` cannot carry these rules alone: it skips a required flag when a
//! flag conflicting with it is present (so `stats --flakes T --per-map F` passed, since
//! `--flakes` conflicts with `--map`), it cannot look at values (`--substrate mirror`
//! only acts with `--substrate-reflectance > 0`), and a flag with a default cannot tell
//! `--bins 0:30:2` typed from the default. So the rules live in one table, [`RULES`],
//! checked right after parsing against what was typed on the command line
//! ([`ValueSource::CommandLine`]); [`given`] answers the same question for checks that
//! need the inputs first (stack flags when no input is a z-stack).

use std::sync::OnceLock;

use anyhow::bail;
use clap::parser::ValueSource;
use clap::{ArgMatches, Command};

/// What a flag needs to act.
#[derive(Clone, Copy)]
enum Need {
    /// At least one of these flags (clap ids) on the command line.
    AnyOf(&'static [&'static str]),
    /// None of these flags on the command line.
    NoneOf(&'static [&'static str]),
    /// A condition on the parsed values.
    When(fn(&ArgMatches) -> bool),
}

/// One rule: in `commands` (`&[]` = every command that has the flag), each flag of
/// `flags` (clap ids), when typed, needs `need`; `why` completes the message after the
/// flag.
struct Rule {
    commands: &'static [&'static str],
    flags: &'static [&'static str],
    need: Need,
    why: &'static str,
}

const fn rule(
    commands: &'static [&'static str],
    flags: &'static [&'static str],
    need: Need,
    why: &'static str,
) -> Rule {
    Rule {
        commands,
        flags,
        need,
        why,
    }
}

/// `--haze` given and > 0.
fn haze_positive(m: &ArgMatches) -> bool {
    m.get_one::<f64>("haze").is_some_and(|&h| h > 0.0)
}

/// `--family` is one that has a smoothness weight (table, or auto, which tries it).
fn family_with_table(m: &ArgMatches) -> bool {
    m.get_one::<String>("family")
        .is_some_and(|f| f == "auto" || f == "table")
}

/// `--substrate-reflectance` > 0.
fn substrate_reflects(m: &ArgMatches) -> bool {
    m.get_one::<f64>("substrate_reflectance")
        .is_some_and(|&r| r > 0.0)
}

/// `--roughness-um` > 0.
fn substrate_rough(m: &ArgMatches) -> bool {
    m.get_one::<f64>("roughness_um").is_some_and(|&r| r > 0.0)
}

/// The flags of `stats` that read or segment maps (none of them acts on `--flakes`).
const STATS_MAP_FLAGS: [&str; 25] = [
    "pixel_um",
    "allow_duplicate_maps",
    "z_unit",
    "accept_md5_mismatch",
    "decimal_comma",
    "decimal_point",
    "channel",
    "intensity",
    "intensity_suffix",
    "height_suffix",
    "intensity_channel",
    "cutoff",
    "peak",
    "min_signal",
    "stack_z_step_um",
    "first_page",
    "z_step_um",
    "noise_um",
    "min_pixels",
    "flakes_out",
    "per_map",
    "pixel_normals",
    "pixel_normals_only",
    "window",
    "tile_um",
];

const STATS_MAP_WHY: &str =
    "applies to --map (stats --flakes reads a flake table: no map is read or segmented)";

const MEASURED_KIND_WHY: &str = "does not apply to a paint: its table gives BRDFs (columns brdf_<channel>_per_sr), not a curve's value column";

/// The rules, checked in order (the first broken one is reported).
static RULES: &[Rule] = &[
    // fit: the Gaussian fit, --nonparametric, --measured-multiangle, --paint.
    rule(
        &["fit"],
        &["bins"],
        Need::AnyOf(&["nonparametric"]),
        "applies only with --nonparametric (the bin edges of the tabulated estimate; the Gaussian, L* and paint fits have none)",
    ),
    rule(
        &["fit"],
        &["lambda"],
        Need::AnyOf(&["nonparametric"]),
        "applies only with --nonparametric (the smoothness weight of the tabulated estimate; the Gaussian, L* and paint fits have none)",
    ),
    rule(
        &["fit"],
        &["hwhm_start"],
        Need::NoneOf(&["nonparametric"]),
        "is the start of the Gaussian width; --nonparametric estimates a table and starts from none",
    ),
    rule(
        &["fit"],
        &["hwhm_start"],
        Need::NoneOf(&["paint"]),
        "does not apply to --paint: every family starts from the previous one's fit",
    ),
    rule(
        &["fit"],
        &["common_scale"],
        Need::NoneOf(&["measured_multiangle"]),
        "does not apply to --measured-multiangle: the L* fit always has one scale for every geometry",
    ),
    rule(
        &["fit"],
        &["family"],
        Need::AnyOf(&["paint"]),
        "applies to --paint",
    ),
    rule(
        &["fit"],
        &["smoothing"],
        Need::AnyOf(&["paint"]),
        "applies to --paint",
    ),
    rule(
        &["fit"],
        &["smoothing"],
        Need::When(family_with_table),
        "is the smoothness weight of --family table (and of auto, which tries it); the other families have none",
    ),
    rule(
        &["fit"],
        &["measured_kind"],
        Need::NoneOf(&["paint"]),
        MEASURED_KIND_WHY,
    ),
    rule(
        &["compare"],
        &["measured_kind"],
        Need::NoneOf(&["paint", "params"]),
        MEASURED_KIND_WHY,
    ),
    // compare: a computed model, a result CSV (--model), a paint (--params, --paint).
    rule(
        &["compare"],
        &["model"],
        Need::NoneOf(&["paint"]),
        "compares against a result CSV; --paint builds a paint from flags: give one of them",
    ),
    rule(
        &["compare"],
        &["clearcoat"],
        Need::NoneOf(&["paint"]),
        "does not apply to --paint: the coat is part of the paint",
    ),
    rule(
        &["compare"],
        &["no_clearcoat"],
        Need::NoneOf(&["paint"]),
        "does not apply to --paint: the coat is part of the paint",
    ),
    rule(
        &["compare"],
        &["transmission"],
        Need::NoneOf(&["paint"]),
        "does not apply to --paint: a paint uses the exact unpolarised Fresnel factors",
    ),
    rule(
        &["compare"],
        &["weighting"],
        Need::NoneOf(&["paint"]),
        "does not apply to --paint: a paint uses the physical weighting",
    ),
    rule(
        &["compare"],
        &["alpha"],
        Need::NoneOf(&["params", "model"]),
        "describes an orientation family; --params and --model bring their own",
    ),
    rule(
        &["compare"],
        &["shape"],
        Need::NoneOf(&["params", "model"]),
        "describes an orientation family; --params and --model bring their own",
    ),
    rule(
        &["model"],
        &["alpha"],
        Need::NoneOf(&["params"]),
        "describes an orientation family; --params brings its own",
    ),
    rule(
        &["model"],
        &["shape"],
        Need::NoneOf(&["params"]),
        "describes an orientation family; --params brings its own",
    ),
    rule(
        &["model"],
        &["multi_angle"],
        Need::NoneOf(&["paint"]),
        "computes the distribution model's colour; it does not apply to --paint (whose channels are --channels)",
    ),
    rule(
        &["model", "compare"],
        &["haze_roughness"],
        Need::When(haze_positive),
        "is the roughness of the haze: it needs --haze > 0",
    ),
    // stats --flakes reads no map.
    rule(
        &["stats"],
        &STATS_MAP_FLAGS,
        Need::AnyOf(&["map"]),
        STATS_MAP_WHY,
    ),
    rule(
        &["stats"],
        &["window", "tile_um"],
        Need::AnyOf(&["pixel_normals", "pixel_normals_only"]),
        "applies to the pixel-level statistics: it needs --pixel-normals or --pixel-normals-only",
    ),
    // Map inputs, wherever they are read.
    rule(
        &[],
        &["height_suffix"],
        Need::AnyOf(&["intensity_suffix"]),
        "is the part of a map's name that --intensity-suffix replaces: it needs --intensity-suffix",
    ),
    rule(
        &["segment"],
        &["overlay_max_deg"],
        Need::AnyOf(&["overlay"]),
        "is the top of the overlays' colour scale: it needs --overlay DIR",
    ),
    // synth, volume.
    rule(
        &["synth"],
        &["correlation_um"],
        Need::When(substrate_rough),
        "is the correlation length of the substrate's roughness: it needs --roughness-um > 0",
    ),
    rule(
        &["volume"],
        &["substrate"],
        Need::When(substrate_reflects),
        "says how a reflecting substrate reflects: it needs --substrate-reflectance > 0 (0, the default, is black)",
    ),
];

/// The ids typed on the command line of the subcommand being run (set by [`check`]).
static GIVEN: OnceLock<Vec<String>> = OnceLock::new();

/// Whether the flag with clap id `id` was typed on the command line (not a default).
/// `false` before [`check`] has run.
pub fn given(id: &str) -> bool {
    GIVEN.get().is_some_and(|g| g.iter().any(|x| x == id))
}

/// Checks the parsed command line (`matches` of `command`, the command tree `main`
/// parsed with) against [`RULES`], and records what was typed for [`given`]. Call
/// once, after the command line parsed.
///
/// # Errors
/// The first rule broken, naming the flag (and its value) and what it needs.
pub fn check(command: &Command, matches: &ArgMatches) -> anyhow::Result<()> {
    let Some((name, sub)) = matches.subcommand() else {
        return Ok(());
    };
    let Some(cmd) = command.find_subcommand(name) else {
        bail!("internal: the parsed subcommand `{name}` is not in the command tree");
    };
    let typed: Vec<String> = cmd
        .get_arguments()
        .map(|a| a.get_id().as_str().to_owned())
        .filter(|id| sub.value_source(id) == Some(ValueSource::CommandLine))
        .collect();
    let result = broken(name, cmd, sub, &typed);
    let _ = GIVEN.set(typed);
    result
}

/// The first rule that `typed` (ids on the command line of subcommand `name`) breaks.
fn broken(name: &str, cmd: &Command, sub: &ArgMatches, typed: &[String]) -> anyhow::Result<()> {
    let has = |id: &str| typed.iter().any(|x| x == id);
    let long = |id: &str| {
        cmd.get_arguments()
            .find(|a| a.get_id() == id)
            .and_then(clap::Arg::get_long)
            .map_or_else(|| id.to_owned(), |l| format!("--{l}"))
    };
    for r in RULES {
        if !(r.commands.is_empty() || r.commands.contains(&name)) {
            continue;
        }
        for &flag in r.flags.iter().filter(|f| has(f)) {
            let ok = match r.need {
                Need::AnyOf(ids) => ids.iter().any(|id| has(id)),
                Need::NoneOf(ids) => !ids.iter().any(|id| has(id)),
                Need::When(f) => f(sub),
            };
            if ok {
                continue;
            }
            // The value as typed (flags without one have none).
            let value = sub
                .get_raw(flag)
                .and_then(|mut v| v.next())
                .map(|v| v.to_string_lossy().into_owned())
                .filter(|_| {
                    cmd.get_arguments().any(|a| {
                        a.get_id() == flag && a.get_num_args().is_some_and(|n| n.takes_values())
                    })
                })
                .map(|v| format!(" {v}"))
                .unwrap_or_default();
            let with = match r.need {
                Need::NoneOf(ids) => {
                    let present: Vec<String> =
                        ids.iter().filter(|i| has(i)).map(|i| long(i)).collect();
                    format!(" (given with {})", present.join(", "))
                }
                _ => String::new(),
            };
            bail!("{}{value}: {}{with}", long(flag), r.why);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use clap::CommandFactory;

    use super::*;

    /// Every rule names flags its commands have (a misspelt id would never fire).
    #[test]
    fn every_rule_names_real_flags() {
        let command = crate::Cli::command();
        let ids = |c: &Command| -> Vec<String> {
            c.get_arguments()
                .map(|a| a.get_id().as_str().to_owned())
                .collect()
        };
        let mut fired_somewhere = vec![false; RULES.len()];
        for sub in command.get_subcommands() {
            let have = ids(sub);
            for (k, r) in RULES.iter().enumerate() {
                if !r.commands.is_empty() && !r.commands.contains(&sub.get_name()) {
                    continue;
                }
                for flag in r.flags {
                    if !have.iter().any(|i| i == flag) {
                        assert!(r.commands.is_empty(), "{}: no flag {flag}", sub.get_name());
                        continue;
                    }
                    fired_somewhere[k] = true;
                    if let Need::AnyOf(o) | Need::NoneOf(o) = r.need {
                        for id in o {
                            assert!(
                                have.iter().any(|i| i == id),
                                "{}: rule for {flag} names no flag {id}",
                                sub.get_name()
                            );
                        }
                    }
                }
            }
        }
        for (k, f) in fired_somewhere.iter().enumerate() {
            assert!(f, "rule {k} ({:?}) applies to no command", RULES[k].flags);
        }
    }
}

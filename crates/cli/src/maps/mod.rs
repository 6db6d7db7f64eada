//! Reading the inputs of a command: height maps (several of them, from files,
//! directories or glob patterns) paired with their intensity maps, z-stacks wherever a
//! map is read, and the out-of-plane detector file. Errors name the file and the flag.
//!
//! **Which files are maps** (docs/cli.md "Several maps"): every `MAP` argument is a
//! file, a directory or a glob pattern (`maps/*.x3p`, quoted so that the shell leaves
//! it alone). A Zarr v3 store (a directory holding `zarr.json`, or named `*.zarr`) is
//! one map. Any other directory stands for its files (not its subdirectories) and Zarr
//! stores with a map or stack extension ([`MAP_EXTENSIONS`]: ISO, text, TIFF, Zarr and
//! instrument formats but `.dat`), in name order,
//! hidden files left out; with `--intensity-suffix` only those whose name carries the
//! height suffix (`--height-suffix`, default `.height`) before the extension. A pattern
//! stands for the files it matches, in name order. A directory or pattern that gives
//! no map, and a file given twice, are errors naming it.
//!
//! **Pairing with intensity maps**, one rule at a time: `--intensity FILE` once per
//! height map in the same order, or `--intensity-suffix S`: the partner of
//! `NAME<height-suffix>.EXT` is `NAME<S>.EXT` in the same directory (the last
//! occurrence of the height suffix is replaced). A map whose name lacks the height
//! suffix, or whose partner does not exist, is an error naming both. A z-stack
//! (`.tif`/`.tiff`) carries its own intensity and takes no partner.

mod collect;
mod load;
pub mod stream;

use std::path::PathBuf;

use anyhow::{Context, bail};
use flakescatter::confocal::{MinSignal, PeakMethod, PeakOptions};
use flakescatter::inputs::{LoadOptions, MapSource, SourceKind};
use flakescatter::io::ReadOptions;
use flakescatter::io::stack::{PageOrder, StackOptions};

use crate::flags::MapArgs;
use crate::output::Plan;
pub use collect::{dangling, expand, pair};
pub use load::load_all;

/// Extensions of files taken from a directory as maps or stacks: the ISO formats, text
/// matrices, TIFF stacks, Zarr stores (`.zarr` directories) and the instrument formats
/// with an extension of their own
/// (MetroPro's `.dat` is also used for text and other data, so `.dat` files are named
/// one by one or by a pattern such as `dir/*.dat`).
pub const MAP_EXTENSIONS: [&str; 14] = [
    "x3p", "sdf", "txt", "asc", "tif", "tiff", "gwy", "plu", "apx", "opd", "sur", "al3d", "frt",
    "zarr",
];

/// Largest number of maps one command reads.
pub const MAX_MAPS: usize = 100_000;

/// How z-stacks given as maps are localised (as `flakescatter stack`).
#[derive(Debug, Clone, clap::Args)]
pub struct StackInputArgs {
    /// Peak localisation of z-stacks given as maps: argmax, parabolic, gaussian or
    /// centroid (docs/physics.md §9).
    #[arg(long, value_name = "METHOD", default_value = "gaussian")]
    pub peak: String,
    /// Stack pixels whose brightest sample is below this (full scale 1) are invalid
    /// (default: estimated from each stack's own noise, as `flakescatter stack`).
    #[arg(long = "min-signal", value_name = "X", allow_negative_numbers = true)]
    pub min_signal: Option<f64>,
    /// z step of z-stacks given as maps, µm, overriding their metadata (needed when the
    /// file has none).
    #[arg(
        long = "stack-z-step-um",
        value_name = "UM",
        allow_negative_numbers = true
    )]
    pub stack_z_step_um: Option<f64>,
    /// Which slice page 0 of a z-stack is: `bottom` (the default when the metadata does
    /// not say) or `top`.
    #[arg(long = "first-page", value_name = "END")]
    pub first_page: Option<String>,
}

impl StackInputArgs {
    /// Refuses the stack flags typed on the command line when none of `sources` is a
    /// z-stack: they would act on nothing (issue 52, item 14).
    pub fn refuse_without_stacks(&self, sources: &[MapSource]) -> anyhow::Result<()> {
        if sources.iter().any(|s| s.kind == SourceKind::Stack) {
            return Ok(());
        }
        let typed: Vec<&str> = [
            ("peak", "--peak"),
            ("min_signal", "--min-signal"),
            ("stack_z_step_um", "--stack-z-step-um"),
            ("first_page", "--first-page"),
        ]
        .into_iter()
        .filter(|(id, _)| crate::flags::modes::given(id))
        .map(|(_, flag)| flag)
        .collect();
        if let Some(first) = typed.first() {
            let names: Vec<String> = sources
                .iter()
                .take(3)
                .map(|s| s.height.display().to_string())
                .collect();
            bail!(
                "{first} applies to z-stacks (.tif, .tiff) given as maps, and no input is one ({}{}): leave {} out",
                names.join(", "),
                if sources.len() > 3 { ", ..." } else { "" },
                typed.join(", ")
            );
        }
        Ok(())
    }

    /// Stack reading and peak options; errors name the flag.
    pub fn options(&self, read: &ReadOptions) -> anyhow::Result<(StackOptions, PeakOptions)> {
        let method = PeakMethod::from_name(&self.peak).with_context(|| {
            format!(
                "--peak {}: expected argmax, parabolic, gaussian or centroid",
                self.peak
            )
        })?;
        if let Some(m) = self.min_signal
            && !(m.is_finite() && (0.0..=1.0).contains(&m))
        {
            bail!("--min-signal {m}: expected a finite level in [0, 1] (full scale 1)");
        }
        if let Some(z) = self.stack_z_step_um
            && !(z.is_finite() && z > 0.0)
        {
            bail!("--stack-z-step-um {z}: the z step must be finite and > 0 µm");
        }
        let first_page = match self.first_page.as_deref() {
            None => None,
            Some("bottom") => Some(PageOrder::BottomFirst),
            Some("top") => Some(PageOrder::TopFirst),
            Some(o) => bail!("--first-page {o}: expected bottom or top"),
        };
        Ok((
            StackOptions {
                pixel_um: read.pixel_um,
                z_step_um: self.stack_z_step_um,
                first_page,
            },
            PeakOptions {
                method,
                min_signal: self
                    .min_signal
                    .map_or(MinSignal::Estimated, MinSignal::Level),
                ..PeakOptions::default()
            },
        ))
    }
}

/// The map inputs of `segment`, `stats --map` and `topo`: calibration, intensity
/// pairing and cutoff, stack localisation (module docs).
#[derive(Debug, Clone, clap::Args)]
pub struct MapInputArgs {
    /// Calibration flags.
    #[command(flatten)]
    pub calibration: MapArgs,
    /// Intensity map of each height map, in the same order (repeat the flag, once per
    /// map); pixels whose intensity is below --cutoff are left out.
    #[arg(long, value_name = "FILE", conflicts_with = "intensity_suffix")]
    pub intensity: Vec<PathBuf>,
    /// Pair each height map `NAME<height-suffix>.EXT` with the intensity map
    /// `NAME<SUFFIX>.EXT` beside it, e.g. `.intensity`.
    #[arg(long = "intensity-suffix", value_name = "SUFFIX")]
    pub intensity_suffix: Option<String>,
    /// The part of a height map's name that --intensity-suffix replaces.
    #[arg(
        long = "height-suffix",
        value_name = "SUFFIX",
        default_value = ".height",
        requires = "intensity_suffix"
    )]
    pub height_suffix: String,
    /// Use this channel of each height map file (index or name, as `info` lists them:
    /// PLU `image0`, MetroPro `intensity`, AL3D `texture`, GWY/SUR/OPD channels) as its
    /// intensity map, instead of a second file.
    #[arg(
        long = "intensity-channel",
        value_name = "NAME|INDEX",
        conflicts_with_all = ["intensity", "intensity_suffix"]
    )]
    pub intensity_channel: Option<String>,
    /// Intensity cutoff, in the intensity maps' own stored values (unit-less; full scale
    /// 1 for z-stacks).
    #[arg(long, value_name = "X", allow_negative_numbers = true)]
    pub cutoff: Option<f64>,
    /// Pool maps that are the same data (a byte-identical copy, or the same file
    /// through a link), which are refused by default: a copy counted twice fakes
    /// independent evidence.
    #[arg(long = "allow-duplicate-maps")]
    pub allow_duplicate_maps: bool,
    /// Localisation of z-stacks given as maps.
    #[command(flatten)]
    pub stack: StackInputArgs,
}

/// The rule that pairs height maps with intensity maps.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Pairing {
    /// No intensity maps.
    None,
    /// One intensity map per height map, in order.
    Explicit(Vec<PathBuf>),
    /// Replace the height suffix by the intensity suffix.
    Suffix {
        /// Part of the height map's name replaced.
        height: String,
        /// What replaces it.
        intensity: String,
    },
}

impl MapInputArgs {
    /// The pairing rule of the flags.
    pub fn pairing(&self) -> Pairing {
        match (&self.intensity_suffix, self.intensity.is_empty()) {
            (Some(s), _) => Pairing::Suffix {
                height: self.height_suffix.clone(),
                intensity: s.clone(),
            },
            (None, false) => Pairing::Explicit(self.intensity.clone()),
            (None, true) => Pairing::None,
        }
    }

    /// Checks the flags and resolves `maps` (files, directories, patterns given as
    /// `flag`) into sources with their partners, before any work: every file must
    /// exist. Registers every file as an input of `plan`.
    pub fn sources(
        &self,
        flag: &str,
        maps: &[PathBuf],
        plan: &mut Plan,
        repeats: Repeats,
    ) -> anyhow::Result<Vec<MapSource>> {
        check_cutoff(self.cutoff)?;
        self.load_options()?;
        let channel = self.calibration.channel()?;
        let intensity_channel =
            crate::flags::selector("--intensity-channel", self.intensity_channel.as_deref())?;
        if let (Some(c), None) = (&intensity_channel, self.cutoff) {
            bail!("--intensity-channel {c} needs --cutoff X");
        }
        let pairing = self.pairing();
        let repeats = match (repeats, self.allow_duplicate_maps) {
            (Repeats::Warn, true) => bail!(
                "--allow-duplicate-maps: this command keeps a map given twice with a warning already; the flag applies to segment and stats"
            ),
            (_, true) => Repeats::Warn,
            (r, false) => r,
        };
        let files = expand(flag, maps, None, &pairing, repeats)?;
        let sources: Vec<MapSource> = pair(&files, &pairing)?
            .into_iter()
            .map(|s| s.with_channels(channel.clone(), intensity_channel.clone()))
            .collect();
        self.stack.refuse_without_stacks(&sources)?;
        check_duplicates(flag, &sources, repeats, "give --allow-duplicate-maps")?;
        for s in &sources {
            match (&s.intensity, &s.intensity_channel, self.cutoff, s.kind) {
                (Some(i), _, None, _) => bail!(
                    "intensity map {} (of {}) needs --cutoff X",
                    i.display(),
                    s.height.display()
                ),
                (None, None, Some(c), SourceKind::Map) => bail!(
                    "--cutoff {c} needs --intensity FILE (once per map), --intensity-suffix or --intensity-channel: {} has no intensity map",
                    s.height.display()
                ),
                _ => {}
            }
        }
        for s in &sources {
            plan.input(flag, &s.height);
            if let Some(i) = &s.intensity {
                plan.input("--intensity", i);
            }
        }
        Ok(sources)
    }

    /// Reader, stack and cutoff options; errors name the flag.
    pub fn load_options(&self) -> anyhow::Result<LoadOptions> {
        let read = self.calibration.read_options()?;
        let (stack, peak) = self.stack.options(&read)?;
        Ok(LoadOptions {
            read,
            cutoff: self.cutoff,
            stack,
            peak,
        })
    }

    /// The JSON echo of the input flags.
    pub fn echo(&self, sources: &[MapSource]) -> serde_json::Value {
        serde_json::json!({
            "maps": sources.iter().map(|s| s.height.display().to_string()).collect::<Vec<_>>(),
            "intensity": sources.iter().map(|s| s.intensity.as_ref().map(|p| p.display().to_string())).collect::<Vec<_>>(),
            "intensity_suffix": self.intensity_suffix,
            "height_suffix": self.intensity_suffix.as_ref().map(|_| &self.height_suffix),
            "cutoff": self.cutoff,
            "channel": self.calibration.channel,
            "intensity_channel": self.intensity_channel,
            "allow_duplicate_maps": self.allow_duplicate_maps,
            "pixel_um": self.calibration.pixel_um,
            "z_unit": self.calibration.z_unit,
            "stacks": sources.iter().any(|s| s.kind == SourceKind::Stack).then(|| serde_json::json!({
                "peak": self.stack.peak,
                "min_signal": self.stack.min_signal,
                "z_step_um": self.stack.stack_z_step_um,
                "first_page": self.stack.first_page,
            })),
        })
    }
}

/// What to do with a map given twice.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Repeats {
    /// Refuse it (statistics: a map counted twice fakes independent evidence).
    Refuse,
    /// Keep it with a warning (the topographic model accumulates what it is given).
    Warn,
}

/// Refuses (or, with [`Repeats::Warn`], warns about) maps whose files are the same data:
/// a byte-identical copy or the same file by another name ([`flakescatter::distinct`]).
/// `allow_with` says how to allow them.
pub fn check_duplicates(
    flag: &str,
    sources: &[MapSource],
    repeats: Repeats,
    allow_with: &str,
) -> anyhow::Result<()> {
    let allowed = repeats == Repeats::Warn;
    let notes = flakescatter::distinct::check_distinct_maps(sources, allowed, allow_with)
        .map_err(|e| anyhow::anyhow!("{flag}: {e}"))?;
    for n in notes {
        crate::output::warn(&format!("{flag}: {n}"));
    }
    Ok(())
}

/// Checks an intensity cutoff: a finite number.
pub fn check_cutoff(cutoff: Option<f64>) -> anyhow::Result<()> {
    match cutoff {
        Some(c) if !c.is_finite() => bail!("--cutoff {c}: expected a finite number"),
        _ => Ok(()),
    }
}

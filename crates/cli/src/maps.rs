//! Reading the inputs of a command: height maps (several of them, from files,
//! directories or glob patterns) paired with their intensity maps, z-stacks wherever a
//! map is read, and the out-of-plane detector file. Errors name the file and the flag.
//!
//! **Which files are maps** (docs/cli.md "Several maps"): every `MAP` argument is a
//! file, a directory or a glob pattern (`maps/*.x3p`, quoted so that the shell leaves
//! it alone). A directory stands for its files (not its subdirectories) with a map or
//! stack extension (`.x3p`, `.sdf`, `.txt`, `.asc`, `.tif`, `.tiff`), in name order,
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

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use flakescatter::confocal::{PeakMethod, PeakOptions};
use flakescatter::inputs::{LoadError, LoadOptions, LoadedMap, MapSource, SourceKind, load_map};
use flakescatter::io::ReadOptions;
use flakescatter::io::stack::{PageOrder, StackOptions};

use crate::flags::MapArgs;
use crate::output::Plan;

/// Extensions of files taken from a directory as maps or stacks.
pub const MAP_EXTENSIONS: [&str; 6] = ["x3p", "sdf", "txt", "asc", "tif", "tiff"];

/// Largest number of maps one command reads.
pub const MAX_MAPS: usize = 100_000;

/// How z-stacks given as maps are localised (as `flakescatter stack`).
#[derive(Debug, Clone, clap::Args)]
pub struct StackInputArgs {
    /// Peak localisation of z-stacks given as maps: argmax, parabolic, gaussian or
    /// centroid (docs/physics.md §9).
    #[arg(long, value_name = "METHOD", default_value = "gaussian")]
    pub peak: String,
    /// Stack pixels whose brightest sample is below this (full scale 1) are invalid.
    #[arg(
        long = "min-signal",
        value_name = "X",
        default_value_t = 0.0,
        allow_negative_numbers = true
    )]
    pub min_signal: f64,
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
    /// Stack reading and peak options; errors name the flag.
    pub fn options(&self, read: &ReadOptions) -> anyhow::Result<(StackOptions, PeakOptions)> {
        let method = PeakMethod::from_name(&self.peak).with_context(|| {
            format!(
                "--peak {}: expected argmax, parabolic, gaussian or centroid",
                self.peak
            )
        })?;
        if !(self.min_signal.is_finite() && (0.0..=1.0).contains(&self.min_signal)) {
            bail!(
                "--min-signal {}: expected a finite level in [0, 1] (full scale 1)",
                self.min_signal
            );
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
                min_signal: self.min_signal,
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
    /// Intensity cutoff, in the intensity maps' own stored values (unit-less; full scale
    /// 1 for z-stacks).
    #[arg(long, value_name = "X", allow_negative_numbers = true)]
    pub cutoff: Option<f64>,
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
        let pairing = self.pairing();
        let files = expand(flag, maps, None, &pairing, repeats)?;
        let sources = pair(&files, &pairing)?;
        for s in &sources {
            match (&s.intensity, self.cutoff, s.kind) {
                (Some(i), None, _) => bail!(
                    "intensity map {} (of {}) needs --cutoff X",
                    i.display(),
                    s.height.display()
                ),
                (None, Some(c), SourceKind::Map) => bail!(
                    "--cutoff {c} needs --intensity FILE (once per map) or --intensity-suffix: {} has no intensity map",
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

/// Whether a path segment is a glob pattern.
fn is_pattern(s: &str) -> bool {
    s.contains(['*', '?', '['])
}

fn has_map_extension(p: &Path) -> bool {
    p.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| MAP_EXTENSIONS.contains(&e.to_ascii_lowercase().as_str()))
}

/// The file name of `p` without its extension (`a.height` for `a.height.x3p`).
fn stem_of(p: &Path) -> String {
    p.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// Expands files, directories and glob patterns into map files (module docs), each
/// relative to `base` when given and not absolute. `flag` names the argument in errors.
pub fn expand(
    flag: &str,
    items: &[PathBuf],
    base: Option<&Path>,
    pairing: &Pairing,
    repeats: Repeats,
) -> anyhow::Result<Vec<PathBuf>> {
    let mut out: Vec<PathBuf> = Vec::new();
    for item in items {
        let path = match base {
            Some(b) if item.is_relative() => b.join(item),
            _ => item.clone(),
        };
        let shown = path.display().to_string();
        if path.is_dir() {
            let mut found: Vec<PathBuf> = std::fs::read_dir(&path)
                .with_context(|| format!("{flag} {shown}: cannot list the directory"))?
                .filter_map(Result::ok)
                .map(|e| e.path())
                .filter(|p| p.is_file() && has_map_extension(p))
                .filter(|p| {
                    !p.file_name()
                        .is_some_and(|n| n.to_string_lossy().starts_with('.'))
                })
                .filter(|p| match pairing {
                    Pairing::Suffix { height, .. } if !height.is_empty() => {
                        stem_of(p).ends_with(height.as_str())
                    }
                    _ => true,
                })
                .collect();
            found.sort();
            if found.is_empty() {
                match pairing {
                    Pairing::Suffix { height, .. } => bail!(
                        "{flag} {shown}: the directory holds no map whose name ends in `{height}` before the extension ({})",
                        MAP_EXTENSIONS.join(", ")
                    ),
                    _ => bail!(
                        "{flag} {shown}: the directory holds no map file ({})",
                        MAP_EXTENSIONS.join(", ")
                    ),
                }
            }
            out.extend(found);
        } else if path.exists() {
            out.push(path);
        } else if is_pattern(&shown) {
            let mut found: Vec<PathBuf> = glob::glob(&shown)
                .with_context(|| format!("{flag} {shown}: not a valid pattern"))?
                .filter_map(Result::ok)
                .filter(|p| p.is_file())
                .collect();
            found.sort();
            if found.is_empty() {
                bail!("{flag} {shown}: the pattern matches no file");
            }
            out.extend(found);
        } else {
            bail!("{flag} {shown}: no such file or directory");
        }
        if out.len() > MAX_MAPS {
            bail!("{flag}: more than {MAX_MAPS} maps");
        }
    }
    for (k, p) in out.iter().enumerate() {
        let same = |q: &PathBuf| {
            q == p
                || matches!((std::fs::canonicalize(q), std::fs::canonicalize(p)), (Ok(a), Ok(b)) if a == b)
        };
        if let Some(q) = out[..k].iter().find(|q| same(q)) {
            match repeats {
                Repeats::Refuse => bail!(
                    "{flag}: {} is given twice (also as {}); each map may be counted once",
                    p.display(),
                    q.display()
                ),
                Repeats::Warn => crate::output::warn(&format!(
                    "{flag}: {} is given twice (also as {}); it is counted twice",
                    p.display(),
                    q.display()
                )),
            }
        }
    }
    Ok(out)
}

/// The intensity partner of `map` under the suffix rule (module docs).
pub fn partner(map: &Path, height: &str, intensity: &str) -> anyhow::Result<PathBuf> {
    let name = map
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let (stem, ext) = match map.extension() {
        Some(e) => (
            name[..name.len() - e.len() - 1].to_owned(),
            format!(".{}", e.to_string_lossy()),
        ),
        None => (name.clone(), String::new()),
    };
    let Some(at) = (!height.is_empty()).then(|| stem.rfind(height)).flatten() else {
        bail!(
            "{}: the name has no `{height}` before its extension, so --intensity-suffix {intensity} finds no partner (set --height-suffix, or give --intensity once per map)",
            map.display()
        );
    };
    let new = format!(
        "{}{intensity}{}{ext}",
        &stem[..at],
        &stem[at + height.len()..]
    );
    Ok(map.with_file_name(new))
}

/// Pairs map files with their intensity maps (module docs).
pub fn pair(files: &[PathBuf], pairing: &Pairing) -> anyhow::Result<Vec<MapSource>> {
    match pairing {
        Pairing::None => Ok(files.iter().map(|f| MapSource::new(f, None)).collect()),
        Pairing::Explicit(list) => {
            if let Some(stack) = files
                .iter()
                .find(|f| SourceKind::of(f) == SourceKind::Stack)
            {
                bail!(
                    "--intensity with the z-stack {}: a stack carries its own intensity; give --intensity only with height maps (or use --intensity-suffix, which skips stacks)",
                    stack.display()
                );
            }
            if list.len() != files.len() {
                bail!(
                    "--intensity given {} times for {} height maps: give one intensity map per height map, in the same order",
                    list.len(),
                    files.len()
                );
            }
            for i in list {
                if !i.is_file() {
                    bail!("--intensity {}: no such file", i.display());
                }
            }
            Ok(files
                .iter()
                .zip(list)
                .map(|(f, i)| MapSource::new(f, Some(i.clone())))
                .collect())
        }
        Pairing::Suffix { height, intensity } => files
            .iter()
            .map(|f| {
                if SourceKind::of(f) == SourceKind::Stack {
                    return Ok(MapSource::new(f, None));
                }
                let p = partner(f, height, intensity)?;
                if !p.is_file() {
                    bail!(
                        "{}: its intensity map {} (--intensity-suffix {intensity}) does not exist",
                        f.display(),
                        p.display()
                    );
                }
                Ok(MapSource::new(f, Some(p)))
            })
            .collect(),
    }
}

/// A map as read, with the file it came from.
pub struct Input {
    /// The files.
    pub source: MapSource,
    /// The map and how it was read.
    pub loaded: LoadedMap,
}

/// Reads every source (progress on stderr for stacks when it is a terminal); errors
/// name the file.
pub fn load_all(sources: &[MapSource], options: &LoadOptions) -> anyhow::Result<Vec<Input>> {
    use std::io::IsTerminal;
    let mut out = Vec::with_capacity(sources.len());
    for s in sources {
        let bar = (s.kind == SourceKind::Stack && std::io::stderr().is_terminal()).then(|| {
            let b = indicatif::ProgressBar::new(0);
            b.set_style(
                indicatif::ProgressStyle::with_template(
                    "localising {msg} {bar:40} {pos}/{len} slices",
                )
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
            );
            b.set_message(s.height.display().to_string());
            b
        });
        let progress = |done: u64, total: u64| {
            if let Some(b) = &bar {
                b.set_length(total);
                b.set_position(done);
            }
        };
        let loaded = load_map(s, options, &progress).map_err(|e| match e {
            LoadError::Cutoff {
                map,
                intensity,
                cutoff,
                source,
            } => anyhow::anyhow!(
                "{} with intensity {intensity} and --cutoff {cutoff}: {source}",
                map.display()
            ),
            e => anyhow::Error::from(e),
        })?;
        if let Some(b) = &bar {
            b.finish_and_clear();
        }
        out.push(Input {
            source: s.clone(),
            loaded,
        });
    }
    Ok(out)
}

/// Checks an intensity cutoff: a finite number.
pub fn check_cutoff(cutoff: Option<f64>) -> anyhow::Result<()> {
    match cutoff {
        Some(c) if !c.is_finite() => bail!("--cutoff {c}: expected a finite number"),
        _ => Ok(()),
    }
}

/// Reads out-of-plane detectors (io's detector reader: CSV with header
/// `theta_r_deg, phi_r_deg`, degrees, ranges checked); returns `(θr, φr)` in radians.
pub fn read_detectors(path: &Path) -> anyhow::Result<Vec<(f64, f64)>> {
    Ok(flakescatter::io::detectors::read_detectors(path)
        .with_context(|| format!("--detectors {}", path.display()))?
        .into_iter()
        .map(|d| (d.theta_r, d.phi_r))
        .collect())
}

//! The maps of a sample as files: a height map with its intensity partner (a second
//! file, or an intensity channel of the same file), or a confocal z-stack (which
//! carries its own intensity), read through [`crate::io`] and [`crate::stack`] and
//! masked by the intensity cutoff.
//!
//! Conventions: heights and pitches in µm as the readers return them; a stack's height
//! map is µm above its lowest slice and its intensity the brightest sample (full scale
//! 1 for integer stacks). The cutoff is in the intensity's own stored values.

pub mod distinct;

use std::path::{Path, PathBuf};

use flakescatter_confocal::{PeakOptions, PeakReport};
use flakescatter_io::stack::{StackInfo, StackOptions};
use flakescatter_io::{
    Channel, ChannelSelector, ReadMapError, ReadOptions, read_intensity, read_selected,
};
use flakescatter_stats::heightmap::{HeightMap, HeightMapError};
use thiserror::Error;

use crate::stack::{StackPipelineError, localise_stack};

/// What kind of file a map is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SourceKind {
    /// A height map (X3P, SDF or plain text, recognised from its content).
    Map,
    /// A confocal z-stack (multi-page TIFF), localised into a height and an intensity
    /// map.
    Stack,
}

impl SourceKind {
    /// [`SourceKind::Stack`] for a `.tif`/`.tiff` file name (any case), else
    /// [`SourceKind::Map`].
    #[must_use]
    pub fn of(path: &Path) -> Self {
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref()
        {
            Some("tif" | "tiff") => Self::Stack,
            _ => Self::Map,
        }
    }
}

/// One map of a sample as files.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MapSource {
    /// The height map or stack file.
    pub height: PathBuf,
    /// Its intensity map (height maps only).
    pub intensity: Option<PathBuf>,
    /// Height map or stack (from the file name, [`SourceKind::of`]).
    pub kind: SourceKind,
    /// Which channel of the height map file holds the heights (index or name, resolved
    /// against the file's channels when it is read); `None`: `ReadOptions::channel`,
    /// else the first. Height maps only.
    pub channel: Option<ChannelSelector>,
    /// An intensity channel of the height map file itself, used as its intensity map
    /// (instead of a partner file: giving both is an error). Height maps only.
    pub intensity_channel: Option<ChannelSelector>,
}

impl MapSource {
    /// A source for `height` (kind from its name) with an optional intensity partner.
    #[must_use]
    pub fn new(height: impl Into<PathBuf>, intensity: Option<PathBuf>) -> Self {
        let height = height.into();
        let kind = SourceKind::of(&height);
        Self {
            height,
            intensity,
            kind,
            channel: None,
            intensity_channel: None,
        }
    }

    /// The same source with its height channel and intensity channel chosen.
    #[must_use]
    pub fn with_channels(
        mut self,
        channel: Option<ChannelSelector>,
        intensity_channel: Option<ChannelSelector>,
    ) -> Self {
        self.channel = channel;
        self.intensity_channel = intensity_channel;
        self
    }
}

/// How maps are read.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LoadOptions {
    /// Reader options of height and intensity maps (pitch override, z unit, ...).
    pub read: ReadOptions,
    /// Intensity cutoff: pixels whose intensity is below it are masked (`None`: no
    /// mask; needs an intensity partner or a stack).
    pub cutoff: Option<f64>,
    /// Stack reading options (voxel size overrides, page order).
    pub stack: StackOptions,
    /// Peak localisation of stacks.
    pub peak: PeakOptions,
}

/// A stack's description and what its localisation did.
#[derive(Debug, Clone, PartialEq)]
pub struct StackSummary {
    /// Size, sample type, voxel sizes, page order and their sources.
    pub info: StackInfo,
    /// Valid and invalid pixels and why.
    pub report: PeakReport,
    /// The localiser options used.
    pub peak: PeakOptions,
    /// The background threshold used and how it was chosen.
    pub threshold: flakescatter_confocal::SignalThreshold,
}

/// A map as read, masked by its intensity cutoff.
#[derive(Debug, Clone, PartialEq)]
pub struct LoadedMap {
    /// The height map, µm, invalid where the file has no value or the intensity is
    /// below the cutoff.
    pub map: HeightMap,
    /// Format name (`x3p`, `sdf`, `text`, `gwy`, `plu`, ..., as `MapFormat::name`) or
    /// `stack (<convention>)`.
    pub format: String,
    /// Valid points before the cutoff.
    pub valid_before_cutoff: usize,
    /// For a stack, what it was and how it was localised.
    pub stack: Option<StackSummary>,
    /// The channels of the map file (name, unit, size, pitch), in the order
    /// `ReadOptions::channel` counts them; empty for a stack.
    pub channels: Vec<Channel>,
    /// The index (in `channels`) of the height channel read; `None` for a stack.
    pub channel: Option<usize>,
    /// The index of the intensity channel of the same file used as the intensity map,
    /// if one was.
    pub intensity_channel: Option<usize>,
}

/// Why a map could not be read.
#[derive(Debug, Error)]
pub enum LoadError {
    /// The height map file (names it).
    #[error(transparent)]
    Height(Box<ReadMapError>),
    /// The intensity partner of a height map.
    #[error("intensity map of {}: {source}", map.display())]
    Intensity {
        /// The height map.
        map: PathBuf,
        /// What went wrong reading the intensity map (names it).
        source: Box<ReadMapError>,
    },
    /// The cutoff could not be applied (e.g. maps of different sizes or pitches).
    #[error("{} with intensity {intensity} and cutoff {cutoff}: {source}", map.display())]
    Cutoff {
        /// The height map or stack.
        map: PathBuf,
        /// The intensity map (or `its own intensity` for a stack).
        intensity: String,
        /// The cutoff.
        cutoff: f64,
        /// What the height map said.
        source: HeightMapError,
    },
    /// A cutoff is asked for a height map without an intensity partner.
    #[error("{}: a cutoff of {cutoff} is asked but the map has no intensity map (or intensity channel) to apply it to", map.display())]
    NoIntensity {
        /// The height map.
        map: PathBuf,
        /// The cutoff.
        cutoff: f64,
    },
    /// The intensity map given is the height map itself (the same path, the same file
    /// through a symbolic or hard link or `..`, or a byte-identical copy): a map cannot
    /// mask itself.
    #[error("{}: the intensity map {} is {}; give the intensity image of the same area (a second file, or an intensity channel of this file)", map.display(), intensity.display(), match why { distinct::Sameness::SameFile if map == intensity => "the height map file itself".to_string(), distinct::Sameness::SameFile => "the height map file itself (the same file by another name)".to_string(), distinct::Sameness::SameContent(h) => format!("a byte-identical copy of the height map (SHA-256 {h})") })]
    OwnIntensity {
        /// The height map.
        map: PathBuf,
        /// The intensity map given.
        intensity: PathBuf,
        /// How it is the same.
        why: distinct::Sameness,
    },
    /// An intensity map is given without a cutoff to apply.
    #[error("{}: the intensity map {} is given but no cutoff to apply it with", map.display(), intensity.display())]
    NoCutoff {
        /// The height map.
        map: PathBuf,
        /// The intensity map.
        intensity: PathBuf,
    },
    /// An intensity channel of the map file is given without a cutoff to apply.
    #[error("{}: the intensity channel {channel} is given but no cutoff to apply it with", map.display())]
    ChannelWithoutCutoff {
        /// The height map.
        map: PathBuf,
        /// The intensity channel.
        channel: ChannelSelector,
    },
    /// Both a partner file and an intensity channel are given for one map.
    #[error("{}: both the intensity map {} and the intensity channel {channel} of the same file are given; give one of them", map.display(), intensity.display())]
    TwoIntensities {
        /// The height map.
        map: PathBuf,
        /// The partner file.
        intensity: PathBuf,
        /// The intensity channel.
        channel: ChannelSelector,
    },
    /// A channel was chosen for a z-stack, which has none.
    #[error("{}: a z-stack has no channels to choose ({what} {channel} was given); it carries its own height and intensity", stack.display())]
    StackChannel {
        /// The stack.
        stack: PathBuf,
        /// `channel` or `intensity channel`.
        what: &'static str,
        /// The channel given.
        channel: ChannelSelector,
    },
    /// An intensity map was paired with a stack, which carries its own.
    #[error("{}: a z-stack carries its own intensity; the intensity map {} cannot be paired with it", stack.display(), intensity.display())]
    StackWithIntensity {
        /// The stack.
        stack: PathBuf,
        /// The intensity map given.
        intensity: PathBuf,
    },
    /// The stack could not be read or localised (names the file).
    #[error(transparent)]
    Stack(Box<StackPipelineError>),
}

/// Reads `source` and masks it with the intensity cutoff; `progress(done, total)` is
/// called after each slice of a stack.
///
/// # Errors
/// [`LoadError`] naming the file (and its partner) and what is wrong.
pub fn load_map(
    source: &MapSource,
    options: &LoadOptions,
    progress: &dyn Fn(u64, u64),
) -> Result<LoadedMap, LoadError> {
    match source.kind {
        SourceKind::Stack => load_stack(source, options, progress),
        SourceKind::Map => load_height_map(source, options),
    }
}

/// A z-stack localised into a height map, masked with its own intensity.
fn load_stack(
    source: &MapSource,
    options: &LoadOptions,
    progress: &dyn Fn(u64, u64),
) -> Result<LoadedMap, LoadError> {
    let path = &source.height;
    for (what, c) in [
        ("channel", &source.channel),
        ("intensity channel", &source.intensity_channel),
    ] {
        if let Some(c) = c {
            return Err(LoadError::StackChannel {
                stack: path.clone(),
                what,
                channel: c.clone(),
            });
        }
    }
    if let Some(i) = &source.intensity {
        return Err(LoadError::StackWithIntensity {
            stack: path.clone(),
            intensity: i.clone(),
        });
    }
    let maps = localise_stack(path, &options.stack, &options.peak, progress)
        .map_err(|e| LoadError::Stack(Box::new(e)))?;
    let mut map = maps.height;
    let valid_before_cutoff = map.valid_count();
    if let Some(cutoff) = options.cutoff {
        map.apply_intensity_cutoff(&maps.intensity, cutoff)
            .map_err(cutoff_error(path, "its own intensity", cutoff))?;
    }
    Ok(LoadedMap {
        map,
        format: format!("stack ({})", maps.info.format.name()),
        valid_before_cutoff,
        stack: Some(StackSummary {
            info: maps.info,
            report: maps.report,
            peak: maps.peak,
            threshold: maps.threshold,
        }),
        channels: Vec::new(),
        channel: None,
        intensity_channel: None,
    })
}

/// A height map masked with the intensity of its partner file or of one of its own
/// channels.
fn load_height_map(source: &MapSource, options: &LoadOptions) -> Result<LoadedMap, LoadError> {
    let path = &source.height;
    if let (Some(i), Some(c)) = (&source.intensity, &source.intensity_channel) {
        return Err(LoadError::TwoIntensities {
            map: path.clone(),
            intensity: i.clone(),
            channel: c.clone(),
        });
    }
    if let Some(i) = &source.intensity
        && let Some(why) = distinct::same_data(path, i)
    {
        return Err(LoadError::OwnIntensity {
            map: path.clone(),
            intensity: i.clone(),
            why,
        });
    }
    if let (Some(c), None) = (&source.intensity_channel, options.cutoff) {
        return Err(LoadError::ChannelWithoutCutoff {
            map: path.clone(),
            channel: c.clone(),
        });
    }
    // A partner intensity file is read first and kept only as its keep-mask (one
    // byte per point), so that the intensities and the heights are never held
    // together; its errors are reported after the height file's own.
    let partner_mask = match (&source.intensity, &source.intensity_channel, options.cutoff) {
        (Some(ipath), None, Some(cutoff)) => {
            // The channel choice is the height map's; the partner file's first.
            // An intensity is expected of it, whatever the map is read as.
            let partner = ReadOptions {
                channel: None,
                as_stored: false,
                ..options.read
            };
            Some(
                read_intensity(ipath, &partner)
                    .map_err(|source| LoadError::Intensity {
                        map: path.clone(),
                        source: Box::new(source),
                    })
                    .and_then(|(intensity, _)| {
                        intensity.intensity_mask(cutoff).map_err(cutoff_error(
                            path,
                            ipath.display().to_string(),
                            cutoff,
                        ))
                    }),
            )
        }
        _ => None,
    };
    let read = read_selected(
        path,
        &options.read,
        source.channel.as_ref(),
        source.intensity_channel.as_ref(),
    )
    .map_err(|e| LoadError::Height(Box::new(e)))?;
    let mut map = read.map;
    let valid_before_cutoff = map.valid_count();
    match (&source.intensity, &read.intensity, options.cutoff) {
        (_, Some((mask, i)), Some(cutoff)) => {
            let c = &read.channels[*i];
            let what = format!("channel {i} ({}) of the same file", c.name);
            map.apply_intensity_cutoff(mask, cutoff)
                .map_err(cutoff_error(path, what, cutoff))?;
        }
        (Some(ipath), None, Some(cutoff)) => {
            // Read above for this very case (a partner file and a cutoff).
            let keep = partner_mask.ok_or_else(|| LoadError::NoIntensity {
                map: path.clone(),
                cutoff,
            })??;
            map.apply_intensity_mask(&keep).map_err(cutoff_error(
                path,
                ipath.display().to_string(),
                cutoff,
            ))?;
        }
        (None, None, Some(cutoff)) => {
            return Err(LoadError::NoIntensity {
                map: path.clone(),
                cutoff,
            });
        }
        (Some(ipath), _, None) => {
            return Err(LoadError::NoCutoff {
                map: path.clone(),
                intensity: ipath.clone(),
            });
        }
        (None, _, None) => {}
    }
    Ok(LoadedMap {
        map,
        format: read.format.name().to_owned(),
        valid_before_cutoff,
        stack: None,
        channels: read.channels,
        channel: Some(read.channel),
        intensity_channel: read.intensity.map(|(_, i)| i),
    })
}

/// The error of an intensity cutoff on the map `map`, the intensity described by
/// `intensity` (a file, a channel of the same file, a stack's own).
fn cutoff_error(
    map: &Path,
    intensity: impl Into<String>,
    cutoff: f64,
) -> impl FnOnce(HeightMapError) -> LoadError {
    let (map, intensity) = (map.to_path_buf(), intensity.into());
    move |source| LoadError::Cutoff {
        map,
        intensity,
        cutoff,
        source,
    }
}

/// Short names of maps for output files and tables' captions: the file name without
/// its extension and without a trailing `.height` (`synth-a.height.x3p` → `synth-a`),
/// `-2`, `-3`, … appended to repeats in order, and every character other than letters,
/// digits, `-`, `_` and `.` replaced by `_`.
#[must_use]
pub fn short_names(sources: &[MapSource]) -> Vec<String> {
    let mut out: Vec<String> = Vec::with_capacity(sources.len());
    for s in sources {
        let stem = s
            .height
            .file_stem()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let stem = stem.strip_suffix(".height").unwrap_or(&stem);
        let mut base: String = stem
            .chars()
            .map(|c| {
                if c.is_alphanumeric() || matches!(c, '-' | '_' | '.') {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        if base.is_empty() || base.starts_with('.') {
            base.insert(0, 'm');
        }
        let mut name = base.clone();
        let mut k = 2;
        while out.contains(&name) {
            name = format!("{base}-{k}");
            k += 1;
        }
        out.push(name);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_names_are_unique_and_safe() {
        let s = |p: &str| MapSource::new(p, None);
        let names = short_names(&[
            s("a/synth.height.x3p"),
            s("b/synth.height.x3p"),
            s("c/my map#1.txt"),
            s("d/.hidden.x3p"),
            s("e/stack.tif"),
        ]);
        assert_eq!(names, ["synth", "synth-2", "my_map_1", "m.hidden", "stack"]);
        assert_eq!(s("e/stack.TIFF").kind, SourceKind::Stack);
        assert_eq!(s("e/map.x3p").kind, SourceKind::Map);
    }
}

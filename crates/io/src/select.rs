//! Choosing channels of a map file by index or by name, and reading a height channel
//! together with an intensity channel of the same file (issue 14: no second file is
//! needed when the instrument stored its intensity image beside the heights).
//!
//! A [`ChannelSelector`] is what a user writes: an all-digit value is a 0-based index in
//! the order [`crate::list_channels`] gives, anything else a name, matched exactly and
//! then, if no channel has exactly that name, ignoring case when that leaves one
//! channel. Resolving it against a file's channels ([`ChannelSelector::resolve`]) gives
//! the index that [`ReadOptions::channel`] takes, so the reader options stay `Copy`.
//!
//! [`read_selected`] reads the file once, lists its channels, resolves both selectors
//! and reads the height channel (as heights) and the intensity channel (values as
//! stored). Errors list every channel of the file: index, name, unit and size.

use std::fmt;
use std::path::Path;
use std::str::FromStr;

use flakescatter_stats::heightmap::HeightMap;
use thiserror::Error;

use crate::map::{MapError, MapFormat, ReadMapError, Source};
use crate::reader::{Channel, ReadOptions, ValueKind};

/// A channel chosen by its 0-based index or its name.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ChannelSelector {
    /// The index in the order of [`crate::list_channels`].
    Index(usize),
    /// The name, matched exactly, then ignoring case if that is unique.
    Name(String),
}

impl FromStr for ChannelSelector {
    type Err = ChannelError;

    /// An all-digit value (ASCII `0`–`9` only) is an index, anything else a name; an
    /// empty value (or only spaces) is refused.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let t = s.trim();
        if t.is_empty() {
            return Err(ChannelError::EmptyName);
        }
        if t.bytes().all(|b| b.is_ascii_digit()) {
            return t
                .parse()
                .map(ChannelSelector::Index)
                .map_err(|_| ChannelError::IndexTooLarge(t.to_string()));
        }
        Ok(ChannelSelector::Name(t.to_string()))
    }
}

impl fmt::Display for ChannelSelector {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ChannelSelector::Index(i) => write!(f, "{i}"),
            ChannelSelector::Name(n) => write!(f, "{n:?}"),
        }
    }
}

/// The channels of a file for messages: `0 = layer0 (µm, 768 x 576), 1 = image0 (a.u.,
/// 768 x 576)`.
#[must_use]
pub fn describe_channels(channels: &[Channel]) -> String {
    channels
        .iter()
        .enumerate()
        .map(|(i, c)| {
            format!(
                "{i} = {} ({}, {} x {})",
                c.name,
                c.unit.as_deref().unwrap_or("no unit"),
                c.nx,
                c.ny
            )
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// A channel choice that the file cannot satisfy.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ChannelError {
    /// The value was empty.
    #[error("an empty channel was given: expected a 0-based index or a channel name")]
    EmptyName,
    /// All digits, but too large for an index.
    #[error("channel {0}: the index is too large")]
    IndexTooLarge(String),
    /// The index is past the file's last channel.
    #[error(
        "channel {requested} was asked for, but the file has {} channel(s): {}",
        available.len(),
        describe_channels(available)
    )]
    NoSuchIndex {
        /// The 0-based index asked for.
        requested: usize,
        /// The channels present.
        available: Vec<Channel>,
    },
    /// No channel has that name, exactly or ignoring case.
    #[error(
        "no channel is named {requested:?} (exactly or ignoring case); the file has {} channel(s): {}",
        available.len(),
        describe_channels(available)
    )]
    NoSuchName {
        /// The name asked for.
        requested: String,
        /// The channels present.
        available: Vec<Channel>,
    },
    /// Several channels have that name (exactly, or ignoring case when none matches
    /// exactly).
    #[error(
        "channel name {requested:?} matches channels {} of the file; give the index instead. The file has {} channel(s): {}",
        matches.iter().map(ToString::to_string).collect::<Vec<_>>().join(" and "),
        available.len(),
        describe_channels(available)
    )]
    Ambiguous {
        /// The name asked for.
        requested: String,
        /// The indices it matches.
        matches: Vec<usize>,
        /// The channels present.
        available: Vec<Channel>,
    },
    /// The intensity channel is the height channel itself.
    #[error(
        "the intensity channel {index} ({name}) is the height channel itself; choose another channel of the file: {}",
        describe_channels(available)
    )]
    SameAsHeight {
        /// Its index.
        index: usize,
        /// Its name.
        name: String,
        /// The channels present.
        available: Vec<Channel>,
    },
}

impl ChannelSelector {
    /// The index of the channel this selector names among `channels` (module docs).
    ///
    /// # Errors
    /// [`ChannelError`] listing the channels when none matches or a name matches
    /// several.
    pub fn resolve(&self, channels: &[Channel]) -> Result<usize, ChannelError> {
        match self {
            ChannelSelector::Index(i) if *i < channels.len() => Ok(*i),
            ChannelSelector::Index(i) => Err(ChannelError::NoSuchIndex {
                requested: *i,
                available: channels.to_vec(),
            }),
            ChannelSelector::Name(name) => {
                let find = |same: &dyn Fn(&str) -> bool| -> Vec<usize> {
                    channels
                        .iter()
                        .enumerate()
                        .filter(|(_, c)| same(&c.name))
                        .map(|(i, _)| i)
                        .collect()
                };
                let mut hits = find(&|n| n == name);
                if hits.is_empty() {
                    let lower = name.to_lowercase();
                    hits = find(&|n| n.to_lowercase() == lower);
                }
                match hits.as_slice() {
                    [i] => Ok(*i),
                    [] => Err(ChannelError::NoSuchName {
                        requested: name.clone(),
                        available: channels.to_vec(),
                    }),
                    _ => Err(ChannelError::Ambiguous {
                        requested: name.clone(),
                        matches: hits,
                        available: channels.to_vec(),
                    }),
                }
            }
        }
    }
}

/// A height channel and, if asked, an intensity channel of the same file.
#[derive(Debug, Clone, PartialEq)]
pub struct SelectedRead {
    /// The height map (µm), as [`crate::read_map`] returns it.
    pub map: HeightMap,
    /// The file's format.
    pub format: MapFormat,
    /// Every channel of the file, in index order.
    pub channels: Vec<Channel>,
    /// The index of the height channel read.
    pub channel: usize,
    /// The intensity channel read (values as stored, unit-less) and its index.
    pub intensity: Option<(HeightMap, usize)>,
}

/// Reads the height channel `channel` (default: `options.channel`, else the first) and,
/// if `intensity` is given, that channel of the same bytes as an intensity map;
/// `extension` as in [`read_bytes`](crate::map::read_bytes).
///
/// # Errors
/// [`MapError::Channel`] when a selector matches no channel, several, or the intensity
/// channel is the height channel; otherwise as [`read_bytes`](crate::map::read_bytes).
pub fn read_selected_bytes(
    bytes: &[u8],
    extension: Option<&str>,
    options: &ReadOptions,
    channel: Option<&ChannelSelector>,
    intensity: Option<&ChannelSelector>,
) -> Result<SelectedRead, MapError> {
    read_selected_from(
        &mut Source::Bytes { bytes, extension },
        options,
        channel,
        intensity,
    )
}

/// [`read_selected_bytes`] of a [`Source`].
fn read_selected_from(
    source: &mut Source<'_>,
    options: &ReadOptions,
    channel: Option<&ChannelSelector>,
    intensity: Option<&ChannelSelector>,
) -> Result<SelectedRead, MapError> {
    let (channels, _) = source.channels(options)?;
    let index = match channel {
        Some(s) => s.resolve(&channels)?,
        None => ChannelSelector::Index(options.channel.unwrap_or(0)).resolve(&channels)?,
    };
    // Index 0 is every reader's default: passing none spares the readers a second
    // listing of the channels (the index is checked above).
    let with = |i: usize| ReadOptions {
        channel: (i != 0).then_some(i),
        ..*options
    };
    let (map, format) = source.read(&with(index), ValueKind::Height)?;
    let intensity = match intensity {
        None => None,
        Some(s) => {
            let i = s.resolve(&channels)?;
            if i == index {
                return Err(MapError::Channel(ChannelError::SameAsHeight {
                    index: i,
                    name: channels[i].name.clone(),
                    available: channels,
                }));
            }
            // An intensity is expected of this channel, whatever the map is read as.
            let as_intensity = ReadOptions {
                as_stored: false,
                ..with(i)
            };
            let (m, _) = source.read(&as_intensity, ValueKind::Intensity)?;
            Some((m, i))
        }
    };
    Ok(SelectedRead {
        map,
        format,
        channels,
        channel: index,
        intensity,
    })
}

/// Reads a map file as [`read_selected_bytes`] does (the file is read once; a large X3P
/// file is read as it is inflated, never held whole).
///
/// # Errors
/// [`ReadMapError::Io`] if the file cannot be read, [`ReadMapError::Format`] naming the
/// file and the problem otherwise.
pub fn read_selected(
    path: impl AsRef<Path>,
    options: &ReadOptions,
    channel: Option<&ChannelSelector>,
    intensity: Option<&ChannelSelector>,
) -> Result<SelectedRead, ReadMapError> {
    let path = path.as_ref();
    let mut buf = Vec::new();
    let mut source = Source::open(path, &mut buf).map_err(|source| ReadMapError::Io {
        path: path.to_path_buf(),
        source: crate::files::explain_open_error(path, source),
    })?;
    read_selected_from(&mut source, options, channel, intensity).map_err(|error| {
        ReadMapError::Format {
            path: path.to_path_buf(),
            error,
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ch(name: &str) -> Channel {
        Channel {
            name: name.into(),
            unit: Some("a.u.".into()),
            nx: 3,
            ny: 2,
            pitch_um: None,
        }
    }

    #[test]
    fn digits_are_indices_and_anything_else_a_name() {
        assert_eq!("2".parse(), Ok(ChannelSelector::Index(2)));
        assert_eq!(" 07 ".parse(), Ok(ChannelSelector::Index(7)));
        assert_eq!("-1".parse(), Ok(ChannelSelector::Name("-1".into())));
        assert_eq!("layer0".parse(), Ok(ChannelSelector::Name("layer0".into())));
        assert_eq!("".parse::<ChannelSelector>(), Err(ChannelError::EmptyName));
        assert!(matches!(
            "99999999999999999999999".parse::<ChannelSelector>(),
            Err(ChannelError::IndexTooLarge(_))
        ));
    }

    #[test]
    fn names_match_exactly_then_ignoring_case_when_unique() {
        let all = [ch("Height"), ch("height"), ch("Intensity")];
        let name = |n: &str| ChannelSelector::Name(n.into());
        // Exact wins over the case-insensitive match of the other one.
        assert_eq!(name("height").resolve(&all), Ok(1));
        assert_eq!(name("Height").resolve(&all), Ok(0));
        assert_eq!(name("INTENSITY").resolve(&all), Ok(2));
        match name("HEIGHT").resolve(&all) {
            Err(ChannelError::Ambiguous { matches, .. }) => assert_eq!(matches, [0, 1]),
            other => panic!("{other:?}"),
        }
        let e = name("phase").resolve(&all).unwrap_err();
        assert_eq!(
            e.to_string(),
            "no channel is named \"phase\" (exactly or ignoring case); the file has 3 channel(s): \
             0 = Height (a.u., 3 x 2), 1 = height (a.u., 3 x 2), 2 = Intensity (a.u., 3 x 2)"
        );
        assert!(matches!(
            ChannelSelector::Index(3).resolve(&all),
            Err(ChannelError::NoSuchIndex { requested: 3, .. })
        ));
    }
}

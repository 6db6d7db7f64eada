//! Choosing channels of a map file by index or by name, and reading a height channel
//! together with an intensity channel of the same file (issue 14: no second file is
//! needed when the instrument stored its intensity image beside the heights).
//!
//! The channels are chosen by [`ChannelSelector`]s ([`crate::channel`]).
//!
//! [`read_selected`] reads the file once, lists its channels, resolves both selectors
//! and reads the height channel (as heights) and the intensity channel (values as
//! stored). Errors list every channel of the file: index, name, unit and size.

use std::path::Path;

use flakescatter_stats::heightmap::HeightMap;

use crate::channel::{ChannelError, ChannelSelector};
use crate::map::{MapError, MapFormat, ReadMapError, Source};
use crate::reader::{Channel, ReadOptions, ValueKind};

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
    let mut source = Source::open_path(path, &mut buf)?;
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

//! Choosing a channel of a map file by index or by name.
//!
//! A [`ChannelSelector`] is what a user writes: an all-digit value is a 0-based index in
//! the order [`crate::list_channels`] gives, anything else a name, matched exactly and
//! then, if no channel has exactly that name, ignoring case when that leaves one
//! channel. Resolving it against a file's channels ([`ChannelSelector::resolve`]) gives
//! the index that [`crate::ReadOptions::channel`] takes, so the reader options stay
//! `Copy`. Errors list every channel of the file: index, name, unit and size.

use std::fmt;
use std::str::FromStr;

use thiserror::Error;

use crate::reader::Channel;

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

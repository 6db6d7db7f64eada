//! The one error type of the binary instrument readers (GWY, AL3D, SUR, OPD, MetroPro,
//! PLU, FRT): what is wrong with a file's bytes, named by byte offset, header field,
//! block, tag or channel. Each reader's own name for it (`GwyError`, …) is an alias,
//! and `map::MapError` says which format it came from.

use flakescatter_stats::heightmap::HeightMapError;
use thiserror::Error;

/// A block of a file: a numbered block (written `0x0066`) or a named one (written
/// quoted, `"Directory"`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum BlockId {
    /// A block by number.
    Number(u16),
    /// A block by name.
    Name(String),
}

impl std::fmt::Display for BlockId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Number(n) => write!(f, "0x{n:04x}"),
            Self::Name(s) => write!(f, "{s:?}"),
        }
    }
}

impl From<u16> for BlockId {
    fn from(n: u16) -> Self {
        Self::Number(n)
    }
}

impl From<String> for BlockId {
    fn from(s: String) -> Self {
        Self::Name(s)
    }
}

impl From<&str> for BlockId {
    fn from(s: &str) -> Self {
        Self::Name(s.to_owned())
    }
}

/// What is wrong with an instrument file's bytes.
#[derive(Debug, Error)]
pub enum FormatError {
    /// The file ends before a structure it declares.
    #[error(
        "file is truncated: {what} at byte {offset} needs {needed} bytes, the file ends at byte {end}"
    )]
    Truncated {
        /// What was being read.
        what: String,
        /// Where it starts.
        offset: usize,
        /// Bytes it needs.
        needed: u64,
        /// Length of the file.
        end: usize,
    },
    /// A header field holds a value the format does not allow.
    #[error("header field {field} (byte {offset}) = {value}: expected {expected}")]
    Field {
        /// The field's name.
        field: &'static str,
        /// Its byte offset.
        offset: usize,
        /// The value read.
        value: String,
        /// What the format allows.
        expected: &'static str,
    },
    /// A header field of one object of a multi-object file (SUR).
    #[error("object {object}, header field {field} (byte {offset}) = {value}: expected {expected}")]
    ObjectField {
        /// The object's number, from 0.
        object: usize,
        /// The field's name.
        field: &'static str,
        /// Its byte offset.
        offset: usize,
        /// The value read.
        value: String,
        /// What the format allows.
        expected: &'static str,
    },
    /// A block is malformed.
    #[error("block {block} (byte {offset}): {what}")]
    Block {
        /// The block.
        block: BlockId,
        /// Its byte offset.
        offset: usize,
        /// What is wrong.
        what: String,
    },
    /// A block the data needs is missing.
    #[error("block {block} ({what}) is missing{hint}")]
    Missing {
        /// The block.
        block: BlockId,
        /// What it holds.
        what: &'static str,
        /// What the file may be instead (with a leading separator), or empty.
        hint: &'static str,
    },
    /// A structure at a byte offset is malformed.
    #[error("byte {offset}: {what}")]
    At {
        /// The byte offset.
        offset: usize,
        /// What is wrong.
        what: String,
    },
    /// The file holds no data of the kind read.
    #[error("{0}")]
    NoData(&'static str),
    /// A channel (named, quoted) is malformed or missing.
    #[error("channel {channel:?}: {what}")]
    Channel {
        /// The channel's name or index.
        channel: String,
        /// What is wrong.
        what: String,
    },
    /// A channel holds another kind of data than the one read.
    #[error("channel {channel} holds {what}")]
    ChannelHolds {
        /// The channel.
        channel: String,
        /// What it holds.
        what: &'static str,
    },
    /// A tag of the header is missing or malformed (AL3D).
    #[error("tag {tag}: {what}")]
    Tag {
        /// The tag.
        tag: String,
        /// What is wrong.
        what: String,
    },
    /// The map the file describes is not a valid height map.
    #[error("{0}")]
    Map(HeightMapError),
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The texts the seven readers' own enums wrote (their format strings, copied
    /// here before they were merged): the merge must not change a message.
    #[test]
    fn messages_are_the_readers_own() {
        let cases: Vec<(FormatError, &str)> = vec![
            (
                FormatError::Block {
                    block: 0x0066.into(),
                    offset: 12,
                    what: "too short".into(),
                },
                "block 0x0066 (byte 12): too short",
            ),
            (
                FormatError::Block {
                    block: "Directory".into(),
                    offset: 0,
                    what: "bad".into(),
                },
                "block \"Directory\" (byte 0): bad",
            ),
            (
                FormatError::Missing {
                    block: 0x000b.into(),
                    what: "image",
                    hint: ": not a MicroProf file",
                },
                "block 0x000b (image) is missing: not a MicroProf file",
            ),
            (
                FormatError::Channel {
                    channel: "Height".into(),
                    what: "no data".into(),
                },
                "channel \"Height\": no data",
            ),
            (
                FormatError::ChannelHolds {
                    channel: "2".into(),
                    what: "intensities",
                },
                "channel 2 holds intensities",
            ),
            (
                FormatError::ObjectField {
                    object: 1,
                    field: "n",
                    offset: 8,
                    value: "0".into(),
                    expected: "> 0",
                },
                "object 1, header field n (byte 8) = 0: expected > 0",
            ),
            (
                FormatError::NoData("the file holds no data field (no container key /N/data)"),
                "the file holds no data field (no container key /N/data)",
            ),
        ];
        for (e, want) in cases {
            assert_eq!(e.to_string(), want);
        }
    }
}

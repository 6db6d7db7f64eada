//! What can go wrong reading or writing an X3P file, and the I/O and zip errors of a
//! read mapped to it (a damaged archive, or the system's failure).

use flakescatter_stats::heightmap::HeightMapError;
use md5::{Digest, Md5};
use thiserror::Error;

/// What is wrong with an X3P file.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum X3pError {
    /// The zip container is unreadable (truncated, corrupt).
    #[error("not a readable zip archive, so not a usable X3P file: {0}")]
    Zip(String),
    /// Reading the archive failed part-way for a reason outside it (the system's I/O: a
    /// disk, network or permission error), not because of what it holds.
    #[error("reading {what} failed ({reason}); the file itself may be intact")]
    Read {
        /// What was being read: `member "bindata/data.bin"`, `the archive`, `the
        /// archive's length` or `the file's start (seeking back to it)`.
        what: String,
        /// The system's error.
        reason: String,
    },
    /// A required member is not in the archive.
    #[error("archive has no member {0:?}")]
    MissingMember(String),
    /// `main.xml` is not well-formed XML or has the wrong root.
    #[error("main.xml: {0}")]
    Xml(String),
    /// A required header element is missing.
    #[error("main.xml: missing element {0}")]
    MissingElement(String),
    /// A header element has a value that cannot be used.
    #[error("main.xml: element {element} = {value:?}: expected {expected}")]
    BadValue {
        /// The element path, e.g. `Record1/Axes/CZ/DataType`.
        element: String,
        /// The value found.
        value: String,
        /// What was expected.
        expected: String,
    },
    /// A binary member does not have the size the header implies.
    #[error("member {member:?} has {found} bytes, expected {expected} ({detail})")]
    DataLength {
        /// The member.
        member: String,
        /// Size implied by the header.
        expected: u64,
        /// Actual size.
        found: u64,
        /// How the expected size was computed.
        detail: String,
    },
    /// A member is too small (compressed) to hold what the header implies.
    #[error(
        "member {member:?} has {compressed} compressed bytes, which cannot inflate to the \
         {expected} bytes the header implies ({detail}): the header or the archive is corrupt"
    )]
    Implausible {
        /// The member.
        member: String,
        /// Size implied by the header.
        expected: u64,
        /// Its compressed size in the archive.
        compressed: u64,
        /// How the expected size was computed.
        detail: String,
    },
    /// A checksum does not match (and the mismatch was not accepted).
    #[error(
        "MD5 of {member:?} is {computed} but the file declares {declared}: the file may be \
         corrupt or edited after it was written (to read it anyway: option \
         accept_md5_mismatch, `--accept-md5-mismatch` on the command line)"
    )]
    Md5Mismatch {
        /// The member checked.
        member: String,
        /// MD5 computed from the member, lower-case hex.
        computed: String,
        /// MD5 declared in the file.
        declared: String,
    },
    /// No checksum is declared for a member that needs one (and that was not accepted).
    #[error(
        "no MD5 checksum for {member:?} ({where_}); ISO 25178-72 requires one (to read the \
         file anyway: option accept_md5_mismatch, `--accept-md5-mismatch` on the command line)"
    )]
    MissingChecksum {
        /// The member without a checksum.
        member: String,
        /// Where the checksum should have been.
        where_: String,
    },
    /// The header's numbers do not make a valid height map.
    #[error("{0}")]
    Map(HeightMapError),
}

/// The zip container of an X3P file could not be assembled in memory.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("cannot build X3P archive: {0}")]
pub struct ArchiveError(pub(super) String);

pub(super) fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

pub(super) fn md5_hex(bytes: &[u8]) -> String {
    hex(&Md5::digest(bytes))
}

/// The error of a failed read of `what` (`member "…"` or `the archive`): a damaged
/// archive (a corrupt deflate stream, a wrong CRC-32, a truncated file: the I/O error
/// kinds `InvalidData`, `InvalidInput` and `UnexpectedEof` that the zip crate and
/// flate2 give for them) is [`X3pError::Zip`]; any other failure is the system's,
/// [`X3pError::Read`].
pub(super) fn io_error(what: &str, e: &std::io::Error) -> X3pError {
    if is_system(e) {
        X3pError::Read {
            what: what.to_string(),
            reason: e.to_string(),
        }
    } else {
        X3pError::Zip(format!("{what}: {e}"))
    }
}

/// Whether an I/O error is the system's, not about the archive's content ([`io_error`]).
pub(super) fn is_system(e: &std::io::Error) -> bool {
    use std::io::ErrorKind::{InvalidData, InvalidInput, UnexpectedEof};
    !matches!(e.kind(), InvalidData | InvalidInput | UnexpectedEof)
}

/// [`io_error`] of a zip crate error: its I/O errors as there, the others (an invalid
/// or unsupported archive) [`X3pError::Zip`].
pub(super) fn zip_error(what: &str, e: &zip::result::ZipError) -> X3pError {
    match e {
        zip::result::ZipError::Io(io) => io_error(what, io),
        other => X3pError::Zip(format!("{what}: {other}")),
    }
}

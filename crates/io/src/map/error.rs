//! What can go wrong reading or writing a height map: inside the file, by format
//! ([`MapError`]), and with the file named ([`ReadMapError`], [`WriteMapError`]).

use std::path::PathBuf;

use flakescatter_stats::heightmap::HeightMapError;
use thiserror::Error;

use crate::al3d::Al3dError;
use crate::channel::ChannelError;
use crate::frt::FrtError;
use crate::gwy::GwyError;
use crate::metropro::MetroProError;
use crate::opd::OpdError;
use crate::plu::PluError;
use crate::reader::ValueKind;
use crate::sdf::SdfError;
use crate::sur::SurError;
use crate::text::TextError;
use crate::x3p::{ArchiveError, X3pError};
use crate::zarr::{ZarrError, ZarrProblem};

use super::format::MapFormat;

/// What went wrong inside a height-map file, by format.
#[derive(Debug, Error)]
pub enum MapError {
    /// An X3P problem.
    #[error("X3P: {0}")]
    X3p(X3pError),
    /// An SDF problem.
    #[error("SDF: {0}")]
    Sdf(SdfError),
    /// A plain-text matrix problem.
    #[error("text matrix: {0}")]
    Text(TextError),
    /// A Gwyddion GWY problem.
    #[error("GWY: {0}")]
    Gwy(GwyError),
    /// An Alicona AL3D problem.
    #[error("AL3D: {0}")]
    Al3d(Al3dError),
    /// A Digital Surf SUR problem.
    #[error("SUR: {0}")]
    Sur(SurError),
    /// A Wyko OPD problem.
    #[error("OPD: {0}")]
    Opd(OpdError),
    /// A Zygo MetroPro problem.
    #[error("MetroPro: {0}")]
    MetroPro(MetroProError),
    /// A Sensofar PLU problem.
    #[error("PLU: {0}")]
    Plu(PluError),
    /// An FRT MicroProf problem.
    #[error("FRT: {0}")]
    Frt(FrtError),
    /// A Zarr v3 store problem (the array or attribute named).
    #[error("Zarr v3 store: {0}")]
    Zarr(ZarrProblem),
    /// The pitch override is not usable.
    #[error("pixel pitch option: {0}")]
    Pitch(HeightMapError),
    /// The file has no bytes at all.
    #[error("the file is empty (0 bytes){}", match expected {
        Some(f) => format!(", so not {}", f.description()),
        None => String::new(),
    })]
    Empty {
        /// The format the file's extension names, if any.
        expected: Option<MapFormat>,
    },
    /// The content is no format this crate reads.
    #[error(
        "not a height-map format this crate reads (see MapFormat::ALL: X3P, SDF, plain text and the instrument formats): {content}"
    )]
    Unrecognised {
        /// What the content is.
        content: String,
    },
    /// The extension names one format and the content is not that format.
    #[error("the extension .{extension} says {}, but {reason}", format.description())]
    NotThisFormat {
        /// The file's extension.
        extension: String,
        /// The format it names.
        format: MapFormat,
        /// Why the content is not that format, and what it is instead.
        reason: String,
    },
    /// An option that only plain-text matrices use was given for a calibrated format.
    #[error(
        "option {option} applies to plain-text matrices only, and this is {}, {why}; leave it out",
        format.description()
    )]
    NotApplicable {
        /// The option, with its command-line flag.
        option: &'static str,
        /// The format of the file.
        format: MapFormat,
        /// Why the format does not need it.
        why: &'static str,
    },
    /// The channel asked for does not exist, or a name matches none or several
    /// (the message lists every channel: index, name, unit, size).
    #[error("{0}")]
    Channel(#[from] ChannelError),
    /// The file declares another quantity than the one asked for ([`crate::quantity`]):
    /// an intensity image where heights are expected, or the reverse.
    #[error(
        "the file holds {} ({}), not {}: {}",
        plural(declared.quantity), declared.by, plural(*wanted),
        match wanted {
            ValueKind::Height => "give it where an intensity image is expected (--intensity, \
                `maps.intensity`), or read it as it is with `convert` or `info`",
            ValueKind::Intensity => "an intensity image is expected here; give the height \
                map as the map itself",
        }
    )]
    Quantity {
        /// What the file declares, and where.
        declared: crate::quantity::Declared,
        /// What was asked for.
        wanted: ValueKind,
    },
    /// A height-only option was given for a file read as the intensities it declares.
    #[error(
        "option {option} applies to heights, and this file holds intensities ({by}); leave it out"
    )]
    HeightOption {
        /// The option, with its command-line flag.
        option: &'static str,
        /// Where the file says it holds intensities.
        by: String,
    },
}

/// `heights` or `intensities`.
fn plural(kind: ValueKind) -> &'static str {
    match kind {
        ValueKind::Height => "heights",
        ValueKind::Intensity => "intensities",
    }
}

/// Error from [`read_map`](super::read_map) and
/// [`read_intensity`](super::read_intensity): the file and what went wrong.
#[derive(Debug, Error)]
pub enum ReadMapError {
    /// The file could not be read at all.
    #[error("cannot read map {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating-system error.
        source: std::io::Error,
    },
    /// The file was read but its content is not a usable map (heights, or an
    /// intensity image where one is read).
    #[error("map {}: {error}", path.display())]
    Format {
        /// The file.
        path: PathBuf,
        /// The problem found in it.
        error: MapError,
    },
}

/// Error from the writers: the file and what went wrong.
#[derive(Debug, Error)]
pub enum WriteMapError {
    /// The file could not be written.
    #[error("cannot write map {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating-system error.
        source: std::io::Error,
    },
    /// The zip container could not be assembled.
    #[error("cannot write map {}: {source}", path.display())]
    Archive {
        /// The file.
        path: PathBuf,
        /// What the zip writer reported.
        source: ArchiveError,
    },
    /// The Zarr store could not be written (the store and what failed named).
    #[error("cannot write map {}: {}", .0.store.display(), .0.problem)]
    Zarr(ZarrError),
    /// The format cannot be written.
    #[error("cannot write map {}: writing {format} is not supported; use X3P, SDF, text or Zarr", path.display())]
    Unsupported {
        /// The file.
        path: PathBuf,
        /// The format asked for.
        format: MapFormat,
    },
}

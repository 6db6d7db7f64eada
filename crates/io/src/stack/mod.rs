//! Confocal z-stacks in multi-page TIFF: ImageJ/Fiji stacks, OME-TIFF and Zeiss LSM.
//!
//! A stack is one grey page per optical slice (8- or 16-bit unsigned, or 32-bit float),
//! all of one size and sample type. [`StackReader`] checks every page's directory first
//! (sizes, sample types, data within the file) and then decodes **one page at a time**:
//! memory is one page plus one `f32` slice, whatever the number of slices, so a
//! localiser can consume a 1.6 GB stack in a few hundred MB.
//!
//! Conventions:
//! * Slices come out as `f32`, row-major (`x` along columns), **scaled to full scale
//!   1**: 8-bit samples are divided by 255, 16-bit by 65535 (4095 for 12-bit LSM data),
//!   32-bit float samples are kept as stored. [`StackInfo::full_scale`] records the
//!   divisor.
//! * Lengths in µm, converted once here from the file's unit; [`Sourced`] says where each
//!   voxel size and the page order came from (file field, option, or the default).
//! * Page order: page 0 is the **lowest** slice (deepest in the coating) unless an option
//!   or the metadata says otherwise (OME-XML planes whose `PositionZ` decreases with
//!   `TheZ`).
//! * Reduced-resolution pages (`NewSubfileType` bit 0, e.g. the thumbnails that LSM files
//!   interleave with the slices) are skipped and counted.
//!
//! Voxel sizes, by format:
//! * **ImageJ** (`ImageDescription` starting `ImageJ=`): `spacing=` is the z step in
//!   `unit=` (or `zunit=`); the pixel size is `1 / XResolution` (`1 / YResolution`) in
//!   that unit. `unit=micron` is how ImageJ writes µm.
//! * **OME-TIFF** (OME-XML in the first `ImageDescription`, parsed with `roxmltree`):
//!   `Pixels` attributes `PhysicalSizeX/Y/Z` with `PhysicalSize*Unit` (default µm).
//! * **Zeiss LSM** (private tag 34412 `CZ_LSMINFO`): `VoxelSizeX/Y/Z` in metres.
//! * A plain TIFF carries no z step, and its resolution tags are usually a display
//!   resolution (72 dpi), not a calibration: both must be given as options.
//!
//! Rooms: this module (what a stack is: formats, sample types, options, the
//! [`StackInfo`] read), `error` (what can go wrong), `reader` (the TIFF directories
//! checked and the slices streamed, [`StackReader`]), `meta` (the metadata conventions),
//! `positions` (OME plane positions) and [`write`](mod@write).

mod error;
mod meta;
mod positions;
mod reader;
pub mod write;

use std::collections::BTreeMap;
use std::fmt;

pub use error::{ReadStackError, StackError};
pub use reader::StackReader;
pub use write::{ImageJStackWriter, StackLayout, WriteStackError};

/// Private TIFF tag of Zeiss LSM files holding the `CZ_LSMINFO` record.
pub const TAG_CZ_LSMINFO: u16 = 34412;

/// The largest number of TIFF directories (pages) read.
pub const MAX_PAGES: usize = 100_000;

/// The largest slice read, in pixels: 2²⁶ (8192 × 8192).
pub const MAX_SLICE_PIXELS: usize = 1 << 26;

/// Which metadata convention a stack follows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StackFormat {
    /// ImageJ / Fiji (`ImageDescription` starting `ImageJ=`).
    ImageJ,
    /// OME-TIFF (OME-XML in the first `ImageDescription`).
    OmeTiff,
    /// Zeiss LSM (tag 34412 `CZ_LSMINFO`).
    Lsm,
    /// A TIFF without any of these.
    PlainTiff,
}

impl StackFormat {
    /// Short name: `imagej`, `ome-tiff`, `lsm` or `tiff`.
    pub fn name(self) -> &'static str {
        match self {
            Self::ImageJ => "imagej",
            Self::OmeTiff => "ome-tiff",
            Self::Lsm => "lsm",
            Self::PlainTiff => "tiff",
        }
    }
}

impl fmt::Display for StackFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Sample type of the pages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SampleType {
    /// 8-bit unsigned integers.
    U8,
    /// 16-bit unsigned integers.
    U16,
    /// 32-bit IEEE floats.
    F32,
}

impl SampleType {
    /// `uint8`, `uint16` or `float32`.
    pub fn name(self) -> &'static str {
        match self {
            Self::U8 => "uint8",
            Self::U16 => "uint16",
            Self::F32 => "float32",
        }
    }

    /// Bytes per sample.
    pub fn bytes(self) -> usize {
        match self {
            Self::U8 => 1,
            Self::U16 => 2,
            Self::F32 => 4,
        }
    }
}

impl fmt::Display for SampleType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Which end of the stack page 0 is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PageOrder {
    /// Page 0 is the lowest slice (deepest in the coating).
    #[default]
    BottomFirst,
    /// Page 0 is the highest slice.
    TopFirst,
}

impl PageOrder {
    /// `bottom` or `top` (which slice page 0 is).
    pub fn name(self) -> &'static str {
        match self {
            Self::BottomFirst => "bottom",
            Self::TopFirst => "top",
        }
    }
}

/// Where a value came from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Source {
    /// A field of the file, described (e.g. `ImageJ spacing= (unit micron)`).
    File(String),
    /// An option given by the caller.
    Option,
    /// Neither file nor option: the documented default.
    Default,
}

impl fmt::Display for Source {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::File(what) => write!(f, "file: {what}"),
            Self::Option => f.write_str("option"),
            Self::Default => f.write_str("default"),
        }
    }
}

/// A value with its [`Source`].
#[derive(Debug, Clone, PartialEq)]
pub struct Sourced<T> {
    /// The value.
    pub value: T,
    /// Where it came from.
    pub source: Source,
}

/// Options for reading a stack. Every field overrides what the file says.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StackOptions {
    /// Pixel pitch `(dx, dy)`, µm.
    pub pixel_um: Option<(f64, f64)>,
    /// Distance between slices, µm.
    pub z_step_um: Option<f64>,
    /// Which end page 0 is.
    pub first_page: Option<PageOrder>,
}

/// What a stack file holds, known before any page is decoded.
#[derive(Debug, Clone, PartialEq)]
pub struct StackInfo {
    /// Metadata convention.
    pub format: StackFormat,
    /// Pixels per row.
    pub nx: usize,
    /// Rows.
    pub ny: usize,
    /// Slices (pages that are not reduced-resolution images).
    pub nz: usize,
    /// Sample type of the slices.
    pub sample: SampleType,
    /// Samples are divided by this on reading (255, 65535, 4095 or 1), with its source.
    pub full_scale: Sourced<f64>,
    /// Pixel pitch `(dx, dy)`, µm; `None` when neither the file nor an option gives it.
    pub pixel_um: Option<Sourced<(f64, f64)>>,
    /// z step, µm; `None` when neither the file nor an option gives it.
    pub z_step_um: Option<Sourced<f64>>,
    /// Which end page 0 is.
    pub first_page: Sourced<PageOrder>,
    /// TIFF directories in the file.
    pub pages: usize,
    /// Reduced-resolution directories skipped (thumbnails).
    pub skipped_pages: usize,
    /// Raw metadata fields (`imagej.spacing`, `ome.PhysicalSizeZ`, `lsm.VoxelSizeZ`,
    /// `tiff.XResolution`, ...).
    pub metadata: BTreeMap<String, String>,
}

/// A fully calibrated stack geometry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Calibration {
    /// Pixel pitch along `x`, µm.
    pub dx_um: f64,
    /// Pixel pitch along `y`, µm.
    pub dy_um: f64,
    /// z step, µm.
    pub dz_um: f64,
}

impl StackInfo {
    /// Pixel pitch and z step, or the error that says which is missing.
    ///
    /// # Errors
    /// [`StackError::MissingPixelSize`] or [`StackError::MissingZStep`].
    pub fn calibration(&self) -> Result<Calibration, StackError> {
        let Some(p) = &self.pixel_um else {
            let note = match self.metadata.get("tiff.XResolution") {
                Some(r) if self.format == StackFormat::PlainTiff => format!(
                    "its XResolution tag ({r} per {}) is a display resolution, not a calibration",
                    self.metadata
                        .get("tiff.ResolutionUnit")
                        .map_or("unit", String::as_str)
                ),
                _ => format!("the {} metadata has no pixel size", self.format),
            };
            return Err(StackError::MissingPixelSize {
                format: self.format,
                note,
            });
        };
        let Some(z) = &self.z_step_um else {
            return Err(StackError::MissingZStep {
                format: self.format,
            });
        };
        Ok(Calibration {
            dx_um: p.value.0,
            dy_um: p.value.1,
            dz_um: z.value,
        })
    }
}

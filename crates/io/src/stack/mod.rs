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

mod meta;
mod positions;
pub mod write;

use std::collections::BTreeMap;
use std::fmt;
use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use thiserror::Error;
use tiff::ColorType;
use tiff::decoder::{Decoder, DecodingResult, Limits, ifd::Value};
use tiff::tags::Tag;

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

/// What is wrong with a stack.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum StackError {
    /// Not a TIFF file at all.
    #[error("not a TIFF file: {0}")]
    NotTiff(String),
    /// The TIFF decoder failed on a page.
    #[error("page {page} (0-based): {message}")]
    Decode {
        /// 0-based TIFF directory index.
        page: usize,
        /// The decoder's message.
        message: String,
    },
    /// A page's data lie beyond the end of the file.
    #[error(
        "page {page} (0-based): its image data end at byte {end} but the file has {file_len} bytes (truncated?)"
    )]
    Truncated {
        /// 0-based TIFF directory index.
        page: usize,
        /// Byte offset where the page's data end.
        end: u64,
        /// File length, bytes.
        file_len: u64,
    },
    /// An uncompressed page has fewer data bytes than its size needs.
    #[error("page {page} (0-based): its strips hold {found} bytes, a {what} page needs {needed}")]
    ShortData {
        /// 0-based TIFF directory index.
        page: usize,
        /// Bytes the strips hold.
        found: u64,
        /// Bytes needed.
        needed: u64,
        /// Size and type, e.g. `128 x 128 uint16`.
        what: String,
    },
    /// A page has another size than the first slice.
    #[error(
        "page {page} (0-based) is {} x {} pixels but the first slice is {} x {}: every slice of a stack must have one size",
        found.0, found.1, expected.0, expected.1
    )]
    PageSize {
        /// 0-based TIFF directory index.
        page: usize,
        /// Size of the first slice `(nx, ny)`.
        expected: (usize, usize),
        /// Size of this page.
        found: (usize, usize),
    },
    /// A page has another sample type than the first slice.
    #[error(
        "page {page} (0-based) holds {found} samples but the first slice holds {expected}: every slice must have one sample type"
    )]
    PageType {
        /// 0-based TIFF directory index.
        page: usize,
        /// Type of the first slice.
        expected: SampleType,
        /// Type of this page.
        found: SampleType,
    },
    /// A page's pixels are not one 8/16-bit unsigned or 32-bit float grey sample.
    #[error(
        "page {page} (0-based) has {what}: a z-stack needs one grey sample per pixel, 8- or 16-bit unsigned or 32-bit float"
    )]
    Sample {
        /// 0-based TIFF directory index.
        page: usize,
        /// What it has.
        what: String,
    },
    /// Fewer than three slices.
    #[error("{}", too_few(*slices))]
    TooFewSlices {
        /// Slices found.
        slices: usize,
    },
    /// More directories than [`MAX_PAGES`].
    #[error("the file has more than {MAX_PAGES} pages")]
    TooManyPages,
    /// Slices larger than [`MAX_SLICE_PIXELS`] (or empty).
    #[error("slices of {nx} x {ny} pixels are not read: at most {MAX_SLICE_PIXELS} pixels")]
    TooLarge {
        /// Pixels per row.
        nx: usize,
        /// Rows.
        ny: usize,
    },
    /// The metadata declare another number of slices than the file holds.
    #[error(
        "{field} says {declared} slices but the file holds {found} (truncated or inconsistent?)"
    )]
    DeclaredCount {
        /// The field, e.g. `ImageJ images=`.
        field: &'static str,
        /// Declared count.
        declared: usize,
        /// Slices found.
        found: usize,
    },
    /// The metadata declare another slice size than the pages have.
    #[error(
        "{field} says {} x {} pixels but the pages are {} x {}",
        declared.0, declared.1, found.0, found.1
    )]
    DeclaredSize {
        /// The fields.
        field: &'static str,
        /// Declared `(nx, ny)`.
        declared: (usize, usize),
        /// Page size.
        found: (usize, usize),
    },
    /// A layout this reader does not handle (several channels or time points, several
    /// series, ImageJ's single-directory layout).
    #[error("unsupported stack: {0}")]
    Unsupported(String),
    /// A metadata field is present but unusable.
    #[error("{format} metadata: {message}")]
    Metadata {
        /// The convention.
        format: StackFormat,
        /// What is wrong.
        message: String,
    },
    /// No pixel size in the file and none given.
    #[error("the stack gives no pixel size ({note}): give it as an option (pixel_um)")]
    MissingPixelSize {
        /// The convention found.
        format: StackFormat,
        /// Why the file's fields do not count.
        note: String,
    },
    /// No z step in the file and none given.
    #[error("the {format} stack gives no z step: give it as an option (z_step_um)")]
    MissingZStep {
        /// The convention found.
        format: StackFormat,
    },
    /// An option is out of range.
    #[error("stack option {name} = {value} is invalid: expected {expected}")]
    BadOption {
        /// The option.
        name: &'static str,
        /// The value given.
        value: f64,
        /// What is accepted.
        expected: &'static str,
    },
}

fn too_few(slices: usize) -> String {
    match slices {
        0 => "the file holds no slice".into(),
        1 => "the file holds a single page: that is an image, not a z-stack (a stack needs at \
              least 3 slices)"
            .into(),
        n => format!("the file holds {n} slices: a z-stack needs at least 3"),
    }
}

/// Error from [`StackReader::open`] and reading a file's slices: the file and what went
/// wrong.
#[derive(Debug, Error)]
pub enum ReadStackError {
    /// The file could not be opened or read.
    #[error("cannot read stack {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating-system error.
        source: std::io::Error,
    },
    /// The file's content is not a usable stack.
    #[error("stack {}: {error}", path.display())]
    Format {
        /// The file.
        path: PathBuf,
        /// The problem.
        error: StackError,
    },
}

/// Streams the slices of a TIFF stack.
pub struct StackReader<R: Read + Seek> {
    decoder: Decoder<R>,
    info: StackInfo,
    /// TIFF directory index of each slice, in page order.
    slices: Vec<usize>,
    next: usize,
    buffer: DecodingResult,
    out: Vec<f32>,
}

impl<R: Read + Seek> fmt::Debug for StackReader<R> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("StackReader")
            .field("info", &self.info)
            .field("next", &self.next)
            .finish_non_exhaustive()
    }
}

impl StackReader<BufReader<File>> {
    /// Opens a stack file and checks every page's directory.
    ///
    /// # Errors
    /// [`ReadStackError::Io`] if the file cannot be opened, [`ReadStackError::Format`]
    /// with the [`StackError`] otherwise.
    pub fn open(path: impl AsRef<Path>, options: &StackOptions) -> Result<Self, ReadStackError> {
        let path = path.as_ref();
        let file = File::open(path).map_err(|source| ReadStackError::Io {
            path: path.to_path_buf(),
            source: crate::files::explain_open_error(path, source),
        })?;
        Self::new(BufReader::new(file), options).map_err(|error| ReadStackError::Format {
            path: path.to_path_buf(),
            error,
        })
    }
}

fn tiff_err(page: usize, e: &tiff::TiffError) -> StackError {
    let message = match e {
        tiff::TiffError::IoError(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            "the file ends inside this page's directory or data (truncated?)".to_string()
        }
        e => e.to_string(),
    };
    StackError::Decode { page, message }
}

/// What one slice page looks like.
struct Page {
    size: (usize, usize),
    sample: SampleType,
}

fn rational(v: Option<Value>) -> Option<(u32, u32)> {
    match v? {
        Value::Rational(n, d) => Some((n, d)),
        Value::List(l) => match l.first() {
            Some(Value::Rational(n, d)) => Some((*n, *d)),
            _ => None,
        },
        _ => None,
    }
}

fn ascii(v: Option<Value>) -> Option<String> {
    match v? {
        Value::Ascii(s) => Some(s),
        Value::List(l) => l.into_iter().find_map(|v| match v {
            Value::Ascii(s) => Some(s),
            _ => None,
        }),
        _ => None,
    }
}

impl<R: Read + Seek> StackReader<R> {
    /// Reads the directories of a stack from any seekable source and checks them.
    ///
    /// # Errors
    /// [`StackError`] saying what is wrong and where (page index, field).
    pub fn new(mut reader: R, options: &StackOptions) -> Result<Self, StackError> {
        check_options(options)?;
        let io = |e: std::io::Error| StackError::NotTiff(e.to_string());
        let file_len = reader.seek(SeekFrom::End(0)).map_err(io)?;
        reader.seek(SeekFrom::Start(0)).map_err(io)?;
        let mut decoder = Decoder::new(reader).map_err(|e| match e {
            tiff::TiffError::FormatError(_) if file_len < 8 => {
                StackError::NotTiff(format!("{file_len} bytes is too short for a TIFF header"))
            }
            tiff::TiffError::FormatError(
                f @ (tiff::TiffFormatError::TiffSignatureNotFound
                | tiff::TiffFormatError::TiffSignatureInvalid),
            ) => StackError::NotTiff(f.to_string()),
            e => tiff_err(0, &e),
        })?;
        let mut limits = Limits::default();
        limits.decoding_buffer_size = MAX_SLICE_PIXELS * 4 + (1 << 20);
        limits.ifd_value_size = 16 << 20;
        decoder = decoder.with_limits(limits);

        let mut slices = Vec::new();
        let mut first: Option<Page> = None;
        let mut declared = meta::Declared::default();
        let mut format = StackFormat::PlainTiff;
        let mut metadata = BTreeMap::new();
        let mut page = 0usize;
        loop {
            let subfile: u32 = decoder
                .find_tag_unsigned(Tag::NewSubfileType)
                .map_err(|e| tiff_err(page, &e))?
                .unwrap_or(0);
            let old_subfile: u32 = decoder
                .find_tag_unsigned(Tag::Unknown(255))
                .map_err(|e| tiff_err(page, &e))?
                .unwrap_or(1);
            let reduced = subfile & 1 == 1 || old_subfile == 2;
            if !reduced {
                let this = inspect(&mut decoder, page, file_len)?;
                match &first {
                    None => {
                        (format, declared) = read_metadata(&mut decoder, page, &mut metadata)?;
                        first = Some(this);
                    }
                    Some(f) => {
                        if this.size != f.size {
                            return Err(StackError::PageSize {
                                page,
                                expected: f.size,
                                found: this.size,
                            });
                        }
                        if this.sample != f.sample {
                            return Err(StackError::PageType {
                                page,
                                expected: f.sample,
                                found: this.sample,
                            });
                        }
                    }
                }
                slices.push(page);
            }
            if !decoder.more_images() {
                break;
            }
            page += 1;
            if page >= MAX_PAGES {
                return Err(StackError::TooManyPages);
            }
            decoder.next_image().map_err(|e| tiff_err(page, &e))?;
        }
        let pages = page + 1;
        let Some(first) = first else {
            return Err(StackError::TooFewSlices { slices: 0 });
        };
        let nz = slices.len();
        let (nx, ny) = first.size;

        if let Some(what) = declared.extra_dimensions.take() {
            return Err(StackError::Unsupported(format!(
                "{what}: only single-channel, single-time-point z-stacks are read"
            )));
        }
        if let Some((n, field)) = declared.slices {
            if format == StackFormat::ImageJ && nz == 1 && n > 1 {
                return Err(StackError::Unsupported(format!(
                    "{field}{n} stored behind a single TIFF directory (ImageJ's layout for \
                     files over 4 GB) is not read; save the stack as OME-TIFF or as a \
                     multi-page TIFF under 4 GB"
                )));
            }
            if n != nz {
                return Err(StackError::DeclaredCount {
                    field,
                    declared: n,
                    found: nz,
                });
            }
        }
        if nz < 3 {
            return Err(StackError::TooFewSlices { slices: nz });
        }
        if let Some((size, field)) = declared.size
            && size != (nx, ny)
        {
            return Err(StackError::DeclaredSize {
                field,
                declared: size,
                found: (nx, ny),
            });
        }

        let file_value = |v: Option<Result<(f64, String), String>>| match v {
            Some(Ok((x, src))) => Ok(Some(Sourced {
                value: x,
                source: Source::File(src),
            })),
            Some(Err(message)) => Err(StackError::Metadata { format, message }),
            None => Ok(None),
        };
        let pixel_um = match options.pixel_um {
            Some(p) => Some(Sourced {
                value: p,
                source: Source::Option,
            }),
            None => match declared.pixel_um {
                Some(Ok((p, src))) => Some(Sourced {
                    value: p,
                    source: Source::File(src),
                }),
                Some(Err(message)) => return Err(StackError::Metadata { format, message }),
                None => None,
            },
        };
        let z_step_um = match options.z_step_um {
            Some(z) => Some(Sourced {
                value: z,
                source: Source::Option,
            }),
            None => file_value(declared.z_step_um)?,
        };
        let first_page = match (options.first_page, declared.top_first) {
            (Some(o), _) => Sourced {
                value: o,
                source: Source::Option,
            },
            (None, Some(Ok((top, why)))) => Sourced {
                value: if top {
                    PageOrder::TopFirst
                } else {
                    PageOrder::BottomFirst
                },
                source: Source::File(why),
            },
            (None, Some(Err(message))) => return Err(StackError::Metadata { format, message }),
            (None, None) => Sourced {
                value: PageOrder::BottomFirst,
                source: Source::Default,
            },
        };
        let full_scale = match (first.sample, declared.full_scale) {
            (SampleType::U16, Some((f, why))) => Sourced {
                value: f,
                source: Source::File(why),
            },
            (SampleType::U8, _) => Sourced {
                value: 255.0,
                source: Source::File("8-bit samples".into()),
            },
            (SampleType::U16, None) => Sourced {
                value: 65535.0,
                source: Source::File("16-bit samples".into()),
            },
            (SampleType::F32, _) => Sourced {
                value: 1.0,
                source: Source::File("float samples are kept as stored".into()),
            },
        };
        metadata.extend(declared.fields);
        let info = StackInfo {
            format,
            nx,
            ny,
            nz,
            sample: first.sample,
            full_scale,
            pixel_um,
            z_step_um,
            first_page,
            pages,
            skipped_pages: pages - nz,
            metadata,
        };
        Ok(Self {
            decoder,
            info,
            slices,
            next: 0,
            buffer: DecodingResult::U8(Vec::new()),
            out: Vec::new(),
        })
    }

    /// What the file holds.
    pub fn info(&self) -> &StackInfo {
        &self.info
    }

    /// Index of the next slice [`StackReader::next_slice`] returns (0-based, page order).
    pub fn position(&self) -> usize {
        self.next
    }

    /// Decodes the next slice (page order): `nx · ny` samples, row-major, divided by
    /// [`StackInfo::full_scale`]; `None` after the last slice.
    ///
    /// # Errors
    /// [`StackError::Decode`] (with the page index) when a page cannot be decoded.
    pub fn next_slice(&mut self) -> Result<Option<&[f32]>, StackError> {
        let Some(&page) = self.slices.get(self.next) else {
            return Ok(None);
        };
        let err = |e: tiff::TiffError| tiff_err(page, &e);
        self.decoder.seek_to_image(page).map_err(err)?;
        self.decoder
            .read_image_to_buffer(&mut self.buffer)
            .map_err(err)?;
        let n = self.info.nx * self.info.ny;
        let scale = (1.0 / self.info.full_scale.value) as f32;
        self.out.clear();
        match &self.buffer {
            DecodingResult::U8(v) if v.len() >= n => {
                self.out
                    .extend(v[..n].iter().map(|&x| f32::from(x) * scale));
            }
            DecodingResult::U16(v) if v.len() >= n => {
                self.out
                    .extend(v[..n].iter().map(|&x| f32::from(x) * scale));
            }
            DecodingResult::F32(v) if v.len() >= n => self.out.extend_from_slice(&v[..n]),
            other => {
                return Err(StackError::Decode {
                    page,
                    message: format!(
                        "decoded {} samples of another type or count than the {n} {} samples \
                         expected",
                        other_len(other),
                        self.info.sample
                    ),
                });
            }
        }
        self.next += 1;
        Ok(Some(&self.out))
    }
}

fn other_len(r: &DecodingResult) -> usize {
    match r {
        DecodingResult::U8(v) => v.len(),
        DecodingResult::U16(v) => v.len(),
        DecodingResult::U32(v) => v.len(),
        DecodingResult::U64(v) => v.len(),
        DecodingResult::F16(v) => v.len(),
        DecodingResult::F32(v) => v.len(),
        DecodingResult::F64(v) => v.len(),
        DecodingResult::I8(v) => v.len(),
        DecodingResult::I16(v) => v.len(),
        DecodingResult::I32(v) => v.len(),
        DecodingResult::I64(v) => v.len(),
    }
}

fn check_options(o: &StackOptions) -> Result<(), StackError> {
    let mut values = Vec::new();
    if let Some((dx, dy)) = o.pixel_um {
        values.push(("pixel_um (x)", dx));
        values.push(("pixel_um (y)", dy));
    }
    if let Some(dz) = o.z_step_um {
        values.push(("z_step_um", dz));
    }
    for (name, value) in values {
        if !(value.is_finite() && value > 0.0) {
            return Err(StackError::BadOption {
                name,
                value,
                expected: "finite and > 0 µm",
            });
        }
    }
    Ok(())
}

/// Size, sample type and data extent of the current page.
fn inspect<R: Read + Seek>(
    decoder: &mut Decoder<R>,
    page: usize,
    file_len: u64,
) -> Result<Page, StackError> {
    let (w, h) = decoder.dimensions().map_err(|e| tiff_err(page, &e))?;
    let (nx, ny) = (w as usize, h as usize);
    if nx == 0 || ny == 0 || nx.saturating_mul(ny) > MAX_SLICE_PIXELS {
        return Err(StackError::TooLarge { nx, ny });
    }
    let colour = decoder.colortype().map_err(|e| StackError::Sample {
        page,
        what: e.to_string(),
    })?;
    let format: u16 = decoder
        .find_tag_unsigned_vec::<u16>(Tag::SampleFormat)
        .map_err(|e| tiff_err(page, &e))?
        .and_then(|v| v.first().copied())
        .unwrap_or(1);
    let sample = match (colour, format) {
        (ColorType::Gray(8), 1) => SampleType::U8,
        (ColorType::Gray(16), 1) => SampleType::U16,
        (ColorType::Gray(32), 3) => SampleType::F32,
        (ColorType::Gray(b), f) => {
            let kind = match f {
                1 => "unsigned integer",
                2 => "signed integer",
                3 => "float",
                _ => "untyped",
            };
            return Err(StackError::Sample {
                page,
                what: format!("{b}-bit {kind} samples"),
            });
        }
        (other, _) => {
            return Err(StackError::Sample {
                page,
                what: format!("{other:?} pixels"),
            });
        }
    };
    // Every chunk must lie inside the file; uncompressed strips must hold the page.
    let (offsets_tag, counts_tag) = if decoder
        .find_tag(Tag::TileOffsets)
        .map_err(|e| tiff_err(page, &e))?
        .is_some()
    {
        (Tag::TileOffsets, Tag::TileByteCounts)
    } else {
        (Tag::StripOffsets, Tag::StripByteCounts)
    };
    let get = |d: &mut Decoder<R>, t: Tag| {
        d.find_tag_unsigned_vec::<u64>(t)
            .map_err(|e| tiff_err(page, &e))
    };
    let offsets = get(decoder, offsets_tag)?.unwrap_or_default();
    let counts = get(decoder, counts_tag)?.unwrap_or_default();
    if offsets.is_empty() || offsets.len() != counts.len() {
        return Err(StackError::Decode {
            page,
            message: format!(
                "{} {offsets_tag:?} but {} {counts_tag:?}",
                offsets.len(),
                counts.len()
            ),
        });
    }
    let mut total = 0u64;
    for (&o, &c) in offsets.iter().zip(&counts) {
        let end = o.saturating_add(c);
        if end > file_len {
            return Err(StackError::Truncated {
                page,
                end,
                file_len,
            });
        }
        total = total.saturating_add(c);
    }
    let compression: u16 = decoder
        .find_tag_unsigned(Tag::Compression)
        .map_err(|e| tiff_err(page, &e))?
        .unwrap_or(1);
    let needed = (nx * ny * sample.bytes()) as u64;
    if compression == 1 && offsets_tag == Tag::StripOffsets && total < needed {
        return Err(StackError::ShortData {
            page,
            found: total,
            needed,
            what: format!("{nx} x {ny} {sample}"),
        });
    }
    Ok(Page {
        size: (nx, ny),
        sample,
    })
}

/// The metadata convention of the first slice page and what it declares.
fn read_metadata<R: Read + Seek>(
    decoder: &mut Decoder<R>,
    page: usize,
    fields: &mut BTreeMap<String, String>,
) -> Result<(StackFormat, meta::Declared), StackError> {
    let err = |e: tiff::TiffError| tiff_err(page, &e);
    let description = ascii(decoder.find_tag(Tag::ImageDescription).map_err(err)?);
    let xres = rational(decoder.find_tag(Tag::XResolution).map_err(err)?);
    let yres = rational(decoder.find_tag(Tag::YResolution).map_err(err)?);
    let unit: Option<u16> = decoder
        .find_tag_unsigned(Tag::ResolutionUnit)
        .map_err(err)?;
    let per = |r: Option<(u32, u32)>| {
        r.filter(|r| r.1 != 0)
            .map(|(n, d)| f64::from(n) / f64::from(d))
    };
    if let Some(r) = per(xres) {
        fields.insert("tiff.XResolution".into(), r.to_string());
        fields.insert(
            "tiff.ResolutionUnit".into(),
            match unit.unwrap_or(2) {
                1 => "none",
                2 => "inch",
                3 => "centimetre",
                _ => "unknown",
            }
            .into(),
        );
    }
    if let Some(lsm) = decoder
        .find_tag(Tag::Unknown(TAG_CZ_LSMINFO))
        .map_err(err)?
    {
        let bytes = lsm.into_u8_vec().map_err(|e| StackError::Metadata {
            format: StackFormat::Lsm,
            message: format!("tag 34412 (CZ_LSMINFO) is not a byte record: {e}"),
        })?;
        let d = meta::lsm(&bytes).map_err(|message| StackError::Metadata {
            format: StackFormat::Lsm,
            message,
        })?;
        return Ok((StackFormat::Lsm, d));
    }
    let Some(text) = description else {
        return Ok((StackFormat::PlainTiff, meta::Declared::default()));
    };
    if meta::is_ome(&text) {
        let d = meta::ome(&text).map_err(|message| {
            if message.contains("images (series)") {
                StackError::Unsupported(message)
            } else {
                StackError::Metadata {
                    format: StackFormat::OmeTiff,
                    message,
                }
            }
        })?;
        return Ok((StackFormat::OmeTiff, d));
    }
    if meta::is_imagej(&text) {
        let d = meta::imagej(&text, xres, yres);
        return Ok((StackFormat::ImageJ, d));
    }
    fields.insert(
        "tiff.ImageDescription".into(),
        text.chars().take(200).collect(),
    );
    Ok((StackFormat::PlainTiff, meta::Declared::default()))
}

//! What can go wrong reading a stack: the content ([`StackError`]) and, reading a file,
//! the file named with it ([`ReadStackError`]).

use std::path::PathBuf;

use thiserror::Error;

use super::{MAX_PAGES, MAX_SLICE_PIXELS, SampleType, StackFormat};

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

/// Error from [`StackReader::open`](super::reader::StackReader::open) and reading a file's slices: the file and what went
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

//! What is wrong with a plain-text height matrix.

use flakescatter_stats::heightmap::HeightMapError;
use thiserror::Error;

/// What is wrong with a plain-text height matrix.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum TextError {
    /// The file is empty or holds only header lines.
    #[error("no data rows found")]
    Empty,
    /// The file contains bytes that do not occur in text.
    #[error(
        "byte {offset} is 0x{byte:02x}, which does not occur in text: binary content, not a \
         text matrix"
    )]
    Binary {
        /// Offset of the first such byte.
        offset: usize,
        /// The byte.
        byte: u8,
    },
    /// A value is not a number.
    #[error("line {line}, column {column}: {token:?} is not a number")]
    BadNumber {
        /// 1-based line number.
        line: usize,
        /// 1-based column (value index in the line).
        column: usize,
        /// The token.
        token: String,
    },
    /// Two separators with nothing between them.
    #[error(
        "line {line}, column {column}: empty value between two separators (write NaN for a \
         missing point)"
    )]
    EmptyValue {
        /// 1-based line number.
        line: usize,
        /// 1-based column of the missing value.
        column: usize,
    },
    /// A row has a different number of values from the first row.
    #[error(
        "line {line}: row has {found} values, expected {expected} (as in the first data row or the column header)"
    )]
    Ragged {
        /// 1-based line number.
        line: usize,
        /// Values in the first row.
        expected: usize,
        /// Values in this row.
        found: usize,
    },
    /// A header size or unit cannot be understood.
    #[error("line {line}: header {key:?} = {value:?}: expected {expected}")]
    BadHeader {
        /// 1-based line number.
        line: usize,
        /// The header key.
        key: String,
        /// The header value.
        value: String,
        /// What was expected.
        expected: &'static str,
    },
    /// The same header key is given twice.
    #[error("header {key:?} is given twice, on lines {first} and {second}")]
    DuplicateHeader {
        /// The key.
        key: String,
        /// 1-based line of the first.
        first: usize,
        /// 1-based line of the second.
        second: usize,
    },
    /// The file gives no pitch and none was supplied.
    #[error(
        "the file does not give the pixel pitch: supply it (option pixel_um, \
         `--pixel-um DX[,DY]` on the command line)"
    )]
    MissingPitch,
    /// The file gives no height unit and none was supplied.
    #[error(
        "the file does not give the unit of its heights: supply it (option z_unit, \
         `--z-unit um|nm|m` on the command line)"
    )]
    MissingZUnit,
    /// The file's value unit is not a length, and the map is read as heights.
    #[error(
        "line {line}: the values' unit is {unit:?}, not a length: a height map needs a \
         length unit (m, mm, µm, nm, pm); if the values are heights, give their unit \
         (option z_unit, `--z-unit um|nm|m` on the command line)"
    )]
    NotALength {
        /// 1-based line of the unit header.
        line: usize,
        /// The unit the file gives.
        unit: String,
    },
    /// The decimal mark cannot be decided from the content.
    #[error(
        "line {line}: {token:?} can be read with a decimal comma or as numbers separated by \
         commas, and the file does not settle which ({why}); say which: option decimal, \
         `--decimal-comma` (or `--decimal-point`) on the command line"
    )]
    AmbiguousDecimal {
        /// 1-based line of the first ambiguous token.
        line: usize,
        /// The token.
        token: String,
        /// Why the content does not decide it.
        why: &'static str,
    },
    /// The content contradicts the decimal mark that was asked for.
    #[error("line {line}: {token:?} contradicts the decimal {mark} asked for: {why}")]
    DecimalContradiction {
        /// 1-based line.
        line: usize,
        /// The token.
        token: String,
        /// `comma` or `point`.
        mark: &'static str,
        /// What the content shows instead.
        why: &'static str,
    },
    /// The profile's `x` column is not evenly spaced.
    #[error("line {line}: x column is not evenly spaced (step {step} vs mean {mean})")]
    UnevenProfile {
        /// 1-based line number.
        line: usize,
        /// The offending step, in the file's x unit.
        step: f64,
        /// Mean step, in the file's x unit.
        mean: f64,
    },
    /// The three columns are a list of `x y z` points on a grid, not a height matrix.
    #[error(
        "line {line}: the 3 columns look like an x, y, z point list ({nx} x values times {ny} y \
         values, one row each), not a height matrix with 3 columns; point lists are not \
         read: export the map as a matrix (one row of heights per line)"
    )]
    PointList {
        /// 1-based line of the first data row.
        line: usize,
        /// Distinct values of the first column.
        nx: usize,
        /// Distinct values of the second column.
        ny: usize,
    },
    /// The profile's `x` column does not increase.
    #[error(
        "line {line}: the x column must increase from row to row (it runs from {first} to {last})"
    )]
    ProfileNotIncreasing {
        /// 1-based line of the first data row.
        line: usize,
        /// First x value.
        first: f64,
        /// Last x value.
        last: f64,
    },
    /// The numbers do not make a valid height map.
    #[error("{0}")]
    Map(HeightMapError),
}

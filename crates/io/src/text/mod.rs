//! Plain-text height matrices: one row of the map per line, values separated by
//! whitespace, commas or semicolons; `NaN` (or any non-finite value) marks an invalid point.
//!
//! Conventions: the first data line is row 0 (`y = 0`), the first value of a line is column
//! 0 (`x = 0`). Lines end in `\n`, `\r\n` or a lone `\r`. The text is UTF-8 (a byte-order
//! mark is skipped), UTF-16 with a byte-order mark, or else read as Latin-1 (Windows
//! exports of `Höhe` and `µm`); `text.encoding` says which. Leading `#` lines are a header
//! in Gwyddion's style, `# Key: value`, with English or German keys:
//! * `Width`/`Breite` and `Height`/`Höhe`: the physical size of the whole image with a
//!   unit (`12.34 µm`); the pitch is `width / nx`, `height / ny` (Gwyddion's convention).
//! * `Pitch x`, `Pitch y` (written by this crate): the pitch itself, which reproduces it
//!   exactly; these take precedence over width and height.
//! * `Value units`/`Z units`/`Werteinheiten`: the unit of the values (`m`, `mm`, `µm`, `nm`).
//!
//! A file that carries no pitch needs [`ReadOptions::pixel_um`]; a height map that
//! carries no length unit needs [`ReadOptions::z_unit`] (the command line's `--pixel-um`
//! and `--z-unit`). Nothing is silently assumed. Intensity images need no unit: any
//! `Value units` (`a.u.`, empty) is recorded in `text.value_units` and the numbers are
//! taken as they are.
//!
//! **Decimal marks** ([`ReadOptions::decimal`]). German exports write `1,5` for 1.5, with
//! whitespace or `;` between values. With [`DecimalMark::Auto`] the reader decides from
//! the whole data section: `;` between values with commas inside them, or several
//! whitespace-separated values of the form `1,5` on a line, mean decimal commas; a `.`
//! in a number, or commas next to spaces (`1, 2`), mean decimal points with commas as
//! separators. When the content allows both readings (every line one token `10,20`, or
//! both kinds of evidence) it refuses, naming `--decimal-comma`; with an explicit mark it
//! refuses content that contradicts it. `text.decimal_mark` records what was used and
//! why. An empty value between two separators (`1,,3`) is an error, not a dropped column.
//!
//! A two-column table whose first line names an `x` column (`X_(microns),y1`) is read as a
//! single profile (`ny = 1`): the second column holds the heights and the pitch is the
//! mean spacing of the `x` column, whose unit is taken from its name.
//!
//! Rooms: `error` (what can go wrong), `encoding` (detection and decoding of the bytes),
//! `numbers` (tokens, fields and the decimal mark), `parse` (the header and data lines
//! of a file), `reader` (its channel and map) and `writer`.
//!
//! [`ReadOptions::pixel_um`]: crate::ReadOptions::pixel_um
//! [`ReadOptions::z_unit`]: crate::ReadOptions::z_unit
//! [`ReadOptions::decimal`]: crate::ReadOptions::decimal
//! [`DecimalMark::Auto`]: crate::DecimalMark::Auto

mod encoding;
mod error;
mod numbers;
mod parse;
mod reader;
mod writer;

pub(crate) use encoding::decode;
pub use encoding::detect;
pub use error::TextError;
pub use reader::{channels, read, read_text_bytes};
pub use writer::{write_intensity_text_string, write_text_string};

//! Reading and writing height maps: the one place that knows every format. It scores
//! the content with each format's `detect`, checks the file extension against the
//! winner, and calls that format's reader (see [`crate::reader`] for the contract each
//! format module fulfils). Readers never call back into this module.
//!
//! Conventions: every reader returns a
//! [`HeightMap`](flakescatter_stats::heightmap::HeightMap) with heights in micrometres
//! and pixel pitch in micrometres, row-major with `x` along columns (X fastest in the
//! file) and `y` along rows. Points the file marks invalid (NaN, `valid.bin`, non-finite
//! values) are invalid in the map's mask. Format-specific header fields go into the map's
//! metadata under `format` and keys prefixed with the format name (`x3p.creator`,
//! `sdf.ManufacID`, `text.channel`, ...).
//!
//! Adding a format: a module with `detect`, `channels` and `read` (as [`crate::x3p`]), a
//! [`MapFormat`] variant, a [`MapError`] variant, and one row in `FORMATS`.
//!
//! A Zarr v3 store ([`crate::zarr`]) is a directory, not bytes: `read` opens a path that
//! is one ([`crate::zarr::is_store`]) as a store before anything reads the file, and
//! [`MapFormat::Zarr`] is in no detection table.
//!
//! Rooms: `format` (the formats and what the messages call them), `dispatch` (each
//! format's reader in one table, detection and the choice of reader), `error` (what can
//! go wrong, by format and with the file named), `read` (the entry points that read a
//! map or list its channels, from memory or from a file) and `write`.

mod dispatch;
mod error;
mod format;
mod read;
mod write;

pub use error::{MapError, ReadMapError, WriteMapError};
pub use format::MapFormat;
pub(crate) use read::Source;
pub use read::{
    list_channels, list_channels_bytes, read_bytes, read_intensity, read_intensity_bytes, read_map,
    read_map_bytes,
};
pub use write::{write_intensity, write_map};

//! X3P (ISO 25178-72 / ISO 5436-2 XML 3D surface profile) reader and writer.
//!
//! An X3P file is a zip archive holding `main.xml` (the header), `md5checksum.hex` (the
//! MD5 of `main.xml`), `bindata/data.bin` (the heights) and optionally `bindata/valid.bin`
//! (one bit per point, least significant bit first, 1 = valid).
//!
//! Conventions: the Z `DataType` `I`/`L`/`F`/`D` is int16/int32/float32/float64,
//! little-endian, X fastest then Y (so X is the map's column index and Y its row index);
//! a real height is `Offset + raw × Increment` in metres, converted here to micrometres.
//! A missing Z `Increment` is taken as 1 and a missing or empty `Offset` as 0; a present
//! Z `Increment` must be finite and > 0 (a zero increment would make every height 0).
//! NaN or a clear `valid.bin` bit marks a point invalid. The X and Y axes must be
//! incremental (`AxisType` `I`); their `Increment` is the pixel pitch in metres, finite
//! and > 0. The file holds one channel, `Z`.
//!
//! Real-file quirks handled: members inside a sub-folder of the zip, `__MACOSX` and other
//! extra members, root `ISO5436_2` or `ISO5436` with or without a namespace prefix
//! (elements are matched by local name), upper-case MD5 and the `hash *main.xml` form of
//! `md5checksum.hex`, non-square pixels.
//!
//! Hostile input: no buffer is sized from a header field before the field has been
//! checked against what the archive can hold (a member is never read past the size the
//! header implies, and capacity hints are bounded by the compressed size).
//!
//! Reading `data.bin` takes one of two ways; both give the same heights bit for bit
//! (one formula, `raw × Increment + Offset`) and the same typed errors.
//! * **Whole** (libdeflate, one call): for a deflated, unencrypted member that declares
//!   exactly the size the header implies and is at most `declared / 2 + 48 MiB`
//!   compressed, when it pays: no MD5 of the data is declared, or the member is under
//!   8 MiB, or only one core is available. The raw deflate stream is a slice of the
//!   file's bytes (no copy); float64 points are inflated straight into the heights'
//!   bytes and decoded where they lie, narrower points into a buffer of the member's
//!   size and then decoded. The CRC-32 the archive declares is checked here (on the
//!   reading thread, while a second one computes the MD5 of a large member chunk by
//!   chunk); a stream that inflates to more than declared, to fewer, or not at all is
//!   refused naming the member.
//! * **Streamed** (the zip crate, zlib-rs): every other member, 1 MiB at a time; float64
//!   points are inflated into the heights' bytes, narrower ones decoded chunk by chunk;
//!   the MD5 of a large member is computed on a second thread as it is inflated, and
//!   the zip crate checks the CRC-32 and the declared size.
//!
//! Why both: whole, libdeflate inflates about twice as fast as zlib-rs streams (4096²
//! float64: 75–95 ms against ~176 ms for a well-compressed map), but the MD5 (500–600 MB/s,
//! the slowest step) can only start once it is done, whereas streamed it overlaps the
//! inflate on a second core. So with an MD5 to compute and a second core, a large
//! member streams; a poorly compressible one (more than `declared / 2 + 48 MiB`
//! compressed) always does, since its inflate is slow either way and streaming
//! overlaps it with the MD5.
//!
//! From a file ([`read_from`], which `read_map` and `read_selected` use for an X3P
//! file of 8 MiB or more) the archive is read as it is inflated, through a buffered
//! reader: nothing holds the file's bytes, the file is read on the inflating thread
//! while the MD5 runs on the other; the whole way, where it pays, first reads the
//! member's compressed bytes (not the file's). On the benchmark's 4096² file (with an
//! MD5, so streamed) that took 480 ms to 406 ms (the read of the file into memory,
//! about 100 ms, is gone; the streaming inflate is then the slowest step).
//!
//! Memory: besides the file's bytes (held by the caller, unless read from a file), a
//! read holds the float64 heights, the validity mask and, on the whole way for
//! narrower points, a buffer of at most half the heights' size (and, from a file, the
//! member's compressed bytes); streamed, a few 1 MiB chunks. The compressed-size bound
//! (half the member's inflated size plus 48 MiB) keeps what the whole way adds to the
//! heights within half their size plus 48 MiB for float64 points, three quarters of it
//! for narrower ones.
//!
//! Rooms: `error` (what can go wrong, and the I/O and zip errors mapped to it),
//! `header` (the `main.xml` model: elements, axes, data links, `Record2` metadata),
//! `data` (the `data.bin` / `valid.bin` members streamed), `whole` (`data.bin`
//! inflated in one call), `reader` (the archive opened, checksums, a map assembled) and
//! `writer` (a map written as an archive).

mod data;
mod error;
mod header;
mod reader;
mod whole;
mod writer;

pub use error::{ArchiveError, X3pError};
pub use reader::{channels, channels_from, detect, read, read_from, read_x3p_bytes};
pub(crate) use reader::{is_zip, main_xml};
pub use writer::{write_intensity_x3p_bytes, write_x3p_bytes};

#[cfg(test)]
mod tests;

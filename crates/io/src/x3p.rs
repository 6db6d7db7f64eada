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

use std::io::{Cursor, Read, Seek, Write};

use flakescatter_stats::heightmap::{HeightMap, HeightMapError};
use md5::{Digest, Md5};
use roxmltree::{Document, Node};
use thiserror::Error;

use crate::reader::{Channel, Confidence, ReadOptions, ValueKind};
use crate::units::parse_scaled;

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
pub struct ArchiveError(String);

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

fn md5_hex(bytes: &[u8]) -> String {
    hex(&Md5::digest(bytes))
}

/// The error of a failed read of `what` (`member "…"` or `the archive`): a damaged
/// archive (a corrupt deflate stream, a wrong CRC-32, a truncated file: the I/O error
/// kinds `InvalidData`, `InvalidInput` and `UnexpectedEof` that the zip crate and
/// flate2 give for them) is [`X3pError::Zip`]; any other failure is the system's,
/// [`X3pError::Read`].
fn io_error(what: &str, e: &std::io::Error) -> X3pError {
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
fn is_system(e: &std::io::Error) -> bool {
    use std::io::ErrorKind::{InvalidData, InvalidInput, UnexpectedEof};
    !matches!(e.kind(), InvalidData | InvalidInput | UnexpectedEof)
}

/// [`io_error`] of a zip crate error: its I/O errors as there, the others (an invalid
/// or unsupported archive) [`X3pError::Zip`].
fn zip_error(what: &str, e: &zip::result::ZipError) -> X3pError {
    match e {
        zip::result::ZipError::Io(io) => io_error(what, io),
        other => X3pError::Zip(format!("{what}: {other}")),
    }
}

/// Whether `bytes` start like a zip archive (a local file header or an empty archive).
pub(crate) fn is_zip(bytes: &[u8]) -> bool {
    bytes.starts_with(b"PK\x03\x04") || bytes.starts_with(b"PK\x05\x06")
}

/// Scores `bytes` as X3P: a zip archive that names `main.xml` near its start or end
/// (local header, central directory) is certain; any other zip archive is likely.
pub fn detect(bytes: &[u8]) -> Confidence {
    if !is_zip(bytes) {
        return 0;
    }
    let window = 64 << 10;
    let head = &bytes[..bytes.len().min(window)];
    let tail = &bytes[bytes.len().saturating_sub(window)..];
    let names_main = |b: &[u8]| b.windows(8).any(|w| w == b"main.xml");
    if names_main(head) || names_main(tail) {
        100
    } else {
        60
    }
}

/// First child element with the given local name.
fn child<'a, 'i>(node: Node<'a, 'i>, name: &str) -> Option<Node<'a, 'i>> {
    node.children()
        .find(|c| c.is_element() && c.tag_name().name() == name)
}

/// Element at a `/`-separated path of local names below `node`.
fn at<'a, 'i>(node: Node<'a, 'i>, path: &str) -> Option<Node<'a, 'i>> {
    path.split('/').try_fold(node, |n, name| child(n, name))
}

/// Trimmed text of the element at `path`, `None` if absent; empty text is `Some("")`.
fn text_at<'a>(node: Node<'a, '_>, path: &str) -> Option<&'a str> {
    at(node, path).map(|n| n.text().unwrap_or("").trim())
}

fn required<'a>(node: Node<'a, '_>, path: &str) -> Result<&'a str, X3pError> {
    text_at(node, path).ok_or_else(|| X3pError::MissingElement(path.to_string()))
}

fn bad(element: &str, value: &str, expected: &str) -> X3pError {
    X3pError::BadValue {
        element: element.to_string(),
        value: value.to_string(),
        expected: expected.to_string(),
    }
}

/// A decimal in metres at `path` times `10^shift` (6: µm), finite and, with `positive`,
/// > 0; `default` if absent or empty.
fn metres_scaled(
    node: Node<'_, '_>,
    path: &str,
    default: Option<f64>,
    shift: i32,
    positive: bool,
) -> Result<f64, X3pError> {
    match text_at(node, path) {
        Some(s) if !s.is_empty() => {
            let expected = if positive {
                "a finite decimal number > 0 in metres"
            } else {
                "a finite decimal number in metres"
            };
            let v = parse_scaled(s, shift)
                .filter(|v| v.is_finite())
                .ok_or_else(|| bad(path, s, expected))?;
            // A value so small that it underflows to 0 in µm is as unusable as 0 itself.
            if positive && !(v > 0.0) {
                return Err(bad(path, s, expected));
            }
            Ok(v)
        }
        _ => default.ok_or_else(|| X3pError::MissingElement(path.to_string())),
    }
}

fn size_at(node: Node<'_, '_>, path: &str) -> Result<usize, X3pError> {
    let s = required(node, path)?;
    match s.parse::<usize>() {
        Ok(n) if n > 0 => Ok(n),
        _ => Err(bad(path, s, "a positive integer (number of points)")),
    }
}

/// The Z data types of ISO 25178-72.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum DataType {
    I16,
    I32,
    F32,
    F64,
}

impl DataType {
    fn width(self) -> usize {
        match self {
            DataType::I16 => 2,
            DataType::I32 | DataType::F32 => 4,
            DataType::F64 => 8,
        }
    }

    fn code(self) -> &'static str {
        match self {
            DataType::I16 => "I",
            DataType::I32 => "L",
            DataType::F32 => "F",
            DataType::F64 => "D",
        }
    }

    fn decode(self, c: &[u8]) -> f64 {
        match self {
            DataType::I16 => f64::from(i16::from_le_bytes([c[0], c[1]])),
            DataType::I32 => f64::from(i32::from_le_bytes([c[0], c[1], c[2], c[3]])),
            DataType::F32 => f64::from(f32::from_le_bytes([c[0], c[1], c[2], c[3]])),
            DataType::F64 => f64::from_le_bytes([c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]]),
        }
    }
}

/// Everything `main.xml` says that reading the data needs, checked.
struct Header {
    nx: usize,
    ny: usize,
    /// Pitch in µm (the override's when one is given).
    pitch: (f64, f64),
    z_scale: f64,
    z_offset: f64,
    dtype: DataType,
    data_link: String,
    data_md5: Option<String>,
    valid_link: Option<String>,
    valid_md5: Option<String>,
    checksum_file: String,
    meta: Vec<(String, String)>,
}

fn parse_header(
    root: Node<'_, '_>,
    options: &ReadOptions,
    kind: ValueKind,
) -> Result<Header, X3pError> {
    let root_name = root.tag_name().name();
    if root_name != "ISO5436_2" && root_name != "ISO5436" {
        return Err(X3pError::Xml(format!(
            "root element is <{root_name}>, expected <ISO5436_2>"
        )));
    }
    let mut meta: Vec<(String, String)> = vec![("x3p.root".into(), root_name.into())];
    for path in ["Record1/Revision", "Record1/FeatureType"] {
        if let Some(v) = text_at(root, path) {
            let key = path.rsplit('/').next().unwrap_or(path).to_lowercase();
            meta.push((format!("x3p.{key}"), v.to_string()));
        }
    }
    let feature = text_at(root, "Record1/FeatureType").unwrap_or("SUR");
    if feature == "PCL" {
        return Err(bad(
            "Record1/FeatureType",
            feature,
            "SUR or PRF (point clouds are not height maps)",
        ));
    }

    // Axes.
    for axis in ["CX", "CY"] {
        let path = format!("Record1/Axes/{axis}/AxisType");
        let t = required(root, &path)?;
        if t != "I" {
            return Err(bad(
                &path,
                t,
                "I (incremental); absolute X/Y coordinates are not supported",
            ));
        }
    }
    for axis in ["CX", "CY", "CZ"] {
        for field in ["AxisType", "DataType", "Increment", "Offset"] {
            if let Some(v) = text_at(root, &format!("Record1/Axes/{axis}/{field}")) {
                meta.push((
                    format!("x3p.{}.{}", axis.to_lowercase(), field.to_lowercase()),
                    v.to_string(),
                ));
            }
        }
    }
    // The pitch override replaces the file's X/Y increments, which are then not used.
    let pitch = match options.pixel_um {
        Some(p) => p,
        None => (
            metres_scaled(root, "Record1/Axes/CX/Increment", None, 6, true)?,
            metres_scaled(root, "Record1/Axes/CY/Increment", None, 6, true)?,
        ),
    };
    let z_shift = crate::reader::metre_shift(kind);
    let z_unit = 10f64.powi(z_shift);
    let z_scale = metres_scaled(
        root,
        "Record1/Axes/CZ/Increment",
        Some(z_unit),
        z_shift,
        true,
    )?;
    let z_offset = metres_scaled(root, "Record1/Axes/CZ/Offset", Some(0.0), z_shift, false)?;
    let dt_path = "Record1/Axes/CZ/DataType";
    let dtype = match required(root, dt_path)? {
        "I" => DataType::I16,
        "L" => DataType::I32,
        "F" => DataType::F32,
        "D" => DataType::F64,
        other => {
            return Err(bad(
                dt_path,
                other,
                "I, L, F or D (int16, int32, float32, float64)",
            ));
        }
    };

    // Matrix and data links.
    let nx = size_at(root, "Record3/MatrixDimension/SizeX")?;
    let ny = size_at(root, "Record3/MatrixDimension/SizeY")?;
    if let Some(s) = text_at(root, "Record3/MatrixDimension/SizeZ")
        && s != "1"
    {
        return Err(bad(
            "Record3/MatrixDimension/SizeZ",
            s,
            "1 (one layer of heights)",
        ));
    }
    if at(root, "Record3/DataLink").is_none() && at(root, "Record3/DataList").is_some() {
        return Err(bad(
            "Record3/DataList",
            "(values inline in main.xml)",
            "binary data in a member (Record3/DataLink); inline DataList files are not read",
        ));
    }
    let data_link = required(root, "Record3/DataLink/PointDataLink")?;
    if data_link.is_empty() {
        return Err(bad(
            "Record3/DataLink/PointDataLink",
            data_link,
            "the name of the data member, e.g. bindata/data.bin",
        ));
    }
    let checksum_file = text_at(root, "Record4/ChecksumFile")
        .filter(|s| !s.is_empty())
        .unwrap_or("md5checksum.hex");
    Ok(Header {
        nx,
        ny,
        pitch,
        z_scale,
        z_offset,
        dtype,
        data_link: data_link.to_string(),
        data_md5: text_at(root, "Record3/DataLink/MD5ChecksumPointData")
            .filter(|s| !s.is_empty())
            .map(str::to_string),
        valid_link: text_at(root, "Record3/DataLink/ValidPointsLink")
            .filter(|s| !s.is_empty())
            .map(str::to_string),
        valid_md5: text_at(root, "Record3/DataLink/MD5ChecksumValidPoints")
            .filter(|s| !s.is_empty())
            .map(str::to_string),
        checksum_file: checksum_file.to_string(),
        meta,
    })
}

/// A member's bytes (at most the limit asked for) and, when asked for, their MD5
/// (lower-case hex).
type Member = (Vec<u8>, Option<String>);

/// Reads member `name`, at most `limit` bytes of it (so that a zip bomb or a lying header
/// cannot exhaust memory); with `hash`, also its MD5.
fn read_member<R: Read + Seek>(
    archive: &mut zip::ZipArchive<R>,
    name: &str,
    hash: bool,
    limit: u64,
) -> Result<Option<Member>, X3pError> {
    let mut buf = Vec::new();
    let read = stream_member(archive, name, hash, limit, &mut buf)?;
    Ok(read.map(|(_, digest)| (buf, digest)))
}

/// Where [`stream_member`] puts a member's bytes.
trait Sink {
    /// Called once before the first chunk, with a capacity hint in bytes.
    fn reserve(&mut self, hint: usize);
    /// One chunk of the member, in order.
    fn take(&mut self, chunk: &[u8]);
}

impl Sink for Vec<u8> {
    fn reserve(&mut self, hint: usize) {
        Vec::reserve(self, hint);
    }
    fn take(&mut self, chunk: &[u8]) {
        self.extend_from_slice(chunk);
    }
}

/// Decodes `data.bin` into heights as it is inflated: at most `n` points of `dtype`,
/// `raw × scale (+ offset)`.
struct Points {
    z: Vec<f64>,
    n: usize,
    dtype: DataType,
    scale: f64,
    offset: f64,
}

impl Sink for Points {
    fn reserve(&mut self, hint: usize) {
        self.z.reserve((hint / self.dtype.width()).min(self.n));
    }
    fn take(&mut self, chunk: &[u8]) {
        let room = self.n - self.z.len();
        let (dtype, scale, offset) = (self.dtype, self.scale, self.offset);
        self.z.extend(
            chunk
                .chunks_exact(dtype.width())
                .take(room)
                .map(|c| scaled(dtype.decode(c), scale, offset)),
        );
    }
}

/// A point's value from its raw number, `raw × scale (+ offset)`: the one formula of
/// both ways of reading `data.bin`, so that their heights are the same bit for bit.
#[inline]
fn scaled(raw: f64, scale: f64, offset: f64) -> f64 {
    let z = raw * scale;
    if offset == 0.0 { z } else { z + offset }
}

/// Heights read from `data.bin`, the number of bytes it inflated to (or as many as were
/// read, at most one past what the header implies) and its MD5 (lower-case hex).
type Heights = (Vec<f64>, u64, Option<String>);

/// Decodes float64 points in place: `chunk` holds their little-endian bytes.
fn decode_f64(chunk: &mut [f64], scale: f64, offset: f64) {
    for v in chunk {
        *v = scaled(f64::from_bits(u64::from_le(v.to_bits())), scale, offset);
    }
}

/// Reads a float64 member `name` of `n` points straight into the heights' own vector:
/// the zip crate inflates each [`STREAM_CHUNK`] of the member into the vector's bytes
/// (checking its CRC-32 at the end and refusing more bytes than the archive declares),
/// and the points are then decoded where they lie, `raw × scale (+ offset)`, so that
/// nothing is copied and no buffer but the heights is held. With `hash`, the MD5 is
/// computed on a second thread for a large member, a chunk at a time as it is
/// inflated; that thread also decodes each chunk it hashes while no other waits for it,
/// else hands it back to the reading thread to decode, so that whichever thread is the
/// faster (inflating or hashing, depending on how well the data compressed) takes the
/// decoding. Returns the heights, the number of bytes read (at most `8n + 1`: more
/// than `8n` means the member is too long; fewer, too short, and the heights are then
/// not decoded) and the MD5 (lower-case hex); `None` when there is no such member.
fn read_f64_member<R: Read + Seek>(
    archive: &mut zip::ZipArchive<R>,
    name: &str,
    hash: bool,
    n: usize,
    scale: f64,
    offset: f64,
) -> Result<Option<Heights>, X3pError> {
    let mut file = match archive.by_name(name) {
        Ok(f) => f,
        Err(zip::result::ZipError::FileNotFound) => return Ok(None),
        Err(e) => return Err(zip_error(&format!("member {name:?}"), &e)),
    };
    let zip_err = |e: std::io::Error| io_error(&format!("member {name:?}"), &e);
    // Sized by the header, which the caller has checked against the compressed size
    // and the archive's declared size; zeroed pages are mapped as they are first
    // written, so a member shorter than that costs only what it holds.
    let mut z = vec![0.0f64; n];
    let step = STREAM_CHUNK / 8;
    let mut total = 0u64;
    // Fills `chunk` from the member; false once the member has ended (short).
    let mut fill = |chunk: &mut [f64]| -> Result<bool, X3pError> {
        let bytes: &mut [u8] = bytemuck::cast_slice_mut(chunk);
        let mut at = 0;
        while at < bytes.len() {
            match file.read(&mut bytes[at..]) {
                Ok(0) => break,
                Ok(k) => at += k,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => return Err(zip_err(e)),
            }
        }
        total += at as u64;
        Ok(at == bytes.len())
    };
    let mut whole = true;
    let digest = if !hash || n * 8 < 8 * STREAM_CHUNK {
        let mut h = hash.then(Md5::new);
        for chunk in z.chunks_mut(step) {
            whole = fill(chunk)?;
            if let Some(h) = &mut h {
                h.update(bytemuck::cast_slice::<f64, u8>(chunk));
            }
            if !whole {
                break;
            }
            decode_f64(chunk, scale, offset);
        }
        h.map(|h| hex(&h.finalize()))
    } else {
        let digest = std::thread::scope(|scope| {
            // Each chunk goes from the checksum thread (fresh) to the reader, back to it
            // (filled), and possibly back to the reader (hashed, still raw).
            let (fresh_tx, fresh_rx) = std::sync::mpsc::channel::<&mut [f64]>();
            let (filled_tx, filled_rx) = std::sync::mpsc::channel::<&mut [f64]>();
            let (raw_tx, raw_rx) = std::sync::mpsc::channel::<&mut [f64]>();
            let mut chunks = z.chunks_mut(step);
            let hasher = scope.spawn(move || {
                let mut h = Md5::new();
                let mut fresh_tx = Some(fresh_tx);
                let mut queue = std::collections::VecDeque::new();
                // Chunks handed to the reader and not yet back.
                let mut out = 0;
                loop {
                    queue.extend(filled_rx.try_iter());
                    // Keep the reader a few chunks ahead; while nothing waits to be
                    // hashed, first touch each page of a chunk, so that the reader does
                    // not stop for the page faults.
                    while out < AHEAD
                        && let Some(tx) = &fresh_tx
                    {
                        let Some(chunk) = chunks.next() else {
                            // The reader's loop ends once it has taken the last one.
                            fresh_tx = None;
                            break;
                        };
                        if queue.is_empty() {
                            for v in chunk.iter_mut().step_by(PAGE / 8) {
                                *v = 0.0;
                            }
                        }
                        if tx.send(chunk).is_err() {
                            fresh_tx = None;
                            break;
                        }
                        out += 1;
                    }
                    let Some(chunk) = queue.pop_front() else {
                        match filled_rx.recv() {
                            Ok(chunk) => {
                                queue.push_back(chunk);
                                continue;
                            }
                            // The reader has stopped.
                            Err(_) => break,
                        }
                    };
                    out -= 1;
                    h.update(bytemuck::cast_slice::<f64, u8>(chunk));
                    if queue.is_empty() {
                        decode_f64(chunk, scale, offset);
                    } else {
                        // The reader may have stopped already.
                        let _ = raw_tx.send(chunk);
                    }
                }
                hex(&h.finalize())
            });
            let read = (|| {
                for chunk in &fresh_rx {
                    whole = fill(chunk)?;
                    if filled_tx.send(chunk).is_err() {
                        return Err(X3pError::Zip(format!(
                            "member {name:?}: checksum thread stopped"
                        )));
                    }
                    for chunk in raw_rx.try_iter() {
                        decode_f64(chunk, scale, offset);
                    }
                    if !whole {
                        break;
                    }
                }
                Ok(())
            })();
            drop((filled_tx, fresh_rx));
            // The rest come back as the checksum thread finishes (then the channel closes).
            for chunk in raw_rx {
                decode_f64(chunk, scale, offset);
            }
            let digest = hasher
                .join()
                .map_err(|_| X3pError::Zip(format!("member {name:?}: checksum thread failed")));
            read.and(digest)
        })?;
        Some(digest)
    };
    if whole {
        // One byte more tells "too long" from "just right"; at the end of the member
        // the zip crate checks its CRC-32 (an error here if it does not match).
        let mut probe = [0u8; 1];
        let k = loop {
            match file.read(&mut probe) {
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                r => break r.map_err(zip_err)?,
            }
        };
        total += k as u64;
    }
    Ok(Some((z, total, digest)))
}

/// Whether inflating a `data.bin` of `len` bytes whole ([`inflate_whole`]) is faster
/// than streaming it. Whole, libdeflate inflates about twice as fast as the zip crate
/// streams, but the MD5 (500–600 MB/s, the slowest step) can only start once it is done;
/// streamed, the MD5 of a large member runs on a second thread as it is inflated, and
/// the read takes about as long as the slower of the two alone. So whole pays when
/// there is no MD5 to compute, when the member is small enough for its MD5 to be
/// computed on the reading thread either way (below `8 ×` [`STREAM_CHUNK`]), or when
/// there is no second core to overlap it on (then the smaller total work wins).
fn whole_pays(hash: bool, len: u64) -> bool {
    !hash
        || len < 8 * STREAM_CHUNK as u64
        || std::thread::available_parallelism().map_or(true, |p| p.get() < 2)
}

/// Most a `data.bin` member that declares `declared` bytes may take compressed to be
/// inflated whole ([`inflate_whole`]): half its inflated size plus [`WHOLE_SLACK`], so
/// that even a copy of its compressed bytes next to the heights would keep a read within
/// 1.5 times the heights' size plus a constant.
fn whole_limit(declared: u64) -> u64 {
    declared / 2 + WHOLE_SLACK
}

/// A member's raw deflate stream (borrowed from the archive's bytes or read from the
/// archive) and the CRC-32 the archive declares for it.
type Packed<'b> = (std::borrow::Cow<'b, [u8]>, u32);

/// The raw deflate stream of member `name` and the CRC-32 the archive declares for it,
/// when the member is deflated, not encrypted and small enough compressed
/// ([`whole_limit`]); `None` otherwise, and when there is no such member, for the
/// streaming path to handle (and report) as it always has. The stream is a slice of
/// the archive's own `bytes` when they are in memory (nothing is copied), else it is
/// read from the archive (`archive_len` bytes long, which bounds the buffer).
fn whole_member<'b, R: Read + Seek>(
    archive: &mut zip::ZipArchive<R>,
    bytes: Option<&'b [u8]>,
    archive_len: u64,
    name: &str,
) -> Result<Option<Packed<'b>>, X3pError> {
    let Some(index) = archive.index_for_name(name) else {
        return Ok(None);
    };
    let f = archive
        .by_index_raw(index)
        .map_err(|e| zip_error(&format!("member {name:?}"), &e))?;
    if f.compression() != zip::CompressionMethod::Deflated
        || f.encrypted()
        || f.compressed_size() > whole_limit(f.size())
    {
        return Ok(None);
    }
    let crc = f.crc32();
    let Some(bytes) = bytes else {
        let capacity = f.compressed_size().min(archive_len);
        let mut packed = Vec::with_capacity(usize::try_from(capacity).unwrap_or(0));
        let mut f = f;
        f.read_to_end(&mut packed)
            .map_err(|e| io_error(&format!("member {name:?}"), &e))?;
        return Ok(Some((std::borrow::Cow::Owned(packed), crc)));
    };
    let packed = f.data_start().and_then(|start| {
        let start = usize::try_from(start).ok()?;
        let end = start.checked_add(usize::try_from(f.compressed_size()).ok()?)?;
        bytes.get(start..end)
    });
    Ok(packed.map(|p| (std::borrow::Cow::Borrowed(p), crc)))
}

/// Inflates `data.bin` whole with libdeflate: `packed` (its raw deflate stream) straight
/// into the heights' own bytes for float64 points (decoded where they lie afterwards),
/// into a buffer of the member's size for narrower ones (then decoded into the
/// heights). The output is sized for exactly the `n` points the header implies (which
/// the archive declares too, [`whole_member`]): a stream that inflates to more is an
/// error, one that inflates to fewer leaves the heights empty for the caller to report.
/// The CRC-32 the archive declares is checked here (a raw deflate stream carries none);
/// with `hash` the MD5 is computed too, for a large member on a second thread, chunk by
/// chunk, while this one takes the CRC-32 and the decoding. Returns the heights, the
/// number of bytes inflated and the MD5 (lower-case hex).
#[allow(clippy::too_many_arguments)]
fn inflate_whole(
    packed: &[u8],
    crc32: u32,
    name: &str,
    hash: bool,
    n: usize,
    dtype: DataType,
    scale: f64,
    offset: f64,
) -> Result<Heights, X3pError> {
    let width = dtype.width();
    // n <= MAX_POINTS, so this does not overflow.
    let len = n * width;
    let inflate = |out: &mut [u8]| -> Result<usize, X3pError> {
        libdeflater::Decompressor::new()
            .deflate_decompress(packed, out)
            .map_err(|e| match e {
                libdeflater::DecompressionError::BadData => X3pError::Zip(format!(
                    "member {name:?}: corrupt deflate stream (it does not inflate)"
                )),
                libdeflater::DecompressionError::InsufficientSpace => X3pError::Zip(format!(
                    "member {name:?}: inflates to more than its declared uncompressed size \
                     of {len} bytes"
                )),
            })
    };
    let check_crc = |computed: u32| {
        if computed == crc32 {
            Ok(())
        } else {
            Err(X3pError::Zip(format!(
                "member {name:?}: CRC-32 of the inflated bytes is {computed:08x} but the \
                 archive declares {crc32:08x}: the archive is corrupt"
            )))
        }
    };
    let failed = || X3pError::Zip(format!("member {name:?}: checksum thread failed"));
    let threaded = hash && len >= 8 * STREAM_CHUNK;
    if dtype != DataType::F64 {
        let mut raw = vec![0u8; len];
        let k = inflate(&mut raw)?;
        let raw = &raw[..k];
        let (crc, digest) = std::thread::scope(|scope| {
            let hasher = threaded.then(|| scope.spawn(|| md5_hex(raw)));
            let crc = libdeflater::crc32(raw);
            let digest = match hasher {
                Some(h) => Some(h.join().map_err(|_| failed())?),
                None => hash.then(|| md5_hex(raw)),
            };
            Ok::<_, X3pError>((crc, digest))
        })?;
        check_crc(crc)?;
        if k < len {
            return Ok((Vec::new(), k as u64, None));
        }
        let z = raw
            .chunks_exact(width)
            .map(|c| scaled(dtype.decode(c), scale, offset))
            .collect();
        return Ok((z, len as u64, digest));
    }
    // Zeroed pages are mapped as they are first written: the inflate is the first.
    let mut z = vec![0.0f64; n];
    let k = inflate(bytemuck::cast_slice_mut(&mut z))?;
    if k < len {
        check_crc(libdeflater::crc32(&bytemuck::cast_slice(&z)[..k]))?;
        return Ok((Vec::new(), k as u64, None));
    }
    let step = STREAM_CHUNK / 8;
    let mut crc = libdeflater::Crc::new();
    let digest = if threaded {
        let digest = std::thread::scope(|scope| {
            // Each chunk goes to the checksum thread (its CRC-32 taken) and comes back
            // hashed, to be decoded.
            let (tx, rx) = std::sync::mpsc::channel::<&mut [f64]>();
            let (back_tx, back_rx) = std::sync::mpsc::channel::<&mut [f64]>();
            let hasher = scope.spawn(move || {
                let mut h = Md5::new();
                for chunk in rx {
                    h.update(bytemuck::cast_slice::<f64, u8>(chunk));
                    // This thread's receiver lives until the end of the scope.
                    let _ = back_tx.send(chunk);
                }
                hex(&h.finalize())
            });
            for chunk in z.chunks_mut(step) {
                crc.update(bytemuck::cast_slice::<f64, u8>(chunk));
                if tx.send(chunk).is_err() {
                    break;
                }
                for chunk in back_rx.try_iter() {
                    decode_f64(chunk, scale, offset);
                }
            }
            drop(tx);
            // The rest come back as the checksum thread finishes (then the channel closes).
            for chunk in back_rx {
                decode_f64(chunk, scale, offset);
            }
            hasher.join().map_err(|_| failed())
        })?;
        Some(digest)
    } else {
        let mut h = hash.then(Md5::new);
        for chunk in z.chunks_mut(step) {
            let b = bytemuck::cast_slice::<f64, u8>(chunk);
            crc.update(b);
            if let Some(h) = &mut h {
                h.update(b);
            }
            decode_f64(chunk, scale, offset);
        }
        h.map(|h| hex(&h.finalize()))
    };
    check_crc(crc.sum())?;
    Ok((z, len as u64, digest))
}

/// Inflates member `name` chunk by chunk into `sink`, at most `limit` bytes of it (so
/// that a zip bomb or a lying header cannot exhaust memory), without holding the whole
/// member: every chunk but the last is [`STREAM_CHUNK`] bytes (a multiple of every
/// point width). [`Sink::reserve`] is called first with a capacity hint, the declared
/// size bounded by what the compressed bytes can inflate to. With `hash`, the MD5 of the
/// bytes is computed too, on a second thread for a large member (each chunk goes to it
/// once `sink` has seen it, while the next one is being inflated). Returns the number
/// of bytes read and the MD5 (lower-case hex); `None` when there is no such member.
fn stream_member<R: Read + Seek>(
    archive: &mut zip::ZipArchive<R>,
    name: &str,
    hash: bool,
    limit: u64,
    sink: &mut impl Sink,
) -> Result<Option<(u64, Option<String>)>, X3pError> {
    let file = match archive.by_name(name) {
        Ok(f) => f,
        Err(zip::result::ZipError::FileNotFound) => return Ok(None),
        Err(e) => return Err(zip_error(&format!("member {name:?}"), &e)),
    };
    let zip_err = |e: std::io::Error| io_error(&format!("member {name:?}"), &e);
    // The declared size is only a capacity hint (it may lie in a corrupt file): bounded
    // by what the compressed bytes can inflate to (deflate's ratio is below 1032:1).
    let declared = file.size();
    let plausible = file
        .compressed_size()
        .saturating_mul(1032)
        .saturating_add(64);
    sink.reserve(
        usize::try_from(declared.min(limit).min(plausible))
            .unwrap_or(0)
            .min(1 << 28),
    );
    let mut file = file.take(limit);
    let mut total = 0u64;
    // One chunk: inflated into `chunk` (cleared first); false at the end of the member.
    let mut next = |chunk: &mut Vec<u8>| -> Result<bool, X3pError> {
        chunk.clear();
        let n = (&mut file)
            .take(STREAM_CHUNK as u64)
            .read_to_end(chunk)
            .map_err(zip_err)?;
        total += n as u64;
        Ok(n > 0)
    };
    if !hash || declared < 8 * STREAM_CHUNK as u64 {
        let mut h = hash.then(Md5::new);
        let mut chunk = Vec::with_capacity(STREAM_CHUNK);
        while next(&mut chunk)? {
            sink.take(&chunk);
            if let Some(h) = &mut h {
                h.update(&chunk);
            }
        }
        return Ok(Some((total, h.map(|h| hex(&h.finalize())))));
    }
    let digest = std::thread::scope(|scope| {
        let (tx, rx) = std::sync::mpsc::sync_channel::<Vec<u8>>(4);
        let (back_tx, back_rx) = std::sync::mpsc::channel::<Vec<u8>>();
        let hasher = scope.spawn(move || {
            let mut h = Md5::new();
            for chunk in rx {
                h.update(&chunk);
                // Hand the buffer back for reuse; the reader may have stopped already.
                let _ = back_tx.send(chunk);
            }
            hex(&h.finalize())
        });
        let read = (|| {
            loop {
                let mut chunk = back_rx
                    .try_recv()
                    .unwrap_or_else(|_| Vec::with_capacity(STREAM_CHUNK));
                if !next(&mut chunk)? {
                    return Ok(());
                }
                sink.take(&chunk);
                if tx.send(chunk).is_err() {
                    return Err(X3pError::Zip(format!(
                        "member {name:?}: checksum thread stopped"
                    )));
                }
            }
        })();
        drop(tx);
        let digest = hasher
            .join()
            .map_err(|_| X3pError::Zip(format!("member {name:?}: checksum thread failed")));
        read.and(digest)
    })?;
    Ok(Some((total, Some(digest))))
}

/// Bytes inflated per step by [`stream_member`] (1 MiB, a multiple of every point
/// width).
const STREAM_CHUNK: usize = 1 << 20;

/// The constant part of [`whole_limit`] (48 MiB).
const WHOLE_SLACK: u64 = 48 << 20;

/// Chunks that [`read_f64_member`]'s checksum thread keeps ready for the reader.
const AHEAD: usize = 4;

/// The memory page size assumed when touching pages ahead of the reader (a smaller
/// real one only leaves some faults to the reader).
const PAGE: usize = 4096;

/// Deepest `Record2` element whose text goes into the metadata (ISO 25178-72 nests
/// two levels, e.g. `Instrument/Manufacturer`).
const RECORD2_DEPTH: usize = 6;

/// Largest number of points loaded (16384², 2 GiB of float64 heights).
const MAX_POINTS: usize = 1 << 28;

/// The first `n` bits of `valid.bin`, least significant bit of each byte first
/// (`bits` holds at least `n` of them). Built eight points at a time straight into a
/// vector of their final size (no mask of `true` written first).
fn unpack_bits(bits: &[u8], n: usize) -> Vec<bool> {
    let mut valid = Vec::with_capacity(n);
    for &byte in &bits[..n / 8] {
        valid.extend_from_slice(&std::array::from_fn::<bool, 8, _>(|k| byte >> k & 1 == 1));
    }
    if let Some(&last) = bits.get(n / 8) {
        valid.extend((0..n % 8).map(|k| last >> k & 1 == 1));
    }
    valid
}

/// Upper bound on the size of `main.xml` and `md5checksum.hex` read into memory.
const XML_LIMIT: u64 = 64 << 20;

fn is_junk(name: &str) -> bool {
    name.starts_with("__MACOSX/")
        || name.contains("/__MACOSX/")
        || name.rsplit('/').next().is_some_and(|b| b.starts_with("._"))
}

/// Checks `computed` against `declared`; on mismatch either fails or records it.
fn check_md5(
    member: &str,
    computed: &str,
    declared: Result<&str, String>,
    options: &ReadOptions,
    notes: &mut Vec<String>,
) -> Result<(), X3pError> {
    let problem = match declared {
        Ok(d) if d.eq_ignore_ascii_case(computed) => return Ok(()),
        Ok(d) => X3pError::Md5Mismatch {
            member: member.to_string(),
            computed: computed.to_string(),
            declared: d.to_string(),
        },
        Err(where_) => X3pError::MissingChecksum {
            member: member.to_string(),
            where_,
        },
    };
    if options.accept_md5_mismatch {
        notes.push(problem.to_string());
        Ok(())
    } else {
        Err(problem)
    }
}

/// Opens the archive (the file's bytes, or a reader over them) and reads `main.xml`
/// (the shallowest one that is not macOS junk): the archive, the folder prefix of the
/// members (`""` or `"name/"`) and the XML bytes.
fn open<R: Read + Seek>(reader: R) -> Result<(zip::ZipArchive<R>, String, Vec<u8>), X3pError> {
    let mut archive = zip::ZipArchive::new(reader).map_err(|e| match e {
        zip::result::ZipError::Io(io) => io_error("the archive", &io),
        other => X3pError::Zip(other.to_string()),
    })?;
    let mut names = Vec::new();
    for name in archive.file_names() {
        names.push(name.map_err(|e| X3pError::Zip(e.to_string()))?.into_owned());
    }
    let main = names
        .iter()
        .filter(|n| !is_junk(n) && (*n == "main.xml" || n.ends_with("/main.xml")))
        .min_by_key(|n| n.matches('/').count())
        .ok_or_else(|| X3pError::MissingMember("main.xml".to_string()))?
        .clone();
    let prefix = main[..main.len() - "main.xml".len()].to_string();
    let (xml_bytes, _) = read_member(&mut archive, &main, false, XML_LIMIT)?
        .ok_or_else(|| X3pError::MissingMember(main.clone()))?;
    Ok((archive, prefix, xml_bytes))
}

/// The bytes of the archive's `main.xml` (for [`crate::quantity`]).
pub(crate) fn main_xml<R: Read + Seek>(reader: R) -> Result<Vec<u8>, X3pError> {
    open(reader).map(|(_, _, xml)| xml)
}

fn parse_xml(xml_bytes: &[u8]) -> Result<Document<'_>, X3pError> {
    let xml =
        std::str::from_utf8(xml_bytes).map_err(|e| X3pError::Xml(format!("not UTF-8: {e}")))?;
    Document::parse(xml).map_err(|e| X3pError::Xml(e.to_string()))
}

/// The one channel of an X3P file (`Z`, unit `m`), from `main.xml` alone.
///
/// # Errors
/// [`X3pError`] naming the member or element at fault.
pub fn channels(bytes: &[u8], options: &ReadOptions) -> Result<Vec<Channel>, X3pError> {
    channels_from(Cursor::new(bytes), options)
}

/// [`channels`] of an X3P archive read through `reader` (a file, say).
///
/// # Errors
/// As [`channels`], and [`X3pError::Read`] for a read that fails for the system's
/// reason (a damaged archive stays [`X3pError::Zip`]).
pub fn channels_from<R: Read + Seek>(
    reader: R,
    options: &ReadOptions,
) -> Result<Vec<Channel>, X3pError> {
    let (_, _, xml_bytes) = open(reader)?;
    let doc = parse_xml(&xml_bytes)?;
    let h = parse_header(doc.root_element(), options, ValueKind::Height)?;
    Ok(vec![Channel {
        name: "Z".into(),
        unit: Some("m".into()),
        nx: h.nx,
        ny: h.ny,
        pitch_um: Some(h.pitch),
    }])
}

/// Reads an X3P file held in memory. Heights and pitch come back in µm.
///
/// # Errors
/// [`X3pError`] naming the member, element or checksum at fault.
pub fn read_x3p_bytes(bytes: &[u8], options: &ReadOptions) -> Result<HeightMap, X3pError> {
    read(bytes, options, ValueKind::Height)
}

/// Reads an X3P file held in memory: heights (`Offset + raw × Increment` metres, in µm)
/// or intensities (`Offset + raw × Increment` as stored).
///
/// # Errors
/// [`X3pError`] naming the member, element or checksum at fault.
pub fn read(bytes: &[u8], options: &ReadOptions, kind: ValueKind) -> Result<HeightMap, X3pError> {
    read_with(Cursor::new(bytes), Some(bytes), options, kind, Path::Auto).map(|(map, _)| map)
}

/// [`read`] of an X3P archive read through `reader` (a file, say) instead of held in
/// memory: the members are inflated as they are read, so the archive's bytes are never
/// held whole (`data.bin`, when it is inflated in one call, is first read into a buffer
/// of its compressed size).
///
/// # Errors
/// As [`read`], and [`X3pError::Read`] for a read that fails for the system's reason
/// (a damaged archive stays [`X3pError::Zip`]).
pub fn read_from<R: Read + Seek>(
    reader: R,
    options: &ReadOptions,
    kind: ValueKind,
) -> Result<HeightMap, X3pError> {
    read_with(reader, None, options, kind, Path::Auto).map(|(map, _)| map)
}

/// Which way `data.bin` is read ([`read_with`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Path {
    /// [`inflate_whole`] when it pays ([`whole_pays`]) and the member qualifies
    /// ([`whole_member`]), else [`read_f64_member`] when that applies, else
    /// [`stream_member`] into [`Points`].
    Auto,
    /// As `Auto` but never [`inflate_whole`] (only asked for by tests).
    #[cfg(test)]
    Stream,
    /// Taken: [`stream_member`] into [`Points`]; asked for (by tests): always that.
    Points,
    /// Taken: [`read_f64_member`].
    InPlace,
    /// Taken: [`inflate_whole`]; asked for (by tests): [`inflate_whole`] whenever the
    /// member qualifies, whether or not it pays.
    Whole,
}

/// [`read`], with the way `data.bin` may be read; also says which way it was read.
/// `bytes` are the archive's bytes when they are in memory (`reader` then reads them),
/// `None` when `reader` reads them from elsewhere (a file); then a `data.bin` inflated
/// whole is first read into a buffer of its compressed size.
fn read_with<R: Read + Seek>(
    mut reader: R,
    bytes: Option<&[u8]>,
    options: &ReadOptions,
    kind: ValueKind,
    path: Path,
) -> Result<(HeightMap, Path), X3pError> {
    let archive_len = match bytes {
        Some(b) => b.len() as u64,
        None => reader
            .seek(std::io::SeekFrom::End(0))
            .and_then(|len| reader.rewind().map(|()| len))
            .map_err(|e| io_error("the archive's length", &e))?,
    };
    let (mut archive, prefix, xml_bytes) = open(reader)?;
    let doc = parse_xml(&xml_bytes)?;
    let root = doc.root_element();
    let h = parse_header(root, options, kind)?;
    let (nx, ny) = (h.nx, h.ny);
    let mut map_meta = h.meta;
    if !prefix.is_empty() {
        map_meta.push(("x3p.folder".into(), prefix.trim_end_matches('/').into()));
    }
    let n = nx
        .checked_mul(ny)
        .ok_or(X3pError::Map(HeightMapError::TooLarge { nx, ny }))?;
    if n > MAX_POINTS {
        return Err(bad(
            "Record3/MatrixDimension",
            &format!("SizeX {nx} x SizeY {ny}"),
            "at most 268435456 points (16384 x 16384), the largest map this reader loads",
        ));
    }
    let width = h.dtype.width();

    let mut notes = Vec::new();
    let checksum_name = format!("{prefix}{}", h.checksum_file);
    let declared = read_member(&mut archive, &checksum_name, false, XML_LIMIT)?;
    let declared = declared.as_ref().and_then(|(b, _)| {
        std::str::from_utf8(b)
            .ok()
            .and_then(|s| s.split_whitespace().next())
            .map(str::to_string)
    });
    check_md5(
        "main.xml",
        &md5_hex(&xml_bytes),
        declared
            .as_deref()
            .ok_or_else(|| format!("member {checksum_name:?} is missing or empty")),
        options,
        &mut notes,
    )?;

    let data_name = format!("{prefix}{}", h.data_link);
    let expected = (n as u64).saturating_mul(width as u64);
    let detail = || {
        format!(
            "{nx} x {ny} points of {width} bytes, DataType {}",
            h.dtype.code()
        )
    };
    // Plausibility before any inflation: deflate expands at most 1032-fold (stored
    // members not at all), so a member whose compressed size cannot hold the data is
    // refused before a byte is allocated for it.
    let (compressed, declared_size) = match archive.by_name(&data_name) {
        Ok(f) => (Some(f.compressed_size()), Some(f.size())),
        // The system's error is reported now; the others (no such member, an
        // unsupported one) by the read below, as they always were.
        Err(zip::result::ZipError::Io(e)) if is_system(&e) => {
            return Err(io_error(&format!("member {data_name:?}"), &e));
        }
        Err(_) => (None, None),
    };
    if let Some(compressed) = compressed
        && expected > compressed.saturating_mul(1032).saturating_add(1024)
    {
        return Err(X3pError::Implausible {
            member: data_name,
            expected,
            compressed,
            detail: detail(),
        });
    }
    let hash = h.data_md5.is_some();
    // A deflated member that declares exactly the size the header implies and is small
    // enough compressed to be inflated in one go is; otherwise float64 points are
    // inflated in place as they stream, and anything else (narrower points, a size that
    // disagrees, which is then reported as it always was) is decoded chunk by chunk.
    let try_whole = match path {
        Path::Auto => whole_pays(hash, expected),
        Path::Whole => true,
        _ => false,
    };
    let whole = if try_whole && declared_size == Some(expected) {
        whole_member(&mut archive, bytes, archive_len, &data_name)?
    } else {
        None
    };
    #[cfg(test)]
    let path = if path == Path::Stream {
        Path::Auto
    } else {
        path
    };
    let in_place =
        path == Path::Auto && h.dtype == DataType::F64 && declared_size == Some(expected);
    let (z, read_len, computed, path) = if let Some((packed, crc32)) = whole {
        let (z, read_len, computed) = inflate_whole(
            &packed, crc32, &data_name, hash, n, h.dtype, h.z_scale, h.z_offset,
        )?;
        (z, read_len, computed, Path::Whole)
    } else if in_place {
        let (z, read_len, computed) =
            read_f64_member(&mut archive, &data_name, hash, n, h.z_scale, h.z_offset)?
                .ok_or_else(|| X3pError::MissingMember(data_name.clone()))?;
        (z, read_len, computed, Path::InPlace)
    } else {
        // Read one byte more than needed, to tell "too long" from "just right"; the
        // points are decoded as the member is inflated, into the heights' own vector
        // (no copy of the member's bytes is held), at most `n` of them.
        let mut points = Points {
            z: Vec::new(),
            n,
            dtype: h.dtype,
            scale: h.z_scale,
            offset: h.z_offset,
        };
        let (read_len, computed) = stream_member(
            &mut archive,
            &data_name,
            hash,
            expected.saturating_add(1),
            &mut points,
        )?
        .ok_or_else(|| X3pError::MissingMember(data_name.clone()))?;
        (points.z, read_len, computed, Path::Points)
    };
    if read_len != expected {
        let found = if read_len > expected {
            // Longer than needed: report the size the archive declares.
            archive
                .by_name(&data_name)
                .map(|f| f.size())
                .unwrap_or(read_len)
        } else {
            read_len
        };
        return Err(X3pError::DataLength {
            member: data_name,
            expected,
            found,
            detail: detail(),
        });
    }
    if let (Some(d), Some(c)) = (&h.data_md5, computed) {
        check_md5(&data_name, &c, Ok(d), options, &mut notes)?;
    }

    // The mask `valid.bin` gives, if any (else a point is valid iff its height is finite).
    let mut valid = None;
    if let Some(link) = &h.valid_link {
        let name = format!("{prefix}{link}");
        let need = n.div_ceil(8);
        // A little slack for writers that pad the member; its MD5 covers what is read.
        let limit = need as u64 + 4096;
        let (bits, _) = read_member(&mut archive, &name, false, limit + 1)?
            .ok_or_else(|| X3pError::MissingMember(name.clone()))?;
        if bits.len() < need || bits.len() as u64 > limit {
            return Err(X3pError::DataLength {
                member: name,
                expected: need as u64,
                found: bits.len() as u64,
                detail: format!("one bit per point for {n} points"),
            });
        }
        if let Some(d) = &h.valid_md5 {
            check_md5(&name, &md5_hex(&bits), Ok(d), options, &mut notes)?;
        }
        valid = Some(unpack_bits(&bits, n));
        map_meta.push(("x3p.valid_points_member".into(), link.clone()));
    }

    let (dx, dy) = h.pitch;
    let mut map = match valid {
        Some(valid) => HeightMap::with_mask(nx, ny, dx, dy, z, valid),
        None => HeightMap::new(nx, ny, dx, dy, z),
    }
    .map_err(X3pError::Map)?;
    for (k, v) in map_meta {
        map.set_metadata(k, v);
    }
    if let Some(r2) = child(root, "Record2") {
        for node in r2.descendants().filter(|d| d.is_element() && d != &r2) {
            if node.children().any(|c| c.is_element()) {
                continue;
            }
            // Record2 is a few levels deep; deeper leaves are skipped, so that a hostile
            // nesting costs no more than a few steps per element.
            let mut parts: Vec<String> = Vec::new();
            let mut reached = false;
            for a in node
                .ancestors()
                .filter(|a| a.is_element())
                .take(RECORD2_DEPTH + 1)
            {
                if a == r2 {
                    reached = true;
                    break;
                }
                parts.push(a.tag_name().name().to_lowercase());
            }
            if !reached {
                continue;
            }
            parts.reverse();
            let value = node.text().unwrap_or("").trim();
            if !value.is_empty() {
                map.set_metadata(format!("x3p.{}", parts.join(".")), value);
            }
        }
    }
    if notes.is_empty() {
        map.set_metadata("x3p.md5", "ok");
    } else {
        map.set_metadata("x3p.md5", "mismatch accepted");
        map.set_metadata("x3p.md5_mismatch", notes.join("; "));
    }
    Ok((map, path))
}

fn xml_escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for ch in s.chars() {
        match ch {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            c => out.push(c),
        }
    }
    out
}

/// Writes `map` as an X3P archive in memory: float64 heights in metres
/// (`Increment` 1e-6, so the stored raw value is the height in µm and reading it back is
/// exact), pitch written as `{dx}e-6` metres, NaN and a `valid.bin` bit for each invalid
/// point (`valid.bin` only when some point is invalid), and correct MD5 checksums.
/// Members are deflated at level 1, except a `data.bin` that a sample of does not
/// deflate to 90 % of its size (noise in every mantissa bit, as in a measured map),
/// which is stored: deflating it would make it larger and slower to read.
///
/// # Errors
/// [`ArchiveError`] if the archive cannot be assembled.
pub fn write_x3p_bytes(map: &HeightMap) -> Result<Vec<u8>, ArchiveError> {
    write_x3p_with_increment(map, "1e-6")
}

/// Writes an intensity image (unit-less values) as X3P with Z `Increment` 1, so the file
/// stores the values themselves, and a `Record2/Comment` that starts with
/// [`crate::quantity::X3P_INTENSITY_MARK`], so that the file says it holds intensities
/// ([`crate::quantity`]); [`crate::read_intensity`] reads them back exactly.
///
/// # Errors
/// [`ArchiveError`] if the archive cannot be assembled.
pub fn write_intensity_x3p_bytes(map: &HeightMap) -> Result<Vec<u8>, ArchiveError> {
    write_x3p_with_increment(map, "1")
}

/// Bytes of each of the [`SAMPLE_SLICES`] slices of `data.bin` that [`deflate_pays`]
/// deflates.
const SAMPLE_SLICE: usize = 256 << 10;

/// Slices, spread evenly over `data.bin`, that [`deflate_pays`] deflates.
const SAMPLE_SLICES: usize = 8;

/// Whether `data` (a `data.bin` about to be written) is worth deflating: whether
/// [`SAMPLE_SLICES`] slices of [`SAMPLE_SLICE`] bytes spread evenly over it (all of it
/// when it is shorter than that) deflate, at the writer's level 1, to at most 90 % of
/// their size. Float64 heights with noise in every mantissa bit (a measured map, a
/// confocal localisation) do not: level 1 stores them as fixed-Huffman literals, 4–6 %
/// larger than their bytes, and inflating those bounds a read (383 MB/s for the
/// inflate alone against 593 MB/s for the MD5 of a stored member, the step that then
/// bounds it, in `docs/benchmarks.md`). Such a member is stored instead; a map with flat
/// regions or repeated values (a synthetic layer: about 13 % of its size)
/// deflates, and is deflated.
fn deflate_pays(data: &[u8]) -> std::io::Result<bool> {
    let mut sample =
        flate2::write::DeflateEncoder::new(std::io::sink(), flate2::Compression::new(1));
    let mut taken = 0u64;
    if data.len() <= SAMPLE_SLICE * SAMPLE_SLICES {
        sample.write_all(data)?;
        taken = data.len() as u64;
    } else {
        let stride = (data.len() - SAMPLE_SLICE) / (SAMPLE_SLICES - 1);
        for k in 0..SAMPLE_SLICES {
            let at = k * stride;
            sample.write_all(&data[at..at + SAMPLE_SLICE])?;
            taken += SAMPLE_SLICE as u64;
        }
    }
    sample.try_finish()?;
    Ok(sample.total_out() * 10 <= taken * 9)
}

fn write_x3p_with_increment(map: &HeightMap, z_increment: &str) -> Result<Vec<u8>, ArchiveError> {
    let intensity = z_increment == "1";
    let zerr = |e: zip::result::ZipError| ArchiveError(e.to_string());
    let ioerr = |e: std::io::Error| ArchiveError(e.to_string());

    let mut data = Vec::with_capacity(map.len() * 8);
    for (&z, &v) in map.heights().iter().zip(map.valid()) {
        let z = if v { z } else { f64::NAN };
        data.extend_from_slice(&z.to_le_bytes());
    }
    let any_invalid = map.valid_count() < map.len();
    let bits = any_invalid.then(|| {
        let mut bits = vec![0u8; map.len().div_ceil(8)];
        for (i, _) in map.valid().iter().enumerate().filter(|(_, v)| **v) {
            bits[i / 8] |= 1 << (i % 8);
        }
        bits
    });

    // The map's own X3P fields, else what its metadata says of another format's file
    // (crate::provenance), else the placeholder.
    let carried = crate::provenance::Provenance::of(map);
    let comment = crate::provenance::Provenance::x3p_comment(map);
    let comment = crate::quantity::x3p_comment(
        map.metadata()
            .get("x3p.comment")
            .cloned()
            .or(comment)
            .unwrap_or_else(|| {
                concat!("written by flakescatter ", env!("CARGO_PKG_VERSION")).to_string()
            }),
        intensity,
    );
    let meta = |key: &str, default: &str| {
        let from_source = match key {
            "x3p.date" => carried.date.as_deref(),
            "x3p.instrument.manufacturer" => carried.manufacturer.as_deref(),
            "x3p.instrument.model" => carried.model.as_deref(),
            "x3p.instrument.serial" => carried.serial.as_deref(),
            "x3p.comment" => Some(comment.as_str()),
            _ => None,
        };
        // The comment is decided above (it says which quantity the file holds).
        let own = if key == "x3p.comment" {
            None
        } else {
            map.metadata().get(key).map(String::as_str)
        };
        xml_escape(own.or(from_source).unwrap_or(default))
    };
    let valid_link = match &bits {
        Some(b) => format!(
            "\n      <ValidPointsLink>bindata/valid.bin</ValidPointsLink>\n      \
             <MD5ChecksumValidPoints>{}</MD5ChecksumValidPoints>",
            md5_hex(b)
        ),
        None => String::new(),
    };
    let xml = format!(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<p:ISO5436_2 xmlns:p="http://www.opengps.eu/2008/ISO5436_2" xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xsi:schemaLocation="http://www.opengps.eu/2008/ISO5436_2 http://www.opengps.eu/2008/ISO5436_2/ISO5436_2.xsd">
  <Record1>
    <Revision>ISO5436 - 2000</Revision>
    <FeatureType>SUR</FeatureType>
    <Axes>
      <CX>
        <AxisType>I</AxisType>
        <DataType>D</DataType>
        <Increment>{dx}e-6</Increment>
        <Offset>0</Offset>
      </CX>
      <CY>
        <AxisType>I</AxisType>
        <DataType>D</DataType>
        <Increment>{dy}e-6</Increment>
        <Offset>0</Offset>
      </CY>
      <CZ>
        <AxisType>A</AxisType>
        <DataType>D</DataType>
        <Increment>{z_increment}</Increment>
        <Offset>0</Offset>
      </CZ>
    </Axes>
  </Record1>
  <Record2>
    <Date>{date}</Date>
    <Creator>{creator}</Creator>
    <Instrument>
      <Manufacturer>{manufacturer}</Manufacturer>
      <Model>{model}</Model>
      <Serial>{serial}</Serial>
      <Version>{version}</Version>
    </Instrument>
    <CalibrationDate>{date}</CalibrationDate>
    <ProbingSystem>
      <Type>Software</Type>
      <Identification>flakescatter</Identification>
    </ProbingSystem>
    <Comment>{comment}</Comment>
  </Record2>
  <Record3>
    <MatrixDimension>
      <SizeX>{nx}</SizeX>
      <SizeY>{ny}</SizeY>
      <SizeZ>1</SizeZ>
    </MatrixDimension>
    <DataLink>
      <PointDataLink>bindata/data.bin</PointDataLink>
      <MD5ChecksumPointData>{data_md5}</MD5ChecksumPointData>{valid_link}
    </DataLink>
  </Record3>
  <Record4>
    <ChecksumFile>md5checksum.hex</ChecksumFile>
  </Record4>
</p:ISO5436_2>
"#,
        dx = map.dx(),
        dy = map.dy(),
        date = meta("x3p.date", "1970-01-01T00:00:00"),
        creator = meta("x3p.creator", "flakescatter"),
        manufacturer = meta("x3p.instrument.manufacturer", "N/A"),
        model = meta("x3p.instrument.model", "N/A"),
        serial = meta("x3p.instrument.serial", "N/A"),
        version = meta("x3p.instrument.version", "N/A"),
        comment = meta("x3p.comment", ""),
        nx = map.nx(),
        ny = map.ny(),
        data_md5 = md5_hex(&data),
    );
    let checksum = format!("{} *main.xml\n", md5_hex(xml.as_bytes()));

    let mut zip = zip::ZipWriter::new(Cursor::new(Vec::new()));
    let opts = zip::write::SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated)
        .compression_level(Some(1));
    zip.start_file("main.xml", opts).map_err(zerr)?;
    zip.write_all(xml.as_bytes()).map_err(ioerr)?;
    zip.start_file("md5checksum.hex", opts).map_err(zerr)?;
    zip.write_all(checksum.as_bytes()).map_err(ioerr)?;
    let data_opts = if deflate_pays(&data).map_err(ioerr)? {
        opts
    } else {
        opts.compression_method(zip::CompressionMethod::Stored)
            .compression_level(None)
    };
    zip.start_file("bindata/data.bin", data_opts)
        .map_err(zerr)?;
    zip.write_all(&data).map_err(ioerr)?;
    if let Some(b) = &bits {
        zip.start_file("bindata/valid.bin", opts).map_err(zerr)?;
        zip.write_all(b).map_err(ioerr)?;
    }
    Ok(zip.finish().map_err(zerr)?.into_inner())
}

#[cfg(test)]
#[path = "x3p_tests.rs"]
mod tests;

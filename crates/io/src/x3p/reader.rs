//! Reading an X3P archive: detection, the archive opened and `main.xml` found, the
//! checksums checked, `data.bin` read one of the two ways and the map assembled.

use std::io::{Cursor, Read, Seek};

use flakescatter_stats::heightmap::{HeightMap, HeightMapError};

use super::data::{Points, read_f64_member, read_member, stream_member, unpack_bits};
use super::error::{X3pError, io_error, is_system, md5_hex};
use super::header::{DataType, Header, bad, parse_header, parse_xml, record2_metadata};
use super::whole::{inflate_whole, whole_member, whole_pays};
use crate::reader::{Channel, Confidence, ReadOptions, ValueKind};

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

/// Largest number of points loaded (16384², 2 GiB of float64 heights).
const MAX_POINTS: usize = 1 << 28;

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
pub(super) enum Path {
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
pub(super) fn read_with<R: Read + Seek>(
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
    let mut h = parse_header(root, options, kind)?;
    let (nx, ny) = (h.nx, h.ny);
    let mut map_meta = std::mem::take(&mut h.meta);
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
    let (z, computed, path) = read_data(&mut archive, bytes, archive_len, &data_name, &h, path)?;
    if let (Some(d), Some(c)) = (&h.data_md5, computed) {
        check_md5(&data_name, &c, Ok(d), options, &mut notes)?;
    }

    // The mask `valid.bin` gives, if any (else a point is valid iff its height is finite).
    let mut valid = None;
    if let Some(link) = &h.valid_link {
        let name = format!("{prefix}{link}");
        valid = Some(read_valid(&mut archive, &name, &h, options, &mut notes)?);
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
    record2_metadata(root, &mut map);
    if notes.is_empty() {
        map.set_metadata("x3p.md5", "ok");
    } else {
        map.set_metadata("x3p.md5", "mismatch accepted");
        map.set_metadata("x3p.md5_mismatch", notes.join("; "));
    }
    Ok((map, path))
}

/// Reads `data.bin` (member `data_name`) of the `nx × ny` points `h` declares, the way
/// `path` allows ([`read_with`]): the heights, their MD5 when the header declares one
/// (lower-case hex) and the way taken. The member's compressed size is checked against
/// what it must inflate to before anything is allocated for it, and the size it
/// inflates to against what the header implies.
fn read_data<R: Read + Seek>(
    archive: &mut zip::ZipArchive<R>,
    bytes: Option<&[u8]>,
    archive_len: u64,
    data_name: &str,
    h: &Header,
    path: Path,
) -> Result<(Vec<f64>, Option<String>, Path), X3pError> {
    let (nx, ny) = (h.nx, h.ny);
    // The caller has checked that this does not overflow.
    let n = nx * ny;
    let width = h.dtype.width();
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
    let (compressed, declared_size) = match archive.by_name(data_name) {
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
            member: data_name.to_string(),
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
        whole_member(archive, bytes, archive_len, data_name)?
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
    let missing = || X3pError::MissingMember(data_name.to_string());
    let (z, read_len, computed, path) = if let Some((packed, crc32)) = whole {
        let (z, read_len, computed) = inflate_whole(
            &packed, crc32, data_name, hash, n, h.dtype, h.z_scale, h.z_offset,
        )?;
        (z, read_len, computed, Path::Whole)
    } else if in_place {
        let (z, read_len, computed) =
            read_f64_member(archive, data_name, hash, n, h.z_scale, h.z_offset)?
                .ok_or_else(missing)?;
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
            archive,
            data_name,
            hash,
            expected.saturating_add(1),
            &mut points,
        )?
        .ok_or_else(missing)?;
        (points.z, read_len, computed, Path::Points)
    };
    if read_len != expected {
        let found = if read_len > expected {
            // Longer than needed: report the size the archive declares.
            archive
                .by_name(data_name)
                .map(|f| f.size())
                .unwrap_or(read_len)
        } else {
            read_len
        };
        return Err(X3pError::DataLength {
            member: data_name.to_string(),
            expected,
            found,
            detail: detail(),
        });
    }
    Ok((z, computed, path))
}

/// Reads `valid.bin` (member `name`): one bit per point of the `nx × ny` that `h`
/// declares, checked against its MD5 when the header declares one.
fn read_valid<R: Read + Seek>(
    archive: &mut zip::ZipArchive<R>,
    name: &str,
    h: &Header,
    options: &ReadOptions,
    notes: &mut Vec<String>,
) -> Result<Vec<bool>, X3pError> {
    // The caller has checked that this does not overflow.
    let n = h.nx * h.ny;
    let need = n.div_ceil(8);
    // A little slack for writers that pad the member; its MD5 covers what is read.
    let limit = need as u64 + 4096;
    let (bits, _) = read_member(archive, name, false, limit + 1)?
        .ok_or_else(|| X3pError::MissingMember(name.to_string()))?;
    if bits.len() < need || bits.len() as u64 > limit {
        return Err(X3pError::DataLength {
            member: name.to_string(),
            expected: need as u64,
            found: bits.len() as u64,
            detail: format!("one bit per point for {n} points"),
        });
    }
    if let Some(d) = &h.valid_md5 {
        check_md5(name, &md5_hex(&bits), Ok(d), options, notes)?;
    }
    Ok(unpack_bits(&bits, n))
}

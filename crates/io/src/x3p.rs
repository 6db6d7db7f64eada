//! X3P (ISO 25178-72 / ISO 5436-2 XML 3D surface profile) reader and writer.
//!
//! An X3P file is a zip archive holding `main.xml` (the header), `md5checksum.hex` (the
//! MD5 of `main.xml`), `bindata/data.bin` (the heights) and optionally `bindata/valid.bin`
//! (one bit per point, least significant bit first, 1 = valid).
//!
//! Conventions: the Z `DataType` `I`/`L`/`F`/`D` is int16/int32/float32/float64,
//! little-endian, X fastest then Y (so X is the map's column index and Y its row index);
//! a real height is `Offset + raw × Increment` in metres, converted here to micrometres.
//! A missing Z `Increment` is taken as 1 and a missing or empty `Offset` as 0. NaN or a
//! clear `valid.bin` bit marks a point invalid. The X and Y axes must be incremental
//! (`AxisType` `I`); their `Increment` is the pixel pitch in metres.
//!
//! Real-file quirks handled: members inside a sub-folder of the zip, `__MACOSX` and other
//! extra members, root `ISO5436_2` or `ISO5436` with or without a namespace prefix
//! (elements are matched by local name), upper-case MD5 and the `hash *main.xml` form of
//! `md5checksum.hex`, non-square pixels.

use std::io::{Cursor, Read, Write};

use flakescatter_stats::heightmap::{HeightMap, HeightMapError};
use md5::{Digest, Md5};
use roxmltree::{Document, Node};
use thiserror::Error;

use crate::map::{ReadOptions, WriteMapError};
use crate::units::parse_scaled;

/// What is wrong with an X3P file.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum X3pError {
    /// The zip container is unreadable (truncated, corrupt).
    #[error("not a readable zip archive: {0}")]
    Zip(String),
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
    #[error("main.xml: element {element} = {value:?}: {expected}")]
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
    /// A checksum does not match (and the mismatch was not accepted).
    #[error(
        "MD5 of {member:?} is {computed} but the file declares {declared}; \
         the file may be corrupt (an option accepts the mismatch)"
    )]
    Md5Mismatch {
        /// The member checked.
        member: String,
        /// MD5 computed from the member, lower-case hex.
        computed: String,
        /// MD5 declared in the file.
        declared: String,
    },
    /// The header's numbers do not make a valid height map (zero size, bad pitch).
    #[error("{0}")]
    Map(HeightMapError),
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

fn md5_hex(bytes: &[u8]) -> String {
    hex(&Md5::digest(bytes))
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

/// A decimal in metres at `path` times `10^shift` (6: µm); `default` if absent or empty.
fn metres_scaled(
    node: Node<'_, '_>,
    path: &str,
    default: Option<f64>,
    shift: i32,
) -> Result<f64, X3pError> {
    match text_at(node, path) {
        Some(s) if !s.is_empty() => parse_scaled(s, shift)
            .filter(|v| v.is_finite())
            .ok_or_else(|| bad(path, s, "a finite decimal number in metres")),
        _ => default.ok_or_else(|| X3pError::MissingElement(path.to_string())),
    }
}

fn size_at(node: Node<'_, '_>, path: &str) -> Result<usize, X3pError> {
    let s = required(node, path)?;
    s.parse()
        .map_err(|_| bad(path, s, "a non-negative integer"))
}

/// A member's bytes (at most the limit asked for) and, when asked for, their MD5
/// (lower-case hex).
type Member = (Vec<u8>, Option<String>);

/// Reads member `name`, at most `limit` bytes of it (so that a zip bomb or a lying header
/// cannot exhaust memory); with `hash`, also its MD5, computed on a second thread while a
/// large member is being decompressed.
fn read_member<R: Read + std::io::Seek>(
    archive: &mut zip::ZipArchive<R>,
    name: &str,
    hash: bool,
    limit: u64,
) -> Result<Option<Member>, X3pError> {
    let file = match archive.by_name(name) {
        Ok(f) => f,
        Err(zip::result::ZipError::FileNotFound) => return Ok(None),
        Err(e) => return Err(X3pError::Zip(format!("member {name:?}: {e}"))),
    };
    let zip_err = |e: std::io::Error| X3pError::Zip(format!("member {name:?}: {e}"));
    // The declared size is only a capacity hint (it may lie in a corrupt file).
    let hint = usize::try_from(file.size().min(limit))
        .unwrap_or(0)
        .min(1 << 28);
    let declared = file.size();
    let mut file = file.take(limit);
    let mut buf = Vec::with_capacity(hint);
    const CHUNK: usize = 1 << 20;
    if !hash || declared < 8 * CHUNK as u64 {
        file.read_to_end(&mut buf).map_err(zip_err)?;
        let digest = hash.then(|| md5_hex(&buf));
        return Ok(Some((buf, digest)));
    }
    let digest = std::thread::scope(|scope| {
        let (tx, rx) = std::sync::mpsc::sync_channel::<Vec<u8>>(16);
        let hasher = scope.spawn(move || {
            let mut h = Md5::new();
            for chunk in rx {
                h.update(&chunk);
            }
            hex(&h.finalize())
        });
        let read = (|| {
            loop {
                let mut chunk = Vec::with_capacity(CHUNK);
                let n = (&mut file)
                    .take(CHUNK as u64)
                    .read_to_end(&mut chunk)
                    .map_err(zip_err)?;
                if n == 0 {
                    return Ok(());
                }
                buf.extend_from_slice(&chunk);
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
    Ok(Some((buf, Some(digest))))
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
    declared: Option<&str>,
    options: &ReadOptions,
    notes: &mut Vec<String>,
) -> Result<(), X3pError> {
    let problem = match declared {
        Some(d) if d.eq_ignore_ascii_case(computed) => return Ok(()),
        Some(d) => X3pError::Md5Mismatch {
            member: member.to_string(),
            computed: computed.to_string(),
            declared: d.to_string(),
        },
        None => X3pError::MissingMember(format!("checksum for {member}")),
    };
    if options.accept_md5_mismatch {
        notes.push(problem.to_string());
        Ok(())
    } else {
        Err(problem)
    }
}

/// Reads an X3P file held in memory. Heights and pitch come back in µm.
///
/// # Errors
/// [`X3pError`] naming the member, element or checksum at fault.
pub fn read_x3p_bytes(bytes: &[u8], options: &ReadOptions) -> Result<HeightMap, X3pError> {
    read_x3p_scaled(bytes, options, 6)
}

/// As [`read_x3p_bytes`] with Z values `Offset + raw × Increment` multiplied by
/// `10^z_shift` (6 for µm heights, 0 for values as stored).
pub(crate) fn read_x3p_scaled(
    bytes: &[u8],
    options: &ReadOptions,
    z_shift: i32,
) -> Result<HeightMap, X3pError> {
    let mut archive =
        zip::ZipArchive::new(Cursor::new(bytes)).map_err(|e| X3pError::Zip(e.to_string()))?;

    // Find main.xml: the shallowest one that is not macOS junk.
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
    let prefix = &main[..main.len() - "main.xml".len()];

    let (xml_bytes, _) = read_member(&mut archive, &main, false, XML_LIMIT)?
        .ok_or_else(|| X3pError::MissingMember(main.clone()))?;
    let xml =
        std::str::from_utf8(&xml_bytes).map_err(|e| X3pError::Xml(format!("not UTF-8: {e}")))?;
    let doc = Document::parse(xml).map_err(|e| X3pError::Xml(e.to_string()))?;
    let root = doc.root_element();
    let root_name = root.tag_name().name();
    if root_name != "ISO5436_2" && root_name != "ISO5436" {
        return Err(X3pError::Xml(format!(
            "root element is <{root_name}>, expected <ISO5436_2>"
        )));
    }

    let mut map_meta: Vec<(String, String)> = vec![("x3p.root".into(), root_name.into())];
    if !prefix.is_empty() {
        map_meta.push(("x3p.folder".into(), prefix.trim_end_matches('/').into()));
    }
    for path in ["Record1/Revision", "Record1/FeatureType"] {
        if let Some(v) = text_at(root, path) {
            let key = path.rsplit('/').next().unwrap_or(path).to_lowercase();
            map_meta.push((format!("x3p.{key}"), v.to_string()));
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
                map_meta.push((
                    format!("x3p.{}.{}", axis.to_lowercase(), field.to_lowercase()),
                    v.to_string(),
                ));
            }
        }
    }
    let pitch_default = options.pixel_um.map(|_| 1.0);
    let dx = metres_scaled(root, "Record1/Axes/CX/Increment", pitch_default, 6)?;
    let dy = metres_scaled(root, "Record1/Axes/CY/Increment", pitch_default, 6)?;
    let z_unit = 10f64.powi(z_shift);
    let z_scale = metres_scaled(root, "Record1/Axes/CZ/Increment", Some(z_unit), z_shift)?;
    let z_offset = metres_scaled(root, "Record1/Axes/CZ/Offset", Some(0.0), z_shift)?;
    let dt_path = "Record1/Axes/CZ/DataType";
    let dtype = required(root, dt_path)?;
    let width = match dtype {
        "I" => 2,
        "L" => 4,
        "F" => 4,
        "D" => 8,
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
    let n = nx
        .checked_mul(ny)
        .ok_or(X3pError::Map(HeightMapError::TooLarge { nx, ny }))?;
    let data_link = required(root, "Record3/DataLink/PointDataLink")?;

    let mut notes = Vec::new();
    let checksum_file = text_at(root, "Record4/ChecksumFile")
        .filter(|s| !s.is_empty())
        .unwrap_or("md5checksum.hex");
    let declared = read_member(
        &mut archive,
        &format!("{prefix}{checksum_file}"),
        false,
        XML_LIMIT,
    )?;
    let declared = declared.as_ref().and_then(|(b, _)| {
        std::str::from_utf8(b)
            .ok()
            .and_then(|s| s.split_whitespace().next())
            .map(str::to_string)
    });
    check_md5(
        "main.xml",
        &md5_hex(&xml_bytes),
        declared.as_deref(),
        options,
        &mut notes,
    )?;

    let data_name = format!("{prefix}{data_link}");
    let data_md5 = text_at(root, "Record3/DataLink/MD5ChecksumPointData");
    let expected = (n as u64).saturating_mul(width as u64);
    // Read one byte more than needed, to tell "too long" from "just right".
    let (data, computed) = read_member(
        &mut archive,
        &data_name,
        data_md5.is_some(),
        expected.saturating_add(1),
    )?
    .ok_or_else(|| X3pError::MissingMember(data_name.clone()))?;
    if data.len() as u64 != expected {
        let found = if data.len() as u64 > expected {
            // Longer than needed: report the size the archive declares.
            archive
                .by_name(&data_name)
                .map(|f| f.size())
                .unwrap_or(data.len() as u64)
        } else {
            data.len() as u64
        };
        return Err(X3pError::DataLength {
            member: data_name,
            expected,
            found,
            detail: format!("{nx} x {ny} points of {width} bytes, DataType {dtype}"),
        });
    }
    if let (Some(d), Some(c)) = (data_md5, computed) {
        check_md5(&data_name, &c, Some(d), options, &mut notes)?;
    }

    let convert = |raw: f64| {
        let z = raw * z_scale;
        if z_offset == 0.0 { z } else { z + z_offset }
    };
    let z: Vec<f64> = match dtype {
        "I" => data
            .chunks_exact(2)
            .map(|c| convert(f64::from(i16::from_le_bytes([c[0], c[1]]))))
            .collect(),
        "L" => data
            .chunks_exact(4)
            .map(|c| convert(f64::from(i32::from_le_bytes([c[0], c[1], c[2], c[3]]))))
            .collect(),
        "F" => data
            .chunks_exact(4)
            .map(|c| convert(f64::from(f32::from_le_bytes([c[0], c[1], c[2], c[3]]))))
            .collect(),
        _ => data
            .chunks_exact(8)
            .map(|c| {
                let mut b = [0u8; 8];
                b.copy_from_slice(c);
                convert(f64::from_le_bytes(b))
            })
            .collect(),
    };

    let mut valid = vec![true; n];
    if let Some(link) = text_at(root, "Record3/DataLink/ValidPointsLink").filter(|s| !s.is_empty())
    {
        let name = format!("{prefix}{link}");
        let (bits, _) = read_member(&mut archive, &name, false, n.div_ceil(8) as u64)?
            .ok_or_else(|| X3pError::MissingMember(name.clone()))?;
        let need = n.div_ceil(8);
        if bits.len() < need {
            return Err(X3pError::DataLength {
                member: name,
                expected: need as u64,
                found: bits.len() as u64,
                detail: format!("one bit per point for {n} points"),
            });
        }
        if let Some(d) = text_at(root, "Record3/DataLink/MD5ChecksumValidPoints") {
            check_md5(&name, &md5_hex(&bits), Some(d), options, &mut notes)?;
        }
        for (i, v) in valid.iter_mut().enumerate() {
            *v = bits[i / 8] >> (i % 8) & 1 == 1;
        }
        map_meta.push(("x3p.valid_points_member".into(), link.to_string()));
    }

    let mut map = HeightMap::with_mask(nx, ny, dx, dy, z, valid).map_err(X3pError::Map)?;
    for (k, v) in map_meta {
        map.set_metadata(k, v);
    }
    if let Some(r2) = child(root, "Record2") {
        for node in r2.descendants().filter(|d| d.is_element() && d != &r2) {
            if node.children().any(|c| c.is_element()) {
                continue;
            }
            let mut parts: Vec<String> = node
                .ancestors()
                .take_while(|a| a != &r2)
                .filter(|a| a.is_element())
                .map(|a| a.tag_name().name().to_lowercase())
                .collect();
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
    Ok(map)
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
///
/// # Errors
/// [`WriteMapError::Zip`] if the archive cannot be assembled.
pub fn write_x3p_bytes(map: &HeightMap) -> Result<Vec<u8>, WriteMapError> {
    write_x3p_with_increment(map, "1e-6")
}

/// Writes an intensity image (unit-less values) as X3P with Z `Increment` 1, so the file
/// stores the values themselves; [`crate::read_intensity`] reads them back exactly.
///
/// # Errors
/// [`WriteMapError::Zip`] if the archive cannot be assembled.
pub fn write_intensity_x3p_bytes(map: &HeightMap) -> Result<Vec<u8>, WriteMapError> {
    write_x3p_with_increment(map, "1")
}

fn write_x3p_with_increment(map: &HeightMap, z_increment: &str) -> Result<Vec<u8>, WriteMapError> {
    let zerr = |e: zip::result::ZipError| WriteMapError::Zip(e.to_string());
    let ioerr = |e: std::io::Error| WriteMapError::Zip(e.to_string());

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

    let meta = |key: &str, default: &str| {
        xml_escape(
            map.metadata()
                .get(key)
                .map(String::as_str)
                .unwrap_or(default),
        )
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
        comment = meta(
            "x3p.comment",
            concat!("written by flakescatter ", env!("CARGO_PKG_VERSION"))
        ),
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
    zip.start_file("bindata/data.bin", opts).map_err(zerr)?;
    zip.write_all(&data).map_err(ioerr)?;
    if let Some(b) = &bits {
        zip.start_file("bindata/valid.bin", opts).map_err(zerr)?;
        zip.write_all(b).map_err(ioerr)?;
    }
    Ok(zip.finish().map_err(zerr)?.into_inner())
}

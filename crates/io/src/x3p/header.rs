//! The `main.xml` model of an X3P file: elements found by local name, the axes, matrix
//! and data links checked into a [`Header`], and the `Record2` metadata.

use flakescatter_stats::heightmap::HeightMap;
use roxmltree::{Document, Node};

use super::error::X3pError;
use crate::bytes::{f32_le, f64_le, i16_le, i32_le};
use crate::reader::{ReadOptions, ValueKind};
use crate::units::parse_scaled;

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

pub(super) fn bad(element: &str, value: &str, expected: &str) -> X3pError {
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
pub(super) enum DataType {
    I16,
    I32,
    F32,
    F64,
}

impl DataType {
    pub(super) fn width(self) -> usize {
        match self {
            DataType::I16 => 2,
            DataType::I32 | DataType::F32 => 4,
            DataType::F64 => 8,
        }
    }

    pub(super) fn code(self) -> &'static str {
        match self {
            DataType::I16 => "I",
            DataType::I32 => "L",
            DataType::F32 => "F",
            DataType::F64 => "D",
        }
    }

    pub(super) fn decode(self, c: &[u8]) -> f64 {
        match self {
            DataType::I16 => f64::from(i16_le(c, 0)),
            DataType::I32 => f64::from(i32_le(c, 0)),
            DataType::F32 => f64::from(f32_le(c, 0)),
            DataType::F64 => f64_le(c, 0),
        }
    }
}

/// Everything `main.xml` says that reading the data needs, checked.
pub(super) struct Header {
    pub(super) nx: usize,
    pub(super) ny: usize,
    /// Pitch in µm (the override's when one is given).
    pub(super) pitch: (f64, f64),
    pub(super) z_scale: f64,
    pub(super) z_offset: f64,
    pub(super) dtype: DataType,
    pub(super) data_link: String,
    pub(super) data_md5: Option<String>,
    pub(super) valid_link: Option<String>,
    pub(super) valid_md5: Option<String>,
    pub(super) checksum_file: String,
    pub(super) meta: Vec<(String, String)>,
}

pub(super) fn parse_header(
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

pub(super) fn parse_xml(xml_bytes: &[u8]) -> Result<Document<'_>, X3pError> {
    let xml =
        std::str::from_utf8(xml_bytes).map_err(|e| X3pError::Xml(format!("not UTF-8: {e}")))?;
    Document::parse(xml).map_err(|e| X3pError::Xml(e.to_string()))
}

/// Deepest `Record2` element whose text goes into the metadata (ISO 25178-72 nests
/// two levels, e.g. `Instrument/Manufacturer`).
const RECORD2_DEPTH: usize = 6;

/// Copies the leaves of `Record2` (instrument, dates, comment …) into `map`'s metadata
/// as `x3p.<path in lower case, dot-separated>`, e.g. `x3p.instrument.manufacturer`.
pub(super) fn record2_metadata(root: Node<'_, '_>, map: &mut HeightMap) {
    let Some(r2) = child(root, "Record2") else {
        return;
    };
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

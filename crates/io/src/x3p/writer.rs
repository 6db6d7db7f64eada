//! Writing a height map (or an intensity image) as an X3P archive in memory.

use std::io::{Cursor, Write};

use flakescatter_stats::heightmap::HeightMap;

use super::error::{ArchiveError, md5_hex};

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
pub(super) fn deflate_pays(data: &[u8]) -> std::io::Result<bool> {
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

    let xml = header_xml(map, z_increment, &data, bits.as_deref());
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

/// The `main.xml` of a map written with Z `Increment` `z_increment` (`"1"`: an
/// intensity image), `data` its `data.bin` and `bits` its `valid.bin` (when some point
/// is invalid): the map's own X3P fields, else what its metadata says of another
/// format's file ([`crate::provenance`]), else placeholders.
fn header_xml(map: &HeightMap, z_increment: &str, data: &[u8], bits: Option<&[u8]>) -> String {
    let intensity = z_increment == "1";
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
    let valid_link = match bits {
        Some(b) => format!(
            "\n      <ValidPointsLink>bindata/valid.bin</ValidPointsLink>\n      \
             <MD5ChecksumValidPoints>{}</MD5ChecksumValidPoints>",
            md5_hex(b)
        ),
        None => String::new(),
    };
    format!(
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
        data_md5 = md5_hex(data),
    )
}

//! Both ways of reading `data.bin` (whole with libdeflate, streamed with the zip crate)
//! on archives built here with the zip crate's writer from a hand-written `main.xml`,
//! whose heights are known by construction; and the same typed error from each way for
//! a corrupt stream, a declared size that lies, a wrong CRC-32 and a wrong MD5.

use std::io::Write;

use md5::{Digest, Md5};
use rand::{RngExt, SeedableRng};

use super::X3pError;
use super::reader::{Path, read_with};
use crate::reader::{ReadOptions, ValueKind};

const DATA: &str = "bindata/data.bin";

/// Every way a test can ask for: whole whenever the member qualifies, streamed in place,
/// streamed into points.
const PATHS: [Path; 3] = [Path::Whole, Path::Stream, Path::Points];

fn md5_hex(b: &[u8]) -> String {
    Md5::digest(b).iter().map(|x| format!("{x:02x}")).collect()
}

/// An X3P archive of `nx` x `ny` points of Z `DataType` `dtype` (Increment 2e-6 m, Offset
/// 1e-6 m, so a height in µm is `2 raw + 1`), `data` as its `data.bin` (compressed with
/// `method`) and `md5` as the declared MD5 of the data (none when `None`).
fn archive(
    nx: usize,
    ny: usize,
    dtype: &str,
    data: &[u8],
    md5: Option<&str>,
    method: zip::CompressionMethod,
) -> Vec<u8> {
    let md5 = md5
        .map(|m| format!("<MD5ChecksumPointData>{m}</MD5ChecksumPointData>"))
        .unwrap_or_default();
    let main = format!(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<p:ISO5436_2 xmlns:p="http://www.opengps.eu/2008/ISO5436_2">
  <Record1><Revision>ISO5436 - 2000</Revision><FeatureType>SUR</FeatureType>
    <Axes>
      <CX><AxisType>I</AxisType><DataType>D</DataType><Increment>1e-6</Increment><Offset>0</Offset></CX>
      <CY><AxisType>I</AxisType><DataType>D</DataType><Increment>1e-6</Increment><Offset>0</Offset></CY>
      <CZ><AxisType>A</AxisType><DataType>{dtype}</DataType><Increment>2e-6</Increment><Offset>1e-6</Offset></CZ>
    </Axes></Record1>
  <Record3><MatrixDimension><SizeX>{nx}</SizeX><SizeY>{ny}</SizeY><SizeZ>1</SizeZ></MatrixDimension>
    <DataLink><PointDataLink>{DATA}</PointDataLink>{md5}</DataLink></Record3>
  <Record4><ChecksumFile>md5checksum.hex</ChecksumFile></Record4>
</p:ISO5436_2>
"#
    );
    let mut zip = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let opts = zip::write::SimpleFileOptions::default();
    zip.start_file("main.xml", opts).unwrap();
    zip.write_all(main.as_bytes()).unwrap();
    zip.start_file("md5checksum.hex", opts).unwrap();
    zip.write_all(format!("{} *main.xml\n", md5_hex(main.as_bytes())).as_bytes())
        .unwrap();
    zip.start_file(DATA, opts.compression_method(method))
        .unwrap();
    zip.write_all(data).unwrap();
    zip.finish().unwrap().into_inner()
}

/// Raw float64 values `i / 4 - 1000` (exact), their bytes, and the heights they make.
fn f64_points(n: usize) -> (Vec<u8>, Vec<f64>) {
    let raw: Vec<f64> = (0..n).map(|i| i as f64 / 4.0 - 1000.0).collect();
    let bytes = raw.iter().flat_map(|v| v.to_le_bytes()).collect();
    (bytes, raw.iter().map(|r| 2.0 * r + 1.0).collect())
}

/// Where `DATA`'s local header and central directory entry are: (local, central).
fn headers(bytes: &[u8]) -> (usize, usize) {
    let find = |sig: &[u8], name_at: usize| {
        (0..bytes.len() - name_at)
            .find(|&i| {
                bytes[i..].starts_with(sig) && bytes[i + name_at..].starts_with(DATA.as_bytes())
            })
            .expect("member header")
    };
    (find(b"PK\x03\x04", 30), find(b"PK\x01\x02", 46))
}

fn u16_at(b: &[u8], i: usize) -> usize {
    usize::from(u16::from_le_bytes([b[i], b[i + 1]]))
}

/// Overwrites `DATA`'s CRC-32 (`field` 0), compressed size (1) or uncompressed size (2)
/// in both its local header and its central directory entry.
fn patch(bytes: &mut [u8], field: usize, f: impl Fn(u32) -> u32) {
    let (local, central) = headers(bytes);
    for at in [local + 14 + 4 * field, central + 16 + 4 * field] {
        let old = u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap());
        bytes[at..at + 4].copy_from_slice(&f(old).to_le_bytes());
    }
}

/// Where `DATA`'s compressed bytes start.
fn data_start(bytes: &[u8]) -> usize {
    let (local, _) = headers(bytes);
    local + 30 + u16_at(bytes, local + 26) + u16_at(bytes, local + 28)
}

fn read(bytes: &[u8], path: Path) -> Result<(Vec<f64>, Path), X3pError> {
    read_opts(bytes, path, &ReadOptions::default())
}

fn read_opts(
    bytes: &[u8],
    path: Path,
    options: &ReadOptions,
) -> Result<(Vec<f64>, Path), X3pError> {
    read_with(
        std::io::Cursor::new(bytes),
        Some(bytes),
        options,
        ValueKind::Height,
        path,
    )
    .map(|(m, p)| (m.heights().to_vec(), p))
}

/// As [`read`] with `Path::Auto`, through a reader that does not hold the archive's
/// bytes (as for a file, [`super::read_from`]): the same way is taken, a member
/// inflated whole being first read from the reader.
fn read_streamed(bytes: &[u8]) -> Result<(Vec<f64>, Path), X3pError> {
    let reader = std::io::BufReader::with_capacity(4096, std::io::Cursor::new(bytes));
    read_with(
        reader,
        None,
        &ReadOptions::default(),
        ValueKind::Height,
        Path::Auto,
    )
    .map(|(m, p)| (m.heights().to_vec(), p))
}

/// The way the reader says it took, for a deflated float64 member of the right size.
fn taken(asked: Path) -> Path {
    match asked {
        Path::Stream => Path::InPlace,
        other => other,
    }
}

fn deflated() -> zip::CompressionMethod {
    zip::CompressionMethod::Deflated
}

#[test]
fn float64_heights_are_known_on_every_path() {
    // 40 x 25 (single-threaded checksums) and 1024 x 1024 (8 MiB: a second thread).
    for (nx, ny) in [(40, 25), (1024, 1024)] {
        let (data, want) = f64_points(nx * ny);
        for md5 in [None, Some(md5_hex(&data))] {
            let bytes = archive(nx, ny, "D", &data, md5.as_deref(), deflated());
            for path in PATHS {
                let (z, took) = read(&bytes, path).unwrap();
                assert_eq!(took, taken(path));
                assert!(z == want, "{nx} x {ny} via {path:?}: heights differ");
            }
            let (z, took) = read_streamed(&bytes).unwrap();
            assert_eq!(took, read(&bytes, Path::Auto).unwrap().1);
            assert!(z == want, "{nx} x {ny} through a reader: heights differ");
        }
    }
}

#[test]
fn narrow_points_are_known_on_every_path() {
    let n = 1024 * 1024;
    let i16s: Vec<i16> = (0..n).map(|i| (i % 65_536) as i16 ^ 0x5a5a).collect();
    let f32s: Vec<f32> = (0..n).map(|i| (i % 4096) as f32 * 0.25 - 100.0).collect();
    let cases: [(&str, Vec<u8>, Vec<f64>); 2] = [
        (
            "I",
            i16s.iter().flat_map(|v| v.to_le_bytes()).collect(),
            i16s.iter().map(|&v| 2.0 * f64::from(v) + 1.0).collect(),
        ),
        (
            "F",
            f32s.iter().flat_map(|v| v.to_le_bytes()).collect(),
            f32s.iter().map(|&v| 2.0 * f64::from(v) + 1.0).collect(),
        ),
    ];
    for (dtype, data, want) in cases {
        for (nx, ny) in [(1024, 1024), (7, 3)] {
            let (data, want) = (&data[..nx * ny * data.len() / n], &want[..nx * ny]);
            let bytes = archive(nx, ny, dtype, data, Some(&md5_hex(data)), deflated());
            for path in [Path::Whole, Path::Points] {
                let (z, took) = read(&bytes, path).unwrap();
                assert_eq!(took, path, "{dtype}");
                assert!(
                    z == want,
                    "{dtype} {nx} x {ny} via {path:?}: heights differ"
                );
            }
            let (z, took) = read_streamed(&bytes).unwrap();
            assert_eq!(took, read(&bytes, Path::Auto).unwrap().1, "{dtype}");
            assert!(z == want, "{dtype} {nx} x {ny} through a reader");
        }
    }
}

#[test]
fn auto_takes_whole_where_it_pays() {
    let two_cores = std::thread::available_parallelism().is_ok_and(|p| p.get() >= 2);
    for (nx, ny) in [(40, 25), (1024, 1024)] {
        let (data, want) = f64_points(nx * ny);
        for md5 in [None, Some(md5_hex(&data))] {
            let bytes = archive(nx, ny, "D", &data, md5.as_deref(), deflated());
            let (z, took) = read(&bytes, Path::Auto).unwrap();
            // Large (8 MiB) with an MD5 to overlap on a second core: streamed.
            let streamed = md5.is_some() && nx * ny * 8 >= 8 << 20 && two_cores;
            let want_took = if streamed { Path::InPlace } else { Path::Whole };
            assert_eq!(took, want_took, "{nx} x {ny}, MD5 {}", md5.is_some());
            assert!(z == want);
        }
    }
}

#[test]
fn stored_members_stream() {
    let (data, want) = f64_points(1000);
    let bytes = archive(40, 25, "D", &data, None, zip::CompressionMethod::Stored);
    for path in [Path::Auto, Path::Whole] {
        let (z, took) = read(&bytes, path).unwrap();
        let want_took = if path == Path::Auto {
            Path::InPlace
        } else {
            Path::Points
        };
        assert_eq!(took, want_took);
        assert_eq!(z, want);
    }
}

/// Each way's error for `bytes`, all of which must be errors; the last is that of a
/// read through a reader ([`read_streamed`], listed as `Path::Auto`).
fn errors(bytes: &[u8]) -> Vec<(Path, X3pError)> {
    let mut all: Vec<(Path, X3pError)> = PATHS
        .iter()
        .map(|&p| match read(bytes, p) {
            Ok((_, took)) => panic!("{p:?} (took {took:?}) accepted a bad member"),
            Err(e) => (p, e),
        })
        .collect();
    match read_streamed(bytes) {
        Ok((_, took)) => panic!("a reader (took {took:?}) accepted a bad member"),
        Err(e) => all.push((Path::Auto, e)),
    }
    all
}

/// Whether `e` is an archive error that names the data member and says `what`.
fn zip_error(e: &X3pError, what: &[&str]) -> bool {
    matches!(e, X3pError::Zip(m) if m.contains(&format!("{DATA:?}"))
        && what.iter().any(|w| m.to_lowercase().contains(w)))
}

#[test]
fn corrupt_stream_is_a_zip_error_on_every_path() {
    for (nx, ny) in [(40, 25), (1024, 1024)] {
        let (data, _) = f64_points(nx * ny);
        let mut bytes = archive(nx, ny, "D", &data, Some(&md5_hex(&data)), deflated());
        // The first block header: final, block type 3 (reserved, invalid).
        let at = data_start(&bytes);
        bytes[at] = 0b111;
        for (p, e) in errors(&bytes) {
            assert!(
                zip_error(&e, &["corrupt", "invalid", "deflate"]),
                "{p:?}: {e:?}"
            );
        }
    }
}

#[test]
fn wrong_crc_is_a_zip_error_on_every_path() {
    for (nx, ny) in [(40, 25), (1024, 1024)] {
        let (data, _) = f64_points(nx * ny);
        let mut bytes = archive(nx, ny, "D", &data, Some(&md5_hex(&data)), deflated());
        patch(&mut bytes, 0, |crc| crc ^ 1);
        for (p, e) in errors(&bytes) {
            assert!(zip_error(&e, &["checksum", "crc"]), "{p:?}: {e:?}");
        }
    }
}

#[test]
fn member_shorter_than_declared_is_a_length_error_on_every_path() {
    // The header and the archive both say 40 x 25 points, the stream holds one fewer.
    let (data, _) = f64_points(999);
    let mut bytes = archive(40, 25, "D", &data, None, deflated());
    patch(&mut bytes, 2, |_| 8000);
    for (p, e) in errors(&bytes) {
        assert!(
            matches!(
                &e,
                X3pError::DataLength { member, expected: 8000, found: 7992, .. } if member == DATA
            ),
            "{p:?}: {e:?}"
        );
    }
}

#[test]
fn member_longer_than_declared_is_a_zip_error_on_every_path() {
    // The header and the archive both say 40 x 25 points, the stream holds one more.
    let (data, _) = f64_points(1001);
    let mut bytes = archive(40, 25, "D", &data, None, deflated());
    patch(&mut bytes, 2, |_| 8000);
    for (p, e) in errors(&bytes) {
        assert!(zip_error(&e, &["larger", "more than"]), "{p:?}: {e:?}");
    }
}

#[test]
fn wrong_md5_is_a_mismatch_on_every_path() {
    for (nx, ny) in [(40, 25), (1024, 1024)] {
        let (data, want) = f64_points(nx * ny);
        let right = md5_hex(&data);
        let wrong = md5_hex(b"not the data");
        let bytes = archive(nx, ny, "D", &data, Some(&wrong), deflated());
        for (p, e) in errors(&bytes) {
            assert_eq!(
                e,
                X3pError::Md5Mismatch {
                    member: DATA.into(),
                    computed: right.clone(),
                    declared: wrong.clone(),
                },
                "{p:?}"
            );
        }
        let accept = ReadOptions {
            accept_md5_mismatch: true,
            ..ReadOptions::default()
        };
        for p in PATHS {
            let (z, _) = read_opts(&bytes, p, &accept).unwrap();
            assert!(z == want, "{p:?}");
        }
    }
}

/// A reader over an archive whose reads of the bytes `bad` fail, as a disk or network
/// error would (a read that starts before them stops short of them; the rest of the
/// archive, its central directory included, reads as usual).
struct FailingReader {
    inner: std::io::Cursor<Vec<u8>>,
    bad: std::ops::Range<u64>,
}

impl std::io::Read for FailingReader {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let at = self.inner.position();
        if self.bad.contains(&at) {
            return Err(std::io::Error::other("simulated disk error"));
        }
        let room = if at < self.bad.start {
            usize::try_from(self.bad.start - at).unwrap_or(usize::MAX)
        } else {
            usize::MAX
        };
        let n = buf.len().min(room);
        self.inner.read(&mut buf[..n])
    }
}

impl std::io::Seek for FailingReader {
    fn seek(&mut self, to: std::io::SeekFrom) -> std::io::Result<u64> {
        self.inner.seek(to)
    }
}

#[test]
fn a_read_that_fails_mid_member_is_a_read_error_not_a_damaged_archive() {
    // The system's error in the second quarter of data.bin's compressed bytes, on every way
    // of reading it (the archive's bytes not in memory, as from a file), small and
    // large (several 1 MiB chunks, the MD5 on a second thread): the error names the
    // member and carries the system's reason, and does not call the archive damaged.
    for (nx, ny) in [(1024, 1024), (40, 25)] {
        // Values that do not compress (seeded uniform ones), so that data.bin's
        // compressed bytes lie well before the end of the archive, where opening it reads.
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let data: Vec<u8> = (0..nx * ny)
            .flat_map(|_| rng.random_range(-1.0f64..1.0).to_le_bytes())
            .collect();
        let bytes = archive(nx, ny, "D", &data, Some(&md5_hex(&data)), deflated());
        // The second quarter of data.bin's compressed bytes (their size from its local
        // header) fails to read: away from the archive's last kilobytes, which opening
        // it reads.
        let start = data_start(&bytes) as u64;
        let (local, _) = headers(&bytes);
        let packed = u32::from_le_bytes(bytes[local + 18..local + 22].try_into().unwrap());
        let quarter = u64::from(packed) / 4;
        let bad = start + quarter..start + 2 * quarter;
        for path in [Path::Auto, Path::Whole, Path::Stream, Path::Points] {
            let reader = FailingReader {
                inner: std::io::Cursor::new(bytes.clone()),
                bad: bad.clone(),
            };
            let e = read_with(
                reader,
                None,
                &ReadOptions::default(),
                ValueKind::Height,
                path,
            )
            .map(|_| ())
            .expect_err("a failing read");
            assert!(
                matches!(&e, X3pError::Read { what, reason }
                    if what.contains(&format!("{DATA:?}")) && reason.contains("simulated disk error")),
                "{nx}x{ny} {path:?}: {e:?}"
            );
            let shown = e.to_string();
            assert!(!shown.contains("not a readable zip"), "{shown}");
        }
    }
}

/// `len` bytes in blocks of 4096, each block's first `r · 4096` bytes random and the rest
/// zeros, with `zeros_first` bytes of zeros before (seeded).
fn partly_random(len: usize, r: f64, zeros_first: usize) -> Vec<u8> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    let noisy = (r * 4096.0) as usize;
    (0..len)
        .map(|i| {
            if i >= zeros_first && i % 4096 < noisy {
                rng.random::<u8>()
            } else {
                0
            }
        })
        .collect()
}

/// Level 1 of the zip crate's deflater (zlib-rs) codes with the fixed Huffman codes of
/// RFC 1951 §3.2.6: a literal byte 0–143 costs 8 bits, 144–255 costs 9, so random bytes
/// cost (144·8 + 112·9)/256 = 8.4375 bits, 1.0547 of their size (chance matches in
/// random data are rare enough to ignore), while a run of zeros costs about 13 bits per
/// 258 bytes (0.006). Data whose blocks are a fraction `r` random therefore deflate to
/// about 1.0547 r: 0.84 for r = 0.8 (deflate pays, at most 0.9) and 0.95 for r = 0.9
/// (it does not), whether sampled in slices (8 MiB) or whole (1 MiB). With the first
/// 1 MiB zeros and the rest random, the 8 slices spread over 8 MiB hold one slice of
/// zeros and seven random: 7/8 · 1.0547 = 0.92, stored; a sample taken from the start
/// only, or one slice eight times, would see mostly zeros and deflate.
#[test]
fn deflate_pays_at_ninety_per_cent_of_a_spread_sample() {
    for len in [8 << 20, 1 << 20] {
        assert!(
            super::writer::deflate_pays(&partly_random(len, 0.8, 0)).unwrap(),
            "{len}, r = 0.8"
        );
        assert!(
            !super::writer::deflate_pays(&partly_random(len, 0.9, 0)).unwrap(),
            "{len}, r = 0.9"
        );
    }
    assert!(!super::writer::deflate_pays(&partly_random(8 << 20, 1.0, 1 << 20)).unwrap());
    assert!(super::writer::deflate_pays(&[0u8; 100]).unwrap());
}

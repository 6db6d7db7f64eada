//! `data.bin` inflated in one call with libdeflate, when that pays: the raw deflate
//! stream taken from the archive, its CRC-32 checked here, the MD5 of a large member on
//! a second thread.

use std::io::{Read, Seek};

use md5::{Digest, Md5};

use super::data::{Heights, STREAM_CHUNK, decode_f64, scaled};
use super::error::{X3pError, hex, io_error, md5_hex, zip_error};
use super::header::DataType;

/// Whether inflating a `data.bin` of `len` bytes whole ([`inflate_whole`]) is faster
/// than streaming it. Whole, libdeflate inflates about twice as fast as the zip crate
/// streams, but the MD5 (500–600 MB/s, the slowest step) can only start once it is done;
/// streamed, the MD5 of a large member runs on a second thread as it is inflated, and
/// the read takes about as long as the slower of the two alone. So whole pays when
/// there is no MD5 to compute, when the member is small enough for its MD5 to be
/// computed on the reading thread either way (below `8 ×` [`STREAM_CHUNK`]), or when
/// there is no second core to overlap it on (then the smaller total work wins).
pub(super) fn whole_pays(hash: bool, len: u64) -> bool {
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
pub(super) fn whole_member<'b, R: Read + Seek>(
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
pub(super) fn inflate_whole(
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

/// The constant part of [`whole_limit`] (48 MiB).
const WHOLE_SLACK: u64 = 48 << 20;

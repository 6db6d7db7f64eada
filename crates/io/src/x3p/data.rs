//! The binary members of an X3P file streamed: `data.bin` inflated chunk by chunk
//! (decoded into heights as it comes, or inflated in place for float64 points) with
//! its MD5 on a second thread for a large member, other members read whole within a
//! limit, and the `valid.bin` bits unpacked.

use std::io::{Read, Seek};

use md5::{Digest, Md5};

use super::error::{X3pError, hex, io_error, zip_error};
use super::header::DataType;

/// A member's bytes (at most the limit asked for) and, when asked for, their MD5
/// (lower-case hex).
type Member = (Vec<u8>, Option<String>);

/// Reads member `name`, at most `limit` bytes of it (so that a zip bomb or a lying header
/// cannot exhaust memory); with `hash`, also its MD5.
pub(super) fn read_member<R: Read + Seek>(
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
pub(super) trait Sink {
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
pub(super) struct Points {
    pub(super) z: Vec<f64>,
    pub(super) n: usize,
    pub(super) dtype: DataType,
    pub(super) scale: f64,
    pub(super) offset: f64,
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
pub(super) fn scaled(raw: f64, scale: f64, offset: f64) -> f64 {
    let z = raw * scale;
    if offset == 0.0 { z } else { z + offset }
}

/// Heights read from `data.bin`, the number of bytes it inflated to (or as many as were
/// read, at most one past what the header implies) and its MD5 (lower-case hex).
pub(super) type Heights = (Vec<f64>, u64, Option<String>);

/// Decodes float64 points in place: `chunk` holds their little-endian bytes.
pub(super) fn decode_f64(chunk: &mut [f64], scale: f64, offset: f64) {
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
pub(super) fn read_f64_member<R: Read + Seek>(
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

/// Inflates member `name` chunk by chunk into `sink`, at most `limit` bytes of it (so
/// that a zip bomb or a lying header cannot exhaust memory), without holding the whole
/// member: every chunk but the last is [`STREAM_CHUNK`] bytes (a multiple of every
/// point width). [`Sink::reserve`] is called first with a capacity hint, the declared
/// size bounded by what the compressed bytes can inflate to. With `hash`, the MD5 of the
/// bytes is computed too, on a second thread for a large member (each chunk goes to it
/// once `sink` has seen it, while the next one is being inflated). Returns the number
/// of bytes read and the MD5 (lower-case hex); `None` when there is no such member.
pub(super) fn stream_member<R: Read + Seek>(
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
pub(super) const STREAM_CHUNK: usize = 1 << 20;

/// Chunks that [`read_f64_member`]'s checksum thread keeps ready for the reader.
const AHEAD: usize = 4;

/// The memory page size assumed when touching pages ahead of the reader (a smaller
/// real one only leaves some faults to the reader).
const PAGE: usize = 4096;

/// The first `n` bits of `valid.bin`, least significant bit of each byte first
/// (`bits` holds at least `n` of them). Built eight points at a time straight into a
/// vector of their final size (no mask of `true` written first).
pub(super) fn unpack_bits(bits: &[u8], n: usize) -> Vec<bool> {
    let mut valid = Vec::with_capacity(n);
    for &byte in &bits[..n / 8] {
        valid.extend_from_slice(&std::array::from_fn::<bool, 8, _>(|k| byte >> k & 1 == 1));
    }
    if let Some(&last) = bits.get(n / 8) {
        valid.extend((0..n % 8).map(|k| last >> k & 1 == 1));
    }
    valid
}

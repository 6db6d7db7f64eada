//! MERL isotropic BRDF tables (Matusik, Pfister, Brand and McMillan, "A Data-Driven
//! Reflectance Model", ACM Transactions on Graphics 22(3), 2003), read and written as
//! MERL's published reference reader (`BRDFRead.cpp`) lays them out; `docs/formats.md`
//! has the layout and the indexing.
//!
//! A file is three little-endian `int32` dimensions `90, 90, 180`, then
//! `3 × 90 × 90 × 180` little-endian `float64`, channel after channel (R, G, B), each
//! stored divided by its scale ([`SCALES`]: 1/1500, 1.15/1500, 1.66/1500), so that
//! BRDF (sr⁻¹) = stored × scale. Within a channel the bin of half-angle index `h`,
//! difference-angle index `d` and difference-azimuth index `p` is at
//! `p + 180 d + 180·90 h`. A negative stored number marks a bin without a value (below
//! the horizon, or not measured); MERL writes −1.
//!
//! Bins are addressed in Rusinkiewicz's half/difference angles `(θh, θd, φd)`
//! ([`half_diff`]): `θh` by the square root of `θh/(π/2)` (finer near the mirror
//! direction), `θd` and `φd` linearly, `φd` folded into `[0, π)` by reciprocity.
//! [`MerlTable`] keeps the stored numbers themselves, so writing a table and reading it
//! back gives every bin back bit for bit.
//!
//! ```
//! use flakescatter_io::merl::{Bin, MerlTable, read_merl_bytes, write_merl};
//!
//! let mut table = MerlTable::unfilled();
//! let bin = Bin::new(10, 20, 30).unwrap();
//! table.set(1, bin, Some(0.25)); // green channel, 0.25 sr⁻¹
//! let mut bytes = Vec::new();
//! write_merl(&mut bytes, &table)?;
//! let back = read_merl_bytes(&bytes, "in memory")?;
//! assert_eq!(back.raw(), table.raw());
//! assert_eq!(back.value(0, bin), None); // red was left unfilled
//! // The bin's centre directions look it up again.
//! let (wi, wo) = bin.centre_directions().unwrap();
//! let v = back.lookup(wi, wo).unwrap();
//! assert!((v[1] - 0.25).abs() < 1e-15);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::f64::consts::{FRAC_PI_2, PI};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

use thiserror::Error;

/// Number of half-angle `θh` bins.
pub const THETA_H_BINS: usize = 90;
/// Number of difference-angle `θd` bins.
pub const THETA_D_BINS: usize = 90;
/// Number of difference-azimuth `φd` bins (over `[0, π)`).
pub const PHI_D_BINS: usize = 180;
/// Bins per channel.
pub const BINS: usize = THETA_H_BINS * THETA_D_BINS * PHI_D_BINS;
/// The channels, in file order.
pub const CHANNELS: [&str; 3] = ["R", "G", "B"];
/// Stored number × scale = BRDF in sr⁻¹, per channel (R, G, B), as the reference reader.
pub const SCALES: [f64; 3] = [1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0];
/// Bytes of a MERL file: the 12-byte header and three channels of `float64`.
pub const FILE_LEN: usize = 12 + 3 * BINS * 8;
/// The stored number of a bin without a value.
pub const UNFILLED: f64 = -1.0;

/// Why a MERL file could not be read.
#[derive(Debug, Error)]
pub enum MerlError {
    /// The operating system could not read it.
    #[error("cannot read {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating-system error.
        source: std::io::Error,
    },
    /// Shorter than the header.
    #[error(
        "{file}: not a MERL BRDF file: {len} bytes, shorter than its 12-byte header (three int32 dimensions 90, 90, 180)"
    )]
    NoHeader {
        /// The file.
        file: String,
        /// Its length, bytes.
        len: usize,
    },
    /// The dimensions are not MERL's.
    #[error(
        "{file}: not a MERL BRDF file: its header gives dimensions {dims:?}, expected [90, 90, 180] (θh, θd, φd bins)"
    )]
    Dims {
        /// The file.
        file: String,
        /// The three `int32` read.
        dims: [i32; 3],
    },
    /// The length does not match the dimensions.
    #[error(
        "{file}: {len} bytes, expected {FILE_LEN} (the 12-byte header and 3 × 90 × 90 × 180 float64): the file is {}",
        if *len < FILE_LEN { "truncated" } else { "longer than its table" }
    )]
    Length {
        /// The file.
        file: String,
        /// Its length, bytes.
        len: usize,
    },
    /// A stored number is not finite.
    #[error(
        "{file}: channel {} bin (θh {}, θd {}, φd {}) holds {value}, expected a finite number (negative for no value)",
        CHANNELS[*channel], bin.theta_h, bin.theta_d, bin.phi_d
    )]
    NotFinite {
        /// The file.
        file: String,
        /// Channel index (0 R, 1 G, 2 B).
        channel: usize,
        /// The bin.
        bin: Bin,
        /// The number read.
        value: f64,
    },
    /// A table of the wrong size was given to [`MerlTable::from_raw`].
    #[error("a MERL table holds {expected} numbers, not {got}", expected = 3 * BINS)]
    Size {
        /// How many were given.
        got: usize,
    },
}

/// One bin of the table: its `θh`, `θd` and `φd` indices.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Bin {
    /// Half-angle index, `0..90`.
    pub theta_h: usize,
    /// Difference-angle index, `0..90`.
    pub theta_d: usize,
    /// Difference-azimuth index, `0..180`.
    pub phi_d: usize,
}

/// Rusinkiewicz's half/difference angles of a pair of directions, radians: `θh` the
/// half vector's polar angle, `φh` its azimuth, `θd` and `φd` the incident direction's
/// polar angle and azimuth in the half vector's frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HalfDiff {
    /// Half-vector polar angle, `[0, π/2]` for directions above the surface.
    pub theta_h: f64,
    /// Half-vector azimuth, `(−π, π]`.
    pub phi_h: f64,
    /// Difference polar angle, `[0, π/2]`.
    pub theta_d: f64,
    /// Difference azimuth, `(−π, π]` (not folded).
    pub phi_d: f64,
}

impl Bin {
    /// The bin of these indices; `None` outside `90 × 90 × 180`.
    #[must_use]
    pub fn new(theta_h: usize, theta_d: usize, phi_d: usize) -> Option<Self> {
        (theta_h < THETA_H_BINS && theta_d < THETA_D_BINS && phi_d < PHI_D_BINS).then_some(Self {
            theta_h,
            theta_d,
            phi_d,
        })
    }

    /// The bin of flat index `i` (`p + 180 d + 180·90 h`); `None` for `i ≥ BINS`.
    #[must_use]
    pub fn from_index(i: usize) -> Option<Self> {
        Self::new(
            i / (THETA_D_BINS * PHI_D_BINS),
            (i / PHI_D_BINS) % THETA_D_BINS,
            i % PHI_D_BINS,
        )
    }

    /// Flat index within a channel, `p + 180 d + 180·90 h`.
    #[must_use]
    pub fn index(self) -> usize {
        self.phi_d + PHI_D_BINS * (self.theta_d + THETA_D_BINS * self.theta_h)
    }

    /// The bin the reference reader looks up for these half/difference angles (radians):
    /// `h = ⌊90 √(θh/(π/2))⌋` (0 for `θh ≤ 0`), `d = ⌊90 θd/(π/2)⌋`,
    /// `p = ⌊180 φd/π⌋` after adding π to a negative `φd`, each clamped to its range.
    #[must_use]
    pub fn of(theta_h: f64, theta_d: f64, phi_d: f64) -> Self {
        let clamp = |x: f64, n: usize| {
            // `as` saturates (NaN to 0), as the reference's clamps of an int do.
            (x as i64).clamp(0, n as i64 - 1) as usize
        };
        let theta_h = if theta_h <= 0.0 {
            0
        } else {
            clamp(
                (theta_h / FRAC_PI_2 * THETA_H_BINS as f64 * THETA_H_BINS as f64).sqrt(),
                THETA_H_BINS,
            )
        };
        let phi_d = if phi_d < 0.0 { phi_d + PI } else { phi_d };
        Self {
            theta_h,
            theta_d: clamp(theta_d / FRAC_PI_2 * THETA_D_BINS as f64, THETA_D_BINS),
            phi_d: clamp(phi_d / PI * PHI_D_BINS as f64, PHI_D_BINS),
        }
    }

    /// The bin's centre in half/difference angles, radians, with `φh = 0`:
    /// `θh = (π/2)((h + ½)/90)²`, `θd = (π/2)(d + ½)/90`, `φd = π(p + ½)/180`.
    #[must_use]
    pub fn centre(self) -> HalfDiff {
        let u = (self.theta_h as f64 + 0.5) / THETA_H_BINS as f64;
        HalfDiff {
            theta_h: FRAC_PI_2 * u * u,
            phi_h: 0.0,
            theta_d: FRAC_PI_2 * (self.theta_d as f64 + 0.5) / THETA_D_BINS as f64,
            phi_d: PI * (self.phi_d as f64 + 0.5) / PHI_D_BINS as f64,
        }
    }

    /// The incident and outgoing unit directions (both pointing away from the surface,
    /// `z` its normal) of the bin's [`centre`](Self::centre), the half vector in the
    /// `xz` plane; `None` when either is not above the surface (`z ≤ 0`), a bin no
    /// reflection fills.
    #[must_use]
    pub fn centre_directions(self) -> Option<([f64; 3], [f64; 3])> {
        let (wi, wo) = self.centre().directions();
        (wi[2] > 0.0 && wo[2] > 0.0).then_some((wi, wo))
    }
}

impl HalfDiff {
    /// The incident and outgoing unit directions of these angles: the difference vector
    /// `(sin θd cos φd, sin θd sin φd, cos θd)` turned by `θh` about `y`, then by `φh`
    /// about `z`, gives `ωi`; `ωo = 2(ωi·h)h − ωi`, its mirror image about the half
    /// vector `h`. May lie below the surface.
    #[must_use]
    pub fn directions(&self) -> ([f64; 3], [f64; 3]) {
        let (sd, cd) = self.theta_d.sin_cos();
        let d = [sd * self.phi_d.cos(), sd * self.phi_d.sin(), cd];
        let (sh, ch) = self.theta_h.sin_cos();
        let (sp, cp) = self.phi_h.sin_cos();
        // About y by θh, then about z by φh.
        let t = [d[0] * ch + d[2] * sh, d[1], d[2] * ch - d[0] * sh];
        let wi = [t[0] * cp - t[1] * sp, t[0] * sp + t[1] * cp, t[2]];
        let h = [sh * cp, sh * sp, ch];
        let dot = 2.0 * (wi[0] * h[0] + wi[1] * h[1] + wi[2] * h[2]);
        let wo = [dot * h[0] - wi[0], dot * h[1] - wi[1], dot * h[2] - wi[2]];
        (wi, wo)
    }
}

/// The half/difference angles of the incident direction `wi` and outgoing direction
/// `wo` (both away from the surface; normalised here), as the reference reader
/// computes them: `h = (wi + wo)/|wi + wo|`, `θh = acos h.z`, `φh = atan2(h.y, h.x)`,
/// and `wi` turned by `−φh` about `z` then by `−θh` about `y` gives the difference
/// vector, whose polar angle and azimuth are `θd`, `φd`.
#[must_use]
pub fn half_diff(wi: [f64; 3], wo: [f64; 3]) -> HalfDiff {
    let unit = |v: [f64; 3]| {
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        [v[0] / n, v[1] / n, v[2] / n]
    };
    let wi = unit(wi);
    let wo = unit(wo);
    let h = unit([wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]]);
    let theta_h = h[2].clamp(-1.0, 1.0).acos();
    let phi_h = h[1].atan2(h[0]);
    let (sp, cp) = (-phi_h).sin_cos();
    let t = [wi[0] * cp - wi[1] * sp, wi[0] * sp + wi[1] * cp, wi[2]];
    let (sh, ch) = (-theta_h).sin_cos();
    let d = [t[0] * ch + t[2] * sh, t[1], t[2] * ch - t[0] * sh];
    HalfDiff {
        theta_h,
        phi_h,
        theta_d: d[2].clamp(-1.0, 1.0).acos(),
        phi_d: d[1].atan2(d[0]),
    }
}

/// A MERL table: the stored numbers of its three channels (BRDF / scale; negative for
/// a bin without a value).
#[derive(Debug, Clone, PartialEq)]
pub struct MerlTable {
    raw: Vec<f64>,
}

impl MerlTable {
    /// A table whose every bin is without a value ([`UNFILLED`]).
    #[must_use]
    pub fn unfilled() -> Self {
        Self {
            raw: vec![UNFILLED; 3 * BINS],
        }
    }

    /// A table of stored numbers (channel after channel, as in the file).
    ///
    /// # Errors
    /// [`MerlError::Size`] unless there are `3 × BINS` numbers.
    pub fn from_raw(raw: Vec<f64>) -> Result<Self, MerlError> {
        if raw.len() == 3 * BINS {
            Ok(Self { raw })
        } else {
            Err(MerlError::Size { got: raw.len() })
        }
    }

    /// The stored numbers, channel after channel (BRDF / scale; negative: no value).
    #[must_use]
    pub fn raw(&self) -> &[f64] {
        &self.raw
    }

    /// The stored numbers of one channel (`0` R, `1` G, `2` B).
    ///
    /// # Panics
    /// For a channel index above 2.
    #[must_use]
    pub fn channel(&self, channel: usize) -> &[f64] {
        &self.raw[channel * BINS..(channel + 1) * BINS]
    }

    /// The BRDF of `channel` (`0` R, `1` G, `2` B) in `bin`, sr⁻¹; `None` for a bin
    /// without a value.
    ///
    /// # Panics
    /// For a channel index above 2.
    #[must_use]
    pub fn value(&self, channel: usize, bin: Bin) -> Option<f64> {
        let s = self.raw[channel * BINS + bin.index()];
        (s >= 0.0).then(|| s * SCALES[channel])
    }

    /// Sets the BRDF of `channel` in `bin`, sr⁻¹ (stored divided by the channel's
    /// scale); `None`, or a value that is negative or not finite, leaves the bin
    /// without a value.
    ///
    /// # Panics
    /// For a channel index above 2.
    pub fn set(&mut self, channel: usize, bin: Bin, value: Option<f64>) {
        self.raw[channel * BINS + bin.index()] = match value {
            Some(v) if v.is_finite() && v >= 0.0 => v / SCALES[channel],
            _ => UNFILLED,
        };
    }

    /// The BRDF (R, G, B; sr⁻¹) the reference reader returns for the incident
    /// direction `wi` and outgoing direction `wo` (both away from the surface): the
    /// value of the bin [`Bin::of`] their [`half_diff`] angles; `None` when that bin has
    /// no value in some channel.
    #[must_use]
    pub fn lookup(&self, wi: [f64; 3], wo: [f64; 3]) -> Option<[f64; 3]> {
        let a = half_diff(wi, wo);
        let bin = Bin::of(a.theta_h, a.theta_d, a.phi_d);
        Some([
            self.value(0, bin)?,
            self.value(1, bin)?,
            self.value(2, bin)?,
        ])
    }
}

/// `true` when `head` (a file's first bytes, at least 12) starts with MERL's header
/// (`int32` 90, 90, 180).
#[must_use]
pub fn looks_like_merl(head: &[u8]) -> bool {
    head.len() >= 12 && header(head) == [90, 90, 180]
}

/// `true` when the file `path` starts with MERL's header ([`looks_like_merl`]);
/// `false` when it does not or cannot be read (reading it says why).
#[must_use]
pub fn is_merl_file(path: impl AsRef<Path>) -> bool {
    let mut head = [0u8; 12];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut head))
        .is_ok_and(|()| looks_like_merl(&head))
}

fn header(b: &[u8]) -> [i32; 3] {
    [
        crate::bytes::i32_le(b, 0),
        crate::bytes::i32_le(b, 4),
        crate::bytes::i32_le(b, 8),
    ]
}

/// Reads a MERL file.
///
/// # Errors
/// [`MerlError`] naming the file: unreadable, another header, another length, or a
/// stored number that is not finite.
pub fn read_merl(path: impl AsRef<Path>) -> Result<MerlTable, MerlError> {
    let path = path.as_ref();
    let mut bytes = Vec::new();
    std::fs::File::open(path)
        .and_then(|mut f| f.read_to_end(&mut bytes))
        .map_err(|source| MerlError::Io {
            path: path.to_path_buf(),
            source: crate::files::explain_open_error(path, source),
        })?;
    read_merl_bytes(&bytes, &path.display().to_string())
}

/// Reads a MERL file's bytes; `file` names it in errors.
///
/// # Errors
/// As [`read_merl`].
pub fn read_merl_bytes(bytes: &[u8], file: &str) -> Result<MerlTable, MerlError> {
    if bytes.len() < 12 {
        return Err(MerlError::NoHeader {
            file: file.to_owned(),
            len: bytes.len(),
        });
    }
    let dims = header(bytes);
    if dims != [90, 90, 180] {
        return Err(MerlError::Dims {
            file: file.to_owned(),
            dims,
        });
    }
    if bytes.len() != FILE_LEN {
        return Err(MerlError::Length {
            file: file.to_owned(),
            len: bytes.len(),
        });
    }
    let mut raw = Vec::with_capacity(3 * BINS);
    for (k, chunk) in bytes[12..].chunks_exact(8).enumerate() {
        let v = crate::bytes::f64_le(chunk, 0);
        if !v.is_finite() {
            return Err(MerlError::NotFinite {
                file: file.to_owned(),
                channel: k / BINS,
                bin: Bin::from_index(k % BINS).unwrap_or(Bin {
                    theta_h: 0,
                    theta_d: 0,
                    phi_d: 0,
                }),
                value: v,
            });
        }
        raw.push(v);
    }
    Ok(MerlTable { raw })
}

/// Writes `table` in MERL's layout: the header `90, 90, 180` (`int32`), then the
/// stored numbers (`float64`), little-endian.
///
/// # Errors
/// The writer's.
pub fn write_merl(w: &mut (impl Write + ?Sized), table: &MerlTable) -> std::io::Result<()> {
    let mut buf = Vec::with_capacity(FILE_LEN);
    for d in [90i32, 90, 180] {
        buf.extend_from_slice(&d.to_le_bytes());
    }
    for v in &table.raw {
        buf.extend_from_slice(&v.to_le_bytes());
    }
    w.write_all(&buf)
}

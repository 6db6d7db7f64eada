//! MERL BRDF files (`flakescatter_io::merl`) against a writer and a lookup written here,
//! independently, from the layout of MERL's reference reader (`BRDFRead.cpp`,
//! Matusik et al. 2003):
//!
//! * the file: three little-endian `int32` 90, 90, 180, then 3 × 90 × 90 × 180
//!   little-endian `float64`, R then G then B, the BRDF of a channel being the stored
//!   number times 1/1500, 1.15/1500, 1.66/1500;
//! * the lookup of a direction pair `(θin, φin, θout, φout)`: the half vector
//!   `h = (in + out)/|in + out|`, `θh = acos h.z`, `φh = atan2(h.y, h.x)`; the
//!   difference vector is `in` rotated by `−φh` about the normal `(0, 0, 1)`, then by
//!   `−θh` about the binormal `(0, 1, 0)` (Rodrigues' formula
//!   `v cos a + (k × v) sin a + k (k·v)(1 − cos a)`); `θd = acos d.z`,
//!   `φd = atan2(d.y, d.x)`; indices `⌊√(θh/(π/2) · 90 · 90)⌋`, `⌊θd/(π/2) · 90⌋`,
//!   `⌊(φd + π if φd < 0)/π · 180⌋`, clamped, and the bin `p + 180 d + 16200 h`.
//!
//! The test's writer stores a number that encodes the channel and the bin, so a
//! value read back names the bin it came from.

use std::f64::consts::{FRAC_PI_2, PI};

use flakescatter_io::merl::{
    BINS, Bin, FILE_LEN, MerlError, MerlTable, SCALES, read_merl, read_merl_bytes, write_merl,
};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The stored number the test's writer puts in channel `c`, flat bin `i`: distinct for
/// every (c, i), exact in `f64`; every 97th bin is left without a value (−1).
fn encoded(c: usize, i: usize) -> f64 {
    if i % 97 == 5 {
        -1.0
    } else {
        (c * BINS + i) as f64 * 0.5 + 0.25
    }
}

/// The test's own MERL writer: header then channels, little-endian, by hand.
fn independent_file() -> Vec<u8> {
    let mut b = Vec::with_capacity(FILE_LEN);
    for d in [90i32, 90, 180] {
        b.extend_from_slice(&d.to_le_bytes());
    }
    for c in 0..3 {
        for i in 0..BINS {
            b.extend_from_slice(&encoded(c, i).to_le_bytes());
        }
    }
    b
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Rodrigues' rotation of `v` about the unit `axis` by `angle`, as the reference's
/// `rotate_vector`.
fn rotate(v: [f64; 3], axis: [f64; 3], angle: f64) -> [f64; 3] {
    let (s, c) = angle.sin_cos();
    let k_dot_v = axis[0] * v[0] + axis[1] * v[1] + axis[2] * v[2];
    let k_x_v = cross(axis, v);
    [0, 1, 2].map(|j| v[j] * c + k_x_v[j] * s + axis[j] * k_dot_v * (1.0 - c))
}

fn spherical(theta: f64, phi: f64) -> [f64; 3] {
    [
        theta.sin() * phi.cos(),
        theta.sin() * phi.sin(),
        theta.cos(),
    ]
}

/// The reference reader's bin for `(θin, φin, θout, φout)`, step by step.
fn reference_bin(theta_in: f64, phi_in: f64, theta_out: f64, phi_out: f64) -> usize {
    let i = spherical(theta_in, phi_in);
    let o = spherical(theta_out, phi_out);
    let mut h = [i[0] + o[0], i[1] + o[1], i[2] + o[2]];
    let n = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
    h = h.map(|x| x / n);
    let theta_half = h[2].acos();
    let phi_half = h[1].atan2(h[0]);
    let temp = rotate(i, [0.0, 0.0, 1.0], -phi_half);
    let diff = rotate(temp, [0.0, 1.0, 0.0], -theta_half);
    let theta_diff = diff[2].acos();
    let mut phi_diff = diff[1].atan2(diff[0]);
    let th = if theta_half <= 0.0 {
        0
    } else {
        let deg = theta_half / FRAC_PI_2 * 90.0;
        ((deg * 90.0).sqrt() as i64).clamp(0, 89)
    };
    let td = ((theta_diff / FRAC_PI_2 * 90.0) as i64).clamp(0, 89);
    if phi_diff < 0.0 {
        phi_diff += PI;
    }
    let pd = ((phi_diff / PI * 360.0 / 2.0) as i64).clamp(0, 179);
    (pd + td * 180 + th * 180 * 90) as usize
}

#[test]
fn an_independently_written_file_reads_as_the_reference_reader_looks_it_up() {
    let bytes = independent_file();
    let table = read_merl_bytes(&bytes, "independent.binary").unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(2003);
    let mut filled = 0;
    for _ in 0..1000 {
        let (ti, pi) = (rng.random_range(0.0..FRAC_PI_2), rng.random_range(-PI..PI));
        let (to, po) = (rng.random_range(0.0..FRAC_PI_2), rng.random_range(-PI..PI));
        let i = reference_bin(ti, pi, to, po);
        let got = table.lookup(spherical(ti, pi), spherical(to, po));
        if encoded(0, i) < 0.0 {
            assert_eq!(got, None, "bin {i} has no value");
            continue;
        }
        filled += 1;
        let want = [0, 1, 2].map(|c| encoded(c, i) * SCALES[c]);
        assert_eq!(
            got,
            Some(want),
            "directions ({ti}, {pi}), ({to}, {po}): bin {i}"
        );
    }
    assert!(filled > 950, "{filled} of 1000 directions in filled bins");
}

#[test]
fn write_then_read_gives_every_bin_back_bit_for_bit() {
    let mut rng = ChaCha8Rng::seed_from_u64(1500);
    let raw: Vec<f64> = (0..3 * BINS)
        .map(|k| {
            if k % 11 == 0 {
                -1.0
            } else {
                rng.random_range(0.0..1e4) * rng.random_range(0.0..1.0f64).powi(8)
            }
        })
        .collect();
    let table = MerlTable::from_raw(raw).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("paint.binary");
    let mut file = std::fs::File::create(&path).unwrap();
    write_merl(&mut file, &table).unwrap();
    drop(file);
    assert_eq!(std::fs::metadata(&path).unwrap().len(), FILE_LEN as u64);
    let back = read_merl(&path).unwrap();
    let same = back
        .raw()
        .iter()
        .zip(table.raw())
        .all(|(a, b)| a.to_bits() == b.to_bits());
    assert!(same, "a bin changed on the round trip");
    // The header bytes are MERL's, whoever reads them.
    let bytes = std::fs::read(&path).unwrap();
    assert_eq!(&bytes[..12], &[90, 0, 0, 0, 90, 0, 0, 0, 180, 0, 0, 0]);
}

#[test]
fn every_bin_centre_is_looked_up_in_its_own_bin() {
    // The reference's lookup of the directions `Bin::centre_directions` gives must land
    // in the same bin (checked with the test's own lookup, not the library's), and the
    // centre is below the horizon exactly when a direction's z is not positive.
    let mut above = 0;
    for i in 0..BINS {
        let bin = Bin::from_index(i).unwrap();
        let Some((wi, wo)) = bin.centre_directions() else {
            continue;
        };
        above += 1;
        let (ti, pi) = (wi[2].acos(), wi[1].atan2(wi[0]));
        let (to, po) = (wo[2].acos(), wo[1].atan2(wo[0]));
        assert_eq!(reference_bin(ti, pi, to, po), i, "bin {bin:?}");
        // Mirror directions about the half vector: the half vector's polar angle is θh.
        let c = bin.centre();
        let h = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
        let n = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
        assert!((h[2] / n - c.theta_h.cos()).abs() < 1e-12);
        // The angle between wi and wo is 2 θd.
        let dot = wi[0] * wo[0] + wi[1] * wo[1] + wi[2] * wo[2];
        assert!((dot - (2.0 * c.theta_d).cos()).abs() < 1e-12);
    }
    // Roughly half the table is above the horizon for both directions.
    assert!(
        above > BINS / 3 && above < BINS,
        "{above} bins above the horizon"
    );
}

#[test]
fn set_stores_the_value_divided_by_the_channel_scale() {
    let mut t = MerlTable::unfilled();
    let bin = Bin::new(3, 4, 5).unwrap();
    t.set(2, bin, Some(1.66 / 1500.0 * 7.0));
    let stored = t.channel(2)[5 + 180 * 4 + 16200 * 3];
    assert!((stored - 7.0).abs() < 1e-12, "{stored}");
    t.set(2, bin, Some(f64::NAN));
    assert_eq!(t.channel(2)[bin.index()], -1.0);
    t.set(0, bin, Some(-0.5));
    assert_eq!(t.value(0, bin), None);
}

fn err(bytes: &[u8]) -> String {
    read_merl_bytes(bytes, "bad.binary")
        .unwrap_err()
        .to_string()
}

#[test]
fn malformed_files_are_refused_with_the_file_and_what_was_expected() {
    let good = independent_file();
    let e = err(&good[..7]);
    assert!(
        e.contains("bad.binary") && e.contains("7 bytes") && e.contains("header"),
        "{e}"
    );
    let mut dims = good.clone();
    dims[8..12].copy_from_slice(&360i32.to_le_bytes());
    let e = err(&dims);
    assert!(
        e.contains("[90, 90, 360]") && e.contains("expected [90, 90, 180]"),
        "{e}"
    );
    let e = err(&good[..good.len() - 8]);
    assert!(
        e.contains("truncated") && e.contains(&FILE_LEN.to_string()),
        "{e}"
    );
    let mut long = good.clone();
    long.push(0);
    let e = err(&long);
    assert!(e.contains("longer than its table"), "{e}");
    let mut nan = good;
    // Channel G (1), flat bin 16200·2 + 180·3 + 4.
    let k = 12 + 8 * (BINS + 16200 * 2 + 180 * 3 + 4);
    nan[k..k + 8].copy_from_slice(&f64::NAN.to_le_bytes());
    let e = err(&nan);
    assert!(
        e.contains("channel G bin (θh 2, θd 3, φd 4)") && e.contains("NaN"),
        "{e}"
    );
    let missing = read_merl("/nonexistent/dir/paint.binary").unwrap_err();
    assert!(matches!(missing, MerlError::Io { .. }));
    assert!(
        missing
            .to_string()
            .contains("/nonexistent/dir/paint.binary")
    );
}

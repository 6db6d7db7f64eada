//! Fixed-width numbers read at a byte offset, shared by the binary readers (FRT, PLU,
//! SUR, AL3D, OPD, MetroPro, GWY, SDF, X3P): `xxx_le(b, a)` is the little-endian number
//! whose first byte is `b[a]`, `xxx_be(b, a)` the big-endian one.
//!
//! Each reader checks the bytes it reads against the file's length first and names
//! what is missing ("file is truncated: … needs … bytes"); these helpers index the
//! slice directly, so a reader that skipped that check would panic, not read garbage.

/// The `N` bytes at `a` (callers have checked they exist).
#[inline]
fn at<const N: usize>(b: &[u8], a: usize) -> [u8; N] {
    let mut w = [0u8; N];
    w.copy_from_slice(&b[a..a + N]);
    w
}

/// Little-endian `u16` at byte `a`.
#[inline]
pub(crate) fn u16_le(b: &[u8], a: usize) -> u16 {
    u16::from_le_bytes(at(b, a))
}

/// Little-endian `i16` at byte `a`.
#[inline]
pub(crate) fn i16_le(b: &[u8], a: usize) -> i16 {
    i16::from_le_bytes(at(b, a))
}

/// Little-endian `u32` at byte `a`.
#[inline]
pub(crate) fn u32_le(b: &[u8], a: usize) -> u32 {
    u32::from_le_bytes(at(b, a))
}

/// Little-endian `i32` at byte `a`.
#[inline]
pub(crate) fn i32_le(b: &[u8], a: usize) -> i32 {
    i32::from_le_bytes(at(b, a))
}

/// Little-endian `i64` at byte `a`.
#[inline]
pub(crate) fn i64_le(b: &[u8], a: usize) -> i64 {
    i64::from_le_bytes(at(b, a))
}

/// Little-endian `f32` at byte `a`.
#[inline]
pub(crate) fn f32_le(b: &[u8], a: usize) -> f32 {
    f32::from_le_bytes(at(b, a))
}

/// Little-endian `f64` at byte `a`.
#[inline]
pub(crate) fn f64_le(b: &[u8], a: usize) -> f64 {
    f64::from_le_bytes(at(b, a))
}

/// Big-endian `u16` at byte `a`.
#[inline]
pub(crate) fn u16_be(b: &[u8], a: usize) -> u16 {
    u16::from_be_bytes(at(b, a))
}

/// Big-endian `u32` at byte `a`.
#[inline]
pub(crate) fn u32_be(b: &[u8], a: usize) -> u32 {
    u32::from_be_bytes(at(b, a))
}

/// Big-endian `i32` at byte `a`.
#[inline]
pub(crate) fn i32_be(b: &[u8], a: usize) -> i32 {
    i32::from_be_bytes(at(b, a))
}

/// Big-endian `f32` at byte `a`.
#[inline]
pub(crate) fn f32_be(b: &[u8], a: usize) -> f32 {
    f32::from_be_bytes(at(b, a))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each helper against the number written out by hand: bytes 01 02 03 04 05 06 07 08
    /// read little-endian from offset 1 are 0x..05040302, big-endian 0x02030405...
    #[test]
    fn numbers_at_an_offset_in_both_byte_orders() {
        let b = [0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0x08, 0x09];
        assert_eq!(u16_le(&b, 1), 0x0302);
        assert_eq!(u16_be(&b, 1), 0x0203);
        assert_eq!(u32_le(&b, 1), 0x0504_0302);
        assert_eq!(u32_be(&b, 1), 0x0203_0405);
        assert_eq!(i64_le(&b, 1), 0x0908_0706_0504_0302);
        // Signed: the top bit set is negative (two's complement).
        let neg = [0x00, 0xfe, 0xff, 0xff, 0xff];
        assert_eq!(i16_le(&neg, 1), -2);
        assert_eq!(i32_le(&neg, 1), -2);
        assert_eq!(i32_be(&[0xff, 0xff, 0xff, 0xfe], 0), -2);
        // 1.5 = 0x3FC00000 (f32) = 0x3FF8000000000000 (f64).
        assert_eq!(f32_le(&[0x00, 0x00, 0x00, 0xc0, 0x3f], 1), 1.5);
        assert_eq!(f32_be(&[0x3f, 0xc0, 0x00, 0x00], 0), 1.5);
        assert_eq!(f64_le(&[0, 0, 0, 0, 0, 0, 0xf8, 0x3f], 0), 1.5);
    }

    #[test]
    #[should_panic(expected = "out of range")]
    fn reading_past_the_end_is_a_panic_not_garbage() {
        let _ = u32_le(&[1, 2, 3], 0);
    }
}

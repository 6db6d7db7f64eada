//! Numbers as the CLI's files write them: the shortest text that reads back to the same
//! value, in exponent form (`{:e}`), built from `zmij's digits (the shortest-digit formatter serde_json uses) without allocating per
//! value (the curve tables of a large grid write about a million of them).

/// Shortest round-trip text of a value, in exponent form; empty when not finite.
pub fn num(x: f64) -> String {
    let mut s = String::new();
    push_num(&mut s, x);
    s
}

/// Appends [`num`]'s text of `x` to `out`: the shortest digits that read back to `x`, one
/// before the point, then `e` and the decimal exponent (`4.929e2`, `1e0`, `-2.5e-7`), as
/// `format!("{x:e}")` writes them; `0` for zero and nothing for a non-finite value. The
/// digits come from `zmij`, several times faster than the standard library's formatter;
/// the two agree except where two shortest strings are equally near `x` (zmij, like
/// Python's `repr`, takes the even last digit; the standard library rounds up).
pub fn push_num(out: &mut String, x: f64) {
    let mut buf = [0u8; 32];
    let n = num_bytes(&mut buf, x);
    // Only ASCII digits, `-`, `.` and `e` are written.
    out.push_str(std::str::from_utf8(&buf[..n]).unwrap_or_default());
}

/// Appends [`num`]'s text of `x` to a byte buffer (the CSV writer's row buffer).
pub fn push_num_bytes(out: &mut Vec<u8>, x: f64) {
    let mut buf = [0u8; 32];
    let n = num_bytes(&mut buf, x);
    out.extend_from_slice(&buf[..n]);
}

/// Writes [`num`]'s text of `x` into `buf` and returns its length: one pass over
/// `zmij`'s bytes (`ddd.ddd`, `0.000ddd` or `d.ddde±N`, `+` dropped), no allocation, no formatter.
fn num_bytes(buf: &mut [u8; 32], x: f64) -> usize {
    if !x.is_finite() {
        return 0;
    }
    if x == 0.0 {
        buf[0] = b'0';
        return 1;
    }
    let mut digits_buf = zmij::Buffer::new();
    let text = digits_buf.format_finite(x).as_bytes();
    // zmij writes `d.ddde-N` or `de-N` for small magnitudes: already our form (large
    // ones come as `de+N`, and lose the `+` below).
    if text.contains(&b'e') && !text.contains(&b'+') {
        buf[..text.len()].copy_from_slice(text);
        return text.len();
    }
    let (negative, text) = match text.split_first() {
        Some((b'-', t)) => (true, t),
        _ => (false, text),
    };
    // The significant digits (at most 17) and the decimal exponent of the first one:
    // `point` counts the mantissa's digits before its decimal point, `exp10` is zmij's
    // own exponent, if it wrote one.
    let mut digits = [0u8; 20];
    let mut n = 0;
    let mut point: Option<i32> = None;
    let mut first: Option<i32> = None;
    let mut seen = 0i32;
    let mut exp10 = 0i32;
    let mut k = 0;
    while k < text.len() {
        let c = text[k];
        match c {
            b'.' => point = Some(seen),
            b'e' => {
                let (sign, rest) = match text.get(k + 1) {
                    Some(b'-') => (-1, &text[k + 2..]),
                    Some(b'+') => (1, &text[k + 2..]),
                    _ => (1, &text[k + 1..]),
                };
                exp10 = sign * rest.iter().fold(0i32, |e, &d| e * 10 + i32::from(d - b'0'));
                break;
            }
            _ => {
                if first.is_none() && c != b'0' {
                    first = Some(seen);
                }
                if first.is_some() && n < digits.len() {
                    digits[n] = c;
                    n += 1;
                }
                seen += 1;
            }
        }
        k += 1;
    }
    while n > 1 && digits[n - 1] == b'0' {
        n -= 1;
    }
    // The first significant digit's position relative to the decimal point.
    let exponent = point.unwrap_or(seen) - 1 - first.unwrap_or(0) + exp10;
    let mut len = 0;
    if negative {
        buf[len] = b'-';
        len += 1;
    }
    buf[len] = digits[0];
    len += 1;
    if n > 1 {
        buf[len] = b'.';
        len += 1;
        buf[len..len + n - 1].copy_from_slice(&digits[1..n]);
        len += n - 1;
    }
    buf[len] = b'e';
    len += 1;
    if exponent < 0 {
        buf[len] = b'-';
        len += 1;
    }
    // |exponent| ≤ 324: at most three digits.
    let e = exponent.unsigned_abs();
    let mut started = false;
    for div in [100, 10, 1] {
        let d = (e / div) % 10;
        if d != 0 || started || div == 1 {
            buf[len] = b'0' + d as u8;
            len += 1;
            started = true;
        }
    }
    len
}

#[cfg(test)]
mod tests {
    use super::{num, push_num};

    /// `num` against the standard library's `{:e}` (an independent implementation of
    /// the shortest round-trip rule): edge cases and a million bit patterns drawn by a
    /// fixed xorshift sequence over every exponent. Each text reads back to the same bits,
    /// has as many digits as the standard library's, and equals it, except in a tie
    /// between two shortest strings, where the two differ by one in the last digit.
    #[test]
    fn num_is_the_shortest_exponent_form() {
        let mut ties = 0;
        let mut check = |x: f64| {
            let got = num(x);
            if !x.is_finite() {
                assert_eq!(got, "", "{x:?}");
                return;
            }
            if x == 0.0 {
                assert_eq!(got, "0");
                return;
            }
            assert_eq!(got.parse::<f64>().unwrap().to_bits(), x.to_bits(), "{got}");
            let want = format!("{x:e}");
            if got != want {
                let digits = |t: &str| {
                    t.split('e')
                        .next()
                        .unwrap()
                        .replace(['-', '.'], "")
                        .to_owned()
                };
                let (g, w) = (digits(&got), digits(&want));
                let n = g.len();
                assert_eq!(w.len(), n, "{got} vs {want}");
                assert_eq!(g[..n - 1], w[..n - 1], "{got} vs {want}");
                let last = |d: &str| i32::from(d.as_bytes()[n - 1] - b'0');
                assert_eq!(last(&w) - last(&g), 1, "{got} vs {want}");
                assert_eq!(last(&g) % 2, 0, "{got} vs {want}");
                assert_eq!(got.split('e').nth(1), want.split('e').nth(1));
                ties += 1;
            }
        };
        for x in [
            1.0,
            -1.0,
            0.1,
            492.9,
            1e21,
            1e-7,
            123_456_789.0,
            0.000_123,
            f64::MIN_POSITIVE,
            5e-324,
            f64::MAX,
            -f64::MAX,
            2.0f64.powi(60),
            0.3,
            1.5,
            -0.0,
            f64::NAN,
            f64::INFINITY,
            1_658_206_780_088_562.3,
        ] {
            check(x);
        }
        let mut s = 0x9e37_79b9_7f4a_7c15u64;
        for _ in 0..1_000_000 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            check(f64::from_bits(s));
        }
        // Ties are rare but real (the value above is one).
        assert!((1..10_000).contains(&ties), "{ties}");
        // Appending keeps what is there.
        let mut out = String::from("a,");
        push_num(&mut out, 2.5);
        assert_eq!(out, "a,2.5e0");
    }
}

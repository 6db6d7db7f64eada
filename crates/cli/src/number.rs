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

/// Appends `x` as `serde_json` writes an `f64` (or an `Option<f64>`): `zmij`'s shortest
/// digits (`serde_json`'s own formatter: `0.0`, `-89.0`, `0.00006197554196423979`,
/// `5.194952164430276e-7`), `null`
/// for `None` and for a value that is not finite.
pub fn push_json_num(out: &mut Vec<u8>, x: Option<f64>) {
    match x {
        Some(x) if x.is_finite() => {
            out.extend_from_slice(zmij::Buffer::new().format_finite(x).as_bytes());
        }
        _ => out.extend_from_slice(b"null"),
    }
}

/// Writes [`num`]'s text of `x` into `buf` and returns its length: `zmij`'s text
/// (`ddd.ddd`, `0.000ddd`, `d.ddde-N` or `de+N`) rewritten in place into our form, slices
/// copied whole; no allocation, no formatter.
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
    let (negative, body) = match text.split_first() {
        Some((b'-', t)) => (true, t),
        _ => (false, text),
    };
    // zmij's own exponent, if it wrote one: `e-N` is already our form (small
    // magnitudes), `e+N` loses its `+` below.
    let (mantissa, exp10) = match body.iter().position(|&c| c == b'e') {
        Some(k) => {
            let digits = match &body[k + 1..] {
                [b'-', ..] => {
                    buf[..text.len()].copy_from_slice(text);
                    return text.len();
                }
                [b'+', rest @ ..] | rest => rest,
            };
            let e = digits
                .iter()
                .fold(0i32, |e, &d| e * 10 + i32::from(d - b'0'));
            (&body[..k], e)
        }
        None => (body, 0),
    };
    let (int, frac) = match mantissa.iter().position(|&c| c == b'.') {
        Some(p) => (&mantissa[..p], &mantissa[p + 1..]),
        None => (mantissa, &[][..]),
    };
    // The significant digits as (up to) two slices, and the decimal exponent of the
    // first: `ddd.ddd` → int and frac, `0.000ddd` → frac after its leading zeros.
    let (head, tail, exponent) = if int.iter().all(|&c| c == b'0') {
        let zeros = frac.iter().take_while(|&&c| c == b'0').count();
        (&frac[zeros..], &[][..], exp10 - 1 - zeros as i32)
    } else {
        (int, frac, exp10 + int.len() as i32 - 1)
    };
    // Trailing zeros are not significant (`100` → `1e2`); only the last non-empty slice
    // can end in them, and `head` starts with a non-zero digit.
    let trim = |d: &[u8]| d.len() - d.iter().rev().take_while(|&&c| c == b'0').count();
    let (head, tail) = if trim(tail) == 0 {
        (&head[..trim(head)], &[][..])
    } else {
        (head, &tail[..trim(tail)])
    };
    let mut len = 0;
    if negative {
        buf[0] = b'-';
        len = 1;
    }
    buf[len] = head[0];
    len += 1;
    let rest = head.len() - 1 + tail.len();
    if rest > 0 {
        buf[len] = b'.';
        len += 1;
        buf[len..len + head.len() - 1].copy_from_slice(&head[1..]);
        len += head.len() - 1;
        buf[len..len + tail.len()].copy_from_slice(tail);
        len += tail.len();
    }
    buf[len] = b'e';
    len += 1;
    if exponent < 0 {
        buf[len] = b'-';
        len += 1;
    }
    // |exponent| ≤ 324: at most three digits.
    let e = exponent.unsigned_abs();
    if e >= 100 {
        buf[len] = b'0' + (e / 100) as u8;
        len += 1;
    }
    if e >= 10 {
        buf[len] = b'0' + (e / 10 % 10) as u8;
        len += 1;
    }
    buf[len] = b'0' + (e % 10) as u8;
    len + 1
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
        // zmij writes magnitudes of about 1e-5 to 1e16 without an exponent (`123.45`,
        // `0.000123`), which the bit patterns above seldom reach: a million values there,
        // and round numbers with trailing zeros.
        for i in 0..1_000_000 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let u = (s >> 11) as f64 / (1u64 << 53) as f64;
            let v = 10f64.powf(-7.0 + 25.0 * u);
            check(if i % 2 == 0 { v } else { -v });
            if i % 10 == 0 {
                check((v * 1e3).round());
                check((v * 1e3).round() / 1e3);
            }
        }
        // Ties are rare but real (the value above is one).
        assert!((1..10_000).contains(&ties), "{ties}");
        // Appending keeps what is there.
        let mut out = String::from("a,");
        push_num(&mut out, 2.5);
        assert_eq!(out, "a,2.5e0");
    }
}

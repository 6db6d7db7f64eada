//! Numbers as the CLI's files write them: the shortest text that reads back to the same
//! value, in exponent form (`{:e}`), built from `zmij's digits (the shortest-digit formatter serde_json uses) without allocating per
//! value (the curve tables of a large grid write about a million of them).

/// Shortest round-trip text of a value, in exponent form; empty when not finite.
pub fn num(x: f64) -> String {
    let mut out = Vec::with_capacity(24);
    push_num_bytes(&mut out, x);
    // Only ASCII digits, `-`, `.` and `e` are written.
    String::from_utf8(out).unwrap_or_default()
}

/// Appends [`num`]'s text of `x` to a byte buffer (the table writers' row buffers): the
/// shortest digits that read back to `x`, one before the point, then `e` and the
/// decimal exponent (`4.929e2`, `1e0`, `-2.5e-7`), as `format!("{x:e}")` writes them;
/// `0` for zero and nothing for a non-finite value. The digits come from `zmij`, several
/// times faster than the standard library's formatter; the two agree except where two
/// shortest strings are equally near `x` (zmij, like Python's `repr`, takes the even
/// last digit; the standard library rounds up).
///
/// `zmij`'s text is `d.ddde-N` or `de-N` (already this form), `d.ddde+N`, or for
/// decimal exponents −5 to 15 `ddd.ddd`, `0.000ddd` or `ddd000.0`; its pieces are
/// appended straight to `out`, with no allocation, formatter or copy between.
pub fn push_num_bytes(out: &mut Vec<u8>, x: f64) {
    if !x.is_finite() {
        return;
    }
    if x == 0.0 {
        out.push(b'0');
        return;
    }
    let mut digits_buf = zmij::Buffer::new();
    let text = digits_buf.format_finite(x).as_bytes();
    let n = text.len();
    // The exponent form ends in `e`, a sign and one to three digits.
    let e = (3..=5)
        .map(|k| n.wrapping_sub(k))
        .find(|&i| text.get(i) == Some(&b'e'));
    if let Some(e) = e {
        if text[e + 1] == b'-' {
            out.extend_from_slice(text);
        } else {
            out.extend_from_slice(&text[..=e]);
            out.extend_from_slice(&text[e + 2..]);
        }
        return;
    }
    let (sign, body) = match text.split_first() {
        Some((b'-', rest)) => (&b"-"[..], rest),
        _ => (&b""[..], text),
    };
    out.extend_from_slice(sign);
    if body.first() == Some(&b'0') {
        // `0.000ddd`: up to four zeros after the point, then the significant digits.
        let frac = body.get(2..).unwrap_or_default();
        let zeros = frac.iter().take_while(|&&c| c == b'0').count();
        let digits = &frac[zeros..];
        push_mantissa(out, digits, &[]);
        // 1 to 5.
        out.extend_from_slice(&[b'e', b'-', b'1' + zeros as u8]);
        return;
    }
    // `ddd.ddd`, or `ddd000.0` for an integer, whose trailing zeros are not significant
    // (`100` → `1e2`).
    let point = body.iter().position(|&c| c == b'.').unwrap_or(body.len());
    let (int, frac) = body.split_at(point);
    let frac = frac.get(1..).unwrap_or_default();
    let (int, frac) = if frac == b"0" {
        let zeros = int.iter().rev().take_while(|&&c| c == b'0').count();
        (&int[..int.len() - zeros], &[][..])
    } else {
        (int, frac)
    };
    push_mantissa(out, int, frac);
    // 0 to 15.
    let exponent = point.saturating_sub(1) as u8;
    if exponent >= 10 {
        out.extend_from_slice(&[b'e', b'1', b'0' + exponent - 10]);
    } else {
        out.extend_from_slice(&[b'e', b'0' + exponent]);
    }
}

/// Appends `x` as `serde_json` writes an `f64` (or an `Option<f64>`): `zmij`'s shortest
/// digits (`serde_json`'s own formatter: `0.0`, `-89.0`, `0.00006197554196423979`,
/// `5.194952164430276e-7`), `null` for `None` and for a value that is not finite.
pub fn push_json_num(out: &mut Vec<u8>, x: Option<f64>) {
    match x {
        Some(x) if x.is_finite() => {
            out.extend_from_slice(zmij::Buffer::new().format_finite(x).as_bytes());
        }
        _ => out.extend_from_slice(b"null"),
    }
}

/// Appends the significant digits `head` then `tail` (`head` non-empty) with the point
/// after the first: `d.ddd`, or `d` alone.
fn push_mantissa(out: &mut Vec<u8>, head: &[u8], tail: &[u8]) {
    let Some((first, rest)) = head.split_first() else {
        return;
    };
    out.push(*first);
    if !rest.is_empty() || !tail.is_empty() {
        out.push(b'.');
        out.extend_from_slice(rest);
        out.extend_from_slice(tail);
    }
}

#[cfg(test)]
mod tests {
    use super::{num, push_num_bytes};

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
        let mut out = b"a,".to_vec();
        push_num_bytes(&mut out, 2.5);
        assert_eq!(out, b"a,2.5e0");
    }
}

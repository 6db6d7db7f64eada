//! Numbers as the CLI's files write them: the shortest text that reads back to the same
//! value, in exponent form (`{:e}`), built from `ryu`'s digits without allocating per
//! value (the curve tables of a large grid write about a million of them).

use std::fmt::Write as _;

/// Shortest round-trip text of a value, in exponent form; empty when not finite.
pub fn num(x: f64) -> String {
    let mut s = String::new();
    push_num(&mut s, x);
    s
}

/// Appends [`num`]'s text of `x` to `out`: the shortest digits that read back to `x`, one
/// before the point, then `e` and the decimal exponent (`4.929e2`, `1e0`, `-2.5e-7`), as
/// `format!("{x:e}")` writes them; `0` for zero and nothing for a non-finite value. The
/// digits come from `ryu`, several times faster than the standard library's formatter;
/// the two agree except where two shortest strings are equally near `x` (ryu, like
/// Python's `repr`, takes the even last digit; the standard library rounds up).
pub fn push_num(out: &mut String, x: f64) {
    if !x.is_finite() {
        return;
    }
    if x == 0.0 {
        out.push('0');
        return;
    }
    let mut buf = ryu::Buffer::new();
    let text = buf.format_finite(x);
    let (negative, text) = match text.strip_prefix('-') {
        Some(t) => (true, t),
        None => (false, text),
    };
    // ryu writes `ddd.ddd`, `0.000ddd` or `d.ddde±N`; collect the significant digits and
    // the decimal exponent of the first one.
    let (mantissa, exp10) = match text.split_once('e') {
        Some((m, e)) => (m, e.parse::<i32>().unwrap_or(0)),
        None => (text, 0),
    };
    let (int_part, frac_part) = mantissa.split_once('.').unwrap_or((mantissa, ""));
    let mut digits = [0u8; 40];
    let mut n = 0;
    let mut first: Option<i32> = None;
    // Position of each digit relative to the decimal point: int digits 0.., counting down.
    for (k, c) in int_part.bytes().chain(frac_part.bytes()).enumerate() {
        if first.is_none() && c == b'0' {
            continue;
        }
        let pos = int_part.len() as i32 - 1 - k as i32;
        if first.is_none() {
            first = Some(pos);
        }
        if n < digits.len() {
            digits[n] = c;
            n += 1;
        }
    }
    while n > 1 && digits[n - 1] == b'0' {
        n -= 1;
    }
    let exponent = first.unwrap_or(0) + exp10;
    if negative {
        out.push('-');
    }
    out.push(char::from(digits[0]));
    if n > 1 {
        out.push('.');
        for &d in &digits[1..n] {
            out.push(char::from(d));
        }
    }
    out.push('e');
    let _ = write!(out, "{exponent}");
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

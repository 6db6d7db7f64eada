//! Reader options drawn from the first input byte, so that one corpus explores every
//! combination the command line can ask for.

use flakescatter_io::{DecimalMark, ReadOptions, ValueKind, ZUnit};

/// `(options, kind, rest of the input)` from the first byte of `data`.
pub fn split(data: &[u8]) -> Option<(ReadOptions, ValueKind, &[u8])> {
    let (&b, rest) = data.split_first()?;
    let options = ReadOptions {
        pixel_um: (b & 1 != 0).then_some((0.5, 0.25)),
        // None half of the time: X3P and SDF heights refuse the text-only options.
        z_unit: match (b >> 1) & 3 {
            0 | 1 => None,
            2 => Some(ZUnit::Nm),
            _ => Some(ZUnit::M),
        },
        accept_md5_mismatch: b & 8 != 0,
        decimal: match (b >> 4) & 3 {
            0 | 3 => DecimalMark::Auto,
            1 => DecimalMark::Point,
            _ => DecimalMark::Comma,
        },
        channel: (b & 64 != 0).then_some(0),
        // Every bit of the first byte is taken: the length of the rest picks whether the
        // map is read as the quantity its file declares (`convert`, `info`) or as asked.
        as_stored: rest.len() % 2 == 1,
    };
    let kind = if b & 128 != 0 {
        ValueKind::Intensity
    } else {
        ValueKind::Height
    };
    Some((options, kind, rest))
}

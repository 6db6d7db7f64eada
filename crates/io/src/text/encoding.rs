//! Recognising text and decoding it: UTF-8 (with or without a byte-order mark), UTF-16
//! with a byte-order mark, else Latin-1.

use std::borrow::Cow;

use crate::reader::Confidence;

use super::error::TextError;

/// Whether a byte can occur in a text file (anything but C0 controls other than tab,
/// line feed, form feed and carriage return, and DEL).
pub(super) fn text_byte(b: u8) -> bool {
    !(b < 0x20 && !matches!(b, b'\t' | b'\n' | b'\r' | 0x0c) || b == 0x7f)
}

pub(super) fn utf16_bom(bytes: &[u8]) -> Option<bool> {
    if bytes.starts_with(&[0xff, 0xfe]) {
        Some(true)
    } else if bytes.starts_with(&[0xfe, 0xff]) {
        Some(false)
    } else {
        None
    }
}

/// Scores `bytes` as a text matrix: low (20), as the format of last resort, when every
/// byte can occur in text (or the file is UTF-16 with a byte-order mark); 0 otherwise.
pub fn detect(bytes: &[u8]) -> Confidence {
    if bytes.is_empty() {
        return 0;
    }
    if utf16_bom(bytes).is_some() {
        return 20;
    }
    if bytes.iter().all(|&b| text_byte(b)) {
        20
    } else {
        0
    }
}

/// The text and the encoding it was decoded from.
pub(crate) fn decode(bytes: &[u8]) -> Result<(Cow<'_, str>, &'static str), TextError> {
    if let Some(little) = utf16_bom(bytes) {
        let units: Vec<u16> = bytes[2..]
            .chunks(2)
            .map(|c| {
                let pair = [c[0], *c.get(1).unwrap_or(&0)];
                if little {
                    u16::from_le_bytes(pair)
                } else {
                    u16::from_be_bytes(pair)
                }
            })
            .collect();
        let text = String::from_utf16_lossy(&units);
        let name = if little { "UTF-16LE" } else { "UTF-16BE" };
        return Ok((Cow::Owned(text), name));
    }
    if let Some(offset) = bytes.iter().position(|&b| !text_byte(b)) {
        return Err(TextError::Binary {
            offset,
            byte: bytes[offset],
        });
    }
    match std::str::from_utf8(bytes) {
        Ok(s) => Ok((
            Cow::Borrowed(s.strip_prefix('\u{feff}').unwrap_or(s)),
            "UTF-8",
        )),
        // Not UTF-8: Latin-1, where every byte is the code point of the same number.
        Err(_) => Ok((
            Cow::Owned(bytes.iter().map(|&b| char::from(b)).collect()),
            "Latin-1",
        )),
    }
}

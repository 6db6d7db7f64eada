//! Which quantity a map file holds, heights or intensities (issue 52, item 5), so that
//! an intensity image is never read, written or reported as heights.
//!
//! None of the ISO formats has a field for it (an X3P or SDF `Z` is a height in
//! metres), so the writers of this crate mark an intensity image and the readers look
//! for the mark:
//!
//! | format | intensity image written as | recognised by |
//! | --- | --- | --- |
//! | X3P | Z `Increment` 1 (the stored value is the intensity) and a `Record2/Comment` starting [`X3P_INTENSITY_MARK`] | the comment's start; or, for files of earlier versions of this crate, `ProbingSystem/Identification` `flakescatter` with a Z `Increment` of exactly `1` (its height files always have `1e-6`) |
//! | SDF (text, binary) | `Zscale` 1, and the trailer line [`SDF_INTENSITY_LINE`] after the data | a trailer line `Quantity = intensity` |
//! | text | `# Channel: intensity`, no value unit | the header `Channel` (or `Kanal`): `intensity` (`Intensität`), or `height` (`Höhe`) for heights |
//!
//! The instrument formats, which cannot be written, declare nothing here (their
//! channels are chosen by name or index). A file that declares nothing is read as what
//! is asked (heights, or an intensity where one is expected); one that declares the
//! other quantity is refused ([`crate::MapError::Quantity`]), unless
//! [`ReadOptions::as_stored`](crate::ReadOptions::as_stored) asks for the file's own.

use crate::bytes::u16_le;
use crate::reader::{ValueKind, split_lines};

/// How the comment of an X3P intensity image starts.
pub const X3P_INTENSITY_MARK: &str =
    "Intensity, unit-less (Z increment 1: the stored value is the intensity)";

/// The trailer line of an SDF intensity image.
pub const SDF_INTENSITY_LINE: &str =
    "Quantity = intensity (unit-less; Zscale 1: the stored value is the intensity)";

/// A quantity a file declares, and where it says so (for messages).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Declared {
    /// Heights or intensities.
    pub quantity: ValueKind,
    /// Where the file says so, e.g. `its Record2/Comment starts "Intensity, unit-less"`.
    pub by: String,
}

/// The comment an X3P writer writes: `comment` with the intensity mark in front for an
/// intensity image (once), without it for heights.
pub(crate) fn x3p_comment(comment: String, intensity: bool) -> String {
    let rest = comment
        .strip_prefix(X3P_INTENSITY_MARK)
        .map(|r| r.trim_start_matches(['.', ' ']).to_string());
    match (intensity, rest) {
        (true, Some(_)) => comment,
        (true, None) if comment.is_empty() => X3P_INTENSITY_MARK.to_string(),
        (true, None) => format!("{X3P_INTENSITY_MARK}. {comment}"),
        (false, Some(r)) => r,
        (false, None) => comment,
    }
}

/// What the `main.xml` of an X3P file declares (`xml`: its bytes, as
/// [`crate::x3p::main_xml`] gives them).
pub(crate) fn x3p(xml: &[u8]) -> Option<Declared> {
    let Ok(text) = std::str::from_utf8(xml) else {
        return None;
    };
    let Ok(doc) = roxmltree::Document::parse(text) else {
        // The reader reports what is wrong with the XML.
        return None;
    };
    let at = |path: &str| {
        path.split('/')
            .try_fold(doc.root_element(), |n, name| {
                n.children()
                    .find(|c| c.is_element() && c.tag_name().name() == name)
            })
            .map(|n| n.text().unwrap_or("").trim().to_string())
    };
    let comment = at("Record2/Comment").unwrap_or_default();
    if comment.starts_with(X3P_INTENSITY_MARK) {
        return Some(Declared {
            quantity: ValueKind::Intensity,
            by: "its Record2/Comment starts \"Intensity, unit-less\"".into(),
        });
    }
    let ours = at("Record2/ProbingSystem/Identification").as_deref() == Some("flakescatter");
    if ours && at("Record1/Axes/CZ/Increment").as_deref() == Some("1") {
        return Some(Declared {
            quantity: ValueKind::Intensity,
            by: "it was written by flakescatter with a Z Increment of 1, as its intensity images are".into(),
        });
    }
    None
}

/// What an SDF file declares (its trailer).
pub(crate) fn sdf(bytes: &[u8]) -> Option<Declared> {
    let trailer: Vec<String> = if bytes.starts_with(b"aISO") {
        // Text: header `*` data `*` trailer.
        let text = String::from_utf8_lossy(bytes);
        split_lines(&text)
            .skip_while(|l| l.trim() != "*")
            .skip(1)
            .skip_while(|l| l.trim() != "*")
            .skip(1)
            .map(str::to_string)
            .collect()
    } else if bytes.len() >= 81 {
        // Binary: the 81-byte header, the data, then any trailer.
        let u16_at = |a: usize| usize::from(u16_le(bytes, a));
        let width = match bytes[79] {
            0 | 4 => 1,
            1 | 5 => 2,
            2 | 3 | 6 => 4,
            _ => 8,
        };
        let end = 81 + u16_at(42) * u16_at(44) * width;
        bytes
            .get(end..)
            .map(|t| {
                String::from_utf8_lossy(t)
                    .lines()
                    .map(str::to_string)
                    .collect()
            })
            .unwrap_or_default()
    } else {
        Vec::new()
    };
    trailer.iter().find_map(|line| {
        let (k, v) = line.split_once('=')?;
        (k.trim().eq_ignore_ascii_case("quantity")
            && v.trim().to_ascii_lowercase().starts_with("intensity"))
        .then(|| Declared {
            quantity: ValueKind::Intensity,
            by: format!("its trailer says {:?}", line.trim()),
        })
    })
}

/// What a text matrix declares (its `Channel` header).
pub(crate) fn text(bytes: &[u8]) -> Option<Declared> {
    let (text, _) = crate::text::decode(bytes).ok()?;
    for (i, line) in split_lines(&text).enumerate() {
        let Some(h) = line.trim().strip_prefix('#') else {
            continue;
        };
        let Some((key, value)) = h.split_once(':') else {
            continue;
        };
        if !matches!(key.trim().to_lowercase().as_str(), "channel" | "kanal") {
            continue;
        }
        let quantity = match value.trim().to_lowercase().as_str() {
            "intensity" | "intensität" | "intensitaet" => ValueKind::Intensity,
            "height" | "höhe" | "hoehe" => ValueKind::Height,
            _ => return None,
        };
        return Some(Declared {
            quantity,
            by: format!(
                "its header says `# {}: {}` on line {}",
                key.trim(),
                value.trim(),
                i + 1
            ),
        });
    }
    None
}

/// The quantity to read: `wanted` when the file declares none, else the file's own with
/// `as_stored`, else `wanted`, which a file declaring the other quantity contradicts.
pub(crate) fn resolve(
    declared: Option<Declared>,
    wanted: ValueKind,
    as_stored: bool,
) -> Result<ValueKind, (Declared, ValueKind)> {
    match declared {
        None => Ok(wanted),
        Some(d) if as_stored => Ok(d.quantity),
        Some(d) if d.quantity == wanted => Ok(wanted),
        Some(d) => Err((d, wanted)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn x3p_comment_carries_the_mark_once() {
        let m = X3P_INTENSITY_MARK;
        assert_eq!(x3p_comment("abc".into(), true), format!("{m}. abc"));
        assert_eq!(x3p_comment(format!("{m}. abc"), true), format!("{m}. abc"));
        assert_eq!(x3p_comment(format!("{m}. abc"), false), "abc");
        assert_eq!(x3p_comment("abc".into(), false), "abc");
        assert_eq!(x3p_comment(String::new(), true), m);
    }

    #[test]
    fn text_and_sdf_declarations() {
        let d = text(b"# Width: 1 um\n# Channel: intensity\n1 2\n").unwrap();
        assert_eq!(d.quantity, ValueKind::Intensity);
        assert!(d.by.contains("line 2"), "{}", d.by);
        assert_eq!(
            text(b"# Kanal: H\xc3\xb6he\n1 2\n").unwrap().quantity,
            ValueKind::Height
        );
        assert!(text(b"# Channel: Z\n1 2\n").is_none());
        assert!(text(b"1 2\n").is_none());
        let sdf_text = format!("aISO-1.0\nNumPoints = 1\n*\n1\n*\n{SDF_INTENSITY_LINE}\n");
        assert_eq!(
            sdf(sdf_text.as_bytes()).unwrap().quantity,
            ValueKind::Intensity
        );
        assert!(sdf(b"aISO-1.0\nNumPoints = 1\n*\n1\n*\n").is_none());
        // A data value `Quantity = intensity` cannot occur; one before the data's end
        // is not a trailer.
        assert!(sdf(b"aISO-1.0\n*\nQuantity = intensity\n").is_none());
    }

    #[test]
    fn resolve_rules() {
        let i = || {
            Some(Declared {
                quantity: ValueKind::Intensity,
                by: String::new(),
            })
        };
        assert_eq!(
            resolve(None, ValueKind::Intensity, false),
            Ok(ValueKind::Intensity)
        );
        assert_eq!(
            resolve(None, ValueKind::Height, true),
            Ok(ValueKind::Height)
        );
        assert_eq!(
            resolve(i(), ValueKind::Height, true),
            Ok(ValueKind::Intensity)
        );
        assert_eq!(
            resolve(i(), ValueKind::Intensity, false),
            Ok(ValueKind::Intensity)
        );
        assert!(resolve(i(), ValueKind::Height, false).is_err());
    }
}

//! Numbers as written in a text matrix: tokens, the fields of a line, and the decimal
//! mark decided from the whole data section.

use std::borrow::Cow;

use crate::reader::DecimalMark;
use crate::units::{length_unit_exponent, parse_scaled};

use super::error::TextError;

/// A number as written in the file, with a decimal comma when `comma`.
pub(super) fn parse_number(token: &str, comma: bool) -> Option<f64> {
    if comma {
        if token.contains('.') {
            return None;
        }
        token.replacen(',', ".", 1).parse().ok()
    } else {
        token.parse().ok()
    }
}

/// `"12.34 µm"` (or `"12,34 µm"` when `comma`) → 12.34 in µm (exactly rounded).
pub(super) fn length_um(value: &str, comma: bool) -> Option<f64> {
    let mut parts = value.split_whitespace();
    let number = parts.next()?;
    let unit = parts.next()?;
    if parts.next().is_some() {
        return None;
    }
    let number: Cow<str> = if comma && !number.contains('.') && number.matches(',').count() == 1 {
        Cow::Owned(number.replace(',', "."))
    } else {
        Cow::Borrowed(number)
    };
    parse_scaled(&number, length_unit_exponent(unit)?).filter(|v| v.is_finite() && *v > 0.0)
}

/// Splits a data line into its values. `commas_separate`: commas are separators (decimal
/// points); otherwise only whitespace and `;` separate. An explicit separator followed
/// by nothing but another separator is an empty value (`Err(column)`); one at the end
/// of the line is allowed (spreadsheets write them).
pub(super) fn fields(line: &str, commas_separate: bool) -> Result<Vec<&str>, usize> {
    let is_sep = |c: char| c == ';' || (commas_separate && c == ',');
    let parts: Vec<&str> = line.split(is_sep).collect();
    let mut out = Vec::new();
    let last = parts.len() - 1;
    for (k, part) in parts.iter().enumerate() {
        let before = out.len();
        out.extend(part.split_whitespace());
        if out.len() == before && parts.len() > 1 && k != last {
            return Err(out.len() + 1);
        }
    }
    Ok(out)
}

/// `[+-]digits` (at least one digit).
pub(super) fn is_int(s: &str) -> bool {
    let d = s.strip_prefix(['+', '-']).unwrap_or(s);
    !d.is_empty() && d.bytes().all(|b| b.is_ascii_digit())
}

/// `digits[e[+-]digits]`.
pub(super) fn is_fraction(s: &str) -> bool {
    let (digits, exp) = match s.find(['e', 'E']) {
        Some(i) => (&s[..i], Some(&s[i + 1..])),
        None => (s, None),
    };
    !digits.is_empty() && digits.bytes().all(|b| b.is_ascii_digit()) && exp.is_none_or(is_int)
}

/// `1,5`, `-0,25`, `1,5e-3`: a number with one decimal comma.
pub(super) fn is_comma_decimal(token: &str) -> bool {
    match token.split_once(',') {
        Some((a, b)) => is_int(a) && is_fraction(b),
        None => false,
    }
}

/// How the decimal mark was decided, for the metadata.
pub(super) struct Decision {
    pub(super) comma: bool,
    pub(super) how: &'static str,
}

/// Decides the decimal mark from the data lines (after any profile header).
pub(super) fn decide_decimal(
    lines: &[(usize, &str)],
    mark: DecimalMark,
) -> Result<Decision, TextError> {
    let semicolons = lines.iter().any(|(_, l)| l.contains(';'));
    // Evidence, each with its first occurrence (line, token).
    let mut comma_decimal: Option<(usize, &str)> = None; // `1,5` inside a value
    let mut multi_on_line = false; // a line with `1,5` among several values
    let mut separator: Option<(usize, &str, &'static str)> = None; // commas separating
    let mut point: Option<(usize, &str)> = None; // `1.5`
    let mut mixed: Option<(usize, &str, bool)> = None; // `1.000,5` (, several on the line)
    let mut any_comma: Option<(usize, &str)> = None;
    for &(no, line) in lines {
        let tokens: Vec<&str> = line
            .split(|c: char| c.is_whitespace() || c == ';')
            .filter(|t| !t.is_empty())
            .collect();
        for &t in &tokens {
            if t.contains('.') && point.is_none() {
                point = Some((no, t));
            }
            let commas = t.matches(',').count();
            if commas == 0 {
                continue;
            }
            any_comma.get_or_insert((no, t));
            if t.contains('.') {
                if mixed.is_none_or(|m| !m.2 && tokens.len() > 1) {
                    mixed = Some((no, t, tokens.len() > 1));
                }
            } else if is_comma_decimal(t) {
                comma_decimal.get_or_insert((no, t));
                if tokens.len() > 1 {
                    multi_on_line = true;
                }
            } else if t.starts_with(',') || t.ends_with(',') {
                separator.get_or_insert((no, t, "a comma next to a space separates values"));
            } else if commas > 1 {
                separator.get_or_insert((no, t, "more than one comma in a value"));
            }
        }
    }
    let ambiguous = |(line, token): (usize, &str), why| {
        Err(TextError::AmbiguousDecimal {
            line,
            token: token.into(),
            why,
        })
    };
    match mark {
        DecimalMark::Comma => {
            if let Some((line, token)) = point {
                return Err(TextError::DecimalContradiction {
                    line,
                    token: token.into(),
                    mark: "comma",
                    why: "it has a decimal point",
                });
            }
            if let Some((line, token, why)) = separator {
                return Err(TextError::DecimalContradiction {
                    line,
                    token: token.into(),
                    mark: "comma",
                    why,
                });
            }
            Ok(Decision {
                comma: true,
                how: "comma (option)",
            })
        }
        DecimalMark::Point => {
            if semicolons && let Some((line, token)) = any_comma {
                return Err(TextError::DecimalContradiction {
                    line,
                    token: token.into(),
                    mark: "point",
                    why: "values are separated by `;` and this one holds a comma",
                });
            }
            Ok(Decision {
                comma: false,
                how: "point (option)",
            })
        }
        DecimalMark::Auto if semicolons => {
            if let Some((line, token, _)) = mixed {
                return ambiguous(
                    (line, token),
                    "values are separated by `;` and some hold both `.` and `,`",
                );
            }
            if let Some((line, token, _)) = separator {
                return ambiguous(
                    (line, token),
                    "values are separated by `;` and some hold commas that look like separators",
                );
            }
            Ok(if comma_decimal.is_some() {
                Decision {
                    comma: true,
                    how: "comma (detected: `;` separates values)",
                }
            } else {
                Decision {
                    comma: false,
                    how: "point (detected)",
                }
            })
        }
        DecimalMark::Auto => {
            if let Some((line, token, true)) = mixed {
                return ambiguous(
                    (line, token),
                    "whitespace separates values and some hold both `.` and `,`",
                );
            }
            let Some(first) = comma_decimal else {
                return Ok(Decision {
                    comma: false,
                    how: "point (detected)",
                });
            };
            if point.is_some() {
                if multi_on_line {
                    return ambiguous(
                        first,
                        "some values have a decimal point, others look like decimal commas",
                    );
                }
                // `1.5,2.5` and `3,4`: decimal points, so commas separate.
                return Ok(Decision {
                    comma: false,
                    how: "point (detected: `.` in numbers, commas separate values)",
                });
            }
            if separator.is_some() {
                return ambiguous(first, "other lines use commas to separate values");
            }
            if multi_on_line {
                return Ok(Decision {
                    comma: true,
                    how: "comma (detected: whitespace separates values like `1,5`)",
                });
            }
            ambiguous(first, "every line holds a single token")
        }
    }
}

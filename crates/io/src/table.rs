//! The CSV layer under every table reader (flake tables, histograms, measured curves,
//! detector lists, result curves): one header row, comma-separated, `#` comment lines,
//! names matched case-insensitively after trimming, and errors that name the file, the
//! 1-based line and the column.
//!
//! Line numbers are counted here from the bytes, the same way for `\n`, `\r\n` and `\r`
//! line endings and with comment lines counted (the `csv` crate's own counts drift with
//! CRLF files). A header that names a column twice is an error (which would be meant?);
//! a row with another number of fields than the header is an error saying both numbers;
//! a header that is one field holding `;` or tabs gets a hint about the delimiter. Text
//! is UTF-8, UTF-16 with a byte-order mark, or else read as Latin-1.

use std::borrow::Cow;
use std::io::Read;

use thiserror::Error;

/// Errors reading or writing a CSV table.
#[derive(Debug, Error)]
pub enum TableError {
    /// The file could not be opened, read or written.
    #[error("{file}: {source}")]
    Io {
        /// File name.
        file: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// Malformed CSV other than a wrong field count.
    #[error("{file}, line {line}: malformed CSV: {message}")]
    Csv {
        /// File name.
        file: String,
        /// 1-based line.
        line: u64,
        /// What is wrong.
        message: String,
    },
    /// A row with another number of fields than the header.
    #[error(
        "{file}, line {line}: expected {expected} fields (as in the header on line {header_line}), found {found}"
    )]
    FieldCount {
        /// File name.
        file: String,
        /// 1-based line of the row.
        line: u64,
        /// Fields in the header.
        expected: u64,
        /// Fields in the row.
        found: u64,
        /// 1-based line of the header.
        header_line: u64,
    },
    /// A column name appears more than once in the header.
    #[error(
        "{file}, line {line}: column {column} appears twice in the header (fields {first} and {second}); rename or remove one"
    )]
    DuplicateColumn {
        /// File name.
        file: String,
        /// 1-based line of the header.
        line: u64,
        /// The column name (as normalised: trimmed, lower case).
        column: String,
        /// 1-based field index of the first occurrence.
        first: usize,
        /// 1-based field index of the second.
        second: usize,
    },
    /// The header is one field that holds another delimiter.
    #[error(
        "{file}, line {line}: the header {header:?} is a single column holding {delimiter}: \
         this file seems to use {delimiter} between columns, but tables here are \
         comma-separated (with `.` as decimal mark); convert it, e.g. save it as CSV with \
         commas from the spreadsheet"
    )]
    Delimiter {
        /// File name.
        file: String,
        /// 1-based line of the header.
        line: u64,
        /// The header as read.
        header: String,
        /// The delimiter it seems to use (`` `;` `` or `tabs`).
        delimiter: &'static str,
    },
    /// No complete flake column set in the header.
    #[error(
        "{file}, line {line}: header has none of the flake column sets (normals: nx, ny, nz, area_um2; tilts: theta_x_deg, theta_y_deg, area_um2; endpoints: x1_um, z1_um, x2_um, z2_um, y1_um, zy1_um, y2_um, zy2_um); closest is {closest} set, missing column(s) {}",
        missing.join(", ")
    )]
    MissingColumns {
        /// File name.
        file: String,
        /// 1-based line of the header.
        line: u64,
        /// The column set with the most columns present.
        closest: &'static str,
        /// Its missing columns.
        missing: Vec<String>,
    },
    /// The file holds no header row (it is empty, or only comments and blank lines).
    #[error("{file}: the file is empty (no header row)")]
    NoHeader {
        /// File name.
        file: String,
    },
    /// The table has a header but no data rows.
    #[error("{file}: no data rows after the header")]
    Empty {
        /// File name.
        file: String,
    },
    /// A cell is not a valid value.
    #[error("{file}, line {line}, column {column}: {message}")]
    BadValue {
        /// File name.
        file: String,
        /// 1-based line.
        line: u64,
        /// Column name (or names).
        column: String,
        /// What was found and what was expected.
        message: String,
    },
}

pub(crate) fn io_err(file: &str) -> impl FnOnce(std::io::Error) -> TableError + '_ {
    move |source| TableError::Io {
        file: file.to_string(),
        source,
    }
}

/// A csv writer error, naming the file.
pub(crate) fn write_err(file: &str, e: csv::Error) -> TableError {
    match e.into_kind() {
        csv::ErrorKind::Io(source) => TableError::Io {
            file: file.to_string(),
            source,
        },
        kind => TableError::Io {
            file: file.to_string(),
            source: std::io::Error::other(format!("cannot write CSV: {kind:?}")),
        },
    }
}

/// Byte offsets where lines start, for `\n`, `\r\n` and `\r` endings.
struct Lines<'a> {
    text: &'a [u8],
    starts: Vec<usize>,
}

impl<'a> Lines<'a> {
    fn new(text: &'a [u8]) -> Self {
        let mut starts = vec![0];
        let mut i = 0;
        while i < text.len() {
            match text[i] {
                b'\n' => starts.push(i + 1),
                b'\r' if text.get(i + 1) != Some(&b'\n') => starts.push(i + 1),
                _ => {}
            }
            i += 1;
        }
        Self { text, starts }
    }

    /// The 1-based line of the record that the csv reader says starts at `byte`: the
    /// reader may point at the line break before it, or at comment lines before it.
    fn line_of_record(&self, byte: u64) -> u64 {
        let mut at = usize::try_from(byte)
            .unwrap_or(usize::MAX)
            .min(self.text.len());
        loop {
            while at < self.text.len() && matches!(self.text[at], b'\r' | b'\n') {
                at += 1;
            }
            if at < self.text.len() && self.text[at] == b'#' {
                while at < self.text.len() && !matches!(self.text[at], b'\r' | b'\n') {
                    at += 1;
                }
                continue;
            }
            break;
        }
        self.starts.partition_point(|&s| s <= at) as u64
    }
}

/// The text of a table's bytes: UTF-16 with a byte-order mark, UTF-8, else Latin-1
/// (every byte the code point of the same number); a leading byte-order mark dropped
/// and lone `\r` line ends made `\n` ([`plain`]).
fn decode(bytes: &[u8]) -> Cow<'_, [u8]> {
    let utf16 = match bytes.get(..2) {
        Some([0xff, 0xfe]) => Some(true),
        Some([0xfe, 0xff]) => Some(false),
        _ => None,
    };
    let text: Cow<[u8]> = match std::str::from_utf8(bytes) {
        _ if utf16.is_some() => {
            // UTF-16 with a byte-order mark (spreadsheets' "Unicode text").
            let units: Vec<u16> = bytes[2..]
                .chunks(2)
                .map(|c| {
                    let pair = [c[0], *c.get(1).unwrap_or(&0)];
                    if utf16 == Some(true) {
                        u16::from_le_bytes(pair)
                    } else {
                        u16::from_be_bytes(pair)
                    }
                })
                .collect();
            Cow::Owned(String::from_utf16_lossy(&units).into_bytes())
        }
        Ok(_) => Cow::Borrowed(bytes),
        // Latin-1: every byte is the code point of the same number.
        Err(_) => Cow::Owned(
            bytes
                .iter()
                .map(|&b| char::from(b))
                .collect::<String>()
                .into_bytes(),
        ),
    };
    match text {
        Cow::Borrowed(text) => plain(text),
        Cow::Owned(text) => Cow::Owned(plain(&text).into_owned()),
    }
}

/// `text` without a leading byte-order mark, with each lone `\r` made `\n`.
fn plain(text: &[u8]) -> Cow<'_, [u8]> {
    let text: &[u8] = text.strip_prefix("\u{feff}".as_bytes()).unwrap_or(text);
    // The csv reader ends comment lines only at `\n`: a lone `\r` (old Mac files)
    // becomes `\n`, which keeps every byte offset.
    if text
        .iter()
        .enumerate()
        .any(|(i, &b)| b == b'\r' && text.get(i + 1) != Some(&b'\n'))
    {
        let mut owned = text.to_vec();
        for i in 0..owned.len() {
            if owned[i] == b'\r' && owned.get(i + 1) != Some(&b'\n') {
                owned[i] = b'\n';
            }
        }
        Cow::Owned(owned)
    } else {
        Cow::Borrowed(text)
    }
}

/// Refuses a header with no column name, a name given twice (both columns named) or
/// a single column whose name holds `;` or tabs (another delimiter than `,`).
fn check_header(
    file: &str,
    header: &[String],
    header_line: u64,
    raw_header: &csv::StringRecord,
) -> Result<(), TableError> {
    if header.iter().all(String::is_empty) {
        return Err(TableError::NoHeader {
            file: file.to_string(),
        });
    }
    // A hash map of the names seen: a header may have very many columns.
    let mut seen = std::collections::HashMap::new();
    for (j, name) in header.iter().enumerate() {
        if name.is_empty() {
            continue;
        }
        if let Some(first) = seen.insert(name.as_str(), j) {
            return Err(TableError::DuplicateColumn {
                file: file.to_string(),
                line: header_line,
                column: name.clone(),
                first: first + 1,
                second: j + 1,
            });
        }
    }
    if let [only] = header {
        let delimiter = if only.contains(';') {
            Some("`;`")
        } else if only.contains('\t') {
            Some("tabs")
        } else {
            None
        };
        if let Some(delimiter) = delimiter {
            return Err(TableError::Delimiter {
                file: file.to_string(),
                line: header_line,
                header: raw_header.get(0).unwrap_or("").to_string(),
                delimiter,
            });
        }
    }
    Ok(())
}

/// A parsed CSV: lower-cased, trimmed header and records with their line numbers.
pub(crate) struct Table {
    pub(crate) file: String,
    pub(crate) header: Vec<String>,
    pub(crate) header_line: u64,
    pub(crate) rows: Vec<(u64, csv::StringRecord)>,
}

impl Table {
    pub(crate) fn read(mut reader: impl Read, file: &str) -> Result<Self, TableError> {
        let mut bytes = Vec::new();
        reader.read_to_end(&mut bytes).map_err(io_err(file))?;
        let text = decode(&bytes);
        let text: &[u8] = &text;
        let lines = Lines::new(text);
        let mut r = csv::ReaderBuilder::new()
            .has_headers(true)
            .trim(csv::Trim::All)
            .comment(Some(b'#'))
            .from_reader(text);
        let csv_err = |e: csv::Error| -> TableError {
            let line = e.position().map_or(1, |p| lines.line_of_record(p.byte()));
            match e.into_kind() {
                csv::ErrorKind::Io(source) => TableError::Io {
                    file: file.to_string(),
                    source,
                },
                csv::ErrorKind::Utf8 { err, .. } => TableError::Csv {
                    file: file.to_string(),
                    line,
                    message: format!("field {} is not valid UTF-8 text", err.field() + 1),
                },
                kind => TableError::Csv {
                    file: file.to_string(),
                    line,
                    message: format!("{kind:?}"),
                },
            }
        };
        let raw_header = r.headers().map_err(csv_err)?.clone();
        let header_line = raw_header
            .position()
            .map_or(1, |p| lines.line_of_record(p.byte()));
        let header: Vec<String> = raw_header
            .iter()
            .map(|h| h.trim().to_ascii_lowercase())
            .collect();
        check_header(file, &header, header_line, &raw_header)?;
        let mut rows = Vec::new();
        for rec in r.records() {
            let rec = match rec {
                Ok(rec) => rec,
                Err(e) => {
                    if let csv::ErrorKind::UnequalLengths {
                        pos,
                        expected_len,
                        len,
                    } = e.kind()
                    {
                        return Err(TableError::FieldCount {
                            file: file.to_string(),
                            line: pos.as_ref().map_or(0, |p| lines.line_of_record(p.byte())),
                            expected: *expected_len,
                            found: *len,
                            header_line,
                        });
                    }
                    return Err(csv_err(e));
                }
            };
            let line = rec.position().map_or(0, |p| lines.line_of_record(p.byte()));
            if rec.iter().all(str::is_empty) {
                continue;
            }
            rows.push((line, rec));
        }
        Ok(Self {
            file: file.to_string(),
            header,
            header_line,
            rows,
        })
    }

    pub(crate) fn col(&self, name: &str) -> Option<usize> {
        self.header.iter().position(|h| h == name)
    }

    /// The indices of the columns `need`, or an error at the header line naming the
    /// missing ones with `message` (what the file needs).
    pub(crate) fn require<const N: usize>(
        &self,
        need: [&str; N],
        message: &str,
    ) -> Result<[usize; N], TableError> {
        let missing: Vec<&str> = need
            .iter()
            .copied()
            .filter(|c| self.col(c).is_none())
            .collect();
        if !missing.is_empty() {
            return Err(TableError::BadValue {
                file: self.file.clone(),
                line: self.header_line,
                column: missing.join(", "),
                message: format!(
                    "missing from the header (found: {}); {message}",
                    self.header.join(", ")
                ),
            });
        }
        Ok(need.map(|c| self.col(c).unwrap_or(0)))
    }

    pub(crate) fn bad(&self, line: u64, column: &str, message: String) -> TableError {
        TableError::BadValue {
            file: self.file.clone(),
            line,
            column: column.to_string(),
            message,
        }
    }

    /// A finite number from column `name` (index `i`) of a row.
    pub(crate) fn num(
        &self,
        line: u64,
        rec: &csv::StringRecord,
        i: usize,
        name: &str,
    ) -> Result<f64, TableError> {
        let s = rec.get(i).unwrap_or("");
        match s.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            Ok(v) => Err(self.bad(line, name, format!("{v} is not a finite number"))),
            Err(_) if s.is_empty() => {
                Err(self.bad(line, name, "empty cell, expected a number".into()))
            }
            Err(_) if s.matches(',').count() == 1 && s.replace(',', ".").parse::<f64>().is_ok() => {
                Err(self.bad(
                    line,
                    name,
                    format!(
                        "{s:?} is not a number: write decimals with a point ({})",
                        s.replace(',', ".")
                    ),
                ))
            }
            Err(_) => Err(self.bad(line, name, format!("{s:?} is not a number"))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lines_of(text: &str) -> Vec<u64> {
        Table::read(text.as_bytes(), "t.csv")
            .unwrap()
            .rows
            .iter()
            .map(|r| r.0)
            .collect()
    }

    #[test]
    fn line_numbers_with_every_line_ending_and_comments() {
        // Counted by hand: header on line 1 (or 2 after a comment), rows after it.
        assert_eq!(lines_of("a,b\n1,2\n3,4\n"), [2, 3]);
        assert_eq!(lines_of("a,b\r\n1,2\r\n3,4\r\n"), [2, 3]);
        assert_eq!(lines_of("a,b\r1,2\r3,4\r"), [2, 3]);
        assert_eq!(lines_of("# c\r\na,b\r\n1,2\r\n#x\r\n3,4\r\n"), [3, 5]);
        assert_eq!(lines_of("# c\na,b\n\n1,2\n#x\n3,4\n"), [4, 6]);
        let t = Table::read("# c\r\n# d\r\na,b\r\n1,2\r\n".as_bytes(), "t.csv").unwrap();
        assert_eq!(t.header_line, 3);
    }
}

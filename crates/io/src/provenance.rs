//! What a map written in one format keeps of the metadata of the file it was read from
//! in another (issue 14: `convert` keeps "metadata that both formats can hold").
//!
//! Readers put a file's header fields into the map's metadata under their format's
//! prefix (`plu.date`, `frt.sensor_serial`, …). The writers of the two ISO formats look
//! first for their own keys (`x3p.date`, `sdf.ManufacID`, …), so a file read and written
//! in the same format keeps its fields as they were; where those are absent they take
//! what [`Provenance::of`] finds in the other formats' keys:
//!
//! | field | from | X3P | SDF |
//! | --- | --- | --- | --- |
//! | acquisition date | `x3p.date`, `sdf.CreateDate`, `plu.date`, `metropro.time_stamp`, `opd.Date` + `opd.Time`, `sur.date`, `frt.measurement_started` | `Record2/Date` | `CreateDate` |
//! | instrument maker | `x3p.instrument.manufacturer`, `sdf.ManufacID`, else the maker whose instruments write the format (PLU Sensofar, MetroPro Zygo, OPD Wyko, AL3D Alicona, FRT FRT) | `Instrument/Manufacturer` | `ManufacID` (10 characters) |
//! | instrument model, serial | `x3p.instrument.model`; `x3p.instrument.serial`, `frt.sensor_serial` | `Instrument/Model`, `Serial` | — |
//! | everything else | every other metadata entry, `key=value; …` | `Comment` | — |
//!
//! Dates become ISO 8601 `YYYY-MM-DDThh:mm:ss` (with `Z` when the source says UTC:
//! the MetroPro time stamp, seconds since 1970-01-01 00:00 UTC, and FRT's times);
//! others are the instrument's local time, as written. Date forms, by source: SDF
//! `DDMMYYYYhhmm` (`010119700000`, the placeholder of writers without a date, is not a
//! date); PLU `Www Mmm dd hh:mm:ss yyyy` (C `ctime`); OPD `M/D/YYYY` and `h:mm:ss`
//! (Wyko Vision writes US dates); SUR `YYYY-MM-DD hh:mm:ss`. A field that does not parse
//! is not carried as a date (it stays in the X3P comment).

use flakescatter_stats::heightmap::HeightMap;

/// What a map's metadata says of where it came from, in the writers' terms.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Provenance {
    /// Acquisition date, ISO 8601 (`YYYY-MM-DDThh:mm:ss`, `Z` appended for UTC).
    pub date: Option<String>,
    /// Instrument maker.
    pub manufacturer: Option<String>,
    /// Instrument model.
    pub model: Option<String>,
    /// Instrument or sensor serial number.
    pub serial: Option<String>,
    /// The format the map was read from (the `format` metadata key).
    pub format: Option<String>,
}

/// The SDF `ManufacID` written when nothing says who made the data (not a maker).
pub const SDF_DEFAULT_MANUFACTURER: &str = "flakescat";

/// X3P's placeholder for an absent field.
const NOT_AVAILABLE: &str = "N/A";

impl Provenance {
    /// Reads the fields from `map`'s metadata (module docs).
    #[must_use]
    pub fn of(map: &HeightMap) -> Self {
        let m = map.metadata();
        let get = |k: &str| {
            m.get(k)
                .map(|v| v.trim())
                .filter(|v| !v.is_empty() && *v != NOT_AVAILABLE)
        };
        let format = get("format").map(str::to_string);
        let date = get("x3p.date")
            .and_then(iso_date)
            .or_else(|| get("sdf.CreateDate").and_then(sdf_date))
            .or_else(|| get("plu.date").and_then(ctime_date))
            .or_else(|| {
                get("metropro.time_stamp")
                    .and_then(|s| s.parse::<u32>().ok())
                    .filter(|&s| s > 0)
                    .map(|s| utc_iso(i64::from(s)))
            })
            .or_else(|| opd_date(get("opd.Date")?, get("opd.Time")?))
            .or_else(|| get("sur.date").and_then(iso_date))
            .or_else(|| {
                let s = get("frt.measurement_started")?;
                iso_date(s.strip_suffix(" UTC")?).map(|d| d + "Z")
            });
        let maker = match format.as_deref() {
            Some("plu") => Some("Sensofar"),
            Some("metropro") => Some("Zygo"),
            Some("opd") => Some("Wyko"),
            Some("al3d") => Some("Alicona"),
            Some("frt") => Some("FRT"),
            _ => None,
        };
        let manufacturer = get("x3p.instrument.manufacturer")
            .or_else(|| get("sdf.ManufacID").filter(|v| *v != SDF_DEFAULT_MANUFACTURER))
            .or(maker)
            .map(str::to_string);
        Self {
            date,
            manufacturer,
            model: get("x3p.instrument.model").map(str::to_string),
            serial: get("x3p.instrument.serial")
                .or_else(|| get("frt.sensor_serial"))
                .map(str::to_string),
            format,
        }
    }

    /// The date in SDF's `DDMMYYYYhhmm` (seconds dropped).
    #[must_use]
    pub fn sdf_date(&self) -> Option<String> {
        let d = self.date.as_deref()?.as_bytes();
        let part = |a: usize, b: usize| std::str::from_utf8(d.get(a..b)?).ok();
        Some(format!(
            "{}{}{}{}{}",
            part(8, 10)?,
            part(5, 7)?,
            part(0, 4)?,
            part(11, 13)?,
            part(14, 16)?
        ))
    }

    /// The X3P comment of a map read from another format: the source format and every
    /// metadata entry that no X3P field holds, `key=value; …`; `None` for a map with
    /// its own `x3p.comment`, one read from an X3P file, or one without a `format`.
    #[must_use]
    pub fn x3p_comment(map: &HeightMap) -> Option<String> {
        let m = map.metadata();
        if m.contains_key("x3p.comment") {
            return None;
        }
        let format = m.get("format").filter(|f| *f != "x3p")?;
        let rest: Vec<String> = m
            .iter()
            .filter(|(k, _)| *k != "format" && *k != "pitch_source" && !k.starts_with("x3p."))
            .map(|(k, v)| format!("{k}={}", v.trim()))
            .collect();
        Some(format!(
            "converted by flakescatter {} from a {format} file; source metadata: {}",
            env!("CARGO_PKG_VERSION"),
            if rest.is_empty() {
                "none".to_string()
            } else {
                rest.join("; ")
            }
        ))
    }
}

/// `YYYY-MM-DDThh:mm:ss` from numbers checked for range.
fn iso(y: u32, mo: u32, d: u32, h: u32, mi: u32, s: u32) -> Option<String> {
    let ok = (1..=9999).contains(&y)
        && (1..=12).contains(&mo)
        && (1..=31).contains(&d)
        && h < 24
        && mi < 60
        && s < 61;
    ok.then(|| format!("{y:04}-{mo:02}-{d:02}T{h:02}:{mi:02}:{s:02}"))
}

/// `YYYY-MM-DD[T ]hh:mm:ss` (anything after the seconds is dropped).
fn iso_date(s: &str) -> Option<String> {
    let b = s.as_bytes();
    if b.len() < 19 || b[4] != b'-' || b[7] != b'-' || !matches!(b[10], b'T' | b' ') {
        return None;
    }
    let n = |a: usize, z: usize| s.get(a..z)?.parse::<u32>().ok();
    iso(
        n(0, 4)?,
        n(5, 7)?,
        n(8, 10)?,
        n(11, 13)?,
        n(14, 16)?,
        n(17, 19)?,
    )
}

/// SDF `DDMMYYYYhhmm`; the `010119700000` placeholder is no date.
fn sdf_date(s: &str) -> Option<String> {
    if s.len() != 12 || !s.bytes().all(|c| c.is_ascii_digit()) || s == "010119700000" {
        return None;
    }
    let n = |a: usize| s[a..a + 2].parse::<u32>().ok();
    iso(s[4..8].parse().ok()?, n(2)?, n(0)?, n(8)?, n(10)?, 0)
}

/// C `ctime`: `Www Mmm dd hh:mm:ss yyyy` (the day may be space-padded).
fn ctime_date(s: &str) -> Option<String> {
    const MONTHS: [&str; 12] = [
        "Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct", "Nov", "Dec",
    ];
    let f: Vec<&str> = s.split_whitespace().collect();
    let [_, month, day, time, year] = f.as_slice() else {
        return None;
    };
    let mo = MONTHS.iter().position(|m| m == month)? as u32 + 1;
    let t: Vec<u32> = time
        .split(':')
        .map(|x| x.parse().ok())
        .collect::<Option<_>>()?;
    let [h, mi, sec] = t.as_slice() else {
        return None;
    };
    iso(year.parse().ok()?, mo, day.parse().ok()?, *h, *mi, *sec)
}

/// OPD `M/D/YYYY` and `h:mm:ss`.
fn opd_date(date: &str, time: &str) -> Option<String> {
    let d: Vec<u32> = date
        .split('/')
        .map(|x| x.parse().ok())
        .collect::<Option<_>>()?;
    let t: Vec<u32> = time
        .split(':')
        .map(|x| x.parse().ok())
        .collect::<Option<_>>()?;
    match (d.as_slice(), t.as_slice()) {
        ([mo, day, y], [h, mi, s]) => iso(*y, *mo, *day, *h, *mi, *s),
        _ => None,
    }
}

/// `(year, month, day)` of a count of days since 1970-01-01 (proleptic Gregorian), by
/// 400-year eras of 146097 days starting on 0000-03-01, so that the leap day is the
/// last day of a year.
///
/// ```
/// // GNU `date -u -d @951782400`: 2000-02-29 (day 11016 since 1970-01-01).
/// assert_eq!(flakescatter_io::provenance::civil_from_days(11_016), (2000, 2, 29));
/// ```
#[must_use]
pub fn civil_from_days(days: i64) -> (i64, i64, i64) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    (yoe + era * 400 + i64::from(month <= 2), month, day)
}

/// `YYYY-MM-DDThh:mm:ssZ` of a count of seconds since 1970-01-01 00:00 UTC (≥ 0).
fn utc_iso(seconds: i64) -> String {
    let (y, mo, d) = civil_from_days(seconds.div_euclid(86_400));
    let s = seconds.rem_euclid(86_400);
    format!(
        "{y:04}-{mo:02}-{d:02}T{:02}:{:02}:{:02}Z",
        s / 3600,
        s / 60 % 60,
        s % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn date_forms() {
        // By hand from each form's definition (module docs); the Unix time by GNU
        // `date -u -d @1311439776`: Sat Jul 23 16:49:36 UTC 2011.
        assert_eq!(utc_iso(1_311_439_776), "2011-07-23T16:49:36Z");
        assert_eq!(utc_iso(951_782_400), "2000-02-29T00:00:00Z");
        assert_eq!(
            ctime_date("Fri Mar 10 16:35:59 2023").as_deref(),
            Some("2023-03-10T16:35:59")
        );
        assert_eq!(
            ctime_date("Thu Mar  2 06:05:04 2023").as_deref(),
            Some("2023-03-02T06:05:04")
        );
        assert_eq!(ctime_date("Fri Mab 10 16:35:59 2023"), None);
        assert_eq!(
            sdf_date("230920261959").as_deref(),
            Some("2026-09-23T19:59:00")
        );
        assert_eq!(sdf_date("010119700000"), None);
        assert_eq!(sdf_date("321320261959"), None);
        assert_eq!(
            opd_date("7/17/2015", "6:19:48").as_deref(),
            Some("2015-07-17T06:19:48")
        );
        assert_eq!(opd_date("17/7/2015", "6:19:48"), None);
        assert_eq!(
            iso_date("2023-06-22 10:08:53").as_deref(),
            Some("2023-06-22T10:08:53")
        );
        assert_eq!(iso_date("N/A"), None);
        let p = Provenance {
            date: Some("2026-09-23T19:59:07".into()),
            ..Provenance::default()
        };
        assert_eq!(p.sdf_date().as_deref(), Some("230920261959"));
    }
}

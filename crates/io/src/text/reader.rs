//! The channel and the map of a text matrix.

use flakescatter_stats::heightmap::HeightMap;

use crate::reader::{Channel, ReadOptions, ValueKind};
use crate::units::length_unit_exponent;

use super::error::TextError;
use super::parse::{file_pitch, parse, point_list_check, unit_from_name};

/// The channel of a text matrix: its `Channel` header (or `values`), the `Value units`
/// it declares, its size and, if the header gives it, its pitch.
///
/// # Errors
/// [`TextError`] naming the line (and column) at fault.
pub fn channels(bytes: &[u8], options: &ReadOptions) -> Result<Vec<Channel>, TextError> {
    let p = parse(bytes, options)?;
    let (nx, ny) = if p.profile.is_some() {
        (p.rows.len(), 1)
    } else {
        (p.columns, p.rows.len())
    };
    let pitch_um = if p.profile.is_some() {
        None
    } else {
        file_pitch(&p, nx, ny)?
    };
    Ok(vec![Channel {
        name: p.channel.clone().unwrap_or_else(|| "values".into()),
        unit: p.value_unit.as_ref().map(|f| f.value.clone()),
        nx,
        ny,
        pitch_um,
    }])
}

/// Reads a plain-text matrix held in memory as heights (µm).
///
/// # Errors
/// [`TextError`] naming the line (and column) at fault, or the missing calibration.
pub fn read_text_bytes(bytes: &[u8], options: &ReadOptions) -> Result<HeightMap, TextError> {
    read(bytes, options, ValueKind::Height)
}

/// Reads a plain-text matrix held in memory: heights (converted to µm from the unit the
/// file or `options.z_unit` gives) or intensities (the numbers as written).
///
/// # Errors
/// [`TextError`] naming the line (and column) at fault, or the missing calibration.
pub fn read(bytes: &[u8], options: &ReadOptions, kind: ValueKind) -> Result<HeightMap, TextError> {
    let mut p = parse(bytes, options)?;
    let z_exp = match kind {
        ValueKind::Intensity => 0,
        ValueKind::Height => match (options.z_unit, &p.value_unit) {
            (Some(u), _) => u.exponent_to_um(),
            (None, Some(f)) => length_unit_exponent(&f.value).ok_or_else(|| {
                if f.value.is_empty() {
                    TextError::MissingZUnit
                } else {
                    TextError::NotALength {
                        line: f.line,
                        unit: f.value.clone(),
                    }
                }
            })?,
            (None, None) => return Err(TextError::MissingZUnit),
        },
    };
    if let Some(f) = &p.value_unit {
        p.meta.push(("text.value_units".into(), f.value.clone()));
    }
    let z_factor = 10f64.powi(z_exp);

    let rows = std::mem::take(&mut p.rows);
    if p.profile.is_none() {
        point_list_check(&rows)?;
    }
    let (nx, ny, z, pitch) = if let Some((header_line, x_name)) = &p.profile {
        let xs: Vec<f64> = rows.iter().map(|r| r.1[0]).collect();
        let z: Vec<f64> = rows.iter().map(|r| r.1[1] * z_factor).collect();
        let n = xs.len();
        let pitch = if n >= 2 {
            let mean = (xs[n - 1] - xs[0]) / (n - 1) as f64;
            if !(mean.is_finite() && mean > 0.0) {
                return Err(TextError::ProfileNotIncreasing {
                    line: rows[0].0,
                    first: xs[0],
                    last: xs[n - 1],
                });
            }
            for (k, w) in xs.windows(2).enumerate() {
                let step = w[1] - w[0];
                // Tolerate rounding of printed coordinates (5 % of the step).
                let even = (step - mean).abs() <= 0.05 * mean.abs();
                if !even {
                    return Err(TextError::UnevenProfile {
                        line: rows.get(k + 1).map_or(header_line + k + 2, |r| r.0),
                        step,
                        mean,
                    });
                }
            }
            unit_from_name(x_name)
                .map(|e| mean * 10f64.powi(e))
                .filter(|p| p.is_finite() && *p > 0.0)
        } else {
            None
        };
        (n, 1, z, pitch.map(|p| (p, p)))
    } else {
        let (nx, ny) = (p.columns, rows.len());
        let pitch = file_pitch(&p, nx, ny)?;
        let z: Vec<f64> = rows
            .into_iter()
            .flat_map(|(_, r)| r)
            .map(|v| v * z_factor)
            .collect();
        (nx, ny, z, pitch)
    };

    let (dx, dy) = match (options.pixel_um, pitch) {
        (Some(p), _) | (None, Some(p)) => p,
        (None, None) => return Err(TextError::MissingPitch),
    };
    let mut map = HeightMap::new(nx, ny, dx, dy, z).map_err(TextError::Map)?;
    for (k, v) in p.meta {
        map.set_metadata(k, v);
    }
    Ok(map)
}

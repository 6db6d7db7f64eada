//! Spectral files (CSV with a header row, `#` comments, names matched
//! case-insensitively): optical constants of flakes, the clear coat's index, the
//! binder's absorption, reflectance spectra and measured multi-angle colour.
//!
//! | reader | columns (other columns ignored) | rules |
//! | --- | --- | --- |
//! | [`read_complex_index`] | `wavelength_nm, n, k` | `n > 0`, `k ≥ 0` |
//! | [`read_coat_index`] | `wavelength_nm, n` (a `k` column must be 0) | `n ≥ 1` |
//! | [`read_absorption`] | `wavelength_nm, alpha_per_um` | `α ≥ 0`, µm⁻¹, Napierian |
//! | [`read_spectra`] | `wavelength_nm, reflectance_factor` [+ `theta_i_deg, aspecular_deg`] | `R ≥ 0` |
//! | [`read_multiangle`] | `theta_i_deg, aspecular_deg` + `L, a, b` [+ `L_uncertainty`], or + `wavelength_nm, reflectance_factor` | [`min_lightness`] `≤ L* ≤` [`MAX_LIGHTNESS`], `\|a*\|, \|b*\| ≤` [`MAX_LIGHTNESS`], `0 < L_uncertainty ≤` [`MAX_L_UNCERTAINTY`]; `R ≥ 0` |
//!
//! Wavelengths are vacuum wavelengths in nanometres, strictly increasing in file order
//! (within each geometry for the files with geometry columns), at least two per table
//! or spectrum. Reflectance factors are `π × BRDF` (1 for the perfect diffuser). With
//! geometry columns, a file holds one spectrum per `(θi, aspecular)` pair, in order of
//! first appearance; the rows of one geometry need not be contiguous. Angles are
//! degrees in the file and radians in what the readers return; the aspecular angle is
//! measured from the specular direction, positive toward the normal, and the detector
//! `θs = aspecular − θi` must lie in `(−90°, 90°)`.
//!
//! Every error names the file, the 1-based line and the column.

use std::fs::File;
use std::io::Read;
use std::path::Path;

use crate::table::{Table, TableError};

/// The largest `L*` (and `|a*|`, `|b*|`) a measured colour target may have. `L*` of a
/// surface is `116 (Y/Yn)^(1/3) − 16 ≥ 0`; above 100 where the luminance factor `Y/Yn`
/// exceeds the perfect diffuser's, as metallic coatings near specular do (`L*` 100–200
/// at 15° aspecular; the model's own `model --multi-angle` gives 255 at −15° for a
/// hwhm 3° layer). 1000 is a luminance factor of about 640, beyond any multi-angle
/// geometry: what lies above is a unit or typing error (or `1e300`), refused naming the
/// line and column rather than compared.
pub const MAX_LIGHTNESS: f64 = 1000.0;

/// How far below 0 a measured `L*` without a stated uncertainty may lie: a surface's
/// `L*` is never negative, but a measurement of a dark geometry (far from specular) can
/// read a little below 0 through noise; `L* = −5` is a typing error, refused.
pub const LIGHTNESS_NOISE: f64 = 1.0;

/// The furthest below 0 a measured `L*` may lie whatever its stated uncertainty.
pub const MAX_LIGHTNESS_NOISE: f64 = 20.0;

/// The largest standard uncertainty of `L*` accepted: `L*` spans 0–100, so an
/// uncertainty beyond that says nothing of the colour (a unit or typing error).
pub const MAX_L_UNCERTAINTY: f64 = 100.0;

/// The lowest measured `L*` accepted: `−max(LIGHTNESS_NOISE, 5 u)` for a stated standard
/// uncertainty `u` (five standard uncertainties below 0), `−LIGHTNESS_NOISE` without, and
/// never below `−MAX_LIGHTNESS_NOISE`.
#[must_use]
pub fn min_lightness(l_uncertainty: Option<f64>) -> f64 {
    -l_uncertainty
        .map_or(LIGHTNESS_NOISE, |u| LIGHTNESS_NOISE.max(5.0 * u))
        .min(MAX_LIGHTNESS_NOISE)
}

/// `wavelength_nm, n, k` as read (optical constants of a flake metal).
#[derive(Debug, Clone, PartialEq)]
pub struct ComplexIndexFile {
    /// The file (for messages).
    pub file: String,
    /// Wavelengths, nm, strictly increasing.
    pub wavelengths_nm: Vec<f64>,
    /// Real parts, `> 0`.
    pub n: Vec<f64>,
    /// Extinction coefficients, `≥ 0`.
    pub k: Vec<f64>,
}

/// A real quantity versus wavelength as read (the coat's index, the binder's absorption).
#[derive(Debug, Clone, PartialEq)]
pub struct RealSpectrumFile {
    /// The file (for messages).
    pub file: String,
    /// Wavelengths, nm, strictly increasing.
    pub wavelengths_nm: Vec<f64>,
    /// The values.
    pub values: Vec<f64>,
}

/// One reflectance spectrum, with its geometry when the file has geometry columns.
#[derive(Debug, Clone, PartialEq)]
pub struct Spectrum {
    /// Incidence angle, radians (`None` without geometry columns).
    pub theta_i: Option<f64>,
    /// Aspecular angle, radians (`None` without geometry columns).
    pub aspecular: Option<f64>,
    /// Wavelengths, nm, strictly increasing.
    pub wavelengths_nm: Vec<f64>,
    /// Reflectance factors, `≥ 0`.
    pub reflectance: Vec<f64>,
    /// 1-based line of each sample.
    pub lines: Vec<u64>,
}

/// A file of reflectance spectra.
#[derive(Debug, Clone, PartialEq)]
pub struct SpectraFile {
    /// The file (for messages).
    pub file: String,
    /// Whether the file has the geometry columns `theta_i_deg, aspecular_deg`.
    pub has_geometry: bool,
    /// The spectra: one without geometry columns, one per geometry with them.
    pub spectra: Vec<Spectrum>,
}

/// One measured CIELAB row of a multi-angle file.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LabRow {
    /// Incidence angle, radians.
    pub theta_i: f64,
    /// Aspecular angle, radians.
    pub aspecular: f64,
    /// `L*`.
    pub l: f64,
    /// `a*`.
    pub a: f64,
    /// `b*`.
    pub b: f64,
    /// Standard uncertainty of `L*`, when the file has `L_uncertainty`.
    pub l_uncertainty: Option<f64>,
    /// 1-based line.
    pub line: u64,
}

/// What a measured multi-angle file holds.
#[derive(Debug, Clone, PartialEq)]
pub enum MultiAngleData {
    /// CIELAB per geometry (illuminant and observer are the caller's to state).
    Lab(Vec<LabRow>),
    /// A reflectance spectrum per geometry.
    Spectral(Vec<Spectrum>),
}

/// A measured multi-angle file.
#[derive(Debug, Clone, PartialEq)]
pub struct MultiAngleFile {
    /// The file (for messages).
    pub file: String,
    /// The data.
    pub data: MultiAngleData,
}

fn open(path: &Path) -> Result<(File, String), TableError> {
    let name = path.display().to_string();
    match File::open(path) {
        Ok(f) => Ok((f, name)),
        Err(source) => Err(TableError::Io { file: name, source }),
    }
}

/// Reads a flake metal's optical constants `wavelength_nm, n, k`.
///
/// # Errors
/// [`TableError`] naming the file, line and column: missing columns, values that
/// are not finite numbers, wavelengths not positive or not increasing, `n ≤ 0`, `k < 0`,
/// fewer than two rows.
pub fn read_complex_index(path: &Path) -> Result<ComplexIndexFile, TableError> {
    let (f, name) = open(path)?;
    read_complex_index_from(f, &name)
}

/// As [`read_complex_index`] from any reader; `file` names it in errors.
///
/// # Errors
/// As [`read_complex_index`].
pub fn read_complex_index_from(
    reader: impl Read,
    file: &str,
) -> Result<ComplexIndexFile, TableError> {
    let t = Table::read(reader, file)?;
    let [cw, cn, ck] = t.require(
        ["wavelength_nm", "n", "k"],
        "missing column(s); optical constants need wavelength_nm, n, k",
    )?;
    let mut out = ComplexIndexFile {
        file: file.to_string(),
        wavelengths_nm: Vec::new(),
        n: Vec::new(),
        k: Vec::new(),
    };
    for (line, rec) in &t.rows {
        let w = wavelength(&t, *line, rec, cw, out.wavelengths_nm.last().copied())?;
        let n = t.num(*line, rec, cn, "n")?;
        if n <= 0.0 {
            return Err(t.bad(*line, "n", format!("{n} is not > 0")));
        }
        let k = t.num(*line, rec, ck, "k")?;
        if k < 0.0 {
            return Err(t.bad(*line, "k", format!("{k} is negative (expected k >= 0)")));
        }
        out.wavelengths_nm.push(w);
        out.n.push(n);
        out.k.push(k);
    }
    at_least_two(&t, out.wavelengths_nm.len())?;
    Ok(out)
}

/// Reads the clear coat's index `wavelength_nm, n` (`n ≥ 1`). A `k` column is accepted
/// only when every value is 0: the coat is lossless in the models, and absorption in
/// the binder is given separately.
///
/// # Errors
/// As [`read_complex_index`], and for `n < 1` or a non-zero `k`.
pub fn read_coat_index(path: &Path) -> Result<RealSpectrumFile, TableError> {
    let (f, name) = open(path)?;
    read_coat_index_from(f, &name)
}

/// As [`read_coat_index`] from any reader; `file` names it in errors.
///
/// # Errors
/// As [`read_coat_index`].
pub fn read_coat_index_from(reader: impl Read, file: &str) -> Result<RealSpectrumFile, TableError> {
    let t = Table::read(reader, file)?;
    let [cw, cn] = t.require(
        ["wavelength_nm", "n"],
        "missing column(s); a clear-coat index file needs wavelength_nm, n",
    )?;
    let ck = t.col("k");
    let mut out = RealSpectrumFile {
        file: file.to_string(),
        wavelengths_nm: Vec::new(),
        values: Vec::new(),
    };
    for (line, rec) in &t.rows {
        let w = wavelength(&t, *line, rec, cw, out.wavelengths_nm.last().copied())?;
        let n = t.num(*line, rec, cn, "n")?;
        if n < 1.0 {
            return Err(t.bad(
                *line,
                "n",
                format!("{n} is below 1 (a clear coat has n >= 1)"),
            ));
        }
        if let Some(c) = ck {
            let k = t.num(*line, rec, c, "k")?;
            if k != 0.0 {
                return Err(t.bad(
                    *line,
                    "k",
                    format!(
                        "{k}: the clear coat is lossless in the models; give the binder's absorption as a separate file (alpha per µm)"
                    ),
                ));
            }
        }
        out.wavelengths_nm.push(w);
        out.values.push(n);
    }
    at_least_two(&t, out.wavelengths_nm.len())?;
    Ok(out)
}

/// Reads the binder's absorption coefficient `wavelength_nm, alpha_per_um` (Napierian,
/// for intensity, µm⁻¹, `≥ 0`).
///
/// # Errors
/// As [`read_complex_index`], and for a negative coefficient.
pub fn read_absorption(path: &Path) -> Result<RealSpectrumFile, TableError> {
    let (f, name) = open(path)?;
    read_absorption_from(f, &name)
}

/// As [`read_absorption`] from any reader; `file` names it in errors.
///
/// # Errors
/// As [`read_absorption`].
pub fn read_absorption_from(reader: impl Read, file: &str) -> Result<RealSpectrumFile, TableError> {
    let t = Table::read(reader, file)?;
    let [cw, ca] = t.require(
        ["wavelength_nm", "alpha_per_um"],
        "missing column(s); a binder absorption file needs wavelength_nm, alpha_per_um",
    )?;
    let mut out = RealSpectrumFile {
        file: file.to_string(),
        wavelengths_nm: Vec::new(),
        values: Vec::new(),
    };
    for (line, rec) in &t.rows {
        let w = wavelength(&t, *line, rec, cw, out.wavelengths_nm.last().copied())?;
        let a = t.num(*line, rec, ca, "alpha_per_um")?;
        if a < 0.0 {
            return Err(t.bad(
                *line,
                "alpha_per_um",
                format!("{a} is negative (expected an absorption coefficient >= 0 per µm)"),
            ));
        }
        out.wavelengths_nm.push(w);
        out.values.push(a);
    }
    at_least_two(&t, out.wavelengths_nm.len())?;
    Ok(out)
}

/// Reads reflectance spectra `wavelength_nm, reflectance_factor`, optionally with the
/// geometry columns `theta_i_deg, aspecular_deg` (one spectrum per geometry).
///
/// # Errors
/// As [`read_complex_index`], and for a negative reflectance factor, only one of the two
/// geometry columns, angles out of range, or a geometry with fewer than two samples.
pub fn read_spectra(path: &Path) -> Result<SpectraFile, TableError> {
    let (f, name) = open(path)?;
    read_spectra_from(f, &name)
}

/// As [`read_spectra`] from any reader; `file` names it in errors.
///
/// # Errors
/// As [`read_spectra`].
pub fn read_spectra_from(reader: impl Read, file: &str) -> Result<SpectraFile, TableError> {
    let t = Table::read(reader, file)?;
    let cols = t.require(
        ["wavelength_nm", "reflectance_factor"],
        "missing column(s); a reflectance spectrum needs wavelength_nm, reflectance_factor (and optionally theta_i_deg, aspecular_deg)",
    )?;
    let geometry = geometry_columns(&t)?;
    let spectra = spectra_of(&t, cols, geometry)?;
    Ok(SpectraFile {
        file: file.to_string(),
        has_geometry: geometry.is_some(),
        spectra,
    })
}

/// Reads a measured multi-angle file: `theta_i_deg, aspecular_deg` with either CIELAB
/// columns `L, a, b` (and optionally `L_uncertainty`, one standard uncertainty of `L*`)
/// or spectral columns `wavelength_nm, reflectance_factor` (long format, one row per
/// geometry and wavelength).
///
/// # Errors
/// As [`read_spectra`]; for a file with both or neither column set, a repeated geometry
/// in a CIELAB file, an `L*` that is not a number in `[0, MAX_LIGHTNESS]`, an `a*` or
/// `b*` beyond `±MAX_LIGHTNESS` ([`MAX_LIGHTNESS`]), or an `L_uncertainty` that is not a
/// finite number `> 0` (a zero uncertainty would weigh its geometry infinitely in `fit
/// --measured-multiangle`).
pub fn read_multiangle(path: &Path) -> Result<MultiAngleFile, TableError> {
    let (f, name) = open(path)?;
    read_multiangle_from(f, &name)
}

/// As [`read_multiangle`] from any reader; `file` names it in errors.
///
/// # Errors
/// As [`read_multiangle`].
pub fn read_multiangle_from(reader: impl Read, file: &str) -> Result<MultiAngleFile, TableError> {
    let t = Table::read(reader, file)?;
    let [ci, ca] = t.require(
        ["theta_i_deg", "aspecular_deg"],
        "missing column(s); a measured multi-angle file needs theta_i_deg, aspecular_deg and either L, a, b or wavelength_nm, reflectance_factor",
    )?;
    let has = |c: &[&str]| c.iter().all(|c| t.col(c).is_some());
    let lab = has(&["l", "a", "b"]);
    let spectral = has(&["wavelength_nm", "reflectance_factor"]);
    let data = match (lab, spectral) {
        (true, true) => {
            return Err(t.bad(
                1,
                "L, a, b, wavelength_nm, reflectance_factor",
                "the file has both CIELAB and spectral columns: keep one set (which would be meant?)".into(),
            ));
        }
        (false, false) => {
            return Err(t.bad(
                1,
                "L, a, b or wavelength_nm, reflectance_factor",
                "missing column(s); a measured multi-angle file needs L, a, b (CIELAB) or wavelength_nm, reflectance_factor (spectra)".into(),
            ));
        }
        (false, true) => {
            let cols = [
                t.col("wavelength_nm").unwrap_or(0),
                t.col("reflectance_factor").unwrap_or(0),
            ];
            MultiAngleData::Spectral(spectra_of(&t, cols, Some([ci, ca]))?)
        }
        (true, false) => {
            let [cl, cla, clb] = t.require(["l", "a", "b"], "missing column(s) L, a, b")?;
            let cu = t.col("l_uncertainty");
            let mut rows: Vec<LabRow> = Vec::new();
            for (line, rec) in &t.rows {
                let (theta_i, aspecular) = angles(&t, *line, rec, ci, ca)?;
                if let Some(prev) = rows
                    .iter()
                    .find(|r| r.theta_i == theta_i && r.aspecular == aspecular)
                {
                    return Err(t.bad(
                        *line,
                        "theta_i_deg, aspecular_deg",
                        format!(
                            "this geometry is already on line {}: expected each (theta_i_deg, aspecular_deg) once",
                            prev.line
                        ),
                    ));
                }
                let l_uncertainty = match cu {
                    Some(c) => {
                        let u = t.num(*line, rec, c, "L_uncertainty")?;
                        if !(u > 0.0) {
                            return Err(t.bad(
                                *line,
                                "L_uncertainty",
                                format!(
                                    "{u}: expected a standard uncertainty of L* > 0 (a zero one would weigh this geometry infinitely; leave the column out for an unweighted fit)"
                                ),
                            ));
                        }
                        if u > MAX_L_UNCERTAINTY {
                            return Err(t.bad(
                                *line,
                                "L_uncertainty",
                                format!(
                                    "{u}: expected a standard uncertainty of L* of at most {MAX_L_UNCERTAINTY} (L* spans 0 to 100)"
                                ),
                            ));
                        }
                        Some(u)
                    }
                    None => None,
                };
                let l = t.num(*line, rec, cl, "L")?;
                let lo = min_lightness(l_uncertainty);
                if !(lo..=MAX_LIGHTNESS).contains(&l) {
                    return Err(t.bad(
                        *line,
                        "L",
                        format!(
                            "{l}: expected a CIELAB lightness L* from {lo} to {MAX_LIGHTNESS} (L* of a surface is never negative, below 0 only by measurement noise: max(1, 5 L_uncertainty), at most 20; above 100 only for luminance factors beyond the perfect diffuser, as near specular)"
                        ),
                    ));
                }
                let mut ab = [0.0; 2];
                for (v, (c, name)) in ab.iter_mut().zip([(cla, "a"), (clb, "b")]) {
                    *v = t.num(*line, rec, c, name)?;
                    if v.abs() > MAX_LIGHTNESS {
                        return Err(t.bad(
                            *line,
                            name,
                            format!("{v}: expected a CIELAB {name}* from -{MAX_LIGHTNESS} to {MAX_LIGHTNESS}"),
                        ));
                    }
                }
                rows.push(LabRow {
                    theta_i,
                    aspecular,
                    l,
                    a: ab[0],
                    b: ab[1],
                    l_uncertainty,
                    line: *line,
                });
            }
            if rows.is_empty() {
                return Err(TableError::Empty {
                    file: file.to_string(),
                });
            }
            MultiAngleData::Lab(rows)
        }
    };
    Ok(MultiAngleFile {
        file: file.to_string(),
        data,
    })
}

/// The geometry columns, both or neither.
fn geometry_columns(t: &Table) -> Result<Option<[usize; 2]>, TableError> {
    match (t.col("theta_i_deg"), t.col("aspecular_deg")) {
        (Some(i), Some(a)) => Ok(Some([i, a])),
        (None, None) => Ok(None),
        (Some(_), None) => Err(t.bad(
            1,
            "aspecular_deg",
            "missing column: theta_i_deg is given, so the geometry needs aspecular_deg too".into(),
        )),
        (None, Some(_)) => Err(t.bad(
            1,
            "theta_i_deg",
            "missing column: aspecular_deg is given, so the geometry needs theta_i_deg too".into(),
        )),
    }
}

/// The spectra of a table with wavelength/reflectance columns `cols` and optional
/// geometry columns.
fn spectra_of(
    t: &Table,
    [cw, cr]: [usize; 2],
    geometry: Option<[usize; 2]>,
) -> Result<Vec<Spectrum>, TableError> {
    let mut spectra: Vec<Spectrum> = Vec::new();
    for (line, rec) in &t.rows {
        let (theta_i, aspecular) = match geometry {
            Some([ci, ca]) => {
                let (i, a) = angles(t, *line, rec, ci, ca)?;
                (Some(i), Some(a))
            }
            None => (None, None),
        };
        let k = match spectra
            .iter()
            .position(|s| s.theta_i == theta_i && s.aspecular == aspecular)
        {
            Some(k) => k,
            None => {
                spectra.push(Spectrum {
                    theta_i,
                    aspecular,
                    wavelengths_nm: Vec::new(),
                    reflectance: Vec::new(),
                    lines: Vec::new(),
                });
                spectra.len() - 1
            }
        };
        let s = &mut spectra[k];
        let w = wavelength(t, *line, rec, cw, s.wavelengths_nm.last().copied())?;
        let r = t.num(*line, rec, cr, "reflectance_factor")?;
        if r < 0.0 {
            return Err(t.bad(
                *line,
                "reflectance_factor",
                format!("{r} is negative (expected a reflectance factor >= 0)"),
            ));
        }
        s.wavelengths_nm.push(w);
        s.reflectance.push(r);
        s.lines.push(*line);
    }
    if spectra.is_empty() {
        return Err(TableError::Empty {
            file: t.file.clone(),
        });
    }
    for s in &spectra {
        if s.wavelengths_nm.len() < 2 {
            return Err(t.bad(
                s.lines[0],
                "wavelength_nm",
                "only one wavelength for this spectrum: expected at least two".into(),
            ));
        }
    }
    Ok(spectra)
}

/// A wavelength (nm): finite, positive, above the previous one of its spectrum.
fn wavelength(
    t: &Table,
    line: u64,
    rec: &csv::StringRecord,
    c: usize,
    previous: Option<f64>,
) -> Result<f64, TableError> {
    let w = t.num(line, rec, c, "wavelength_nm")?;
    if w <= 0.0 {
        return Err(t.bad(line, "wavelength_nm", format!("{w} is not > 0 nm")));
    }
    if let Some(p) = previous
        && w <= p
    {
        return Err(t.bad(
            line,
            "wavelength_nm",
            format!("{w} nm does not follow {p} nm: expected strictly increasing wavelengths"),
        ));
    }
    Ok(w)
}

/// `(θi, aspecular)` in radians, checked: `θi ∈ [0, 90)`, `θs = aspecular − θi` in
/// `(−90, 90)` degrees.
fn angles(
    t: &Table,
    line: u64,
    rec: &csv::StringRecord,
    ci: usize,
    ca: usize,
) -> Result<(f64, f64), TableError> {
    let ti = t.num(line, rec, ci, "theta_i_deg")?;
    if !(0.0..90.0).contains(&ti) {
        return Err(t.bad(line, "theta_i_deg", format!("{ti} is outside [0, 90)")));
    }
    let asp = t.num(line, rec, ca, "aspecular_deg")?;
    let ts = asp - ti;
    if !(ts > -90.0 && ts < 90.0) {
        return Err(t.bad(
            line,
            "aspecular_deg",
            format!(
                "{asp} at theta_i_deg {ti} puts the detector at theta_s = {ts} degrees, not above the surface: expected |aspecular - theta_i| < 90"
            ),
        ));
    }
    Ok((ti.to_radians(), asp.to_radians()))
}

fn at_least_two(t: &Table, rows: usize) -> Result<(), TableError> {
    match rows {
        0 => Err(TableError::Empty {
            file: t.file.clone(),
        }),
        1 => Err(t.bad(
            t.rows[0].0,
            "wavelength_nm",
            "only one row: a table versus wavelength needs at least two".into(),
        )),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_each_kind() {
        let nk = read_complex_index_from(
            "# Rakić\nwavelength_nm,n,k\n400,0.49,4.86\n500,0.77,6.08\n".as_bytes(),
            "al.csv",
        )
        .unwrap();
        assert_eq!(nk.wavelengths_nm, vec![400.0, 500.0]);
        assert_eq!((nk.n[1], nk.k[0]), (0.77, 4.86));
        let coat = read_coat_index_from(
            "wavelength_nm,n,k\n400,1.52,0\n700,1.49,0\n".as_bytes(),
            "c",
        )
        .unwrap();
        assert_eq!(coat.values, vec![1.52, 1.49]);
        let alpha = read_absorption_from(
            "Wavelength_nm,Alpha_per_um\n400,0.5\n700,0\n".as_bytes(),
            "a",
        )
        .unwrap();
        assert_eq!(alpha.values, vec![0.5, 0.0]);
        let s = read_spectra_from(
            "wavelength_nm,reflectance_factor\n400,0.5\n410,0.6\n420,0.7\n".as_bytes(),
            "s",
        )
        .unwrap();
        assert!(!s.has_geometry && s.spectra.len() == 1);
        assert_eq!(s.spectra[0].lines, vec![2, 3, 4]);
        // Two geometries, interleaved rows.
        let g = read_spectra_from(
            "theta_i_deg,aspecular_deg,wavelength_nm,reflectance_factor\n45,15,400,2\n45,45,400,0.5\n45,15,700,2.1\n45,45,700,0.6\n".as_bytes(),
            "g",
        )
        .unwrap();
        assert_eq!(g.spectra.len(), 2);
        assert_eq!(g.spectra[1].reflectance, vec![0.5, 0.6]);
        assert!((g.spectra[0].aspecular.unwrap() - 15f64.to_radians()).abs() < 1e-15);
        let m = read_multiangle_from(
            "theta_i_deg,aspecular_deg,L,a,b,L_uncertainty\n45,15,120.5,-0.3,-1.2,0.2\n45,110,30,0,0.5,0.1\n"
                .as_bytes(),
            "m",
        )
        .unwrap();
        let MultiAngleData::Lab(rows) = m.data else {
            panic!("a CIELAB file")
        };
        assert_eq!((rows[0].l, rows[0].a, rows[0].b), (120.5, -0.3, -1.2));
        assert_eq!(rows[1].l_uncertainty, Some(0.1));
    }

    #[test]
    fn bad_files_name_line_and_column() {
        type Reader = fn(&[u8], &str) -> Result<(), TableError>;
        let nk: Reader = |b, f| read_complex_index_from(b, f).map(|_| ());
        let coat: Reader = |b, f| read_coat_index_from(b, f).map(|_| ());
        let alpha: Reader = |b, f| read_absorption_from(b, f).map(|_| ());
        let spec: Reader = |b, f| read_spectra_from(b, f).map(|_| ());
        let multi: Reader = |b, f| read_multiangle_from(b, f).map(|_| ());
        let cases: [(Reader, &str, &str); 18] = [
            (nk, "wavelength_nm,n\n400,1\n", "column k"),
            (
                nk,
                "wavelength_nm,n,k\n400,0.5,4\n400,0.6,5\n",
                "line 3, column wavelength_nm",
            ),
            (
                nk,
                "wavelength_nm,n,k\n400,0,4\n500,1,5\n",
                "line 2, column n",
            ),
            (
                nk,
                "wavelength_nm,n,k\n400,1,-4\n500,1,5\n",
                "line 2, column k",
            ),
            (
                nk,
                "wavelength_nm,n,k\n400,1,4\n",
                "line 2, column wavelength_nm: only one row",
            ),
            (
                nk,
                "wavelength_nm,n,k\n-400,1,4\n500,1,5\n",
                "line 2, column wavelength_nm",
            ),
            (
                nk,
                "wavelength_nm,n,k\n400,x,4\n500,1,5\n",
                "line 2, column n",
            ),
            (
                coat,
                "wavelength_nm,n\n400,0.9\n500,1.5\n",
                "line 2, column n",
            ),
            (
                coat,
                "wavelength_nm,n,k\n400,1.5,0\n500,1.5,0.01\n",
                "line 3, column k",
            ),
            (
                alpha,
                "wavelength_nm,alpha_per_um\n400,-1\n500,1\n",
                "line 2, column alpha_per_um",
            ),
            (
                alpha,
                "wavelength_nm,alpha\n400,1\n500,1\n",
                "column alpha_per_um",
            ),
            (
                spec,
                "wavelength_nm,reflectance_factor\n400,-0.1\n500,1\n",
                "line 2, column reflectance_factor",
            ),
            (
                spec,
                "wavelength_nm,reflectance_factor,theta_i_deg\n400,1,45\n500,1,45\n",
                "column aspecular_deg",
            ),
            (
                spec,
                "theta_i_deg,aspecular_deg,wavelength_nm,reflectance_factor\n45,140,400,1\n",
                "line 2, column aspecular_deg",
            ),
            (
                spec,
                "theta_i_deg,aspecular_deg,wavelength_nm,reflectance_factor\n45,15,400,1\n45,45,400,1\n45,45,500,1\n",
                "line 2, column wavelength_nm",
            ),
            (
                multi,
                "theta_i_deg,aspecular_deg,L,a\n45,15,100,0\n",
                "L, a, b or wavelength_nm",
            ),
            (
                multi,
                "theta_i_deg,aspecular_deg,L,a,b\n45,15,100,0,0\n45,15,90,0,0\n",
                "line 3, column theta_i_deg, aspecular_deg",
            ),
            (
                multi,
                "theta_i_deg,aspecular_deg,L,a,b,wavelength_nm,reflectance_factor\n45,15,100,0,0,400,1\n",
                "both CIELAB and spectral",
            ),
        ];
        for (read, text, needle) in cases {
            let e = read(text.as_bytes(), "f.csv").unwrap_err().to_string();
            assert!(
                e.contains("f.csv") && e.contains(needle),
                "`{e}` lacks `{needle}` (input {text:?})"
            );
        }
    }
}

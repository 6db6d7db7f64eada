//! Flake tables and orientation histograms (CSV with a header row).
//!
//! Flake tables (`cli.md`), one of three column sets, any other columns ignored, header
//! names matched case-insensitively after trimming spaces:
//! * **normals**: `nx, ny, nz, area_um2` (unit or not, `nz > 0`; area in µm²);
//! * **tilts**: `theta_x_deg, theta_y_deg, area_um2` (signed tilts in degrees,
//!   `tan θx = ∂z/∂x`, see [`flakescatter_stats::flake`]);
//! * **endpoints** (paper eq. 6): `x1_um, z1_um, x2_um, z2_um` along a line of constant
//!   `y`, `y1_um, zy1_um, y2_um, zy2_um` along a line of constant `x`, all µm; the area is
//!   the eq. 7 estimate.
//!
//! When several sets are complete the first of normals, tilts, endpoints is used.
//! Optional `x_um, y_um` columns give the flake centre. Degrees are converted to radians
//! here; the returned [`Flake`]s carry radians-free unit normals and areas in µm².
//!
//! Histograms: `theta_lo_deg, theta_hi_deg, area_fraction, p_per_rad, p_tilde`, as
//! written by `flakescatter stats` ([`write_histogram`]); [`read_histogram`] needs only
//! the first three.
//!
//! Every error names the file, the 1-based line and the column.

use std::fs::File;
use std::io::{Read, Write};
use std::path::Path;

use flakescatter_stats::flake::{Flake, FlakeError, normal_from_tilts, polar_from_normal};
use flakescatter_stats::histogram::AreaHistogram;
use flakescatter_stats::nalgebra::Vector3 as Vec3;
use flakescatter_stats::segment::SegmentedFlake;

use crate::table::{Table, TableError, io_err, write_err};

/// Which column set a flake table was read with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ColumnSet {
    /// `nx, ny, nz, area_um2`.
    Normals,
    /// `theta_x_deg, theta_y_deg, area_um2`.
    Tilts,
    /// `x1_um, z1_um, x2_um, z2_um, y1_um, zy1_um, y2_um, zy2_um`.
    Endpoints,
}

impl ColumnSet {
    /// The required column names.
    pub fn columns(self) -> &'static [&'static str] {
        match self {
            Self::Normals => &["nx", "ny", "nz", "area_um2"],
            Self::Tilts => &["theta_x_deg", "theta_y_deg", "area_um2"],
            Self::Endpoints => &[
                "x1_um", "z1_um", "x2_um", "z2_um", "y1_um", "zy1_um", "y2_um", "zy2_um",
            ],
        }
    }

    /// Short name: `normals`, `tilts` or `endpoints`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Normals => "normals",
            Self::Tilts => "tilts",
            Self::Endpoints => "endpoints",
        }
    }
}

/// Errors reading or writing flake tables and histograms (the shared CSV error).
pub type FlakeTableError = TableError;

/// A flake table as read: the flakes and the column set used.
#[derive(Debug, Clone, PartialEq)]
pub struct FlakeTable {
    /// The flakes, in file order.
    pub flakes: Vec<Flake>,
    /// The column set they were read with.
    pub column_set: ColumnSet,
}

/// Reads a flake table from a file (module docs).
///
/// # Errors
/// [`FlakeTableError`] naming the file, line and column.
pub fn read_flakes(path: &Path) -> Result<FlakeTable, FlakeTableError> {
    let name = path.display().to_string();
    let f = File::open(path).map_err(io_err(&name))?;
    read_flakes_from(f, &name)
}

/// Reads a flake table from any reader; `file` names it in errors.
///
/// # Errors
/// [`FlakeTableError`] naming the file, line and column.
pub fn read_flakes_from(reader: impl Read, file: &str) -> Result<FlakeTable, FlakeTableError> {
    let t = Table::read(reader, file)?;
    let sets = [ColumnSet::Normals, ColumnSet::Tilts, ColumnSet::Endpoints];
    let chosen = sets
        .iter()
        .copied()
        .find(|s| s.columns().iter().all(|c| t.col(c).is_some()));
    let Some(set) = chosen else {
        // Closest set: the most columns present (ties: fewest missing, then order).
        let best = sets
            .iter()
            .copied()
            .max_by_key(|s| {
                let present = s.columns().iter().filter(|c| t.col(c).is_some()).count();
                let missing = s.columns().len() - present;
                (present, std::cmp::Reverse(missing))
            })
            .expect("three sets");
        return Err(FlakeTableError::MissingColumns {
            file: file.to_string(),
            line: t.header_line,
            closest: best.name(),
            missing: best
                .columns()
                .iter()
                .filter(|c| t.col(c).is_none())
                .map(|c| c.to_string())
                .collect(),
        });
    };
    if t.rows.is_empty() {
        return Err(FlakeTableError::Empty {
            file: file.to_string(),
        });
    }
    let idx: Vec<usize> = set
        .columns()
        .iter()
        .map(|c| t.col(c).expect("checked"))
        .collect();
    let centre = t.col("x_um").zip(t.col("y_um"));
    let mut flakes = Vec::with_capacity(t.rows.len());
    for (line, rec) in &t.rows {
        let line = *line;
        let mut v = [0.0; 8];
        for (k, (&i, name)) in idx.iter().zip(set.columns()).enumerate() {
            v[k] = t.num(line, rec, i, name)?;
        }
        let mut flake = match set {
            ColumnSet::Normals => {
                if v[3] <= 0.0 {
                    return Err(t.bad(
                        line,
                        "area_um2",
                        format!("{} must be > 0 (flake area in µm²)", v[3]),
                    ));
                }
                if v[2] <= 0.0 {
                    return Err(t.bad(
                        line,
                        "nz",
                        format!("{} must be > 0 (normals point into the air)", v[2]),
                    ));
                }
                Flake::new(Vec3::new(v[0], v[1], v[2]), v[3])
                    .map_err(|e| t.bad(line, "nx, ny, nz", e.to_string()))?
            }
            ColumnSet::Tilts => {
                if v[2] <= 0.0 {
                    return Err(t.bad(
                        line,
                        "area_um2",
                        format!("{} must be > 0 (flake area in µm²)", v[2]),
                    ));
                }
                for (k, name) in [(0, "theta_x_deg"), (1, "theta_y_deg")] {
                    if v[k].abs() >= 90.0 {
                        return Err(t.bad(
                            line,
                            name,
                            format!("{} must lie in (-90, 90) degrees", v[k]),
                        ));
                    }
                }
                let n = normal_from_tilts(v[0].to_radians(), v[1].to_radians())
                    .map_err(|e| t.bad(line, "theta_x_deg, theta_y_deg", e.to_string()))?;
                Flake::new(n.into_inner(), v[2])
                    .map_err(|e| t.bad(line, "area_um2", e.to_string()))?
            }
            ColumnSet::Endpoints => Flake::from_endpoints(
                v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7],
            )
            .map_err(|e| match e {
                FlakeError::DegenerateEndpoints { axis: "x", value } => t.bad(
                    line,
                    "x1_um, x2_um",
                    format!(
                        "x2_um = x1_um = {value}: degenerate endpoints, the x trace has zero length"
                    ),
                ),
                FlakeError::DegenerateEndpoints { value, .. } => t.bad(
                    line,
                    "y1_um, y2_um",
                    format!(
                        "y2_um = y1_um = {value}: degenerate endpoints, the y trace has zero length"
                    ),
                ),
                other => t.bad(line, "endpoints", other.to_string()),
            })?,
        };
        if let Some((ix, iy)) = centre {
            let (sx, sy) = (rec.get(ix).unwrap_or(""), rec.get(iy).unwrap_or(""));
            if !(sx.is_empty() && sy.is_empty()) {
                flake.centre_um =
                    Some([t.num(line, rec, ix, "x_um")?, t.num(line, rec, iy, "y_um")?]);
            }
        }
        flakes.push(flake);
    }
    Ok(FlakeTable {
        flakes,
        column_set: set,
    })
}

/// Writes flakes as a table with columns
/// `x_um, y_um, nx, ny, nz, area_um2, theta_n_deg, phi_n_deg` (the normals set plus the
/// centre, empty when unknown, and the polar angles of the normal in degrees, `φn` from
/// `+x` toward `+y` in `[0, 360)`). Numbers are written in Rust's shortest round-trip
/// form, so [`read_flakes_from`] gives back the same values.
///
/// # Errors
/// [`FlakeTableError::Io`] if writing fails; `file` names the destination.
pub fn write_flakes(
    writer: impl Write,
    file: &str,
    flakes: &[Flake],
) -> Result<(), FlakeTableError> {
    let mut w = csv::Writer::from_writer(writer);
    // The first eight columns of a segmented table: the same names, readable alike.
    w.write_record(&SEGMENTED_COLUMNS[..8])
        .map_err(|e| write_err(file, e))?;
    for f in flakes {
        let (t, p) = polar_from_normal(&f.normal);
        let (x, y) = f
            .centre_um
            .map_or((String::new(), String::new()), |[x, y]| {
                (x.to_string(), y.to_string())
            });
        w.write_record([
            x,
            y,
            f.normal.x.to_string(),
            f.normal.y.to_string(),
            f.normal.z.to_string(),
            f.area_um2.to_string(),
            t.to_degrees().to_string(),
            p.to_degrees().to_string(),
        ])
        .map_err(|e| write_err(file, e))?;
    }
    w.flush().map_err(io_err(file))
}

/// Columns of a table of segmented flakes (`segment --out`, `analyze`'s `flakes.csv`):
/// the centre, the normal, the areas and the polar angles first (the first eight are the
/// "normals" set with the centre, so [`read_flakes_from`] reads the table), then the fit's
/// quality, and last the map's name and the flake's number on it (from 1, the label of
/// the overlays).
pub const SEGMENTED_COLUMNS: [&str; 18] = [
    "x_um",
    "y_um",
    "nx",
    "ny",
    "nz",
    "area_um2",
    "theta_n_deg",
    "phi_n_deg",
    "projected_area_um2",
    "equivalent_diameter_um",
    "rms_um",
    "tilt_se_deg",
    "pixels",
    "inliers",
    "touches_border",
    "quality",
    "map",
    "flake",
];

/// A number in a table: Rust's shortest round-trip form, `0` for either zero.
fn shortest(x: f64) -> String {
    if x == 0.0 { "0".into() } else { format!("{x}") }
}

/// Writes segmented flakes of several maps, `(map name, its flakes)`, as a table with
/// the columns [`SEGMENTED_COLUMNS`], flakes numbered from 1 on each map; numbers in
/// shortest round-trip form, angles in degrees.
///
/// # Errors
/// [`FlakeTableError::Io`] if writing fails; `file` names the destination.
pub fn write_segmented_flakes(
    writer: impl Write,
    file: &str,
    maps: &[(&str, &[SegmentedFlake])],
) -> Result<(), FlakeTableError> {
    let mut w = csv::Writer::from_writer(writer);
    w.write_record(SEGMENTED_COLUMNS)
        .map_err(|e| write_err(file, e))?;
    for (name, flakes) in maps {
        for (k, f) in flakes.iter().enumerate() {
            w.write_record([
                shortest(f.centre_um[0]),
                shortest(f.centre_um[1]),
                shortest(f.normal.x),
                shortest(f.normal.y),
                shortest(f.normal.z),
                shortest(f.area_um2),
                shortest(f.theta_n.to_degrees()),
                shortest(f.phi_n.to_degrees()),
                shortest(f.projected_area_um2),
                shortest(f.equivalent_diameter_um),
                shortest(f.rms_um),
                shortest(f.tilt_se.to_degrees()),
                f.pixels.to_string(),
                f.inliers.to_string(),
                f.touches_border.to_string(),
                shortest(f.quality),
                (*name).to_owned(),
                (k + 1).to_string(),
            ])
            .map_err(|e| write_err(file, e))?;
        }
    }
    w.flush().map_err(io_err(file))
}

/// Writes an area-weighted histogram as CSV with columns
/// `theta_lo_deg, theta_hi_deg, area_fraction, p_per_rad, p_tilde`
/// (see [`flakescatter_stats::histogram`] for their normalisation).
///
/// # Errors
/// [`FlakeTableError::Io`] if writing fails; `file` names the destination.
pub fn write_histogram(
    writer: impl Write,
    file: &str,
    hist: &AreaHistogram,
) -> Result<(), FlakeTableError> {
    write_histogram_bins(writer, file, hist.edges(), hist.area_fractions())
}

/// Writes any binned distribution in the histogram CSV format of [`write_histogram`]:
/// `edges_rad` (`n + 1` increasing edges, radians) and `n` area fractions; per bin
/// `p_per_rad = fraction / Δθ` and `p_tilde = fraction / (cos θlo − cos θhi)` (the exact
/// solid-angle normalisation, `Σ p̃ (cos θlo − cos θhi) = Σ fraction`). Edges are
/// written in degrees as the shortest decimals that convert to them
/// ([`flakescatter_stats::decimal::degrees_text`]): `1.5`, not `1.5000000000000002`.
///
/// # Errors
/// [`FlakeTableError::Io`] if writing fails; `file` names the destination.
pub fn write_histogram_bins(
    writer: impl Write,
    file: &str,
    edges_rad: &[f64],
    area_fractions: &[f64],
) -> Result<(), FlakeTableError> {
    let mut w = csv::Writer::from_writer(writer);
    w.write_record([
        "theta_lo_deg",
        "theta_hi_deg",
        "area_fraction",
        "p_per_rad",
        "p_tilde",
    ])
    .map_err(|e| write_err(file, e))?;
    for (e, f) in edges_rad.windows(2).zip(area_fractions) {
        w.write_record([
            flakescatter_stats::decimal::degrees_text(e[0]),
            flakescatter_stats::decimal::degrees_text(e[1]),
            f.to_string(),
            (f / (e[1] - e[0])).to_string(),
            (f / (e[0].cos() - e[1].cos())).to_string(),
        ])
        .map_err(|e| write_err(file, e))?;
    }
    w.flush().map_err(io_err(file))
}

/// A histogram read back as a tabulated distribution: bin edges in radians and the area
/// fraction of each bin, ready for
/// [`Orientation::tabulated`](flakescatter_stats::Orientation::tabulated).
#[derive(Debug, Clone, PartialEq)]
pub struct HistogramTable {
    /// `n + 1` increasing edges, radians, in `[0, π/2]`.
    pub edges_rad: Vec<f64>,
    /// `n` area fractions (as in the file, not renormalised).
    pub area_fractions: Vec<f64>,
}

/// Reads a histogram file (columns `theta_lo_deg, theta_hi_deg, area_fraction`, others
/// ignored). Bins must be contiguous (each `theta_lo_deg` equals the previous
/// `theta_hi_deg` to 1e-9°), within `[0, 90]` degrees, with non-negative fractions that
/// are not all zero.
///
/// # Errors
/// [`FlakeTableError`] naming the file, line and column.
pub fn read_histogram(path: &Path) -> Result<HistogramTable, FlakeTableError> {
    let name = path.display().to_string();
    let f = File::open(path).map_err(io_err(&name))?;
    read_histogram_from(f, &name)
}

/// As [`read_histogram`] from any reader; `file` names it in errors.
///
/// # Errors
/// [`FlakeTableError`] naming the file, line and column.
pub fn read_histogram_from(
    reader: impl Read,
    file: &str,
) -> Result<HistogramTable, FlakeTableError> {
    let t = Table::read(reader, file)?;
    let need = ["theta_lo_deg", "theta_hi_deg", "area_fraction"];
    let [ilo, ihi, ifr] = t.require(
        need,
        "missing histogram column(s); expected theta_lo_deg, theta_hi_deg, area_fraction",
    )?;
    if t.rows.is_empty() {
        return Err(FlakeTableError::Empty {
            file: file.to_string(),
        });
    }
    let mut edges_deg: Vec<f64> = Vec::with_capacity(t.rows.len() + 1);
    let mut fractions = Vec::with_capacity(t.rows.len());
    let mut last_line = 0;
    for (line, rec) in &t.rows {
        let line = *line;
        last_line = line;
        let lo = t.num(line, rec, ilo, need[0])?;
        let hi = t.num(line, rec, ihi, need[1])?;
        let fr = t.num(line, rec, ifr, need[2])?;
        if !(0.0..=90.0).contains(&lo) {
            return Err(t.bad(line, need[0], format!("{lo} must lie in [0, 90] degrees")));
        }
        if !(hi > lo && hi <= 90.0) {
            return Err(t.bad(
                line,
                need[1],
                format!("{hi} must be above theta_lo_deg = {lo} and at most 90 degrees"),
            ));
        }
        if fr < 0.0 {
            return Err(t.bad(line, need[2], format!("{fr} must be >= 0")));
        }
        match edges_deg.last() {
            None => edges_deg.push(lo),
            Some(&prev) if (prev - lo).abs() <= 1e-9 => {}
            Some(&prev) => {
                return Err(t.bad(
                    line,
                    need[0],
                    format!(
                        "{lo} does not continue the previous bin, which ended at {prev} degrees"
                    ),
                ));
            }
        }
        edges_deg.push(hi);
        fractions.push(fr);
    }
    if fractions.iter().all(|&f| f == 0.0) {
        return Err(t.bad(last_line, need[2], "all area fractions are zero".into()));
    }
    let edges_rad = edges_deg
        .iter()
        .map(|d| d.to_radians().min(std::f64::consts::FRAC_PI_2))
        .collect();
    Ok(HistogramTable {
        edges_rad,
        area_fractions: fractions,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str) -> Result<FlakeTable, FlakeTableError> {
        read_flakes_from(text.as_bytes(), "t.csv")
    }

    fn err(text: &str) -> String {
        read(text).unwrap_err().to_string()
    }

    #[test]
    fn reads_normals_with_extra_columns_and_centres() {
        // Unnormalised normal (0, 3, 4) has unit normal (0, 0.6, 0.8): θn = atan(3/4).
        let t = read(
            "id, x_um, y_um, nx, ny, nz, area_um2\na, 1.5, 2.5, 0, 3, 4, 10\nb,,, 0, 0, 1, 2\n",
        )
        .unwrap();
        assert_eq!(t.column_set, ColumnSet::Normals);
        assert_eq!(t.flakes.len(), 2);
        let f = &t.flakes[0];
        assert!((f.normal.y - 0.6).abs() < 1e-15 && (f.normal.z - 0.8).abs() < 1e-15);
        assert_eq!(f.area_um2, 10.0);
        assert_eq!(f.centre_um, Some([1.5, 2.5]));
        assert_eq!(t.flakes[1].centre_um, None);
    }

    #[test]
    fn reads_tilts_and_endpoints() {
        // θx = 45°: normal ∝ (−1, 0, 1), θn = 45°, leaning toward −x.
        let t = read("theta_x_deg,theta_y_deg,area_um2\n45,0,3\n").unwrap();
        assert_eq!(t.column_set, ColumnSet::Tilts);
        let n = t.flakes[0].normal;
        assert!((n.x + 0.5f64.sqrt()).abs() < 1e-15 && (n.z - 0.5f64.sqrt()).abs() < 1e-15);
        // Endpoints: rise 1 over 10 in x, 0 over 20 in y; eq. 7 area 10·20/cos θx
        // = 200·sqrt(1.01).
        let t =
            read("x1_um,z1_um,x2_um,z2_um,y1_um,zy1_um,y2_um,zy2_um\n0,5,10,6,0,1,20,1\n").unwrap();
        assert_eq!(t.column_set, ColumnSet::Endpoints);
        assert!((t.flakes[0].area_um2 - 200.0 * 1.01f64.sqrt()).abs() < 1e-12);
        assert!((t.flakes[0].theta_n() - 0.1f64.atan()).abs() < 1e-15);
    }

    #[test]
    fn bad_input_names_file_line_and_column() {
        let e = err("nx,ny,nz\n0,0,1\n");
        assert!(
            e.contains("t.csv") && e.contains("closest is normals set") && e.contains("area_um2"),
            "{e}"
        );
        let e = err("theta_x_deg,area_um2\n1,2\n");
        assert!(
            e.contains("closest is tilts set") && e.contains("theta_y_deg"),
            "{e}"
        );
        let e = err("nx,ny,nz,area_um2\n");
        assert!(e.contains("no data rows"), "{e}");
        let e = err("nx,ny,nz,area_um2\n0,0,1,1\n0,zero,1,1\n");
        assert!(
            e.contains("line 3") && e.contains("column ny") && e.contains("\"zero\""),
            "{e}"
        );
        let e = err("nx,ny,nz,area_um2\n0,0,1,NaN\n");
        assert!(
            e.contains("line 2") && e.contains("column area_um2") && e.contains("finite"),
            "{e}"
        );
        let e = err("nx,ny,nz,area_um2\n0,0,1,0\n");
        assert!(e.contains("column area_um2") && e.contains("> 0"), "{e}");
        let e = err("theta_x_deg,theta_y_deg,area_um2\n1,1,-2\n");
        assert!(e.contains("line 2") && e.contains("column area_um2"), "{e}");
        let e = err("nx,ny,nz,area_um2\n0,0,-1,1\n");
        assert!(e.contains("column nz"), "{e}");
        let e = err(
            "x1_um,z1_um,x2_um,z2_um,y1_um,zy1_um,y2_um,zy2_um\n0,0,10,1,0,0,5,0\n3,0,3,1,0,0,5,0\n",
        );
        assert!(
            e.contains("line 3") && e.contains("x1_um, x2_um") && e.contains("degenerate"),
            "{e}"
        );
        let e = err("nx,ny,nz,area_um2\n0,0,1\n");
        assert!(
            e.contains("line 2") && e.contains("expected 4 fields") && e.contains("found 3"),
            "{e}"
        );
    }

    #[test]
    fn flake_table_round_trip() {
        let flakes: Vec<Flake> = [(0.1, 0.2, 0.97, 3.5), (-0.3, 0.01, 0.9, 0.125)]
            .iter()
            .enumerate()
            .map(|(i, &(x, y, z, a))| {
                let mut f = Flake::new(Vec3::new(x, y, z), a).unwrap();
                if i == 0 {
                    f.centre_um = Some([12.25, -3.0]);
                }
                f
            })
            .collect();
        let mut buf = Vec::new();
        write_flakes(&mut buf, "mem", &flakes).unwrap();
        let text = String::from_utf8(buf).unwrap();
        assert!(text.starts_with("x_um,y_um,nx,ny,nz,area_um2,theta_n_deg,phi_n_deg\n"));
        let back = read(&text).unwrap();
        assert_eq!(back.column_set, ColumnSet::Normals);
        assert_eq!(back.flakes.len(), 2);
        for (a, b) in flakes.iter().zip(&back.flakes) {
            assert!((a.normal.into_inner() - b.normal.into_inner()).norm() < 1e-15);
            assert_eq!(a.area_um2, b.area_um2);
            assert_eq!(a.centre_um, b.centre_um);
        }
        // theta_n_deg of the second flake from its components: atan(sqrt(0.09 + 1e-4)/0.9).
        let row2: Vec<&str> = text.lines().nth(2).unwrap().split(',').collect();
        let tn: f64 = row2[6].parse().unwrap();
        assert!((tn - (0.0901f64.sqrt() / 0.9).atan().to_degrees()).abs() < 1e-12);
    }

    #[test]
    fn histogram_round_trip_and_errors() {
        let h = AreaHistogram::new([(0.01, 1.0), (0.03, 3.0)], 1f64.to_radians()).unwrap();
        let mut buf = Vec::new();
        write_histogram(&mut buf, "mem", &h).unwrap();
        let text = String::from_utf8(buf).unwrap();
        assert!(text.starts_with("theta_lo_deg,theta_hi_deg,area_fraction,p_per_rad,p_tilde\n"));
        let back = read_histogram_from(text.as_bytes(), "h.csv").unwrap();
        assert_eq!(back.edges_rad.len(), 91);
        assert_eq!(back.area_fractions, h.area_fractions());
        for (a, b) in back.edges_rad.iter().zip(h.edges()) {
            assert!((a - b).abs() < 1e-15);
        }
        let e = |s: &str| {
            read_histogram_from(s.as_bytes(), "h.csv")
                .unwrap_err()
                .to_string()
        };
        let m = e("theta_lo_deg,area_fraction\n0,1\n");
        assert!(m.contains("h.csv, line 1, column theta_hi_deg"), "{m}");
        let m = e("theta_lo_deg,theta_hi_deg,area_fraction\n0,1,0.5\n2,3,0.5\n");
        assert!(
            m.contains("line 3") && m.contains("does not continue"),
            "{m}"
        );
        let m = e("theta_lo_deg,theta_hi_deg,area_fraction\n0,1,-0.5\n");
        assert!(m.contains("column area_fraction"), "{m}");
        let m = e("theta_lo_deg,theta_hi_deg,area_fraction\n0,1,0\n");
        assert!(m.contains("all area fractions are zero"), "{m}");
        let m = e("theta_lo_deg,theta_hi_deg,area_fraction\n0,95,1\n");
        assert!(m.contains("column theta_hi_deg"), "{m}");
    }
}

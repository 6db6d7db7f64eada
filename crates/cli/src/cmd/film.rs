//! `flakescatter film`: reflection and transmission of a thin-film flake (a layer stack,
//! e.g. TiO2 on mica) over angles and wavelengths (docs/cli.md "film", physics.md §13).

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::Context;
use flakescatter::film::{FilmError, FilmRow, FilmSetup, film_table};
use flakescatter::io::spectral::read_complex_index;
use flakescatter::optics::catalogue::Catalogue;
use flakescatter::optics::material::ComplexIndexTable;
use serde_json::{Value, json};

use crate::flags::DEFAULT_WAVELENGTHS;
use crate::output::{Kind, Plan, print, print_json};
use crate::parse::{angles, check_range_in, fixed, shortest};
use crate::tables::num;

/// Most rows (angles × wavelengths) of one table.
const MAX_ROWS: usize = 1_000_000;

/// Amplitude and power reflection and transmission of a thin-film flake for s and p
/// polarisation, by the transfer-matrix (Rouard) recursion: a stack of layers from the
/// incidence side between the binder (--ambient) and either the binder again (a free
/// flake) or an opaque --substrate. Conventions (exp(−iωt), n + ik with k ≥ 0, p
/// amplitudes with r_p = −r_s at normal incidence, as the `tmm` package): physics.md §13.
///
/// Built-in materials: TiO2 (rutile), anatase, Fe2O3, SiO2, Al2O3, mica, aluminium, Cr,
/// Ag (sources in docs/physics.md §13); or an index such as 2.6+0.01i; or a table of
/// your own with --material NAME=FILE.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The layers from the incidence side, `material:thickness_nm` separated by `/`
    /// (e.g. `TiO2:120/mica:400/TiO2:120`; a material is a name or `2.6+0.01i`).
    #[arg(long, value_name = "SPEC", allow_hyphen_values = true)]
    pub stack: String,
    /// Real index of the medium around the flake (the binder), on the incidence side and,
    /// without --substrate, below the stack.
    #[arg(
        long,
        value_name = "N",
        default_value_t = 1.5,
        allow_hyphen_values = true
    )]
    pub ambient: f64,
    /// An opaque core under the stack (e.g. aluminium): a material name or `n+ki`.
    /// Its `T` columns are the power it absorbs.
    #[arg(long, value_name = "MATERIAL", allow_hyphen_values = true)]
    pub substrate: Option<String>,
    /// A table of optical constants of your own, `NAME=FILE` with FILE a CSV
    /// `wavelength_nm,n,k`; NAME is then usable in --stack and --substrate (repeatable).
    #[arg(long, value_name = "NAME=FILE")]
    pub material: Vec<String>,
    /// Incidence angles in the ambient, degrees (0–90): a list or `start:stop:step`.
    #[arg(
        long,
        value_name = "LIST",
        default_value = "0:80:10",
        allow_hyphen_values = true
    )]
    pub theta_deg: String,
    /// Vacuum wavelengths, nm: a list or `start:stop:step`.
    #[arg(long, value_name = "LIST", default_value = DEFAULT_WAVELENGTHS, allow_hyphen_values = true)]
    pub wavelengths: String,
    /// Write the table here as CSV (`-` = stdout): `wavelength_nm, theta_deg, rs_re,
    /// rs_im, rp_re, rp_im, ts_re, ts_im, tp_re, tp_im, R_s, R_p, T_s, T_p`.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Print a JSON document (inputs, units, conventions, rows) on stdout.
    #[arg(long)]
    pub json: bool,
}

/// `NAME=FILE` of `--material`.
fn material_arg(text: &str) -> anyhow::Result<(String, PathBuf)> {
    match text.split_once('=') {
        Some((n, f)) if !n.trim().is_empty() && !f.is_empty() => {
            Ok((n.trim().to_string(), PathBuf::from(f)))
        }
        _ => anyhow::bail!("--material {text:?}: expected NAME=FILE (a CSV wavelength_nm,n,k)"),
    }
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let materials: Vec<(String, PathBuf)> = args
        .material
        .iter()
        .map(|m| material_arg(m))
        .collect::<anyhow::Result<_>>()?;
    let mut plan = Plan::new();
    for (_, path) in &materials {
        plan.input("--material", path);
    }
    let out = plan.output("--out", args.out.as_deref(), Kind::Table);
    if args.json {
        plan.stdout("--json");
    } else if out.is_none() {
        plan.stdout("the table");
    }
    plan.check()?;
    let thetas_deg = angles("--theta-deg", &args.theta_deg)?;
    check_range_in(
        "--theta-deg",
        &thetas_deg,
        (0.0, 90.0),
        (false, false),
        ("°", "degrees"),
    )?;
    let wavelengths = angles("--wavelengths", &args.wavelengths)?;
    check_range_in(
        "--wavelengths",
        &wavelengths,
        (0.0, f64::INFINITY),
        (true, true),
        (" nm", "nanometres"),
    )?;
    let rows_wanted = thetas_deg.len().saturating_mul(wavelengths.len());
    if rows_wanted > MAX_ROWS {
        anyhow::bail!(
            "--theta-deg × --wavelengths: {rows_wanted} rows is more than the limit of {MAX_ROWS}"
        );
    }
    let mut catalogue = Catalogue::builtin();
    for (name, path) in &materials {
        let f = read_complex_index(path)
            .with_context(|| format!("reading --material {name}={}", path.display()))?;
        let t = ComplexIndexTable::new(f.wavelengths_nm, f.n, f.k)
            .with_context(|| format!("--material {name}={}", path.display()))?;
        catalogue
            .add(name, t)
            .with_context(|| format!("--material {name}={}", path.display()))?;
    }
    let setup = FilmSetup::parse(
        &args.stack,
        args.ambient,
        args.substrate.as_deref(),
        &catalogue,
    )
    .map_err(flagged)?;
    let thetas: Vec<f64> = thetas_deg.iter().map(|d| d.to_radians()).collect();
    let rows = film_table(&setup, &thetas, &wavelengths).map_err(flagged)?;
    if let Some(dest) = &out {
        let n = rows.len();
        plan.write(
            dest,
            |w| Ok(w.write_all(csv(&rows, &thetas_deg).as_bytes())?),
            Some(format!("{n} rows")),
        )?;
    }
    plan.finish()?;
    if args.json {
        print_json(&summary(&args, &setup, &rows, &thetas_deg))
    } else if out.is_none() {
        print(&text(&setup, &rows, &thetas_deg))
    } else {
        Ok(())
    }
}

/// A [`FilmError`] in terms of this command's flags.
fn flagged(e: FilmError) -> anyhow::Error {
    match e {
        FilmError::Stack(x) => anyhow::anyhow!("--stack: {x}"),
        FilmError::Substrate(x) => anyhow::anyhow!("--substrate: {x}"),
        FilmError::Ambient(v) => {
            anyhow::anyhow!("--ambient {v}: expected a finite real index >= 1")
        }
        other => other.into(),
    }
}

/// Columns of the CSV and of the JSON rows.
const COLUMNS: [&str; 14] = [
    "wavelength_nm",
    "theta_deg",
    "rs_re",
    "rs_im",
    "rp_re",
    "rp_im",
    "ts_re",
    "ts_im",
    "tp_re",
    "tp_im",
    "R_s",
    "R_p",
    "T_s",
    "T_p",
];

/// The row's values in [`COLUMNS`] order (`theta_deg` as typed, not converted back).
fn values(r: &FilmRow, theta_deg: f64) -> [f64; 14] {
    let p = &r.response;
    [
        r.wavelength_nm,
        theta_deg,
        p.rs.re,
        p.rs.im,
        p.rp.re,
        p.rp.im,
        p.ts.re,
        p.ts.im,
        p.tp.re,
        p.tp.im,
        p.r_s(),
        p.r_p(),
        p.t_s(),
        p.t_p(),
    ]
}

/// Rows are wavelength-major: row `i` has angle `thetas_deg[i % thetas_deg.len()]`.
fn csv(rows: &[FilmRow], thetas_deg: &[f64]) -> String {
    let mut out = COLUMNS.join(",");
    out.push('\n');
    for (i, r) in rows.iter().enumerate() {
        let v = values(r, thetas_deg[i % thetas_deg.len()]);
        let cells: Vec<String> = v.iter().map(|&x| num(x)).collect();
        out.push_str(&cells.join(","));
        out.push('\n');
    }
    out
}

fn summary(args: &Args, setup: &FilmSetup, rows: &[FilmRow], thetas_deg: &[f64]) -> Value {
    let (lo, hi) = setup.range_nm();
    json!({
        "version": env!("CARGO_PKG_VERSION"),
        "command": "film",
        "inputs": {
            "stack": setup.stack.label(),
            "stack_as_given": args.stack,
            "ambient": setup.ambient,
            "substrate": setup.substrate.as_ref().map(|s| s.label()),
            "exit_medium": if setup.substrate.is_some() { "substrate (opaque core)" } else { "ambient (a free flake)" },
            "materials": args.material,
            "theta_deg": args.theta_deg,
            "wavelengths_nm": args.wavelengths,
            "tables_cover_nm": [lo, if hi.is_finite() { json!(hi) } else { Value::Null }],
        },
        "units": {
            "wavelength_nm": "nm, in vacuum",
            "theta_deg": "degrees, incidence angle in the ambient",
            "thickness": "nm",
            "amplitudes": "complex amplitude coefficients (re, im), dimensionless",
            "powers": "R: power reflectance; T: power transmitted into the exit medium (absorbed by a substrate); A = 1 - R - T absorbed in the layers",
        },
        "conventions": "time dependence exp(-i omega t); index n + ik with k >= 0; p amplitudes with r_p = -r_s at normal incidence and (r_s, r_p) = (-1, +1) for a perfect conductor (the tmm package's); layers listed from the incidence side (physics.md section 13)",
        "columns": COLUMNS,
        "rows": rows.iter().enumerate().map(|(i, r)| values(r, thetas_deg[i % thetas_deg.len()]).to_vec()).collect::<Vec<_>>(),
    })
}

/// The table for the terminal (display rounding): powers only.
fn text(setup: &FilmSetup, rows: &[FilmRow], thetas_deg: &[f64]) -> String {
    let mut s = format!(
        "stack {} in an ambient of {}{}\n",
        setup.stack.label(),
        shortest(setup.ambient),
        setup.substrate.as_ref().map_or_else(
            || " (a free flake)".to_string(),
            |m| format!(" on {}", m.label())
        )
    );
    s.push_str("wavelength_nm  theta_deg      R_s      R_p      T_s      T_p\n");
    for (i, r) in rows.iter().enumerate() {
        let p = &r.response;
        let _ = writeln!(
            s,
            "{:>13}  {:>9}  {:>7}  {:>7}  {:>7}  {:>7}",
            shortest(r.wavelength_nm),
            shortest(thetas_deg[i % thetas_deg.len()]),
            fixed(p.r_s(), 4),
            fixed(p.r_p(), 4),
            fixed(p.t_s(), 4),
            fixed(p.t_p(), 4)
        );
    }
    s
}

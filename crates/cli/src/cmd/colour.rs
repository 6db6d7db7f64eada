//! `flakescatter colour`: CIE XYZ, CIELAB and L*C*h of reflectance spectra, and colour
//! differences from a reference (docs/cli.md "colour", physics.md §8).

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::Context;
use flakescatter::io::spectral::read_spectra;
use flakescatter::spectral::{ColourReport, SpectrumColour, colour_report};
use serde_json::{Value, json};

use crate::flags::ColourArgs;
use crate::output::{Kind, Plan, print, print_json};
use crate::parse::{deg, deg_num, fixed};
use crate::spectra::{colour_json, colour_units, hue_deg};
use crate::tables::num;

/// Colour of reflectance spectra: CIE XYZ, CIELAB and L*C*h under --illuminant and
/// --observer, with ASTM E308 weights at the spectrum's own sampling (no interpolation);
/// with --reference, the sample's ΔE*ab, ΔE*94 and CIEDE2000 from the reference.
///
/// A spectrum file is CSV `wavelength_nm,reflectance_factor` (reflectance factor =
/// π × BRDF, 1 for the perfect diffuser; at least 400–700 nm, steps of at most 20 nm,
/// within 360–830 nm). With the columns `theta_i_deg,aspecular_deg` it holds one
/// spectrum per geometry (as `model --multi-angle --spectra-out` writes) and the report
/// is per geometry, with the flop index where the geometries allow it. A table for
/// humans goes to stdout; --json gives `X, Y, Z, L, a, b, C, h` (and `delta_e_ab,
/// delta_e_94, delta_e_2000` with --reference).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The sample's spectrum (or spectra per geometry).
    #[arg(long, value_name = "FILE")]
    pub reflectance: PathBuf,
    /// The standard's spectrum (same geometries as the sample, if it has them).
    #[arg(long, value_name = "FILE")]
    pub reference: Option<PathBuf>,
    #[command(flatten)]
    pub colour: ColourArgs,
    /// Write one CSV row per spectrum here (`-` = stdout).
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Print a JSON summary on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let mut plan = Plan::new();
    plan.input("--reflectance", &args.reflectance);
    if let Some(r) = &args.reference {
        plan.input("--reference", r);
    }
    let out = plan.output("--out", args.out.as_deref(), Kind::Table);
    if args.json {
        plan.stdout("--json");
    } else if out.is_none() {
        plan.stdout("the report");
    }
    plan.check()?;
    let sample = read_spectra(&args.reflectance)
        .with_context(|| format!("reading --reflectance {}", args.reflectance.display()))?;
    let reference = match &args.reference {
        Some(p) => {
            Some(read_spectra(p).with_context(|| format!("reading --reference {}", p.display()))?)
        }
        None => None,
    };
    let report = colour_report(
        &sample,
        reference.as_ref(),
        args.colour.illuminant(),
        args.colour.observer(),
    )?;
    for w in &report.warnings {
        crate::output::warn(w);
    }
    if let Some(dest) = &out {
        let n = report.spectra.len();
        plan.write(
            dest,
            |w| Ok(w.write_all(csv(&report).as_bytes())?),
            Some(format!("{n} rows")),
        )?;
    }
    plan.finish()?;
    if args.json {
        print_json(&summary(&args, &report))
    } else if out.is_none() {
        print(&text(&args, &report))
    } else {
        Ok(())
    }
}

fn geometry_json(s: &SpectrumColour, v: &mut Value) {
    if let Some(g) = s.geometry {
        v["theta_i_deg"] = json!(deg_num(g.theta_i()));
        v["aspecular_deg"] = json!(deg_num(g.aspecular()));
    }
}

fn spectrum_json(s: &SpectrumColour) -> Value {
    let mut v = colour_json(&s.xyz, &s.lab);
    geometry_json(s, &mut v);
    if let Some((xyz, lab)) = &s.reference {
        v["reference"] = colour_json(xyz, lab);
    }
    if let Some(d) = &s.difference {
        v["delta_l"] = json!(d.delta_l);
        v["delta_a"] = json!(d.delta_a);
        v["delta_b"] = json!(d.delta_b);
        v["delta_e_ab"] = json!(d.delta_e_ab);
        v["delta_e_94"] = json!(d.delta_e_94);
        v["delta_e_2000"] = json!(d.delta_e_2000);
    }
    v
}

fn summary(args: &Args, r: &ColourReport) -> Value {
    let mut v = json!({
        "version": env!("CARGO_PKG_VERSION"),
        "command": "colour",
        "inputs": {
            "reflectance": args.reflectance.display().to_string(),
            "reference": args.reference.as_ref().map(|p| p.display().to_string()),
            "colorimetry": args.colour.echo(),
        },
        "units": colour_units(),
        "delta_e": "delta_e_ab: CIE 1976; delta_e_94: CIE 1994, graphic-arts constants, weights from the reference's chroma; delta_e_2000: CIEDE2000 (kL = kC = kH = 1); delta_l/a/b: sample - reference",
        "warnings": r.warnings,
    });
    let geometric = r.spectra.iter().any(|s| s.geometry.is_some());
    if geometric {
        v["geometries"] = Value::Array(r.spectra.iter().map(spectrum_json).collect());
        v["flop_index"] = json!(r.flop_index);
        if args.reference.is_some() {
            v["reference_flop_index"] = json!(r.reference_flop_index);
        }
    } else if let (Some(s), Value::Object(into)) = (r.spectra.first(), &mut v)
        && let Value::Object(from) = spectrum_json(s)
    {
        into.extend(from);
    }
    v
}

fn csv(r: &ColourReport) -> String {
    let geometric = r.spectra.iter().any(|s| s.geometry.is_some());
    let with_ref = r.spectra.iter().any(|s| s.difference.is_some());
    let mut out = String::new();
    if geometric {
        out.push_str("theta_i_deg,aspecular_deg,");
    }
    out.push_str("X,Y,Z,L,a,b,C,h_deg");
    if with_ref {
        out.push_str(",reference_L,reference_a,reference_b,delta_l,delta_a,delta_b,delta_e_ab,delta_e_94,delta_e_2000");
    }
    out.push('\n');
    for s in &r.spectra {
        if let Some(g) = s.geometry {
            let _ = write!(out, "{},{},", deg(g.theta_i()), deg(g.aspecular()));
        }
        let _ = write!(
            out,
            "{},{},{},{},{},{},{},{}",
            num(s.xyz.x),
            num(s.xyz.y),
            num(s.xyz.z),
            num(s.lab.l),
            num(s.lab.a),
            num(s.lab.b),
            num(s.lab.chroma()),
            num(hue_deg(&s.lab))
        );
        if let (Some((_, rl)), Some(d)) = (&s.reference, &s.difference) {
            let _ = write!(
                out,
                ",{},{},{},{},{},{},{},{},{}",
                num(rl.l),
                num(rl.a),
                num(rl.b),
                num(d.delta_l),
                num(d.delta_a),
                num(d.delta_b),
                num(d.delta_e_ab),
                num(d.delta_e_94),
                num(d.delta_e_2000)
            );
        }
        out.push('\n');
    }
    out
}

/// The report for the terminal (display rounding).
fn text(args: &Args, r: &ColourReport) -> String {
    let c = args.colour.echo();
    let mut s = format!(
        "{} under {} / {}° observer",
        args.reflectance.display(),
        c["illuminant"].as_str().unwrap_or(""),
        c["observer_deg"]
    );
    if let Some(p) = &args.reference {
        let _ = write!(s, ", against {}", p.display());
    }
    s.push('\n');
    let geometric = r.spectra.iter().any(|s| s.geometry.is_some());
    if geometric {
        s.push_str("theta_i  aspecular ");
    }
    s.push_str("      L*       a*       b*       C*    h_deg");
    let with_ref = r.spectra.iter().any(|x| x.difference.is_some());
    if with_ref {
        s.push_str("      dL*    dE*ab    dE*94   dE2000");
    }
    s.push('\n');
    for x in &r.spectra {
        if let Some(g) = x.geometry {
            let _ = write!(s, "{:<8} {:<9} ", deg(g.theta_i()), deg(g.aspecular()));
        }
        let _ = write!(
            s,
            "{:>8} {:>8} {:>8} {:>8} {:>8}",
            fixed(x.lab.l, 2),
            fixed(x.lab.a, 2),
            fixed(x.lab.b, 2),
            fixed(x.lab.chroma(), 2),
            fixed(hue_deg(&x.lab), 1)
        );
        if let Some(d) = &x.difference {
            let _ = write!(
                s,
                " {:>8} {:>8} {:>8} {:>8}",
                fixed(d.delta_l, 2),
                fixed(d.delta_e_ab, 2),
                fixed(d.delta_e_94, 2),
                fixed(d.delta_e_2000, 2)
            );
        }
        s.push('\n');
    }
    if geometric {
        let f = |x: Option<f64>| x.map_or_else(|| "not defined".to_string(), |v| fixed(v, 2));
        let _ = write!(s, "flop index {}", f(r.flop_index));
        if args.reference.is_some() {
            let _ = write!(s, " (reference {})", f(r.reference_flop_index));
        }
        s.push('\n');
    }
    s
}

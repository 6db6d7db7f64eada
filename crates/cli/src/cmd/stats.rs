//! `flakescatter stats`: area-weighted flake orientation histogram and Gaussian width fit.

use std::path::PathBuf;

use anyhow::{Context, bail};
use flakescatter::io::flakes::{read_flakes, write_histogram};
use flakescatter::stats::fit::fit_gaussian_ml;
use flakescatter::stats::histogram::AreaHistogram;

use crate::flags::SegmentArgs;
use crate::maps::segment_file;
use crate::output::{Kind, Plan, print_json};
use crate::tables::write_flakes;

/// Orientation statistics of a flake table (--flakes) or of the flakes segmented from a
/// height map (--map, as `flakescatter segment`): writes the area-weighted histogram of the
/// flake polar angle θn (CSV `theta_lo_deg, theta_hi_deg, area_fraction, p_per_rad,
/// p_tilde`) and fits a Gaussian p̃ by maximum likelihood.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Flake table (CSV with header): columns `nx, ny, nz, area_um2`, or
    /// `theta_x_deg, theta_y_deg, area_um2`, or the endpoint columns
    /// `x1_um, z1_um, x2_um, z2_um, y1_um, zy1_um, y2_um, zy2_um` (paper eq. 6).
    #[arg(
        long,
        value_name = "FILE",
        required_unless_present = "map",
        conflicts_with = "map"
    )]
    pub flakes: Option<PathBuf>,
    /// Height map to segment into flakes first (as `flakescatter segment MAP`); the
    /// histogram then uses each flake's fitted normal and true area.
    #[arg(long, value_name = "MAP")]
    pub map: Option<PathBuf>,
    /// Map input and segmentation flags (with --map).
    #[command(flatten)]
    pub segment: SegmentArgs,
    /// With --map: also write the flake table (as `segment --out`) here.
    #[arg(long = "flakes-out", value_name = "FILE", requires = "map")]
    pub flakes_out: Option<PathBuf>,
    /// Histogram bin width in degrees, in [0.001, 45].
    #[arg(
        long,
        value_name = "DEG",
        default_value_t = 1.0,
        allow_negative_numbers = true
    )]
    pub bin: f64,
    /// Write the histogram CSV here (`-` = stdout). Without `--out` and `--json` the
    /// histogram goes to stdout.
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Print a JSON summary on stdout: fitted `hwhm_deg`, `hwhm_ci95_deg`, `flakes`,
    /// `total_area_um2`, bin width, input file and version.
    #[arg(long)]
    pub json: bool,
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let mut plan = Plan::new();
    if let Some(f) = &args.flakes {
        plan.input("--flakes", f);
    }
    if let Some(m) = &args.map {
        plan.input("--map", m);
        args.segment.inputs(&mut plan);
    }
    let table = plan.table("--out", args.out.as_deref(), args.json);
    let flakes_out = plan.output("--flakes-out", args.flakes_out.as_deref(), Kind::Table);
    if args.json {
        plan.stdout("--json");
    }
    // At least 0.001°: 90 000 bins over [0, 90°] at most.
    if !(args.bin.is_finite() && (0.001..=45.0).contains(&args.bin)) {
        bail!(
            "--bin {}: the bin width must be in [0.001, 45] degrees",
            args.bin
        );
    }
    if args.map.is_some() {
        args.segment.params()?;
        args.segment.calibration.read_options()?;
    }
    plan.check()?;
    let (flakes, source, column_set) = match (&args.flakes, &args.map) {
        (Some(path), _) => {
            let table = read_flakes(path)
                .with_context(|| format!("reading --flakes {}", path.display()))?;
            (table.flakes, path.clone(), table.column_set.name())
        }
        (None, Some(map)) => {
            let (_, seg) = segment_file(map, &args.segment)?;
            if seg.flakes.is_empty() {
                bail!(
                    "no flake found in --map {}: nothing to histogram",
                    map.display()
                );
            }
            if let Some(dest) = &flakes_out {
                plan.write(
                    dest,
                    |w| write_flakes(w, &seg.flakes),
                    Some(format!("{} flakes", seg.flakes.len())),
                )?;
            }
            let flakes = seg.flakes.iter().map(|f| f.to_flake()).collect();
            (flakes, map.clone(), "segmented map")
        }
        (None, None) => bail!("give --flakes FILE or --map MAP"),
    };
    let hist = AreaHistogram::from_flakes(&flakes, args.bin.to_radians())
        .with_context(|| format!("histogram of {}", source.display()))?;
    let samples: Vec<(f64, f64)> = flakes.iter().map(|f| (f.theta_n(), f.area_um2)).collect();
    let fit = fit_gaussian_ml(&samples)
        .with_context(|| format!("fitting a Gaussian to {}", source.display()));
    let fit = if args.json { Some(fit?) } else { None };
    if let Some(dest) = &table {
        let name = dest.name();
        plan.write(
            dest,
            |w| Ok(write_histogram(w, &name, &hist)?),
            Some(format!("{} bins", hist.bins().len())),
        )?;
    }
    plan.finish()?;
    if let Some(fit) = fit {
        let (lo, hi) = fit.hwhm_ci95();
        let finite = |x: f64| if x.is_finite() { Some(x) } else { None };
        print_json(&serde_json::json!({
            "version": env!("CARGO_PKG_VERSION"),
            "input": {
                "flakes_file": args.flakes.as_ref().map(|p| p.display().to_string()),
                "map": args.map.as_ref().map(|p| p.display().to_string()),
                "intensity": args.segment.intensity.as_ref().map(|p| p.display().to_string()),
                "cutoff": args.segment.cutoff,
                "column_set": column_set,
                "bin_deg": args.bin,
            },
            "flakes": flakes.len(),
            "total_area_um2": hist.total_area_um2(),
            "fit": "maximum likelihood, Gaussian p_tilde ∝ exp(-θ²/(2 sigma²)) on [0, 90°), area-weighted",
            "hwhm_deg": fit.hwhm().to_degrees(),
            "hwhm_ci95_deg": [finite(lo.to_degrees()), finite(hi.to_degrees())],
            "hwhm_ci95_method": fit.ci_method.describe(),
            "sigma_deg": fit.sigma.to_degrees(),
            "effective_flakes": fit.effective_n,
            "histogram_bins": hist.bins().len(),
            "histogram_file": args.out.as_ref().map(|p| p.display().to_string()),
        }))?;
    }
    Ok(())
}

//! `flakescatter stack STACK --height-out H`: from a confocal z-stack (multi-page TIFF) to
//! the height, intensity and peak-width maps, by sub-step localisation of each pixel's
//! axial peak ([`flakescatter::stack::localise_stack`], docs/physics.md §9).

use std::path::{Path, PathBuf};

use anyhow::bail;
use flakescatter::confocal::{
    MAX_HALF_WINDOW, MinSignal, PeakMethod, PeakOptions, SignalThreshold,
};
use flakescatter::io::stack::{ReadStackError, Source, StackError, StackInfo, StackOptions};
use flakescatter::io::{MapFormat, write_intensity, write_map};
use flakescatter::stack::{StackMaps, StackPipelineError, localise_stack};
use flakescatter::stats::heightmap::HeightMap;
use serde_json::{Value, json};

use crate::cmd::synth::FirstPage;
use crate::output::{Kind, Plan, note, print_json, warn};
use crate::parse::pair;

/// The axial-peak estimator (docs/physics.md §9).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum PeakKind {
    /// The brightest slice, as microscope software reports it: heights quantised to the
    /// z step (rms error step/√12), terraces with exactly vertical normals.
    Argmax,
    /// Least-squares parabola through the slices within the peak.
    Parabolic,
    /// Parabola through the log intensities: exact for a Gaussian response (default).
    Gaussian,
    /// Thresholded centroid of the slices within the peak.
    Centroid,
}

impl PeakKind {
    fn method(self) -> PeakMethod {
        match self {
            Self::Argmax => PeakMethod::Argmax,
            Self::Parabolic => PeakMethod::Parabolic,
            Self::Gaussian => PeakMethod::Gaussian,
            Self::Centroid => PeakMethod::Centroid,
        }
    }
}

/// Turn a confocal z-stack into a height map: per pixel the height of its axial intensity
/// peak, localised between slices (default: a Gaussian fit through the three samples
/// around the maximum; docs/physics.md §9 gives each estimator's bias).
///
/// Reads multi-page TIFF stacks (8/16-bit unsigned or 32-bit float, one page per slice)
/// with the voxel size of ImageJ/Fiji, OME-TIFF or Zeiss LSM metadata; --pixel-um and
/// --z-step-um override it and are needed when the file has none. Slices are read one at
/// a time. Heights are in µm above the lowest slice; pixels whose brightest sample is
/// below --min-signal or on the first or last slice are invalid.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The z-stack (multi-page TIFF: ImageJ, OME-TIFF, Zeiss LSM or plain TIFF).
    #[arg(value_name = "STACK")]
    pub stack: PathBuf,
    /// Height map output (µm above the lowest slice): `.x3p` (ISO 25178-72) or `.txt`.
    #[arg(long, value_name = "MAP")]
    pub height_out: PathBuf,
    /// Intensity map output (brightest sample per pixel, full scale 1 for integer
    /// stacks): `.x3p` or `.txt`; mask the height map with it (`--intensity`, `--cutoff`).
    #[arg(long, value_name = "MAP")]
    pub intensity_out: Option<PathBuf>,
    /// Quality map output: the full width at half maximum of each pixel's axial peak,
    /// µm (`.x3p` or `.txt`); invalid where the height is or the width is undetermined.
    #[arg(long, value_name = "MAP")]
    pub quality_out: Option<PathBuf>,
    /// Peak estimator.
    #[arg(long, value_enum, default_value = "gaussian")]
    pub peak: PeakKind,
    /// Pixels whose brightest sample is below this are invalid (sample units: full
    /// scale 1 for 8/16-bit stacks, the stored value for float stacks). Default:
    /// estimated from the stack's own noise, dark level + k × noise sd so that one
    /// background pixel in a thousand passes (docs/physics.md §9); the value used is
    /// printed and in the JSON.
    #[arg(long, value_name = "X", allow_negative_numbers = true)]
    pub min_signal: Option<f64>,
    /// The slices within the peak are those at or above this fraction of the maximum,
    /// in (0, 1] (also the centroid's threshold).
    #[arg(
        long,
        value_name = "F",
        default_value_t = 0.5,
        allow_negative_numbers = true
    )]
    pub fraction: f64,
    /// Slices kept on each side of the running maximum, 1 to 32: must cover the slices
    /// within the peak (FWHM / (2 · z step) + 1).
    #[arg(long, value_name = "N", default_value_t = 3, value_parser = crate::parse::count_in::<1, MAX_HALF_WINDOW>)]
    pub half_window: usize,
    /// Pixel pitch in µm, `D` or `DX,DY` (overrides the file's).
    #[arg(long, value_name = "DX[,DY]", allow_hyphen_values = true)]
    pub pixel_um: Option<String>,
    /// Distance between slices in µm (overrides the file's).
    #[arg(long, value_name = "DZ", allow_negative_numbers = true)]
    pub z_step_um: Option<f64>,
    /// Which end page 0 is (overrides the file; default: the metadata's order, else
    /// bottom: page 0 is the lowest slice, deepest in the coating).
    #[arg(long, value_enum)]
    pub first_page: Option<FirstPage>,
    /// Print a JSON summary on stdout: the stack (size, voxel sizes and where they came
    /// from, page order), the estimator, counts of valid and invalid pixels.
    #[arg(long)]
    pub json: bool,
}

/// The reading options from the flags, checked.
fn read_options(args: &Args) -> anyhow::Result<StackOptions> {
    let pixel_um = match &args.pixel_um {
        None => None,
        Some(text) => {
            let (dx, dy) = pair("--pixel-um", text, "a length in µm", |p| {
                p.parse::<f64>().ok()
            })?;
            for v in [dx, dy] {
                if !(v.is_finite() && v > 0.0) {
                    bail!("--pixel-um {text}: the pitch must be a finite length > 0 µm");
                }
            }
            Some((dx, dy))
        }
    };
    if let Some(dz) = args.z_step_um
        && !(dz.is_finite() && dz > 0.0)
    {
        bail!("--z-step-um {dz}: the distance between slices must be a finite length > 0 µm");
    }
    Ok(StackOptions {
        pixel_um,
        z_step_um: args.z_step_um,
        first_page: args.first_page.map(FirstPage::order),
    })
}

/// The estimator options from the flags, checked.
fn peak_options(args: &Args) -> anyhow::Result<PeakOptions> {
    if !(args.fraction > 0.0 && args.fraction <= 1.0) {
        bail!(
            "--fraction {}: expected a fraction in (0, 1]",
            args.fraction
        );
    }
    if let Some(m) = args.min_signal
        && !m.is_finite()
    {
        bail!("--min-signal {m}: expected a finite number");
    }
    if !(1..=MAX_HALF_WINDOW).contains(&args.half_window) {
        bail!(
            "--half-window {}: expected 1 to {MAX_HALF_WINDOW} slices",
            args.half_window
        );
    }
    Ok(PeakOptions {
        method: args.peak.method(),
        fraction: args.fraction,
        min_signal: args
            .min_signal
            .map_or(MinSignal::Estimated, MinSignal::Level),
        half_window: args.half_window,
        saturation: None,
    })
}

/// A stack error in the user's terms: a missing voxel size names the flag that gives it.
fn explain(err: StackPipelineError) -> anyhow::Error {
    match err {
        StackPipelineError::Read(ReadStackError::Format { path, error }) => {
            let name = path.display();
            match error {
                StackError::MissingPixelSize { note, .. } => anyhow::anyhow!(
                    "stack {name}: the file gives no pixel size ({note}); give it with --pixel-um DX[,DY] (µm)"
                ),
                StackError::MissingZStep { format } => anyhow::anyhow!(
                    "stack {name}: the {format} file gives no z step; give the distance between slices with --z-step-um DZ (µm)"
                ),
                error => anyhow::anyhow!("stack {name}: {error}"),
            }
        }
        StackPipelineError::Read(e) => anyhow::Error::from(e),
        e => anyhow::anyhow!("{e}"),
    }
}

/// The map format of an output path (the output layer allows only these two).
fn format_of(path: &Path) -> MapFormat {
    if path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("txt"))
    {
        MapFormat::Text
    } else {
        MapFormat::X3p
    }
}

/// Writes one map through the output layer.
fn write(plan: &mut Plan, map: &HeightMap, path: &Path, intensity: bool) -> anyhow::Result<()> {
    let format = format_of(path);
    let detail = format!("{} x {}", map.nx(), map.ny());
    plan.write_via_path(
        path,
        |tmp| {
            if intensity {
                write_intensity(map, tmp, format)?;
            } else {
                write_map(map, tmp, format)?;
            }
            Ok(())
        },
        Some(detail),
    )
}

/// Runs the subcommand.
pub fn run(args: Args) -> anyhow::Result<()> {
    let mut plan = Plan::new();
    plan.input("STACK", &args.stack);
    plan.output("--height-out", Some(&args.height_out), Kind::Map);
    plan.output("--intensity-out", args.intensity_out.as_deref(), Kind::Map);
    plan.output("--quality-out", args.quality_out.as_deref(), Kind::Map);
    if args.json {
        plan.stdout("--json");
    }
    let read = read_options(&args)?;
    let peak = peak_options(&args)?;
    plan.check()?;

    let bar = crate::output::progress::bar("localising {bar:40} {pos}/{len} slices {eta}", true);
    let progress = |done: u64, total: u64| crate::output::progress::show(bar.as_ref(), done, total);
    let maps = localise_stack(&args.stack, &read, &peak, &progress).map_err(explain)?;
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    let r = &maps.report;
    if r.valid == 0 {
        bail!(
            "stack {}: no pixel has a usable peak ({} below --min-signal {}, {} brightest on the first slice, {} on the last, {} not fittable); nothing written",
            args.stack.display(),
            r.below_signal,
            maps.threshold.level,
            r.first_slice,
            r.last_slice,
            r.not_fittable
        );
    }
    note(&format!(
        "background threshold (--min-signal) {}: {}",
        maps.threshold.level, maps.threshold
    ));
    let warnings = warnings(&maps, args.half_window);
    for w in &warnings {
        warn(w);
    }
    write(&mut plan, &maps.height, &args.height_out, false)?;
    if let Some(p) = &args.intensity_out {
        write(&mut plan, &maps.intensity, p, true)?;
    }
    if let Some(p) = &args.quality_out {
        write(&mut plan, &maps.width, p, false)?;
    }
    plan.finish()?;
    if args.json {
        let mut s = summary(&args, &maps);
        s["warnings"] = json!(warnings);
        print_json(&s)?;
    }
    Ok(())
}

/// What the counts say that a user should know.
fn warnings(maps: &StackMaps, half_window: usize) -> Vec<String> {
    let r = &maps.report;
    let mut out = Vec::new();
    if r.window_limited > 0 {
        out.push(format!(
            "{} of {} valid pixels have peaks wider than the ±{half_window} slices kept around the maximum; their fit uses a truncated peak (raise --half-window)",
            r.window_limited, r.valid
        ));
    }
    if r.saturated > 0 {
        out.push(format!(
            "{} pixels reach full scale (saturated): their peaks are clipped and their heights less certain",
            r.saturated
        ));
    }
    let edge = r.first_slice + r.last_slice;
    if edge > 0 {
        out.push(format!(
            "{edge} pixels are brightest on the first or last slice ({} first, {} last): their surface may lie outside the stack; they are invalid",
            r.first_slice, r.last_slice
        ));
    }
    out
}

fn source(s: &Source) -> String {
    s.to_string()
}

/// The stack as read: size, voxel sizes and page order with where each came from.
fn stack_json(info: &StackInfo) -> Value {
    json!({
        "format": info.format.name(),
        "nx": info.nx,
        "ny": info.ny,
        "slices": info.nz,
        "sample": info.sample.name(),
        "full_scale": info.full_scale.value,
        "pixel_um": info.pixel_um.as_ref().map(|p| json!([p.value.0, p.value.1])),
        "pixel_source": info.pixel_um.as_ref().map(|p| source(&p.source)),
        "z_step_um": info.z_step_um.as_ref().map(|z| z.value),
        "z_step_source": info.z_step_um.as_ref().map(|z| source(&z.source)),
        "first_page": info.first_page.value.name(),
        "first_page_source": source(&info.first_page.source),
        "pages": info.pages,
        "skipped_pages": info.skipped_pages,
    })
}

/// The background threshold used: the level, `given` or `estimated`, and the estimate.
pub fn threshold_json(t: &SignalThreshold) -> Value {
    json!({
        "min_signal": t.level,
        "source": match (t.estimate.is_some(), t.too_short) {
            (true, _) => "estimated",
            (false, true) => "not estimated (stack too short)",
            (false, false) => "given",
        },
        "how": t.to_string(),
        "estimate": t.estimate.map(|e| json!({
            "dark_level": e.baseline,
            "noise_sd": e.noise_sd,
            "k": e.k,
            "background_pass_probability": e.false_valid,
            "pixels_sampled": e.pixels,
            "slices": e.slices,
        })),
    })
}

/// The `--json` summary.
fn summary(args: &Args, maps: &StackMaps) -> Value {
    let r = &maps.report;
    let show = |p: &Option<PathBuf>| p.as_ref().map(|p| p.display().to_string());
    let h = maps.height.summary();
    let w = maps.width.summary();
    json!({
        "version": env!("CARGO_PKG_VERSION"),
        "command": "stack",
        "inputs": {
            "stack": args.stack.display().to_string(),
            "peak": maps.peak.method.name(),
            "fraction": maps.peak.fraction,
            "min_signal": args.min_signal,
            "half_window": maps.peak.half_window,
            "pixel_um": args.pixel_um,
            "z_step_um": args.z_step_um,
            "first_page": args.first_page.map(|f| f.order().name()),
        },
        "stack": stack_json(&maps.info),
        "background": threshold_json(&maps.threshold),
        "counts": {
            "pixels": maps.height.len(),
            "valid": r.valid,
            "below_signal": r.below_signal,
            "first_slice": r.first_slice,
            "last_slice": r.last_slice,
            "not_fittable": r.not_fittable,
            "window_limited": r.window_limited,
            "saturated": r.saturated,
        },
        "height_um": h.map(|h| json!({"min": h.min, "max": h.max, "mean": h.mean, "rms": h.rms})),
        "peak_fwhm_um": w.map(|w| json!({"min": w.min, "max": w.max, "mean": w.mean})),
        "height_file": args.height_out.display().to_string(),
        "intensity_file": show(&args.intensity_out),
        "quality_file": show(&args.quality_out),
        "units": {
            "height_um": "µm above the lowest slice (valid pixels): min, max, mean, rms about the mean",
            "peak_fwhm_um": "µm, full width at half maximum of the axial peaks (the quality map)",
            "intensity": "brightest sample of each pixel, full scale 1 for 8/16-bit stacks",
            "pixel_um": "µm, (dx, dy)",
            "z_step_um": "µm, distance between slices",
            "background": "min_signal: the threshold used (sample units, full scale 1 for 8/16-bit stacks), given by --min-signal or estimated as dark_level + k × noise_sd (median sample; 1.4826 × MAD of successive-slice differences / √2; k so that a background pixel passes with background_pass_probability)",
            "counts": "pixels: valid, or invalid because their brightest sample is below min_signal, on the first or last slice, or the fit is impossible; window_limited: valid pixels whose peak reached the edge of the kept slices; saturated: pixels at full scale",
        },
    })
}

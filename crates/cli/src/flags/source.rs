//! Where orientations and maps come from: the orientation source of `model` and
//! `compare`, map calibration, segmentation.

use std::path::PathBuf;

use anyhow::{Context, bail};
use flakescatter::io::flakes::read_histogram;
use flakescatter::io::{ChannelSelector, DecimalMark, ReadOptions, ZUnit};
use flakescatter::stats::segment::SegmentParams;
use flakescatter::stats::{GaussianWidth, Orientation};
use serde_json::{Value, json};

use crate::output::Plan;

/// Where the flake orientation distribution comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum OrientationKind {
    /// A Gaussian p~(θn) ∝ exp(-θn²/(2s²)) with one of --hwhm, --sigma, --rms-tilt.
    Gaussian,
    /// A measured histogram (`--distribution FILE`, the CSV written by `stats`).
    Table,
    /// Trowbridge–Reitz (GGX) slopes of scale --alpha (heavy-tailed; physics.md §3).
    TrowbridgeReitz,
    /// Pearson VII (Student-t) slopes of scale --alpha and shape --shape (> 0.5; 1 is
    /// Trowbridge–Reitz, large is Beckmann).
    PearsonVii,
}

/// Where the orientation distribution comes from (`model`, `compare`).
#[derive(Debug, Clone, clap::Args)]
#[command(group = clap::ArgGroup::new("width").multiple(false).args(["hwhm", "sigma", "rms_tilt"]))]
pub struct OrientationArgs {
    /// Orientation source.
    #[arg(long, value_enum, default_value = "gaussian")]
    pub orientation: OrientationKind,
    /// Gaussian half-width at half-maximum of p~, degrees, in (0, 90) (the paper's w).
    /// Default 6 when no width is given.
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    pub hwhm: Option<f64>,
    /// Gaussian standard deviation s of each tilt component, degrees, in (0, 90).
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    pub sigma: Option<f64>,
    /// Gaussian rms tilt σt = s·√2 (p~ ∝ exp(-θ²/σt²)), degrees, in (0, 90).
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    pub rms_tilt: Option<f64>,
    /// Histogram CSV (`theta_lo_deg, theta_hi_deg, area_fraction`, as written by
    /// `flakescatter stats` or `fit --nonparametric`) for `--orientation table`.
    #[arg(long, value_name = "FILE")]
    pub distribution: Option<PathBuf>,
    /// Slope scale (tan of an angle, > 0) of `--orientation trowbridge-reitz` or
    /// `pearson-vii`.
    #[arg(long, value_name = "A", allow_negative_numbers = true)]
    pub alpha: Option<f64>,
    /// Shape of `--orientation pearson-vii`, in [0.55, 1e4].
    #[arg(long, value_name = "G", allow_negative_numbers = true)]
    pub shape: Option<f64>,
}

/// Validate a width flag (degrees) and convert it: finite, at least the library's
/// smallest Gaussian width, below 90°.
pub fn width(flag: &str, deg: f64) -> anyhow::Result<f64> {
    let min_deg = flakescatter::stats::distribution::MIN_GAUSSIAN_WIDTH.to_degrees();
    if !(deg.is_finite() && deg >= min_deg && deg < 90.0) {
        bail!("{flag} {deg}: the width must be at least {min_deg:.1e} and below 90 degrees");
    }
    Ok(deg.to_radians())
}

impl OrientationArgs {
    /// Registers `--distribution` as an input.
    pub fn inputs(&self, plan: &mut Plan) {
        if let Some(p) = &self.distribution {
            plan.input("--distribution", p);
        }
    }

    /// Checks the flags without reading the histogram.
    pub fn validate(&self) -> anyhow::Result<()> {
        let heavy = matches!(
            self.orientation,
            OrientationKind::TrowbridgeReitz | OrientationKind::PearsonVii
        );
        if !heavy && self.alpha.is_some() {
            bail!("--alpha needs --orientation trowbridge-reitz or pearson-vii");
        }
        if self.orientation != OrientationKind::PearsonVii && self.shape.is_some() {
            bail!("--shape needs --orientation pearson-vii");
        }
        match self.orientation {
            OrientationKind::TrowbridgeReitz | OrientationKind::PearsonVii => {
                if self.hwhm.is_some() || self.sigma.is_some() || self.rms_tilt.is_some() {
                    bail!("--hwhm/--sigma/--rms-tilt need --orientation gaussian");
                }
                if self.distribution.is_some() {
                    bail!("--distribution needs --orientation table");
                }
                if self.alpha.is_none() {
                    bail!("--orientation trowbridge-reitz/pearson-vii needs --alpha");
                }
                if self.orientation == OrientationKind::PearsonVii && self.shape.is_none() {
                    bail!("--orientation pearson-vii needs --shape");
                }
            }
            OrientationKind::Gaussian => {
                if self.distribution.is_some() {
                    bail!("--distribution needs --orientation table");
                }
                for (flag, v) in [
                    ("--hwhm", self.hwhm),
                    ("--sigma", self.sigma),
                    ("--rms-tilt", self.rms_tilt),
                ] {
                    if let Some(v) = v {
                        width(flag, v)?;
                    }
                }
            }
            OrientationKind::Table => {
                if self.hwhm.is_some() || self.sigma.is_some() || self.rms_tilt.is_some() {
                    bail!("--hwhm/--sigma/--rms-tilt need --orientation gaussian");
                }
                if self.distribution.is_none() {
                    bail!("--orientation table needs --distribution FILE");
                }
            }
        }
        Ok(())
    }

    /// The orientation distribution the flags ask for, with its JSON echo.
    pub fn orientation(&self) -> anyhow::Result<(Orientation, Value)> {
        self.validate()?;
        if let Some(alpha) = self.alpha {
            let shape = self.shape.unwrap_or(1.0);
            let o = Orientation::pearson_vii(alpha, shape)
                .with_context(|| format!("--alpha {alpha} --shape {shape}"))?;
            let echo = if self.orientation == OrientationKind::TrowbridgeReitz {
                json!({"kind": "trowbridge-reitz", "alpha": alpha})
            } else {
                json!({"kind": "pearson-vii", "alpha": alpha, "shape": shape})
            };
            return Ok((o, echo));
        }
        if let Some(path) = &self.distribution {
            let t = read_histogram(path)
                .with_context(|| format!("reading --distribution {}", path.display()))?;
            let o = Orientation::tabulated(t.edges_rad, t.area_fractions)
                .with_context(|| format!("--distribution {}", path.display()))?;
            return Ok((
                o,
                json!({"kind": "table", "file": path.display().to_string()}),
            ));
        }
        let (w, echo) = match (self.hwhm, self.sigma, self.rms_tilt) {
            (Some(h), _, _) => (
                GaussianWidth::Hwhm(width("--hwhm", h)?),
                json!({"hwhm_deg": h}),
            ),
            (_, Some(s), _) => (
                GaussianWidth::Sigma(width("--sigma", s)?),
                json!({"sigma_deg": s}),
            ),
            (_, _, Some(r)) => (
                GaussianWidth::RmsTilt(width("--rms-tilt", r)?),
                json!({"rms_tilt_deg": r}),
            ),
            _ => (
                GaussianWidth::Hwhm(6f64.to_radians()),
                json!({"hwhm_deg": 6.0}),
            ),
        };
        let o = Orientation::gaussian(w).context("Gaussian width")?;
        Ok((o, json!({"kind": "gaussian", "width": echo})))
    }
}

/// Calibration flags shared by every subcommand that reads height maps.
#[derive(Debug, Clone, clap::Args)]
pub struct MapArgs {
    /// Pixel pitch in µm, `DX` or `DX,DY` (x along columns, y along rows). Required for
    /// plain-text matrices without a size header; overrides the file's pitch otherwise.
    #[arg(long = "pixel-um", value_name = "DX[,DY]", allow_hyphen_values = true)]
    pub pixel_um: Option<String>,
    /// Unit of the heights in plain-text matrices without a unit header: `um`, `nm` or
    /// `m`. Overrides the file's unit; refused for X3P and SDF height maps, which are
    /// calibrated, and for intensity images, which have no height unit.
    #[arg(long = "z-unit", value_name = "UNIT")]
    pub z_unit: Option<String>,
    /// Read X3P files whose MD5 checksums do not match; the mismatch is reported in the
    /// metadata (`x3p.md5_mismatch`) instead of failing.
    #[arg(long)]
    pub accept_md5_mismatch: bool,
    /// Plain-text matrices write decimals with a comma (`1,5`, German exports); values
    /// are then separated by whitespace or `;`. Without this flag (or --decimal-point)
    /// the decimal mark is detected, and a file that allows both readings is refused.
    #[arg(long, conflicts_with = "decimal_point")]
    pub decimal_comma: bool,
    /// Plain-text matrices write decimals with a point; commas separate values.
    #[arg(long)]
    pub decimal_point: bool,
    /// Which channel of the map file holds the heights: its 0-based index as `info`
    /// lists the channels (GWY data fields, PLU layers, OPD arrays, SUR objects, ...) or
    /// its name (matched exactly, else ignoring case when that is unique). Default: the
    /// first. A channel the file does not have is refused with the list of its channels.
    #[arg(long, value_name = "NAME|INDEX")]
    pub channel: Option<String>,
}

impl MapArgs {
    /// Parses the flags into reader options; errors name the flag.
    pub fn read_options(&self) -> anyhow::Result<ReadOptions> {
        let pixel_um = match &self.pixel_um {
            None => None,
            Some(s) => {
                let (x, y) = crate::parse::pair("--pixel-um", s, "a number (µm)", |p| {
                    p.parse::<f64>().ok()
                })?;
                if !(x.is_finite() && x > 0.0 && y.is_finite() && y > 0.0) {
                    bail!("--pixel-um {s}: the pitch must be finite and > 0 µm");
                }
                Some((x, y))
            }
        };
        let z_unit = match &self.z_unit {
            None => None,
            Some(s) => Some(
                s.parse::<ZUnit>()
                    .with_context(|| format!("--z-unit {s}"))?,
            ),
        };
        Ok(ReadOptions {
            pixel_um,
            z_unit,
            accept_md5_mismatch: self.accept_md5_mismatch,
            decimal: if self.decimal_comma {
                DecimalMark::Comma
            } else if self.decimal_point {
                DecimalMark::Point
            } else {
                DecimalMark::Auto
            },
            // Channels are chosen per file (a name may have another index in each):
            // see `channel`, resolved when each file is read.
            channel: None,
            // `convert` and `info` read maps as their files declare them (their own
            // option); every other command reads heights.
            as_stored: false,
        })
    }

    /// The `--channel` choice; errors name the flag.
    pub fn channel(&self) -> anyhow::Result<Option<ChannelSelector>> {
        selector("--channel", self.channel.as_deref())
    }
}

/// Parses a `NAME|INDEX` flag value (all digits: an index, else a name).
pub fn selector(flag: &str, value: Option<&str>) -> anyhow::Result<Option<ChannelSelector>> {
    value
        .map(|v| {
            v.parse::<ChannelSelector>()
                .with_context(|| format!("{flag} {v:?}"))
        })
        .transpose()
}

/// Segmentation flags of `segment` and `stats --map` (the map inputs are
/// [`crate::maps::MapInputArgs`]).
#[derive(Debug, Clone, clap::Args)]
pub struct SegmentArgs {
    /// z quantisation step of the instrument, µm (0 = none); sets the height-jump and
    /// plane-residual thresholds.
    #[arg(
        long = "z-step-um",
        value_name = "UM",
        default_value_t = 0.3,
        allow_negative_numbers = true
    )]
    pub z_step_um: f64,
    /// Height noise standard deviation of the instrument, µm.
    #[arg(
        long = "noise-um",
        value_name = "UM",
        default_value_t = 0.03,
        allow_negative_numbers = true
    )]
    pub noise_um: f64,
    /// Smallest flake kept, pixels (>= 3).
    #[arg(long = "min-pixels", value_name = "N", default_value_t = 100, value_parser = crate::parse::count_in::<3, { usize::MAX }>)]
    pub min_pixels: usize,
}

impl SegmentArgs {
    /// The segmentation parameters; errors name the flag.
    pub fn params(&self) -> anyhow::Result<SegmentParams> {
        if !(self.z_step_um.is_finite() && self.z_step_um >= 0.0) {
            bail!("--z-step-um {}: must be finite and >= 0 µm", self.z_step_um);
        }
        if !(self.noise_um.is_finite() && self.noise_um >= 0.0) {
            bail!("--noise-um {}: must be finite and >= 0 µm", self.noise_um);
        }
        if self.min_pixels < 3 {
            bail!("--min-pixels {}: must be at least 3", self.min_pixels);
        }
        let mut p = SegmentParams::for_instrument(self.z_step_um, self.noise_um);
        p.min_pixels = self.min_pixels;
        Ok(p)
    }
}

//! The paint parameter file (`fit --paint --params-out P.json`, read by `model --params`,
//! `compare --params`; `docs/formats.md`): JSON, the paint in its first five keys and the
//! fit that made it, as a report, under `"fit"` (ignored on reading).
//!
//! ```json
//! {
//!   "format": "flakescatter paint parameters",
//!   "version": 1,
//!   "coat": { "n": 1.5, "roughness": 0.012, "haze": 0.31, "haze_roughness": 0.35 },
//!   "orientation": { "family": "trowbridge-reitz", "alpha": 0.11 },
//!   "flakes": { "metal": "aluminium", "coverage": 0.45 },
//!   "channels": [ { "name": "g", "wavelength_nm": 547, "flake_scale": 0.4, "base_albedo": 0.02 } ],
//!   "fit": { ... }
//! }
//! ```
//!
//! `orientation` is one of `{"family": "gaussian", "hwhm_deg": w}`,
//! `{"family": "trowbridge-reitz", "alpha": α}`, `{"family": "pearson-vii", "alpha": α,
//! "shape": γ}`, `{"family": "table", "knots_deg": [...], "ln_p_tilde": [...]}` (a
//! log-linear table) or `{"family": "histogram", "edges_deg": [...], "area_fractions":
//! [...]}` (physics.md §3); `metal` is `"aluminium"`, `"perfect-conductor"`, `{"n": n, "k": k}`
//! or interference flakes `{"stack": "TiO2:120/mica:400/TiO2:120", "core": "aluminium"}`
//! (`core` optional; physics.md §13; `band_fwhm_nm` optional, the colour channels' band,
//! §12.7). `flakes.layers` (optional, a whole number 1–1000,
//! absent = 1) piles free interference flakes that many deep (physics.md §12.8).
//! `channels[].tint` (optional, a finite number >= 0, absent = 0; written only when not
//! 0) is the binder's optical depth over the flakes (physics.md §12.9). Roughness
//! values are GGX slope scales (dimensionless); angles in degrees, wavelengths in nm.

use std::path::Path;

use flakescatter_optics::catalogue::{Catalogue, MaterialSpec};
use flakescatter_optics::stack_spec::StackSpec;
use flakescatter_paint::{Channel, ChannelParams, CoatParams, FlakeMetal, PaintParams};
use flakescatter_stats::decimal::typed_degrees;
use flakescatter_stats::{GaussianWidth, Orientation};
use serde::{Deserialize, Serialize};

use crate::PipelineError;

/// The `format` value.
pub const FORMAT: &str = "flakescatter paint parameters";
/// The `version` written and read.
pub const VERSION: u32 = 1;

/// The file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParamsFile {
    /// Always [`FORMAT`].
    pub format: String,
    /// Always [`VERSION`].
    pub version: u32,
    /// The coat.
    pub coat: CoatSection,
    /// The flakes' orientations.
    pub orientation: OrientationSection,
    /// The flakes.
    pub flakes: FlakesSection,
    /// The channels.
    pub channels: Vec<ChannelSection>,
    /// The report of the fit that made the paint (not read back).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fit: Option<serde_json::Value>,
}

/// `coat`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CoatSection {
    /// Index.
    pub n: f64,
    /// GGX slope scale of the coat's own surface (0: flat).
    pub roughness: f64,
    /// Haze fraction.
    pub haze: f64,
    /// GGX slope scale of the haze.
    pub haze_roughness: f64,
}

/// `orientation`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "family", rename_all = "kebab-case", deny_unknown_fields)]
pub enum OrientationSection {
    /// Gaussian `p̃`.
    Gaussian {
        /// Its hwhm, degrees.
        hwhm_deg: f64,
    },
    /// Trowbridge–Reitz.
    TrowbridgeReitz {
        /// Slope scale.
        alpha: f64,
    },
    /// Pearson VII.
    PearsonVii {
        /// Slope scale.
        alpha: f64,
        /// Shape `γ`.
        shape: f64,
    },
    /// A histogram: `area_fractions[i]` between `edges_deg[i]` and `edges_deg[i + 1]`.
    Histogram {
        /// Bin edges, degrees.
        edges_deg: Vec<f64>,
        /// Area fraction per bin.
        area_fractions: Vec<f64>,
    },
    /// Log-linear table.
    Table {
        /// Knots, degrees.
        knots_deg: Vec<f64>,
        /// `ln p̃` at them.
        ln_p_tilde: Vec<f64>,
    },
}

/// `flakes`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FlakesSection {
    /// The metal.
    pub metal: MetalSection,
    /// Coverage in `[0, 1]`.
    pub coverage: f64,
    /// Flakes piled one under another (a whole number 1–1000; absent: 1, not written
    /// for 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub layers: Option<serde_json::Number>,
}

/// `flakes.metal`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum MetalSection {
    /// `"aluminium"` or `"perfect-conductor"`.
    Named(String),
    /// A complex index.
    Index {
        /// Real part.
        n: f64,
        /// Imaginary part.
        k: f64,
    },
    /// Interference flakes: a stack spec (`material:thickness_nm/…`, as `--flake-stack`)
    /// and an optional opaque core (a material name or `n+ki`, as `--flake-core`).
    Stack {
        /// The layers, from the side light arrives on.
        stack: String,
        /// The core, if any.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        core: Option<String>,
        /// The colour channels' band, full width at half maximum in nm (absent: one
        /// wavelength per channel; physics.md §12.7).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        band_fwhm_nm: Option<f64>,
    },
}

/// One of `channels`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChannelSection {
    /// Name (`r`, `g`, `b`, `y`, `value`, `<number>nm`).
    pub name: String,
    /// Wavelength of the flake optics, nm (must be the one of the name).
    pub wavelength_nm: f64,
    /// Flake reflectance scale.
    pub flake_scale: f64,
    /// Base albedo.
    pub base_albedo: f64,
    /// The binder's tint over the flakes, its Napierian optical depth at normal
    /// incidence (physics.md §12.9; absent: 0, not written for 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tint: Option<f64>,
}

impl ParamsFile {
    /// The file of `params`, with the fit report `fit`.
    #[must_use]
    pub fn new(params: &PaintParams, fit: Option<serde_json::Value>) -> Self {
        // The fit report's keys sorted, whatever serde_json's `preserve_order` (turned
        // on by zarrs) would keep: the file's text stays as it was.
        let fit = fit.map(|mut f| {
            f.sort_all_objects();
            f
        });
        Self {
            format: FORMAT.into(),
            version: VERSION,
            coat: CoatSection {
                n: params.coat.n,
                roughness: params.coat.roughness,
                haze: params.coat.haze,
                haze_roughness: params.coat.haze_roughness,
            },
            orientation: orientation_section(&params.orientation),
            flakes: FlakesSection {
                metal: match &params.flake_metal {
                    FlakeMetal::Aluminium => MetalSection::Named("aluminium".into()),
                    FlakeMetal::PerfectConductor => MetalSection::Named("perfect-conductor".into()),
                    FlakeMetal::Index { n, k } => MetalSection::Index { n: *n, k: *k },
                    FlakeMetal::Stack(s) => MetalSection::Stack {
                        stack: s.stack.label(),
                        core: s.core.as_ref().map(MaterialSpec::label),
                        band_fwhm_nm: s.band_fwhm_nm,
                    },
                },
                coverage: params.coverage,
                layers: (params.flake_metal.layers() > 1)
                    .then(|| params.flake_metal.layers().into()),
            },
            channels: params
                .channels
                .iter()
                .map(|c| ChannelSection {
                    name: c.channel.name.clone(),
                    wavelength_nm: c.channel.wavelength_nm,
                    flake_scale: c.flake_scale,
                    base_albedo: c.base_albedo,
                    tint: (c.tint != 0.0).then_some(c.tint),
                })
                .collect(),
            fit,
        }
    }

    /// The paint of the file.
    ///
    /// # Errors
    /// [`PipelineError::Paint`] naming `file` and the key: a wrong format or version, an
    /// unknown metal, a channel whose wavelength is not its name's, an invalid
    /// orientation; the paint model's own checks are made when it is built.
    pub fn to_params(&self, file: &str) -> Result<PaintParams, PipelineError> {
        let bad = |key: &str, msg: String| {
            PipelineError::Paint(flakescatter_paint::PaintError::Parameter(format!(
                "{file}: {key}: {msg}"
            )))
        };
        if self.format != FORMAT || self.version != VERSION {
            return Err(bad(
                "format/version",
                format!(
                    "\"{}\" version {}: expected \"{FORMAT}\" version {VERSION}",
                    self.format, self.version
                ),
            ));
        }
        let orientation = match &self.orientation {
            OrientationSection::Gaussian { hwhm_deg } => {
                Orientation::gaussian(GaussianWidth::Hwhm(hwhm_deg.to_radians()))
            }
            OrientationSection::TrowbridgeReitz { alpha } => Orientation::trowbridge_reitz(*alpha),
            OrientationSection::PearsonVii { alpha, shape } => {
                Orientation::pearson_vii(*alpha, *shape)
            }
            OrientationSection::Histogram {
                edges_deg,
                area_fractions,
            } => Orientation::tabulated(
                edges_deg.iter().map(|d| d.to_radians()).collect(),
                area_fractions.clone(),
            ),
            OrientationSection::Table {
                knots_deg,
                ln_p_tilde,
            } => Orientation::log_linear(
                knots_deg.iter().map(|d| d.to_radians()).collect(),
                ln_p_tilde.clone(),
            ),
        }
        .map_err(|e| bad("orientation", e.to_string()))?;
        let flake_metal = match &self.flakes.metal {
            MetalSection::Named(n) if n == "aluminium" => FlakeMetal::Aluminium,
            MetalSection::Named(n) if n == "perfect-conductor" => FlakeMetal::PerfectConductor,
            MetalSection::Named(n) => {
                return Err(bad(
                    "flakes.metal",
                    format!(
                        "\"{n}\": expected \"aluminium\", \"perfect-conductor\", {{\"n\": .., \"k\": ..}} or {{\"stack\": .., \"core\": ..}}"
                    ),
                ));
            }
            MetalSection::Index { n, k } => FlakeMetal::Index { n: *n, k: *k },
            MetalSection::Stack {
                stack,
                core,
                band_fwhm_nm,
            } => {
                let catalogue = Catalogue::builtin();
                let stack = StackSpec::parse(stack, &catalogue)
                    .map_err(|e| bad("flakes.metal.stack", e.to_string()))?;
                let core = core
                    .as_deref()
                    .map(|c| catalogue.parse(c))
                    .transpose()
                    .map_err(|e| bad("flakes.metal.core", e.to_string()))?;
                FlakeMetal::stack(stack, core)
                    .with_band(*band_fwhm_nm)
                    .map_err(|e| bad("flakes.metal.band_fwhm_nm", e.to_string()))?
            }
        };
        let flake_metal = match &self.flakes.layers {
            None => flake_metal,
            Some(v) => {
                let layers = v
                    .as_u64()
                    .and_then(|l| u32::try_from(l).ok())
                    .filter(|l| (1..=flakescatter_optics::flake::MAX_PILE).contains(l))
                    .ok_or_else(|| {
                        bad(
                            "flakes.layers",
                            format!("{v}: expected a whole number from 1 to 1000"),
                        )
                    })?;
                flake_metal
                    .with_layers(layers)
                    .map_err(|e| bad("flakes.layers", e.to_string()))?
            }
        };
        let channels = self
            .channels
            .iter()
            .enumerate()
            .map(|(i, c)| {
                let channel = Channel::parse(&c.name)
                    .map_err(|e| bad(&format!("channels[{i}].name"), e.to_string()))?;
                if channel.wavelength_nm != c.wavelength_nm {
                    return Err(bad(
                        &format!("channels[{i}].wavelength_nm"),
                        format!(
                            "{} nm, but channel `{}` is taken at {} nm",
                            c.wavelength_nm, c.name, channel.wavelength_nm
                        ),
                    ));
                }
                let tint = c.tint.unwrap_or(0.0);
                if !(tint.is_finite() && tint >= 0.0) {
                    return Err(bad(
                        &format!("channels[{i}].tint"),
                        format!("{tint}: expected the binder's optical depth over the flakes, a finite number >= 0"),
                    ));
                }
                Ok(ChannelParams {
                    channel,
                    flake_scale: c.flake_scale,
                    base_albedo: c.base_albedo,
                    tint,
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(PaintParams {
            coat: CoatParams {
                n: self.coat.n,
                roughness: self.coat.roughness,
                haze: self.coat.haze,
                haze_roughness: self.coat.haze_roughness,
            },
            orientation,
            coverage: self.flakes.coverage,
            flake_metal,
            channels,
        })
    }

    /// The file as pretty JSON text (numbers in shortest round-trip form).
    ///
    /// # Errors
    /// [`PipelineError::Paint`] when a number is not finite (JSON has no NaN).
    pub fn to_json(&self) -> Result<String, PipelineError> {
        serde_json::to_string_pretty(self).map_err(|e| {
            PipelineError::Paint(flakescatter_paint::PaintError::Parameter(format!(
                "the parameter file cannot be written: {e}"
            )))
        })
    }
}

/// The orientation section of `o`.
#[must_use]
pub fn orientation_section(o: &Orientation) -> OrientationSection {
    if let Some(w) = o.gaussian_width() {
        return OrientationSection::Gaussian {
            hwhm_deg: typed_degrees(w.hwhm()),
        };
    }
    if let Some((alpha, shape)) = o.pearson_vii_params() {
        return if shape == 1.0 {
            OrientationSection::TrowbridgeReitz { alpha }
        } else {
            OrientationSection::PearsonVii { alpha, shape }
        };
    }
    if let Some((knots, ln)) = o.log_linear_knots() {
        return OrientationSection::Table {
            knots_deg: knots.iter().map(|&k| typed_degrees(k)).collect(),
            ln_p_tilde: ln.to_vec(),
        };
    }
    // A histogram: its bins and their area fractions.
    let edges = o.bin_edges().unwrap_or(&[]).to_vec();
    let area_fractions = edges
        .windows(2)
        .map(|w| o.mass_between(w[0], w[1]))
        .collect();
    OrientationSection::Histogram {
        // Degrees as typed: `1.5`, not `1.5000000000000002` (issue 52, item 16).
        edges_deg: edges.iter().map(|&e| typed_degrees(e)).collect(),
        area_fractions,
    }
}

/// Reads a parameter file.
///
/// # Errors
/// [`PipelineError::Paint`] naming the file: unreadable, not JSON of this format (with
/// the line and column serde reports), or parameters out of range.
pub fn read_params(path: &Path) -> Result<PaintParams, PipelineError> {
    let name = path.display().to_string();
    let text = flakescatter_io::files::read_text(path).map_err(|e| {
        PipelineError::Paint(flakescatter_paint::PaintError::Parameter(e.to_string()))
    })?;
    let file: ParamsFile = serde_json::from_str(&text).map_err(|e| {
        PipelineError::Paint(flakescatter_paint::PaintError::Parameter(format!(
            "{name}: not a paint parameter file ({e}); expected the JSON that `fit --paint --params-out` writes"
        )))
    })?;
    file.to_params(&name)
}

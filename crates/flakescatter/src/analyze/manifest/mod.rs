//! The sample manifest of `flakescatter analyze` (TOML, parsed with `serde`): which maps
//! (or z-stacks) make the sample and how they pair with intensity maps, the instrument
//! of the microscope, the coating, the measured curve(s) and which models to run.
//! Every key is documented in `docs/guide.md` ("One sample, one command"). An unknown
//! key, a value of the wrong type and a value out of range are errors naming the key and
//! the file, before any work.
//!
//! Units as the key names say: degrees in `_deg` keys, micrometres in `_um` keys.

mod check;

use std::path::PathBuf;

use serde::{Deserialize, Serialize};
use thiserror::Error;

/// A manifest that cannot be used.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("{file}: {message}")]
pub struct ManifestError {
    /// The manifest file.
    pub file: String,
    /// What is wrong, naming the key.
    pub message: String,
}

/// A sample manifest.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// Name of the sample in reports (default: the manifest's file name without
    /// `.toml`); letters, digits, `-`, `_` and `.`.
    #[serde(default)]
    pub name: Option<String>,
    /// Free text for the report.
    #[serde(default)]
    pub description: Option<String>,
    /// The maps.
    pub maps: Maps,
    /// z-stack localisation, for maps that are stacks.
    #[serde(default)]
    pub stack: StackSection,
    /// The confocal instrument (segmentation thresholds).
    #[serde(default)]
    pub instrument: InstrumentSection,
    /// The coating.
    #[serde(default)]
    pub coating: CoatingSection,
    /// The measured goniometric curve(s).
    #[serde(default)]
    pub measured: Option<MeasuredSection>,
    /// Statistics settings.
    #[serde(default)]
    pub stats: StatsSection,
    /// Which models to run, and the goniometer's geometry.
    #[serde(default)]
    pub models: ModelsSection,
    /// A measured BRDF table of the sample to fit a paint to (physics.md §12).
    #[serde(default)]
    pub paint: Option<PaintSection>,
}

/// `[paint]`: the paint fitted to a measured BRDF table of the sample (`fit --paint`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PaintSection {
    /// The BRDF table (`theta_i_deg, theta_r_deg, phi_r_deg, brdf_<channel>_per_sr`),
    /// relative to the manifest's directory.
    pub file: PathBuf,
    /// Orientation family: `auto` (default), `gaussian`, `trowbridge-reitz`,
    /// `pearson-vii` or `table`.
    #[serde(default = "default_family")]
    pub family: String,
    /// The flakes' coverage, if known, in `[0, 1]` (default: the middle of the interval
    /// the table allows).
    #[serde(default)]
    pub coverage: Option<f64>,
    /// Aspecular range of the points used, degrees (default `[2, 180]`).
    #[serde(default)]
    pub region_deg: Option<[f64; 2]>,
    /// Detectors beyond this polar angle are left out, degrees (default 90: none).
    #[serde(default)]
    pub max_theta_r_deg: Option<f64>,
    /// Values below this BRDF are left out, 1/sr (default 0: none).
    #[serde(default)]
    pub min_value: Option<f64>,
}

fn default_family() -> String {
    "auto".into()
}

/// `[maps]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Maps {
    /// Height maps or z-stacks: files, directories or glob patterns, relative to the
    /// manifest's directory.
    pub files: Vec<PathBuf>,
    /// One intensity map per height map, in order (or `intensity_suffix`).
    #[serde(default)]
    pub intensity: Vec<PathBuf>,
    /// Pair `NAME<height_suffix>.EXT` with `NAME<intensity_suffix>.EXT`.
    #[serde(default)]
    pub intensity_suffix: Option<String>,
    /// The part of a height map's name the intensity suffix replaces (default
    /// `.height`).
    #[serde(default = "default_height_suffix")]
    pub height_suffix: String,
    /// Intensity cutoff in the intensity maps' stored values.
    #[serde(default)]
    pub cutoff: Option<f64>,
    /// Pixel pitch `[dx, dy]`, µm, for maps that carry none (plain text).
    #[serde(default)]
    pub pixel_um: Option<[f64; 2]>,
    /// Unit of plain-text heights: `um`, `nm` or `m`.
    #[serde(default)]
    pub z_unit: Option<String>,
    /// Which channel of each map file holds the heights: a 0-based index (`2`, or
    /// `"2"`) or a channel name (`"layer0"`: exact, else ignoring case when unique), as
    /// `flakescatter info` lists them. Default: the first.
    #[serde(default)]
    pub channel: Option<ChannelKey>,
    /// An intensity channel of each map file itself (index or name, as `channel`) used
    /// as its intensity map with `cutoff`, instead of a second file; excludes
    /// `intensity` and `intensity_suffix`.
    #[serde(default)]
    pub intensity_channel: Option<ChannelKey>,
    /// Pool maps that are the same data (a copy, or the same file through a link),
    /// which are refused by default (`crate::distinct`).
    #[serde(default)]
    pub allow_duplicates: bool,
}

/// A channel in a manifest: an integer index or a string (all digits: an index; else a
/// name). Read by hand (`keys` module) so that a wrong value names the accepted forms.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
#[serde(untagged)]
pub enum ChannelKey {
    /// A 0-based index.
    Index(usize),
    /// A name (or an index written as a string).
    Name(String),
}

impl ChannelKey {
    /// The selector this key means.
    ///
    /// # Errors
    /// The reason an empty (or too large) value is refused.
    pub fn selector(&self) -> Result<flakescatter_io::ChannelSelector, String> {
        match self {
            ChannelKey::Index(i) => Ok(flakescatter_io::ChannelSelector::Index(*i)),
            ChannelKey::Name(n) => n.parse().map_err(|e| format!("{e}")),
        }
    }
}

impl Maps {
    /// The height channel and intensity channel selectors of the keys `channel` and
    /// `intensity_channel`.
    ///
    /// # Errors
    /// A message naming the key.
    pub fn channels(
        &self,
    ) -> Result<
        (
            Option<flakescatter_io::ChannelSelector>,
            Option<flakescatter_io::ChannelSelector>,
        ),
        String,
    > {
        let one = |key: &str, v: &Option<ChannelKey>| {
            v.as_ref()
                .map(|c| c.selector().map_err(|e| format!("key `maps.{key}`: {e}")))
                .transpose()
        };
        Ok((
            one("channel", &self.channel)?,
            one("intensity_channel", &self.intensity_channel)?,
        ))
    }
}

fn default_height_suffix() -> String {
    ".height".into()
}

/// `[stack]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StackSection {
    /// Peak localisation: `argmax`, `parabolic`, `gaussian` (default) or `centroid`.
    #[serde(default = "default_peak")]
    pub peak: String,
    /// Pixels whose brightest sample is below this (full scale 1) are invalid; absent:
    /// estimated from each stack's own noise (`flakescatter_confocal::noise`).
    #[serde(default)]
    pub min_signal: Option<f64>,
    /// z step override, µm.
    #[serde(default)]
    pub z_step_um: Option<f64>,
    /// Which slice page 0 is: `bottom` or `top` (default: from the metadata, else
    /// bottom).
    #[serde(default)]
    pub first_page: Option<String>,
}

fn default_peak() -> String {
    "gaussian".into()
}

impl Default for StackSection {
    fn default() -> Self {
        Self {
            peak: default_peak(),
            min_signal: None,
            z_step_um: None,
            first_page: None,
        }
    }
}

/// `[instrument]`: the confocal microscope, for segmentation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InstrumentSection {
    /// z quantisation step of the height maps, µm (0 = none; default 0.3).
    #[serde(default = "default_z_step")]
    pub z_step_um: f64,
    /// Height noise sd, µm (default 0.03).
    #[serde(default = "default_noise")]
    pub noise_um: f64,
    /// Smallest flake kept, pixels (default 100).
    #[serde(default = "default_min_pixels")]
    pub min_pixels: usize,
}

fn default_z_step() -> f64 {
    0.3
}
fn default_noise() -> f64 {
    0.03
}
fn default_min_pixels() -> usize {
    100
}

impl Default for InstrumentSection {
    fn default() -> Self {
        Self {
            z_step_um: default_z_step(),
            noise_um: default_noise(),
            min_pixels: default_min_pixels(),
        }
    }
}

/// `[coating]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CoatingSection {
    /// Clear-coat refractive index (default 1.5).
    #[serde(default = "default_n")]
    pub n: f64,
    /// Complex flake index `[n, k]` (default a perfect conductor).
    #[serde(default)]
    pub flake_index: Option<[f64; 2]>,
    /// Interference flakes: a thin-film stack, `"TiO2:120/mica:400"` (physics.md §13),
    /// at `wavelength_nm`, instead of `flake_index`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flake_stack: Option<String>,
    /// An opaque core under the stack's layers (a material name or `n+ki`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub flake_core: Option<String>,
    /// The vacuum wavelength, nm, at which the stack reflects (needed with `flake_stack`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wavelength_nm: Option<f64>,
}

fn default_n() -> f64 {
    1.5
}

impl Default for CoatingSection {
    fn default() -> Self {
        Self {
            n: default_n(),
            flake_index: None,
            flake_stack: None,
            flake_core: None,
            wavelength_nm: None,
        }
    }
}

/// `[measured]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeasuredSection {
    /// Measured curve CSV files (`theta_i_deg, theta_s_deg, value[, uncertainty]`),
    /// relative to the manifest's directory; several are joined (they must not repeat a
    /// point).
    pub files: Vec<PathBuf>,
    /// What `value` is: `brdf` (default), `reflectance-factor` or `relative`.
    #[serde(default = "default_kind")]
    pub kind: String,
}

fn default_kind() -> String {
    "brdf".into()
}

/// `[stats]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StatsSection {
    /// Histogram bin width, degrees (default 1).
    #[serde(default = "default_bin")]
    pub bin_deg: f64,
    /// Also the pixel-level statistics (where the width comes from; default true).
    #[serde(default = "default_true")]
    pub pixel_normals: bool,
    /// Top of the overlays' tilt colour scale, degrees (default 20).
    #[serde(default = "default_overlay_max")]
    pub overlay_max_deg: f64,
}

fn default_bin() -> f64 {
    1.0
}
fn default_true() -> bool {
    true
}
fn default_overlay_max() -> f64 {
    20.0
}

impl Default for StatsSection {
    fn default() -> Self {
        Self {
            bin_deg: default_bin(),
            pixel_normals: true,
            overlay_max_deg: default_overlay_max(),
        }
    }
}

/// In-plane detector angles: a list, or an inclusive range. Read by hand (`keys`
/// module) so that a wrong value names the key and the accepted forms.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum Angles {
    /// Degrees.
    List(Vec<f64>),
    /// `{ from = -70, to = 70, step = 0.5 }`, degrees, inclusive.
    Range {
        /// First angle.
        from: f64,
        /// Last angle (inclusive when on the grid).
        to: f64,
        /// Step, > 0.
        step: f64,
    },
}

/// Which topographic model to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TopoKind {
    /// Not run.
    None,
    /// One ray per usable pixel (paper eqs. 14–15).
    Plain,
    /// Averaged exactly over the sample's rotation (physics.md §5.1; the default).
    Isotropic,
}

/// `[models]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelsSection {
    /// Incidences, degrees (default: those of the measured curve, else 30 and 60).
    #[serde(default)]
    pub theta_i_deg: Option<Vec<f64>>,
    /// Detectors, degrees (default `{ from = -70, to = 70, step = 0.5 }`).
    #[serde(default)]
    pub theta_s_deg: Option<Angles>,
    /// Detector half-angle, degrees (default 1.5).
    #[serde(default = "default_aperture")]
    pub aperture_deg: f64,
    /// Include the clear coat's own reflection (default true, as a goniometer sees it).
    #[serde(default = "default_true")]
    pub clearcoat: bool,
    /// The distribution model with the pooled width (default true).
    #[serde(default = "default_true")]
    pub distribution_fitted: bool,
    /// The distribution model with the pooled histogram (default true).
    #[serde(default = "default_true")]
    pub distribution_histogram: bool,
    /// The topographic model: `isotropic` (default), `plain` or `none`.
    #[serde(default = "default_topo")]
    pub topographic: TopoKind,
    /// Fit the Gaussian width to the measured curve (default true; needs `[measured]`).
    #[serde(default = "default_true")]
    pub fit: bool,
    /// The multi-angle readout (45°, L* and flop index) of the pooled width (default
    /// true).
    #[serde(default = "default_true")]
    pub multi_angle: bool,
    /// Least-squares window of the topographic model, pixels (default 5).
    #[serde(default = "default_window")]
    pub window: usize,
    /// Tile side of the topographic standard errors, µm (default 32).
    #[serde(default = "default_tile")]
    pub tile_um: f64,
}

fn default_aperture() -> f64 {
    1.5
}
fn default_topo() -> TopoKind {
    TopoKind::Isotropic
}
fn default_window() -> usize {
    5
}
fn default_tile() -> f64 {
    flakescatter_topo::DEFAULT_BLOCK_UM
}

impl Default for ModelsSection {
    fn default() -> Self {
        Self {
            theta_i_deg: None,
            theta_s_deg: None,
            aperture_deg: default_aperture(),
            clearcoat: true,
            distribution_fitted: true,
            distribution_histogram: true,
            topographic: default_topo(),
            fit: true,
            multi_angle: true,
            window: default_window(),
            tile_um: default_tile(),
        }
    }
}

impl Angles {
    /// The angles in degrees; `key` names the key in errors.
    ///
    /// # Errors
    /// A message naming `key` for an empty list, a bad step or more than 10⁶ angles.
    pub fn degrees(&self, key: &str) -> Result<Vec<f64>, String> {
        match self {
            Self::List(v) if v.is_empty() => Err(format!("{key}: empty list")),
            Self::List(v) => Ok(v.clone()),
            Self::Range { from, to, step } => {
                if !(step.is_finite() && *step > 0.0 && from.is_finite() && to.is_finite()) {
                    return Err(format!("{key}: from, to and step must be finite, step > 0"));
                }
                if to < from {
                    return Err(format!("{key}: the range is empty (to < from)"));
                }
                // Stepped on the decimals as written (`-80 + 0.1 k` is -79.9, …, 80).
                let range = flakescatter_stats::decimal::DecimalRange::new(*from, *to, *step)
                    .ok_or_else(|| format!("{key}: from, to and step must be finite, step > 0"))?;
                if range.len() > 1_000_001 {
                    return Err(format!("{key}: more than 10^6 angles"));
                }
                Ok(range.iter().collect())
            }
        }
    }
}

impl Manifest {
    /// Parses and checks the manifest text of `file` (named in errors).
    ///
    /// # Errors
    /// [`ManifestError`] naming the key: TOML syntax (with line and column), an unknown
    /// key, a wrong type, or a value out of range ([`Manifest::validate`]).
    pub fn from_toml(text: &str, file: &str) -> Result<Self, ManifestError> {
        let m: Self = toml::from_str(text).map_err(|e| ManifestError {
            file: file.to_owned(),
            message: e.to_string().trim_end().replace('\n', "\n    "),
        })?;
        m.validate(file)?;
        Ok(m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const OK: &str = r#"
        [maps]
        files = ["a.height.x3p"]
        intensity_suffix = ".intensity"
        cutoff = 0.49
        [models]
        fit = false
        theta_s_deg = { from = -70, to = 70, step = 0.5 }
    "#;

    #[test]
    fn defaults_and_ranges() {
        let m = Manifest::from_toml(OK, "s.toml").unwrap();
        assert_eq!(m.maps.height_suffix, ".height");
        assert_eq!(m.models.topographic, TopoKind::Isotropic);
        assert_eq!(m.instrument.z_step_um, 0.3);
        let ts = m.models.theta_s_deg.unwrap().degrees("k").unwrap();
        assert_eq!((ts.len(), ts[0], ts[1], ts[280]), (281, -70.0, -69.5, 70.0));
        // Issue 52, item 16: a range steps on its decimals; every angle prints as the
        // decimal -80 + k/10 (one place), and the end is included exactly.
        let r = Angles::Range {
            from: -80.0,
            to: 80.0,
            step: 0.1,
        };
        let v = r.degrees("k").unwrap();
        assert_eq!(v.len(), 1601);
        for (k, x) in v.iter().enumerate() {
            // The decimal text of (k − 800)/10, from integers.
            let n = k as i64 - 800;
            let (sign, q, r) = (if n < 0 { "-" } else { "" }, n.abs() / 10, n.abs() % 10);
            let want = if r == 0 {
                format!("{sign}{q}")
            } else {
                format!("{sign}{q}.{r}")
            };
            assert_eq!(format!("{x}"), want, "k = {k}");
        }
    }

    #[test]
    fn channels_are_indices_or_names() {
        use flakescatter_io::ChannelSelector;
        let text = OK.replace(
            "intensity_suffix = \".intensity\"\n",
            "channel = 0\nintensity_channel = \"Image0\"\n",
        );
        let m = Manifest::from_toml(&text, "s.toml").unwrap();
        assert_eq!(
            m.maps.channels().unwrap(),
            (
                Some(ChannelSelector::Index(0)),
                Some(ChannelSelector::Name("Image0".into()))
            )
        );
        // A string of digits is an index, as on the command line.
        let m = Manifest::from_toml(&OK.replace("cutoff", "channel = \"2\"\ncutoff"), "s.toml")
            .unwrap();
        assert_eq!(
            m.maps.channels().unwrap().0,
            Some(ChannelSelector::Index(2))
        );
    }

    #[test]
    fn errors_name_the_key_and_the_file() {
        let cases = [
            (
                OK.replace("cutoff = 0.49", "cutof = 0.49"),
                "unknown field `cutof`",
            ),
            (OK.replace("cutoff = 0.49", "cutoff = \"x\""), "cutoff"),
            (
                OK.replace("fit = false", "fit = false\naperture_deg = 0"),
                "models.aperture_deg",
            ),
            (OK.replace("fit = false", "fit = true"), "models.fit"),
            (
                OK.replace("[models]", "[coating]\nn = 0.5\n[models]"),
                "coating.n",
            ),
            (
                OK.replace("fit = false", "fit = false\ntopographic = \"round\""),
                "topographic",
            ),
            (OK.replace("cutoff = 0.49\n", ""), "maps.cutoff"),
            (format!("name = \"a b\"\n{OK}"), "key `name`"),
            (
                OK.replace("cutoff = 0.49", "cutoff = 0.49\nintensity_channel = 1"),
                "maps.intensity_channel",
            ),
            (
                OK.replace("cutoff = 0.49", "cutoff = 0.49\nchannel = \"\""),
                "maps.channel",
            ),
            (
                OK.replace(
                    "intensity_suffix = \".intensity\"",
                    "intensity_channel = \"image0\"",
                )
                .replace("cutoff = 0.49\n", ""),
                "maps.cutoff",
            ),
        ];
        for (text, needle) in cases {
            let e = Manifest::from_toml(&text, "dir/s.toml")
                .unwrap_err()
                .to_string();
            assert!(e.starts_with("dir/s.toml: "), "{e}");
            assert!(e.contains(needle), "{needle}: {e}");
        }
    }
}

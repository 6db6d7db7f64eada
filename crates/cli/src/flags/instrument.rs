//! Coating, model and instrument flags of `model`, `topo`, `compare` and `fit`.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use flakescatter::optics::flake::FlakeReflectance;
use flakescatter::optics::polarization::{Transmission, Weighting};
use flakescatter::{Coating, DetectorSet, Instrument, Settings};
use serde_json::{Value, json};

use super::{DEFAULT_THETA_I, DEFAULT_THETA_S};

/// The default detector half-angle, degrees.
pub const DEFAULT_APERTURE_DEG: f64 = 1.5;

/// Largest number of incidence × detector rows a command computes.
pub const MAX_ROWS: usize = 10_000_000;
use crate::output::Plan;
use crate::parse::{angles, check_range};

/// Coating and model flags shared by `model`, `topo`, `compare` and `fit`.
#[derive(Debug, Clone, clap::Args)]
pub struct OpticsArgs {
    /// Clear-coat refractive index (real, >= 1).
    #[arg(
        long = "n",
        value_name = "X",
        default_value_t = 1.5,
        allow_negative_numbers = true
    )]
    pub n: f64,
    /// Detector cone half-angle in degrees, in [0, 20]; 0 = point detectors (default 1.5).
    #[arg(long, value_name = "A", allow_negative_numbers = true)]
    pub aperture: Option<f64>,
    /// Fresnel bookkeeping: exact-unpolarized (m00), s or p (a polarised beam, m00 ± m01;
    /// both exact in every direction), or paper (T_av at each crossing, eq. 10). Any
    /// other polarisation, and analysers: --incident, --analyzer (model, topo).
    #[arg(long, value_name = "K", default_value = "exact-unpolarized")]
    pub transmission: Transmission,
    /// Ray weighting: physical, or paper-printed (the printed eqs. 9/13/14; breaks
    /// energy conservation, for reproducing the paper's shapes only).
    #[arg(long, value_name = "K", default_value = "physical")]
    pub weighting: Weighting,
    /// Complex flake index `N,K` (e.g. `0.96,6.69` for aluminium at 550 nm); default a
    /// perfect conductor, as in the paper.
    #[arg(long, value_name = "N,K", allow_hyphen_values = true)]
    pub flake_index: Option<String>,
}

impl OpticsArgs {
    /// The coating these flags describe.
    pub fn coating(&self) -> anyhow::Result<Coating> {
        let flake = match &self.flake_index {
            None => FlakeReflectance::PerfectConductor,
            Some(s) => {
                let parts: Vec<&str> = s.split(',').map(str::trim).collect();
                let parsed: Option<Vec<f64>> = parts.iter().map(|p| p.parse().ok()).collect();
                match parsed.as_deref() {
                    Some([n, k]) if n.is_finite() && k.is_finite() => {
                        FlakeReflectance::complex(*n, *k)
                            .with_context(|| format!("--flake-index {s}"))?
                    }
                    _ => bail!(
                        "--flake-index {s}: expected two finite numbers `N,K`, e.g. 0.96,6.69"
                    ),
                }
            }
        };
        Coating::new(self.n, flake).map_err(|e| anyhow::anyhow!("--n {e}"))
    }

    /// The model settings, with the clear coat's reflection on or off.
    pub fn settings(&self, clearcoat: bool) -> Settings {
        Settings {
            transmission: self.transmission,
            weighting: self.weighting,
            clearcoat,
            ..Settings::default()
        }
    }

    /// The detector half-angle in degrees as given, or the default 1.5.
    pub fn aperture_deg(&self) -> f64 {
        self.aperture.unwrap_or(DEFAULT_APERTURE_DEG)
    }

    /// The detector half-angle in radians, checked to be in `[0, 20°]`.
    pub fn aperture_rad(&self) -> anyhow::Result<f64> {
        let a = self.aperture_deg();
        if !(a.is_finite() && (0.0..=20.0).contains(&a)) {
            bail!("--aperture {a}: expected a half-angle in [0, 20] degrees");
        }
        Ok(a.to_radians())
    }

    /// The coating and settings echo for JSON.
    pub fn echo(&self, clearcoat: bool) -> Value {
        json!({
            "n": self.n,
            "aperture_deg": self.aperture_deg(),
            "transmission": self.transmission.name(),
            "weighting": self.weighting.name(),
            "clearcoat": clearcoat,
            "flake_index": self.flake_index.clone().unwrap_or_else(|| "perfect-conductor".into()),
        })
    }
}

/// Instrument flags of `model` and `topo`: incidences, detectors, coating.
#[derive(Debug, Clone, clap::Args)]
pub struct InstrumentArgs {
    /// Coating and model flags.
    #[command(flatten)]
    pub optics: OpticsArgs,
    /// Incidence angles in degrees, in [0, 90): a list `0,30,60`, an inclusive range
    /// `start:stop:step`, or both comma-separated [default: 0,30,45,60,75; 45 with
    /// --multi-angle].
    #[arg(long, value_name = "LIST", allow_hyphen_values = true)]
    pub theta_i: Option<String>,
    /// Signed in-plane detector angles in degrees, in (-90, 90); `theta_s = -theta_i` is
    /// the specular direction, positive angles are on the source side [default:
    /// -70:70:0.5].
    #[arg(long, value_name = "LIST", allow_hyphen_values = true)]
    pub theta_s: Option<String>,
    /// Out-of-plane detectors: CSV with header `theta_r_deg,phi_r_deg` (phi_r = 0 is the
    /// specular half-plane); replaces --theta-s.
    #[arg(long, value_name = "FILE", conflicts_with = "theta_s")]
    pub detectors: Option<PathBuf>,
    /// Add the clear coat's own specular reflection (physics.md §6).
    #[arg(long)]
    pub clearcoat: bool,
}

impl InstrumentArgs {
    /// Registers `--detectors` as an input.
    pub fn inputs(&self, plan: &mut Plan) {
        if let Some(p) = &self.detectors {
            plan.input("--detectors", p);
        }
    }

    /// The `--theta-i` list as typed, or the default.
    pub fn theta_i_text(&self) -> &str {
        self.theta_i.as_deref().unwrap_or(DEFAULT_THETA_I)
    }

    /// Incidences in degrees, checked to be in `[0, 90)`.
    pub fn theta_i_deg(&self) -> anyhow::Result<Vec<f64>> {
        let v = angles("--theta-i", self.theta_i_text())?;
        check_range("--theta-i", &v, 0.0, 90.0, false, true)?;
        Ok(v)
    }

    /// The instrument these flags describe (angles converted to radians).
    pub fn instrument(&self) -> anyhow::Result<Instrument> {
        let theta_i = self.theta_i_deg()?;
        let aperture = self.optics.aperture_rad()?;
        let detectors = match &self.detectors {
            Some(path) => DetectorSet::OutOfPlane(read_detectors(path)?),
            None => {
                let text = self.theta_s.as_deref().unwrap_or(DEFAULT_THETA_S);
                let ts = angles("--theta-s", text)?;
                check_range("--theta-s", &ts, -90.0, 90.0, true, true)?;
                DetectorSet::InPlane(ts.into_iter().map(f64::to_radians).collect())
            }
        };
        let rows = theta_i.len() as f64 * detectors.len() as f64;
        if rows > MAX_ROWS as f64 {
            bail!(
                "--theta-i and --theta-s/--detectors: {} incidences × {} detectors = {rows:e} rows is more than the limit of {MAX_ROWS}",
                theta_i.len(),
                detectors.len()
            );
        }
        Ok(Instrument::new(
            theta_i.into_iter().map(f64::to_radians).collect(),
            detectors,
            aperture,
        )?)
    }

    /// The model settings (clear coat as `--clearcoat` says).
    pub fn settings(&self) -> Settings {
        self.optics.settings(self.clearcoat)
    }

    /// The flags echoed for JSON metadata.
    pub fn echo(&self) -> Value {
        let mut v = self.optics.echo(self.clearcoat);
        v["theta_i_deg"] = json!(self.theta_i_text());
        v["theta_s_deg"] = match &self.detectors {
            Some(_) => Value::Null,
            None => json!(self.theta_s.as_deref().unwrap_or(DEFAULT_THETA_S)),
        };
        v["detectors_file"] = json!(self.detectors.as_ref().map(|p| p.display().to_string()));
        v
    }
}

/// Reads out-of-plane detectors (io's detector reader: CSV with header
/// `theta_r_deg, phi_r_deg`, degrees, ranges checked); returns `(θr, φr)` in radians.
fn read_detectors(path: &Path) -> anyhow::Result<Vec<(f64, f64)>> {
    Ok(flakescatter::io::detectors::read_detectors(path)
        .with_context(|| format!("--detectors {}", path.display()))?
        .into_iter()
        .map(|d| (d.theta_r, d.phi_r))
        .collect())
}

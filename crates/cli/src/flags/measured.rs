//! The measured curve of `compare` and `fit` and the selection of its points.

use std::path::PathBuf;

use anyhow::Context;
use flakescatter::Settings;
use flakescatter::compare::{MeasuredKind, select};
use flakescatter::io::measured::{MeasuredCurve, read_measured};
use serde_json::{Value, json};

use super::OpticsArgs;
use crate::output::{Plan, note};
use crate::parse::{angles, check_range, deg_num};

/// Angles selected by `--theta-i` and `--theta-s`, degrees (`None` = all).
struct Selection {
    theta_i: Option<Vec<f64>>,
    theta_s: Option<Vec<f64>>,
}

/// The measured curve of `compare` and `fit`, which of its points to use, and the
/// coating flags.
#[derive(Debug, Clone, clap::Args)]
pub struct MeasuredArgs {
    /// Measured curve, CSV with header `theta_i_deg, theta_s_deg, value` and optionally
    /// `uncertainty` (one standard uncertainty, same unit as value).
    #[arg(
        long,
        value_name = "FILE",
        required_unless_present = "measured_multiangle"
    )]
    pub measured: Option<PathBuf>,
    /// Measured multi-angle colour instead of a curve: CSV `theta_i_deg, aspecular_deg`
    /// with `L, a, b` (optionally `L_uncertainty`) or with `wavelength_nm,
    /// reflectance_factor` (one row per geometry and wavelength). `compare` gives ΔE per
    /// geometry, `fit` fits the width to L*.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["measured", "measured_kind", "theta_i", "theta_s"])]
    pub measured_multiangle: Option<PathBuf>,
    /// What `value` is: brdf (1/sr), reflectance-factor (π × BRDF) or relative (1 at
    /// specular).
    #[arg(long, value_name = "KIND", default_value = "brdf")]
    pub measured_kind: MeasuredKind,
    /// Use only the measured points at these incidences, degrees (list or range); each
    /// must be in the file. Default: every incidence of the file.
    #[arg(long, value_name = "LIST", allow_hyphen_values = true)]
    pub theta_i: Option<String>,
    /// Use only the measured points at these detector angles, degrees (list or range).
    /// Default: every angle of the file.
    #[arg(long, value_name = "LIST", allow_hyphen_values = true)]
    pub theta_s: Option<String>,
    /// Leave out the clear coat's own specular reflection (on by default in comparisons,
    /// so that the specular peak is modelled too).
    #[arg(long)]
    pub no_clearcoat: bool,
    /// Include the clear coat's own specular reflection (the default here).
    #[arg(long, conflicts_with = "no_clearcoat")]
    pub clearcoat: bool,
    /// Coating and model flags.
    #[command(flatten)]
    pub optics: OpticsArgs,
}

impl MeasuredArgs {
    /// Registers `--measured` or `--measured-multiangle` as an input.
    pub fn inputs(&self, plan: &mut Plan) {
        if let Some(m) = &self.measured {
            plan.input("--measured", m);
        }
        if let Some(m) = &self.measured_multiangle {
            plan.input("--measured-multiangle", m);
        }
    }

    /// The `--theta-i` / `--theta-s` selections in degrees (`None` = all).
    fn selection_deg(&self) -> anyhow::Result<Selection> {
        let ti = match &self.theta_i {
            Some(t) => {
                let v = angles("--theta-i", t)?;
                check_range("--theta-i", &v, 0.0, 90.0, false, true)?;
                Some(v)
            }
            None => None,
        };
        let ts = match &self.theta_s {
            Some(t) => {
                let v = angles("--theta-s", t)?;
                check_range("--theta-s", &v, -90.0, 90.0, true, true)?;
                Some(v)
            }
            None => None,
        };
        Ok(Selection {
            theta_i: ti,
            theta_s: ts,
        })
    }

    /// Reads `--measured` for the paint model (a BRDF table, or an in-plane curve of
    /// BRDFs or reflectance factors) and keeps the incidences of `--theta-i`;
    /// `--theta-s` (in-plane only) is refused.
    pub fn read_paint(&self) -> anyhow::Result<flakescatter::paint::Measurement> {
        let Some(path) = &self.measured else {
            anyhow::bail!("give --measured FILE (a BRDF table)");
        };
        if self.theta_s.is_some() {
            anyhow::bail!(
                "--theta-s selects in-plane detectors of a curve; a paint uses every detector of the table within --region and --max-theta-r"
            );
        }
        let Selection { theta_i: ti, .. } = self.selection_deg()?;
        let mut m = flakescatter::paint::read_measurement(path, self.measured_kind)
            .with_context(|| format!("reading --measured {}", path.display()))?;
        if let Some(ti) = ti {
            let all = m.rows.len();
            for t in &ti {
                if !m
                    .rows
                    .iter()
                    .any(|r| (r.theta_i.to_degrees() - t).abs() < 1e-9)
                {
                    anyhow::bail!("--theta-i {t}: {} has no row at this incidence", m.file);
                }
            }
            m.rows
                .retain(|r| ti.iter().any(|t| (r.theta_i.to_degrees() - t).abs() < 1e-9));
            note(&format!(
                "using {} of {all} rows of {} (--theta-i {})",
                m.rows.len(),
                m.file,
                self.theta_i.as_deref().unwrap_or("")
            ));
        }
        Ok(m)
    }

    /// Checks the selection flags without reading the file.
    pub fn validate(&self) -> anyhow::Result<()> {
        self.selection_deg().map(|_| ())
    }

    /// Reads the measured file and keeps the selected points; says on stderr what was
    /// selected. Returns the curve and the JSON echo of the selection.
    pub fn read(&self) -> anyhow::Result<(MeasuredCurve, Value)> {
        let Some(path) = &self.measured else {
            anyhow::bail!("give --measured FILE (a goniometric curve)");
        };
        if flakescatter::io::files::read_text(path)
            .is_ok_and(|t| flakescatter::io::brdf::looks_like_brdf_table(&t))
        {
            anyhow::bail!(
                "--measured {}: a BRDF table with detector geometry and channels (theta_r_deg, phi_r_deg, brdf_<channel>_per_sr): fit it with `fit --paint`, compare a fitted paint with `compare --params P.json`",
                path.display()
            );
        }
        if flakescatter::io::merl::is_merl_file(path) {
            anyhow::bail!(
                "--measured {}: a MERL BRDF table (R, G, B over every direction): fit it with `fit --paint`, compare a paint with it with `compare --params P.json` or `compare --paint`",
                path.display()
            );
        }
        let all = read_measured(path)
            .with_context(|| format!("reading --measured {}", path.display()))?;
        let Selection {
            theta_i: ti,
            theta_s: ts,
        } = self.selection_deg()?;
        if ti.is_none() && ts.is_none() {
            let n = all.points.len();
            return Ok((all, json!({"points_in_file": n, "points_used": n})));
        }
        let rad = |v: &Option<Vec<f64>>| {
            v.as_ref()
                .map(|v| v.iter().map(|d| d.to_radians()).collect::<Vec<_>>())
        };
        let curve = select(&all, rad(&ti).as_deref(), rad(&ts).as_deref())
            .map_err(|e| anyhow::anyhow!("--theta-i/--theta-s: {e}"))?;
        let used_i: Vec<f64> = curve.incidences().iter().map(|&t| deg_num(t)).collect();
        let mut what = Vec::new();
        if let Some(t) = &self.theta_i {
            what.push(format!("--theta-i {t}"));
        }
        if let Some(t) = &self.theta_s {
            what.push(format!("--theta-s {t}"));
        }
        note(&format!(
            "using {} of {} measured points of {} ({})",
            curve.points.len(),
            all.points.len(),
            path.display(),
            what.join(", ")
        ));
        let echo = json!({
            "theta_i_deg": self.theta_i,
            "theta_s_deg": self.theta_s,
            "incidences_used_deg": used_i,
            "points_in_file": all.points.len(),
            "points_used": curve.points.len(),
        });
        Ok((curve, echo))
    }

    /// Whether the clear coat's reflection is modelled.
    pub fn clearcoat(&self) -> bool {
        !self.no_clearcoat
    }

    /// Settings with the clear coat on unless `--no-clearcoat`.
    pub fn settings(&self) -> Settings {
        self.optics.settings(self.clearcoat())
    }
}

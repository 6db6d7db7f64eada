//! Polarisation flags of `model` and `topo` (docs/cli.md "Polarisation"): the Mueller
//! columns, the incident Stokes vector and the analyser in front of the detectors
//! (physics.md §11, SCATMECH's bases).
//!
//! Without any of these flags the commands take the scalar path (`m00`, or `m00 ± m01`
//! for `--transmission s|p`, exact in every direction). Any of them takes the Mueller
//! path, which `--transmission s|p|paper` would contradict, so that combination is
//! refused with a pointer to the one spelling that works.

use anyhow::{anyhow, bail};
use flakescatter::Polarimetry;
use flakescatter::optics::mueller::{Analyzer, Stokes};
use flakescatter::optics::polarization::Transmission;
use serde_json::{Value, json};

/// What `--polarization` adds to the output.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum PolarizationKind {
    /// The BRDF the detectors read, no Mueller columns (default).
    Scalar,
    /// Also the cone-averaged Mueller BRDF, columns m00 … m33 (1/sr, row-major), and
    /// the degree of polarisation for unpolarised incidence.
    Mueller,
}

/// Polarisation flags (docs/cli.md "Polarisation").
#[derive(Debug, Clone, clap::Args)]
pub struct PolarizationArgs {
    /// `mueller` adds the columns m00 … m33 (cone-averaged Mueller BRDF, 1/sr,
    /// row-major, detector-axis basis as SCATMECH defines it) and dop_unpolarized.
    #[arg(long, value_enum, value_name = "K", default_value = "scalar")]
    pub polarization: PolarizationKind,
    /// Incident polarisation: `unpolarized`, `s`, `p`, or a Stokes vector `S0,S1,S2,S3`
    /// in the incident direction's (s, p) basis (S1 > 0 is s, S3 > 0 left circular);
    /// normalised to S0 = 1. The default is unpolarised light.
    #[arg(long, value_name = "STATE", allow_hyphen_values = true)]
    pub incident: Option<String>,
    /// Ideal polariser in front of every detector: `none`, `s`, `p`, or the fully
    /// polarised Stokes vector `S0,S1,S2,S3` it passes, in the detector axis' (s, p)
    /// basis. The default is none (every polarisation detected).
    #[arg(long, value_name = "STATE", allow_hyphen_values = true)]
    pub analyzer: Option<String>,
}

impl PolarizationArgs {
    /// The polarisation flags that were given, as typed (for messages).
    fn given(&self) -> Vec<String> {
        let mut v = Vec::new();
        if self.polarization == PolarizationKind::Mueller {
            v.push("--polarization mueller".to_owned());
        }
        if let Some(s) = &self.incident {
            v.push(format!("--incident {s}"));
        }
        if let Some(s) = &self.analyzer {
            v.push(format!("--analyzer {s}"));
        }
        v
    }

    /// Whether the Mueller columns are written.
    pub fn elements(&self) -> bool {
        self.polarization == PolarizationKind::Mueller
    }

    /// The polarimetry the flags ask for, `None` when none was given (scalar path);
    /// refuses `--transmission` values other than the default alongside them, and
    /// invalid Stokes vectors, naming the flag.
    pub fn polarimetry(&self, transmission: Transmission) -> anyhow::Result<Option<Polarimetry>> {
        let given = self.given();
        if given.is_empty() {
            return Ok(None);
        }
        match transmission {
            Transmission::ExactUnpolarized => {}
            Transmission::S | Transmission::P => bail!(
                "--transmission {t} and {g} both set the polarisation: give it once, with --incident (--transmission {t} alone is --incident {t} with no analyser, exact in every direction)",
                t = transmission.name(),
                g = given.join(", ")
            ),
            Transmission::Paper => bail!(
                "--transmission paper is the paper's approximation (a product of averaged Fresnel factors) and has no Mueller form; drop it to use {}",
                given.join(", ")
            ),
        }
        let incident = match &self.incident {
            None => Stokes::UNPOLARIZED,
            Some(text) => parse_state("--incident", text, &["unpolarized", "unpolarised"])?
                .unwrap_or(Stokes::UNPOLARIZED),
        };
        let analyzer = match &self.analyzer {
            None => Analyzer::None,
            Some(text) => match parse_state("--analyzer", text, &["none"])? {
                None => Analyzer::None,
                Some(state) => {
                    Analyzer::polarizer(state).map_err(|e| anyhow!("--analyzer {text}: {e}"))?
                }
            },
        };
        Ok(Some(Polarimetry { incident, analyzer }))
    }

    /// The flags and what they stand for, for JSON metadata.
    pub fn echo(&self, p: &Polarimetry) -> Value {
        json!({
            "polarization": match self.polarization {
                PolarizationKind::Scalar => "scalar",
                PolarizationKind::Mueller => "mueller",
            },
            "incident": self.incident.as_deref().unwrap_or("unpolarized"),
            "incident_stokes": p.incident.normalized().parameters(),
            "analyzer": self.analyzer.as_deref().unwrap_or("none"),
            "analyzer_row": p.analyzer.row(),
        })
    }
}

/// `s`, `p`, one of `none_words` (→ `None`) or four numbers `S0,S1,S2,S3`, checked to be
/// the Stokes vector of a beam (finite, S0 > 0, degree of polarisation ≤ 1).
fn parse_state(flag: &str, text: &str, none_words: &[&str]) -> anyhow::Result<Option<Stokes>> {
    let t = text.trim();
    let lower = t.to_ascii_lowercase();
    if none_words.contains(&lower.as_str()) {
        return Ok(None);
    }
    match lower.as_str() {
        "s" => return Ok(Some(Stokes::S)),
        "p" => return Ok(Some(Stokes::P)),
        _ => {}
    }
    let expected = format!(
        "expected {}, s, p or a Stokes vector of four numbers S0,S1,S2,S3 (e.g. 1,0,0,1 for left circular)",
        none_words[0]
    );
    let parts: Vec<&str> = t.split(',').map(str::trim).collect();
    let values: Option<Vec<f64>> = parts.iter().map(|p| p.parse::<f64>().ok()).collect();
    let Some(Ok(s)) = values.map(<[f64; 4]>::try_from) else {
        bail!("{flag} {text}: {expected}");
    };
    if !s.iter().all(|v| v.is_finite()) {
        bail!("{flag} {text}: the Stokes parameters must be finite numbers");
    }
    if !(s[0] > 0.0) {
        bail!("{flag} {text}: S0 (the power) must be > 0");
    }
    // Scaled before any square (optics::stokes): subnormal and huge vectors are
    // normalised, not refused.
    Stokes::new(s)
        .map(Some)
        .map_err(|e| anyhow!("{flag} {text}: {e}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(incident: Option<&str>, analyzer: Option<&str>) -> PolarizationArgs {
        PolarizationArgs {
            polarization: PolarizationKind::Scalar,
            incident: incident.map(str::to_owned),
            analyzer: analyzer.map(str::to_owned),
        }
    }

    #[test]
    fn states_parse_by_name_and_by_stokes_vector() {
        let p = args(Some("S"), Some("p"))
            .polarimetry(Transmission::ExactUnpolarized)
            .unwrap()
            .unwrap();
        assert_eq!(p.incident, Stokes::S);
        assert_eq!(p.analyzer.row(), [0.5, -0.5, 0.0, 0.0]);
        // A Stokes vector is normalised to S0 = 1 where it is used.
        let p = args(Some("2, 0, 0, 2"), None)
            .polarimetry(Transmission::ExactUnpolarized)
            .unwrap()
            .unwrap();
        assert_eq!(p.incident.normalized().parameters(), [1.0, 0.0, 0.0, 1.0]);
        assert!(
            args(None, None)
                .polarimetry(Transmission::S)
                .unwrap()
                .is_none()
        );
    }

    #[test]
    fn bad_states_name_the_flag_and_the_rule() {
        let err = |i: Option<&str>, a: Option<&str>, t: Transmission| {
            args(i, a).polarimetry(t).unwrap_err().to_string()
        };
        let e = err(Some("1,2,0,0"), None, Transmission::ExactUnpolarized);
        assert!(
            e.starts_with("--incident 1,2,0,0") && e.contains("is 2, above 1"),
            "{e}"
        );
        // Just beyond the rounding tolerance: the digits that differ from 1 are shown.
        let e = err(
            Some("1,1.00000001,0,0"),
            None,
            Transmission::ExactUnpolarized,
        );
        assert!(
            e.contains("is 1.00000001") && e.contains("(1 + 1.0e-8), above 1"),
            "{e}"
        );
        let e = err(Some("0,0,0,0"), None, Transmission::ExactUnpolarized);
        assert!(e.contains("S0 (the power) must be > 0"), "{e}");
        let e = err(Some("1,0,0,inf"), None, Transmission::ExactUnpolarized);
        assert!(e.contains("finite"), "{e}");
        let e = err(Some("1,0,0"), None, Transmission::ExactUnpolarized);
        assert!(e.contains("four numbers S0,S1,S2,S3"), "{e}");
        let e = err(None, Some("1,0.5,0,0"), Transmission::ExactUnpolarized);
        assert!(
            e.starts_with("--analyzer 1,0.5,0,0")
                && e.contains("degree of polarisation 0.5 (within"),
            "{e}"
        );
        let e = err(None, Some("unpolarized"), Transmission::ExactUnpolarized);
        assert!(e.contains("expected none, s, p"), "{e}");
        let e = err(Some("s"), None, Transmission::S);
        assert!(e.contains("--incident s"), "{e}");
        let e = err(None, Some("p"), Transmission::Paper);
        assert!(
            e.contains("--transmission paper") && e.contains("no Mueller form"),
            "{e}"
        );
    }
}

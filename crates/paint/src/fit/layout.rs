//! The parameter vector of the joint fit: which entry is what, its bounds, finite
//! difference step and transform to the physical parameter.
//!
//! Entries, in order: the orientation family's shape (Gaussian `ln hwhm`; Trowbridge–
//! Reitz `ln α`; Pearson VII `ln α`, `ln γ`; log-linear `ln p̃` at every knot but the
//! first, which is 0), the coat surface (`ln α`, then the haze fraction `h` and
//! `ln αh` when the haze is fitted), the coat index `n` when fitted, the thickness (nm) of
//! the flake stack's fitted layers when fitted, then per channel the
//! flake and the base amplitude: `ln(c s_k)` and `ln((1 − c)² ρ_k)` when the coverage is
//! free (the data fix only these products: physics.md §12.5), or `ln s_k` and `ln ρ_k`
//! at a given coverage; last, when the binder's tint is fitted
//! ([`Layout::with_tint`]), per channel the tint `t_k` (physics.md §12.9), in
//! `[0, MAX_TINT]`.

use flakescatter_stats::{GaussianWidth, Orientation};

use crate::PaintError;
use crate::coat::CoatParams;

/// An orientation family of the fit.
#[derive(Debug, Clone, PartialEq)]
pub enum Family {
    /// Gaussian `p̃ ∝ exp(−θ²/(2s²))`, its hwhm fitted.
    Gaussian,
    /// Trowbridge–Reitz (GGX), its slope scale fitted.
    TrowbridgeReitz,
    /// Pearson VII, slope scale and shape fitted.
    PearsonVii,
    /// Log-linear table: `ln p̃` at these knots (radians, the first 0) fitted, with a
    /// smoothness penalty on its second differences.
    LogLinear {
        /// The knots, radians.
        knots: Vec<f64>,
    },
}

impl Family {
    /// The command-line name.
    #[must_use]
    pub fn name(&self) -> &'static str {
        match self {
            Self::Gaussian => "gaussian",
            Self::TrowbridgeReitz => "trowbridge-reitz",
            Self::PearsonVii => "pearson-vii",
            Self::LogLinear { .. } => "table",
        }
    }

    /// The default knots of the log-linear table, radians: 0, 1, 2, 3.5, 5.5, 8, 11, 15,
    /// 20, 26, 33, 42, 55, 70, 90° (closer near the normal, where flake light is sharp).
    #[must_use]
    pub fn default_knots() -> Vec<f64> {
        [
            0.0, 1.0, 2.0, 3.5, 5.5, 8.0, 11.0, 15.0, 20.0, 26.0, 33.0, 42.0, 55.0, 70.0, 90.0,
        ]
        .iter()
        .map(|d: &f64| d.to_radians())
        .collect()
    }

    /// The families of a choice by name, as the command line and manifests give it:
    /// `auto` (every family, [`Family::all`]) or one family's [`Family::name`].
    ///
    /// # Errors
    /// [`PaintError::Parameter`] for another name, listing [`Family::CHOICES`].
    pub fn choice(name: &str) -> Result<Vec<Self>, PaintError> {
        if name == "auto" {
            return Ok(Self::all());
        }
        Self::all()
            .into_iter()
            .find(|f| f.name() == name)
            .map(|f| vec![f])
            .ok_or_else(|| {
                PaintError::Parameter(format!(
                    "orientation family `{name}`: expected {}",
                    Self::CHOICES
                ))
            })
    }

    /// The names [`Family::choice`] takes.
    pub const CHOICES: &'static str = "auto, gaussian, trowbridge-reitz, pearson-vii or table";

    /// The four families, the table on its default knots.
    #[must_use]
    pub fn all() -> Vec<Self> {
        vec![
            Self::Gaussian,
            Self::TrowbridgeReitz,
            Self::PearsonVii,
            Self::LogLinear {
                knots: Self::default_knots(),
            },
        ]
    }

    /// Number of shape parameters.
    #[must_use]
    pub fn shape_len(&self) -> usize {
        match self {
            Self::Gaussian | Self::TrowbridgeReitz => 1,
            Self::PearsonVii => 2,
            Self::LogLinear { knots } => knots.len() - 1,
        }
    }
}

/// How the per-channel amplitudes are parametrised (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Amplitudes {
    /// `ln(c s_k)`, `ln((1 − c)² ρ_k)`.
    Free,
    /// `ln s_k`, `ln ρ_k` at this coverage.
    Coverage(f64),
}

/// The layout (module docs).
#[derive(Debug, Clone)]
pub(crate) struct Layout {
    pub family: Family,
    pub haze: bool,
    pub n_fixed: f64,
    pub channels: usize,
    pub amplitudes: Amplitudes,
    pub names: Vec<String>,
    pub bounds: Vec<(f64, f64)>,
    pub steps: Vec<f64>,
    coat: usize,
    n_index: Option<usize>,
    thickness_index: Option<usize>,
    amp: usize,
    tint_index: Option<usize>,
    channel_names: Vec<String>,
}

/// The largest binder tint (optical depth over the flakes at normal incidence) a fit
/// may reach: `exp(−2·5)` at normal incidence, far darker than any paint's flakes.
pub const MAX_TINT: f64 = 5.0;

/// Where a fit's tints start when no earlier fit gives them.
const TINT_START: f64 = 0.1;

/// Bounds of the log-linear table's `ln p̃` (relative to its value at 0).
const LN_P_BOUNDS: (f64, f64) = (-80.0, 30.0);

impl Layout {
    pub(crate) fn new(
        family: Family,
        haze: bool,
        fit_n: bool,
        n: f64,
        channel_names: &[String],
        amplitudes: Amplitudes,
        thickness: Option<(f64, f64)>,
    ) -> Self {
        let mut entries: Vec<(String, (f64, f64), f64)> = Vec::new();
        let mut push = |name: String, b: (f64, f64), h: f64| {
            entries.push((name, b, h));
            entries.len()
        };
        match &family {
            Family::Gaussian => {
                push(
                    "ln hwhm".into(),
                    (0.05f64.to_radians().ln(), 60f64.to_radians().ln()),
                    1e-5,
                );
            }
            Family::TrowbridgeReitz => {
                push("ln alpha".into(), (1e-4f64.ln(), 2f64.ln()), 1e-5);
            }
            Family::PearsonVii => {
                push("ln alpha".into(), (1e-4f64.ln(), 2f64.ln()), 1e-5);
                push("ln shape".into(), (0.56f64.ln(), 1e3f64.ln()), 1e-5);
            }
            Family::LogLinear { knots } => {
                for k in &knots[1..] {
                    push(
                        format!("ln p~({:.1} deg)", k.to_degrees()),
                        LN_P_BOUNDS,
                        1e-5,
                    );
                }
            }
        }
        let coat = push(
            "ln coat roughness".into(),
            (1e-3f64.ln(), crate::coat::MAX_ROUGHNESS.ln()),
            1e-5,
        ) - 1;
        if haze {
            push("haze".into(), (0.0, 1.0), 1e-6);
            push(
                "ln haze roughness".into(),
                (0.02f64.ln(), crate::coat::MAX_ROUGHNESS.ln()),
                1e-5,
            );
        }
        let n_index = if fit_n {
            Some(push("n".into(), (1.0, 2.5), 1e-6) - 1)
        } else {
            None
        };
        // nm: steps of 1e-3 nm resolve the model's change (an interference fringe moves
        // over tens of nm).
        let thickness_index = thickness.map(|b| push("thickness (nm)".into(), b, 1e-3) - 1);
        let amp = thickness_index
            .or(n_index)
            .map_or(coat + if haze { 3 } else { 1 }, |i| i + 1);
        let (fa, ba) = match amplitudes {
            Amplitudes::Free => ("ln flake amplitude", "ln base amplitude"),
            Amplitudes::Coverage(_) => ("ln flake scale", "ln base albedo"),
        };
        for c in channel_names {
            push(format!("{fa} {c}"), (1e-6f64.ln(), 0.0), 1e-5);
        }
        for c in channel_names {
            push(format!("{ba} {c}"), (1e-9f64.ln(), 0.0), 1e-5);
        }
        let names = entries.iter().map(|e| e.0.clone()).collect();
        let bounds = entries.iter().map(|e| e.1).collect();
        let steps = entries.iter().map(|e| e.2).collect();
        Self {
            family,
            haze,
            n_fixed: n,
            channels: channel_names.len(),
            amplitudes,
            names,
            bounds,
            steps,
            coat,
            n_index,
            thickness_index,
            amp,
            tint_index: None,
            channel_names: channel_names.to_vec(),
        }
    }

    /// This layout with the binder's tint of every channel fitted too when `on` (its
    /// entries appended after the amplitudes; module docs).
    pub(crate) fn with_tint(mut self, on: bool) -> Self {
        if on && self.tint_index.is_none() {
            self.tint_index = Some(self.names.len());
            for c in &self.channel_names {
                self.names.push(format!("tint {c}"));
                self.bounds.push((0.0, MAX_TINT));
                self.steps.push(1e-5);
            }
        }
        self
    }

    /// Index of channel 0's tint, when fitted (channel `k`'s is `k` further).
    pub(crate) fn tint_index(&self) -> Option<usize> {
        self.tint_index
    }

    /// Channel `k`'s tint (0 when not fitted).
    pub(crate) fn tint(&self, q: &[f64], k: usize) -> f64 {
        self.tint_index.map_or(0.0, |i| q[i + k])
    }

    /// Start values of the tint entries: `from`'s (another fit's) when it has them,
    /// else a small tint inside the range.
    pub(crate) fn start_tints(&self, q0: &mut [f64], from: Option<(&Layout, &[f64])>) {
        if let Some(i) = self.tint_index {
            for k in 0..self.channels {
                q0[i + k] = match from {
                    Some((l, q)) if l.tint_index.is_some() && l.channels == self.channels => {
                        l.tint(q, k)
                    }
                    _ => TINT_START,
                };
            }
        }
    }

    /// Number of parameters.
    pub(crate) fn len(&self) -> usize {
        self.names.len()
    }

    /// The shape entries.
    pub(crate) fn shape<'q>(&self, q: &'q [f64]) -> &'q [f64] {
        &q[..self.family.shape_len()]
    }

    /// The orientation distribution of `q`.
    pub(crate) fn orientation(&self, q: &[f64]) -> Result<Orientation, PaintError> {
        let e = |e: flakescatter_stats::DistributionError| PaintError::Fit(e.to_string());
        match &self.family {
            Family::Gaussian => Orientation::gaussian(GaussianWidth::Hwhm(q[0].exp())).map_err(e),
            Family::TrowbridgeReitz => Orientation::trowbridge_reitz(q[0].exp()).map_err(e),
            Family::PearsonVii => Orientation::pearson_vii(q[0].exp(), q[1].exp()).map_err(e),
            Family::LogLinear { knots } => {
                let mut ln = Vec::with_capacity(knots.len());
                ln.push(0.0);
                ln.extend_from_slice(&q[..knots.len() - 1]);
                Orientation::log_linear(knots.clone(), ln).map_err(e)
            }
        }
    }

    /// The coat entries' parameters.
    pub(crate) fn coat(&self, q: &[f64]) -> CoatParams {
        let (haze, haze_roughness) = if self.haze {
            (q[self.coat + 1], q[self.coat + 2].exp())
        } else {
            (0.0, 0.0)
        };
        CoatParams {
            n: self.n(q),
            roughness: q[self.coat].exp(),
            haze,
            haze_roughness,
        }
    }

    /// The coat entries, for cache keys.
    pub(crate) fn coat_entries<'q>(&self, q: &'q [f64]) -> &'q [f64] {
        let end = if self.haze {
            self.coat + 3
        } else {
            self.coat + 1
        };
        &q[self.coat..end]
    }

    /// The coat index.
    pub(crate) fn n(&self, q: &[f64]) -> f64 {
        self.n_index.map_or(self.n_fixed, |i| q[i])
    }

    /// Index of the stack thickness, when fitted.
    pub(crate) fn thickness_index(&self) -> Option<usize> {
        self.thickness_index
    }

    /// The fitted stack thickness (nm), when fitted.
    pub(crate) fn thickness(&self, q: &[f64]) -> Option<f64> {
        self.thickness_index.map(|i| q[i])
    }

    /// The flake amplitude `c s_k` of channel `k`.
    pub(crate) fn flake_amplitude(&self, q: &[f64], k: usize) -> f64 {
        let v = q[self.amp + k].exp();
        match self.amplitudes {
            Amplitudes::Free => v,
            Amplitudes::Coverage(c) => c * v,
        }
    }

    /// The base amplitude `(1 − c)² ρ_k` of channel `k`.
    pub(crate) fn base_amplitude(&self, q: &[f64], k: usize) -> f64 {
        let v = q[self.amp + self.channels + k].exp();
        match self.amplitudes {
            Amplitudes::Free => v,
            Amplitudes::Coverage(c) => (1.0 - c) * (1.0 - c) * v,
        }
    }

    /// Index of channel `k`'s flake entry; its base entry is `channels` further.
    pub(crate) fn amplitude_index(&self, k: usize) -> usize {
        self.amp + k
    }

    /// Index of the coat roughness entry (haze and haze roughness follow when fitted).
    pub(crate) fn coat_index(&self) -> usize {
        self.coat
    }

    /// Index of `n`, when fitted.
    pub(crate) fn n_index(&self) -> Option<usize> {
        self.n_index
    }

    /// The log-linear table's second-difference penalty rows, weight `lambda`: the
    /// change of slope of `ln p̃` (per radian) at each inner knot.
    pub(crate) fn penalty(&self, q: &[f64], lambda: f64, out: &mut Vec<f64>) {
        if let Family::LogLinear { knots } = &self.family {
            let ln = |j: usize| if j == 0 { 0.0 } else { q[j - 1] };
            for j in 1..knots.len() - 1 {
                let left = (ln(j) - ln(j - 1)) / (knots[j] - knots[j - 1]);
                let right = (ln(j + 1) - ln(j)) / (knots[j + 1] - knots[j]);
                out.push(lambda * (right - left));
            }
        }
    }

    /// Shape entries that reproduce `o` as closely as the family allows (the start of a
    /// fit from another family's result): the log-linear table samples `ln p̃` of `o`
    /// at its knots; the others match `o`'s narrowest feature.
    pub(crate) fn shape_from(&self, o: &Orientation) -> Vec<f64> {
        let clamp = |v: f64, j: usize| v.clamp(self.bounds[j].0, self.bounds[j].1);
        match &self.family {
            Family::Gaussian => vec![clamp((o.narrowest_feature() * 1.1774).ln(), 0)],
            Family::TrowbridgeReitz => vec![clamp(o.narrowest_feature().tan().ln(), 0)],
            Family::PearsonVii => match o.pearson_vii_params() {
                Some((a, g)) => vec![clamp(a.ln(), 0), clamp(g.ln(), 1)],
                None => vec![clamp(o.narrowest_feature().tan().ln(), 0), 0.0],
            },
            Family::LogLinear { knots } => {
                let p0 = o.p2(0.0).max(1e-300);
                knots[1..]
                    .iter()
                    .enumerate()
                    .map(|(j, &k)| {
                        // Just inside the support, so that p2 is not zero at its end.
                        let t = k.min(o.support_end() * (1.0 - 1e-9));
                        let p = o.p2(t);
                        let v = if p > 0.0 {
                            (p / p0).ln()
                        } else {
                            LN_P_BOUNDS.0
                        };
                        clamp(v, j)
                    })
                    .collect()
            }
        }
    }
}

//! The joint fit of a paint to a measured BRDF table (physics.md §12.5): one parameter
//! set for every incidence and every row, in and out of the plane.
//!
//! The orientation distribution, the coat surface (and index, optionally) are shared by
//! every channel; each channel has a flake and a base amplitude. Residuals are
//! `(ln m − ln y)/σ` with `σ = u/y` from the table's uncertainty columns, or `σ = 1` for
//! every point without them (relative weighting: every point counts the same in log).
//! The minimiser is [`flakescatter_numerics::lm`]. The log-linear table adds penalty rows
//! `λ · Δ(d ln p̃/dθ)` at its inner knots (`λ` = [`FitOptions::smoothing`]).
//!
//! **Coverage.** The BRDF depends on the coverage `c` only through `c s_k` and
//! `(1 − c)² ρ_k` (physics.md §12.5): a table cannot tell more flakes of a duller metal
//! from fewer bright ones. So the fit estimates these amplitudes, reports the interval
//! of `c` in which every `s_k ≤ 1` and `ρ_k ≤ 1`, and gives `s_k`, `ρ_k` at a coverage:
//! the one given ([`FitOptions::coverage`], e.g. measured on a confocal map), or the
//! interval's middle. When the interval is empty the fit is repeated at the coverage
//! closest to both conditions with `s_k`, `ρ_k` held in `[0, 1]`, and warns.
//!
//! **Uncertainties.** `(JᵀJ)⁻¹` at the optimum, scaled by `χ²/dof` as
//! [`flakescatter_numerics::lm::noise_scale`] says; 95 % intervals are
//! `estimate ± t(0.975, dof) σ` in the fitted (mostly logarithmic) parameters, mapped to
//! the physical ones (so they are asymmetric for `ln` parameters); correlations of the
//! fitted parameters. Warnings flag a poor fit, a parameter on a bound, few points per
//! parameter, an empty coverage interval and parameters known to less than ±50 %.

pub mod data;
mod engine;
mod layers;
mod layout;
pub mod report;
mod result;
mod solve;
pub mod thickness;

use crate::PaintError;
use crate::coat::CoatParams;
use crate::model::FlakeMetal;
pub use data::{Measurement, Observation, Point, Selection, select};
pub use layers::{LayersFit, MAX_SCAN, fit_flake_layers, fit_flake_layers_with};
use layout::{Amplitudes, Layout};
pub use layout::{Family, MAX_TINT};
pub use report::{Evidence, GroupResidual, Region, group_residuals};
pub use result::{Candidate, CoverageChoice, Estimate, PaintFit, PaintFitWarning};
use result::{Selected, finish};
use solve::{Solved, solve};
pub use thickness::ThicknessFit;

/// Options of the joint fit.
#[derive(Debug, Clone, PartialEq)]
pub struct FitOptions {
    /// Families to fit; the one with the lowest BIC is kept (all are reported).
    pub families: Vec<Family>,
    /// Coat index (the start value when fitted).
    pub n: f64,
    /// Fit the coat index too.
    pub fit_n: bool,
    /// The flakes' coverage, if known (module docs); `None`: the middle of the interval
    /// the data allow.
    pub coverage: Option<f64>,
    /// The flake metal.
    pub flake_metal: FlakeMetal,
    /// The points used.
    pub selection: Selection,
    /// Fit a haze population of the coat surface (default on).
    pub haze: bool,
    /// `λ` of the log-linear table's smoothness penalty (default 0.01).
    pub smoothing: f64,
    /// Fit the thickness of these layers of the flake stack (default none; needs
    /// [`FlakeMetal::Stack`] flakes): [`thickness`].
    pub thickness: Option<ThicknessFit>,
}

impl FitOptions {
    /// Defaults: every family, `n` = 1.5 fixed, aluminium flakes, the default selection,
    /// haze fitted, `λ` = 0.01.
    #[must_use]
    pub fn new() -> Self {
        Self {
            families: Family::all(),
            n: 1.5,
            fit_n: false,
            coverage: None,
            flake_metal: FlakeMetal::Aluminium,
            selection: Selection::default(),
            haze: true,
            smoothing: 0.01,
            thickness: None,
        }
    }
}

impl Default for FitOptions {
    fn default() -> Self {
        Self::new()
    }
}

/// Parameters a fit may add to those [`FitOptions`] sets up (kept apart from
/// [`FitOptions`], whose literals callers write out in full; the default adds none).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FitExtras {
    /// Fit the binder's tint over the flakes in every channel (physics.md §12.9): the
    /// optical depths `t_k ∈ [0, MAX_TINT]` join the joint fit (started at 0.1, or at
    /// the previous family's), after the amplitudes; the fitted paint's channels carry
    /// them ([`crate::ChannelParams::tint`]).
    pub tint: bool,
}

/// Fit `m` (module docs): [`fit_paint_with`] and no extra parameters.
///
/// # Errors
/// As [`fit_paint_with`].
pub fn fit_paint(m: &Measurement, opts: &FitOptions) -> Result<PaintFit, PaintError> {
    fit_paint_with(m, opts, FitExtras::default())
}

/// Fit `m` (module docs) with the parameters of `opts` and those `extras` adds.
///
/// # Errors
/// [`PaintError::Data`] for unusable data (named file, line, column), too few points;
/// [`PaintError::Parameter`] for bad options; [`PaintError::Fit`] when no family
/// converges.
pub fn fit_paint_with(
    m: &Measurement,
    opts: &FitOptions,
    extras: FitExtras,
) -> Result<PaintFit, PaintError> {
    if opts.families.is_empty() {
        return Err(PaintError::Parameter("no orientation family to fit".into()));
    }
    if let Some(c) = opts.coverage
        && !(0.0..=1.0).contains(&c)
    {
        return Err(PaintError::Parameter(format!(
            "coverage = {c}: expected a fraction in [0, 1]"
        )));
    }
    if !(opts.smoothing.is_finite() && opts.smoothing >= 0.0) {
        return Err(PaintError::Parameter(format!(
            "smoothing = {}: expected a finite value >= 0",
            opts.smoothing
        )));
    }
    if extras.tint && opts.coverage == Some(0.0) {
        return Err(PaintError::Parameter(
            "a fitted tint with coverage 0: without flakes there is no flake light for a tint to change".into(),
        ));
    }
    CoatParams::flat(opts.n).validate()?;
    if let Some(t) = &opts.thickness {
        t.check(&opts.flake_metal)?;
    }
    let (points, have_u) = select(m, &opts.selection)?;
    let names: Vec<String> = m.channels.iter().map(|c| c.name.clone()).collect();
    let amplitudes = opts.coverage.map_or(Amplitudes::Free, Amplitudes::Coverage);
    // A fitted thickness starts at the minimum of a scan (module docs of `thickness`).
    let mut scanned = None;
    let started;
    let opts = match &opts.thickness {
        Some(t) => {
            let (profile, best) = thickness::scan(m, &points, have_u, opts, &names, amplitudes, t)?;
            started = FitOptions {
                flake_metal: opts.flake_metal.with_thickness(&t.layers, best)?,
                ..opts.clone()
            };
            scanned = Some(profile);
            &started
        }
        None => opts,
    };
    let range = opts.thickness.as_ref().map(|t| t.range_nm);

    // Families in order, each starting from the best result so far; the log-linear
    // table and Pearson VII start from a Trowbridge–Reitz fit when there is none.
    let mut order = opts.families.clone();
    let needs_start = order
        .iter()
        .any(|f| matches!(f, Family::LogLinear { .. } | Family::PearsonVii));
    if needs_start && !order.contains(&Family::TrowbridgeReitz) {
        order.insert(0, Family::TrowbridgeReitz);
    }
    order.sort_by_key(|f| match f {
        Family::Gaussian => 0,
        Family::TrowbridgeReitz => 1,
        Family::PearsonVii => 2,
        Family::LogLinear { .. } => 3,
    });
    let mut candidates = Vec::new();
    let mut best: Option<Solved> = None;
    let mut last_error = None;
    for family in order {
        let layout = Layout::new(
            family.clone(),
            opts.haze,
            opts.fit_n,
            opts.n,
            &names,
            amplitudes,
            range,
        )
        .with_tint(extras.tint);
        match solve(m, &points, have_u, layout, opts, best.as_ref()) {
            Ok(s) => {
                if opts.families.contains(&family) {
                    candidates.push(Candidate {
                        family: family.clone(),
                        evidence: s.evidence,
                    });
                }
                let better = best.as_ref().is_none_or(|b| {
                    !opts.families.contains(&b.layout.family) || s.evidence.bic < b.evidence.bic
                });
                if better || !opts.families.contains(&family) && best.is_none() {
                    best = Some(s);
                }
            }
            Err(e) => last_error = Some(e),
        }
    }
    let Some(mut solved) = best.filter(|b| opts.families.contains(&b.layout.family)) else {
        return Err(last_error.unwrap_or_else(|| PaintError::Fit("no family converged".into())));
    };

    let mut warnings = Vec::new();
    // Coverage (module docs).
    let coverage = match opts.coverage {
        Some(c) => coverage_bounds(&solved, c, true),
        None => {
            let mut choice = coverage_bounds(&solved, 0.0, false);
            if choice.min <= choice.max {
                choice.used = 0.5 * (choice.min + choice.max);
            } else {
                warnings.push(PaintFitWarning::CoverageInfeasible {
                    min: choice.min,
                    max: choice.max,
                });
                let c = (0.5 * (choice.min + choice.max)).clamp(0.0, 1.0);
                let layout = Layout::new(
                    solved.layout.family.clone(),
                    opts.haze,
                    opts.fit_n,
                    opts.n,
                    &names,
                    Amplitudes::Coverage(c),
                    range,
                )
                .with_tint(extras.tint);
                let refit = solve(m, &points, have_u, layout, opts, Some(&solved))?;
                solved = refit;
                choice.used = c;
            }
            choice
        }
    };
    let selected = Selected {
        solved,
        coverage,
        candidates,
        warnings,
        thickness_scan: scanned,
    };
    finish(m, points, have_u, selected, opts)
}

/// The coverage interval of a solution; `used` is `c` (or filled in by the caller).
fn coverage_bounds(s: &Solved, c: f64, given: bool) -> CoverageChoice {
    let q = &s.fit.x;
    let l = &s.layout;
    let (mut min, mut max) = (0.0f64, 1.0f64);
    for k in 0..l.channels {
        min = min.max(l.flake_amplitude(q, k));
        max = max.min(1.0 - l.base_amplitude(q, k).sqrt());
    }
    CoverageChoice {
        used: c,
        min,
        max,
        given,
    }
}

/// The model `model` at the points of `m` within `sel` (no fit): the points, and the
/// model's value at each, sr⁻¹.
///
/// # Errors
/// As [`select`]; [`PaintError::Data`] when a channel of `m` is not in the model (named),
/// [`PaintError::Geometry`] for an incidence out of range.
pub fn evaluate(
    model: &crate::PaintModel,
    m: &Measurement,
    sel: &Selection,
) -> Result<(Vec<Point>, Vec<f64>), PaintError> {
    let index: Vec<usize> = m
        .channels
        .iter()
        .map(|c| {
            model.channel_index(&c.name).ok_or_else(|| {
                PaintError::Data(format!(
                    "{}: channel `{}` (column brdf_{}_per_sr) is not in the paint's parameters, which have {}",
                    m.file,
                    c.name,
                    c.name,
                    model
                        .params()
                        .channels
                        .iter()
                        .map(|c| c.channel.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ))
            })
        })
        .collect::<Result<_, _>>()?;
    let (points, _) = select(m, sel)?;
    let mut incidences: Vec<(f64, crate::PaintIncidence)> = Vec::new();
    let mut values = Vec::with_capacity(points.len());
    for p in &points {
        let o = &m.rows[p.row];
        let inc = match incidences.iter().position(|(t, _)| *t == o.theta_i) {
            Some(i) => i,
            None => {
                incidences.push((o.theta_i, model.incidence(o.theta_i)?));
                incidences.len() - 1
            }
        };
        values.push(model.brdf(&incidences[inc].1, &o.direction(), index[p.channel]));
    }
    Ok((points, values))
}

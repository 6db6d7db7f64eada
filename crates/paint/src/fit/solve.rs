//! One family's fit: start values (from another family's result or defaults; the
//! amplitudes by non-negative least squares) and the minimisation.

use flakescatter_numerics::lm::{self, LmError};
use flakescatter_numerics::nnls::nnls;
use flakescatter_stats::Orientation;
use nalgebra::{DMatrix, DVector};

use super::FitOptions;
use super::data::{Measurement, Point};
use super::engine::Engine;
use super::layout::{Amplitudes, Family, Layout};
use super::report::Evidence;
use crate::PaintError;

/// One family's converged fit.
pub(super) struct Solved {
    pub(super) layout: Layout,
    pub(super) fit: lm::Fit,
    pub(super) orientation: Orientation,
    pub(super) model: Vec<f64>,
    pub(super) evidence: Evidence,
}

/// Fit one layout from `start` (another family's solution) or the defaults.
pub(super) fn solve(
    m: &Measurement,
    points: &[Point],
    have_u: bool,
    layout: Layout,
    opts: &FitOptions,
    start: Option<&Solved>,
) -> Result<Solved, PaintError> {
    let np = layout.len();
    if points.len() <= np {
        return Err(PaintError::Data(format!(
            "{}: {} points are too few for {np} parameters",
            m.file,
            points.len()
        )));
    }
    let layers = opts.thickness.as_ref().map_or(&[][..], |t| &t.layers[..]);
    let engine = Engine::new(
        m,
        points,
        &layout,
        opts.flake_metal.clone(),
        layers,
        opts.smoothing,
    );
    let mut q0 = start_values(&layout, opts, start)?;
    // Amplitudes: non-negative least squares on relative residuals per channel, with
    // the shape and coat of q0 (the model is linear in them up to the base's small
    // denominator), unless the start has them.
    start_amplitudes(&engine, &layout, points, &mut q0, start)?;
    let fit = lm::minimise(
        |q: &[f64]| engine.residuals(q),
        &q0,
        &layout.bounds,
        &layout.steps,
        lm::Settings {
            max_iterations: 400,
            max_tries: 30,
            // A thousandth of what one parameter fitting noise would take off χ².
            min_relative_decrease: Some(1e-3 / (points.len() - np) as f64),
        },
    )
    .map_err(|e| match e {
        LmError::Model(e) => e,
        LmError::NotConverged { iterations, .. } => PaintError::Fit(format!(
            "the {} fit did not converge in {iterations} iterations",
            layout.family.name()
        )),
        other => PaintError::Fit(format!("the {} fit failed: {other}", layout.family.name())),
    })?;
    let model = engine.values(&fit.x)?;
    let chi2: f64 = fit.residuals[..points.len()].iter().map(|r| r * r).sum();
    let orientation = layout.orientation(&fit.x)?;
    let evidence = Evidence::new(chi2, points.len(), np, have_u);
    Ok(Solved {
        layout,
        fit,
        orientation,
        model,
        evidence,
    })
}

/// Start values of the shape, the coat, `n` and the stack thickness (module docs of
/// [`super::thickness`]): from `start` (another fit's result) or the defaults; the
/// amplitudes are left 0 (see [`start_amplitudes`]).
pub(super) fn start_values(
    layout: &Layout,
    opts: &FitOptions,
    start: Option<&Solved>,
) -> Result<Vec<f64>, PaintError> {
    let mut q0 = vec![0.0; layout.len()];
    // Shape.
    let shape = match start {
        Some(s) => layout.shape_from(&s.orientation),
        None => match layout.family {
            Family::Gaussian => vec![8f64.to_radians().ln()],
            Family::TrowbridgeReitz => vec![0.15f64.ln()],
            Family::PearsonVii => vec![0.15f64.ln(), 0.0],
            Family::LogLinear { .. } => {
                let o = Orientation::trowbridge_reitz(0.15)
                    .map_err(|e| PaintError::Fit(e.to_string()))?;
                layout.shape_from(&o)
            }
        },
    };
    q0[..shape.len()].copy_from_slice(&shape);
    // Coat (and n) from the start, or defaults.
    let ci = layout.coat_index();
    match start {
        Some(s) => {
            let c = s.layout.coat(&s.fit.x);
            q0[ci] = c.roughness.max(1e-3).ln();
            if layout.haze {
                q0[ci + 1] = c.haze;
                q0[ci + 2] = c.haze_roughness.max(0.02).ln();
            }
            if let Some(i) = layout.n_index() {
                q0[i] = c.n;
            }
        }
        None => {
            q0[ci] = 0.01f64.ln();
            if layout.haze {
                q0[ci + 1] = 0.1;
                q0[ci + 2] = 0.3f64.ln();
            }
            if let Some(i) = layout.n_index() {
                q0[i] = opts.n;
            }
        }
    }
    if let (Some(i), Some(t)) = (layout.thickness_index(), &opts.thickness) {
        q0[i] = start
            .and_then(|s| s.layout.thickness(&s.fit.x))
            .unwrap_or_else(|| super::thickness::start(t, &opts.flake_metal));
    }
    layout.start_tints(&mut q0, start.map(|s| (&s.layout, &s.fit.x[..])));
    Ok(q0)
}

/// Start values of the amplitudes (see [`solve`]).
pub(super) fn start_amplitudes(
    engine: &Engine<'_>,
    layout: &Layout,
    points: &[Point],
    q0: &mut [f64],
    start: Option<&Solved>,
) -> Result<(), PaintError> {
    let nc = layout.channels;
    if let Some(s) = start
        && s.layout.channels == nc
    {
        for k in 0..nc {
            let (a, b) = (
                s.layout.flake_amplitude(&s.fit.x, k),
                s.layout.base_amplitude(&s.fit.x, k),
            );
            set_amplitudes(layout, q0, k, a, b);
        }
        return Ok(());
    }
    // Columns: the flakes alone (flake amplitude 1, base at its floor) and the base alone.
    let lo = |i: usize| layout.bounds[i].0;
    let mut q = q0.to_vec();
    for k in 0..nc {
        q[layout.amplitude_index(k)] = 0.0;
        q[layout.amplitude_index(k) + nc] = lo(layout.amplitude_index(k) + nc);
    }
    let flakes = engine.values(&q)?;
    for k in 0..nc {
        q[layout.amplitude_index(k)] = lo(layout.amplitude_index(k));
        q[layout.amplitude_index(k) + nc] = (0.1f64).ln();
    }
    let base = engine.values(&q)?;
    for k in 0..nc {
        q[layout.amplitude_index(k)] = lo(layout.amplitude_index(k));
        q[layout.amplitude_index(k) + nc] = lo(layout.amplitude_index(k) + nc);
    }
    let coat = engine.values(&q)?;
    for k in 0..nc {
        let idx: Vec<usize> = (0..points.len())
            .filter(|&i| points[i].channel == k)
            .collect();
        let a = DMatrix::from_fn(idx.len(), 2, |r, c| {
            let i = idx[r];
            let v = if c == 0 {
                flakes[i] - coat[i]
            } else {
                base[i] - coat[i]
            };
            v / points[i].value
        });
        let b = DVector::from_iterator(
            idx.len(),
            idx.iter()
                .map(|&i| (points[i].value - coat[i]) / points[i].value),
        );
        let x = nnls(&a, &b).unwrap_or_else(|| DVector::from_vec(vec![0.1, 0.1]));
        // The base column was made at amplitude 0.1.
        set_amplitudes(layout, q0, k, x[0], 0.1 * x[1]);
    }
    Ok(())
}

/// Channel `k`'s fitted amplitude entries in `q0` for the amplitudes `a` (coverage ×
/// flake scale) and `b` ((1 − coverage)² × base albedo): their logarithms, or those of
/// the scale and albedo at a fixed coverage, inside the bounds.
fn set_amplitudes(layout: &Layout, q0: &mut [f64], k: usize, a: f64, b: f64) {
    let (fa, fb) = match layout.amplitudes {
        Amplitudes::Free => (a, b),
        Amplitudes::Coverage(c) => (
            if c > 0.0 { a / c } else { 1.0 },
            if c < 1.0 {
                b / ((1.0 - c) * (1.0 - c))
            } else {
                1.0
            },
        ),
    };
    let i = layout.amplitude_index(k);
    let j = i + layout.channels;
    for (idx, v) in [(i, fa), (j, fb)] {
        q0[idx] = v
            .max(1e-300)
            .ln()
            .clamp(layout.bounds[idx].0, layout.bounds[idx].1);
    }
}

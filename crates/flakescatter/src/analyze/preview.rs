//! What a sample's report previews: the paint fitted to its `[paint]` table, or else the
//! paint its maps predict — the flakes of the pooled width (a Gaussian of the pooled
//! flake-level width) under the manifest's clear coat — tabulated as a MERL table
//! ([`crate::export`]) for a renderer. Rendering is the caller's (the command-line tool
//! runs `flakescatter.mitsuba` when it is installed).

use flakescatter_io::merl::MerlTable;

use crate::export::{BrdfSource, merl_table, paint_rgb};
use crate::paint_model::{PaintModel, PaintParams};
use crate::{Coating, PipelineError, Settings};

/// The model a report's preview shows.
#[derive(Debug, Clone)]
pub enum PreviewModel {
    /// The paint fitted to the sample's `[paint]` table.
    Paint(Box<PaintParams>),
    /// The flakes of the pooled width under the sample's clear coat (grey).
    Flakes {
        /// The pooled orientation distribution (a Gaussian of the pooled width).
        orientation: flakescatter_stats::Orientation,
        /// The coating.
        coating: Coating,
        /// The model settings (the clear coat's specular delta is not tabulated).
        settings: Settings,
    },
}

impl PreviewModel {
    /// Its MERL table, every bin at its centre.
    ///
    /// # Errors
    /// The model's ([`merl_table`]); a paint without r, g, b channels or one channel.
    pub fn table(&self) -> Result<MerlTable, PipelineError> {
        match self {
            Self::Paint(p) => {
                let model = PaintModel::new((**p).clone()).map_err(PipelineError::Paint)?;
                let rgb = paint_rgb(&model)?;
                Ok(merl_table(&BrdfSource::Paint { model: &model, rgb }, &|_, _| {})?.table)
            }
            Self::Flakes {
                orientation,
                coating,
                settings,
            } => {
                let model =
                    crate::pipeline::distribution_model(coating, settings, orientation.clone())?;
                Ok(merl_table(&BrdfSource::Distribution(&model), &|_, _| {})?.table)
            }
        }
    }

    /// What it is, for the report's caption.
    #[must_use]
    pub fn describe(&self) -> String {
        match self {
            Self::Paint(_) => {
                "the paint fitted to the sample's measured BRDF table ([paint])".into()
            }
            Self::Flakes { coating, .. } => format!(
                "the flakes of the pooled width (Gaussian) under a clear coat of index {} (grey; the coat's mirror reflection is not shown)",
                coating.n
            ),
        }
    }
}

//! A thin-film stack written as text, `"TiO2:120/mica:400/TiO2:120"`: layers from the incidence
//! side separated by `/`, each `material:thickness_nm`, a material being a name of the
//! [`Catalogue`] or an index `n+ki`. Resolved to a [`FilmStack`] at each wavelength.

use crate::catalogue::{Catalogue, CatalogueError, MaterialSpec};

use crate::thinfilm::{FilmStack, Layer, MAX_LAYERS};

/// Errors from a stack spec. Layers are numbered from 1, from the incidence side.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StackSpecError {
    /// No layer at all.
    #[error("the stack is empty: expected layers material:thickness_nm separated by '/'")]
    Empty,
    /// More than [`MAX_LAYERS`] layers.
    #[error("{0} layers: expected at most {MAX_LAYERS}")]
    TooManyLayers(usize),
    /// A layer with nothing in it (`a:1//b:2`, a leading or trailing `/`).
    #[error("layer {layer} is empty: expected material:thickness_nm")]
    EmptyLayer {
        /// Layer (1-based).
        layer: usize,
    },
    /// A layer without `:thickness`.
    #[error("layer {layer} {text:?}: no thickness: expected material:thickness_nm")]
    MissingThickness {
        /// Layer (1-based).
        layer: usize,
        /// The layer's text.
        text: String,
    },
    /// A thickness that is not a finite number > 0.
    #[error(
        "layer {layer} {text:?}: thickness {value:?} is not valid: expected a finite number of nm > 0"
    )]
    BadThickness {
        /// Layer (1-based).
        layer: usize,
        /// The layer's text.
        text: String,
        /// The thickness text.
        value: String,
    },
    /// A layer number that the stack does not have (layers are numbered from 1).
    #[error("layer {layer}: the stack has {layers} layer(s), numbered from 1")]
    NoSuchLayer {
        /// The layer asked for.
        layer: usize,
        /// Layers in the stack.
        layers: usize,
    },
    /// The material is not known or its index is not valid.
    #[error("layer {layer} {text:?}: {source}")]
    Material {
        /// Layer (1-based).
        layer: usize,
        /// The layer's text.
        text: String,
        /// What the catalogue said.
        #[source]
        source: CatalogueError,
    },
}

/// A parsed stack spec: each layer's material and thickness (nm).
#[derive(Debug, Clone, PartialEq)]
pub struct StackSpec {
    layers: Vec<(MaterialSpec, f64)>,
}

impl StackSpec {
    /// Parse `text` against `catalogue`.
    ///
    /// # Errors
    /// [`StackSpecError`] naming the first bad layer.
    pub fn parse(text: &str, catalogue: &Catalogue) -> Result<Self, StackSpecError> {
        if text.trim().is_empty() {
            return Err(StackSpecError::Empty);
        }
        let parts: Vec<&str> = text.split('/').collect();
        if parts.len() > MAX_LAYERS {
            return Err(StackSpecError::TooManyLayers(parts.len()));
        }
        let mut layers = Vec::with_capacity(parts.len());
        for (i, part) in parts.iter().enumerate() {
            let layer = i + 1;
            let p = part.trim();
            if p.is_empty() {
                return Err(StackSpecError::EmptyLayer { layer });
            }
            let Some((name, thick)) = p.rsplit_once(':') else {
                return Err(StackSpecError::MissingThickness {
                    layer,
                    text: p.into(),
                });
            };
            let thick_t = thick.trim().trim_end_matches("nm").trim();
            let d: f64 = match thick_t.parse() {
                Ok(d) if f64::is_finite(d) && d > 0.0 => d,
                _ => {
                    return Err(StackSpecError::BadThickness {
                        layer,
                        text: p.into(),
                        value: thick.trim().into(),
                    });
                }
            };
            if name.trim().is_empty() {
                return Err(StackSpecError::EmptyLayer { layer });
            }
            let material = catalogue
                .parse(name)
                .map_err(|source| StackSpecError::Material {
                    layer,
                    text: p.into(),
                    source,
                })?;
            layers.push((material, d));
        }
        Ok(Self { layers })
    }

    /// The layers: material and thickness (nm), from the incidence side.
    #[must_use]
    pub fn layers(&self) -> &[(MaterialSpec, f64)] {
        &self.layers
    }

    /// The same stack with each layer of `layers` (numbered from 1) `thickness_nm` thick:
    /// the layers a thickness fit moves together (e.g. the two TiO2 coats of a
    /// TiO2/mica/TiO2 pigment).
    ///
    /// # Errors
    /// [`StackSpecError::NoSuchLayer`] for a layer number outside `1..=len`,
    /// [`StackSpecError::BadThickness`] unless `thickness_nm` is finite and > 0.
    pub fn with_thickness(
        &self,
        layers: &[usize],
        thickness_nm: f64,
    ) -> Result<Self, StackSpecError> {
        let mut out = self.clone();
        for &layer in layers {
            let Some((m, d)) = layer.checked_sub(1).and_then(|i| out.layers.get_mut(i)) else {
                return Err(StackSpecError::NoSuchLayer {
                    layer,
                    layers: self.layers.len(),
                });
            };
            if !(thickness_nm.is_finite() && thickness_nm > 0.0) {
                return Err(StackSpecError::BadThickness {
                    layer,
                    text: format!("{}:{thickness_nm}", m.label()),
                    value: thickness_nm.to_string(),
                });
            }
            *d = thickness_nm;
        }
        Ok(out)
    }

    /// The wavelengths where every layer has an index, nm (the intersection of the
    /// tables' ranges).
    #[must_use]
    pub fn range_nm(&self) -> (f64, f64) {
        self.layers
            .iter()
            .fold((0.0f64, f64::INFINITY), |(lo, hi), (m, _)| {
                let (a, b) = m.range_nm();
                (lo.max(a), hi.min(b))
            })
    }

    /// The spec written back, `name:thickness/…` (canonical names).
    #[must_use]
    pub fn label(&self) -> String {
        self.layers
            .iter()
            .map(|(m, d)| format!("{}:{d}", m.label()))
            .collect::<Vec<_>>()
            .join("/")
    }

    /// The stack at `wavelength_nm`.
    ///
    /// # Errors
    /// [`StackSpecError::Material`] naming the first layer whose table does not cover
    /// the wavelength.
    pub fn at(&self, wavelength_nm: f64) -> Result<FilmStack, StackSpecError> {
        let mut layers = Vec::with_capacity(self.layers.len());
        for (i, (m, d)) in self.layers.iter().enumerate() {
            let index = m
                .index_at(wavelength_nm)
                .map_err(|source| StackSpecError::Material {
                    layer: i + 1,
                    text: format!("{}:{d}", m.label()),
                    source,
                })?;
            // Materials and thicknesses were validated when parsed.
            layers.push(Layer {
                index,
                thickness_nm: *d,
            });
        }
        Ok(FilmStack { layers })
    }
}

//! Writing ImageJ-style multi-page TIFF stacks, one slice at a time.
//!
//! The file is what ImageJ itself writes for a calibrated single-channel stack: one
//! uncompressed grey page per slice (8/16-bit unsigned or 32-bit float), the first page
//! carrying the `ImageDescription`
//! `ImageJ=1.11a\nimages=N\nslices=N\nunit=micron\nspacing=DZ\nloop=false\n` and every
//! page `XResolution = 1/dx`, `YResolution = 1/dy` pixels per micron with
//! `ResolutionUnit` none. Pages are written in the order given (the format has no field
//! for the page order: write the lowest slice first, or say otherwise when reading).
//! The resolutions are stored as the rationals `10⁶ / round(dx · 10⁶)`, so pixel sizes
//! that are whole picometres read back exactly.

use std::fs::File;
use std::io::{Seek, Write};
use std::path::{Path, PathBuf};

use thiserror::Error;
use tiff::encoder::colortype::{ColorType, Gray8, Gray16, Gray32Float};
use tiff::encoder::{Rational, TiffEncoder, TiffValue};
use tiff::tags::{ResolutionUnit, Tag};

use super::SampleType;

/// Size, spacing and sample type of a stack to write.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StackLayout {
    /// Pixels per row, ≥ 1.
    pub nx: usize,
    /// Rows, ≥ 1.
    pub ny: usize,
    /// Slices, ≥ 1.
    pub nz: usize,
    /// Pixel pitch along `x`, µm, in `[1e-6, 4000]`.
    pub dx_um: f64,
    /// Pixel pitch along `y`, µm, in `[1e-6, 4000]`.
    pub dy_um: f64,
    /// Distance between slices, µm (> 0).
    pub dz_um: f64,
    /// Sample type of every page.
    pub sample: SampleType,
}

/// Why a stack could not be written.
#[derive(Debug, Error)]
pub enum WriteStackError {
    /// The file could not be created or written.
    #[error("cannot write stack {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating-system error.
        source: std::io::Error,
    },
    /// The TIFF encoder failed.
    #[error("TIFF encoder: {0}")]
    Encode(String),
    /// A layout field is out of range.
    #[error("stack layout {name} = {value} is invalid: expected {expected}")]
    BadLayout {
        /// The field.
        name: &'static str,
        /// The value given.
        value: f64,
        /// What is accepted.
        expected: &'static str,
    },
    /// A slice of the wrong length or sample type, or one slice too many.
    #[error("slice {slice} (0-based): {message}")]
    Slice {
        /// 0-based slice index.
        slice: usize,
        /// What is wrong.
        message: String,
    },
    /// `finish` before every declared slice was written.
    #[error("the layout declares {expected} slices but {written} were written")]
    Incomplete {
        /// Declared slices.
        expected: usize,
        /// Slices written.
        written: usize,
    },
}

fn encode(e: tiff::TiffError) -> WriteStackError {
    WriteStackError::Encode(e.to_string())
}

/// Writes an ImageJ-style stack slice by slice (see the module docs).
pub struct ImageJStackWriter<W: Write + Seek> {
    encoder: TiffEncoder<W>,
    layout: StackLayout,
    written: usize,
    description: String,
    x_resolution: Rational,
    y_resolution: Rational,
}

impl<W: Write + Seek> std::fmt::Debug for ImageJStackWriter<W> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ImageJStackWriter")
            .field("layout", &self.layout)
            .field("written", &self.written)
            .finish_non_exhaustive()
    }
}

impl ImageJStackWriter<File> {
    /// Creates the file and a writer for `layout`. The file is written unbuffered (each
    /// page's strips go out in one piece), so nothing is left to flush.
    ///
    /// # Errors
    /// [`WriteStackError::BadLayout`] for an unusable layout, [`WriteStackError::Io`] if
    /// the file cannot be created.
    pub fn create(path: impl AsRef<Path>, layout: StackLayout) -> Result<Self, WriteStackError> {
        let path = path.as_ref();
        check_layout(&layout)?;
        let file = File::create(path).map_err(|source| WriteStackError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::new(file, layout)
    }
}

fn resolution(name: &'static str, pitch_um: f64) -> Result<Rational, WriteStackError> {
    let d = (pitch_um * 1e6).round();
    if !(d >= 1.0 && d <= f64::from(u32::MAX)) {
        return Err(WriteStackError::BadLayout {
            name,
            value: pitch_um,
            expected: "in [1e-6, 4000] µm",
        });
    }
    Ok(Rational {
        n: 1_000_000,
        d: d as u32,
    })
}

fn check_layout(l: &StackLayout) -> Result<(), WriteStackError> {
    for (name, n) in [("nx", l.nx), ("ny", l.ny), ("nz", l.nz)] {
        if n == 0 || n > u32::MAX as usize {
            return Err(WriteStackError::BadLayout {
                name,
                value: n as f64,
                expected: "in 1..=2^32 - 1",
            });
        }
    }
    if !(l.dz_um.is_finite() && l.dz_um > 0.0) {
        return Err(WriteStackError::BadLayout {
            name: "dz_um",
            value: l.dz_um,
            expected: "finite and > 0",
        });
    }
    resolution("dx_um", l.dx_um)?;
    resolution("dy_um", l.dy_um)?;
    Ok(())
}

impl<W: Write + Seek> ImageJStackWriter<W> {
    /// A writer into any seekable sink (e.g. `&mut Cursor<Vec<u8>>`).
    ///
    /// # Errors
    /// [`WriteStackError::BadLayout`] for an unusable layout, [`WriteStackError::Encode`]
    /// if the TIFF header cannot be written.
    pub fn new(sink: W, layout: StackLayout) -> Result<Self, WriteStackError> {
        check_layout(&layout)?;
        let encoder = TiffEncoder::new(sink).map_err(encode)?;
        let description = format!(
            "ImageJ=1.11a\nimages={n}\nslices={n}\nunit=micron\nspacing={dz}\nloop=false\n",
            n = layout.nz,
            dz = layout.dz_um
        );
        Ok(Self {
            encoder,
            x_resolution: resolution("dx_um", layout.dx_um)?,
            y_resolution: resolution("dy_um", layout.dy_um)?,
            layout,
            written: 0,
            description,
        })
    }

    /// Slices written so far.
    pub fn written(&self) -> usize {
        self.written
    }

    fn write<C: ColorType>(
        &mut self,
        sample: SampleType,
        data: &[C::Inner],
    ) -> Result<(), WriteStackError>
    where
        [C::Inner]: TiffValue,
    {
        let l = self.layout;
        let slice = self.written;
        if slice >= l.nz {
            return Err(WriteStackError::Slice {
                slice,
                message: format!("the layout declares {} slices", l.nz),
            });
        }
        if sample != l.sample {
            return Err(WriteStackError::Slice {
                slice,
                message: format!("{sample} samples given, the layout says {}", l.sample),
            });
        }
        if data.len() != l.nx * l.ny {
            return Err(WriteStackError::Slice {
                slice,
                message: format!(
                    "{} samples given, expected nx * ny = {}",
                    data.len(),
                    l.nx * l.ny
                ),
            });
        }
        let mut image = self
            .encoder
            .new_image::<C>(l.nx as u32, l.ny as u32)
            .map_err(encode)?;
        let dir = image.encoder();
        if slice == 0 {
            dir.write_tag(Tag::ImageDescription, self.description.as_str())
                .map_err(encode)?;
        }
        dir.write_tag(Tag::XResolution, self.x_resolution.clone())
            .map_err(encode)?;
        dir.write_tag(Tag::YResolution, self.y_resolution.clone())
            .map_err(encode)?;
        dir.write_tag(Tag::ResolutionUnit, ResolutionUnit::None.to_u16())
            .map_err(encode)?;
        image.write_data(data).map_err(encode)?;
        self.written += 1;
        Ok(())
    }

    /// Writes the next slice of 8-bit samples (row-major, `nx · ny`).
    ///
    /// # Errors
    /// [`WriteStackError::Slice`] for a wrong length or type or one slice too many,
    /// [`WriteStackError::Encode`] if writing fails.
    pub fn write_u8(&mut self, slice: &[u8]) -> Result<(), WriteStackError> {
        self.write::<Gray8>(SampleType::U8, slice)
    }

    /// Writes the next slice of 16-bit samples. Errors as [`Self::write_u8`].
    ///
    /// # Errors
    /// As [`Self::write_u8`].
    pub fn write_u16(&mut self, slice: &[u16]) -> Result<(), WriteStackError> {
        self.write::<Gray16>(SampleType::U16, slice)
    }

    /// Writes the next slice of 32-bit float samples. Errors as [`Self::write_u8`].
    ///
    /// # Errors
    /// As [`Self::write_u8`].
    pub fn write_f32(&mut self, slice: &[f32]) -> Result<(), WriteStackError> {
        self.write::<Gray32Float>(SampleType::F32, slice)
    }

    /// Checks that every slice was written. The TIFF is complete after each slice; this
    /// only catches a short stack.
    ///
    /// # Errors
    /// [`WriteStackError::Incomplete`] if fewer slices than declared were written.
    pub fn finish(self) -> Result<(), WriteStackError> {
        if self.written != self.layout.nz {
            return Err(WriteStackError::Incomplete {
                expected: self.layout.nz,
                written: self.written,
            });
        }
        Ok(())
    }
}

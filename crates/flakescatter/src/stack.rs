//! From a confocal z-stack to the maps the models use, in one call.
//!
//! [`localise_stack`] opens a TIFF stack (ImageJ, OME-TIFF or Zeiss LSM; the
//! [`io::stack`](crate::io::stack) reader), streams its slices one at a time into the
//! [`confocal`](crate::confocal) localiser and returns the height map (µm above the
//! lowest slice), the intensity map (brightest sample, full scale 1 for integer
//! stacks), the peak-width map (µm), the stack's description (size, voxel sizes, page
//! order and where each came from) and the localiser's counts. Memory stays within a
//! few times one map, whatever the number of slices.
//!
//! [`write_synthetic_stack`] writes a [`SyntheticStack`] of the synth crate as an
//! ImageJ-style TIFF, so a stack with a known surface can go through the same path;
//! [`covering_slices`] chooses slices that hold every pixel's axial peak.

use std::io::{Read, Seek, Write};
use std::path::{Path, PathBuf};

use flakescatter_confocal::{
    ConfocalError, Localiser, PeakMaps, PeakOptions, PeakReport, SignalThreshold, SliceOrder,
    StackGeometry,
};
use flakescatter_io::stack::{
    ImageJStackWriter, PageOrder, ReadStackError, SampleType, StackError, StackInfo, StackLayout,
    StackOptions, StackReader, WriteStackError,
};
use flakescatter_stats::heightmap::HeightMap;
use flakescatter_synth::{BitDepth, SynthError, SyntheticStack};
use thiserror::Error;

/// The maps of a localised stack and what they rest on.
#[derive(Debug, Clone, PartialEq)]
pub struct StackMaps {
    /// Height above the lowest slice, µm; invalid where the localiser found no peak.
    pub height: HeightMap,
    /// Brightest sample per pixel (unit-less, full scale 1 for integer stacks).
    pub intensity: HeightMap,
    /// FWHM of the axial peak, µm (see [`PeakMaps::width`]).
    pub width: HeightMap,
    /// The stack: size, sample type, voxel sizes, page order and their sources.
    pub info: StackInfo,
    /// Counts of valid and invalid pixels and why.
    pub report: PeakReport,
    /// The localiser options used (with the saturation level filled in).
    pub peak: PeakOptions,
    /// The background threshold used (the given `min_signal`, or the one estimated
    /// from the stack's noise) and how it was chosen.
    pub threshold: SignalThreshold,
}

/// Why a stack could not be turned into maps or written.
#[derive(Debug, Error)]
pub enum StackPipelineError {
    /// The stack file could not be read (names the file).
    #[error(transparent)]
    Read(#[from] ReadStackError),
    /// A stack from memory is not usable.
    #[error("stack: {0}")]
    Stack(#[from] StackError),
    /// The localiser refused the geometry or options.
    #[error("peak localisation: {0}")]
    Localise(#[from] ConfocalError),
    /// Writing a stack failed.
    #[error(transparent)]
    Write(#[from] WriteStackError),
    /// A synthetic slice could not be rendered.
    #[error("synthetic stack: {0}")]
    Synth(#[from] SynthError),
}

/// Reads the stack at `path` and localises every pixel's axial peak.
///
/// `progress(done, total)` is called after each slice. When `peak.saturation` is `None`
/// and the samples are integers, full scale (1.0) is used as the saturation level of the
/// report.
///
/// # Errors
/// [`StackPipelineError::Read`] naming the file for anything wrong with it (including a
/// missing pixel size or z step: [`StackError::MissingPixelSize`],
/// [`StackError::MissingZStep`]); [`StackPipelineError::Localise`] for bad options.
pub fn localise_stack(
    path: impl AsRef<Path>,
    read: &StackOptions,
    peak: &PeakOptions,
    progress: &dyn Fn(u64, u64),
) -> Result<StackMaps, StackPipelineError> {
    let path = path.as_ref();
    let in_file = |error: StackError| ReadStackError::Format {
        path: PathBuf::from(path),
        error,
    };
    let reader = StackReader::open(path, read)?;
    localise_reader(reader, peak, progress).map_err(|e| match e {
        StackPipelineError::Stack(error) => StackPipelineError::Read(in_file(error)),
        e => e,
    })
}

/// As [`localise_stack`] on an opened reader (e.g. a stack in memory).
///
/// # Errors
/// [`StackPipelineError::Stack`] for a missing calibration or a page that cannot be
/// decoded, [`StackPipelineError::Localise`] for bad options.
pub fn localise_reader<R: Read + Seek>(
    mut reader: StackReader<R>,
    peak: &PeakOptions,
    progress: &dyn Fn(u64, u64),
) -> Result<StackMaps, StackPipelineError> {
    let info = reader.info().clone();
    let c = info.calibration()?;
    let mut peak = *peak;
    if peak.saturation.is_none() && info.sample != SampleType::F32 {
        peak.saturation = Some(1.0);
    }
    let geometry = StackGeometry {
        nx: info.nx,
        ny: info.ny,
        nz: info.nz,
        dx_um: c.dx_um,
        dy_um: c.dy_um,
        dz_um: c.dz_um,
        order: match info.first_page.value {
            PageOrder::BottomFirst => SliceOrder::BottomFirst,
            PageOrder::TopFirst => SliceOrder::TopFirst,
        },
    };
    let mut localiser = Localiser::new(geometry, peak)?;
    let total = info.nz as u64;
    while let Some(slice) = reader.next_slice()? {
        localiser.push_slice(slice)?;
        progress(localiser.slices_pushed() as u64, total);
    }
    let PeakMaps {
        mut height,
        mut intensity,
        mut width,
        report,
        threshold,
    } = localiser.finish()?;
    for (map, unit) in [
        (&mut height, "um (above the lowest slice)"),
        (&mut intensity, "1 (brightest sample, full scale 1)"),
        (&mut width, "um (FWHM of the axial peak)"),
    ] {
        map.set_metadata("source", "confocal z-stack");
        map.set_metadata("z_unit", unit);
        map.set_metadata("stack.format", info.format.name());
        map.set_metadata("stack.slices", info.nz.to_string());
        map.set_metadata("stack.sample", info.sample.name());
        map.set_metadata("stack.z_step_um", c.dz_um.to_string());
        if let Some(z) = &info.z_step_um {
            map.set_metadata("stack.z_step_source", z.source.to_string());
        }
        if let Some(p) = &info.pixel_um {
            map.set_metadata("stack.pixel_source", p.source.to_string());
        }
        map.set_metadata("stack.first_page", info.first_page.value.name());
        map.set_metadata(
            "stack.first_page_source",
            info.first_page.source.to_string(),
        );
        map.set_metadata("stack.peak", peak.method.name());
        map.set_metadata("stack.fraction", peak.fraction.to_string());
        map.set_metadata("stack.min_signal", threshold.level.to_string());
        map.set_metadata("stack.min_signal_source", threshold.to_string());
        for (k, v) in &info.metadata {
            map.set_metadata(k.clone(), v.clone());
        }
    }
    Ok(StackMaps {
        height,
        intensity,
        width,
        info,
        report,
        peak,
        threshold,
    })
}

/// Slices `z_step_um` apart that cover `surface` (µm above the substrate) with
/// `margin_um` to spare below its lowest and above its highest valid height: returns
/// `(z_first_um, slices)`, the height of slice 0 (a multiple of the step at or below
/// `min − margin`, to 1e-9 µm) and the number of slices (so that the last is at or above
/// `max + margin`). A margin of a few axial FWHM keeps every peak off the first and
/// last slice. `None` when the map has no valid point or the step or margin is not
/// finite and positive (resp. non-negative).
#[must_use]
pub fn covering_slices(
    surface: &HeightMap,
    z_step_um: f64,
    margin_um: f64,
) -> Option<(f64, usize)> {
    if !(z_step_um.is_finite() && z_step_um > 0.0 && margin_um.is_finite() && margin_um >= 0.0) {
        return None;
    }
    let s = surface.summary()?;
    // A whole number of steps, rounded to 1e-9 µm so that it reads as typed (−1.8, not
    // −1.7999999999999998).
    let first = (((s.min - margin_um) / z_step_um).floor() * z_step_um * 1e9).round() / 1e9;
    let span = s.max + margin_um - first;
    // The last slice, first + (slices − 1)·Δ, must reach max + margin.
    let slices = (span / z_step_um - 1e-9).ceil().max(0.0) as usize + 1;
    Some((first, slices.max(3)))
}

fn layout(stack: &SyntheticStack) -> StackLayout {
    let (nx, ny, nz) = stack.size();
    let (dx_um, dy_um) = stack.pitch_um();
    StackLayout {
        nx,
        ny,
        nz,
        dx_um,
        dy_um,
        dz_um: stack.spec().z_step_um,
        sample: match stack.spec().bit_depth {
            BitDepth::Eight => SampleType::U8,
            BitDepth::Sixteen => SampleType::U16,
        },
    }
}

fn write_slices<W: Write + Seek>(
    mut writer: ImageJStackWriter<W>,
    stack: &SyntheticStack,
    order: PageOrder,
    progress: &dyn Fn(u64, u64),
) -> Result<(), StackPipelineError> {
    let nz = stack.size().2;
    for p in 0..nz {
        progress(p as u64, nz as u64);
        let k = match order {
            PageOrder::BottomFirst => p,
            PageOrder::TopFirst => nz - 1 - p,
        };
        let counts = stack.slice(k)?;
        match stack.spec().bit_depth {
            BitDepth::Sixteen => writer.write_u16(&counts)?,
            BitDepth::Eight => {
                let bytes: Vec<u8> = counts.iter().map(|&c| c.min(255) as u8).collect();
                writer.write_u8(&bytes)?;
            }
        }
    }
    writer.finish()?;
    progress(nz as u64, nz as u64);
    Ok(())
}

/// Writes `stack` as an ImageJ-style TIFF at `path`, slices in `order` (ImageJ has no
/// field for it: read a `TopFirst` file with [`StackOptions::first_page`]). Slices are
/// rendered and written one at a time.
///
/// # Errors
/// [`StackPipelineError::Write`] if the file cannot be written.
pub fn write_synthetic_stack(
    path: impl AsRef<Path>,
    stack: &SyntheticStack,
    order: PageOrder,
) -> Result<(), StackPipelineError> {
    write_synthetic_stack_with(path, stack, order, &|_, _| {})
}

/// As [`write_synthetic_stack`], calling `progress(done, total)` with the number of
/// slices written before each slice and at the end.
///
/// # Errors
/// [`StackPipelineError::Write`] if the file cannot be written.
pub fn write_synthetic_stack_with(
    path: impl AsRef<Path>,
    stack: &SyntheticStack,
    order: PageOrder,
    progress: &dyn Fn(u64, u64),
) -> Result<(), StackPipelineError> {
    let writer = ImageJStackWriter::create(path, layout(stack))?;
    write_slices(writer, stack, order, progress)
}

/// As [`write_synthetic_stack`] into any seekable sink (e.g. `&mut Cursor<Vec<u8>>`).
///
/// # Errors
/// [`StackPipelineError::Write`] if writing fails.
pub fn write_synthetic_stack_to<W: Write + Seek>(
    sink: W,
    stack: &SyntheticStack,
    order: PageOrder,
) -> Result<(), StackPipelineError> {
    let writer = ImageJStackWriter::new(sink, layout(stack))?;
    write_slices(writer, stack, order, &|_, _| {})
}

#[cfg(test)]
mod tests {
    use super::covering_slices;
    use flakescatter_stats::heightmap::HeightMap;

    #[test]
    fn covering_slices_reach_past_both_ends() {
        // Heights 1..5 µm, step 0.3, margin 1.8: slice 0 at the multiple of 0.3 at or
        // below −0.8, i.e. −0.9; the last slice must reach 6.8: −0.9 + 26·0.3 = 6.9, the
        // first multiple of the step above it, so 27 slices.
        let map = HeightMap::new(2, 1, 1.0, 1.0, vec![1.0, 5.0]).unwrap();
        let (first, n) = covering_slices(&map, 0.3, 1.8).unwrap();
        assert!((first + 0.9).abs() < 1e-12, "{first}");
        assert_eq!(n, 27);
        assert!(first + (n - 1) as f64 * 0.3 >= 6.8 - 1e-9);
        assert!(first + (n - 2) as f64 * 0.3 < 6.8);
        // No valid point, or a bad step: no answer.
        let empty = HeightMap::new(1, 1, 1.0, 1.0, vec![f64::NAN]).unwrap();
        assert!(covering_slices(&empty, 0.3, 1.0).is_none());
        assert!(covering_slices(&map, 0.0, 1.0).is_none());
        assert!(covering_slices(&map, 0.3, f64::NAN).is_none());
    }
}

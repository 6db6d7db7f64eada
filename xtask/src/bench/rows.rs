//! The table's rows: which criterion benchmark each row reads, the work one iteration
//! does, the target from the issues and the floor it is paired with; and a measured row.

/// What one iteration of a benchmark processes, for the throughput column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unit {
    /// Rays traced (usable pixels × incidences): rays/s.
    Rays,
    /// Map pixels: pixels/s.
    Pixels,
    /// Function evaluations: evaluations/s.
    Evaluations,
    /// Detector readings (incidences × detectors): detectors/s.
    Detectors,
    /// Bytes of data: MB/s (10⁶ bytes per second).
    Bytes,
    /// Stack voxels (pixels × slices): voxels/s.
    Voxels,
    /// Straight ray segments of the volume model: segments/s. The bench counts them
    /// (deterministic for its seed) and gives the count to criterion as the
    /// benchmark's throughput; the table reads it from criterion's `benchmark.json`
    /// ([`crate::bench::read_elements`]), so [`RowSpec::work`] is 0 for such rows.
    Segments,
}

impl Unit {
    /// The throughput unit as printed in the table.
    #[must_use]
    pub fn per_second(self) -> &'static str {
        match self {
            Self::Rays => "rays/s",
            Self::Pixels => "pixels/s",
            Self::Evaluations => "evaluations/s",
            Self::Detectors => "detectors/s",
            Self::Bytes => "MB/s",
            Self::Voxels => "voxels/s",
            Self::Segments => "segments/s",
        }
    }
}

/// A target from the issues.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Target {
    /// The median time per iteration must be at most this many seconds.
    MaxSeconds(f64),
    /// The throughput must be at least this many units per second.
    MinPerSecond(f64),
    /// The median time must be at most `times` × the median of the benchmark `of`
    /// (measured in the same run: a cost relative to another operation).
    MaxTimes {
        /// Criterion id of the reference benchmark.
        of: &'static str,
        /// Largest allowed ratio of the two medians.
        times: f64,
    },
    /// The median time must be at most this many times the row's floor.
    MaxFloorRatio(f64),
}

/// The compute limit of a row where one is known: the throughput (in the row's unit per
/// second) of the fastest known implementation of the same work on the same core, or of
/// the step that bounds the row done alone, and where that figure comes from. Printed in
/// its own column with our share of it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limit {
    /// Criterion id of the row.
    pub id: &'static str,
    /// The figure, or the bench that measures it.
    pub source: LimitSource,
    /// Where the figure comes from.
    pub note: &'static str,
}

/// Where a [`Limit`]'s throughput comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LimitSource {
    /// A figure measured outside this project's benches, units per second.
    Known(f64),
    /// A criterion bench (its id) of the bounding step alone, on the row's input and
    /// in the same run: the row's work over that bench's median.
    Measured(&'static str),
}

/// The known compute limits. Issue 22: a vectorised C version of the point BRDF with
/// AVX2 vector `exp`/`acos` runs 173–186 M evaluations/s on one core of this machine
/// (the lower end is taken). The X3P read cannot be faster than inflating its
/// `data.bin` with the zip crate's streaming inflater (zlib-rs), which the read bench
/// times alone on the same file; the read of a stored `data.bin` cannot be faster than
/// its MD5, timed alone on the same bytes.
pub const LIMITS: [Limit; 4] = [
    Limit {
        id: "gaussian/point_brdf_x1000",
        source: LimitSource::Known(1.73e8),
        note: "vectorised C, AVX2",
    },
    Limit {
        id: "gaussian/point_brdf_batch_x1000",
        source: LimitSource::Known(1.73e8),
        note: "vectorised C, AVX2",
    },
    Limit {
        id: "read_x3p/4096x4096_f64",
        source: LimitSource::Measured("read_x3p/inflate_4096x4096_f64"),
        note: "the streaming inflate of `data.bin` alone, measured",
    },
    Limit {
        id: "read_x3p/stored_4096x4096_f64",
        source: LimitSource::Measured("read_x3p/md5_4096x4096_f64"),
        note: "the MD5 of `data.bin` alone, measured",
    },
];

/// One row of the table: which benchmark, what it measures, what it should reach.
#[derive(Debug, Clone, Copy)]
pub struct RowSpec {
    /// Operation, as printed.
    pub operation: &'static str,
    /// Size of the input, as printed (e.g. `4096²`).
    pub size: &'static str,
    /// Criterion id `<group>/<function>[/<value>]` (its directory under `target/criterion`).
    pub id: &'static str,
    /// Criterion id of the floor measured on the same input, if any.
    pub floor: Option<&'static str>,
    /// Work done by one iteration, in `unit` (0 for [`Unit::Segments`]: read from
    /// criterion's output).
    pub work: f64,
    /// Unit of `work`.
    pub unit: Unit,
    /// Target from the issues, if any.
    pub target: Option<Target>,
    /// How the target is stated in the issue (printed next to it).
    pub target_note: &'static str,
    /// Whether the row is measured by `--quick`.
    pub quick: bool,
}

/// One criterion bench target to run: `cargo bench -p <package> --bench <bench>`.
#[derive(Debug, Clone, Copy)]
pub struct BenchTarget {
    /// Cargo package.
    pub package: &'static str,
    /// Bench target name.
    pub bench: &'static str,
}

/// Every bench target the table draws on, in the order they run.
pub const TARGETS: &[BenchTarget] = &[
    BenchTarget {
        package: "flakescatter-optics",
        bench: "optics",
    },
    BenchTarget {
        package: "flakescatter-gaussian",
        bench: "model",
    },
    BenchTarget {
        package: "flakescatter-topo",
        bench: "topo",
    },
    BenchTarget {
        package: "flakescatter-stats",
        bench: "segment",
    },
    BenchTarget {
        package: "flakescatter-io",
        bench: "read_x3p",
    },
    BenchTarget {
        package: "flakescatter-synth",
        bench: "generate",
    },
    BenchTarget {
        package: "flakescatter-volume",
        bench: "volume",
    },
    BenchTarget {
        package: "flakescatter",
        bench: "spectral",
    },
    BenchTarget {
        package: "flakescatter-io",
        bench: "read_stack",
    },
    BenchTarget {
        package: "flakescatter-confocal",
        bench: "localise",
    },
    BenchTarget {
        package: "flakescatter-colour",
        bench: "colour",
    },
    BenchTarget {
        package: "flakescatter",
        bench: "paint",
    },
    BenchTarget {
        package: "flakescatter",
        bench: "export",
    },
];

/// Usable pixels of an `n × n` map with the default 5 × 5 normal window: `(n − 4)²`.
const fn usable(n: u64) -> f64 {
    ((n - 4) * (n - 4)) as f64
}

/// `n²` as f64.
const fn square(n: u64) -> f64 {
    (n * n) as f64
}

/// The table, in order. Work counts match the benches' inputs (see each bench file).
pub const ROWS: &[RowSpec] = &[
    RowSpec {
        operation: "Fresnel power, air → coating",
        size: "1000 calls",
        id: "optics/fresnel_air_to_coating_x1000",
        floor: None,
        work: 1000.0,
        unit: Unit::Evaluations,
        target: None,
        target_note: "",
        quick: true,
    },
    RowSpec {
        operation: "Snell refraction into the coating",
        size: "1000 calls",
        id: "optics/snell_into_coating_x1000",
        floor: None,
        work: 1000.0,
        unit: Unit::Evaluations,
        target: None,
        target_note: "",
        quick: true,
    },
    RowSpec {
        operation: "Snell refraction out of the coating",
        size: "1000 calls",
        id: "optics/snell_out_of_coating_x1000",
        floor: None,
        work: 1000.0,
        unit: Unit::Evaluations,
        target: None,
        target_note: "",
        quick: true,
    },
    RowSpec {
        operation: "Mirror reflection by a flake",
        size: "1000 calls",
        id: "optics/reflect_x1000",
        floor: None,
        work: 1000.0,
        unit: Unit::Evaluations,
        target: None,
        target_note: "",
        quick: true,
    },
    RowSpec {
        operation: "Internal half vector",
        size: "1000 calls",
        id: "optics/half_vector_x1000",
        floor: None,
        work: 1000.0,
        unit: Unit::Evaluations,
        target: None,
        target_note: "",
        quick: true,
    },
    RowSpec {
        operation: "Distribution model, point BRDF",
        size: "1000 directions",
        id: "gaussian/point_brdf_x1000",
        floor: None,
        work: 1000.0,
        unit: Unit::Evaluations,
        target: Some(Target::MinPerSecond(1e7)),
        target_note: "> 10⁷ evaluations/s",
        quick: true,
    },
    RowSpec {
        operation: "Distribution model, batch point BRDF (issue 22)",
        size: "1000 directions",
        id: "gaussian/point_brdf_batch_x1000",
        floor: None,
        work: 1000.0,
        unit: Unit::Evaluations,
        target: Some(Target::MinPerSecond(1.2e8)),
        target_note: "≥ 120 M evaluations/s, 1 thread",
        quick: true,
    },
    RowSpec {
        operation: "Distribution model, point Mueller BRDF",
        size: "1000 directions",
        id: "gaussian/point_mueller_x1000",
        floor: None,
        work: 1000.0,
        unit: Unit::Evaluations,
        target: Some(Target::MaxTimes {
            of: "gaussian/point_brdf_x1000",
            times: 3.0,
        }),
        target_note: "≤ 3× the point BRDF",
        quick: true,
    },
    RowSpec {
        operation: "Distribution model, point BRDF, metal flake (aluminium 0.96 + 6.69i)",
        size: "1000 directions",
        id: "gaussian/point_brdf_metal_x1000",
        floor: None,
        work: 1000.0,
        unit: Unit::Evaluations,
        target: None,
        target_note: "",
        quick: true,
    },
    RowSpec {
        operation: "Distribution model, point BRDF, interference flake (3 layers, issue 47)",
        size: "1000 directions",
        id: "gaussian/point_brdf_stack3_x1000",
        floor: None,
        work: 1000.0,
        unit: Unit::Evaluations,
        target: Some(Target::MaxTimes {
            of: "gaussian/point_brdf_metal_x1000",
            times: 3.0,
        }),
        target_note: "≤ 3× the metal flake",
        quick: true,
    },
    RowSpec {
        operation: "Distribution model, default set (exact cones, α = 1.5°)",
        size: "5 × 281",
        id: "gaussian/default_set_5x281_exact_1thread",
        floor: None,
        work: 1405.0,
        unit: Unit::Detectors,
        target: Some(Target::MaxSeconds(0.002)),
        target_note: "< 2 ms, 1 thread (issue 22; < 20 ms in issue 4)",
        quick: true,
    },
    RowSpec {
        operation: "Spectral distribution model, ASTM E2194 set + colorimetry",
        size: "41 λ × 6",
        id: "spectral/multi_angle_41wl_e2194",
        floor: None,
        work: 246.0,
        unit: Unit::Detectors,
        target: None,
        target_note: "",
        quick: true,
    },
    RowSpec {
        operation: "Windowed normals (5 × 5)",
        size: "1024²",
        id: "topo/normals/1024",
        floor: Some("topo/floor_1024"),
        work: square(1024),
        unit: Unit::Pixels,
        target: None,
        target_note: "",
        quick: true,
    },
    RowSpec {
        operation: "Windowed normals (5 × 5)",
        size: "4096²",
        id: "topo/normals/4096",
        floor: Some("topo/floor_4096"),
        work: square(4096),
        unit: Unit::Pixels,
        target: Some(Target::MaxFloorRatio(15.0)),
        target_note: "≤ 15× the floor (issue 22)",
        quick: false,
    },
    RowSpec {
        operation: "Topographic model, 5 incidences × 281 detectors",
        size: "1024²",
        id: "topo/run_5inc_281det/1024",
        floor: Some("topo/floor_1024"),
        work: usable(1024) * 5.0,
        unit: Unit::Rays,
        target: None,
        target_note: "",
        quick: true,
    },
    RowSpec {
        operation: "Topographic model, 5 incidences × 281 detectors",
        size: "2048²",
        id: "topo/run_5inc_281det/2048",
        floor: Some("topo/floor_2048"),
        work: usable(2048) * 5.0,
        unit: Unit::Rays,
        target: None,
        target_note: "",
        quick: false,
    },
    RowSpec {
        operation: "Topographic model, isotropic, 5 incidences × 281 detectors",
        size: "1024²",
        id: "topo/isotropic_5inc_281det/1024",
        floor: Some("topo/floor_1024"),
        work: usable(1024) * 5.0,
        unit: Unit::Rays,
        target: None,
        target_note: "",
        quick: true,
    },
    RowSpec {
        operation: "Topographic model, isotropic, 5 incidences × 281 detectors",
        size: "2048²",
        id: "topo/isotropic_5inc_281det/2048",
        floor: Some("topo/floor_2048"),
        work: usable(2048) * 5.0,
        unit: Unit::Rays,
        target: Some(Target::MaxTimes {
            of: "topo/run_5inc_281det/2048",
            times: 3.0,
        }),
        target_note: "≤ 3× the plain model at 2048²",
        quick: false,
    },
    RowSpec {
        operation: "Topographic model, 5 incidences × 281 detectors",
        size: "4096²",
        id: "topo/run_5inc_281det/4096",
        floor: Some("topo/floor_4096"),
        work: usable(4096) * 5.0,
        unit: Unit::Rays,
        target: Some(Target::MinPerSecond(2.5e8)),
        target_note: "≥ 250 M rays/s, 2 cores (issue 22; < 1.5 s in issue 4)",
        quick: false,
    },
    RowSpec {
        operation: "Flake segmentation",
        size: "2048²",
        id: "segment/2048x2048",
        floor: Some("segment/floor_2048x2048"),
        work: square(2048),
        unit: Unit::Pixels,
        target: Some(Target::MaxSeconds(1.0)),
        target_note: "< 1 s, 2 cores",
        quick: true,
    },
    RowSpec {
        operation: "Read X3P (float64, deflate)",
        size: "4096²",
        id: "read_x3p/4096x4096_f64",
        floor: Some("read_x3p/floor_4096x4096_f64"),
        work: square(4096) * 8.0,
        unit: Unit::Bytes,
        target: Some(Target::MinPerSecond(4e8)),
        target_note: "≥ 400 MB/s (issue 22; < 1 s in issue 4)",
        quick: true,
    },
    RowSpec {
        operation: "Read X3P (float64, stored, as this writer stores noisy heights)",
        size: "4096²",
        id: "read_x3p/stored_4096x4096_f64",
        floor: Some("read_x3p/floor_stored_4096x4096_f64"),
        work: square(4096) * 8.0,
        unit: Unit::Bytes,
        target: None,
        target_note: "",
        quick: true,
    },
    RowSpec {
        operation: "Synthetic layer (defaults)",
        size: "512²",
        id: "generate/512_default",
        floor: Some("generate/floor_512"),
        work: square(512),
        unit: Unit::Pixels,
        target: None,
        target_note: "",
        quick: true,
    },
    RowSpec {
        operation: "Synthetic layer (defaults)",
        size: "2048²",
        id: "generate/2048_default",
        floor: Some("generate/floor_2048"),
        work: square(2048),
        unit: Unit::Pixels,
        target: Some(Target::MaxSeconds(2.0)),
        target_note: "< 2 s",
        quick: true,
    },
    RowSpec {
        operation: "Synthetic layer (roughness, PSF, noise)",
        size: "2048²",
        id: "generate/2048_rough_psf_noise",
        floor: Some("generate/floor_2048"),
        work: square(2048),
        unit: Unit::Pixels,
        target: None,
        target_note: "",
        quick: false,
    },
    RowSpec {
        operation: "Volume model, paper's coating, 10⁶ rays at 45° × 281 cones (columns one diameter wide)",
        size: "10⁵ flakes",
        id: "volume/trace_1e5_flakes_cell_one_diameter",
        floor: None,
        work: 0.0,
        unit: Unit::Segments,
        target: Some(Target::MinPerSecond(1e7)),
        target_note: "≥ 10⁷ segments/s, 2 cores",
        quick: true,
    },
    RowSpec {
        operation: "Read a confocal z-stack (ImageJ TIFF, uint16), slice by slice",
        size: "1024² × 100",
        id: "read_stack/imagej_1024x1024x100_u16",
        floor: None,
        work: 1024.0 * 1024.0 * 100.0 * 2.0,
        unit: Unit::Bytes,
        target: None,
        target_note: "",
        quick: false,
    },
    RowSpec {
        operation: "Confocal localisation, Gaussian peak (default), streaming",
        size: "1024² × 100",
        id: "localise/gaussian_1024x1024x100",
        floor: None,
        work: 1024.0 * 1024.0 * 100.0,
        unit: Unit::Voxels,
        target: None,
        target_note: "",
        quick: false,
    },
    RowSpec {
        operation: "Confocal localisation, argmax (brightest slice)",
        size: "1024² × 100",
        id: "localise/argmax_1024x1024x100",
        floor: None,
        work: 1024.0 * 1024.0 * 100.0,
        unit: Unit::Voxels,
        target: None,
        target_note: "",
        quick: false,
    },
    RowSpec {
        operation: "Spectrum → CIELAB (ASTM E308 weights built and applied, D65, 10°)",
        size: "1 nm, 360–830 nm",
        id: "spectrum_to_lab/build_and_apply_1nm_360_830",
        floor: None,
        work: 1.0,
        unit: Unit::Evaluations,
        target: None,
        target_note: "",
        quick: true,
    },
    RowSpec {
        operation: "Joint paint fit (4 families, BIC), measured blue paint",
        size: "1495 rows × 3",
        id: "paint/joint_fit_blue_auto",
        floor: None,
        work: 4485.0,
        unit: Unit::Detectors,
        target: Some(Target::MaxSeconds(5.0)),
        target_note: "< 5 s, 2 cores (issue 46)",
        quick: true,
    },
    RowSpec {
        operation: "Joint paint fit (table family), measured blue paint",
        size: "1495 rows × 3",
        id: "paint/joint_fit_blue_table",
        floor: None,
        work: 4485.0,
        unit: Unit::Detectors,
        target: None,
        target_note: "",
        quick: true,
    },
    RowSpec {
        operation: "MERL export, flakes (hwhm 6°, grey), every bin at its centre",
        size: "1,458,000 bins × 3",
        id: "export/merl_flakes_full_table",
        floor: None,
        work: 4_374_000.0,
        unit: Unit::Evaluations,
        target: Some(Target::MaxSeconds(3.0)),
        target_note: "< 3 s, 2 cores (issue 48)",
        quick: true,
    },
    RowSpec {
        operation: "MERL export, paint fitted to the measured blue paint",
        size: "1,458,000 bins × 3",
        id: "export/merl_paint_full_table",
        floor: None,
        work: 4_374_000.0,
        unit: Unit::Evaluations,
        target: Some(Target::MaxSeconds(3.0)),
        target_note: "< 3 s, 2 cores (issue 48)",
        quick: true,
    },
];

/// A measured row: the spec with what criterion reported.
#[derive(Debug, Clone)]
pub struct Row {
    /// The row's specification.
    pub spec: RowSpec,
    /// Work of one iteration in the row's unit: [`RowSpec::work`], or for
    /// [`Unit::Segments`] the count criterion recorded (`Err`: why it is missing).
    pub work: Result<f64, String>,
    /// Median time per iteration, seconds (`Err`: why it is missing).
    pub median_s: Result<f64, String>,
    /// Median time of the floor, seconds (`None` without a floor; `Err`: missing).
    pub floor_s: Option<Result<f64, String>>,
    /// Median time of the reference of a [`Target::MaxTimes`], seconds (`None` for
    /// other targets; `Err`: missing).
    pub reference_s: Option<Result<f64, String>>,
    /// Median time of the bench of a [`LimitSource::Measured`] limit, seconds (`None`
    /// for other rows; `Err`: missing).
    pub limit_s: Option<Result<f64, String>>,
}

impl Row {
    /// Throughput in units per second (bytes per second for [`Unit::Bytes`]).
    #[must_use]
    pub fn per_second(&self) -> Option<f64> {
        let w = *self.work.as_ref().ok()?;
        self.median_s.as_ref().ok().map(|&t| w / t)
    }

    /// Whether the target is met: `None` without a target or a measurement.
    #[must_use]
    pub fn met(&self) -> Option<bool> {
        let t = *self.median_s.as_ref().ok()?;
        match self.spec.target? {
            Target::MaxSeconds(max) => Some(t <= max),
            Target::MinPerSecond(min) => Some(*self.work.as_ref().ok()? / t >= min),
            Target::MaxTimes { times, .. } => {
                let r = *self.reference_s.as_ref()?.as_ref().ok()?;
                Some(t <= times * r)
            }
            Target::MaxFloorRatio(max) => Some(self.ratio()? <= max),
        }
    }

    /// The row's compute limit, if one is known ([`LIMITS`]).
    #[must_use]
    pub fn limit(&self) -> Option<&'static Limit> {
        LIMITS.iter().find(|l| l.id == self.spec.id)
    }

    /// The throughput of the row's compute limit, units per second: `None` without a
    /// limit, `Err` when the bench that measures it is missing (why).
    #[must_use]
    pub fn limit_per_second(&self) -> Option<Result<f64, String>> {
        Some(match self.limit()?.source {
            LimitSource::Known(v) => Ok(v),
            LimitSource::Measured(_) => {
                let t = self.limit_s.clone()?;
                let w = self.work.clone();
                t.and_then(|t| {
                    let w = w?;
                    if t > 0.0 {
                        Ok(w / t)
                    } else {
                        Err("a median of zero".to_owned())
                    }
                })
            }
        })
    }

    /// Median time over floor median time, when both were measured.
    #[must_use]
    pub fn ratio(&self) -> Option<f64> {
        let t = *self.median_s.as_ref().ok()?;
        let f = *self.floor_s.as_ref()?.as_ref().ok()?;
        (f > 0.0).then(|| t / f)
    }
}

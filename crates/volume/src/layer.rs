//! Flakes as thin cylinders and their placement without interpenetration.
//!
//! Conventions: lengths in µm; `z` up, the film is `−film ≤ z ≤ 0`; the tile is
//! `[0, L)²`, periodic. A flake is a solid circular cylinder: mid-plane centre `c`,
//! unit axis (face normal) `m` with `m.z ≥ 0`, radius `r = d/2`, thickness `t`. Its
//! **top face** is the disc of radius `r` at `(x − c)·m = t/2` (outward normal `m`),
//! its **bottom face** the disc at `(x − c)·m = −t/2` (outward normal `−m`), its
//! **rim** the side wall `|x − c − ((x − c)·m) m| = r`, `|(x − c)·m| ≤ t/2`.
//!
//! # Placement rule (random sequential addition)
//! Flakes are drawn one at a time from a ChaCha8 stream of the layer's seed: diameter,
//! then normal ([`Orientation::sample_normal`]), both drawn **once**; then the centre
//! (`x`, `y` uniform on the tile, depth from the depth rule restricted to where the flake
//! lies wholly inside the film) is drawn until the flake overlaps no flake already
//! placed, nor any periodic image of one. Overlap is decided exactly for the two solid
//! cylinders by the GJK intersection test of `parry3d-f64` (touching counts as
//! overlapping) after a bounding-sphere prefilter. A flake that finds no free position
//! in [`LayerSpec::max_attempts`](crate::LayerSpec::max_attempts) tries ends placement
//! with [`VolumeError::LoadingTooHigh`]. Redrawing only the position keeps the diameter
//! and orientation distributions of the placed flakes exactly those requested; the
//! positions are those of random sequential addition (not a Poisson process: flakes
//! exclude each other).

use flakescatter_optics::{UnitVec3, Vec3};
use flakescatter_stats::Orientation;
use parry3d_f64::math::{Pose, Rot3, Vector};
use parry3d_f64::query::intersection_test;
use parry3d_f64::shape::Cylinder;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, LogNormal};

use crate::VolumeError;
use crate::inside::{Inside, half_extent, nearest_allowed};
use crate::params::{Amount, DepthBins, Diameter, LayerParams, MAX_FLAKES};

/// ChaCha8 stream of the layer's draws (the rays have generators of their own, module
/// `trace`).
pub(crate) const LAYER_STREAM: u64 = 1 << 63;

/// One flake: a solid thin cylinder (64 bytes, aligned to a cache line).
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(align(64))]
pub struct Flake {
    /// Mid-plane centre, µm: `x, y ∈ [0, L)`, `z ∈ (−film, 0)`.
    pub centre: Vec3,
    /// Unit face normal (cylinder axis), `z ≥ 0`.
    pub normal: UnitVec3,
    /// Radius `d/2`, µm.
    pub radius_um: f64,
    /// Thickness `t`, µm.
    pub thickness_um: f64,
}

impl Flake {
    /// Diameter, µm.
    #[must_use]
    pub fn diameter_um(&self) -> f64 {
        2.0 * self.radius_um
    }

    /// Volume `π r² t`, µm³.
    #[must_use]
    pub fn volume_um3(&self) -> f64 {
        std::f64::consts::PI * self.radius_um * self.radius_um * self.thickness_um
    }

    /// Area of one face, `π r²`, µm².
    #[must_use]
    pub fn face_area_um2(&self) -> f64 {
        std::f64::consts::PI * self.radius_um * self.radius_um
    }

    /// Half-extent of the cylinder along the unit direction `e`:
    /// `r sqrt(1 − (m·e)²) + (t/2)|m·e|` (its support function), µm.
    #[must_use]
    pub fn half_extent(&self, e: &Vec3) -> f64 {
        let c = self.normal.dot(e);
        self.radius_um * (1.0 - c * c).max(0.0).sqrt() + 0.5 * self.thickness_um * c.abs()
    }

    /// Whether the point `p` (µm, same frame as the centre, no periodic wrapping) lies
    /// in the solid cylinder (boundary included).
    #[must_use]
    pub fn contains(&self, p: &Vec3) -> bool {
        let d = p - self.centre;
        let s = d.dot(&self.normal);
        let radial = d - s * self.normal.into_inner();
        s.abs() <= 0.5 * self.thickness_um && radial.norm_squared() <= self.radius_um.powi(2)
    }

    /// Radius of the smallest sphere about the centre holding the cylinder, µm.
    #[must_use]
    pub fn bounding_radius(&self) -> f64 {
        self.radius_um.hypot(0.5 * self.thickness_um)
    }
}

/// What placement achieved.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LayerStats {
    /// Flakes placed.
    pub flakes: usize,
    /// Requested volume fraction (`None` for a flake count).
    pub requested_volume_fraction: Option<f64>,
    /// Realised volume fraction `Σ π r² t / (L² film)`.
    pub volume_fraction: f64,
    /// Realised projected coverage `Σ π r² m.z / L²`: the face area seen from above per
    /// unit tile area, counting overlaps in projection twice.
    pub projected_coverage: f64,
    /// Realised face-area coverage `Σ π r² / L²`.
    pub area_coverage: f64,
    /// Centre positions tried in all (accepted and rejected).
    pub attempts: u64,
    /// Flakes taller than the film at their tilt, given a diameter that fits (module
    /// `inside`, rule 1; their normals are kept).
    pub resized: usize,
    /// Flakes whose centre the depth rule could not put inside the film, placed at the
    /// nearest depth that is (rule 2).
    pub moved: usize,
    /// The face area the resized flakes lost, as a fraction of the face area of all
    /// flakes as drawn (0 when none was resized): how much the area-weighted
    /// orientation distribution of the layer is short of its tail.
    pub resized_area_fraction: f64,
}

/// A placed flake layer: the film, the tile and the flakes.
#[derive(Debug, Clone, PartialEq)]
pub struct Layer {
    film_um: f64,
    tile_um: f64,
    flakes: Vec<Flake>,
    stats: LayerStats,
    mean_diameter_um: f64,
}

impl Layer {
    /// Place the flakes of `params` (module docs: placement rule).
    ///
    /// # Errors
    /// [`VolumeError::LoadingTooHigh`] when a flake finds no free position;
    /// [`VolumeError::DepthRange`] when the film or the depth rule cannot hold a typical
    /// flake (module `inside`; other flakes are resized or moved by its rules); [`VolumeError::Geometry`] if the overlap test
    /// cannot be evaluated.
    pub fn generate(params: &LayerParams) -> Result<Self, VolumeError> {
        Self::generate_realisation(params, 0)
    }

    /// Realisation `k` of the layer: the same placement rule drawing from ChaCha8
    /// stream `LAYER_STREAM + k` of the seed, so realisations `0, 1, …` of one seed are
    /// independent layers (realisation 0 is [`Layer::generate`]'s). `k` below 2⁶².
    ///
    /// # Errors
    /// As [`Layer::generate`].
    pub fn generate_realisation(params: &LayerParams, k: u64) -> Result<Self, VolumeError> {
        let spec = params.spec();
        let (l, f, t) = (spec.tile_um, spec.film_um, spec.thickness_um);
        let mut rng = ChaCha8Rng::seed_from_u64(spec.seed);
        rng.set_stream(LAYER_STREAM.wrapping_add(k));
        let target_volume = spec.amount.volume_fraction().map(|phi| phi * l * l * f);
        let target_count = match spec.amount {
            Amount::Count(c) => Some(c),
            _ => None,
        };
        let mut inside = Inside::new(params)?;
        let mut placer = Placer::new(l, spec.diameter.max_um() + t);
        let mut flakes: Vec<Flake> = Vec::new();
        let mut volume = 0.0;
        let mut attempts = 0u64;
        let lognormal = match spec.diameter {
            Diameter::LogNormal { mean_um, rel_sd } if rel_sd > 0.0 => {
                Some(LogNormal::from_mean_cv(mean_um, rel_sd).map_err(|e| {
                    VolumeError::Geometry(format!("log-normal diameter distribution: {e}"))
                })?)
            }
            _ => None,
        };
        loop {
            let done = match (target_count, target_volume) {
                (Some(c), _) => flakes.len() >= c,
                (None, Some(v)) => volume >= v,
                (None, None) => true,
            };
            if done {
                break;
            }
            let d = draw_diameter(&spec.diameter, lognormal.as_ref(), &mut rng);
            let normal = sample_normal(&spec.orientation, &mut rng);
            // Rule 1 of module `inside`: a flake taller than the film gets a diameter
            // that fits at its tilt.
            let d = inside.diameter(d, normal.z, &mut rng);
            let r = 0.5 * d;
            let hz = half_extent(r, t, normal.z);
            let (lo, hi) = if hz <= 0.5 * f {
                (hz, f - hz)
            } else {
                (0.5 * f, 0.5 * f)
            };
            let index = flakes.len();
            // Rule 2: no depth of the rule lets it lie in the film: the nearest that does.
            let depth = DepthSampler::new(params.depth_bins(), lo, hi).unwrap_or_else(|| {
                inside.moved += 1;
                DepthSampler::at(nearest_allowed(params.depth_bins(), lo, hi))
            });
            let mut placed = false;
            for _ in 0..spec.max_attempts {
                attempts += 1;
                let x = l * rng.random::<f64>();
                let y = l * rng.random::<f64>();
                let z = -depth.sample(&mut rng);
                let flake = Flake {
                    centre: Vec3::new(x, y, z),
                    normal,
                    radius_um: r,
                    thickness_um: t,
                };
                if !placer.overlaps(&flake, &flakes)? {
                    placer.insert(&flake, index);
                    volume += flake.volume_um3();
                    flakes.push(flake);
                    placed = true;
                    break;
                }
            }
            if !placed {
                return Err(VolumeError::LoadingTooHigh {
                    placed: flakes.len(),
                    volume_fraction: volume / (l * l * f),
                    attempts: spec.max_attempts,
                });
            }
        }
        // Flakes near each other in the tile near each other in memory (the tracer reads
        // the flakes of a column together): sort along a Z-order curve of cells one mean
        // diameter wide. The sort is stable and the keys depend only on the positions.
        let cell = spec.diameter.mean_um();
        flakes.sort_by_key(|k| {
            let ix = ((k.centre.x / cell) as u32).min(0xffff);
            let iy = ((k.centre.y / cell) as u32).min(0xffff);
            morton(ix) | (morton(iy) << 1)
        });
        let area: f64 = flakes.iter().map(Flake::face_area_um2).sum();
        let projected: f64 = flakes.iter().map(|k| k.face_area_um2() * k.normal.z).sum();
        let stats = LayerStats {
            flakes: flakes.len(),
            requested_volume_fraction: spec.amount.volume_fraction(),
            volume_fraction: volume / (l * l * f),
            projected_coverage: projected / (l * l),
            area_coverage: area / (l * l),
            attempts,
            resized: inside.resized,
            moved: inside.moved,
            resized_area_fraction: if inside.resized > 0 {
                (inside.area_drawn - inside.area_resized)
                    / (area - inside.area_resized + inside.area_drawn)
            } else {
                0.0
            },
        };
        Ok(Self {
            film_um: f,
            tile_um: l,
            flakes,
            stats,
            mean_diameter_um: spec.diameter.mean_um(),
        })
    }

    /// A layer from given flakes, checked: every flake inside the film and the tile, with
    /// a positive radius and thickness, and no two overlapping (the same exact test as
    /// placement). For tests and for flakes measured elsewhere.
    ///
    /// # Errors
    /// [`VolumeError::Parameter`] for an invalid film or tile,
    /// [`VolumeError::TooManyFlakes`] for more than [`MAX_FLAKES`] flakes,
    /// [`VolumeError::BadFlake`] naming the first invalid flake,
    /// [`VolumeError::Overlap`] for the first overlapping pair,
    /// [`VolumeError::TileTooSmall`] for a flake that does not fit in the tile.
    pub fn from_flakes(
        film_um: f64,
        tile_um: f64,
        flakes: Vec<Flake>,
    ) -> Result<Self, VolumeError> {
        if !(film_um.is_finite() && film_um > 0.0) {
            return Err(VolumeError::Parameter {
                name: "film_um",
                value: film_um,
                expected: "a finite thickness > 0 µm",
            });
        }
        if !(tile_um.is_finite() && tile_um > 0.0) {
            return Err(VolumeError::Parameter {
                name: "tile_um",
                value: tile_um,
                expected: "a finite tile side > 0 µm",
            });
        }
        if flakes.len() > MAX_FLAKES {
            return Err(VolumeError::TooManyFlakes {
                requested: flakes.len() as f64,
                max: MAX_FLAKES,
            });
        }
        let mut max_extent: f64 = 0.0;
        for (i, k) in flakes.iter().enumerate() {
            let bad = |reason: &'static str| VolumeError::BadFlake { index: i, reason };
            if !(k.radius_um.is_finite() && k.radius_um > 0.0) {
                return Err(bad("radius must be finite and > 0"));
            }
            if !(k.thickness_um.is_finite() && k.thickness_um > 0.0) {
                return Err(bad("thickness must be finite and > 0"));
            }
            if k.centre.iter().any(|v| !v.is_finite())
                || !(0.0..tile_um).contains(&k.centre.x)
                || !(0.0..tile_um).contains(&k.centre.y)
            {
                return Err(bad("centre x and y must lie in [0, tile_um)"));
            }
            if k.normal.iter().any(|v| !v.is_finite())
                || k.normal.z < 0.0
                || (k.normal.norm() - 1.0).abs() > 1e-9
            {
                return Err(bad("normal must be a unit vector with z >= 0"));
            }
            let hz = k.half_extent(&Vec3::z());
            if k.centre.z + hz > 0.0 || k.centre.z - hz < -film_um {
                return Err(bad("flake must lie wholly inside the film"));
            }
            max_extent = max_extent.max(k.diameter_um() + k.thickness_um);
        }
        if tile_um <= max_extent {
            return Err(VolumeError::TileTooSmall {
                tile_um,
                flake_extent_um: max_extent,
            });
        }
        let mut placer = Placer::new(tile_um, max_extent);
        for (i, k) in flakes.iter().enumerate() {
            if let Some(j) = placer.first_overlap(k, &flakes[..i])? {
                return Err(VolumeError::Overlap {
                    first: j,
                    second: i,
                });
            }
            placer.insert(k, i);
        }
        let volume: f64 = flakes.iter().map(Flake::volume_um3).sum();
        let area: f64 = flakes.iter().map(Flake::face_area_um2).sum();
        let projected: f64 = flakes.iter().map(|k| k.face_area_um2() * k.normal.z).sum();
        let mean_d = if flakes.is_empty() {
            0.0
        } else {
            flakes.iter().map(Flake::diameter_um).sum::<f64>() / flakes.len() as f64
        };
        let stats = LayerStats {
            flakes: flakes.len(),
            requested_volume_fraction: None,
            volume_fraction: volume / (tile_um * tile_um * film_um),
            projected_coverage: projected / (tile_um * tile_um),
            area_coverage: area / (tile_um * tile_um),
            attempts: flakes.len() as u64,
            resized: 0,
            moved: 0,
            resized_area_fraction: 0.0,
        };
        Ok(Self {
            film_um,
            tile_um,
            flakes,
            stats,
            mean_diameter_um: mean_d,
        })
    }

    /// Film thickness, µm.
    #[must_use]
    pub fn film_um(&self) -> f64 {
        self.film_um
    }

    /// Tile side, µm.
    #[must_use]
    pub fn tile_um(&self) -> f64 {
        self.tile_um
    }

    /// The flakes: in the order given to [`Layer::from_flakes`], or for a generated
    /// layer sorted along a Z-order curve of the tile (for memory locality).
    #[must_use]
    pub fn flakes(&self) -> &[Flake] {
        &self.flakes
    }

    /// What placement achieved.
    #[must_use]
    pub fn stats(&self) -> &LayerStats {
        &self.stats
    }

    /// Mean diameter of the flake distribution (or of the given flakes), µm; sets the
    /// tracing grid's cell size.
    #[must_use]
    pub fn mean_diameter_um(&self) -> f64 {
        self.mean_diameter_um
    }

    /// Bytes held by the flake list (the tracer's grid adds its own, see
    /// [`crate::Tracer::memory_bytes`]).
    #[must_use]
    pub fn memory_bytes(&self) -> usize {
        self.flakes.capacity() * std::mem::size_of::<Flake>()
    }
}

/// The bits of `v` (16 used) spread to the even bit positions.
fn morton(v: u32) -> u64 {
    let mut x = u64::from(v & 0xffff);
    x = (x | (x << 8)) & 0x00ff_00ff;
    x = (x | (x << 4)) & 0x0f0f_0f0f;
    x = (x | (x << 2)) & 0x3333_3333;
    (x | (x << 1)) & 0x5555_5555
}

fn draw_diameter(d: &Diameter, lognormal: Option<&LogNormal<f64>>, rng: &mut ChaCha8Rng) -> f64 {
    match (*d, lognormal) {
        (Diameter::LogNormal { mean_um, .. }, Some(ln)) => loop {
            let v = ln.sample(rng);
            if (0.25 * mean_um..=3.0 * mean_um).contains(&v) {
                break v;
            }
        },
        (Diameter::LogNormal { mean_um, .. }, None) => mean_um,
        (Diameter::Fixed(v), _) => v,
    }
}

fn sample_normal(o: &Orientation, rng: &mut ChaCha8Rng) -> UnitVec3 {
    let m = o.sample_normal(rng);
    UnitVec3::new_unchecked(Vec3::new(m.x, m.y, m.z))
}

/// Draws a centre depth from the depth bins restricted to `[lo, hi]` (exact inverse CDF
/// of the restricted piecewise-constant density).
struct DepthSampler {
    /// `(lo, hi, cumulative mass)` of the restricted bins.
    bins: Vec<(f64, f64, f64)>,
}

impl DepthSampler {
    /// Every centre at depth `z`.
    fn at(z: f64) -> Self {
        Self {
            bins: vec![(z, z, 1.0)],
        }
    }

    fn new(depth: &DepthBins, lo: f64, hi: f64) -> Option<Self> {
        if !(hi >= lo) {
            return None;
        }
        match depth {
            DepthBins::Fixed(z) => (lo..=hi).contains(z).then(|| Self {
                bins: vec![(*z, *z, 1.0)],
            }),
            DepthBins::Bins(b) => {
                let mut out = Vec::new();
                let mut acc = 0.0;
                for &(a, c, w) in b {
                    let (a, c) = (a.max(lo), c.min(hi));
                    if c > a {
                        acc += w * (c - a);
                        out.push((a, c, acc));
                    }
                }
                if out.is_empty() {
                    // A range of zero width (lo = hi) inside a bin still allows one depth.
                    return b
                        .iter()
                        .any(|&(a, c, _)| a <= lo && lo <= c && lo == hi)
                        .then(|| Self {
                            bins: vec![(lo, lo, 1.0)],
                        });
                }
                for bin in &mut out {
                    bin.2 /= acc;
                }
                Some(Self { bins: out })
            }
        }
    }

    fn sample(&self, rng: &mut ChaCha8Rng) -> f64 {
        let u: f64 = rng.random();
        let i = self
            .bins
            .partition_point(|b| b.2 <= u)
            .min(self.bins.len() - 1);
        let (a, c, _) = self.bins[i];
        let v: f64 = rng.random();
        a + v * (c - a)
    }
}

/// A hash of flake centres on a periodic grid of cells at least as wide as the largest
/// interaction range, for the overlap queries of placement.
struct Placer {
    tile: f64,
    side: usize,
    cell: f64,
    cells: Vec<Vec<u32>>,
}

impl Placer {
    fn new(tile: f64, range: f64) -> Self {
        // Cells at least `range` wide, at most 1024 per side (memory), at least 1.
        let range = if range > 0.0 { range } else { tile };
        let side = ((tile / range).floor() as usize).clamp(1, 1024);
        Self {
            tile,
            side,
            cell: tile / side as f64,
            cells: vec![Vec::new(); side * side],
        }
    }

    fn cell_of(&self, v: f64) -> usize {
        ((v / self.cell) as usize).min(self.side - 1)
    }

    fn insert(&mut self, k: &Flake, index: usize) {
        let (ix, iy) = (self.cell_of(k.centre.x), self.cell_of(k.centre.y));
        self.cells[iy * self.side + ix].push(index as u32);
    }

    fn overlaps(&self, k: &Flake, flakes: &[Flake]) -> Result<bool, VolumeError> {
        Ok(self.first_overlap(k, flakes)?.is_some())
    }

    /// The first placed flake (or periodic image of one) that `k` overlaps.
    fn first_overlap(&self, k: &Flake, flakes: &[Flake]) -> Result<Option<usize>, VolumeError> {
        let check = |j: usize| -> Result<bool, VolumeError> {
            let other = &flakes[j];
            let reach = k.bounding_radius() + other.bounding_radius();
            let d = other.centre - k.centre;
            for sx in [-1.0, 0.0, 1.0] {
                for sy in [-1.0, 0.0, 1.0] {
                    let dx = d.x + sx * self.tile;
                    let dy = d.y + sy * self.tile;
                    if dx * dx + dy * dy + d.z * d.z > reach * reach {
                        continue;
                    }
                    let shifted = Vec3::new(
                        other.centre.x + sx * self.tile,
                        other.centre.y + sy * self.tile,
                        other.centre.z,
                    );
                    if cylinders_intersect(k, other, &shifted)? {
                        return Ok(true);
                    }
                }
            }
            Ok(false)
        };
        if self.side < 3 {
            for j in 0..flakes.len() {
                if check(j)? {
                    return Ok(Some(j));
                }
            }
            return Ok(None);
        }
        let (ix, iy) = (self.cell_of(k.centre.x), self.cell_of(k.centre.y));
        let s = self.side;
        let mut found: Option<usize> = None;
        for dy in [s - 1, 0, 1] {
            for dx in [s - 1, 0, 1] {
                let c = ((iy + dy) % s) * s + (ix + dx) % s;
                for &j in &self.cells[c] {
                    let j = j as usize;
                    if found.is_some_and(|f| f <= j) {
                        continue;
                    }
                    if check(j)? {
                        found = Some(j);
                    }
                }
            }
        }
        Ok(found)
    }
}

/// The parry pose of a flake cylinder (parry's cylinders lie along their local `y`).
fn pose(centre: &Vec3, normal: &UnitVec3) -> Pose {
    let m = Vector::new(normal.x, normal.y, normal.z);
    Pose::from_parts(
        Vector::new(centre.x, centre.y, centre.z),
        Rot3::from_rotation_arc(Vector::Y, m),
    )
}

/// Exact (GJK) intersection test of flake `a` and flake `b` moved to `b_centre`.
fn cylinders_intersect(a: &Flake, b: &Flake, b_centre: &Vec3) -> Result<bool, VolumeError> {
    let ca = Cylinder::new(0.5 * a.thickness_um, a.radius_um);
    let cb = Cylinder::new(0.5 * b.thickness_um, b.radius_um);
    intersection_test(
        &pose(&a.centre, &a.normal),
        &ca,
        &pose(b_centre, &b.normal),
        &cb,
    )
    .map(|r| r.intersecting)
    .map_err(|e| VolumeError::Geometry(format!("cylinder overlap test: {e:?}")))
}

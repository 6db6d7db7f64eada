//! Random fields and Gaussian filters on a pixel grid.
//!
//! Conventions: grids are row-major (`index = row * nx + col`), `x = col * dx` and
//! `y = row * dy` in micrometres (the `HeightMap` convention of the stats crate).
//!
//! Randomness is reproducible and independent of the number of threads: every row of
//! every field draws from its own ChaCha8 generator, seeded from the layer seed, a
//! per-field tag and the row index ([`stream_rng`]). Rows are then processed in
//! parallel in any order without changing a single bit.
//!
//! **Correlated field.** [`correlated_field`] filters white Gaussian noise with a
//! separable Gaussian kernel `g(u) = exp(-u² / (2 s²))`, `s = ℓ / 2`, per axis. The
//! autocorrelation of the result is `g ⋆ g ∝ exp(-u² / (4 s²))`, so
//! `C(Δx, Δy) = rms² · exp(-(Δx² + Δy²) / ℓ²)`: `ℓ` is the lag at which the
//! correlation has fallen to `1/e` (the usual "Gaussian correlation length" of surface
//! metrology). The field is scaled by the exact variance of the discrete filter,
//! `(Σ gx²)(Σ gy²)`, so its *expected* mean square is `rms²`; one realisation
//! fluctuates about it by roughly `sqrt(π ℓ² / A)` in relative variance (`A` the map area).

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;

/// Tags that separate the random streams of the generator.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Stream {
    /// Flake placement, sizes and orientations (one sequential stream).
    Flakes = 1,
    /// Background heights between flakes.
    Background = 2,
    /// White noise behind the roughness field.
    Roughness = 3,
    /// Confocal height noise.
    HeightNoise = 4,
    /// Intensity noise.
    IntensityNoise = 5,
    /// Photon and read noise of rendered confocal stacks (`stack` module).
    StackNoise = 6,
}

/// SplitMix64 finaliser: a bijective 64-bit mix (Steele, Lea & Flood 2014).
const fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The generator of stream `tag`, row `row`, for the layer seed `seed`.
pub(crate) fn stream_rng(seed: u64, tag: Stream, row: u64) -> ChaCha8Rng {
    let key = splitmix64(splitmix64(splitmix64(seed) ^ tag as u64) ^ row);
    ChaCha8Rng::seed_from_u64(key)
}

/// Samples of `exp(-k² / (2 s²))` for `k = -R..=R`, `R = ceil(4 s)` (not normalised).
/// `s` is in pixels and must be positive.
pub(crate) fn gaussian_kernel(s_px: f64) -> Vec<f64> {
    let radius = (4.0 * s_px).ceil().max(1.0) as isize;
    (-radius..=radius)
        .map(|k| {
            let u = k as f64 / s_px;
            (-0.5 * u * u).exp()
        })
        .collect()
}

/// A field of independent standard normal values, `nx` × `ny`, one stream per row.
pub(crate) fn white_noise(seed: u64, tag: Stream, nx: usize, ny: usize) -> Vec<f64> {
    let mut out = vec![0.0; nx * ny];
    out.par_chunks_mut(nx.max(1))
        .enumerate()
        .for_each(|(row, chunk)| {
            let mut rng = stream_rng(seed, tag, row as u64);
            for v in chunk {
                *v = StandardNormal.sample(&mut rng);
            }
        });
    out
}

/// Correlated Gaussian field of mean square `rms²` and correlation length `ell_um`
/// (see the module docs for the correlation function). `ell_um = 0` gives white noise
/// of the same rms.
pub(crate) fn correlated_field(
    seed: u64,
    nx: usize,
    ny: usize,
    dx_um: f64,
    dy_um: f64,
    rms_um: f64,
    ell_um: f64,
) -> Vec<f64> {
    if ell_um <= 0.0 {
        let mut f = white_noise(seed, Stream::Roughness, nx, ny);
        f.iter_mut().for_each(|v| *v *= rms_um);
        return f;
    }
    let kx = gaussian_kernel(ell_um / 2.0 / dx_um);
    let ky = gaussian_kernel(ell_um / 2.0 / dy_um);
    let (rx, ry) = (kx.len() / 2, ky.len() / 2);
    // Noise on a padded grid, so that every output pixel sees a full kernel.
    let (px, py) = (nx + 2 * rx, ny + 2 * ry);
    let noise = white_noise(seed, Stream::Roughness, px, py);
    // Row pass (valid part only): py rows of nx values.
    let mut rows = vec![0.0; nx * py];
    rows.par_chunks_mut(nx)
        .zip(noise.par_chunks(px))
        .for_each(|(out, src)| {
            for (c, o) in out.iter_mut().enumerate() {
                *o = kx
                    .iter()
                    .zip(&src[c..c + kx.len()])
                    .map(|(w, v)| w * v)
                    .sum();
            }
        });
    // Column pass: ny rows of nx values.
    let norm = rms_um
        / (kx.iter().map(|w| w * w).sum::<f64>() * ky.iter().map(|w| w * w).sum::<f64>()).sqrt();
    let mut out = vec![0.0; nx * ny];
    out.par_chunks_mut(nx).enumerate().for_each(|(r, o)| {
        for (k, w) in ky.iter().enumerate() {
            let src = &rows[(r + k) * nx..(r + k + 1) * nx];
            for (a, b) in o.iter_mut().zip(src) {
                *a += w * b;
            }
        }
        o.iter_mut().for_each(|v| *v *= norm);
    });
    out
}

/// Blur `data` (`nx` × `ny`) with a normalised Gaussian of standard deviation `sd_um`.
/// At the map edges the truncated kernel is renormalised over the pixels that exist,
/// so a constant map stays constant.
pub(crate) fn gaussian_blur(
    data: &mut [f64],
    nx: usize,
    ny: usize,
    dx_um: f64,
    dy_um: f64,
    sd_um: f64,
) {
    if sd_um <= 0.0 {
        return;
    }
    let kx = gaussian_kernel(sd_um / dx_um);
    let ky = gaussian_kernel(sd_um / dy_um);
    let (rx, ry) = ((kx.len() / 2) as isize, (ky.len() / 2) as isize);
    let mut tmp = vec![0.0; nx * ny];
    tmp.par_chunks_mut(nx)
        .zip(data.par_chunks(nx))
        .for_each(|(out, src)| {
            for (c, o) in out.iter_mut().enumerate() {
                let lo = (c as isize - rx).max(0);
                let hi = (c as isize + rx).min(nx as isize - 1);
                let (mut s, mut w) = (0.0, 0.0);
                for j in lo..=hi {
                    let wk = kx[(j - c as isize + rx) as usize];
                    s += wk * src[j as usize];
                    w += wk;
                }
                *o = s / w;
            }
        });
    data.par_chunks_mut(nx).enumerate().for_each(|(r, out)| {
        let lo = (r as isize - ry).max(0);
        let hi = (r as isize + ry).min(ny as isize - 1);
        out.iter_mut().for_each(|v| *v = 0.0);
        let mut wsum = 0.0;
        for j in lo..=hi {
            let wk = ky[(j - r as isize + ry) as usize];
            wsum += wk;
            let src = &tmp[j as usize * nx..(j as usize + 1) * nx];
            for (a, b) in out.iter_mut().zip(src) {
                *a += wk * b;
            }
        }
        out.iter_mut().for_each(|v| *v /= wsum);
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blur_keeps_constants_and_mass_of_a_centred_spike() {
        let (nx, ny) = (41, 37);
        let mut c = vec![2.5; nx * ny];
        gaussian_blur(&mut c, nx, ny, 0.2, 0.3, 0.5);
        assert!(c.iter().all(|v| (v - 2.5).abs() < 1e-12));
        // A unit spike far from the edges: the blur redistributes it with weights summing
        // to 1, and its second moment along x is the kernel's, s² = (0.5/0.2)² px².
        let mut d = vec![0.0; nx * ny];
        d[18 * nx + 20] = 1.0;
        gaussian_blur(&mut d, nx, ny, 0.2, 0.3, 0.5);
        let total: f64 = d.iter().sum();
        assert!((total - 1.0).abs() < 1e-12);
        let m2: f64 = (0..ny)
            .flat_map(|r| (0..nx).map(move |c| (r, c)))
            .map(|(r, c)| d[r * nx + c] * (c as f64 - 20.0).powi(2))
            .sum();
        // Discrete Gaussian with s = 2.5 px truncated at 4 s: variance equals s² to ~1e-3.
        assert!((m2 - 6.25).abs() < 0.01, "{m2}");
    }

    #[test]
    fn streams_are_distinct_and_reproducible() {
        let a = white_noise(7, Stream::Background, 16, 4);
        let b = white_noise(7, Stream::Background, 16, 4);
        let c = white_noise(7, Stream::Roughness, 16, 4);
        assert_eq!(a, b);
        assert_ne!(a, c);
        assert_ne!(a[..16], a[16..32]);
    }
}

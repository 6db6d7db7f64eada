//! The colour of an aluminium flake seen as a mirror at normal incidence: the built-in
//! optical constants (optics::material) through the flake reflectance (optics::flake)
//! and the colorimetry (colour), against colour-science 0.4.7 doing the same sums from
//! the same tables. The reference numbers come from this script, run in a venv outside
//! the repository (`pip install colour-science==0.4.7 numpy`) from the repository root:
//!
//! ```text
//! import numpy as np, colour
//! grid = np.arange(360.0, 831.0)
//! ill = colour.SpectralDistribution(dict(zip(*np.genfromtxt(
//!     "crates/colour/data/CIE_std_illum_D65.csv", delimiter=",").T)))
//! cmfs = colour.MSDS_CMFS["CIE 1964 10 Degree Standard Observer"]
//! white = colour.sd_to_XYZ(colour.SpectralDistribution(dict(zip(grid, np.ones_like(grid)))),
//!                          cmfs, ill, method="Integration")
//! for name in ("rakic1995", "mcpeak2015"):
//!     d = np.genfromtxt(f"crates/optics/data/aluminium_{name}.csv", delimiter=",",
//!                       comments="#", skip_header=1)
//!     d = d[~np.isnan(d[:, 0])]
//!     n, k = np.interp(grid, d[:, 0], d[:, 1]), np.interp(grid, d[:, 0], d[:, 2])
//!     for medium in (1.0, 1.5):
//!         N = (n + 1j * k) / medium
//!         R = np.abs((1 - N) / (1 + N)) ** 2
//!         XYZ = colour.sd_to_XYZ(colour.SpectralDistribution(dict(zip(grid, R))), cmfs, ill,
//!                                method="Integration")
//!         print(name, medium, colour.XYZ_to_Lab(XYZ / 100, colour.XYZ_to_xy(white / 100)))
//! ```
//!
//! The tint is small and bluish-green (a* ≈ −0.2 to −0.4, b* ≈ −0.5 to −0.8), slightly
//! stronger under a clear coat, and the two datasets agree on its sign and size.

use flakescatter::colour::{Illuminant, Lab, Observer, TristimulusWeights, delta_e_ab};
use flakescatter::optics::material::ComplexIndexTable;

fn flake_lab(table: &ComplexIndexTable, n_medium: f64) -> Lab {
    let wl: Vec<f64> = (360..=830).map(f64::from).collect();
    let r: Vec<f64> = wl
        .iter()
        .map(|&l| table.flake_at(l).unwrap().average(1.0, n_medium))
        .collect();
    TristimulusWeights::new(&wl, Illuminant::D65, Observer::Cie1964TenDegree)
        .unwrap()
        .lab(&r)
        .unwrap()
}

#[test]
fn aluminium_flake_tint_matches_colour_science() {
    let cases = [
        (
            ComplexIndexTable::aluminium_rakic_1995(),
            1.0,
            [96.611414, -0.215165, -0.469636],
        ),
        (
            ComplexIndexTable::aluminium_rakic_1995(),
            1.5,
            [95.083025, -0.323923, -0.769658],
        ),
        (
            ComplexIndexTable::aluminium_mcpeak_2015(),
            1.0,
            [96.613359, -0.275403, -0.477951],
        ),
        (
            ComplexIndexTable::aluminium_mcpeak_2015(),
            1.5,
            [95.121772, -0.412340, -0.803776],
        ),
    ];
    for (table, n_medium, [l, a, b]) in cases {
        let ours = flake_lab(table, n_medium);
        let de = delta_e_ab(&Lab { l, a, b }, &ours);
        assert!(
            de < 1e-4,
            "n_medium {n_medium}: {ours:?} vs ({l}, {a}, {b}), ΔE*ab {de}"
        );
        assert!(ours.a < 0.0 && ours.b < 0.0);
    }
}

"""flakescatter from Python: a shipped confocal map to both models' curves.

Run from the repository root after ``pip install ./crates/python``:

    python examples/python/quickstart.py            # prints the numbers
    python examples/python/quickstart.py out.png    # and plots them (needs matplotlib)

Angles are degrees (signed in-plane detector angles: theta_s = -theta_i is specular),
lengths micrometres, BRDF 1/sr, as on the command line.
"""

import pathlib
import sys

import numpy as np

import flakescatter as fs

ROOT = pathlib.Path(__file__).resolve().parents[2]
FIXTURES = ROOT / "fixtures"

# A synthetic confocal map of a layer of flakes with hwhm 6 deg (fixtures/README.md),
# masked by its intensity image where the microscope saw no flake.
height = fs.read_map(
    FIXTURES / "synth-hwhm6-rough.height.x3p",
    intensity=FIXTURES / "synth-hwhm6-rough.intensity.x3p",
    cutoff=0.49,
)
print(f"map: {height.nx} x {height.ny} pixels, pitch {height.pitch_um} um")

# Individual flakes and their area-weighted orientation distribution.
flakes = fs.segment(height)
stats = fs.orientation_stats(flakes)
lo, hi = stats["hwhm_ci95_deg"]
print(
    f"{len(flakes['area_um2'])} flakes; fitted hwhm {stats['hwhm_deg']:.2f} deg "
    f"(95 % interval {lo:.2f} to {hi:.2f}, {stats['hwhm_ci95_method']})"
)

# Both models at 30 deg incidence, in-plane detectors every degree.
theta_s = np.arange(-89.0, 90.0, 1.0)
dist = fs.distribution_model(hwhm=stats["hwhm_deg"], theta_i=[30.0], theta_s=theta_s)
topo = fs.topographic_model(height, theta_i=[30.0], theta_s=theta_s)
k = int(np.argmin(np.abs(theta_s + 30.0)))
print(f"BRDF at specular (1/sr): distribution {dist['brdf_per_sr'][k]:.4g}, "
      f"topographic {topo['brdf_per_sr'][k]:.4g} +- {topo['std_err'][k]:.2g}")
# The shipped maps keep the microscope's 0.3 um z step (heights of the brightest slice),
# so most 5 x 5 windows see a flat terrace and reflect like a mirror: the topographic
# model puts most of its light at specular. Localise real z-stacks between the slices
# (fs.localise_stack, Gaussian peak; docs/guide.md section 8) before tracing them.
near = np.abs(theta_s + 30.0) <= 2.0
share = np.nansum(topo["reflectance"][near]) / np.nansum(topo["reflectance"])
print(f"topographic model: {share:.0%} of the collected light within 2 deg of specular")

if len(sys.argv) > 1:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5))
    ax.semilogy(dist["theta_s_deg"], dist["relative"], label="distribution model")
    ax.errorbar(
        topo["theta_s_deg"],
        topo["relative"],
        yerr=topo["relative"] * topo["std_err"] / topo["brdf_per_sr"],
        fmt=".",
        ms=3,
        label="topographic model (+- 1 standard error)",
    )
    ax.set_xlabel("detector angle theta_s (degrees)")
    ax.set_ylabel("relative reflectance (1 at specular)")
    ax.set_title("Synthetic hwhm-6 deg layer, theta_i = 30 deg (synthetic data)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(sys.argv[1], dpi=150)
    print(f"wrote {sys.argv[1]}")

"""Linear-sRGB weights of a BRDF spectrum sampled at 380, 390, ..., 780 nm, made with
colour-science (https://www.colour-science.org, BSD-3-Clause), independently of
flakescatter: for each wavelength i the unit spectrum e_i goes through
colour.sd_to_XYZ (CIE 1931 2 degree observer, illuminant D65, method "ASTM E308"),
divided by 100 (Y = 1 for the white), then colour.XYZ_to_RGB to sRGB without the
transfer function (linear) and without chromatic adaptation (illuminant = sRGB's D65
white). RGB of a spectrum f = sum_i f_i * row_i.

Run: python make_srgb_weights.py > srgb_weights_380_780_10.csv
"""

import sys

import colour
import numpy as np

wl = np.arange(380, 781, 10)
cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
ill = colour.SDS_ILLUMINANTS["D65"]
srgb = colour.RGB_COLOURSPACES["sRGB"]
print(f"# colour-science {colour.__version__}: linear sRGB weight of each wavelength")
print("wavelength_nm,r,g,b")
for i, w in enumerate(wl):
    v = np.zeros(len(wl))
    v[i] = 1.0
    sd = colour.SpectralDistribution(dict(zip(wl, v)))
    xyz = colour.sd_to_XYZ(sd, cmfs, ill, method="ASTM E308") / 100.0
    rgb = colour.XYZ_to_RGB(
        xyz, srgb, illuminant=srgb.whitepoint, apply_cctf_encoding=False
    )
    print(f"{w}," + ",".join(f"{x:.12g}" for x in rgb))
sys.stdout.flush()

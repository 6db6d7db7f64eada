"""Writes `python.zarr`, a Zarr v3 height-map store made by zarr-python (independently of
flakescatter's writer), and `expected.txt`, the values numpy computes from the same
arrays. Run from this directory:  python make_zarr.py  (see README.md for versions).

Layout (docs/formats.md "Zarr v3 maps"): root group attributes pitch_x_um, pitch_y_um,
height_unit; arrays height (float64 [ny, nx], NaN = invalid), mask (bool), intensity
(float64). Chunks of 2 x 3 points on a 5 x 7 map: partial chunks at the right and
bottom edges. Codecs: zarr-python's defaults (bytes + zstd).
"""

import shutil

import numpy as np
import zarr

NY, NX = 5, 7
y, x = np.mgrid[0:NY, 0:NX].astype(np.float64)
height = 1.7 * np.sin(0.3 * x) * np.cos(0.2 * y) + 0.01 * x * y - 0.125
height[1, 4] = np.nan  # invalid in the heights themselves
mask = np.ones((NY, NX), dtype=bool)
mask[3, 0] = False  # invalid by the mask
mask[4, 6] = False
intensity = 100.0 + 10.0 * x + y

shutil.rmtree("python.zarr", ignore_errors=True)
root = zarr.open_group("python.zarr", mode="w", zarr_format=3)
root.attrs.update({"pitch_x_um": 0.18, "pitch_y_um": 0.25, "height_unit": "um"})
for name, data in [("height", height), ("mask", mask), ("intensity", intensity)]:
    a = root.create_array(name, shape=data.shape, chunks=(2, 3), dtype=data.dtype,
                          fill_value=np.nan if data.dtype == np.float64 else False)
    a[:] = data

# What a reader must give: heights with the mask applied (NaN = invalid), row-major.
expected = np.where(mask, height, np.nan)
with open("expected.txt", "w") as f:
    f.write(f"# zarr {zarr.__version__}, numpy {np.__version__}\n")
    f.write(f"shape {NY} {NX}\n")
    f.write(f"valid {int(np.isfinite(expected).sum())}\n")
    f.write(f"mean {float(np.nanmean(expected))!r}\n")
    f.write(f"intensity_sum {float(intensity.sum())!r}\n")
    for v in expected.ravel():
        f.write(f"{float(v)!r}\n")

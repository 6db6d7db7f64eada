"""MERL BRDF tables (`flakescatter.read_brdf`) against a file written here with numpy
in the layout of MERL's reference reader (Matusik et al. 2003): three little-endian
int32 90, 90, 180, then 3 x 90 x 90 x 180 little-endian float64, R, G, B, each the BRDF
divided by 1/1500, 1.15/1500, 1.66/1500; a negative number is a bin without a value."""

import numpy as np
import pytest

import flakescatter as fs

SCALES = np.array([1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0])


def write_merl(path, stored):
    with open(path, "wb") as f:
        f.write(np.array([90, 90, 180], dtype="<i4").tobytes())
        f.write(np.ascontiguousarray(stored, dtype="<f8").tobytes())


def test_values_come_back_scaled_with_nan_for_bins_without_a_value(tmp_path):
    rng = np.random.default_rng(3)
    stored = rng.uniform(0.0, 5000.0, size=(3, 90, 90, 180))
    stored[:, 89, 80:, :] = -1.0  # grazing bins without a value
    p = tmp_path / "paint.binary"
    write_merl(p, stored)
    t = fs.read_brdf(p)
    assert t["channels"] == ["R", "G", "B"]
    assert t["brdf"].shape == (3, 90, 90, 180)
    want = stored * SCALES[:, None, None, None]
    filled = stored >= 0
    # stored x scale, the reference reader's product, exactly.
    assert np.array_equal(t["brdf"][filled], want[filled])
    assert np.isnan(t["brdf"][~filled]).all()
    # The flat order is the file's: bin p + 180 d + 16200 h of channel c.
    c, h, d, p_ = 2, 17, 33, 101
    flat = stored.reshape(-1)[c * 1458000 + p_ + 180 * d + 16200 * h]
    assert t["brdf"][c, h, d, p_] == flat * SCALES[c]


def test_bad_files_raise_naming_the_file(tmp_path):
    with pytest.raises(fs.FileError, match="missing.binary"):
        fs.read_brdf(tmp_path / "missing.binary")
    short = tmp_path / "short.binary"
    write_merl(short, np.zeros(100))
    with pytest.raises(fs.FileFormatError, match=r"short\.binary.*truncated"):
        fs.read_brdf(short)
    dims = tmp_path / "dims.binary"
    dims.write_bytes(np.array([90, 90, 360], dtype="<i4").tobytes() + bytes(16))
    with pytest.raises(fs.FileFormatError, match=r"dims\.binary.*\[90, 90, 360\]"):
        fs.read_brdf(dims)

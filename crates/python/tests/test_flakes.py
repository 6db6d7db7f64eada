"""segment / orientation_stats: the CLI's `segment` flake table and `stats` histogram and
JSON, number for number."""

import numpy as np
import pytest

import flakescatter as fs
from conftest import CUTOFF, HEIGHT, INTENSITY, assert_column_equal, read_csv

FLAKE_COLUMNS = [
    "x_um", "y_um", "nx", "ny", "nz", "area_um2", "theta_n_deg", "phi_n_deg",
    "projected_area_um2", "equivalent_diameter_um", "rms_um", "tilt_se_deg",
    "pixels", "inliers", "touches_border", "quality",
]


@pytest.fixture(scope="module")
def flakes():
    m = fs.read_map(HEIGHT, intensity=INTENSITY, cutoff=CUTOFF)
    return fs.segment(m)


@pytest.fixture(scope="module")
def cli_table(cli, tmp_path_factory):
    out = tmp_path_factory.mktemp("seg") / "flakes.csv"
    cli.run("segment", HEIGHT, "--intensity", INTENSITY, "--cutoff", CUTOFF, "--out", out)
    return out


def test_segment_equals_cli_table(flakes, cli_table):
    table = read_csv(cli_table)
    # The CLI's table also says which map (file) and which flake of it each row is, for
    # tables pooled over several maps; segment() takes one Map and returns its flakes
    # in the same order.
    assert list(flakes) == FLAKE_COLUMNS
    assert list(table) == FLAKE_COLUMNS + ["map", "flake"]
    n = len(table["x_um"])
    assert n > 30
    for c in FLAKE_COLUMNS:
        a = flakes[c]
        assert a.ndim == 1 and a.shape == (n,), c
        if c in ("pixels", "inliers"):
            assert a.dtype == np.int64
            assert a.tolist() == [int(v) for v in table[c]], c
        elif c == "touches_border":
            assert a.dtype == np.bool_
            assert a.tolist() == [v == "true" for v in table[c]]
        else:
            assert a.dtype == np.float64
            assert_column_equal(a, table[c], c)
    # The normals are unit vectors and theta_n is their polar angle (closed form).
    norm = np.sqrt(flakes["nx"] ** 2 + flakes["ny"] ** 2 + flakes["nz"] ** 2)
    np.testing.assert_allclose(norm, 1.0, atol=1e-12)
    np.testing.assert_allclose(np.degrees(np.arccos(flakes["nz"])), flakes["theta_n_deg"], atol=1e-6)


def test_segment_parameters_as_cli(cli, tmp_path):
    m = fs.read_map(HEIGHT, intensity=INTENSITY, cutoff=CUTOFF)
    got = fs.segment(m, z_step_um=0.1, noise_um=0.01, min_pixels=400)
    out = tmp_path / "f.csv"
    cli.run("segment", HEIGHT, "--intensity", INTENSITY, "--cutoff", CUTOFF,
            "--z-step-um", 0.1, "--noise-um", 0.01, "--min-pixels", 400, "--out", out)
    table = read_csv(out)
    assert_column_equal(got["area_um2"], table["area_um2"])
    assert_column_equal(got["theta_n_deg"], table["theta_n_deg"])


def test_orientation_stats_equals_cli_stats(flakes, cli_table, cli, tmp_path):
    hist = tmp_path / "hist.csv"
    want = cli.json("stats", "--flakes", cli_table, "--bin", 0.5, "--out", hist)
    table = read_csv(hist)
    for source in (flakes, cli_table, str(cli_table)):
        got = fs.orientation_stats(source, bin_deg=0.5)
        h = got["histogram"]
        assert list(h) == list(table)
        for c in table:
            assert h[c].dtype == np.float64 and h[c].ndim == 1
            assert_column_equal(h[c], table[c], c)
        for k in ("hwhm_deg", "sigma_deg", "effective_flakes", "flakes", "total_area_um2"):
            assert got[k] == want[k], k
        lo, hi = got["hwhm_ci95_deg"]
        cli_lo, cli_hi = want["hwhm_ci95_deg"]
        assert lo == cli_lo and hi == (float("inf") if cli_hi is None else cli_hi)
        assert got["hwhm_ci95_method"] == want["hwhm_ci95_method"]
        assert got["column_set"] == want["input"]["column_set"]
    # The area fractions sum to 1 and p_per_rad is the fraction per bin width (closed form).
    assert h["area_fraction"].sum() == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(
        h["p_per_rad"], h["area_fraction"] / np.radians(h["theta_hi_deg"] - h["theta_lo_deg"]), rtol=1e-9
    )


def test_orientation_stats_errors(cli, tmp_path, flakes):
    with pytest.raises(fs.InputError):
        fs.orientation_stats(flakes, bin_deg=0.0)
    with pytest.raises(fs.InputError):
        fs.orientation_stats({"nx": [0.0], "ny": [0.0]})
    bad = tmp_path / "bad.csv"
    bad.write_text("nx,ny,nz,area_um2\n0,0,1,5\n0,0,x,5\n")
    with pytest.raises(fs.FileFormatError) as e:
        fs.orientation_stats(bad)
    assert isinstance(e.value, ValueError)
    assert str(e.value) in cli.fails("stats", "--flakes", bad)
    with pytest.raises(fs.FileError):
        fs.orientation_stats(tmp_path / "missing.csv")


def test_segment_errors():
    m = fs.read_map(HEIGHT)
    for kwargs in (dict(z_step_um=-1), dict(noise_um=float("nan")), dict(min_pixels=2)):
        with pytest.raises(fs.InputError):
            fs.segment(m, **kwargs)
    with pytest.raises(TypeError):
        fs.segment("not a map")

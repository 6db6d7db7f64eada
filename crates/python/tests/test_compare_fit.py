"""compare / fit against the CLI's `compare --json --out` and `fit --json`, on a measured
curve made by the CLI's distribution model with a deterministic ripple."""

import math

import numpy as np
import pytest

import flakescatter as fs
from conftest import assert_column_equal, read_csv


@pytest.fixture(scope="module")
def measured(cli, tmp_path_factory):
    """A 'measured' BRDF: the model at hwhm 5°, clear coat on, times 1 + 0.05 sin(k)."""
    d = tmp_path_factory.mktemp("measured")
    model = read_csv(cli.run("model", "--hwhm", 5, "--clearcoat", "--theta-i", "30,60",
                             "--theta-s", "-80:80:1"))
    lines = ["theta_i_deg,theta_s_deg,value,uncertainty"]
    for k, (ti, ts, b) in enumerate(zip(model["theta_i_deg"], model["theta_s_deg"], model["brdf_per_sr"])):
        v = float(b) * (1 + 0.05 * math.sin(k))
        lines.append(f"{ti},{ts},{v!r},{0.05 * v!r}")
    path = d / "measured.csv"
    path.write_text("\n".join(lines) + "\n")
    cols = read_csv(path)
    as_dict = {k: np.array([float(x) for x in v]) for k, v in cols.items()}
    return path, as_dict


def test_compare_equals_cli(cli, measured, tmp_path):
    path, as_dict = measured
    out = tmp_path / "c.csv"
    want = cli.json("compare", "--measured", path, "--hwhm", 6, "--out", out)
    table = read_csv(out)
    for source in (path, as_dict):
        got = fs.compare(source, hwhm=6.0)
        pts = got["points"]
        for c in ("theta_i_deg", "theta_s_deg", "measured", "model", "residual_log10"):
            assert pts[c].dtype == np.float64
            assert_column_equal(pts[c], table[c], c)
        assert pts["region"].tolist() == table["region"]
        assert len(got["incidences"]) == len(want["incidences"])
        for g, w in zip(got["incidences"], want["incidences"]):
            assert g["theta_i_deg"] == w["theta_i_deg"] and g["scale"] == w["scale"]
            assert g["regions"] == w["regions"]


def test_compare_selection_and_kind_equal_cli(cli, measured, tmp_path):
    path, _ = measured
    out = tmp_path / "c.csv"
    cli.run("compare", "--measured", path, "--hwhm", 4, "--theta-i", 60, "--theta-s", "-70:-50:1",
            "--no-clearcoat", "--aperture", 2, "--out", out)
    got = fs.compare(path, hwhm=4.0, theta_i=[60], theta_s=np.arange(-70, -49, 1.0),
                     clearcoat=False, aperture=2.0)
    table = read_csv(out)
    assert_column_equal(got["points"]["residual_log10"], table["residual_log10"])


def test_gaussian_fit_equals_cli(cli, measured):
    path, as_dict = measured
    for flags, kwargs in (
        ([], {}),
        (["--common-scale", "--fit-n", "--hwhm-start", "3", "--region", "4:30"],
         dict(common_scale=True, fit_n=True, hwhm_start=3.0, region=(4, 30))),
    ):
        want = cli.json("fit", "--measured", path, *flags)
        for source in (path, as_dict):
            got = fs.fit(source, **kwargs)
            for k in ("hwhm_deg", "hwhm_std_deg", "n", "n_std", "chi2", "dof", "points",
                      "iterations", "uncertainty_basis", "uncertainty_scale", "warnings"):
                assert got[k] == want[k], k
            assert got["scales"] == [(s["theta_i_deg"], s["scale"]) for s in want["scales"]]
    # The curve was made at hwhm 5°: the fit finds it within a few standard errors.
    g = fs.fit(path)
    assert abs(g["hwhm_deg"] - 5.0) < 4 * g["hwhm_std_deg"] + 0.05


def test_nonparametric_fit_equals_cli(cli, measured, tmp_path):
    path, _ = measured
    out = tmp_path / "h.csv"
    want = cli.json("fit", "--measured", path, "--nonparametric", "--bins", "0:20:2",
                    "--lambda", 0.1, "--out", out)
    got = fs.fit(path, nonparametric=True, bins=np.arange(0, 21, 2.0), lambda_=0.1)
    for k, v in (("lambda", "lambda"), ("points", "points"), ("chi2_relative", "chi2_relative")):
        assert got[k] == want[v]
    for c in ("theta_lo_deg", "theta_hi_deg", "area_fraction", "p_tilde"):
        assert got[c].tolist() == [b[c] for b in want["bins"]], c
    # The estimate feeds the distribution model as the CLI's histogram file does.
    a = fs.distribution_model(distribution=got, theta_i=[45])
    b = fs.distribution_model(distribution=out, theta_i=[45])
    np.testing.assert_allclose(a["brdf_per_sr"], b["brdf_per_sr"], rtol=1e-12)


def test_compare_fit_errors(cli, measured, tmp_path):
    path, as_dict = measured
    with pytest.raises(fs.FileError):
        fs.compare(tmp_path / "missing.csv")
    bad = tmp_path / "bad.csv"
    bad.write_text("theta_i_deg,theta_s_deg,value\n30,-30,1\n30,95,1\n")
    with pytest.raises(fs.FileFormatError) as e:
        fs.fit(bad)
    assert str(e.value) in cli.fails("fit", "--measured", bad)
    neg = tmp_path / "neg.csv"
    neg.write_text("theta_i_deg,theta_s_deg,value\n30,-30,1\n30,-20,-1\n30,-10,1\n")
    with pytest.raises(fs.InputError) as e:
        fs.compare(neg)
    assert "not positive" in str(e.value)
    assert str(e.value) in cli.fails("compare", "--measured", neg)
    with pytest.raises(fs.InputError) as e:
        fs.compare(path, theta_i=[45])
    assert "no measured point at θi = 45°" in str(e.value)
    for kwargs in (dict(measured_kind="volts"), dict(region=(40, 5)), dict(hwhm_start=70),
                   dict(nonparametric=True, bins=[5, 1]), dict(nonparametric=True, lambda_=-1),
                   dict(nonparametric=True, fit_n=True), dict(aperture=30)):
        with pytest.raises(fs.InputError):
            fs.fit(path, **kwargs)
    with pytest.raises(fs.InputError):
        fs.compare({"theta_i_deg": [30], "value": [1]})
    with pytest.raises(fs.InputError):
        fs.compare(42)

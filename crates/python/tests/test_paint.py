"""Real paints from Python: fit_paint and paint_brdf against the CLI's fit --paint and
model --params on the same inputs (the CLI writes shortest round-trip numbers, so the
comparisons are exact where both compute the same thing)."""

import json

import numpy as np
import pytest

import flakescatter as fs

from conftest import FIXTURES

GOLD = FIXTURES / "real" / "paints" / "gold-metallic-paint2.csv"


def test_fit_paint_matches_the_cli(cli, tmp_path):
    got = fs.fit_paint(GOLD, family="trowbridge-reitz", max_theta_r=80, min_value=1e-3)
    params = tmp_path / "p.json"
    want = cli.json(
        "fit", "--measured", GOLD, "--paint", "--family", "trowbridge-reitz",
        "--max-theta-r", 80, "--min-value", 1e-3, "--params-out", params,
    )["fit"]
    assert got["fit"]["family"] == want["family"] == "trowbridge-reitz"
    assert got["fit"]["chi2"] == want["chi2"]
    assert got["fit"]["residuals"] == want["residuals"]
    written = json.loads(params.read_text())
    for key in ("coat", "orientation", "flakes", "channels"):
        assert got["params"][key] == written[key]
    # One row per point used, every channel; the model column is positive.
    pts = got["points"]
    assert len(pts["model"]) == got["fit"]["points"]
    assert set(pts["channel"]) == {"r", "g", "b"}
    assert np.all(pts["model"] > 0)
    assert got["worst_ratio"] < 1.0


def test_paint_brdf_matches_model_params(cli, tmp_path):
    params = tmp_path / "p.json"
    cli.run(
        "fit", "--measured", GOLD, "--paint", "--family", "gaussian",
        "--theta-i", "45", "--params-out", params,
    )
    det = tmp_path / "det.csv"
    tr = [5.0, 30.0, 44.0, 60.0, 30.0]
    pr = [0.0, 0.0, 0.0, 180.0, 45.0]
    det.write_text("theta_r_deg,phi_r_deg\n" + "".join(f"{a},{b}\n" for a, b in zip(tr, pr)))
    text = cli.run(
        "model", "--params", params, "--theta-i", "30,45", "--detectors", det, "--aperture", 0
    )
    header, *rows = [line.split(",") for line in text.strip().splitlines()]
    for source in (params, json.loads(params.read_text())):
        got = fs.paint_brdf(source, [30, 45], tr, pr)
        for ch in ("r", "g", "b"):
            col = header.index(f"brdf_{ch}_per_sr")
            want = np.array([float(r[col]) for r in rows])
            assert np.array_equal(got[f"brdf_{ch}_per_sr"], want)


def test_bad_tables_name_file_line_and_column(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("theta_i_deg,theta_r_deg,phi_r_deg,brdf_g_per_sr\n30,10,0,-1\n")
    with pytest.raises(fs.InputError, match=r"bad\.csv, line 2, column brdf_g_per_sr"):
        fs.fit_paint(bad)
    with pytest.raises(fs.InputError, match="family"):
        fs.fit_paint(GOLD, family="cauchy")
    with pytest.raises(fs.InputError, match="not a paint parameter"):
        fs.paint_brdf({"format": "x"}, [30], [10], [0])


COLOUR_CHANGING = FIXTURES / "real" / "paints" / "color-changing-paint1.csv"


def test_fit_paint_with_a_fitted_film_matches_the_cli(cli):
    """Interference flakes with a fitted thickness: the same fit as the CLI's."""
    kw = dict(family="trowbridge-reitz", max_theta_r=80, min_value=1e-3)
    got = fs.fit_paint(COLOUR_CHANGING, flake_stack="TiO2:100", fit_thickness=[1],
                       thickness_range_nm=(20, 400), **kw)
    want = cli.json(
        "fit", "--measured", COLOUR_CHANGING, "--paint", "--family", "trowbridge-reitz",
        "--max-theta-r", 80, "--min-value", 1e-3, "--flake-stack", "TiO2:100",
        "--fit-thickness", 1, "--thickness-range", "20:400",
    )["fit"]
    assert got["fit"]["chi2"] == want["chi2"]
    assert got["fit"]["thickness"] == want["thickness"]
    thick = [e for e in got["fit"]["physical"] if e["name"] == "thickness (nm)"]
    assert len(thick) == 1 and 20 < thick[0]["value"] < 400
    # The parameter file carries the fitted stack.
    assert got["params"]["flakes"]["metal"]["stack"].startswith("TiO2:")


def test_fit_paint_with_piled_flakes_matches_the_cli(cli):
    """A pile of 4 film flakes: the same fit as the CLI's, and the parameter file
    carries the layers."""
    kw = dict(family="trowbridge-reitz", max_theta_r=80, min_value=1e-3)
    got = fs.fit_paint(COLOUR_CHANGING, flake_stack="TiO2:386", flake_layers=4, **kw)
    want = cli.json(
        "fit", "--measured", COLOUR_CHANGING, "--paint", "--family", "trowbridge-reitz",
        "--max-theta-r", 80, "--min-value", 1e-3, "--flake-stack", "TiO2:386",
        "--flake-layers", 4,
    )["fit"]
    assert got["fit"]["chi2"] == want["chi2"]
    assert got["fit"]["flake_layers"] == want["flake_layers"] == 4
    assert got["params"]["flakes"]["layers"] == 4
    one = fs.fit_paint(COLOUR_CHANGING, flake_stack="TiO2:386", **kw)
    assert "layers" not in one["params"]["flakes"] and "flake_layers" not in one["fit"]
    assert one["fit"]["chi2"] != got["fit"]["chi2"]


@pytest.mark.parametrize(
    "kw, word",
    [
        (dict(flake_stack="TiO2:-4"), "flake_stack"),
        (dict(flake_stack="TiO2:40", flake_core="unobtainium"), "flake_core"),
        (dict(flake_core="aluminium"), "flake_core needs flake_stack"),
        (dict(flake_stack="TiO2:40", flake_index=(1.0, 6.0)), "give one"),
        (dict(fit_thickness=[1]), "fit_thickness needs interference flakes"),
        (dict(flake_stack="TiO2:40", fit_thickness=[2]), "layer 2"),
        (dict(flake_stack="TiO2:40", fit_thickness=[1], thickness_range_nm=(50, 20)),
         "thickness range"),
        (dict(flake_stack="TiO2:40", flake_layers=0), "flake_layers=0"),
        (dict(flake_stack="TiO2:40", flake_layers=1001), "flake_layers=1001"),
        (dict(flake_layers=2), "flake_layers needs free interference flakes"),
        (dict(flake_stack="TiO2:40", flake_core="aluminium", flake_layers=2),
         "flake_layers needs free interference flakes"),
    ],
)
def test_bad_stack_keywords_are_named(kw, word):
    with pytest.raises(fs.Error, match=word):
        fs.fit_paint(COLOUR_CHANGING, **kw)


def test_a_fractional_flake_layer_count_is_a_type_error_naming_it():
    with pytest.raises(TypeError, match="flake_layers"):
        fs.fit_paint(COLOUR_CHANGING, flake_stack="TiO2:40", flake_layers=2.5)

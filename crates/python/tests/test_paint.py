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


def _pile_truth(layers):
    """A paint whose flakes are a free 150 nm TiO2 film piled `layers` deep: rough coat
    of index 1.5 without haze, Trowbridge-Reitz flakes (alpha 0.1) at coverage 0.5,
    a different flake scale and base albedo per channel."""
    flakes = {"metal": {"stack": "TiO2:150"}, "coverage": 0.5}
    if layers != 1:
        flakes["layers"] = layers
    return {
        "format": "flakescatter paint parameters",
        "version": 1,
        "coat": {"n": 1.5, "roughness": 0.03, "haze": 0, "haze_roughness": 0},
        "orientation": {"family": "trowbridge-reitz", "alpha": 0.1},
        "flakes": flakes,
        "channels": [
            {"name": "r", "wavelength_nm": 612, "flake_scale": 0.9, "base_albedo": 0.05},
            {"name": "g", "wavelength_nm": 547, "flake_scale": 0.7, "base_albedo": 0.1},
            {"name": "b", "wavelength_nm": 464, "flake_scale": 0.8, "base_albedo": 0.2},
        ],
    }


def test_fit_flake_layers_finds_the_pile_depth_a_table_was_made_with(tmp_path):
    """A table made by the paint model with the flakes piled 4 deep (incidences 20, 45,
    65 degrees; in-plane detectors every 4 degrees to 80 on both sides, out of the plane
    at 30 and 60 degrees azimuth): fit_flake_layers=True, given only the film, gives back
    4, with the whole scan 1..16 (the coverage given, as the fit cannot tell it from the
    flake scale; the other parameters fitted back too). The data are exact, so the truth fits to rounding
    and its neighbours 3 and 5 do not."""
    tr = [4.0 * k for k in range(1, 21)] * 2 + [10.0 * k for k in range(1, 9)] * 2
    pr = [0.0] * 20 + [180.0] * 20 + [30.0] * 8 + [60.0] * 8
    table = fs.paint_brdf(_pile_truth(4), [20, 45, 65], tr, pr)
    cols = ["theta_i_deg", "theta_r_deg", "phi_r_deg"] + [
        f"brdf_{c}_per_sr" for c in "rgb"
    ]
    path = tmp_path / "pile4.csv"
    rows = zip(*(table[c] for c in cols))
    path.write_text(
        ",".join(cols) + "\n" + "".join(",".join(repr(float(v)) for v in r) + "\n" for r in rows)
    )
    got = fs.fit_paint(path, family="trowbridge-reitz", haze=False, coverage=0.5,
                       flake_stack="TiO2:150", fit_flake_layers=True)
    fit = got["fit"]
    assert fit["flake_layers"] == 4, fit["flake_layers_scan"]
    scan = fit["flake_layers_scan"]
    assert scan["layers"] == list(range(1, 17))
    chi2 = dict(zip(scan["layers"], scan["chi2"]))
    assert all(c is not None for c in chi2.values())
    assert min(chi2, key=chi2.get) == 4
    assert chi2[4] < 1e-12, chi2
    assert chi2[3] > 1e3 * max(chi2[4], 1e-15) and chi2[5] > 1e3 * max(chi2[4], 1e-15)
    assert fit["chi2"] == chi2[4]
    # The paint returned is the pile kept, and its parameters are the truth's.
    assert got["params"]["flakes"]["layers"] == 4
    for ch, (s, rho) in zip(got["params"]["channels"], [(0.9, 0.05), (0.7, 0.1), (0.8, 0.2)]):
        assert ch["flake_scale"] == pytest.approx(s, rel=1e-4)
        assert ch["base_albedo"] == pytest.approx(rho, rel=1e-4, abs=1e-6)
    assert got["worst_ratio"] < 1e-4


@pytest.mark.parametrize(
    "kw, word",
    [
        (dict(flake_stack="TiO2:40", flake_layers=2),
         r"fit_flake_layers=True and flake_layers=2: give one"),
        (dict(), "fit_flake_layers=True needs free interference flakes"),
        (dict(flake_index=(1.0, 6.0)), "fit_flake_layers=True needs free interference flakes"),
        (dict(flake_stack="TiO2:40", flake_core="aluminium"),
         "fit_flake_layers=True needs free interference flakes"),
    ],
)
def test_fit_flake_layers_refusals_name_the_keyword(kw, word):
    """The combinations the CLI refuses (--fit-flake-layers with --flake-layers, or
    without a free --flake-stack) are an InputError (a ValueError) naming the keyword,
    before any fit."""
    with pytest.raises(fs.InputError, match=word) as e:
        fs.fit_paint(COLOUR_CHANGING, fit_flake_layers=True, **kw)
    assert isinstance(e.value, ValueError)


def test_channel_band_fits_a_banded_table_back(tmp_path):
    """A table made by the paint model with a free 300 nm TiO2 film seen through 60 nm
    channel bands (flakes.metal.band_fwhm_nm): fit_paint(channel_band_nm=60) fits it to
    rounding and returns the band in its parameter file; without the band (one
    wavelength per channel) it cannot."""
    truth = _pile_truth(1)
    truth["flakes"] = {"metal": {"stack": "TiO2:300", "band_fwhm_nm": 60}, "coverage": 0.5}
    tr = [4.0 * k for k in range(1, 21)] * 2 + [10.0 * k for k in range(1, 9)] * 2
    pr = [0.0] * 20 + [180.0] * 20 + [30.0] * 8 + [60.0] * 8
    table = fs.paint_brdf(truth, [20, 45, 65], tr, pr)
    cols = ["theta_i_deg", "theta_r_deg", "phi_r_deg"] + [f"brdf_{c}_per_sr" for c in "rgb"]
    path = tmp_path / "band60.csv"
    rows = zip(*(table[c] for c in cols))
    path.write_text(
        ",".join(cols) + "\n" + "".join(",".join(repr(float(v)) for v in r) + "\n" for r in rows)
    )
    kw = dict(family="trowbridge-reitz", haze=False, coverage=0.5, flake_stack="TiO2:300")
    banded = fs.fit_paint(path, channel_band_nm=60.0, **kw)
    plain = fs.fit_paint(path, **kw)
    assert banded["fit"]["chi2"] < 1e-12
    assert plain["fit"]["chi2"] > 1e3 * max(banded["fit"]["chi2"], 1e-15)
    assert banded["params"]["flakes"]["metal"]["band_fwhm_nm"] == 60.0
    for bad, word in [(0.0, "channel band"), (500.0, "channel band")]:
        with pytest.raises(fs.InputError, match=word):
            fs.fit_paint(path, channel_band_nm=bad, **kw)
    with pytest.raises(fs.InputError, match="interference flakes"):
        fs.fit_paint(path, channel_band_nm=40.0, family="trowbridge-reitz")


def test_fit_tint_gives_back_the_tints_a_table_was_made_with(tmp_path):
    """A table made by the paint model with aluminium flakes under a tinted binder
    (optical depths 0.05, 0.15, 0.4 in r, g, b): fit_paint(fit_tint=True) fits it to
    rounding and gives the tints back; without them the fit cannot."""
    truth = _pile_truth(1)
    truth["flakes"] = {"metal": "aluminium", "coverage": 0.5}
    for ch, t in zip(truth["channels"], [0.05, 0.15, 0.4]):
        ch["tint"] = t
    tr = [4.0 * k for k in range(1, 21)] * 2 + [10.0 * k for k in range(1, 9)] * 2
    pr = [0.0] * 20 + [180.0] * 20 + [30.0] * 8 + [60.0] * 8
    table = fs.paint_brdf(truth, [20, 45, 65], tr, pr)
    cols = ["theta_i_deg", "theta_r_deg", "phi_r_deg"] + [f"brdf_{c}_per_sr" for c in "rgb"]
    path = tmp_path / "tinted.csv"
    rows = zip(*(table[c] for c in cols))
    path.write_text(
        ",".join(cols) + "\n" + "".join(",".join(repr(float(v)) for v in r) + "\n" for r in rows)
    )
    kw = dict(family="trowbridge-reitz", haze=False, coverage=0.5)
    tinted = fs.fit_paint(path, fit_tint=True, **kw)
    plain = fs.fit_paint(path, **kw)
    assert tinted["fit"]["chi2"] < 1e-10
    assert plain["fit"]["chi2"] > 1e3 * max(tinted["fit"]["chi2"], 1e-15)
    got = [ch.get("tint", 0.0) for ch in tinted["params"]["channels"]]
    assert got == pytest.approx([0.05, 0.15, 0.4], abs=1e-4)

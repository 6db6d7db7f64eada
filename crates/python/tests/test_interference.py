"""Interference (thin-film) flakes in the volume model from Python: `volume_model` with
`flake_stack`, `flake_core` and `wavelength_nm` against `flakescatter volume
--flake-stack --flake-core --wavelength` on the same inputs, and against what a lossless
film must do (physics.md §10, §13)."""

import numpy as np
import pytest

import flakescatter as fs

KW = dict(hwhm=6.0, theta_i=[45], theta_s=[-60.0, -45.0, -30.0, 0.0, 20.0], aperture=5.0,
          rays=20000, tile_um=200.0, seed=7, layers=4)
CLI_KW = ["--hwhm", 6, "--theta-i", 45, "--theta-s", "-60,-45,-30,0,20", "--aperture", 5,
          "--rays", 20000, "--tile-um", 200, "--seed", 7, "--layers", 4]


@pytest.mark.parametrize("stack, core", [("2.6:120", None), ("TiO2:80", "aluminium")])
def test_volume_model_with_a_stack_matches_the_cli(cli, stack, core):
    """The same flake (the stack at 550 nm), so the same rays: every number equal."""
    got = fs.volume_model(flake_stack=stack, flake_core=core, wavelength_nm=550.0, **KW)
    args = ["volume", "--flake-stack", stack, "--wavelength", 550, *CLI_KW]
    if core:
        args += ["--flake-core", core]
    want = cli.json(*args)
    rows = want["rows"]
    assert [r["theta_s_deg"] for r in rows] == KW["theta_s"]
    for col, key in [("brdf_per_sr", "brdf_per_sr"), ("reflectance", "reflectance"),
                     ("multiple_bounce_brdf_per_sr", "multiple_bounce_brdf_per_sr")]:
        assert list(got[col]) == [r[key] for r in rows], col
    for key in ("absorbed_substrate", "absorbed_flakes", "escaped_single", "coat_reflected"):
        assert got["energy"][key][0] == want["energy"][0][key], key


def test_a_lossless_film_flake_absorbs_nothing_and_lets_light_down():
    """Flakes of a lossless film (index 2.6, 120 nm, no core) absorb nothing, and the
    light they transmit reaches the black substrate: it takes more than under mirror
    flakes (the default perfect conductor) of the same layer, which transmit nothing."""
    film = fs.volume_model(flake_stack="2.6:120", wavelength_nm=550.0, **KW)
    mirror = fs.volume_model(**KW)
    assert abs(film["energy"]["absorbed_flakes"][0]) < 1e-12
    np.testing.assert_allclose(film["energy"]["total"], 1.0, rtol=1e-9)
    assert film["energy"]["absorbed_substrate"][0] > mirror["energy"]["absorbed_substrate"][0] + 0.1
    assert film["energy"]["coat_reflected"][0] == mirror["energy"]["coat_reflected"][0]


@pytest.mark.parametrize(
    "kw, word",
    [
        (dict(flake_stack="2.6:120"), "flake_stack needs wavelength_nm"),
        (dict(wavelength_nm=550.0), "apply to flake_stack only"),
        (dict(flake_core="aluminium"), "apply to flake_stack only"),
        (dict(flake_stack="2.6:120", flake_index=(1.0, 6.0), wavelength_nm=550.0),
         "flake_stack and flake_index"),
        (dict(flake_stack="TiO2:-4", wavelength_nm=550.0), "flake_stack"),
        (dict(flake_stack="TiO2:40", flake_core="unobtainium", wavelength_nm=550.0),
         "flake_core"),
    ],
)
def test_bad_volume_stack_keywords_are_named(kw, word):
    with pytest.raises(fs.InputError, match=word):
        fs.volume_model(rays=1000, **kw)


def test_a_spectrum_is_a_call_per_wavelength(cli):
    """`volume --wavelengths` traces the same layers and rays at each wavelength (one
    seed), so its rows at 550 nm are the single-wavelength call's."""
    want = cli.json("volume", "--flake-stack", "2.6:120", "--wavelengths", "500,550", *CLI_KW)
    rows = [r for r in want["rows"] if r["wavelength_nm"] == 550]
    got = fs.volume_model(flake_stack="2.6:120", wavelength_nm=550.0, **KW)
    assert list(got["brdf_per_sr"]) == [r["brdf_per_sr"] for r in rows]

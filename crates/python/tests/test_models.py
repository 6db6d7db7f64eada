"""The distribution and topographic models (and their Mueller forms) against the CLI's
`model` and `topo` tables, exactly; shapes and dtypes; bad parameters."""

import warnings

import numpy as np
import pytest

import flakescatter as fs
from conftest import (
    CUTOFF, FIXTURES, HEIGHT, HEIGHT3, INTENSITY, INTENSITY3, assert_column_equal, read_csv,
)

CURVE = ["theta_i_deg", "theta_s_deg", "phi_s_deg", "aperture_deg", "brdf_per_sr", "reflectance", "relative"]
TOPO = CURVE + ["rays", "std_err"]


def assert_table_equal(got, csv_text, columns):
    table = read_csv(csv_text)
    assert list(table) == columns
    n = len(table["theta_i_deg"])
    for c in columns:
        a = got[c]
        assert a.ndim == 1 and a.shape == (n,), c
        if c == "rays":
            assert a.dtype == np.int64
            assert a.tolist() == [int(v) for v in table[c]]
        else:
            assert a.dtype == np.float64, c
            assert_column_equal(a, table[c], c)


def test_distribution_defaults_equal_cli(cli):
    got = fs.distribution_model()
    assert_table_equal(got, cli.run("model"), CURVE)
    assert len(got["brdf_per_sr"]) == 5 * 281


@pytest.mark.parametrize(
    "kwargs,flags",
    [
        (dict(hwhm=3.0, theta_i=[20, 45], theta_s=np.arange(-60, 61, 2.5)),
         ["--hwhm", "3", "--theta-i", "20,45", "--theta-s", "-60:60:2.5"]),
        (dict(sigma=4.0, theta_i=30, theta_s=[-30, -25, 0, 10], aperture=0.0),
         ["--sigma", "4", "--theta-i", "30", "--theta-s", "-30,-25,0,10", "--aperture", "0"]),
        (dict(rms_tilt=8.0, n=1.6, transmission="paper", weighting="paper-printed", theta_i=[60]),
         ["--rms-tilt", "8", "--n", "1.6", "--transmission", "paper", "--weighting", "paper-printed", "--theta-i", "60"]),
        (dict(hwhm=6.0, clearcoat=True, flake_index=(0.96, 6.69), cone="constant", aperture=2.0, theta_i=[45]),
         ["--hwhm", "6", "--clearcoat", "--flake-index", "0.96,6.69", "--cone", "constant", "--aperture", "2", "--theta-i", "45"]),
        (dict(hwhm=5.0, transmission="s", theta_i=[0, 75]),
         ["--hwhm", "5", "--transmission", "s", "--theta-i", "0,75"]),
    ],
)
def test_distribution_options_equal_cli(cli, kwargs, flags):
    assert_table_equal(fs.distribution_model(**kwargs), cli.run("model", *flags), CURVE)


def test_out_of_plane_detectors_equal_cli(cli, tmp_path):
    det = np.array([[60.0, 0.0], [55.0, 10.0], [40.0, 180.0], [0.0, 0.0], [70.5, -45.0]])
    f = tmp_path / "det.csv"
    f.write_text("theta_r_deg,phi_r_deg\n" + "".join(f"{float(t)!r},{float(p)!r}\n" for t, p in det))
    got = fs.distribution_model(detectors=det, theta_i=[30, 60])
    assert_table_equal(got, cli.run("model", "--detectors", f, "--theta-i", "30,60"), CURVE)
    np.testing.assert_array_equal(got["phi_s_deg"], np.tile(det[:, 1], 2))


def test_tabulated_distribution_equals_cli(cli, tmp_path):
    flakes = tmp_path / "flakes.csv"
    hist = tmp_path / "hist.csv"
    cli.run("segment", HEIGHT, "--intensity", INTENSITY, "--cutoff", CUTOFF, "--out", flakes)
    cli.run("stats", "--flakes", flakes, "--bin", 2, "--out", hist)
    want = cli.run("model", "--orientation", "table", "--distribution", hist, "--theta-i", "45")
    assert_table_equal(fs.distribution_model(distribution=hist, theta_i=[45]), want, CURVE)
    h = fs.orientation_stats(flakes, bin_deg=2)["histogram"]
    assert_table_equal(fs.distribution_model(distribution=h, theta_i=[45]), want, CURVE)


def test_topographic_equals_cli(cli):
    m = fs.read_map(HEIGHT, intensity=INTENSITY, cutoff=CUTOFF)
    with pytest.warns(fs.FlakescatterWarning, match="tiles"):
        got = fs.topographic_model(m, theta_i=[0, 45, 60], theta_s=np.arange(-70, 71, 1.0))
    want = cli.run("topo", HEIGHT, "--intensity", INTENSITY, "--cutoff", CUTOFF,
                   "--theta-i", "0,45,60", "--theta-s", "-70:70:1")
    assert_table_equal(got, want, TOPO)


def test_topographic_base_under_stack_flakes_equals_cli(cli):
    # A Lambertian base under the map's free thin-film flakes (physics.md §13, "The base
    # under a map's flakes"): the numbers of `topo --flake-stack ... --wavelengths 550
    # --base-albedo 0.8` (whose spectral table leads with wavelength_nm), every row above
    # the black base's; bad albedos and flakes that transmit nothing are refused.
    m = fs.read_map(HEIGHT, intensity=INTENSITY, cutoff=CUTOFF)
    kw = dict(theta_i=[30.0], theta_s=np.arange(-70.0, 71.0, 10.0), flake_stack="TiO2:100",
              wavelength_nm=550.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", fs.FlakescatterWarning)
        got = fs.topographic_model(m, base_albedo=0.8, **kw)
        black = fs.topographic_model(m, **kw)
    text = cli.run("topo", HEIGHT, "--intensity", INTENSITY, "--cutoff", CUTOFF,
                   "--flake-stack", "TiO2:100", "--wavelengths", "550", "--base-albedo", "0.8",
                   "--theta-i", "30", "--theta-s", "-70:70:10")
    text = "".join(line.split(",", 1)[1] + "\n" for line in text.strip().splitlines())
    assert_table_equal(got, text, TOPO)
    assert np.all(got["reflectance"] > black["reflectance"])
    for bad in [-0.1, 1.5, float("nan")]:
        with pytest.raises(fs.InputError, match="base_albedo"):
            fs.topographic_model(m, base_albedo=bad, **kw)
    with pytest.raises(fs.InputError, match="transmit"):
        fs.topographic_model(m, theta_i=[30.0], flake_index=(0.96, 6.69), base_albedo=0.5)


def test_topographic_two_maps_and_options_equal_cli(cli):
    maps = [
        fs.read_map(HEIGHT, intensity=INTENSITY, cutoff=CUTOFF),
        fs.read_map(HEIGHT3, intensity=INTENSITY3, cutoff=CUTOFF),
    ]
    got = fs.topographic_model(maps, window=7, tile_um=20.0, n=1.55, clearcoat=True,
                               theta_i=[30], aperture=2.5, transmission="p")
    want = cli.run("topo", HEIGHT, HEIGHT3, "--intensity", INTENSITY, "--intensity", INTENSITY3,
                   "--cutoff", CUTOFF, "--window", 7, "--tile-um", 20, "--n", 1.55, "--clearcoat",
                   "--theta-i", 30, "--aperture", 2.5, "--transmission", "p")
    assert_table_equal(got, want, TOPO)


def test_mueller_readings_equal_scalar_cli(cli):
    ts = np.arange(-70, 71, 5.0)
    flags = ["--hwhm", "6", "--theta-i", "30,60", "--theta-s", "-70:70:5"]
    unpol = read_csv(cli.run("model", *flags))
    s_pol = read_csv(cli.run("model", *flags, "--transmission", "s"))
    got = fs.distribution_mueller(hwhm=6.0, theta_i=[30, 60], theta_s=ts)
    rows = 2 * len(ts)
    for k in ("mueller_brdf_per_sr", "mueller_reflectance", "mueller_std_err"):
        assert got[k].shape == (rows, 4, 4) and got[k].dtype == np.float64
    for k in ("detected_brdf_per_sr", "detected_std_err", "relative", "dop_unpolarized"):
        assert got[k].shape == (rows,)
    # m00 is the unpolarised BRDF of the scalar model (a different code path: the
    # scalar Fresnel bookkeeping against the Mueller product), to rounding.
    want = np.array([float(v) for v in unpol["brdf_per_sr"]])
    np.testing.assert_allclose(got["mueller_brdf_per_sr"][:, 0, 0], want, rtol=1e-9)
    np.testing.assert_allclose(got["detected_brdf_per_sr"], want, rtol=1e-9)
    # s-polarised incidence read without analyser = the scalar model with --transmission s.
    s = fs.distribution_mueller(hwhm=6.0, theta_i=[30, 60], theta_s=ts, incident="s")
    np.testing.assert_allclose(
        s["detected_brdf_per_sr"], [float(v) for v in s_pol["brdf_per_sr"]], rtol=1e-9
    )
    # a . M . s by hand for a crossed analyser equals the binding's reading.
    x = fs.distribution_mueller(hwhm=6.0, theta_i=[30, 60], theta_s=ts, incident="s", analyzer="p")
    a, st = np.array([0.5, -0.5, 0, 0]), np.array([1.0, 1.0, 0, 0])
    np.testing.assert_allclose(
        x["detected_brdf_per_sr"], np.einsum("i,rij,j->r", a, got["mueller_brdf_per_sr"], st),
        rtol=1e-12, atol=1e-15,
    )


def test_topographic_mueller_equals_cli(cli):
    m = fs.read_map(HEIGHT, intensity=INTENSITY, cutoff=CUTOFF)
    with pytest.warns(fs.FlakescatterWarning):
        got = fs.topographic_mueller(m, theta_i=[45], theta_s=np.arange(-70, 71, 2.0))
    want = read_csv(cli.run("topo", HEIGHT, "--intensity", INTENSITY, "--cutoff", CUTOFF,
                            "--theta-i", "45", "--theta-s", "-70:70:2"))
    assert got["rays"].tolist() == [int(v) for v in want["rays"]]
    np.testing.assert_allclose(got["mueller_brdf_per_sr"][:, 0, 0],
                               [float(v) for v in want["brdf_per_sr"]], rtol=1e-9, atol=1e-300)


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(hwhm=0.0), dict(hwhm=90.0), dict(sigma=float("nan")), dict(hwhm=3, sigma=3),
        dict(n=0.9), dict(aperture=21), dict(aperture=-1), dict(theta_i=[90]),
        dict(theta_i=[-1]), dict(theta_s=[90]), dict(theta_s=[np.inf]), dict(theta_i=[]),
        dict(theta_s=[10], detectors=[[10, 0]]), dict(detectors=[1, 2, 3]),
        dict(detectors=[[95, 0]]), dict(transmission="circular"), dict(weighting="heavy"),
        dict(cone="exactish"), dict(flake_index=(-1.0, 2.0)), dict(theta_s="abc"),
        dict(distribution={"theta_lo_deg": [0, 2], "theta_hi_deg": [1, 3], "area_fraction": [1, 1]}),
        dict(distribution={"theta_lo_deg": [0], "theta_hi_deg": [1, 2], "area_fraction": [1]}),
    ],
)
def test_bad_model_parameters_raise_value_errors(kwargs):
    with pytest.raises(ValueError) as e:
        fs.distribution_model(**kwargs)
    assert isinstance(e.value, fs.Error)


def test_bad_topographic_parameters():
    m = fs.read_map(HEIGHT)
    for kwargs in (dict(window=4), dict(window=1), dict(tile_um=0), dict(aperture=0.0)):
        with pytest.raises(fs.InputError):
            fs.topographic_model(m, theta_i=[30], **kwargs)
    with pytest.raises(fs.InputError):
        fs.topographic_model([], theta_i=[30])
    with pytest.raises(fs.InputError):
        fs.topographic_model([m, "x"], theta_i=[30])
    tiny = fs.Map(np.zeros((3, 3)), 1.0)
    with pytest.raises(fs.InputError):
        fs.topographic_model(tiny, window=5, theta_i=[30])
    with pytest.raises(fs.InputError):
        fs.distribution_mueller(incident=[1, 2, 0, 0])
    with pytest.raises(fs.InputError):
        fs.distribution_mueller(analyzer=[1, 0.5, 0, 0])


def test_settings_share_the_cli_messages():
    """The keywords refuse what the CLI's flags and the manifest's keys refuse, with the
    same words (flakescatter::checks; crates/cli/tests/checks.rs), naming the keyword."""
    index = "0.5: the refractive index must be a finite number >= 1"
    with pytest.raises(fs.InputError, match="^n=" + index):
        fs.distribution_model(n=0.5)
    paint = str(FIXTURES / "real" / "paints" / "blue-metallic-paint2.csv")
    with pytest.raises(fs.InputError, match="^n=" + index):
        fs.fit_paint(paint, n=0.5)
    m = fs.read_map(HEIGHT, intensity=INTENSITY, cutoff=CUTOFF)
    with pytest.raises(fs.InputError, match="^window=4: the least-squares window must be"):
        fs.topographic_model([m], window=4)
    with pytest.raises(fs.InputError, match="^tile_um=-2: the tile side must be"):
        fs.topographic_model([m], tile_um=-2.0)


def test_base_under_stack_flakes_equals_cli(cli):
    # A Lambertian base under free thin-film flakes (physics.md §13): the same numbers as
    # `model --flake-stack ... --wavelengths 550 --base-albedo 0.8` (whose spectral table
    # leads with wavelength_nm), above the black base far from specular.
    kw = dict(hwhm=4.0, theta_i=[30.0], theta_s=np.arange(-70.0, 71.0, 10.0))
    got = fs.distribution_model(flake_stack="TiO2:100", wavelength_nm=550.0, base_albedo=0.8, **kw)
    text = cli.run("model", "--flake-stack", "TiO2:100", "--wavelengths", "550", "--base-albedo", "0.8",
                   "--hwhm", "4", "--theta-i", "30", "--theta-s", "-70:70:10")
    text = "".join(line.split(",", 1)[1] + "\n" for line in text.strip().splitlines())
    assert_table_equal(got, text, CURVE)
    black = fs.distribution_model(flake_stack="TiO2:100", wavelength_nm=550.0, **kw)
    far = np.abs(kw["theta_s"] + 30.0) > 40.0
    assert np.all(got["brdf_per_sr"][far] > black["brdf_per_sr"][far])
    for bad in [-0.1, 1.5, float("nan")]:
        with pytest.raises(fs.InputError, match="base_albedo"):
            fs.distribution_model(flake_stack="TiO2:100", wavelength_nm=550.0, base_albedo=bad, **kw)
    with pytest.raises(fs.InputError, match="transmit"):
        fs.distribution_model(flake_index=(0.96, 6.69), base_albedo=0.5, **kw)

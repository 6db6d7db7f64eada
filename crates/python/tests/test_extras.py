"""The features without a CLI command on this branch, checked against closed forms,
published values and independent software: the isotropic topographic model against the
one-ray model averaged over rotated copies of a map, the volume model's clear coat
against Fresnel's equations, colorimetry against CIE closed forms and Sharma et al.'s
CIEDE2000 test data, stacks written by `tifffile` against the known surface."""

import math

import numpy as np
import pytest

import flakescatter as fs


def plane_map(tilt_deg, phi_deg, size=24, pitch=1.0):
    """A plane whose normal has polar angle `tilt_deg` and azimuth `phi_deg`:
    z = -tan(tilt) (x cos(phi) + y sin(phi)), µm."""
    y, x = np.mgrid[0:size, 0:size] * pitch
    t, p = math.radians(tilt_deg), math.radians(phi_deg)
    return fs.Map(-math.tan(t) * (x * math.cos(p) + y * math.sin(p)), pitch)


def test_isotropic_model_is_the_rotation_average_of_the_ray_model():
    tilt, ti, ts = 5.0, 30.0, np.arange(-50, -9, 1.0)
    kw = dict(theta_i=[ti], theta_s=ts, aperture=1.5, tile_um=1000.0)
    with pytest.warns(fs.FlakescatterWarning):
        iso = fs.isotropic_model(plane_map(tilt, 0.0), **kw)
    n = 2880
    acc = np.zeros(len(ts))
    peak = 0.0
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", fs.FlakescatterWarning)
        for k in range(n):
            r = fs.topographic_model(plane_map(tilt, (k + 0.5) * 360.0 / n), **kw)["reflectance"]
            acc += r
            peak = max(peak, r.max())
    mean = acc / n
    # Sampling the azimuth at n midpoints misses at most 1/n of the ring at each of the
    # two cone crossings: |mean - exact| <= 2 peak / n (plus the table's own error).
    assert (iso["reflectance"] > 0).sum() >= 3
    tol = 2.0 * peak / n + iso["interpolation_error"] + 1e-12
    assert np.all(np.abs(mean - iso["reflectance"]) <= tol), np.abs(mean - iso["reflectance"]) / tol
    for c in ("theta_i_deg", "theta_s_deg", "phi_s_deg", "aperture_deg", "brdf_per_sr",
              "reflectance", "relative", "std_err", "interpolation_error"):
        assert iso[c].dtype == np.float64 and iso[c].shape == (len(ts),)
    assert iso["rays"].dtype == np.int64


def fresnel_unpolarised(theta_i_deg, n):
    ci = math.cos(math.radians(theta_i_deg))
    st = math.sin(math.radians(theta_i_deg)) / n
    ct = math.sqrt(1 - st * st)
    rs = ((ci - n * ct) / (ci + n * ct)) ** 2
    rp = ((n * ci - ct) / (n * ci + ct)) ** 2
    return 0.5 * (rs + rp)


def test_volume_model_without_flakes_is_the_clear_coat():
    ti = [0.0, 30.0, 60.0]
    r = fs.volume_model(flakes=0, n=1.5, theta_i=ti, theta_s=[-30.0, 0.0, -60.0, 10.0],
                        rays=10000, tile_um=200.0)
    want = [fresnel_unpolarised(t, 1.5) for t in ti]
    np.testing.assert_allclose(r["energy"]["coat_reflected"], want, rtol=1e-12)
    np.testing.assert_allclose(r["energy"]["total"], 1.0, rtol=1e-12)
    # The specular detector of each incidence collects the whole reflected beam.
    spec = {0.0: 1, 30.0: 0, 60.0: 2}
    refl = r["reflectance"].reshape(3, 4)
    for i, t in enumerate(ti):
        assert refl[i, spec[t]] == pytest.approx(want[i], rel=1e-12)
        others = [j for j in range(4) if j != spec[t]]
        assert np.all(refl[i, others] == 0.0)


def test_volume_model_tinted_binder_without_flakes_is_beer_lambert():
    # No flakes, black substrate: each channel enters with T_c(θi) and crosses the film
    # once, d / cos θt, so the binder takes ½ Σ T_c (1 − exp(−α d / cos θt)) and the
    # substrate the rest; nothing escapes.
    alpha, d, n = 0.03, 20.0, 1.5
    ti = [0.0, 45.0]
    r = fs.volume_model(flakes=0, n=n, theta_i=ti, theta_s=[0.0], rays=6400, tile_um=200.0,
                        film_um=d, binder_absorption=alpha, layers=2)
    for i, t in enumerate(ti):
        a = 1.0 - fresnel_unpolarised(t, n)
        ct = np.sqrt(1.0 - (np.sin(np.radians(t)) / n) ** 2)
        keep = np.exp(-alpha * d / ct)
        assert r["energy"]["absorbed_binder"][i] == pytest.approx(a * (1.0 - keep), rel=1e-12)
        assert r["energy"]["absorbed_substrate"][i] == pytest.approx(a * keep, rel=1e-12)
    np.testing.assert_allclose(r["energy"]["total"], 1.0, rtol=1e-12)
    with pytest.raises(fs.InputError, match="binder_absorption"):
        fs.volume_model(binder_absorption=-0.1, rays=1000)


def test_volume_model_conserves_energy_and_is_reproducible():
    kw = dict(hwhm=6.0, theta_i=[45], theta_s=np.arange(-70, 71, 5.0), rays=20000,
              tile_um=200.0, seed=7)
    a, b = fs.volume_model(**kw), fs.volume_model(**kw)
    np.testing.assert_array_equal(a["brdf_per_sr"], b["brdf_per_sr"])
    np.testing.assert_allclose(a["energy"]["total"], 1.0, rtol=1e-9)
    # The BRDF is split by history: coat + single + multiple.
    np.testing.assert_allclose(
        a["brdf_per_sr"],
        a["coat_brdf_per_sr"] + a["single_bounce_brdf_per_sr"] + a["multiple_bounce_brdf_per_sr"],
        rtol=1e-12, atol=1e-300,
    )
    assert a["layer"]["flakes"] > 0 and a["rays"].dtype == np.int64
    with pytest.raises(fs.InputError):
        fs.volume_model(mass_fraction=0.1, flakes=3)
    with pytest.raises(fs.InputError):
        fs.volume_model(substrate="glass")
    with pytest.raises(fs.InputError):
        fs.volume_model(film_um=-1.0, rays=1000)
    # A black substrate has no albedo (it was ignored).
    with pytest.raises(fs.InputError, match="substrate_albedo"):
        fs.volume_model(substrate_albedo=0.5, rays=1000)


def test_volume_model_errors_include_the_scatter_between_layers():
    # Issue 52, item 19: the default draws 8 layers; std_err is the standard error of
    # their mean, its parts add in quadrature, and the 95 % interval is Student's t on
    # 7 degrees of freedom (t = 2.3646). One layer gives the rays' part only.
    kw = dict(hwhm=6.0, theta_i=[30], theta_s=[-30.0, -20.0], rays=16000, tile_um=300.0)
    r = fs.volume_model(**kw)
    assert r["layers"] == 8 and r["rays_per_layer"] == 2048
    assert r["rays_per_incidence"] == 8 * 2048
    # The between-layer part is sqrt(max(0, total² - rays²)).
    layer = r["layer_std_err"]
    assert np.all(layer >= 0.0)
    big = layer > 0.0
    np.testing.assert_allclose(r["std_err"][big] ** 2,
                               r["ray_std_err"][big] ** 2 + layer[big] ** 2, rtol=1e-9)
    np.testing.assert_allclose(r["ci95"], 2.364624251592785 * r["std_err"], rtol=1e-6)
    one = fs.volume_model(layers=1, **kw)
    np.testing.assert_array_equal(one["std_err"], one["ray_std_err"])
    assert np.all(np.isnan(one["layer_std_err"])) and np.all(np.isnan(one["ci95"]))
    with pytest.raises(fs.InputError, match="layers"):
        fs.volume_model(layers=0, rays=1000)


def test_spectrum_to_lab_closed_forms():
    w = np.arange(400.0, 701.0, 10.0)
    one = fs.spectrum_to_lab(w, np.full(len(w), 0.2))
    # A flat spectrum is neutral: X, Y, Z are r times the white point, a* = b* = 0,
    # L* = 116 r^(1/3) - 16 (CIE 15, for r > 0.008856).
    assert one["Y"] == pytest.approx(20.0, rel=1e-12)
    assert one["L"] == pytest.approx(116 * 0.2 ** (1 / 3) - 16, abs=1e-9)
    assert abs(one["a"]) < 1e-9 and abs(one["b"]) < 1e-9
    many = fs.spectrum_to_lab(w, np.outer([0.1, 0.5, 1.0], np.ones(len(w))), illuminant="D50", observer="2")
    assert many["L"].shape == (3,) and many["L"].dtype == np.float64
    np.testing.assert_allclose(many["L"], [116 * r ** (1 / 3) - 16 for r in (0.1, 0.5, 1.0)], atol=1e-9)
    # The D65 / 10° white point at 1 nm over 360-830 nm (CIE 15: 94.811, 100, 107.304).
    wp = fs.spectrum_to_lab(np.arange(360.0, 831.0), np.ones(471))["white_point"]
    assert wp[0] == pytest.approx(94.811, abs=0.01) and wp[2] == pytest.approx(107.304, abs=0.01)


# Sharma, Wu, Dalal, Color Res. Appl. 30 (2005) 21-30, Table 1 (pairs 1, 2, 3, 7, 17-20, 25).
SHARMA = [
    ((50.0000, 2.6772, -79.7751), (50.0000, 0.0000, -82.7485), 2.0425),
    ((50.0000, 3.1571, -77.2803), (50.0000, 0.0000, -82.7485), 2.8615),
    ((50.0000, 2.8361, -74.0200), (50.0000, 0.0000, -82.7485), 3.4412),
    ((50.0000, 0.0000, 0.0000), (50.0000, -1.0000, 2.0000), 2.3669),
    ((50.0000, 2.5000, 0.0000), (73.0000, 25.0000, -18.0000), 27.1492),
    ((50.0000, 2.5000, 0.0000), (61.0000, -5.0000, 29.0000), 22.8977),
    ((50.0000, 2.5000, 0.0000), (56.0000, -27.0000, -3.0000), 31.9030),
    ((50.0000, 2.5000, 0.0000), (58.0000, 24.0000, 15.0000), 19.4535),
    ((60.2574, -34.0099, 36.2677), (60.4626, -34.1751, 39.4387), 1.2644),
]


def test_delta_e_published_and_closed_form():
    ref = np.array([p[0] for p in SHARMA])
    smp = np.array([p[1] for p in SHARMA])
    got = fs.delta_e(ref, smp)
    assert got.shape == (len(SHARMA),)
    np.testing.assert_allclose(got, [p[2] for p in SHARMA], atol=5e-5)
    assert fs.delta_e(SHARMA[0][0], SHARMA[0][1]) == pytest.approx(2.0425, abs=5e-5)
    # ΔE*ab is the Euclidean distance (CIE 1976).
    np.testing.assert_allclose(fs.delta_e(ref, smp, formula="ab"), np.linalg.norm(ref - smp, axis=1), rtol=1e-12)
    assert fs.delta_e(ref.reshape(3, 3, 3), smp.reshape(3, 3, 3), formula="94").shape == (3, 3)
    with pytest.raises(fs.InputError):
        fs.delta_e([1, 2], [1, 2])
    with pytest.raises(fs.InputError):
        fs.delta_e(ref, smp, formula="76")
    with pytest.raises(fs.InputError):
        fs.spectrum_to_lab([400, 500], [0.1, 0.2, 0.3])
    with pytest.raises(fs.InputError):
        fs.spectrum_to_lab(w := np.arange(400.0, 701.0, 10.0), np.ones(len(w)), illuminant="F2")


def test_localise_stack_written_by_tifffile(tmp_path):
    tifffile = pytest.importorskip("tifffile")
    nz, ny, nx, dz, dx = 40, 12, 16, 0.25, 0.5
    y, x = np.mgrid[0:ny, 0:nx]
    truth = 3.0 + 0.1 * x + 0.05 * y  # µm above the lowest slice
    z = np.arange(nz)[:, None, None] * dz
    fwhm = 1.2
    s = fwhm / (2 * math.sqrt(2 * math.log(2)))
    stack = np.exp(-0.5 * ((z - truth) / s) ** 2).astype(np.float32)
    path = tmp_path / "stack.tif"
    tifffile.imwrite(path, stack, imagej=True, resolution=(1 / dx, 1 / dx),
                     metadata={"spacing": dz, "unit": "um", "axes": "ZYX"})
    r = fs.localise_stack(path)
    h = r["height"]
    assert isinstance(h, fs.Map) and h.shape == (ny, nx) and h.pitch_um == (dx, dx)
    assert r["info"]["nz"] == nz and r["info"]["z_step_um"] == dz
    assert r["report"]["valid"] == nx * ny
    # A Gaussian's log is a parabola: the Gaussian estimator recovers the centre to the
    # float32 rounding of the samples.
    np.testing.assert_allclose(h.heights_um, truth, atol=2e-4)
    np.testing.assert_allclose(r["intensity"].heights_um.max(), 1.0, atol=1e-6)
    np.testing.assert_allclose(r["width"].heights_um, fwhm, atol=0.05)
    with pytest.raises(fs.FileError):
        fs.localise_stack(tmp_path / "missing.tif")
    junk = tmp_path / "junk.tif"
    junk.write_bytes(b"II*\x00" + b"\x00" * 20)
    with pytest.raises(fs.FileFormatError):
        fs.localise_stack(junk)
    with pytest.raises(fs.InputError):
        fs.localise_stack(path, method="spline")

"""Thin-film flakes (`flakescatter.film`, physics.md section 13) against the `tmm`
package (S. J. Byrnes, PyPI, MIT licence), an independent transfer-matrix code, on
random stacks drawn here, and bad specs raising InputError naming the layer."""

import numpy as np
import pytest
import tmm

import flakescatter as fs


def tmm_amplitudes(n_list, d_list, theta_deg, wl):
    out = {}
    for pol in ("s", "p"):
        r = tmm.coh_tmm(pol, n_list, d_list, np.radians(theta_deg), wl)
        out[pol] = r
    return out


def test_random_stacks_agree_with_tmm():
    rng = np.random.default_rng(2047)
    thetas = np.array([0.0, 20.0, 45.0, 70.0, 85.0])
    wls = np.array([400.0, 480.0, 555.0, 640.0, 720.0])
    for _ in range(12):
        layers = []
        for _ in range(int(rng.integers(1, 6))):
            n = rng.uniform(1.2, 2.8)
            k = 0.0 if rng.random() < 0.5 else rng.uniform(0.0, 0.4)
            layers.append((n, k, rng.uniform(20.0, 500.0)))
        spec = "/".join(f"{n!r}+{k!r}i:{d!r}" for n, k, d in layers)
        ambient = float(rng.choice([1.0, 1.5]))
        res = fs.film(spec, theta_deg=thetas, wavelengths_nm=wls, ambient=ambient)
        assert res["R_s"].shape == (len(wls), len(thetas))
        n_list = [ambient] + [complex(n, k) for n, k, _ in layers] + [ambient]
        d_list = [np.inf] + [d for _, _, d in layers] + [np.inf]
        for i, wl in enumerate(wls):
            for j, th in enumerate(thetas):
                ref = tmm_amplitudes(n_list, d_list, th, wl)
                assert abs(res["rs"][i, j] - ref["s"]["r"]) < 1e-10
                assert abs(res["rp"][i, j] - ref["p"]["r"]) < 1e-10
                assert abs(res["ts"][i, j] - ref["s"]["t"]) < 1e-10
                assert abs(res["tp"][i, j] - ref["p"]["t"]) < 1e-10
                assert abs(res["T_s"][i, j] - ref["s"]["T"]) < 1e-10
                assert abs(res["R_p"][i, j] - ref["p"]["R"]) < 1e-10


def test_named_materials_on_a_substrate():
    # SiO2 on aluminium: R + T = 1 (a lossless layer; T is what the metal absorbs).
    res = fs.film("SiO2:100", theta_deg=[0, 40], wavelengths_nm=[450, 600], substrate="Al")
    assert np.allclose(res["R_s"] + res["T_s"], 1.0, atol=1e-12)
    assert res["stack"] == "SiO2:100"


@pytest.mark.parametrize(
    "spec, words",
    [
        ("TiO2:120/kryptonite:4", ["layer 2", "kryptonite"]),
        ("TiO2:-3", ["layer 1", "-3"]),
        ("TiO2:120//mica:4", ["layer 2", "empty"]),
        ("/".join(["SiO2:10"] * 201), ["201 layers"]),
    ],
)
def test_bad_specs_name_the_layer(spec, words):
    with pytest.raises(fs.InputError) as e:
        fs.film(spec, theta_deg=[0], wavelengths_nm=[550])
    for w in words:
        assert w in str(e.value)


def test_bad_arguments():
    with pytest.raises(fs.InputError, match="theta_deg"):
        fs.film("TiO2:50", theta_deg=[95], wavelengths_nm=[550])
    with pytest.raises(fs.InputError, match="850"):
        fs.film("anatase:50", theta_deg=[0], wavelengths_nm=[850])
    with pytest.raises(fs.InputError, match="ambient"):
        fs.film("TiO2:50", theta_deg=[0], wavelengths_nm=[550], ambient=0.5)


def test_stack_flakes_in_the_models():
    # A 1 µm layer of index 0.96 + 6.69i is bulk metal: the distribution model with that
    # stack equals the metal flake given by flake_index (the single-interface Fresnel
    # formula, another code path) to 1e-9.
    kw = dict(hwhm=6.0, theta_i=[30.0], theta_s=np.arange(-70.0, 31.0, 10.0))
    metal = fs.distribution_model(flake_index=(0.96, 6.69), **kw)
    stack = fs.distribution_model(flake_stack="0.96+6.69i:1000", wavelength_nm=550.0, **kw)
    assert np.allclose(stack["brdf_per_sr"], metal["brdf_per_sr"], rtol=1e-9, atol=0)
    # A lossless free stack reflects less than the perfect mirror, detector by detector.
    mirror = fs.distribution_model(**kw)
    film = fs.distribution_model(flake_stack="TiO2:120/mica:400/TiO2:120", wavelength_nm=550.0, **kw)
    assert np.all(film["brdf_per_sr"] <= mirror["brdf_per_sr"])
    with pytest.raises(fs.InputError, match="wavelength_nm"):
        fs.distribution_model(flake_stack="TiO2:100", **kw)
    with pytest.raises(fs.InputError, match="flake_index"):
        fs.distribution_model(flake_stack="TiO2:100", wavelength_nm=550.0, flake_index=(1.0, 6.0), **kw)
    with pytest.raises(fs.InputError, match="layer 1"):
        fs.distribution_model(flake_stack="TiO2:-1", wavelength_nm=550.0, **kw)
    with pytest.raises(fs.InputError, match="flake_stack only"):
        fs.distribution_model(wavelength_nm=550.0, **kw)

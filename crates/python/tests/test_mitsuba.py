"""flakescatter.mitsuba: the Mitsuba 3 BSDF over a MERL table, and the previews.

Every expectation here comes from outside the code under test: the MERL files are
written by this file's own numpy writer from analytic BRDFs, and looked up by this
file's own numpy transcription of MERL's reference reader (``BRDFRead.cpp``, Matusik
et al. 2003), in float64:

* file: int32 little-endian dims 90, 90, 180, then 3 × 90 × 90 × 180 float64
  little-endian, channel R, G, B, each stored divided by its scale
  (1/1500, 1.15/1500, 1.66/1500); −1 marks an unfilled bin;
* bin: ``phi_d_idx + 180 · theta_d_idx + 180 · 90 · theta_h_idx`` with
  θh idx = floor(sqrt(θh/(π/2) · 90 · 90)), θd idx = floor(θd/(π/2) · 90),
  φd (+π if negative) idx = floor(φd/π · 180), each clamped; (θh, θd, φd) the
  Rusinkiewicz angles, the difference vector being ωin rotated by −φh about z then
  by −θh about y.

The Mitsuba tests need the extra (``pip install flakescatter[render]``) and are
skipped, with that reason, without it (the LLVM ones also when Dr.Jit's LLVM backend
cannot run here); with FLAKESCATTER_REQUIRE_MITSUBA=1 (CI) either is a failure. The
import-hygiene tests run always.
"""

import math
import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

import flakescatter

try:  # the optional extra
    import drjit as dr
    import mitsuba as mi
except ImportError:  # pragma: no cover - CI installs it
    mi = None

needs_mitsuba = pytest.mark.skipif(
    mi is None, reason="mitsuba is not installed (pip install flakescatter[render])"
)

SCALES = np.array([1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0])
N_TH, N_TD, N_PD = 90, 90, 180


# ------------------------------------------------------------ independent MERL code


def theta_h_centres():
    """θh at the centre of each θh bin: the index is floor(90 sqrt(θh/(π/2))), so bin k
    spans θh/(π/2) ∈ [(k/90)², ((k+1)/90)²); its centre in index space is k + ½."""
    return ((np.arange(N_TH) + 0.5) / N_TH) ** 2 * (math.pi / 2)


def write_merl(path, values, unfilled=None):
    """Write a MERL file from ``values`` (3, 90, 90, 180) in sr⁻¹: each channel divided
    by its scale, −1 where ``unfilled`` (a boolean (90, 90, 180) mask) is set."""
    stored = np.asarray(values, dtype=np.float64) / SCALES[:, None, None, None]
    if unfilled is not None:
        stored[:, unfilled] = -1.0
    with open(path, "wb") as f:
        f.write(np.array([N_TH, N_TD, N_PD], dtype="<i4").tobytes())
        f.write(stored.astype("<f8").tobytes())
    return path


def lobe_paint(albedo, amplitude, hwhm_deg):
    """f(θh) = albedo/π + amplitude · exp(−ln 2 · (θh/hwhm)²) per channel (a Lambertian
    base and a Gaussian lobe in θh of half width at half maximum ``hwhm``), evaluated
    at each θh bin's centre; constant over θd and φd."""
    th = theta_h_centres()
    lobe = np.exp(-math.log(2.0) * (th / math.radians(hwhm_deg)) ** 2)
    f = np.asarray(albedo)[:, None] / math.pi + np.asarray(amplitude)[:, None] * lobe[None, :]
    return np.broadcast_to(f[:, :, None, None], (3, N_TH, N_TD, N_PD)).copy()


def read_stored(path):
    """The file's values in sr⁻¹ (stored × scale), negative (unfilled) bins as 0."""
    raw = np.fromfile(path, dtype="<f8", offset=12).reshape(3, N_TH, N_TD, N_PD)
    return np.where(raw < 0, 0.0, raw * SCALES[:, None, None, None])


def rusinkiewicz(w_in, w_out):
    """(θh, θd, φd) of unit directions, as BRDFRead.cpp's std_coords_to_half_diff."""
    h = w_in + w_out
    h = h / np.linalg.norm(h, axis=-1, keepdims=True)
    theta_h = np.arccos(np.clip(h[..., 2], -1, 1))
    phi_h = np.arctan2(h[..., 1], h[..., 0])

    def rotate(v, axis, angle):  # Rodrigues, as the reference's rotate_vector
        c, s = np.cos(angle)[..., None], np.sin(angle)[..., None]
        axis = np.broadcast_to(axis, v.shape)
        dot = np.sum(axis * v, axis=-1, keepdims=True)
        return v * c + axis * dot * (1 - c) + np.cross(axis, v) * s

    t = rotate(w_in, np.array([0.0, 0.0, 1.0]), -phi_h)
    d = rotate(t, np.array([0.0, 1.0, 0.0]), -theta_h)
    return theta_h, np.arccos(np.clip(d[..., 2], -1, 1)), np.arctan2(d[..., 1], d[..., 0])


def merl_index(w_in, w_out):
    theta_h, theta_d, phi_d = rusinkiewicz(w_in, w_out)
    ih = np.floor(np.sqrt(np.maximum(theta_h, 0) / (math.pi / 2) * N_TH * N_TH))
    ih = np.clip(np.where(theta_h <= 0, 0, ih), 0, N_TH - 1).astype(int)
    idd = np.clip(np.floor(theta_d / (math.pi / 2) * N_TD), 0, N_TD - 1).astype(int)
    phi_d = np.where(phi_d < 0, phi_d + math.pi, phi_d)
    ip = np.clip(np.floor(phi_d / math.pi * N_PD), 0, N_PD - 1).astype(int)
    return ih, idd, ip


def merl_lookup(table, w_in, w_out):
    """RGB value (sr⁻¹) of ``table`` (3, 90, 90, 180) in the bin of (w_in, w_out)."""
    ih, idd, ip = merl_index(w_in, w_out)
    return np.moveaxis(table[:, ih, idd, ip], 0, -1)


def direction(theta_deg, phi_deg):
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])


# Two paints: a narrow (hwhm 4°) and a broad (10°) Gaussian lobe in θh over a
# Lambertian base, with different RGB albedos and lobe heights.
PAINTS = {
    "narrow": dict(albedo=(0.20, 0.25, 0.30), amplitude=(30.0, 27.0, 24.0), hwhm_deg=4.0),
    "broad": dict(albedo=(0.30, 0.22, 0.12), amplitude=(5.0, 4.5, 4.0), hwhm_deg=10.0),
}


def horizon_mask():
    """Bins whose centre has θh + θd > 90°, left unfilled (−1) as MERL leaves bins
    below the horizon; directions above the horizon still reach them (at φd near 90°
    both directions have z = cos θh cos θd > 0), so the plugin must cope with them."""
    th = theta_h_centres()
    td = (np.arange(N_TD) + 0.5) / N_TD * (math.pi / 2)
    return np.broadcast_to((th[:, None] + td[None, :] > math.pi / 2)[:, :, None],
                           (N_TH, N_TD, N_PD))


@pytest.fixture(scope="module")
def paint_files(tmp_path_factory):
    d = tmp_path_factory.mktemp("merl")
    files = {name: str(write_merl(d / f"{name}.binary", lobe_paint(**p)))
             for name, p in PAINTS.items()}
    files["broad-unfilled"] = str(write_merl(d / "broad-unfilled.binary",
                                             lobe_paint(**PAINTS["broad"]), horizon_mask()))
    return files


@pytest.fixture
def variant():
    """Restores the active Mitsuba variant after a test that switches it."""
    before = mi.variant() if mi is not None else None
    yield
    if before is not None:
        mi.set_variant(before)


def use(name):
    mi.set_variant(name)
    import flakescatter.mitsuba as fm

    fm.register()
    return fm


JIT = "llvm_ad_rgb"


def llvm_usable():
    """Whether llvm_ad_rgb can run here. Dr.Jit's LLVM backend aborts the process (not
    an exception) when the system's libLLVM cannot lower its min/max (seen with
    LLVM 15: "Cannot select: fmaximum"), so ask a child process first."""
    if mi is None or JIT not in mi.variants():
        return False, f"{JIT} is not among mitsuba.variants()"
    probe = ("import drjit as dr, mitsuba as mi; mi.set_variant('llvm_ad_rgb'); "
             "x = dr.linspace(mi.Float, -1, 1, 64); dr.eval(dr.atan2(x, dr.maximum(x, 0.1)))")
    r = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True)
    if r.returncode != 0:
        return False, ("Dr.Jit's LLVM backend fails with this machine's libLLVM "
                       "(install LLVM >= 16, e.g. apt install libllvm19): "
                       + (r.stderr.strip().splitlines() or ["?"])[0])
    return True, ""


_LLVM = llvm_usable() if mi is not None else (False, "mitsuba is not installed")
needs_llvm = pytest.mark.skipif(not _LLVM[0], reason=_LLVM[1])


def test_mitsuba_is_there_when_required():
    """CI sets FLAKESCATTER_REQUIRE_MITSUBA=1 after installing the extra: there the
    skips above would hide the χ² test, so a missing Mitsuba or an unusable LLVM
    variant is a failure instead."""
    if os.environ.get("FLAKESCATTER_REQUIRE_MITSUBA") != "1":
        pytest.skip("FLAKESCATTER_REQUIRE_MITSUBA is not 1 (CI sets it)")
    assert mi is not None, "mitsuba is not importable: pip install flakescatter[render]"
    assert _LLVM[0], _LLVM[1]


# ------------------------------------------------------------ χ² (Mitsuba's own test)


@needs_mitsuba
@needs_llvm
@pytest.mark.parametrize("paint", ["narrow", "broad", "broad-unfilled"])
@pytest.mark.parametrize("theta_i", [10.0, 45.0, 70.0])
def test_chi2_sampling_matches_pdf(paint, theta_i, paint_files, variant):
    """Mitsuba's χ² goodness-of-fit test of sample() against pdf() (``mitsuba.chi2``,
    as Mitsuba tests its own BSDFs): 10⁶ samples histogrammed on the sphere against the
    pdf integrated over each cell. The reference is pdf(), which the test integrates
    itself; a sampler that does not draw from it (a wrong mixture weight, a missing
    Jacobian 1/(4|ωo·m|), a lobe about the wrong axis) is rejected.

    ``ires=16`` (not the default 4): the hwhm-4° paint's lobe (Beckmann α ≈ 0.084)
    is narrower than a few of the 1.8° cells, and a 4-point trapezoid rule misintegrates
    it — Mitsuba's own roughconductor with α = 0.084 fails at ires=4 (p ≈ 0) and passes
    at 16 on this very test. The Šidák correction covers the 9 tests.

    "broad-unfilled" has MERL's unfilled bins: Mitsuba counts a sample of weight 0 as
    failed, so pdf() must be 0 where eval is 0 for the samples that count to follow it
    (a real ``export --format merl`` table failed here before that rule)."""
    from mitsuba.chi2 import BSDFAdapter, ChiSquareTest, SphericalDomain

    use(JIT)
    wi = [float(x) for x in direction(theta_i, 0.0)]
    sample_func, pdf_func = BSDFAdapter(
        "flakescatter", {"type": "flakescatter", "filename": paint_files[paint]}, wi=wi)
    chi2 = ChiSquareTest(domain=SphericalDomain(), sample_func=sample_func,
                         pdf_func=pdf_func, sample_dim=3, ires=16, seed=7)
    ok = chi2.run(significance_level=0.01, test_count=9, quiet=True)
    print(f"chi2 {paint} theta_i={theta_i}: p = {chi2.p_value}")
    assert ok, chi2.messages


@needs_mitsuba
@needs_llvm
def test_chi2_on_a_table_from_export(cli_bin, tmp_path, variant):
    """The same χ² test on a table written by ``flakescatter export --format merl``
    (the distribution model, hwhm 10°: a quarter of its bins unfilled, values spanning
    ten decades), at 45°, where it failed before pdf() was made 0 where eval is 0."""
    from mitsuba.chi2 import BSDFAdapter, ChiSquareTest, SphericalDomain

    path = tmp_path / "hwhm10.binary"
    subprocess.run([str(cli_bin), "export", "--format", "merl", "--hwhm", "10", "--out",
                    str(path)], check=True, capture_output=True)
    use(JIT)
    wi = [float(x) for x in direction(45.0, 0.0)]
    sample_func, pdf_func = BSDFAdapter(
        "flakescatter", {"type": "flakescatter", "filename": str(path)}, wi=wi)
    chi2 = ChiSquareTest(domain=SphericalDomain(), sample_func=sample_func,
                         pdf_func=pdf_func, sample_dim=3, ires=16, seed=7)
    ok = chi2.run(significance_level=0.01, quiet=True)
    print(f"chi2 exported hwhm 10 at 45: p = {chi2.p_value}")
    assert ok, chi2.messages


# ------------------------------------------------------------ eval against the reference


def random_pairs(n, seed):
    """n pairs of directions uniform over the upper hemisphere (z = cos θ uniform)."""
    rng = np.random.default_rng(seed)

    def draw():
        z = rng.uniform(0.02, 1.0, n)
        phi = rng.uniform(0.0, 2.0 * math.pi, n)
        s = np.sqrt(1.0 - z * z)
        return np.stack([s * np.cos(phi), s * np.sin(phi), z], axis=-1)

    return draw(), draw()


@pytest.fixture(scope="module")
def bin_table(tmp_path_factory):
    """A table whose every bin differs (so that a wrong bin gives a wrong value), with
    the bins of θh + θd > 90° at their centres left unfilled (−1) as MERL does."""
    rng = np.random.default_rng(48)
    values = rng.uniform(0.1, 2.0, size=(3, N_TH, N_TD, N_PD))
    path = write_merl(tmp_path_factory.mktemp("bins") / "bins.binary", values, horizon_mask())
    return str(path), read_stored(path)


def plugin_eval(bsdf, wi, wo):
    """Mitsuba's eval for arrays of (wi, wo) pairs, in any variant: (n, 3)."""
    ctx = mi.BSDFContext()
    if dr.is_jit_v(mi.Float):
        si = dr.zeros(mi.SurfaceInteraction3f, len(wi))
        si.wi = mi.Vector3f(*(mi.Float(wi[:, k].astype(np.float32)) for k in range(3)))
        v = bsdf.eval(ctx, si, mi.Vector3f(*(mi.Float(wo[:, k].astype(np.float32))
                                            for k in range(3))))
        return np.stack([np.array(v[k]) for k in range(3)], axis=-1)
    out = []
    for a, b in zip(wi, wo):
        si = dr.zeros(mi.SurfaceInteraction3f)
        si.wi = mi.Vector3f(*map(float, a))
        v = bsdf.eval(ctx, si, mi.Vector3f(*map(float, b)))
        out.append([v[0], v[1], v[2]])
    return np.array(out)


@needs_mitsuba
@pytest.mark.parametrize("name", ["scalar_rgb", JIT])
def test_eval_is_the_reference_lookup_times_cos(name, bin_table, variant):
    """eval(ωi, ωo) = table[bin(ωo, ωi)] × cos θo at 400 random pairs, the bin and the
    value from this file's numpy transcription of BRDFRead.cpp (float64). Every bin
    holds a different random value, so a wrong index is a wrong value. Pairs within
    1e-4 rad of a bin edge (where the plugin's single precision may legitimately
    choose the neighbour) are left out, by checking that the reference gives the same
    bin at the pair and at slightly rotated copies of it."""
    if name == JIT and not _LLVM[0]:
        pytest.skip(_LLVM[1])
    path, table = bin_table
    use(name)
    bsdf = mi.load_dict({"type": "flakescatter", "filename": path})
    wi, wo = random_pairs(400, seed=1)
    # Mitsuba's wo (towards the light) is MERL's incident direction.
    expected = merl_lookup(table, wo, wi) * wo[:, 2:3]
    stable = np.ones(len(wi), dtype=bool)
    ref = np.stack(merl_index(wo, wi))
    for eps in (1e-4, -1e-4):
        c, s = math.cos(eps), math.sin(eps)
        rot = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
        for a, b in ((wo @ rot.T, wi), (wo, wi @ rot.T)):
            stable &= np.all(np.stack(merl_index(a, b)) == ref, axis=0)
    assert stable.sum() > 350
    got = plugin_eval(bsdf, wi[stable], wo[stable])
    np.testing.assert_allclose(got, expected[stable], rtol=1e-6, atol=0)
    # Unfilled bins (about a third of these pairs' bins at θh + θd > 90°) read as 0.
    filled = read_raw_sign(path)[tuple(ref[:, stable])]
    assert (~filled).sum() > 10 and np.all(got[~filled] == 0.0)


def read_raw_sign(path):
    """True where the file's first channel stores a non-negative value."""
    raw = np.fromfile(path, dtype="<f8", offset=12, count=N_TH * N_TD * N_PD)
    return raw.reshape(N_TH, N_TD, N_PD) >= 0


@needs_mitsuba
@pytest.mark.parametrize("name", ["scalar_rgb", JIT])
def test_one_sided(name, paint_files, variant):
    """Zero below the horizon on either side (the table has no value there), nonzero
    above: the Lambertian base alone gives albedo/π × cos θo > 0."""
    if name == JIT and not _LLVM[0]:
        pytest.skip(_LLVM[1])
    use(name)
    bsdf = mi.load_dict({"type": "flakescatter", "filename": paint_files["broad"]})
    up, down = direction(40.0, 10.0), direction(40.0, 10.0) * np.array([1, 1, -1])
    pairs = np.array([(up, up), (up, down), (down, up), (down, down)])
    v = plugin_eval(bsdf, pairs[:, 0], pairs[:, 1])
    assert np.all(v[0] > 0) and np.all(v[1:] == 0)


# ------------------------------------------------------------ rendering


def render_patch(path, light_dir, view_dir, irradiance):
    """A flat patch (Mitsuba's rectangle: [-1, 1]² in z = 0, normal +z) lit by one
    directional emitter of irradiance E arriving from ``light_dir``, seen by an
    orthographic camera along ``view_dir`` framing its central 1 × 1 (5 × 5 pixels);
    the patch therefore fills the frame and every pixel sees the same (ωi, ωo)."""
    origin = (3.0 * view_dir).tolist()
    up = [0.0, 1.0, 0.0] if abs(view_dir[1]) < 0.9 else [1.0, 0.0, 0.0]
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 2},
        "sensor": {
            "type": "orthographic",
            "to_world": mi.ScalarTransform4f().look_at(origin=origin, target=[0, 0, 0], up=up)
            @ mi.ScalarTransform4f().scale([0.5, 0.5, 1.0]),
            "film": {"type": "hdrfilm", "width": 5, "height": 5, "pixel_format": "rgb",
                     "rfilter": {"type": "box"}},
            "sampler": {"type": "independent", "sample_count": 4},
        },
        "sun": {"type": "directional", "direction": (-light_dir).tolist(),
                "irradiance": {"type": "rgb", "value": [irradiance] * 3}},
        "patch": {"type": "rectangle",
                  "bsdf": {"type": "flakescatter", "filename": path}},
    })
    return np.array(mi.render(scene), dtype=np.float64)[..., :3]


@needs_mitsuba
@pytest.mark.parametrize("name", ["scalar_rgb", JIT])
def test_flat_patch_radiance_is_brdf_cos_irradiance(name, paint_files, variant):
    """Radiance from a flat patch under one distant light of irradiance E (on a plane
    normal to the beam): L(ωo) = f(ωi, ωo) · cos θi · E (the rendering equation with a
    delta light; the path tracer finds it by emitter sampling alone, so the value has
    no Monte Carlo noise). f from this file's numpy lookup of the same file. Light at
    θi = 30°, camera at θo = 35°, 20° off the mirror direction (the lobe's flank plus
    the Lambertian base); both away from bin edges (checked)."""
    if name == JIT and not _LLVM[0]:
        pytest.skip(_LLVM[1])
    use(name)
    path = paint_files["narrow"]
    light, view = direction(30.0, 0.0), direction(35.0, 160.0)
    e = 2.5
    table = read_stored(path)
    f = merl_lookup(table, light[None], view[None])[0]
    for eps in (1e-4, -1e-4):  # the same bin under small rotations: not on an edge
        c, s = math.cos(eps), math.sin(eps)
        rot = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
        assert np.array_equal(merl_lookup(table, (rot @ light)[None], view[None])[0], f)
    expected = f * math.cos(math.radians(30.0)) * e
    image = render_patch(path, light, view, e)
    centre = image[2, 2]
    ratio = centre / expected
    print(f"flat patch {name}: centre {centre}, expected {expected}, ratio {ratio}")
    assert np.all(np.abs(ratio - 1.0) < 0.02), (centre, expected)


def highlight_size(image):
    """Pixels whose luminance (Rec. 709 weights) exceeds half the image's peak."""
    lum = image @ np.array([0.2126, 0.7152, 0.0722])
    return int(np.count_nonzero(lum > 0.5 * lum.max()))


@needs_mitsuba
def test_sphere_previews_show_the_lobe_width(paint_files, tmp_path, variant):
    """The sphere previews of the hwhm-4° and hwhm-10° paints differ visibly: the
    highlight (pixels above half the peak luminance) of the broad paint is larger.
    Expected ratio: on a sphere seen from afar the highlight is the set of pixels whose
    normal lies within ~hwhm of the half vector, an area ∝ hwhm², so about
    (10/4)² ≈ 6 (less where the narrow highlight spans few pixels); the issue asks
    > 1.5. Also: the PNG is written, 8-bit RGB of the requested size."""
    fm = use(JIT if _LLVM[0] else "scalar_rgb")
    res, spp = (64, 16) if _LLVM[0] else (32, 4)
    sizes = {}
    for name in ("narrow", "broad"):
        out = tmp_path / f"{name}.png"
        r = fm.render_preview(paint_files[name], out, resolution=res, spp=spp)
        assert r["png"] == str(out) and r["image"].shape == (res, res, 3)
        png = mi.Bitmap(str(out))
        assert (png.width(), png.height(), png.channel_count()) == (res, res, 3)
        assert png.component_format() == mi.Struct.Type.UInt8
        sizes[name] = highlight_size(r["image"])
    ratio = sizes["broad"] / sizes["narrow"]
    print(f"highlight sizes {sizes}, ratio {ratio:.2f}")
    assert sizes["narrow"] >= 1 and ratio > 1.5


# ------------------------------------------------------------ bad files


@pytest.fixture
def bad_files(tmp_path):
    """A truncated file (right header, 100 values instead of 3 × 1 458 000) and one whose
    header announces 90 × 90 × 360 bins (the full-φd layout, not MERL's)."""
    short = tmp_path / "short.binary"
    short.write_bytes(np.array([90, 90, 180], "<i4").tobytes() + np.zeros(100, "<f8").tobytes())
    dims = tmp_path / "dims.binary"
    dims.write_bytes(np.array([90, 90, 360], "<i4").tobytes()
                     + np.zeros(3 * 90 * 90 * 360, "<f8").tobytes())
    return {"missing": tmp_path / "missing.binary", "short": short, "dims": dims}


@needs_mitsuba
@pytest.mark.parametrize("kind, error", [("missing", flakescatter.FileError),
                                         ("short", flakescatter.FileFormatError),
                                         ("dims", flakescatter.FileFormatError)])
def test_bad_file_is_a_clear_error_naming_it(kind, error, bad_files, tmp_path, variant):
    """A missing, truncated or wrong-dimension file: the project's error naming the file
    from load_bsdf and render_preview (no PNG written); through mitsuba.load_dict,
    Mitsuba's RuntimeError carrying the same text."""
    fm = use("scalar_rgb")
    path = bad_files[kind]
    with pytest.raises(error, match=path.name):
        fm.load_bsdf(path)
    out = tmp_path / "never.png"
    with pytest.raises(error, match=path.name):
        fm.render_preview(path, out, resolution=8, spp=1)
    assert not out.exists()
    with pytest.raises(RuntimeError, match=rf"{error.__name__}.*{path.name}"):
        mi.load_dict({"type": "flakescatter", "filename": str(path)})


@needs_mitsuba
def test_a_spectral_variant_is_refused_naming_it(variant):
    """The table is RGB: registering in a spectral variant is refused, not mixed up."""
    import flakescatter.mitsuba as fm

    mi.set_variant("scalar_spectral")
    with pytest.raises(ValueError, match="scalar_spectral"):
        fm.register()


@needs_mitsuba
def test_missing_filename_property_is_named(variant):
    use("scalar_rgb")
    with pytest.raises(RuntimeError, match="'filename'"):
        mi.load_dict({"type": "flakescatter"})


@needs_mitsuba
def test_bad_preview_arguments_are_refused(paint_files, tmp_path, variant):
    import flakescatter.mitsuba as fm

    """Each argument is honoured or refused naming it; nothing is written."""
    out = tmp_path / "x.png"
    for kwargs, what in [({"shape": "cube"}, "shape"), ({"resolution": 0}, "resolution"),
                         ({"spp": 0}, "spp"),
                         ({"sun_direction": (0, 0, 0)}, "sun_direction"),
                         ({"sun_irradiance": (1, 1)}, "sun_irradiance"),
                         ({"sky_radiance": (0.1, -1, 0.1)}, "sky_radiance"),
                         ({"exposure": 0.0}, "exposure"),
                         ({"variant": "scalar_spectral"}, "variant")]:
        with pytest.raises(ValueError, match=what):
            fm.render_preview(paint_files["broad"], out, **kwargs)
    missing = tmp_path / "no-such-folder" / "x.png"
    with pytest.raises(flakescatter.FileError, match="no-such-folder"):
        fm.render_preview(paint_files["broad"], missing)
    assert not out.exists() and not missing.parent.exists()


# ------------------------------------------------------------ without mitsuba


def run_python(code):
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return r.stdout


def test_package_import_does_not_import_mitsuba():
    """Mitsuba is an optional extra: importing flakescatter (and its mitsuba module)
    must not load it."""
    out = run_python("import sys, flakescatter, flakescatter.mitsuba; "
                     "print('mitsuba' in sys.modules, 'drjit' in sys.modules)")
    assert out.split() == ["False", "False"]


def test_without_mitsuba_the_error_says_how_to_install_it(tmp_path):
    """With mitsuba unimportable (sys.modules entry None: ImportError on import),
    register and render_preview raise ImportError with the install hint."""
    out = run_python(
        "import sys\n"
        "sys.modules['mitsuba'] = None; sys.modules['drjit'] = None\n"
        "import flakescatter.mitsuba as fm\n"
        "for call in (fm.register, lambda: fm.render_preview('x.binary', 'x.png')):\n"
        "    try:\n"
        "        call()\n"
        "    except ImportError as e:\n"
        "        print(e)\n")
    lines = out.strip().splitlines()
    assert len(lines) == 2 and all("pip install flakescatter[render]" in x for x in lines)


@needs_mitsuba
@pytest.mark.parametrize("paint", ["narrow", "broad"])
def test_sampling_lobe_follows_the_table(paint, paint_files, variant):
    """The sampler's Beckmann lobe is fitted to the table's peak: a Gaussian in θh of
    half width h falls to half at θh = h, a Beckmann D ∝ exp(−tan²θ/α²) at
    tan²θ = α² ln 2, so the matching α is tan h / sqrt(ln 2) (0.0840 for 4°, 0.2118 for
    10°); within 5 % (the estimate interpolates between bin centres). Both paints'
    lobes outweigh their Lambertian bases, so the lobe gets the maximum share, 0.9."""
    fm = use("scalar_rgb")
    bsdf = fm.load_bsdf(paint_files[paint])
    hwhm = math.radians(PAINTS[paint]["hwhm_deg"])
    assert bsdf.alpha == pytest.approx(math.tan(hwhm) / math.sqrt(math.log(2.0)), rel=0.05)
    assert bsdf.lobe_weight == pytest.approx(0.9)


@needs_mitsuba
@needs_llvm
def test_guide_snippets_run_as_written(cli_bin, tmp_path, monkeypatch, variant):
    """docs/guide.md §14 run as written, in an empty folder: its `flakescatter export`
    commands (with the built CLI), then its two Python blocks; the previews are the
    256 × 256 PNGs the guide promises."""
    guide = (pathlib.Path(__file__).resolve().parents[3] / "docs" / "guide.md").read_text()
    section = guide.split("## 14. Seeing a paint: Mitsuba previews", 1)[1].split("\n## ", 1)[0]
    shell = section.split("```sh\n", 1)[1].split("```", 1)[0]
    commands = [line.split("#")[0].split() for line in shell.splitlines()]
    blocks = [b.split("```", 1)[0] for b in section.split("```python\n")[1:]]
    assert len(blocks) == 2
    monkeypatch.chdir(tmp_path)
    exports = 0
    for argv in filter(None, commands):
        if argv[:2] == ["pip", "install"]:
            continue  # done: this test runs in that environment
        if argv[:2] == ["mkdir", "-p"]:
            os.makedirs(argv[2], exist_ok=True)
            continue
        assert argv[0] == "flakescatter", f"the guide runs {argv}: teach this test"
        subprocess.run([str(cli_bin)] + argv[1:], check=True, capture_output=True)
        exports += 1
    assert exports == 2
    for block in blocks:
        exec(compile(block, "docs/guide.md §14", "exec"), {})
    for name in ("hwhm4", "hwhm10"):
        png = mi.Bitmap(str(tmp_path / "out" / f"{name}.png"))
        assert (png.width(), png.height()) == (256, 256)

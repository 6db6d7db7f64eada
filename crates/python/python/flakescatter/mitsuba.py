"""Seeing a paint: a Mitsuba 3 BSDF over a tabulated (MERL) BRDF, and rendered previews.

Mitsuba 3 (PyPI ``mitsuba``) is an optional extra: ``pip install flakescatter[render]``.
Importing this module works without it; :func:`register` and :func:`render_preview`
import Mitsuba when called and raise :class:`ImportError` with that hint when it is
missing.

The BSDF (plugin name ``"flakescatter"``, property ``filename``)
------------------------------------------------------------------
``register()`` makes the plugin available to the active Mitsuba variant (tested with
``scalar_rgb`` and ``llvm_ad_rgb``; any RGB variant should do)::

    import mitsuba as mi, flakescatter.mitsuba as fm
    mi.set_variant("llvm_ad_rgb")
    fm.register()
    bsdf = mi.load_dict({"type": "flakescatter", "filename": "paint.binary"})

``filename`` is an isotropic tabulated BRDF in the MERL format (Matusik et al. 2003,
the layout of MERL's reference reader ``BRDFRead.cpp``; ``docs/formats.md``), read
with :func:`flakescatter.read_brdf`: 90 × 90 × 180 bins over the Rusinkiewicz
half/difference angles (θh, θd, φd) in R, G, B, in sr⁻¹. A missing file raises
:class:`flakescatter.FileError`, a malformed one :class:`flakescatter.FileFormatError`,
both naming the file: directly from :func:`load_bsdf` and :func:`render_preview`,
wrapped in Mitsuba's ``RuntimeError`` (their text kept) from ``mitsuba.load_dict``.

* **eval** is the table's value × cos θo (Mitsuba's convention), RGB, looked up in the
  bin of (ωi, ωo) exactly as the reference reader does (no interpolation): θh index
  ``floor(sqrt(θh/(π/2) · 90 · 90))``, θd index ``floor(θd/(π/2) · 90)``, φd folded into
  [0, π) by reciprocity and indexed ``floor(φd/π · 180)``, each clamped to the table;
  the difference vector is MERL's: the light-side direction rotated by −φh about the
  normal, then by −θh about the binormal. Mitsuba's ``wo`` (towards the light in
  radiance transport) plays MERL's incident direction; by reciprocity the other choice
  differs only on bin boundaries. Bins the file leaves unfilled (stored negative,
  below the horizon) are 0. The BSDF is one-sided: 0 when either direction is at or
  below the surface's horizon (wrap it in Mitsuba's ``twosided`` for a two-sided one).
* **sample / pdf**: a mixture of two strategies, chosen by ``sample1``:

  - with probability ``w``, a Beckmann microfacet lobe (``mi.MicrofacetDistribution``,
    visible-normal sampling) reflected about the sampled normal;
  - with probability ``1 − w``, cosine-weighted hemisphere sampling.

  ``pdf`` is the mixture's exact density ``w · p_lobe(ωo) + (1 − w) · p_cos(ωo)``
  (``p_lobe = D_ωi(m) / (4 |ωo · m|)``, m the half vector), 0 below either horizon and
  wherever eval is 0 (unfilled bins: a sample drawn there is a failed sample, weight
  0, so the samples that count have exactly this density); the
  sample's ``pdf`` is computed by the same function on the sampled direction, so that
  sample and pdf agree exactly (Mitsuba's χ² test, ``mitsuba.chi2``, passes:
  ``crates/python/tests/test_mitsuba.py``). The weight is ``eval / pdf``.

  The lobe's roughness and ``w`` are estimated from the table when it is loaded:
  the channel-mean BRDF at θd < 10°, averaged over φd, as a function of θh; its
  baseline b is the median at θh > 45°, its peak p the value of the first θh bin; the
  half width θ½ is where it falls to b + (p − b)/2 (linear between bin centres), and the
  Beckmann roughness α = tan θ½ / sqrt(ln 2) (a Beckmann D falls to half at
  tan²θ = α² ln 2), clamped to [0.01, 1]. The lobe's albedo is estimated as
  (p − b) · 4πα² against the diffuse part's π b, and ``w`` is the lobe's share, clamped
  to [0.1, 0.9] so that each strategy keeps some samples. The estimates only steer the
  sampling (noise), never the values: a poor estimate costs variance, not bias.

  The two strategies are reported as components 0 (glossy) and 1 (diffuse) of the
  sample, but the BSDF is one table: a ``BSDFContext`` selecting one component or
  type is not honoured (eval and pdf are always of the whole).

Previews
--------
:func:`render_preview` renders a sphere (or a curved panel) with the plugin under a
documented light and writes a tone-mapped PNG; see its docstring.
"""

from __future__ import annotations

import math
import os
from typing import Any, Dict, Optional, Sequence, Tuple

import numpy as np

__all__ = ["register", "load_bsdf", "render_preview", "montage", "main", "PLUGIN_NAME", "SUN_DIRECTION",
           "SUN_IRRADIANCE", "SKY_RADIANCE"]

#: The plugin's name in scene descriptions (``{"type": "flakescatter", ...}``).
PLUGIN_NAME = "flakescatter"

#: Preview light, world coordinates (camera on +z looking at the origin, +y up): the
#: direction *towards* the sun, 45° from the viewing axis, up and to the camera's left.
SUN_DIRECTION = (-0.5, 0.5, math.sqrt(0.5))
#: Irradiance of the sun on a plane normal to its beam (relative units, RGB).
SUN_IRRADIANCE = (1.0, 1.0, 1.0)
#: Radiance of the uniform sky, the same from every direction (relative units, RGB):
#: an upward plane receives π × 0.05 ≈ 0.157 from it, about 1/6 of the sun's.
SKY_RADIANCE = (0.05, 0.05, 0.05)

_HINT = (
    "flakescatter.mitsuba needs Mitsuba 3: pip install flakescatter[render] "
    "(or pip install mitsuba)"
)

# MERL's table: 90 θh bins (square-root spaced), 90 θd bins, 180 φd bins over [0, π).
_N_TH, _N_TD, _N_PD = 90, 90, 180
_N_BINS = _N_TH * _N_TD * _N_PD


def _mitsuba():
    """Mitsuba and Dr.Jit, imported on first use, with the install hint when absent."""
    try:
        import drjit as dr
        import mitsuba as mi
    except ImportError as e:  # pragma: no cover - exercised without mitsuba installed
        raise ImportError(_HINT) from e
    return mi, dr


def _rgb_variant(mi) -> str:
    try:
        v = mi.variant()
    except Exception:  # no variant set yet
        v = None
    if v is None:
        raise RuntimeError("flakescatter.mitsuba: no Mitsuba variant is set; call "
                           "mitsuba.set_variant('scalar_rgb') (or 'llvm_ad_rgb') first")
    if not v.endswith("_rgb"):
        raise ValueError(f"flakescatter.mitsuba: the plugin works in RGB variants "
                         f"(e.g. scalar_rgb, llvm_ad_rgb), not {v!r}")
    return v


# --------------------------------------------------------------------------- table


_TABLE_CACHE: Dict[Tuple[str, int, int], Tuple[np.ndarray, float, float]] = {}


def _load_table(filename: str) -> Tuple[np.ndarray, float, float]:
    """The table (float32, 3 × 90·90·180, unfilled bins 0), lobe roughness α and weight w.

    Read with :func:`flakescatter.read_brdf` (the project's one MERL reader); the last
    few tables are kept, keyed by path, modification time and size, because Mitsuba
    builds a plugin anew for every scene it loads.
    """
    from . import read_brdf

    try:
        st = os.stat(filename)
        key = (os.path.realpath(filename), st.st_mtime_ns, st.st_size)
    except OSError:
        key = None  # read_brdf reports the missing file in the project's words
    if key is not None and key in _TABLE_CACHE:
        return _TABLE_CACHE[key]
    brdf = np.asarray(read_brdf(filename)["brdf"], dtype=np.float64)
    if brdf.shape != (3, _N_TH, _N_TD, _N_PD):
        raise ValueError(f"{filename}: read_brdf returned a table of shape {brdf.shape}, "
                         f"expected (3, 90, 90, 180)")
    table = np.where(np.isfinite(brdf) & (brdf > 0.0), brdf, 0.0)
    alpha, weight = _lobe_estimate(table)
    entry = (np.ascontiguousarray(table.reshape(3, _N_BINS), dtype=np.float32), alpha, weight)
    if key is not None:
        if len(_TABLE_CACHE) >= 4:
            _TABLE_CACHE.pop(next(iter(_TABLE_CACHE)))
        _TABLE_CACHE[key] = entry
    return entry


def _lobe_estimate(table: np.ndarray) -> Tuple[float, float]:
    """Beckmann roughness α and lobe weight w of the sampling mixture (module docstring)."""
    # Channel mean at θd < 10° (the first 10 θd bins), averaged over φd: f(θh bin).
    g = table.mean(axis=0)[:, :10, :].mean(axis=(1, 2))
    th_centres = ((np.arange(_N_TH) + 0.5) / _N_TH) ** 2 * (math.pi / 2)
    base = float(np.median(g[th_centres > math.radians(45.0)]))
    peak = float(g[0])
    if not peak > base:
        return 1.0, 0.1
    half = base + 0.5 * (peak - base)
    below = np.nonzero(g < half)[0]
    if below.size == 0:
        theta_half = math.pi / 4
    else:
        k = int(below[0])
        if k == 0:
            theta_half = th_centres[0]
        else:
            # Linear between the bin centres on either side of the crossing.
            t = (g[k - 1] - half) / (g[k - 1] - g[k])
            theta_half = th_centres[k - 1] + t * (th_centres[k] - th_centres[k - 1])
    alpha = min(max(math.tan(min(theta_half, 1.4)) / math.sqrt(math.log(2.0)), 0.01), 1.0)
    lobe = (peak - base) * 4.0 * math.pi * alpha * alpha
    diffuse = math.pi * max(base, 0.0)
    weight = lobe / (lobe + diffuse) if lobe + diffuse > 0 else 0.5
    return alpha, min(max(weight, 0.1), 0.9)


# --------------------------------------------------------------------------- plugin


def _make_plugin_class(mi, dr):
    """The BSDF class for the active variant (Mitsuba types are per variant)."""
    pi = math.pi
    scalar = not dr.is_jit_v(mi.Float)

    class FlakescatterBSDF(mi.BSDF):
        """A MERL table as a Mitsuba BSDF (see :mod:`flakescatter.mitsuba`)."""

        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            if "filename" not in props:
                raise ValueError("flakescatter BSDF: the property 'filename' (a MERL "
                                 ".binary file) is required")
            self.filename = str(props["filename"])
            table, alpha, weight = _load_table(self.filename)
            if scalar:
                self._table = table  # numpy, indexed with Python ints
            else:
                self._table = [mi.Float(table[c]) for c in range(3)]
            self.alpha = alpha
            self.lobe_weight = weight
            self._distr = mi.MicrofacetDistribution(mi.MicrofacetType.Beckmann, alpha, True)
            glossy = mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.FrontSide
            diffuse = mi.BSDFFlags.DiffuseReflection | mi.BSDFFlags.FrontSide
            self.m_components = [glossy, diffuse]
            self.m_flags = glossy | diffuse

        # The table's value in the bin of (w_in, w_out), both unit, local frame.
        def _lookup(self, w_in, w_out, active):
            # θ from atan2(sin, cos) rather than the reference's acos(cos): the same
            # angle, but accurate in single precision near 0, where the θh bins are
            # narrowest (bin 1 starts at 0.011°).
            h = w_in + w_out
            theta_h = dr.atan2(dr.sqrt(h.x * h.x + h.y * h.y), h.z)
            s_ph, c_ph = dr.sincos(dr.atan2(h.y, h.x))
            # w_in rotated by -φh about the normal (z), then by -θh about the binormal (y).
            tx = w_in.x * c_ph + w_in.y * s_ph
            ty = w_in.y * c_ph - w_in.x * s_ph
            tz = w_in.z
            s_th, c_th = dr.sincos(theta_h)
            dx = tx * c_th - tz * s_th
            dz = tx * s_th + tz * c_th
            theta_d = dr.atan2(dr.sqrt(dx * dx + ty * ty), dz)
            phi_d = dr.atan2(ty, dx)
            phi_d = dr.select(phi_d < 0, phi_d + pi, phi_d)
            i_h = dr.sqrt(dr.maximum(theta_h, 0) / (pi / 2) * (_N_TH * _N_TH))
            i_h = dr.clip(mi.Int32(dr.floor(i_h)), 0, _N_TH - 1)
            i_d = dr.clip(mi.Int32(dr.floor(theta_d / (pi / 2) * _N_TD)), 0, _N_TD - 1)
            i_p = dr.clip(mi.Int32(dr.floor(phi_d / pi * _N_PD)), 0, _N_PD - 1)
            ind = i_p + _N_PD * i_d + _N_PD * _N_TD * i_h
            if scalar:
                if not active:
                    return mi.Color3f(0.0)
                t = self._table
                return mi.Color3f(float(t[0, ind]), float(t[1, ind]), float(t[2, ind]))
            idx = mi.UInt32(ind)
            return mi.Color3f(*(dr.gather(mi.Float, t, idx, active) for t in self._table))

        def _eval(self, wi, wo, active):
            cos_i = mi.Frame3f.cos_theta(wi)
            cos_o = mi.Frame3f.cos_theta(wo)
            active = active & (cos_i > 0) & (cos_o > 0)
            value = self._lookup(wo, wi, active) * cos_o
            return dr.select(active, value, 0.0)

        def _pdf(self, wi, wo, active, value=None):
            cos_i = mi.Frame3f.cos_theta(wi)
            cos_o = mi.Frame3f.cos_theta(wo)
            active = active & (cos_i > 0) & (cos_o > 0)
            # Where the BSDF is 0 (an unfilled bin, a zero bin) the density is 0 too:
            # a sample landing there is a failed sample (weight 0) for Mitsuba, so the
            # density of the samples that count excludes those directions.
            if value is None:
                value = self._eval(wi, wo, active)
            active = active & dr.any(value > 0)
            m = dr.normalize(wi + wo)
            p_lobe = self._distr.pdf(wi, m) / (4.0 * dr.abs_dot(wo, m))
            p_cos = mi.warp.square_to_cosine_hemisphere_pdf(wo)
            w = self.lobe_weight
            p = w * p_lobe + (1.0 - w) * p_cos
            return dr.select(active & dr.isfinite(p), p, 0.0)

        def eval(self, ctx, si, wo, active=True):
            return self._eval(si.wi, wo, active)

        def pdf(self, ctx, si, wo, active=True):
            return self._pdf(si.wi, wo, active)

        def eval_pdf(self, ctx, si, wo, active=True):
            value = self._eval(si.wi, wo, active)
            return value, self._pdf(si.wi, wo, active, value)

        def sample(self, ctx, si, sample1, sample2, active=True):
            wi = si.wi
            active = active & (mi.Frame3f.cos_theta(wi) > 0)
            lobe = sample1 < self.lobe_weight
            m, _ = self._distr.sample(wi, sample2)
            wo = dr.select(lobe, mi.reflect(wi, m),
                           mi.warp.square_to_cosine_hemisphere(sample2))
            value = self._eval(wi, wo, active)
            pdf = self._pdf(wi, wo, active, value)
            bs = dr.zeros(mi.BSDFSample3f)
            bs.wo = wo
            bs.pdf = pdf
            bs.eta = 1.0
            bs.sampled_type = dr.select(lobe, mi.UInt32(+mi.BSDFFlags.GlossyReflection),
                                        mi.UInt32(+mi.BSDFFlags.DiffuseReflection))
            bs.sampled_component = dr.select(lobe, mi.UInt32(0), mi.UInt32(1))
            ok = active & (pdf > 0)
            return bs, dr.select(ok, value / dr.select(ok, pdf, 1.0), 0.0)

        def to_string(self):
            return (f"FlakescatterBSDF[filename={self.filename!r}, "
                    f"alpha={self.alpha:.4g}, lobe_weight={self.lobe_weight:.3g}]")

    return FlakescatterBSDF


def register() -> None:
    """Register the ``"flakescatter"`` BSDF plugin for the active Mitsuba variant.

    Call after ``mitsuba.set_variant(...)`` (an RGB variant: ``scalar_rgb``,
    ``llvm_ad_rgb``, ...) and again after switching variants; registering twice is
    harmless. Raises :class:`ImportError` (with the install hint) without Mitsuba.
    """
    mi, dr = _mitsuba()
    _rgb_variant(mi)
    cls = _make_plugin_class(mi, dr)
    mi.register_bsdf(PLUGIN_NAME, lambda props: cls(props))


def load_bsdf(filename):
    """The plugin for ``filename`` as a ``mitsuba.BSDF`` of the active variant (after
    :func:`register`), with the project's errors unwrapped: a missing file raises
    :class:`flakescatter.FileError`, a malformed one
    :class:`flakescatter.FileFormatError`, both naming the file. (Through
    ``mitsuba.load_dict`` the same errors arrive wrapped in Mitsuba's ``RuntimeError``,
    their text kept.)"""
    mi, _ = _mitsuba()
    filename = os.fspath(filename)
    _load_table(filename)
    register()
    return mi.load_dict({"type": PLUGIN_NAME, "filename": filename})


# --------------------------------------------------------------------------- previews


def _choose_variant(mi, variant: Optional[str]) -> str:
    """``variant`` if given, else the active RGB variant, else llvm_ad_rgb / scalar_rgb."""
    if variant is not None and not str(variant).endswith("_rgb"):
        raise ValueError(f"variant: the plugin works in RGB variants (e.g. scalar_rgb, "
                         f"llvm_ad_rgb), not {variant!r}")
    if variant is None:
        try:
            current = mi.variant()
        except Exception:
            current = None
        if current is not None and current.endswith("_rgb"):
            return current
        available = mi.variants()
        variant = "llvm_ad_rgb" if "llvm_ad_rgb" in available else "scalar_rgb"
    if mi.variant() != variant:
        mi.set_variant(variant)
    return variant


def _panel_mesh(mi, bsdf):
    """A curved panel: the square [-1, 1]² (as seen along z) cut from a sphere of radius
    2.5 whose top is at the origin, bulging towards the camera (+z); its normals lean
    up to 34° from +z at the corners (23.6° at the edges' midpoints)."""
    n, r = 33, 2.5
    x, y = np.meshgrid(np.linspace(-1.0, 1.0, n), np.linspace(-1.0, 1.0, n), indexing="ij")
    z = np.sqrt(r * r - x * x - y * y)
    pos = np.stack([x, y, z - r], axis=-1).reshape(-1, 3)
    nrm = (np.stack([x, y, z], axis=-1) / r).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij")
    v00, v01 = (i * n + j).ravel(), (i * n + j + 1).ravel()
    v10, v11 = v00 + n, v01 + n
    faces = np.concatenate([np.stack([v00, v10, v11], -1), np.stack([v00, v11, v01], -1)])
    props = mi.Properties()
    props["bsdf"] = bsdf
    mesh = mi.Mesh("panel", len(pos), len(faces), props=props, has_vertex_normals=True)
    params = mi.traverse(mesh)
    for key, data in (("vertex_positions", pos), ("vertex_normals", nrm), ("faces", faces)):
        params[key] = type(params[key])(data.ravel().tolist())
    params.update()
    return mesh


def _rgb_argument(name: str, value) -> list:
    """Three finite non-negative numbers (an RGB triple), or a ValueError naming ``name``."""
    v = np.asarray(value, dtype=np.float64).reshape(-1)
    if v.shape != (3,) or not np.all(np.isfinite(v)) or np.any(v < 0):
        raise ValueError(f"{name}: expected 3 finite non-negative numbers (R, G, B), "
                         f"got {value!r}")
    return [float(x) for x in v]


def _tonemap(linear: np.ndarray, exposure: float, white: float) -> np.ndarray:
    """Exposure, extended Reinhard per channel (x ≥ white → 1), sRGB encoding, 8 bits."""
    x = np.maximum(linear * exposure, 0.0)
    y = np.minimum(x * (1.0 + x / (white * white)) / (1.0 + x), 1.0)
    srgb = np.where(y <= 0.0031308, 12.92 * y, 1.055 * np.power(y, 1.0 / 2.4) - 0.055)
    return np.clip(np.rint(srgb * 255.0), 0, 255).astype(np.uint8)


def render_preview(
    brdf_file,
    out_png,
    *,
    shape: str = "sphere",
    resolution: int = 256,
    spp: int = 64,
    variant: Optional[str] = None,
    sun_direction: Sequence[float] = SUN_DIRECTION,
    sun_irradiance: Sequence[float] = SUN_IRRADIANCE,
    sky_radiance: Sequence[float] = SKY_RADIANCE,
    exposure: Optional[float] = None,
    white: float = 8.0,
    seed: int = 0,
) -> Dict[str, Any]:
    """Render a sphere (or a curved panel) painted with the MERL table ``brdf_file`` and
    write a tone-mapped PNG to ``out_png``.

    Scene (world coordinates, +y up): the object at the origin — ``shape="sphere"``, a
    unit sphere; ``shape="panel"``, a gently domed square panel, [-1, 1]² as seen by the
    camera, cut from a sphere of radius 2.5 (normals up to 34° from the viewing axis at
    the corners) — seen by a perspective camera on the
    +z axis at distance 4.5 (field of view 30°, the object nearly fills the frame),
    ``resolution`` × ``resolution`` pixels, ``spp`` samples per pixel, Gaussian pixel
    filter, Mitsuba's path tracer (``max_depth`` 3).

    Light (relative units, RGB):

    * the sun: a directional emitter of irradiance ``sun_irradiance`` (on a plane
      normal to the beam, default 1) arriving from ``sun_direction`` (the direction
      towards the sun; default (−0.5, 0.5, √½), 45° from the viewing axis, up and to the
      left in the image), so that the highlight is where the normal is about 22.5° from
      the viewing axis;
    * the sky: a constant emitter of radiance ``sky_radiance`` (default 0.05) from every
      direction (a uniform grey surround, no ground): it lights any plane with π × 0.05
      ≈ 0.157, about 1/6 of the sun.

    Tone map, per channel: the linear radiance is multiplied by ``exposure`` (default
    1 / L_white, L_white = cos θ × E_sun / π + L_sky the radiance of a white Lambertian
    disc facing the camera under this light, θ the sun's angle from the viewing axis,
    45° by default; from the first channel of each),
    then mapped by the extended Reinhard curve ``y = x (1 + x / white²) / (1 + x)``
    (``white`` = 8: eight times a white diffuser is displayed white, the highlight
    keeps its shape instead of clipping), clamped to 1, sRGB-encoded and written as an
    8-bit RGB PNG with Mitsuba's bitmap writer.

    ``variant`` is the Mitsuba variant to render with; by default the active RGB
    variant, else ``llvm_ad_rgb`` when available, else ``scalar_rgb`` (this call may
    change the active variant, and registers the plugin for it).

    Returns a dict: ``"png"`` (the path written), ``"image"`` (the linear RGB radiance,
    float32, shape (resolution, resolution, 3), rows top to bottom), ``"exposure"``,
    ``"variant"``, ``"light"`` (the sun direction, sun irradiance and sky radiance
    used). Raises :class:`flakescatter.FileError` / :class:`flakescatter.FileFormatError`
    for a missing or malformed ``brdf_file``, :class:`ValueError` for a bad argument.
    """
    mi, dr = _mitsuba()
    if shape not in ("sphere", "panel"):
        raise ValueError(f"shape: expected 'sphere' or 'panel', got {shape!r}")
    if int(resolution) < 1 or int(spp) < 1:
        raise ValueError(f"resolution and spp must be at least 1 (got {resolution}, {spp})")
    sun = np.asarray(sun_direction, dtype=np.float64)
    if sun.shape != (3,) or not np.all(np.isfinite(sun)) or np.linalg.norm(sun) == 0:
        raise ValueError(f"sun_direction: expected 3 finite numbers, not all 0, "
                         f"got {sun_direction!r}")
    sun = sun / np.linalg.norm(sun)
    brdf_file = os.fspath(brdf_file)
    _load_table(brdf_file)  # the project's error for a missing or malformed file, unwrapped

    e_sun = _rgb_argument("sun_irradiance", sun_irradiance)
    l_sky = _rgb_argument("sky_radiance", sky_radiance)
    if exposure is None:
        l_white = max(float(sun[2]), 0.0) * e_sun[0] / math.pi + l_sky[0]
        exposure = 1.0 / l_white if l_white > 0 else 1.0
    elif not (math.isfinite(exposure) and exposure > 0):
        raise ValueError(f"exposure: expected a positive number, got {exposure!r}")
    out_png = os.fspath(out_png)
    folder = os.path.dirname(os.path.abspath(out_png))
    if not os.path.isdir(folder):
        from . import FileError

        raise FileError(f"{out_png}: cannot write the preview: the folder {folder} "
                        f"does not exist")
    variant = _choose_variant(mi, variant)
    bsdf = load_bsdf(brdf_file)
    if shape == "sphere":
        obj = {"type": "sphere", "bsdf": bsdf}
    else:
        obj = _panel_mesh(mi, bsdf)
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 3},
        "sensor": {
            "type": "perspective",
            "fov": 30.0,
            "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 4.5], target=[0, 0, 0],
                                                        up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": int(resolution), "height": int(resolution),
                     "pixel_format": "rgb", "rfilter": {"type": "gaussian"}},
            "sampler": {"type": "independent", "sample_count": int(spp), "seed": int(seed)},
        },
        "sun": {"type": "directional", "direction": (-sun).tolist(),
                "irradiance": {"type": "rgb", "value": e_sun}},
        "sky": {"type": "constant", "radiance": {"type": "rgb", "value": l_sky}},
        "object": obj,
    })
    image = np.array(mi.render(scene, seed=int(seed)), dtype=np.float32)[..., :3]
    bitmap = mi.Bitmap(_tonemap(image, exposure, white), mi.Bitmap.PixelFormat.RGB)
    bitmap.write(out_png, mi.Bitmap.FileFormat.PNG)
    return {
        "png": out_png,
        "image": image,
        "exposure": float(exposure),
        "variant": variant,
        "light": {"sun_direction": tuple(sun.tolist()), "sun_irradiance": tuple(e_sun),
                  "sky_radiance": tuple(l_sky)},
    }


def montage(pngs: Sequence[Any], out_png, *, gap: int = 8) -> str:
    """Put preview PNGs of one height side by side, left to right in the order given,
    separated by ``gap`` white pixels, and write the result to ``out_png`` (8-bit RGB).
    Used for samples compared in one report (``flakescatter analyze``). Raises
    :class:`ValueError` for no images or images of different heights."""
    mi, _ = _mitsuba()
    if not pngs:
        raise ValueError("montage: no images")
    images = []
    for p in pngs:
        a = np.array(mi.Bitmap(os.fspath(p)).convert(
            mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, srgb_gamma=True))
        images.append(a[..., :3])
    h = images[0].shape[0]
    if any(a.shape[0] != h for a in images):
        raise ValueError("montage: the images are of different heights: "
                         + ", ".join(str(a.shape[0]) for a in images))
    parts = []
    for k, a in enumerate(images):
        if k:
            parts.append(np.full((h, gap, 3), 255, dtype=np.uint8))
        parts.append(a.astype(np.uint8))
    out = np.ascontiguousarray(np.concatenate(parts, axis=1))
    mi.Bitmap(out, mi.Bitmap.PixelFormat.RGB).write(os.fspath(out_png),
                                                    mi.Bitmap.FileFormat.PNG)
    return os.fspath(out_png)


def main(argv: Optional[Sequence[str]] = None) -> int:
    """``python -m flakescatter.mitsuba check | preview BRDF.binary OUT.png [--shape S]
    [--resolution N] [--spp N] [--seed N] | montage OUT.png IN.png...``: the previews
    from the command line (``flakescatter analyze`` runs them). ``check`` exits 0 when
    Mitsuba can render here and prints the variant it would use; errors go to stderr
    with exit status 2."""
    import argparse
    import json
    import sys

    parser = argparse.ArgumentParser(prog="python -m flakescatter.mitsuba")
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("check", help="exit 0 when Mitsuba can render here")
    p = sub.add_parser("preview", help="render a MERL table's preview to a PNG")
    p.add_argument("brdf")
    p.add_argument("out")
    p.add_argument("--shape", default="sphere", choices=("sphere", "panel"))
    p.add_argument("--resolution", type=int, default=256)
    p.add_argument("--spp", type=int, default=64)
    p.add_argument("--seed", type=int, default=0)
    m = sub.add_parser("montage", help="PNGs of one height side by side")
    m.add_argument("out")
    m.add_argument("images", nargs="+")
    args = parser.parse_args(argv)
    try:
        if args.command == "check":
            mi, _ = _mitsuba()
            print(json.dumps({"mitsuba": mi.__version__,
                              "variant": _choose_variant(mi, None)}))
        elif args.command == "preview":
            r = render_preview(args.brdf, args.out, shape=args.shape,
                               resolution=args.resolution, spp=args.spp, seed=args.seed)
            print(json.dumps({"png": r["png"], "variant": r["variant"],
                              "exposure": r["exposure"], "light": r["light"]}))
        else:
            print(json.dumps({"png": montage(args.images, args.out)}))
    except (ImportError, ValueError, OSError, RuntimeError) as e:
        print(f"{type(e).__name__}: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

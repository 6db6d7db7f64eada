"""`flakescatter analyze` renders each report's preview through this package's
`flakescatter.mitsuba` (the CLI runs `$FLAKESCATTER_PYTHON -m flakescatter.mitsuba`):
two samples of the shipped synthetic maps, one of flakes with a hwhm of 3 degrees and
one of 6 degrees (fixtures/README.md: how they were drawn), each get a sphere whose
highlight is larger for the wider distribution, the batch report puts them side by side,
and a rerun takes both from the report's cache. Needs Mitsuba (the render extra)."""

import json
import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

try:  # the optional extra
    import mitsuba as mi
except ImportError:  # pragma: no cover - CI installs it
    mi = None

REQUIRE = os.environ.get("FLAKESCATTER_REQUIRE_MITSUBA") == "1"
needs_mitsuba = pytest.mark.skipif(
    mi is None and not REQUIRE,
    reason="mitsuba is not installed (pip install flakescatter[render])",
)
ROOT = pathlib.Path(__file__).resolve().parents[3]


def manifest(path, name, stem):
    maps = ROOT / "fixtures" / f"{stem}.height.x3p"
    path.write_text(
        f'name = "{name}"\n[maps]\nfiles = ["{maps.as_posix()}"]\n'
        'intensity_suffix = ".intensity"\ncutoff = 0.49\n'
        "[coating]\nn = 1.5\n[models]\nfit = false\n"
    )
    return path


def luminance(png):
    a = np.array(mi.Bitmap(str(png)).convert(
        mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, srgb_gamma=False))
    return a[..., :3].mean(axis=2)


def highlight_pixels(png):
    lum = luminance(png)
    return int((lum > 0.5 * lum.max()).sum())


@needs_mitsuba
def test_analyze_renders_previews_side_by_side_and_reuses_them(tmp_path, cli_bin):
    assert mi is not None, "FLAKESCATTER_REQUIRE_MITSUBA=1 but mitsuba is not importable"
    a = manifest(tmp_path / "a.toml", "smooth3", "synth-hwhm3-smooth")
    b = manifest(tmp_path / "b.toml", "rough6", "synth-hwhm6-rough")
    out = tmp_path / "report"
    env = dict(os.environ, FLAKESCATTER_PYTHON=sys.executable)
    run = lambda: subprocess.run(  # noqa: E731
        [str(cli_bin), "analyze", str(a), str(b), "--out", str(out)],
        env=env, capture_output=True, text=True)
    r = run()
    assert r.returncode == 0, r.stderr
    for name in ("smooth3", "rough6"):
        png = out / name / "preview.png"
        assert png.exists(), (name, r.stderr)
        assert luminance(png).shape == (192, 192)
        assert "(preview.png)" in (out / name / "index.md").read_text()
    # The wider distribution spreads the sun's highlight over more of the sphere.
    small = highlight_pixels(out / "smooth3" / "preview.png")
    large = highlight_pixels(out / "rough6" / "preview.png")
    assert large > 1.5 * small, (small, large)
    summary = json.loads((out / "rough6" / "summary.json").read_text())
    assert summary["preview"]["png"] == "preview.png"
    assert "preview.png" in summary["files"] and "cache/preview.json" in summary["files"]
    side = luminance(out / "previews.png")
    assert side.shape == (192, 2 * 192 + 8)
    assert "Left to right: smooth3, rough6" in (out / "index.md").read_text()
    # A rerun renders nothing: the same bytes, from the report's cache.
    before = (out / "rough6" / "preview.png").read_bytes()
    key = (out / "rough6" / "cache" / "preview.json").read_text()
    r = run()
    assert r.returncode == 0, r.stderr
    assert (out / "rough6" / "preview.png").read_bytes() == before
    assert (out / "rough6" / "cache" / "preview.json").read_text() == key


def test_analyze_without_a_renderer_says_why(tmp_path, cli_bin):
    a = manifest(tmp_path / "a.toml", "smooth3", "synth-hwhm3-smooth")
    out = tmp_path / "report"
    env = dict(os.environ, FLAKESCATTER_PYTHON=str(tmp_path / "no-such-python"))
    r = subprocess.run([str(cli_bin), "analyze", str(a), "--out", str(out)],
                       env=env, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    md = (out / "index.md").read_text()
    assert "No preview: rendering needs the Python package with Mitsuba 3" in md
    assert "no-such-python cannot be run" in md
    assert not (out / "preview.png").exists()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["preview"]["png"] is None
    assert "no-such-python cannot be run" in summary["preview"]["note"]
    r = subprocess.run([str(cli_bin), "analyze", str(a), "--out", str(out), "--no-preview"],
                       env=env, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "Preview" not in (out / "index.md").read_text()

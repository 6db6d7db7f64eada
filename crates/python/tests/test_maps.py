"""read_map / write_map / Map: against the CLI's `info --json` and independent readers
(Python's zipfile + numpy for X3P, numpy.loadtxt for the text format)."""

import errno
import xml.etree.ElementTree as ET
import zipfile

import numpy as np
import pytest

import flakescatter as fs
from conftest import CUTOFF, FIXTURES, HEIGHT, INTENSITY

FIXTURES_REAL = FIXTURES / "real"


def x3p_heights_um(path):
    """Heights (µm) of an X3P with float64 Z data, decoded by hand from the archive
    (ISO 25178-72: value = Offset + raw × Increment, metres; NaN marks invalid points)."""
    with zipfile.ZipFile(path) as z:
        root = ET.fromstring(z.read("main.xml"))
        cz = root.find("Record1/Axes/CZ")
        assert cz.findtext("DataType") == "D"
        inc = float(cz.findtext("Increment"))
        off = float(cz.findtext("Offset"))
        nx = int(root.findtext("Record3/MatrixDimension/SizeX"))
        ny = int(root.findtext("Record3/MatrixDimension/SizeY"))
        link = root.findtext("Record3/DataLink/PointDataLink")
        raw = np.frombuffer(z.read(link), dtype="<f8").reshape(ny, nx)
    return (off + raw * inc) * 1e6


def test_read_map_shapes_dtypes_and_cli_info(cli):
    m = fs.read_map(HEIGHT)
    info = cli.json("info", HEIGHT)
    assert isinstance(m, fs.Map)
    assert m.heights_um.shape == (info["ny"], info["nx"]) == m.shape
    assert m.heights_um.dtype == np.float64 and m.heights_um.ndim == 2
    assert m.valid.dtype == np.bool_ and m.valid.shape == m.shape
    assert (m.nx, m.ny) == (info["nx"], info["ny"])
    dx, dy = m.pitch_um
    assert (dx * 1e-6, dy * 1e-6) == (info["dx_m"], info["dy_m"])
    assert m.format == info["format"] == "x3p"
    assert m.metadata == info["metadata"]
    assert m.valid_count == int(m.valid.sum()) == info["valid_points"]
    z = m.heights_um[m.valid]
    assert np.isnan(m.heights_um[~m.valid]).all()
    assert z.min() * 1e-6 == info["min_m"] and z.max() * 1e-6 == info["max_m"]
    # numpy's summation is a second implementation: agreement to rounding.
    assert z.mean() * 1e-6 == pytest.approx(info["mean_m"], rel=1e-12)
    assert z.std() * 1e-6 == pytest.approx(info["rms_m"], rel=1e-12)


def test_read_map_matches_hand_decoded_x3p():
    m = fs.read_map(HEIGHT)
    want = x3p_heights_um(HEIGHT)
    np.testing.assert_allclose(m.heights_um, want, rtol=1e-13, atol=0)


def test_intensity_cutoff_as_cli(cli):
    m = fs.read_map(HEIGHT, intensity=INTENSITY, cutoff=CUTOFF)
    info = cli.json("info", HEIGHT, "--intensity", INTENSITY, "--cutoff", CUTOFF)
    assert m.valid_count == info["valid_points"]
    full = fs.read_map(HEIGHT)
    assert info["valid_points_before_cutoff"] == full.valid_count
    # The mask is the height mask and the intensity threshold, computed here by hand.
    # An X3P intensity image stores its values in its Z axis (Z increment 1).
    intensity = x3p_heights_um(INTENSITY) / 1e6
    kept = full.valid & (intensity >= CUTOFF)
    assert intensity.shape == full.shape
    np.testing.assert_array_equal(m.valid, kept)


def test_an_intensity_image_is_not_read_as_heights(tmp_path, cli):
    # The file says it holds intensities (its X3P comment): read_map, which returns
    # heights, refuses it as the CLI does (issue 52, item 5).
    with pytest.raises(fs.FileFormatError) as e:
        fs.read_map(INTENSITY)
    assert "holds intensities" in str(e.value)
    assert "holds intensities" in cli.fails("stats", "--map", INTENSITY)
    # A map given as its own intensity image (item 6), by its path or through a link.
    link = tmp_path / "link.x3p"
    link.symlink_to(HEIGHT)
    copy = tmp_path / "copy.x3p"
    copy.write_bytes(HEIGHT.read_bytes())
    for other in (HEIGHT, link, copy):
        with pytest.raises(fs.InputError) as e:
            fs.read_map(HEIGHT, intensity=other, cutoff=CUTOFF)
        assert "height map file" in str(e.value)


def test_write_map_round_trips_and_is_read_by_others(tmp_path, cli):
    m = fs.read_map(HEIGHT, intensity=INTENSITY, cutoff=CUTOFF)
    x3p, txt = tmp_path / "out.x3p", tmp_path / "out.txt"
    fs.write_map(m, x3p)
    fs.write_map(m, str(txt))
    for p in (x3p, txt):
        back = fs.read_map(p)
        np.testing.assert_array_equal(back.valid, m.valid)
        np.testing.assert_array_equal(back.heights_um, m.heights_um)
        assert back.pitch_um == m.pitch_um
        assert cli.json("info", p)["valid_points"] == m.valid_count
    # SDF (ISO 25178-71 text): read back exactly, and parsed here by hand — header
    # lines `key = value` up to `*`, then one profile per line in metres (Zscale 1e-6
    # applies to µm values), `BAD` for invalid points.
    sdf = tmp_path / "out.sdf"
    fs.write_map(m, sdf)
    back = fs.read_map(sdf)
    np.testing.assert_array_equal(back.valid, m.valid)
    np.testing.assert_array_equal(back.heights_um[m.valid], m.heights_um[m.valid])
    lines = sdf.read_text().splitlines()
    star = lines.index("*")
    header = dict(l.split("=", 1) for l in lines[1:star])
    header = {k.strip(): v.strip() for k, v in header.items()}
    assert lines[0] == "aISO-1.0"
    assert (int(header["NumPoints"]), int(header["NumProfiles"])) == (m.nx, m.ny)
    rows = [[np.nan if t == "BAD" else float(t) for t in l.split()] for l in lines[star + 1:] if l.strip() and l != "*"]
    z = np.array(rows) * float(header["Zscale"]) * 1e6
    np.testing.assert_allclose(z[m.valid], m.heights_um[m.valid], rtol=1e-15)
    assert np.isnan(z[~m.valid]).all()
    # The text format read by numpy: µm, NaN for invalid points, '#' header lines.
    np.testing.assert_array_equal(np.loadtxt(txt, comments="#"), m.heights_um)
    # The X3P decoded by hand: heights in metres, NaN where invalid.
    np.testing.assert_allclose(x3p_heights_um(x3p), m.heights_um, rtol=1e-15, equal_nan=True)


def test_write_map_stores_noise_and_deflates_structure(tmp_path):
    # Heights with 52 random mantissa bits cannot be deflated (at level 1) to 90 % of
    # their size, so the writer stores data.bin; a map of 16 repeated levels is
    # deflated. Python's zipfile says which, and numpy decodes the heights by hand.
    rng = np.random.default_rng(7)
    noise = rng.random((300, 400)) - 0.5
    levels = (np.arange(300 * 400).reshape(300, 400) // 4096 % 16) * 0.25
    for z, method in ((noise, zipfile.ZIP_STORED), (levels, zipfile.ZIP_DEFLATED)):
        path = tmp_path / "written.x3p"
        fs.write_map(fs.Map(z, 0.5), path)
        with zipfile.ZipFile(path) as archive:
            info = archive.getinfo("bindata/data.bin")
        assert info.compress_type == method
        assert info.file_size == z.size * 8
        if method == zipfile.ZIP_STORED:
            assert info.compress_size == info.file_size
        else:
            assert info.compress_size * 10 < info.file_size
        np.testing.assert_allclose(x3p_heights_um(path), z, rtol=1e-15, atol=0)
        np.testing.assert_array_equal(fs.read_map(path).heights_um, z)


def test_map_from_numpy():
    z = np.arange(12, dtype=float).reshape(3, 4)
    z[1, 2] = np.nan
    valid = np.ones((3, 4), bool)
    valid[0, 0] = False
    m = fs.Map(z, (0.5, 0.25), valid)
    assert m.shape == (3, 4) and (m.nx, m.ny) == (4, 3) and m.pitch_um == (0.5, 0.25)
    assert m.valid_count == 10 and m.format is None
    assert not m.valid[0, 0] and not m.valid[1, 2]
    assert np.isnan(m.heights_um[0, 0]) and m.heights_um[2, 3] == 11.0
    assert fs.Map(np.zeros((2, 2), np.int32), 1.0).pitch_um == (1.0, 1.0)


def test_missing_file_is_file_error_with_the_cli_message(cli, tmp_path):
    path = tmp_path / "nope.x3p"
    with pytest.raises(fs.FileError) as e:
        fs.read_map(path)
    assert isinstance(e.value, OSError) and isinstance(e.value, fs.Error)
    assert e.value.errno == errno.ENOENT
    assert str(e.value) in cli.fails("info", path)


def test_bad_content_is_file_format_error_with_the_cli_message(cli, tmp_path):
    path = tmp_path / "bad.txt"
    path.write_text("1 2 3\n4 five 6\n")
    with pytest.raises(fs.FileFormatError) as e:
        fs.read_map(path, pixel_um=1.0, z_unit="um")
    assert isinstance(e.value, ValueError)
    assert str(e.value) in cli.fails("info", path, "--pixel-um", "1", "--z-unit", "um")
    broken = tmp_path / "broken.x3p"
    broken.write_bytes(HEIGHT.read_bytes()[:5000])
    with pytest.raises(fs.FileFormatError) as e:
        fs.read_map(broken)
    assert str(e.value) in cli.fails("info", broken)


PLU = FIXTURES_REAL / "instruments" / "plu-1.plu"


def test_intensity_channel_of_the_same_file_as_cli(cli):
    # plu-1.plu: a grey image after the heights. Gwyddion 2.62 and surfalize 0.19.2
    # count 212266 of its 442368 grey levels below 170 (fixtures/real/instruments/
    # expected-channels.txt), and every height is valid: 230102 points stay.
    m = fs.read_map(PLU, intensity_channel="Image0", cutoff=170)
    info = cli.json("info", PLU, "--intensity-channel", "Image0", "--cutoff", 170)
    assert m.valid_count == info["valid_points"] == 442368 - 212266
    assert info["intensity_channel"] == 1 and info["channel"] == 0
    assert fs.read_map(PLU, channel="layer0").valid_count == 442368
    with pytest.raises(fs.InputError) as e:
        fs.read_map(PLU, channel="phase")
    assert "1 = image0 (a.u., 768 x 576)" in str(e.value)
    assert str(e.value) in cli.fails("info", PLU, "--channel", "phase")
    with pytest.raises(fs.InputError):
        fs.read_map(PLU, intensity=PLU, intensity_channel=1, cutoff=1.0)
    with pytest.raises(fs.InputError):
        fs.read_map(PLU, intensity_channel=1)


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(cutoff=0.5),
        dict(intensity=INTENSITY),
        dict(intensity=INTENSITY, cutoff=float("nan")),
        dict(channel=1),
        dict(channel=""),
        dict(channel=-1),
        dict(pixel_um=-1.0),
        dict(z_unit="furlong"),
    ],
)
def test_bad_read_parameters_are_input_errors(kwargs):
    with pytest.raises(fs.InputError):
        fs.read_map(HEIGHT, **kwargs)


@pytest.mark.parametrize(
    "args",
    [
        (np.zeros(5), 1.0),
        (np.zeros((2, 2)), 0.0),
        (np.zeros((2, 2)), (1.0, float("inf"))),
        (np.zeros((0, 3)), 1.0),
        (np.zeros((2, 2)), 1.0, np.ones((3, 2), bool)),
        ([["a", "b"]], 1.0),
    ],
)
def test_bad_maps_are_input_errors(args):
    with pytest.raises(fs.InputError):
        fs.Map(*args)


def test_write_map_errors(tmp_path):
    m = fs.read_map(HEIGHT)
    with pytest.raises(fs.InputError):
        fs.write_map(m, tmp_path / "x.png")
    with pytest.raises(fs.InputError):
        fs.write_map(m, tmp_path / "x.bin", format="png")
    with pytest.raises(fs.FileError):
        fs.write_map(m, tmp_path / "no" / "such" / "dir.x3p")


def test_panic_becomes_internal_error():
    with pytest.raises(fs.InternalError) as e:
        fs._flakescatter._panic_for_test()
    assert isinstance(e.value, fs.Error) and "deliberate panic" in str(e.value)

#!/usr/bin/env python3
"""Builds the seed corpora of the fuzz targets (fuzz/corpus/<target>/, not committed)
from files in the repository: the real files in fixtures/real (those under 16 KiB, so
that libFuzzer runs fast; csafe-logo.x3p is 29 KiB but inflates to 2.4 MiB per run), their X3P archives re-packed with stored members (so that
mutations reach main.xml and data.bin, not only the deflate stream), small hand-made
inputs for what the real files do not show (binary SDF, decimal commas, CRLF, valid.bin),
and heads of the committed CSV outputs for the table readers.

Map targets take one options byte first (fuzz_targets/options.rs) and the dispatcher
one extension byte after it; seeds are written with a few values of each.

Usage: python3 fuzz/seeds.py   (from the repository root; standard library only)
"""
import hashlib, io, os, struct, zipfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OUT = os.path.join(ROOT, "fuzz", "corpus")
REAL = os.path.join(ROOT, "fixtures", "real")


def write(target, data):
    d = os.path.join(OUT, target)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, hashlib.sha1(data).hexdigest()), "wb") as f:
        f.write(data)


def stored(zbytes):
    src = zipfile.ZipFile(io.BytesIO(zbytes))
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", zipfile.ZIP_STORED) as dst:
        for info in src.infolist():
            if not info.is_dir():
                dst.writestr(info.filename, src.read(info.filename))
    return out.getvalue()


def x3p(nx, ny, dtype, values, valid=None, z_inc="1e-6"):
    fmt = {"I": "<h", "L": "<i", "F": "<f", "D": "<d"}[dtype]
    data = b"".join(struct.pack(fmt, v) for v in values)
    link = ""
    if valid is not None:
        link = "<ValidPointsLink>bindata/valid.bin</ValidPointsLink>"
    xml = f"""<?xml version="1.0" encoding="UTF-8"?>
<p:ISO5436_2 xmlns:p="http://www.opengps.eu/2008/ISO5436_2"><Record1><Revision>ISO5436 - 2000</Revision><FeatureType>SUR</FeatureType><Axes>
<CX><AxisType>I</AxisType><DataType>D</DataType><Increment>0.5e-6</Increment><Offset>0</Offset></CX>
<CY><AxisType>I</AxisType><DataType>D</DataType><Increment>1e-6</Increment><Offset>0</Offset></CY>
<CZ><AxisType>A</AxisType><DataType>{dtype}</DataType><Increment>{z_inc}</Increment><Offset>0</Offset></CZ></Axes></Record1>
<Record2><Date>2024-01-01T00:00:00</Date><Creator>seed</Creator></Record2>
<Record3><MatrixDimension><SizeX>{nx}</SizeX><SizeY>{ny}</SizeY><SizeZ>1</SizeZ></MatrixDimension>
<DataLink><PointDataLink>bindata/data.bin</PointDataLink><MD5ChecksumPointData>{hashlib.md5(data).hexdigest()}</MD5ChecksumPointData>{link}</DataLink></Record3>
<Record4><ChecksumFile>md5checksum.hex</ChecksumFile></Record4></p:ISO5436_2>
""".encode()
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", zipfile.ZIP_STORED) as z:
        z.writestr("main.xml", xml)
        z.writestr("md5checksum.hex", hashlib.md5(xml).hexdigest() + " *main.xml\n")
        z.writestr("bindata/data.bin", data)
        if valid is not None:
            z.writestr("bindata/valid.bin", bytes(valid))
    return out.getvalue()


def binary_sdf(magic, nx, ny, dtype, raw):
    h = magic + b"SEEDMAKER\0" + b"010120240000" * 2 + struct.pack("<HH", nx, ny)
    h += struct.pack("<dddd", 1e-6, 1e-6, 1e-9, 1e-9) + bytes([0, dtype, 0])
    fmt = {0: "<B", 1: "<H", 2: "<I", 3: "<f", 4: "<b", 5: "<h", 6: "<i", 7: "<d"}[dtype]
    return h + b"".join(struct.pack(fmt, v) for v in raw)


def real(name):
    with open(os.path.join(REAL, name), "rb") as f:
        return f.read()


maps = {"x3p": [], "sdf": [], "text": []}
for name in sorted(os.listdir(REAL)):
    if os.path.isdir(os.path.join(REAL, name)):
        continue
    b = real(name)
    if len(b) > 16 << 10 or name.startswith("LICENSE") or name.endswith(".md") or name.startswith("."):
        continue
    if name.endswith(".x3p"):
        maps["x3p"] += [v for v in (b, stored(b)) if len(v) <= 16 << 10]
    elif name.endswith(".sdf"):
        maps["sdf"].append(b)
    else:
        maps["text"].append(b)
maps["x3p"] += [
    x3p(3, 2, "I", [-3, 7, 0, 1, 2, 3]),
    x3p(2, 2, "L", [100000, -1, 5, 6], z_inc="1e-9"),
    x3p(3, 3, "F", [1.5] * 9, valid=[0b11110101, 0b1]),
    x3p(2, 1, "D", [1.0, float("nan")]),
]
maps["sdf"] += [
    binary_sdf(b"bISO-1.0", 3, 2, 5, [-1, 0, 1, 2, 3, 4]),
    binary_sdf(b"bISO-2.0", 2, 1, 7, [1.25, float("nan")]),
    binary_sdf(b"bISO-1.0", 2, 2, 0, [0, 1, 254, 255]),
]
maps["text"] += [
    b"# Breite: 2,0 \xb5m\n# H\xf6he: 2,0 \xb5m\n# Werteinheiten: \xb5m\n1,5 2,25\n-0,5 4\n",
    b"1,5;2,25;3\r\n-0,5;4;1,5e-3;\r\n",
    b"1, 2, 3\r4, 5, 6\r",
    b"# Width: 2 um\n# Height: 1 um\n# Value units: a.u.\n0.5 NaN\n",
    b"x_um;z\n0,1;2\n0,2;3\n",
    "\ufeff# Width: 2 µm\n# Height: 1 µm\n# Value units: nm\n1000\t2000\n".encode("utf-16"),
]
OPTION_BYTES = [0x00, 0x03, 0x0a, 0x21, 0x13, 0x80, 0xc9]
for target, seeds in maps.items():
    for s in seeds:
        for o in OPTION_BYTES:
            write(target, bytes([o]) + s)
            write("map", bytes([o, 0]) + s)
        for e in range(1, 6):
            write("map", bytes([0, e]) + s)

tables = {
    "measured": [os.path.join("docs", "figures", "measured.csv")],
    "flakes": [os.path.join("fixtures", "synth-hwhm3-smooth.truth.csv")],
    "histogram": [os.path.join("docs", "figures", "fig7.csv")],
    "curves": [os.path.join("docs", "figures", "fig4.csv")],
    "detectors": [],
}
for target, files in tables.items():
    for rel in files:
        with open(os.path.join(ROOT, rel), "rb") as f:
            lines = f.read().split(b"\n")
        write(target, b"\n".join(lines[:12]) + b"\n")
        write(target, b"\r\n".join(lines[:6]) + b"\r\n")
extra = {
    "measured": [b"# m\r\ntheta_i_deg,theta_s_deg,value,uncertainty\r\n30,-30,1.5,0.01\r\n30,-20,0.5,0\r\n"],
    "flakes": [
        b"theta_x_deg,theta_y_deg,area_um2\n45,0,3\n-1.5,2,0.5\n",
        b"x1_um,z1_um,x2_um,z2_um,y1_um,zy1_um,y2_um,zy2_um\n0,5,10,6,0,1,20,1\n",
        b"id, x_um, y_um, nx, ny, nz, area_um2\na, 1.5, 2.5, 0, 3, 4, 10\nb,,, 0, 0, 1, 2\n",
    ],
    "histogram": [b"theta_lo_deg,theta_hi_deg,area_fraction,p_per_rad,p_tilde\n0,1,0.25,1,1\n1,2,0.75,1,1\n"],
    "detectors": [
        b"theta_r_deg,phi_r_deg\n30,0\n30,90\n60,-180\n",
        b"# d\r\ntheta_r_deg;phi_r_deg\r\n30;0\r\n",
    ],
    "curves": [b"theta_i_deg,theta_s_deg,phi_s_deg,aperture_deg,brdf_per_sr,reflectance,relative\n30,-30,0,1.5,0.25,,\n30,-29.5,0,1.5,0.2,1e-3,0.8\n"],
}
for target, seeds in extra.items():
    for s in seeds:
        write(target, s)
# Instrument files (fixtures/real/instruments): their first 8 KiB behind the dispatcher's
# two option bytes, so detection and the header readers of each format are reached (a
# head is a truncated file: refused with the byte offset, and mutated towards headers).
INSTRUMENTS = os.path.join(REAL, "instruments")
for name in sorted(os.listdir(INSTRUMENTS)):
    if name.split(".")[-1] in ("gwy", "plu", "dat", "opd", "sur", "al3d", "frt"):
        with open(os.path.join(INSTRUMENTS, name), "rb") as f:
            head = f.read(8190)
        write("map", bytes([0, 0]) + head)
        write("map", bytes([0x03, 0]) + head)
# Stacks: the io tests' three stack fixtures (tifffile ImageJ and OME-TIFF, a byte-built
# LSM file), each behind every voxel-size/page-order option byte.
STACKS = os.path.join(ROOT, "crates", "io", "tests", "data", "stack")
for name in sorted(os.listdir(STACKS)):
    if name.endswith((".tif", ".lsm")):
        with open(os.path.join(STACKS, name), "rb") as f:
            data = f.read()
        for o in (0x00, 0x03, 0x07, 0x0b):
            write("stack", bytes([o]) + data)
# Spectral files: the heads of the shipped tables behind each reader byte (0 optical
# constants, 1 coat index, 2 binder absorption, 3 spectra, 4 measured multi-angle).
spectral = {
    0: [os.path.join("crates", "optics", "data", "aluminium_rakic1995.csv")],
    2: [os.path.join("crates", "flakescatter", "tests", "data", "spectral", "binder_alpha.csv")],
    3: [os.path.join("crates", "flakescatter", "tests", "data", "spectral", "reference_spectra.csv")],
}
for which, files in spectral.items():
    for rel in files:
        with open(os.path.join(ROOT, rel), "rb") as f:
            lines = f.read().split(b"\n")
        write("spectral", bytes([which]) + b"\n".join(lines[:16]) + b"\n")
        write("spectral", bytes([which]) + b"\r\n".join(lines[:8]) + b"\r\n")
write("spectral", b"\x01wavelength_nm,n\n400,1.52\n700,1.50\n")
write("spectral", b"\x04theta_i_deg,aspecular_deg,L,a,b\n45,15,90.5,-0.6,-1.4\n45,45,40,-0.2,-0.9\n")
for t in sorted(os.listdir(OUT)):
    print(t, len(os.listdir(os.path.join(OUT, t))))

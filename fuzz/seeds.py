#!/usr/bin/env python3
"""Builds the seed corpora of the fuzz targets (fuzz/corpus/<target>/, not committed)
from files in the repository: the real files in fixtures/real (those under 16 KiB, so
that libFuzzer runs fast; csafe-logo.x3p is 29 KiB but inflates to 2.4 MiB per run), their X3P archives re-packed with stored members (so that
mutations reach main.xml and data.bin, not only the deflate stream), small hand-made
inputs for what the real files do not show (binary SDF, decimal commas, CRLF, valid.bin),
heads of the committed CSV outputs for the table readers, and for the instrument readers
(the dispatcher and one target per format) the first 8 KiB of each real instrument file
plus small valid files shrunk from them (see the instrument section below).

Set FLAKESCATTER_SEEDS_SMALL=DIR to also write the small instrument files into DIR with
their extensions, to check that each reads (`flakescatter info DIR/plu-0.plu`).

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
    "brdf": [
        os.path.join("fixtures", "real", "paints", "gold-metallic-paint2.csv"),
        os.path.join("fixtures", "real", "paints", "ilm_l3_37_metallic_rgb.csv"),
    ],
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
    "brdf": [
        b"theta_i_deg,theta_r_deg,phi_r_deg,brdf_550nm_per_sr,brdf_550nm_per_sr_uncertainty,note\n30,0,0,1.5,0.1,a\n30,10,180,0.5,0.02,b\n30,20,45,0.25,0.01,c\n",
        b"# t\r\ntheta_i_deg,theta_r_deg,phi_r_deg,brdf_r_per_sr,brdf_g_per_sr\r\n15,5,-30,1e-2,2e-2\r\n15,5,330,1,1\r\n",
    ],
}
for target, seeds in extra.items():
    for s in seeds:
        write(target, s)
# Instrument files (fixtures/real/instruments), for the dispatcher and for each reader's
# own target (gwy, plu, metropro, opd, sur, al3d, frt):
# * each real file's first 8 KiB: a truncated file, refused with the byte offset, from
#   which mutation works on the header;
# * small valid files (a few KiB) that the reader accepts, so that mutation also reaches
#   the data decoding, the invalid-point rules and the scales. Each is the real file
#   shrunk (its header kept, its size fields rewritten to a small window cut from the
#   middle of its data), except GWY, built from scratch from the layout gwy.rs reads
#   (the real GWY file is a tree of objects whose sizes would all need rewriting).
INSTRUMENTS = os.path.join(REAL, "instruments")
INSTRUMENT_FILES = {
    "gwy": ["gwyfile-test.gwy"],
    "plu": ["plu-1.plu"],
    "metropro": ["metropro-1.dat"],
    "opd": ["opd-1.opd"],
    "sur": ["sur-2.sur", "sur-3.sur"],
    "al3d": ["al3d-1.al3d"],
    "frt": ["frt-1.frt", "frt-2.frt"],
}
# The dispatcher's extension byte naming each format (fuzz_targets/map.rs EXTENSIONS).
MAP_EXTENSION = {"gwy": 6, "plu": 7, "metropro": 5, "opd": 8, "sur": 9, "al3d": 10, "frt": 11}


def instrument(name):
    with open(os.path.join(INSTRUMENTS, name), "rb") as f:
        return f.read()


def window(data, item, row_items, x0, y0, nx, ny, rows=None):
    """The nx x ny window at (x0, y0) of a row-major array of `row_items` items a row
    (or the nx items at x0 of each of the given rows)."""
    return b"".join(
        data[(y * row_items + x0) * item:(y * row_items + x0 + nx) * item]
        for y in (rows if rows is not None else range(y0, y0 + ny))
    )


def gwy_object(name, components):
    body = b"".join(components)
    return name.encode() + b"\0" + struct.pack("<I", len(body)) + body


def gwy_component(key, kind, value):
    return key.encode() + b"\0" + kind.encode() + value


def gwy_field(nx, ny, values, unit_xy="m", unit_z="m"):
    def unit(u):
        return gwy_object("GwySIUnit", [gwy_component("unitstr", "s", u.encode() + b"\0")])

    return gwy_object("GwyDataField", [
        gwy_component("xres", "i", struct.pack("<i", nx)),
        gwy_component("yres", "i", struct.pack("<i", ny)),
        gwy_component("xreal", "d", struct.pack("<d", nx * 0.5e-6)),
        gwy_component("yreal", "d", struct.pack("<d", ny * 0.25e-6)),
        gwy_component("xoff", "d", struct.pack("<d", 1e-6)),
        gwy_component("si_unit_xy", "o", unit(unit_xy)),
        gwy_component("si_unit_z", "o", unit(unit_z)),
        gwy_component("data", "D", struct.pack("<I", len(values)) + struct.pack(f"<{len(values)}d", *values)),
    ])


def gwy_small():
    """Channel 0: 4 x 3 heights in m with a NaN and a mask point; channel 1: no units
    (needs --pixel-um and --z-unit); one object holding every other component type."""
    z = [1e-7 * (k % 5) - 2e-7 for k in range(12)]
    z[5] = float("nan")
    mask = [0.0] * 12
    mask[7] = 1.0
    other = gwy_object("GwyGraphModel", [
        gwy_component("curves", "O", struct.pack("<I", 1) + gwy_object("GwyGraphCurveModel", [
            gwy_component("xdata", "D", struct.pack("<I", 2) + struct.pack("<2d", 0.0, 1.0)),
        ])),
        gwy_component("labels", "S", struct.pack("<I", 2) + b"a\0b\0"),
        gwy_component("flags", "C", struct.pack("<I", 3) + b"\1\2\3"),
        gwy_component("ids", "I", struct.pack("<I", 2) + struct.pack("<2i", 1, -2)),
        gwy_component("big", "Q", struct.pack("<I", 1) + struct.pack("<q", 1 << 40)),
        gwy_component("count", "q", struct.pack("<q", 5)),
        gwy_component("visible", "b", b"\1"),
        gwy_component("char", "c", b"x"),
    ])
    return b"GWYP" + gwy_object("GwyContainer", [
        gwy_component("/0/data", "o", gwy_field(4, 3, z)),
        gwy_component("/0/data/title", "s", b"Height\0"),
        gwy_component("/0/mask", "o", gwy_field(4, 3, mask, "m", "")),
        gwy_component("/1/data", "o", gwy_field(2, 2, [1.0, 2.0, 3.0, 4.0], "", "")),
        gwy_component("/1/data/title", "s", b"Uncalibrated\0"),
        gwy_component("/0/graph", "o", other),
    ])


def plu_small(nx=6, ny=4, layers=1):
    """plu-1.plu's 500-byte header with an nx x ny window of its heights and grey image
    (`layers` copies of that layer, each with its image)."""
    b = instrument("plu-1.plu")
    NY, NX = struct.unpack_from("<II", b, 500)
    n = NX * NY
    heights, image = 508, 508 + 4 * n + 8
    x0, y0 = NX // 2, NY // 2
    h = bytearray(b[:500])
    struct.pack_into("<II", h, 388, ny, nx)
    h[489] = layers
    layer = struct.pack("<II", ny, nx) + window(b, 4, NX, x0, y0, nx, ny)
    layer += b[heights + 4 * n:heights + 4 * n + 8] + window(b[image:], 3, NX, x0, y0, nx, ny)
    return bytes(h) + layer * layers


def metropro_small(nx=6, ny=4, intensity=True):
    """metropro-1.dat's 834-byte header with an nx x ny window of its phase frame (and of
    its intensity frame, or none)."""
    b = instrument("metropro-1.dat")
    aw, ah, buckets, ac_bytes = struct.unpack_from(">HHHxxI", b, 52)
    cw, chh = struct.unpack_from(">HH", b, 68)
    h = bytearray(b[:834])
    x0, y0 = cw // 2, chh // 2
    ac = window(b[834:], 2, aw, x0, y0, nx, ny) if intensity else b""
    struct.pack_into(">HHHxxI", h, 52, nx if intensity else 0, ny if intensity else 0,
                     1 if intensity else 0, len(ac))
    struct.pack_into(">HHI", h, 68, nx, ny, 4 * nx * ny)
    return bytes(h) + ac + window(b[834 + ac_bytes:], 4, cw, x0, y0, nx, ny)


def opd_small(nx=6, ny=4):
    """opd-1.opd's directory without its empty entries and its big skipped blocks, each
    array cut to nx x ny (stored y fastest, y reversed)."""
    b = instrument("opd-1.opd")
    dir_len = struct.unpack_from("<i", b, 20)[0]
    pos, entries = 2 + dir_len, []
    for i in range(1, dir_len // 24):
        e = 2 + i * 24
        kind, length = struct.unpack_from("<hi", b, e + 16)
        payload = b[pos:pos + length]
        pos += length
        if length == 0 or (kind not in (3, 5, 6, 7, 8, 12) and length > 256):
            continue
        if kind == 3:
            NX, NY, item = struct.unpack_from("<HHH", payload)
            cols = [payload[6 + (x * NY + NY - ny) * item:6 + (x * NY + NY) * item]
                    for x in range(NX // 2, NX // 2 + nx)]
            payload = struct.pack("<HHH", nx, ny, item) + b"".join(cols)
        entries.append((b[e:e + 18] + struct.pack("<i", len(payload)) + b[e + 22:e + 24], payload))
    d = b[2:18] + b[18:20] + struct.pack("<i", 24 * (len(entries) + 1)) + b[24:26]
    return b[:2] + d + b"".join(e for e, _ in entries) + b"".join(p for _, p in entries)


def sur_object(b, nx, ny, bits=32, objects=1):
    """One object of a SUR file: the file's 512-byte header, an nx x ny window of its
    (32-bit) data, one point at min - 2 (non-measured); 16-bit: rescaled into i16."""
    h = bytearray(b[:512])
    NX, NY = struct.unpack_from("<ii", h, 108)
    zones = struct.unpack_from("<h", h, 334)[0] + struct.unpack_from("<h", h, 336)[0]
    raw = list(struct.unpack(f"<{nx * ny}i", window(b[512 + zones:], 4, NX, NX // 2, NY // 2, nx, ny)))
    lo, hi = min(raw), max(raw)
    if bits == 16:
        raw = [int((v - lo) * 60000 // max(hi - lo, 1)) - 30000 for v in raw]
        lo, hi = -30000, 30000
        scale = struct.unpack_from("<f", h, 128)[0] * max(hi - lo, 1) / 60000
        struct.pack_into("<f", h, 128, scale)
    raw[1] = lo - 2
    struct.pack_into("<h", h, 14, objects)
    struct.pack_into("<h", h, 86, 1)
    struct.pack_into("<h", h, 98, bits)
    struct.pack_into("<iiiii", h, 100, lo, hi, nx, ny, nx * ny)
    struct.pack_into("<hh", h, 334, 0, 0)
    return bytes(h) + struct.pack(f"<{nx * ny}{'i' if bits == 32 else 'h'}", *raw)


def al3d_small(name="al3d-1.al3d", nx=5, ny=4):
    """al3d-1.al3d's tags (sizes and offsets rewritten) with an nx x ny window of its
    depth image and of its four texture planes (R, G, B and repeatability); nx = 5 pads
    every line (depth lines to 24 bytes, texture lines to 8), and one depth is set above
    InvalidPixelValue."""
    b = instrument(name)
    count = int(b[17 + 52 + 20:17 + 52 + 50].split(b"\0")[0])
    tags = [b[17 + 52 * i:17 + 52 * (i + 1)] for i in range(count + 2)]
    values = {t[:20].split(b"\0")[0].decode(): t[20:50].split(b"\0")[0] for t in tags}
    NX, NY = int(values["Cols"]), int(values["Rows"])
    depth_at, texture_at = int(values["DepthImageOffset"]), int(values["TextureImageOffset"])
    planes = int(values["NumberOfPlanes"])
    stride, line = -(-nx * 4 // 8) * 8, -(-nx // 8) * 8
    depth = 17 + 52 * len(tags)
    texture = depth + stride * ny
    new = {"Cols": nx, "Rows": ny, "DepthImageOffset": depth, "TextureImageOffset": texture}
    out = b"AliconaImaging\0\r\n"
    for t in tags:
        key = t[:20].split(b"\0")[0].decode()
        if key in new:
            t = t[:20] + str(new[key]).encode().ljust(30, b"\0") + b"\r\n"
        out += t
    x0, y0 = NX // 2, NY // 2
    NSTRIDE = -(-NX * 4 // 8) * 8
    rows = [bytearray(b[depth_at + (y0 + y) * NSTRIDE + 4 * x0:][:4 * nx]) for y in range(ny)]
    rows[1][4:8] = struct.pack("<f", 3.1e15)
    out += b"".join(bytes(r).ljust(stride, b"\0") for r in rows)
    NLINE = -(-NX // 8) * 8
    for p in range(planes):
        at = texture_at + p * NLINE * NY
        out += b"".join(b[at + (y0 + y) * NLINE + x0:][:nx].ljust(line, b"\0") for y in range(ny))
    return out


def frt_blocks(b):
    version = b[12:16]
    wide = version == b"1.01"
    pos, blocks = 18, []
    for _ in range(struct.unpack_from("<H", b, 16)[0]):
        bid = struct.unpack_from("<H", b, pos)[0]
        size = struct.unpack_from("<Q" if wide else "<I", b, pos + 2)[0]
        pos += 10 if wide else 6
        blocks.append((bid, b[pos:pos + size]))
        pos += size
    return blocks


def frt_file(version, blocks):
    out = b"FRTM_GLIDERV" + version + struct.pack("<H", len(blocks))
    for bid, payload in blocks:
        out += struct.pack("<H", bid) + struct.pack("<Q" if version == b"1.01" else "<I", len(payload)) + payload
    return out


def frt_small(name, nx=6, ny=4, version=b"1.00"):
    """The file's blocks with its image(s) (0x000b, and every image of 0x007d) cut to nx
    points from the middle column of ny - 1 middle rows and the last row (frt-1.frt's
    interrupted last row of raw 0, frt-2.frt's undefined 1), 0x0066 rewritten to match;
    other blocks kept as they are."""
    b = instrument(name)
    blocks = frt_blocks(b)
    NX, NY, bits = struct.unpack("<III", dict(blocks)[0x0066])
    x0 = NX // 2
    out = []
    for bid, p in blocks:
        if bid == 0x0066:
            p = struct.pack("<III", nx, ny, bits)
        elif bid == 0x000b:
            p = window(p, bits // 8, NX, x0, 0, nx, ny, [*range(NY // 2, NY // 2 + ny - 1), NY - 1])
        elif bid == 0x007d:
            q, at = p[:8], 8
            while at + 16 <= len(p):
                kind, inx, iny, ibits = struct.unpack_from("<IIII", p, at)
                data = p[at + 16:at + 16 + inx * iny * ibits // 8]
                q += struct.pack("<IIII", kind, nx, ny, ibits)
                q += window(data, ibits // 8, inx, inx // 2, 0, nx, ny,
                            [*range(iny // 2, iny // 2 + ny - 1), iny - 1])
                at += 16 + len(data)
            p = q
        out.append((bid, p))
    return frt_file(version, out)


small = {
    "gwy": [gwy_small()],
    "plu": [plu_small(), plu_small(3, 2, layers=2)],
    "metropro": [metropro_small(), metropro_small(3, 2, intensity=False)],
    "opd": [opd_small()],
    "sur": [sur_object(instrument("sur-2.sur"), 6, 4),
            sur_object(instrument("sur-3.sur"), 3, 2, bits=16, objects=2)
            + sur_object(instrument("sur-3.sur"), 2, 2)],
    "al3d": [al3d_small()],
    "frt": [frt_small("frt-1.frt"), frt_small("frt-2.frt", 5, 3, version=b"1.01")],
}
SMALL_OUT = os.environ.get("FLAKESCATTER_SEEDS_SMALL")  # write the small files here too
for target, names in INSTRUMENT_FILES.items():
    for name in names:
        head = instrument(name)[:8192]
        for o in (0x00, 0x80):
            write(target, bytes([o]) + head)
        write("map", bytes([0, 0]) + head[:8190])
        write("map", bytes([0x03, 0]) + head[:8190])
    for k, s in enumerate(small[target]):
        assert len(s) < 16 << 10, (target, len(s))
        if SMALL_OUT:
            ext = "dat" if target == "metropro" else target
            with open(os.path.join(SMALL_OUT, f"{target}-{k}.{ext}"), "wb") as f:
                f.write(s)
        for o in OPTION_BYTES:
            write(target, bytes([o]) + s)
        for o, e in ((0, MAP_EXTENSION[target]), (0, 0), (0x80, MAP_EXTENSION[target]), (0, 2)):
            write("map", bytes([o, e]) + s)
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
# `analyze` manifests: the shipped sample manifest, and small hand-made ones with the
# angle-range forms, a [measured] table and both angle forms of [models].
with open(os.path.join(ROOT, "fixtures", "sample.toml"), "rb") as f:
    write("manifest", f.read())
write("manifest", b'name = "a"\n[maps]\nfiles = ["x.x3p"]\n')
write("manifest", b'[maps]\nfiles = ["m/*.x3p"]\n[models]\ntheta_i_deg = [45]\ntheta_s_deg = { from = -70, to = 70, step = 1 }\n')
write("manifest", b'[maps]\nfiles = ["a.txt"]\n[measured]\nfiles = ["curves.csv"]\n[models]\ntheta_s_deg = [-10, 0, 10]\n')
# Polarimetry: little-endian doubles, a Stokes vector then a Jones matrix's eight
# numbers (the states of the issue: subnormal, huge, just over-polarised, circular).
for stokes in ([1, 1, 0, 0], [1e-310, 1e-310, 0, 0], [1e200, 1e200, 0, 0], [1, 1.00000001, 0, 0],
               [1, 0, 0, 1], [2, 0.5, -0.3, 1.2], [1, 0.7071067812, 0.7071067812, 0]):
    for jones in ([], [-0.6, 0.1, 0, 0, 0, 0, 0.7, -0.2], [1, 0, 0.3, 0, 0.3, 0, 1, 0]):
        write("polarimetry", struct.pack("<%dd" % (4 + len(jones)), *stokes, *jones))
for t in sorted(os.listdir(OUT)):
    print(t, len(os.listdir(os.path.join(OUT, t))))

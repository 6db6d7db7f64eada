"""Writes the stack fixtures of crates/io/tests/stack.rs with software other than ours.

Run with Python 3.11, numpy and tifffile (2026.3.3 was used):
    python make_stacks.py            # writes the three .tif/.lsm files here

Every file holds the same analytic stack: 16 x 12 pixels, 9 slices, a plane surface at
    h(col, row) = 0.6 + 0.04 col + 0.02 row   (µm above the lowest slice)
seen through a Gaussian axial response of FWHM 0.6 µm,
    I(z) = A exp(-4 ln 2 (z - h)^2 / 0.6^2),
sampled at slice heights z_k = k dz and rounded to integers.
"""
import struct
import numpy as np
import tifffile

NX, NY, NZ = 16, 12, 9
FWHM = 0.6


def stack(dz, amplitude, dtype):
    col = np.arange(NX)[None, None, :]
    row = np.arange(NY)[None, :, None]
    z = (np.arange(NZ) * dz)[:, None, None]
    h = 0.6 + 0.04 * col + 0.02 * row
    i = amplitude * np.exp(-4 * np.log(2) * (z - h) ** 2 / FWHM**2)
    return np.round(i).astype(dtype)


# 1. ImageJ hyperstack, 16-bit, 0.2 µm pixels, 0.25 µm z step, page 0 = lowest slice.
tifffile.imwrite(
    "imagej-u16.tif",
    stack(0.25, 60000, np.uint16),
    imagej=True,
    resolution=(1 / 0.2, 1 / 0.2),
    metadata={"spacing": 0.25, "unit": "um", "axes": "ZYX"},
)

# 2. OME-TIFF, 16-bit, pixel size given in nm (180 nm), z step 0.3 µm, stored top slice
#    first: the pages are reversed and the planes' PositionZ decrease with TheZ.
data = stack(0.3, 50000, np.uint16)[::-1]
tifffile.imwrite(
    "ome-u16-topfirst.ome.tif",
    data,
    ome=True,
    metadata={
        "axes": "ZYX",
        "PhysicalSizeX": 180.0,
        "PhysicalSizeXUnit": "nm",
        "PhysicalSizeY": 180.0,
        "PhysicalSizeYUnit": "nm",
        "PhysicalSizeZ": 0.3,
        "PhysicalSizeZUnit": "µm",
        "Plane": {"PositionZ": [float(10.0 - 0.3 * k) for k in range(NZ)]},
    },
)

# 3. Zeiss LSM, 8-bit, built byte by byte from the TIFF 6.0 layout and the CZ_LSMINFO
#    record (Zeiss "LSM 5 file format"; field order as in tifffile's TIFF.CZ_LSMINFO):
#    every slice page is followed by a thumbnail page (NewSubfileType = 1), as LSM510
#    files are. Voxel sizes in metres: 0.18 µm pixels, 0.3 µm z step.
slices = stack(0.3, 250, np.uint8)
thumb = np.full((4, 4), 7, np.uint8)
lsminfo = bytearray(512)
struct.pack_into("<Ii", lsminfo, 0, 0x0400494C, 512)
struct.pack_into("<8i", lsminfo, 8, NX, NY, NZ, 1, 1, 1, 4, 4)
struct.pack_into("<3d", lsminfo, 40, 0.18e-6, 0.18e-6, 0.3e-6)

out = bytearray(b"II*\0\0\0\0\0")
pages = []
for k in range(NZ):
    pages.append((slices[k], 0, bytes(lsminfo) if k == 0 else None))
    pages.append((thumb, 1, None))
ifd_offsets = []
# Lay out: [data, extra][IFD] per page, each IFD pointing to the next.
prev_next_ptr = 4
for img, subfile, extra in pages:
    h, w = img.shape
    data_off = len(out)
    out += img.tobytes()
    extra_off = None
    if extra is not None:
        if len(out) % 2:
            out += b"\0"
        extra_off = len(out)
        out += extra
    if len(out) % 2:
        out += b"\0"
    ifd_off = len(out)
    struct.pack_into("<I", out, prev_next_ptr, ifd_off)
    tags = [
        (254, 4, 1, subfile),
        (256, 3, 1, w),
        (257, 3, 1, h),
        (258, 3, 1, 8),
        (259, 3, 1, 1),
        (262, 3, 1, 1),
        (273, 4, 1, data_off),
        (277, 3, 1, 1),
        (278, 3, 1, h),
        (279, 4, 1, w * h),
    ]
    if extra_off is not None:
        tags.append((34412, 1, len(extra), extra_off))
    out += struct.pack("<H", len(tags))
    for tag, typ, count, value in tags:
        if typ == 3:
            out += struct.pack("<HHIHH", tag, typ, count, value, 0)
        else:
            out += struct.pack("<HHII", tag, typ, count, value)
    prev_next_ptr = len(out)
    out += struct.pack("<I", 0)
open("zeiss-u8.lsm", "wb").write(bytes(out))

# Independent check of what the files declare, with tifffile's own readers.
with tifffile.TiffFile("imagej-u16.tif") as t:
    print("imagej", t.imagej_metadata, t.pages[0].tags["XResolution"].value)
with tifffile.TiffFile("ome-u16-topfirst.ome.tif") as t:
    print("ome", t.is_ome, t.series[0].shape)
with tifffile.TiffFile("zeiss-u8.lsm") as t:
    m = t.lsm_metadata
    print("lsm", t.is_lsm, m["DimensionX"], m["DimensionY"], m["DimensionZ"],
          m["VoxelSizeX"], m["VoxelSizeY"], m["VoxelSizeZ"], len(t.pages))
    print("lsm series", t.series[0].shape, int(t.series[0].asarray().max()))

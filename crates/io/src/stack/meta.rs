//! Voxel-size metadata of confocal TIFF stacks: ImageJ descriptions, OME-XML and the
//! Zeiss `CZ_LSMINFO` record. Pure functions on the tag contents; the reader in the
//! parent module finds the tags.
//!
//! Conventions: every length is returned in µm (converted once, here); a field that is
//! present but unusable comes back as `Err(reason)` so that the reader can report it
//! unless an option overrides that quantity.

use crate::bytes::{f64_le, i32_le, u32_le};
use std::collections::BTreeMap;

/// A declared value with a description of its origin, or why it is unusable.
pub(crate) type Field<T> = Option<Result<(T, String), String>>;

/// What a metadata block says about the stack. `None` = not stated.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Declared {
    /// Pixel size `(dx, dy)` in µm, with a description of where it came from.
    pub pixel_um: Field<(f64, f64)>,
    /// z step in µm, with its origin.
    pub z_step_um: Field<f64>,
    /// Number of z slices declared (`slices=`, `SizeZ`, `DimensionZ`).
    pub slices: Option<(usize, &'static str)>,
    /// Declared `(nx, ny)` of each slice, with the field names.
    pub size: Option<((usize, usize), &'static str)>,
    /// Channels × time points other than one: the stack is not a plain z-stack.
    pub extra_dimensions: Option<String>,
    /// `true` when page 0 is the top slice, with the reason; `None` when not stated;
    /// an error when the metadata contradict themselves on it.
    pub top_first: Field<bool>,
    /// Full-scale sample value when the metadata says the data use fewer bits than
    /// their container (12-bit LSM data in 16-bit pages).
    pub full_scale: Option<(f64, String)>,
    /// Raw fields worth keeping in the maps' metadata.
    pub fields: BTreeMap<String, String>,
}

/// Factor from a length unit label (ImageJ, OME, LSM spellings) to µm.
pub(crate) fn unit_to_um(label: &str) -> Option<f64> {
    Some(match label.trim() {
        "m" => 1e6,
        "cm" => 1e4,
        "mm" => 1e3,
        "um" | "µm" | "μm" | "micron" | "microns" | "\\u00B5m" | "\\u00b5m" => 1.0,
        "nm" => 1e-3,
        "pm" => 1e-6,
        "Å" | "Angstrom" | "angstrom" => 1e-4,
        "in" | "inch" | "inches" => 25_400.0,
        _ => return None,
    })
}

fn positive(name: &str, text: &str, factor: f64) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v * factor),
        Ok(v) => Err(format!("{name} = {v} is not a positive length")),
        Err(_) => Err(format!("{name} = {text:?} is not a number")),
    }
}

fn count(text: &str) -> Option<usize> {
    text.trim().parse::<usize>().ok()
}

/// Is this `ImageDescription` written by ImageJ?
pub(crate) fn is_imagej(description: &str) -> bool {
    description.starts_with("ImageJ=")
}

/// Is this `ImageDescription` an OME-XML document?
pub(crate) fn is_ome(description: &str) -> bool {
    let head = description.trim_start();
    (head.starts_with("<?xml") || head.starts_with("<OME")) && description.contains("<OME")
}

/// The pixel size, in the resolution's unit, of a TIFF resolution tag `name` written as
/// the rational `n/d` pixels per unit (`None`: no tag). A zero numerator (no pixels per
/// unit) or denominator is not a usable resolution.
fn pixel_size(name: &str, r: Option<(u32, u32)>, unit: &str) -> Result<Option<f64>, String> {
    match r {
        None => Ok(None),
        Some((0, d)) => Err(format!(
            "{name} is 0/{d}, zero pixels per {unit}: not a usable resolution (the pixel size would be infinite)"
        )),
        Some((n, 0)) => Err(format!(
            "{name} is {n}/0, a zero denominator: not a usable resolution"
        )),
        // Size of a pixel in the unit: 1 / (n/d) = d/n, one rounding.
        Some((n, d)) => Ok(Some(f64::from(d) / f64::from(n))),
    }
}

/// Parses an ImageJ `ImageDescription` (`key=value` lines) together with the first
/// page's `XResolution` and `YResolution` tags, rationals `n/d` in pixels per unit
/// (ImageJ writes them with `ResolutionUnit` none): the pixel size is `d/n` in the
/// description's unit; a missing `YResolution` means square pixels.
pub(crate) fn imagej(
    description: &str,
    x_res: Option<(u32, u32)>,
    y_res: Option<(u32, u32)>,
) -> Declared {
    let mut kv = BTreeMap::new();
    for line in description.lines() {
        if let Some((k, v)) = line.split_once('=') {
            kv.insert(k.trim().to_string(), v.trim().to_string());
        }
    }
    let mut d = Declared::default();
    for key in [
        "ImageJ", "images", "slices", "channels", "frames", "unit", "yunit", "zunit", "spacing",
    ] {
        if let Some(v) = kv.get(key) {
            d.fields.insert(format!("imagej.{key}"), v.clone());
        }
    }
    let channels = kv.get("channels").and_then(|v| count(v)).unwrap_or(1);
    let frames = kv.get("frames").and_then(|v| count(v)).unwrap_or(1);
    if channels > 1 || frames > 1 {
        d.extra_dimensions = Some(format!(
            "ImageJ hyperstack with channels={channels}, frames={frames}"
        ));
    }
    // `slices=` is the z count; plain ImageJ stacks write only `images=`.
    if let Some(n) = kv.get("slices").and_then(|v| count(v)) {
        d.slices = Some((n, "ImageJ slices="));
    } else if let Some(n) = kv.get("images").and_then(|v| count(v)) {
        d.slices = Some((n, "ImageJ images="));
    }
    let unit = kv.get("unit").map(String::as_str);
    let x_unit = unit.filter(|u| *u != "pixel" && !u.is_empty());
    let y_unit = kv.get("yunit").map(String::as_str).or(x_unit);
    let z_unit = kv.get("zunit").map(String::as_str).or(x_unit);
    if let Some(u) = x_unit {
        d.pixel_um = Some(match (unit_to_um(u), y_unit.and_then(unit_to_um)) {
            (Some(fx), Some(fy)) => {
                let yu = y_unit.unwrap_or(u);
                match (
                    pixel_size("XResolution", x_res, u),
                    pixel_size("YResolution", y_res, yu),
                ) {
                    (Ok(Some(px)), Ok(py)) => Ok((
                        (fx * px, fy * py.unwrap_or(px)),
                        format!("ImageJ XResolution/YResolution (pixels per {u})"),
                    )),
                    (Err(e), _) | (_, Err(e)) => Err(format!("ImageJ unit={u}: {e}")),
                    (Ok(None), _) => Err(format!(
                        "ImageJ unit={u} but the page has no XResolution tag"
                    )),
                }
            }
            _ => Err(format!("ImageJ unit={u:?} is not a length unit")),
        });
    }
    if let Some(s) = kv.get("spacing") {
        d.z_step_um = Some(match z_unit.and_then(unit_to_um) {
            Some(f) => positive("ImageJ spacing", s, f).map(|v| {
                (
                    v,
                    format!("ImageJ spacing= (unit {})", z_unit.unwrap_or("?")),
                )
            }),
            None => Err(format!(
                "ImageJ spacing={s} has no length unit (unit={:?})",
                unit.unwrap_or("")
            )),
        });
    }
    d
}

fn attr<'a>(node: roxmltree::Node<'a, '_>, name: &str) -> Option<&'a str> {
    node.attribute(name)
}

/// Parses the OME-XML of an OME-TIFF (first page's `ImageDescription`).
pub(crate) fn ome(xml: &str) -> Result<Declared, String> {
    let doc = roxmltree::Document::parse(xml).map_err(|e| format!("OME-XML: {e}"))?;
    let images: Vec<_> = doc
        .descendants()
        .filter(|n| n.tag_name().name() == "Image")
        .collect();
    let image = match images.as_slice() {
        [] => return Err("OME-XML has no <Image> element".into()),
        [one] => *one,
        many => {
            return Err(format!(
                "OME-XML describes {} images (series); only single-image z-stacks are read",
                many.len()
            ));
        }
    };
    let pixels = image
        .children()
        .find(|n| n.tag_name().name() == "Pixels")
        .ok_or("OME-XML <Image> has no <Pixels> element")?;
    let mut d = Declared::default();
    let get = |name: &str| attr(pixels, name);
    for key in [
        "DimensionOrder",
        "Type",
        "SizeX",
        "SizeY",
        "SizeZ",
        "SizeC",
        "SizeT",
        "PhysicalSizeX",
        "PhysicalSizeXUnit",
        "PhysicalSizeY",
        "PhysicalSizeYUnit",
        "PhysicalSizeZ",
        "PhysicalSizeZUnit",
    ] {
        if let Some(v) = get(key) {
            d.fields.insert(format!("ome.{key}"), v.to_string());
        }
    }
    let size = |name: &str| -> Result<Option<usize>, String> {
        get(name)
            .map(|v| count(v).ok_or(format!("OME-XML Pixels {name}={v:?} is not a count")))
            .transpose()
    };
    let (sx, sy, sz) = (size("SizeX")?, size("SizeY")?, size("SizeZ")?);
    let (sc, st) = (size("SizeC")?.unwrap_or(1), size("SizeT")?.unwrap_or(1));
    if let (Some(x), Some(y)) = (sx, sy) {
        d.size = Some(((x, y), "OME-XML SizeX/SizeY"));
    }
    if let Some(z) = sz {
        d.slices = Some((z, "OME-XML SizeZ"));
    }
    if sc > 1 || st > 1 {
        d.extra_dimensions = Some(format!("OME-TIFF with SizeC={sc}, SizeT={st}"));
    }
    // Physical sizes default to µm (OME schema 2016-06).
    let physical = |axis: &str| -> Option<Result<(f64, String), String>> {
        let v = get(&format!("PhysicalSize{axis}"))?;
        let unit = get(&format!("PhysicalSize{axis}Unit")).unwrap_or("µm");
        Some(match unit_to_um(unit) {
            Some(f) => positive(&format!("OME-XML PhysicalSize{axis}"), v, f)
                .map(|x| (x, format!("OME-XML PhysicalSize{axis} ({unit})"))),
            None => Err(format!(
                "OME-XML PhysicalSize{axis}Unit={unit:?} is not a length unit"
            )),
        })
    };
    d.pixel_um = match (physical("X"), physical("Y")) {
        (Some(Ok((x, _))), Some(Ok((y, _)))) => Some(Ok((
            (x, y),
            "OME-XML PhysicalSizeX/PhysicalSizeY".to_string(),
        ))),
        (Some(Ok((x, sx))), None) => Some(Ok(((x, x), sx))),
        (Some(Err(e)), _) | (_, Some(Err(e))) => Some(Err(e)),
        (None, Some(Ok(_))) => Some(Err("OME-XML has PhysicalSizeY but no PhysicalSizeX".into())),
        (None, None) => None,
    };
    d.z_step_um = physical("Z");
    // Step and page order from the planes' PositionZ, when every z plane (C = T = 0)
    // has one (super::positions).
    if let Some(nz) = sz.filter(|&n| n >= 2) {
        let declared = match &d.z_step_um {
            Some(Ok((dz, _))) => Some(*dz),
            _ => None,
        };
        let decided = super::positions::decide(pixels, nz, declared);
        if decided.z_step_um.is_some() {
            // A PhysicalSizeZ that is itself unusable stays the error.
            if !matches!(d.z_step_um, Some(Err(_))) {
                d.z_step_um = decided.z_step_um;
            }
            d.fields.insert(
                "ome.PositionZ".into(),
                match &d.z_step_um {
                    Some(Ok((_, src))) if src.contains("PositionZ") => "used for the z step".into(),
                    Some(Ok(_)) => "not used for the z step".into(),
                    _ => "inconsistent (refused unless the z step is given)".into(),
                },
            );
        }
        d.top_first = decided.top_first;
    }
    Ok(d)
}

/// Magic numbers of `CZ_LSMINFO` (LSM 1.3 and LSM 1.5 and later).
pub(crate) const LSM_MAGIC: [u32; 2] = [0x0300_494C, 0x0400_494C];

/// Parses the `CZ_LSMINFO` record (TIFF tag 34412) of a Zeiss LSM file.
///
/// Layout, little-endian, from the Zeiss "LSM 5 file format" description as transcribed
/// in tifffile's `TIFF.CZ_LSMINFO` (C. Gohlke): `u32 MagicNumber`, `i32 StructureSize`,
/// `i32 DimensionX, DimensionY, DimensionZ, DimensionChannels, DimensionTime, DataType,
/// ThumbnailX, ThumbnailY` (offsets 8–39), `f64 VoxelSizeX, VoxelSizeY, VoxelSizeZ` in
/// metres (offsets 40, 48, 56), then origins, scan type and offsets to sub-records (not
/// used). `DataType`: 1 = 8-bit, 2 = 12-bit (in 16-bit samples), 5 = 32-bit float.
pub(crate) fn lsm(bytes: &[u8]) -> Result<Declared, String> {
    if bytes.len() < 64 {
        return Err(format!(
            "CZ_LSMINFO record has {} bytes, expected at least 64",
            bytes.len()
        ));
    }
    let u32_at = |o: usize| u32_le(bytes, o);
    let i32_at = |o: usize| i32_le(bytes, o);
    let f64_at = |o: usize| f64_le(bytes, o);
    let magic = u32_at(0);
    if !LSM_MAGIC.contains(&magic) {
        return Err(format!(
            "CZ_LSMINFO magic number is {magic:#010x}, expected 0x0300494c or 0x0400494c"
        ));
    }
    let dims = [
        ("DimensionX", i32_at(8)),
        ("DimensionY", i32_at(12)),
        ("DimensionZ", i32_at(16)),
        ("DimensionChannels", i32_at(20)),
        ("DimensionTime", i32_at(24)),
        ("DataType", i32_at(28)),
    ];
    let mut d = Declared::default();
    for (k, v) in dims {
        d.fields.insert(format!("lsm.{k}"), v.to_string());
    }
    let dim = |i: usize| -> Result<usize, String> {
        let (k, v) = dims[i];
        usize::try_from(v).map_err(|_| format!("CZ_LSMINFO {k} = {v} is negative"))
    };
    let (x, y, z, c, t) = (dim(0)?, dim(1)?, dim(2)?, dim(3)?, dim(4)?);
    d.size = Some(((x, y), "CZ_LSMINFO DimensionX/DimensionY"));
    d.slices = Some((z, "CZ_LSMINFO DimensionZ"));
    if c > 1 || t > 1 {
        d.extra_dimensions = Some(format!(
            "LSM file with DimensionChannels={c}, DimensionTime={t}"
        ));
    }
    if dims[5].1 == 2 {
        d.full_scale = Some((4095.0, "CZ_LSMINFO DataType = 2 (12-bit)".into()));
    }
    let voxel = |name: &str, o: usize| -> Result<f64, String> {
        let v = f64_at(o);
        positive_f64(v).ok_or(format!(
            "CZ_LSMINFO {name} = {v} m is not a positive length"
        ))
    };
    let (vx, vy, vz) = (
        voxel("VoxelSizeX", 40),
        voxel("VoxelSizeY", 48),
        voxel("VoxelSizeZ", 56),
    );
    for (k, v) in [("VoxelSizeX", 40), ("VoxelSizeY", 48), ("VoxelSizeZ", 56)] {
        d.fields.insert(format!("lsm.{k}"), f64_at(v).to_string());
    }
    d.pixel_um = Some(match (vx, vy) {
        (Ok(x), Ok(y)) => Ok((
            (x * 1e6, y * 1e6),
            "CZ_LSMINFO VoxelSizeX/VoxelSizeY (m)".into(),
        )),
        (Err(e), _) | (_, Err(e)) => Err(e),
    });
    d.z_step_um = Some(vz.map(|z| (z * 1e6, "CZ_LSMINFO VoxelSizeZ (m)".into())));
    Ok(d)
}

fn positive_f64(v: f64) -> Option<f64> {
    (v.is_finite() && v > 0.0).then_some(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn imagej_description_as_imagej_writes_it() {
        // The description ImageJ 1.x writes for a 40-slice calibrated stack.
        let text = "ImageJ=1.54f\nimages=40\nslices=40\nunit=micron\nspacing=0.3\nloop=false\n";
        // 1 / 0.18 µm = 5.555... pixels per micron.
        let d = imagej(text, Some((50, 9)), None);
        let ((dx, dy), _) = d.pixel_um.unwrap().unwrap();
        assert!((dx - 0.18).abs() < 1e-15 && (dy - 0.18).abs() < 1e-15);
        assert_eq!(d.z_step_um.unwrap().unwrap().0, 0.3);
        assert_eq!(d.slices, Some((40, "ImageJ slices=")));
        assert!(d.extra_dimensions.is_none());
        // nm with a separate z unit.
        let text = "ImageJ=1.54f\nimages=5\nunit=nm\nzunit=micron\nspacing=0.25\n";
        let d = imagej(text, Some((1, 100)), Some((1, 50)));
        let ((dx, dy), _) = d.pixel_um.unwrap().unwrap();
        assert!((dx - 0.1).abs() < 1e-15 && (dy - 0.05).abs() < 1e-15);
        assert_eq!(d.z_step_um.unwrap().unwrap().0, 0.25);
        // Uncalibrated: ImageJ writes no unit (or unit=pixel).
        let d = imagej("ImageJ=1.54f\nimages=5\n", Some((72, 1)), None);
        assert!(d.pixel_um.is_none() && d.z_step_um.is_none());
        // Bad values are reported, not guessed.
        let d = imagej(
            "ImageJ=\nimages=5\nunit=micron\nspacing=-1\n",
            Some((2, 1)),
            None,
        );
        assert!(d.z_step_um.unwrap().unwrap_err().contains("-1"));
        let d = imagej("ImageJ=\nunit=furlong\nspacing=1\n", Some((2, 1)), None);
        assert!(d.pixel_um.unwrap().unwrap_err().contains("furlong"));
        let d = imagej("ImageJ=\nchannels=2\nslices=5\n", None, None);
        assert!(d.extra_dimensions.unwrap().contains("channels=2"));
        // A resolution tag that is present but zero is named as such (issue 52, item
        // 23), not taken for a missing tag; a zero YResolution is not replaced by X's.
        let text = "ImageJ=1.54f\nimages=5\nunit=micron\n";
        let e = imagej(text, Some((0, 1)), None)
            .pixel_um
            .unwrap()
            .unwrap_err();
        assert!(
            e.contains("XResolution is 0/1") && e.contains("not a usable"),
            "{e}"
        );
        let e = imagej(text, Some((5, 0)), None)
            .pixel_um
            .unwrap()
            .unwrap_err();
        assert!(e.contains("XResolution is 5/0"), "{e}");
        let e = imagej(text, Some((50, 9)), Some((0, 1)))
            .pixel_um
            .unwrap()
            .unwrap_err();
        assert!(e.contains("YResolution is 0/1"), "{e}");
        let e = imagej(text, None, None).pixel_um.unwrap().unwrap_err();
        assert!(e.contains("no XResolution tag"), "{e}");
    }

    #[test]
    fn ome_units_and_order() {
        let xml = r#"<?xml version="1.0" encoding="UTF-8"?>
<OME xmlns="http://www.openmicroscopy.org/Schemas/OME/2016-06">
 <Image ID="Image:0"><Pixels ID="Pixels:0" DimensionOrder="XYZCT" Type="uint16"
   SizeX="4" SizeY="3" SizeZ="3" SizeC="1" SizeT="1"
   PhysicalSizeX="180" PhysicalSizeXUnit="nm" PhysicalSizeY="0.2" PhysicalSizeZ="0.3">
  <Plane TheZ="0" TheC="0" TheT="0" PositionZ="10.6"/>
  <Plane TheZ="1" TheC="0" TheT="0" PositionZ="10.3"/>
  <Plane TheZ="2" TheC="0" TheT="0" PositionZ="10.0"/>
 </Pixels></Image></OME>"#;
        let d = ome(xml).unwrap();
        let ((dx, dy), _) = d.pixel_um.unwrap().unwrap();
        // 180 nm = 0.18 µm; Y without a unit is µm.
        assert!((dx - 0.18).abs() < 1e-15 && dy == 0.2);
        assert_eq!(d.z_step_um.unwrap().unwrap().0, 0.3);
        assert_eq!(d.slices, Some((3, "OME-XML SizeZ")));
        assert_eq!(d.size.unwrap().0, (4, 3));
        assert!(d.top_first.unwrap().unwrap().0);
        assert!(ome("<OME></OME>").unwrap_err().contains("no <Image>"));
        assert!(
            ome("<OME><Image/><Image/></OME>")
                .unwrap_err()
                .contains("2 images")
        );
        assert!(ome("<OME><Image>").unwrap_err().starts_with("OME-XML"));
    }

    #[test]
    fn lsm_record_layout() {
        let mut rec = vec![0u8; 500];
        rec[0..4].copy_from_slice(&0x0400_494Cu32.to_le_bytes());
        rec[4..8].copy_from_slice(&500i32.to_le_bytes());
        for (o, v) in [(8, 6i32), (12, 5), (16, 4), (20, 1), (24, 1), (28, 2)] {
            rec[o..o + 4].copy_from_slice(&v.to_le_bytes());
        }
        for (o, v) in [(40, 1.8e-7f64), (48, 1.8e-7), (56, 3.0e-7)] {
            rec[o..o + 8].copy_from_slice(&v.to_le_bytes());
        }
        let d = lsm(&rec).unwrap();
        let ((dx, _), _) = d.pixel_um.unwrap().unwrap();
        assert!((dx - 0.18).abs() < 1e-12);
        assert!((d.z_step_um.unwrap().unwrap().0 - 0.3).abs() < 1e-12);
        assert_eq!(d.size.unwrap().0, (6, 5));
        assert_eq!(d.slices.unwrap().0, 4);
        assert_eq!(d.full_scale.unwrap().0, 4095.0);
        rec[0] = 0;
        assert!(lsm(&rec).unwrap_err().contains("magic"));
        assert!(lsm(&rec[..20]).unwrap_err().contains("20 bytes"));
    }
}

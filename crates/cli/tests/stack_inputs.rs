//! What a stack's own metadata and noise decide (issue 52, items 9, 20 and the
//! `XResolution` of item 23), on stacks written here with the tiff crate:
//! * OME-TIFF plane positions (`PositionZ`): used for the z step when consistent and
//!   said so in the JSON, refused naming the planes and values when not monotonic,
//!   unevenly spaced or at odds with `PhysicalSizeZ` (the flags still override);
//! * the default background threshold, estimated from the stack's noise: on a stack half
//!   surface, half dark background, the background is left out and the surface kept, in
//!   the proportions the noise model predicts;
//! * an ImageJ stack whose `XResolution` is 0/1 is said to have an unusable resolution,
//!   not a missing tag.

mod common;

use std::path::{Path, PathBuf};
use std::process::Output;

use common::{run, s, stderr};
use tiff::encoder::{Rational, TiffEncoder, colortype::Gray16};
use tiff::tags::{ResolutionUnit, Tag};

fn scratch(name: &str) -> PathBuf {
    common::scratch("stackinputs", name)
}

fn json(o: &Output) -> serde_json::Value {
    assert_eq!(o.status.code(), Some(0), "{}", stderr(o));
    serde_json::from_slice(&o.stdout).unwrap()
}

/// A 16-bit stack, `pages[k]` row-major `nx × ny`, with `description` on page 0 and
/// `XResolution`/`YResolution` `res` pixels per unit (unit none, as ImageJ writes).
fn write_stack(
    path: &Path,
    nx: u32,
    ny: u32,
    pages: &[Vec<u16>],
    description: &str,
    res: Rational,
) {
    let mut file = std::fs::File::create(path).unwrap();
    let mut enc = TiffEncoder::new(&mut file).unwrap();
    for (k, page) in pages.iter().enumerate() {
        let mut img = enc.new_image::<Gray16>(nx, ny).unwrap();
        if k == 0 {
            img.encoder()
                .write_tag(Tag::ImageDescription, description)
                .unwrap();
        }
        img.resolution(ResolutionUnit::None, res.clone());
        img.write_data(page).unwrap();
    }
}

/// `nz` pages of 4 × 3 pixels whose axial response (Gaussian, FWHM 2 slices, peak 60000
/// counts over a floor of 100) peaks on slice 2 exactly.
fn peak_pages(nz: usize) -> Vec<Vec<u16>> {
    (0..nz)
        .map(|k| {
            let u = (k as f64 - 2.0) / 2.0;
            let v = 100.0 + 60000.0 * (-4.0 * 2f64.ln() * u * u).exp();
            vec![v.round() as u16; 12]
        })
        .collect()
}

/// OME-XML of a 4 × 3 × `z.len()` uint16 stack, 0.2 µm pixels, `PhysicalSizeZ` if
/// given, planes at `z` (µm) when `z` is not empty.
fn ome(physical_z: Option<f64>, nz: usize, z: &[f64]) -> String {
    let pz = physical_z.map_or(String::new(), |v| format!(" PhysicalSizeZ=\"{v}\""));
    let planes: String = z
        .iter()
        .enumerate()
        .map(|(k, v)| format!("<Plane TheZ=\"{k}\" TheC=\"0\" TheT=\"0\" PositionZ=\"{v}\" PositionZUnit=\"&#181;m\"/>"))
        .collect();
    format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?><OME xmlns=\"http://www.openmicroscopy.org/Schemas/OME/2016-06\"><Image ID=\"Image:0\"><Pixels ID=\"Pixels:0\" DimensionOrder=\"XYZCT\" Type=\"uint16\" SizeX=\"4\" SizeY=\"3\" SizeZ=\"{nz}\" SizeC=\"1\" SizeT=\"1\" PhysicalSizeX=\"0.2\" PhysicalSizeY=\"0.2\"{pz}>{planes}</Pixels></Image></OME>"
    )
}

#[test]
fn ome_plane_positions_give_the_step_or_are_refused() {
    let d = scratch("ome");
    let one = Rational { n: 1, d: 1 };
    let stack = |name: &str, physical_z: Option<f64>, z: &[f64]| {
        let p = d.join(name);
        write_stack(
            &p,
            4,
            3,
            &peak_pages(5),
            &ome(physical_z, 5, z),
            one.clone(),
        );
        p
    };
    let out = d.join("h.txt");
    let go = |p: &Path, extra: &[&str]| {
        let mut args = vec!["stack", s(p), "--height-out", s(&out), "--json"];
        args.extend(extra);
        run(&args)
    };
    // Consistent positions 0.31 µm apart against PhysicalSizeZ 0.3 (3.3 %, within the
    // 5 % tolerance): the positions' step is used, and said so. The peak on slice 2
    // (exact for the Gaussian fit) is then 2 × 0.31 µm above slice 0.
    let p = stack("even.ome.tif", Some(0.3), &[0.0, 0.31, 0.62, 0.93, 1.24]);
    let v = json(&go(&p, &[]));
    let z = v["stack"]["z_step_um"].as_f64().unwrap();
    assert!((z - 0.31).abs() < 1e-12, "{z}");
    let src = v["stack"]["z_step_source"].as_str().unwrap();
    assert!(
        src.contains("PositionZ") && src.contains("mean step of 5 planes"),
        "{src}"
    );
    let h = v["height_um"]["mean"].as_f64().unwrap();
    assert!((h - 0.62).abs() < 1e-4, "{h}");
    // Decreasing positions: page 0 is the top, from the file.
    let p = stack("down.ome.tif", Some(0.3), &[1.2, 0.9, 0.6, 0.3, 0.0]);
    let v = json(&go(&p, &[]));
    assert_eq!(v["stack"]["first_page"], "top");
    // Not monotonic: refused naming the planes and the values...
    let p = stack("shuffled.ome.tif", Some(0.3), &[0.0, 0.3, 0.2, 0.9, 1.2]);
    std::fs::remove_file(&out).unwrap();
    let o = go(&p, &[]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("not monotonic") && e.contains("TheZ=1 at 0.3") && e.contains("TheZ=2 at 0.2"),
        "{e}"
    );
    assert!(e.contains("shuffled.ome.tif"), "{e}");
    assert!(!out.exists());
    // ...unless the flags give both the step and the order.
    let v = json(&go(&p, &["--z-step-um", "0.3", "--first-page", "bottom"]));
    assert_eq!(v["stack"]["z_step_source"], "option");
    // 0.6 µm apart against PhysicalSizeZ 0.3 (the case): refused naming both.
    let p = stack("double.ome.tif", Some(0.3), &[0.0, 0.6, 1.2, 1.8, 2.4]);
    let e = stderr(&go(&p, &[]));
    assert!(
        e.contains("0.6 µm apart") && e.contains("PhysicalSizeZ says 0.3"),
        "{e}"
    );
    let v = json(&go(&p, &["--z-step-um", "0.3"]));
    assert_eq!(v["stack"]["z_step_um"], 0.3);
    // Unevenly spaced.
    let p = stack("uneven.ome.tif", None, &[0.0, 0.3, 0.9, 1.2, 1.5]);
    let e = stderr(&go(&p, &[]));
    assert!(
        e.contains("not evenly spaced") && e.contains("TheZ=1 to TheZ=2 is 0.6"),
        "{e}"
    );
    // No positions: PhysicalSizeZ, as before.
    let p = stack("plain.ome.tif", Some(0.3), &[]);
    let v = json(&go(&p, &[]));
    assert_eq!(v["stack"]["z_step_um"], 0.3);
    assert!(
        v["stack"]["z_step_source"]
            .as_str()
            .unwrap()
            .contains("PhysicalSizeZ")
    );
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn an_imagej_resolution_of_zero_is_named_as_such() {
    let d = scratch("xres");
    let p = d.join("zero.tif");
    let description = "ImageJ=1.54f\nimages=5\nslices=5\nunit=micron\nspacing=0.3\nloop=false\n";
    write_stack(
        &p,
        4,
        3,
        &peak_pages(5),
        description,
        Rational { n: 0, d: 1 },
    );
    let o = run(&["stack", s(&p), "--height-out", s(&d.join("h.txt"))]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(
        e.contains("XResolution is 0/1") && e.contains("not a usable resolution"),
        "{e}"
    );
    assert!(!e.contains("no XResolution tag"), "{e}");
    // The same stack with a real resolution (5 pixels per micron: 0.2 µm) is read.
    write_stack(
        &p,
        4,
        3,
        &peak_pages(5),
        description,
        Rational { n: 5, d: 1 },
    );
    let v = json(&run(&[
        "stack",
        s(&p),
        "--height-out",
        s(&d.join("h.txt")),
        "--json",
    ]));
    assert_eq!(v["stack"]["pixel_um"][0], 0.2);
    let _ = std::fs::remove_dir_all(&d);
}

/// Standard normal deviates from a fixed xorshift stream (Box–Muller), so the test
/// needs no random-number crate and always draws the same noise.
struct Noise(u64);

impl Noise {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }

    fn normal(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }
}

/// Φ(x) for x ≥ 3 from the asymptotic series of the upper tail.
fn normal_cdf(x: f64) -> f64 {
    assert!(x >= 3.0, "{x}");
    let phi = (-x * x / 2.0).exp() / (2.0 * std::f64::consts::PI).sqrt();
    let x2 = x * x;
    1.0 - phi / x * (1.0 - 1.0 / x2 + 3.0 / (x2 * x2) - 15.0 / (x2 * x2 * x2))
}

/// The noise model (module docs of `flakescatter_confocal::noise`): counts `b + A·g + n`,
/// `b` = 3000, `σ` = 600 counts (0.0092 of full scale), `A` = 30000 on the surface half
/// (columns < 32) and 0 on the dark half; `g` a Gaussian axial response of FWHM 3
/// slices peaking between slices 12 and 27 of 40. A background pixel passes a
/// threshold `t` iff the largest of its 40 samples reaches it:
/// `p = 1 − Φ((t − b)/σ)^40`; a surface pixel's peak sample is `≥ b + 0.87 A − 5σ`
/// (its nearest slice at most half a slice from the peak) with probability `1 − 3e-7`,
/// far above any `t` within a few σ of `b`: none is lost.
#[test]
fn the_default_threshold_drops_a_dark_background_and_keeps_the_surface() {
    let d = scratch("background");
    let (nx, ny, nz) = (64u32, 32u32, 40usize);
    let (b, sigma, a) = (3000.0, 600.0, 30000.0);
    let mut noise = Noise(0x9E37_79B9_7F4A_7C15);
    let peak = |col: u32, row: u32| 12.0 + 15.0 * f64::from(col) / 31.0 + 0.01 * f64::from(row);
    let pages: Vec<Vec<u16>> = (0..nz)
        .map(|k| {
            (0..nx * ny)
                .map(|i| {
                    let (col, row) = (i % nx, i / nx);
                    let signal = if col < nx / 2 {
                        let u = (k as f64 - peak(col, row)) / 3.0;
                        a * (-4.0 * 2f64.ln() * u * u).exp()
                    } else {
                        0.0
                    };
                    (b + signal + sigma * noise.normal())
                        .round()
                        .clamp(0.0, 65535.0) as u16
                })
                .collect()
        })
        .collect();
    let p = d.join("half.tif");
    let description = format!("ImageJ=1.54f\nimages={nz}\nslices={nz}\nunit=micron\nspacing=0.3\n");
    write_stack(&p, nx, ny, &pages, &description, Rational { n: 5, d: 1 });
    let out = d.join("h.txt");
    let o = run(&["stack", s(&p), "--height-out", s(&out), "--json"]);
    let v = json(&o);
    // The value used is printed and in the JSON.
    let level = v["background"]["min_signal"].as_f64().unwrap();
    assert_eq!(v["background"]["source"], "estimated");
    assert!(
        stderr(&o).contains(&format!("background threshold (--min-signal) {level}")),
        "{}",
        stderr(&o)
    );
    // The model's pass probability at the level used (full scale 65535).
    let z = (level * 65535.0 - b) / sigma;
    let p_bg = 1.0 - normal_cdf(z).powi(nz as i32);
    assert!(p_bg < 5e-3, "threshold {z} σ above the floor: p = {p_bg}");
    // Valid pixels per half, from the height map written (NaN = invalid).
    let text = std::fs::read_to_string(&out).unwrap();
    let rows: Vec<Vec<f64>> = text
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| l.split_whitespace().map(|t| t.parse().unwrap()).collect())
        .collect();
    let count = |surface: bool| {
        rows.iter()
            .flat_map(|r| r.iter().enumerate())
            .filter(|(c, h)| ((*c as u32) < nx / 2) == surface && h.is_finite())
            .count()
    };
    let n_half = f64::from(nx / 2 * ny);
    let allowed = n_half * p_bg + 5.0 * (n_half * p_bg).sqrt() + 1.0;
    let kept_bg = count(false);
    assert!(
        (kept_bg as f64) <= allowed,
        "{kept_bg} background pixels kept, at most {allowed:.1} expected"
    );
    assert!((kept_bg as f64) < 0.01 * n_half);
    assert_eq!(count(true) as f64, n_half, "every surface pixel is kept");
    // --min-signal overrides it: 0 keeps most of the background (the old default).
    let v = json(&run(&[
        "stack",
        s(&p),
        "--height-out",
        s(&out),
        "--json",
        "--min-signal",
        "0",
    ]));
    assert_eq!(v["background"]["source"], "given");
    assert!(v["counts"]["valid"].as_f64().unwrap() > n_half * 1.3);
    let _ = std::fs::remove_dir_all(&d);
}

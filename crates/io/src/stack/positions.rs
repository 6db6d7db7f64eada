//! The z positions of an OME-TIFF's planes (`Plane` elements' `PositionZ`, issue 52,
//! item 9): when they are consistent they give the z step and the page order; when they
//! are not, the stack is refused naming the plane and the values, unless options give
//! what they would have decided.
//!
//! Rules, for the z planes of the first channel and time point (`TheC = TheT = 0`):
//! * Either every plane `TheZ = 0 .. SizeZ−1` has a `PositionZ` or none has (then the
//!   z step is `PhysicalSizeZ` and the order the default, as before). A plane without
//!   one among planes with one, a position that is not a number, and one plane given
//!   twice with two positions are refused.
//! * Units: `PositionZUnit` (a length: nm, µm, mm, ...); a plane without one is read in
//!   µm, the unit of `PhysicalSizeZ`'s default (the OME schema's default, "reference
//!   frame", is no length; writers that mean µm omit it). A unit that is not a length
//!   (`reference frame`, `pixel`) gives the order only, not a step.
//! * The positions must change monotonically with `TheZ` (strictly): they give the
//!   page order (increasing: page 0 is the bottom, decreasing: the top), else the order
//!   is refused.
//! * They must be evenly spaced: every step within [`TOLERANCE`] (5 %) of the mean step
//!   `|z_last − z_first| / (SizeZ − 1)`, since the localiser places slice `k` at
//!   `k · step`. 5 % is the spacing tolerance of this crate's text profiles, ten
//!   times the rounding of positions printed to 3 decimals at a 0.01 µm-scale step and
//!   more than the step error of a stage encoder (tens of nm at steps of 0.3 µm and up).
//! * With `PhysicalSizeZ`, the mean step must agree with it within [`TOLERANCE`] of
//!   `PhysicalSizeZ`. Then the mean step of the positions is the z step (the positions
//!   are what the stage did; `PhysicalSizeZ` what was asked of it), and the source says
//!   so; when the two agree to 1e-9 (the rounding of printed positions), the declared
//!   `PhysicalSizeZ` is kept exactly as written, confirmed by the positions.
//!
//! A step problem is reported as the z step's error (an option giving the z step
//! overrides it), an order problem as the page order's (an option giving the first page
//! overrides it).

use std::collections::BTreeMap;

use roxmltree::Node;

use super::meta::{Field, unit_to_um};

/// Relative tolerance of the plane spacing and of its agreement with `PhysicalSizeZ`.
pub const TOLERANCE: f64 = 0.05;

/// What the planes' positions decide: the z step (µm) and the page order (`true`: page
/// 0 is the top), each with its source, or why it cannot be decided. Both `None` when
/// no plane has a position.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Decided {
    pub z_step_um: Field<f64>,
    pub top_first: Field<bool>,
}

/// The planes' positions (in µm when `factor`, the unit's factor to µm, is known; as
/// written in a unit that is no length otherwise).
type Positions = (Vec<f64>, Option<f64>);

/// The positions of the `nz` z planes in `pixels`, or why they are unusable.
fn positions(pixels: Node<'_, '_>, nz: usize) -> Result<Option<Positions>, String> {
    // By TheZ: `nz` comes from the file's SizeZ and is not checked against the pages
    // here, so nothing is allocated by it.
    let mut pos: BTreeMap<usize, (f64, String)> = BTreeMap::new();
    let mut any = false;
    for plane in pixels.children().filter(|n| n.tag_name().name() == "Plane") {
        let the = |k: &str| {
            plane
                .attribute(k)
                .and_then(|v| v.trim().parse::<usize>().ok())
                .unwrap_or(0)
        };
        if the("TheC") != 0 || the("TheT") != 0 {
            continue;
        }
        let z = the("TheZ");
        let Some(text) = plane.attribute("PositionZ") else {
            continue;
        };
        if z >= nz {
            return Err(format!(
                "OME-XML Plane TheZ={z} has PositionZ={text} but SizeZ is {nz}"
            ));
        }
        any = true;
        let v: f64 = text
            .trim()
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite())
            .ok_or_else(|| {
                format!("OME-XML Plane TheZ={z} PositionZ={text:?} is not a finite number")
            })?;
        let unit = plane.attribute("PositionZUnit").unwrap_or("µm").to_string();
        if let Some((w, u)) = pos.get(&z)
            && (*w != v || *u != unit)
        {
            return Err(format!(
                "OME-XML Plane TheZ={z} is given twice, with PositionZ {w} {u} and {v} {unit}"
            ));
        }
        pos.insert(z, (v, unit));
    }
    if !any {
        return Ok(None);
    }
    if pos.len() < nz {
        // Every key is below nz, so one of 0..nz is missing: the first gap, else the end.
        let missing = pos
            .keys()
            .enumerate()
            .find(|(i, z)| *i != **z)
            .map_or(pos.len(), |(i, _)| i);
        return Err(format!(
            "OME-XML Plane TheZ={missing} has no PositionZ while other planes have one"
        ));
    }
    let pos: Vec<(f64, String)> = pos.into_values().collect();
    let unit = &pos[0].1;
    if let Some((k, (_, u))) = pos.iter().enumerate().find(|(_, (_, u))| u != unit) {
        return Err(format!(
            "OME-XML Plane TheZ={k} has PositionZUnit {u:?}, TheZ=0 {unit:?}: one unit for all planes is expected"
        ));
    }
    let factor = unit_to_um(unit);
    Ok(Some((
        pos.iter().map(|(v, _)| v * factor.unwrap_or(1.0)).collect(),
        factor,
    )))
}

/// The page order and z step the planes of `pixels` decide (module docs), against the
/// declared `physical_z` (µm) when there is one.
pub(crate) fn decide(pixels: Node<'_, '_>, nz: usize, physical_z: Option<f64>) -> Decided {
    let mut d = Decided::default();
    let (p, factor) = match positions(pixels, nz) {
        Ok(Some(found)) => found,
        Ok(None) => return d,
        Err(e) => {
            d.z_step_um = Some(Err(e.clone()));
            d.top_first = Some(Err(e));
            return d;
        }
    };
    let unit = if factor.is_some() { "µm" } else { "(unit)" };
    let list = || {
        let v: Vec<String> = p.iter().map(|x| format!("{x}")).collect();
        format!("[{}] {unit}", v.join(", "))
    };
    let total = p[nz - 1] - p[0];
    if let Some(k) = (0..nz - 1).find(|&k| {
        let s = p[k + 1] - p[k];
        s == 0.0 || s.signum() != total.signum()
    }) {
        let e = format!(
            "OME-XML Plane PositionZ is not monotonic in TheZ: TheZ={k} at {} {unit}, TheZ={} at {} {unit} (positions {})",
            p[k],
            k + 1,
            p[k + 1],
            list()
        );
        d.z_step_um = Some(Err(e.clone()));
        d.top_first = Some(Err(e));
        return d;
    }
    let down = total < 0.0;
    d.top_first = Some(Ok((
        down,
        format!(
            "OME-XML Plane PositionZ {} with TheZ (taken as increasing upward)",
            if down { "decreases" } else { "increases" }
        ),
    )));
    let Some(_) = factor else {
        // Positions in a unit that is not a length give the order only.
        return d;
    };
    let mean = total.abs() / (nz - 1) as f64;
    // The step farthest from the mean, if it is too far.
    let off = |k: usize| ((p[k + 1] - p[k]).abs() - mean).abs();
    let worst = (0..nz - 1).max_by(|&a, &b| off(a).total_cmp(&off(b)));
    if let Some(k) = worst.filter(|&k| off(k) > TOLERANCE * mean) {
        d.z_step_um = Some(Err(format!(
            "OME-XML Plane PositionZ is not evenly spaced: TheZ={k} to TheZ={} is {} µm, the mean step is {mean} µm (the farthest step, more than {} % apart; positions {})",
            k + 1,
            (p[k + 1] - p[k]).abs(),
            TOLERANCE * 100.0,
            list()
        )));
        return d;
    }
    d.z_step_um = Some(match physical_z {
        Some(dz) if (mean - dz).abs() > TOLERANCE * dz => Err(format!(
            "OME-XML Plane PositionZ are {mean} µm apart (mean of {} steps) but PhysicalSizeZ says {dz} µm (more than {} % apart)",
            nz - 1,
            TOLERANCE * 100.0
        )),
        // The same step but for the rounding of printed positions: the declared value,
        // exactly as written.
        Some(dz) if (mean - dz).abs() <= 1e-9 * dz => Ok((
            dz,
            format!("OME-XML PhysicalSizeZ, confirmed by the Plane PositionZ of {nz} planes"),
        )),
        Some(dz) => Ok((
            mean,
            format!(
                "OME-XML Plane PositionZ (mean step of {nz} planes; PhysicalSizeZ {dz} µm agrees within {} %)",
                TOLERANCE * 100.0
            ),
        )),
        None => Ok((
            mean,
            format!("OME-XML Plane PositionZ (mean step of {nz} planes; no PhysicalSizeZ)"),
        )),
    });
    d
}

#[cfg(test)]
mod tests {
    use super::super::meta::ome;

    /// OME-XML of a 4 x 3 x `z.len()` stack with `PhysicalSizeZ` (if given) and planes
    /// at `z` (µm unless `unit`).
    fn xml(physical_z: Option<f64>, z: &[&str], unit: Option<&str>) -> String {
        let pz = physical_z.map_or(String::new(), |v| format!(" PhysicalSizeZ=\"{v}\""));
        let u = unit.map_or(String::new(), |u| format!(" PositionZUnit=\"{u}\""));
        let planes: String = z
            .iter()
            .enumerate()
            .map(|(k, v)| {
                format!("<Plane TheZ=\"{k}\" TheC=\"0\" TheT=\"0\" PositionZ=\"{v}\"{u}/>")
            })
            .collect();
        format!(
            "<OME><Image><Pixels SizeX=\"4\" SizeY=\"3\" SizeZ=\"{}\" SizeC=\"1\" SizeT=\"1\" \
             PhysicalSizeX=\"0.2\"{pz}>{planes}</Pixels></Image></OME>",
            z.len()
        )
    }

    #[test]
    fn consistent_positions_give_the_step_and_the_order() {
        // Steps 0.30, 0.31, 0.29 µm: mean (10.9 − 10.0)/3 = 0.3, each within 5 % of it,
        // and 0.3 agrees with PhysicalSizeZ 0.3 (to rounding): the declared value kept.
        let d = ome(&xml(Some(0.3), &["10.0", "10.3", "10.61", "10.9"], None)).unwrap();
        let (dz, src) = d.z_step_um.unwrap().unwrap();
        assert_eq!(dz, 0.3);
        assert!(src.contains("confirmed by the Plane PositionZ"), "{src}");
        assert!(!d.top_first.unwrap().unwrap().0);
        // Mean 0.31 µm against PhysicalSizeZ 0.3 (3.3 % apart): the positions' step.
        let d = ome(&xml(Some(0.3), &["0", "0.31", "0.62"], None)).unwrap();
        let (dz, src) = d.z_step_um.unwrap().unwrap();
        assert!((dz - 0.31).abs() < 1e-12, "{dz}");
        assert!(
            src.contains("mean step of 3 planes") && src.contains("agrees within 5 %"),
            "{src}"
        );
        // In nm, decreasing (page 0 the top), no PhysicalSizeZ: 250 nm = 0.25 µm.
        let d = ome(&xml(None, &["1000", "750", "500"], Some("nm"))).unwrap();
        assert!((d.z_step_um.unwrap().unwrap().0 - 0.25).abs() < 1e-12);
        assert!(d.top_first.unwrap().unwrap().0);
        // No positions at all: PhysicalSizeZ, order not stated.
        let d = ome(&xml(Some(0.3), &[], None).replace("SizeZ=\"0\"", "SizeZ=\"3\"")).unwrap();
        assert_eq!(d.z_step_um.unwrap().unwrap().0, 0.3);
        assert!(d.top_first.is_none());
    }

    #[test]
    fn a_huge_size_z_allocates_nothing_and_names_the_missing_plane() {
        // Three planes with positions, SizeZ claiming 10^12 (and u64::MAX): the
        // positions were once held in a vector of SizeZ entries, so the reader aborted
        // allocating 32 TB. Now the first plane without a position is named.
        for size in ["1000000000000", "18446744073709551615"] {
            let text = xml(Some(0.3), &["0", "0.3", "0.6"], None)
                .replace("SizeZ=\"3\"", &format!("SizeZ=\"{size}\""));
            let d = ome(&text).unwrap();
            let e = d.z_step_um.unwrap().unwrap_err();
            assert!(e.contains("TheZ=3 has no PositionZ"), "{size}: {e}");
        }
    }

    #[test]
    fn inconsistent_positions_are_refused_naming_plane_and_values() {
        // Not monotonic: the order and the step are both refused, TheZ 1 -> 2 named.
        let d = ome(&xml(Some(0.3), &["10.0", "10.3", "10.1", "10.9"], None)).unwrap();
        let e = d.z_step_um.unwrap().unwrap_err();
        assert!(
            e.contains("not monotonic")
                && e.contains("TheZ=1 at 10.3")
                && e.contains("TheZ=2 at 10.1"),
            "{e}"
        );
        assert!(d.top_first.unwrap().is_err());
        // 0.6 µm apart against PhysicalSizeZ 0.3 (the case): the order stands,
        // the step is refused naming both.
        let d = ome(&xml(Some(0.3), &["0", "0.6", "1.2", "1.8"], None)).unwrap();
        let e = d.z_step_um.unwrap().unwrap_err();
        assert!(
            e.contains("0.6 µm apart") && e.contains("PhysicalSizeZ says 0.3"),
            "{e}"
        );
        assert!(!d.top_first.unwrap().unwrap().0);
        // Uneven: 0.3 then 0.5 then 0.3 (mean 0.3667; 0.5 is 36 % off).
        let d = ome(&xml(None, &["0", "0.3", "0.8", "1.1"], None)).unwrap();
        let e = d.z_step_um.unwrap().unwrap_err();
        assert!(
            e.contains("not evenly spaced") && e.contains("TheZ=1 to TheZ=2"),
            "{e}"
        );
        // Just inside and just outside the 5 % agreement with PhysicalSizeZ.
        let at = |mean: f64| {
            let z: Vec<String> = (0..3).map(|k| format!("{}", k as f64 * mean)).collect();
            let z: Vec<&str> = z.iter().map(String::as_str).collect();
            ome(&xml(Some(0.3), &z, None)).unwrap().z_step_um.unwrap()
        };
        assert!(at(0.3 * 1.049).is_ok() && at(0.3 * 0.951).is_ok());
        assert!(at(0.3 * 1.051).is_err() && at(0.3 * 0.949).is_err());
        // A plane without a position among planes with one; a position that is no number.
        let partial = xml(Some(0.3), &["0", "0.3", "0.6"], None).replace(" PositionZ=\"0.3\"", "");
        let e = ome(&partial).unwrap().z_step_um.unwrap().unwrap_err();
        assert!(e.contains("TheZ=1 has no PositionZ"), "{e}");
        let e = ome(&xml(None, &["0", "x", "0.6"], None))
            .unwrap()
            .z_step_um
            .unwrap()
            .unwrap_err();
        assert!(e.contains("TheZ=1 PositionZ=\"x\""), "{e}");
        // A unit that is not a length gives the order only.
        let d = ome(&xml(Some(0.3), &["0", "7", "9"], Some("reference frame"))).unwrap();
        assert_eq!(d.z_step_um.unwrap().unwrap().0, 0.3);
        assert!(!d.top_first.unwrap().unwrap().0);
    }
}

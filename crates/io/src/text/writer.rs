//! A height map or an intensity image written as a text matrix.

use flakescatter_stats::heightmap::HeightMap;

/// Writes `map` as a plain-text matrix: a `#` header (Gwyddion-style size and units, plus
/// exact `Pitch x`/`Pitch y` lines), then one line per row of heights in µm in Rust's
/// shortest round-trip notation, `NaN` for invalid points. Reading it back gives the same
/// heights (bit for bit), mask and pitch.
pub fn write_text_string(map: &HeightMap) -> String {
    write_text_with(map, "height", "# Value units: µm\n")
}

/// Writes an intensity image (unit-less values) as a plain-text matrix: as
/// [`write_text_string`] but with channel `intensity` and no value unit, so the numbers
/// are the values themselves ([`crate::read_intensity`] reads them back exactly).
pub fn write_intensity_text_string(map: &HeightMap) -> String {
    write_text_with(map, "intensity", "")
}

pub(super) fn write_text_with(map: &HeightMap, channel: &str, unit_line: &str) -> String {
    let mut out = String::with_capacity(map.len() * 12 + 200);
    out.push_str(&format!(
        "# Channel: {channel}\n# Width: {} µm\n# Height: {} µm\n# Pitch x: {} µm\n# Pitch y: {} µm\n{unit_line}",
        map.dx() * map.nx() as f64,
        map.dy() * map.ny() as f64,
        map.dx(),
        map.dy()
    ));
    for row in 0..map.ny() {
        for col in 0..map.nx() {
            if col > 0 {
                out.push(' ');
            }
            match map.get(col, row) {
                Some(z) => out.push_str(&format!("{z:e}")),
                None => out.push_str("NaN"),
            }
        }
        out.push('\n');
    }
    out
}

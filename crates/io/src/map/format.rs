//! The height-map formats: their names, descriptions, signatures and extensions.

use std::fmt;

/// The height-map file formats this crate understands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MapFormat {
    /// ISO 25178-72 XML 3D surface profile (a zip archive).
    X3p,
    /// ISO 25178-71 surface data file, text (`aISO-1.0`, `aISO-2.0`) or binary
    /// (`bISO-1.0`, `bISO-2.0`).
    Sdf,
    /// Plain-text matrix (whitespace, comma or semicolon separated), Gwyddion `#`
    /// headers understood.
    Text,
    /// Gwyddion native file (`GWYP` magic), one channel per data field.
    Gwy,
    /// Sensofar PLu topography (no magic; recognised from its header).
    Plu,
    /// Zygo MetroPro phase map (`.dat`).
    MetroPro,
    /// Wyko / Bruker Vision OPD (`.opd`).
    Opd,
    /// Digital Surf SUR (MountainsMap), one channel per object.
    Sur,
    /// Alicona AL3D depth image (focus variation).
    Al3d,
    /// FRT MicroProf (`.frt`), one channel per image (topography, intensity, ...).
    Frt,
    /// Zarr v3 store (a directory holding `zarr.json`, [`crate::zarr`]): channel 0 the
    /// `height` array, then `intensity` if present. Not in [`MapFormat::ALL`]: a store
    /// is a directory, never recognised from a file's bytes.
    Zarr,
}

impl MapFormat {
    /// Every format read from a file's bytes, in detection order ([`MapFormat::Zarr`],
    /// a directory, is not among them).
    pub const ALL: [MapFormat; 10] = [
        MapFormat::X3p,
        MapFormat::Sdf,
        MapFormat::Text,
        MapFormat::Gwy,
        MapFormat::Plu,
        MapFormat::MetroPro,
        MapFormat::Opd,
        MapFormat::Sur,
        MapFormat::Al3d,
        MapFormat::Frt,
    ];

    /// Short lower-case name: `x3p`, `sdf` or `text`.
    pub fn name(self) -> &'static str {
        match self {
            MapFormat::X3p => "x3p",
            MapFormat::Sdf => "sdf",
            MapFormat::Text => "text",
            MapFormat::Gwy => "gwy",
            MapFormat::Al3d => "al3d",
            MapFormat::Sur => "sur",
            MapFormat::Opd => "opd",
            MapFormat::MetroPro => "metropro",
            MapFormat::Plu => "plu",
            MapFormat::Frt => "frt",
            MapFormat::Zarr => "zarr",
        }
    }

    /// What a file of this format is, for messages: `an X3P file`, ...
    pub fn description(self) -> &'static str {
        match self {
            MapFormat::X3p => "an X3P file (ISO 25178-72)",
            MapFormat::Sdf => "an SDF file (ISO 25178-71)",
            MapFormat::Text => "a plain-text matrix",
            MapFormat::Gwy => "a Gwyddion GWY file",
            MapFormat::Al3d => "an Alicona AL3D file",
            MapFormat::Sur => "a Digital Surf SUR file",
            MapFormat::Opd => "a Wyko OPD file",
            MapFormat::MetroPro => "a Zygo MetroPro DAT file",
            MapFormat::Plu => "a Sensofar PLU file",
            MapFormat::Frt => "an FRT MicroProf file",
            MapFormat::Zarr => "a Zarr v3 store",
        }
    }

    /// What content of this format must look like, for messages.
    pub(super) fn signature(self) -> &'static str {
        match self {
            MapFormat::X3p => "it is not a zip archive, so not an X3P file",
            MapFormat::Sdf => {
                "it does not start with aISO- or bISO-, so not an ISO 25178-71 SDF file"
            }
            MapFormat::Text => "it holds bytes that do not occur in text, so not a text matrix",
            MapFormat::Gwy => "it does not start with GWYP, so not a Gwyddion GWY file",
            MapFormat::Al3d => "it does not start with AliconaImaging, so not an Alicona AL3D file",
            MapFormat::Sur => "it does not start with DIGITAL SURF, so not a Digital Surf SUR file",
            MapFormat::Opd => {
                "it does not have the OPD Directory block at byte 2, so not a Wyko OPD file"
            }
            MapFormat::MetroPro => {
                "it does not start with a MetroPro magic (88 1B 03 6F..71), so not a Zygo MetroPro file"
            }
            MapFormat::Plu => {
                "it lacks the PLU header (a date, a topography type and matching sizes), so not a Sensofar PLU file"
            }
            MapFormat::Frt => "it does not start with FRTM_GLIDERV, so not an FRT MicroProf file",
            MapFormat::Zarr => {
                "it is a file, not a directory holding zarr.json, so not a Zarr v3 store"
            }
        }
    }

    /// File extensions (lower case, without the dot) that name this format.
    pub fn extensions(self) -> &'static [&'static str] {
        match self {
            MapFormat::X3p => &["x3p"],
            MapFormat::Sdf => &["sdf"],
            MapFormat::Text => &["txt", "csv", "asc", "tsv"],
            MapFormat::Gwy => &["gwy"],
            MapFormat::Al3d => &["al3d"],
            MapFormat::Sur => &["sur"],
            MapFormat::Opd => &["opd"],
            // `.dat` is also common for text matrices: the content alone decides.
            MapFormat::MetroPro => &[],
            MapFormat::Plu => &["plu", "apx"],
            MapFormat::Frt => &["frt"],
            MapFormat::Zarr => &["zarr"],
        }
    }

    /// The format an extension names (case-insensitive, without the dot), if any.
    pub fn from_extension(ext: &str) -> Option<Self> {
        let ext = ext.to_ascii_lowercase();
        Self::ALL
            .into_iter()
            .chain([MapFormat::Zarr])
            .find(|f| f.extensions().contains(&ext.as_str()))
    }
}

impl fmt::Display for MapFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

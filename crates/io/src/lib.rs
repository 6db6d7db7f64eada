//! File formats for flakescatter: height maps (X3P, ISO 25178-71 SDF, plain-text
//! matrices with Gwyddion headers), flake tables, histograms, measured curves,
//! detector lists and spectral files (optical constants, reflectance spectra, measured
//! multi-angle colour).
//!
//! Only this crate (and the CLI) touches files. Every height-map reader returns a
//! [`HeightMap`](flakescatter_stats::heightmap::HeightMap) in micrometres (heights and
//! pitch), row-major with `x` along columns, with an explicit validity mask; the format
//! is recognised from the file's content ([`MapFormat::detect`]), and a file extension
//! that names another format is an error.
//!
//! Module shape: [`reader`] holds what the format modules share (options, value kind,
//! channels); each format is one module ([`x3p`], [`sdf`], [`text`]) that imports only
//! [`reader`] and [`units`]; [`map`] detects and dispatches. The CSV tables
//! ([`flakes`], [`measured`], [`detectors`], [`curves`]) share one reader ([`table`]) that names the
//! file, line and column in every error.
//!
//! ```
//! use flakescatter_io::{read_map_bytes, x3p::write_x3p_bytes, MapFormat, ReadOptions};
//! use flakescatter_stats::heightmap::HeightMap;
//!
//! // A 3 x 2 map (µm) with one invalid point, 0.5 µm x 0.25 µm pixels.
//! let map = HeightMap::new(3, 2, 0.5, 0.25, vec![0.0, 1.5, f64::NAN, -2.0, 0.25, 3.0])?;
//! let bytes = write_x3p_bytes(&map)?;
//! let (back, format) = read_map_bytes(&bytes, &ReadOptions::default())?;
//! assert_eq!(format, MapFormat::X3p);
//! assert_eq!((back.nx(), back.ny(), back.dx(), back.dy()), (3, 2, 0.5, 0.25));
//! assert_eq!(back.valid_count(), 5);
//! assert_eq!(back.get(1, 0), Some(1.5));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod al3d;
pub mod brdf;
mod bytes;
pub mod channel;
pub mod curves;
pub mod detectors;
pub mod files;
pub mod flakes;
pub mod format_error;
pub mod frt;
pub mod gwy;
pub mod map;
pub mod measured;
pub mod merl;
pub mod metropro;
pub mod opd;
pub mod plu;
pub mod provenance;
pub mod quantity;
pub mod reader;
pub mod sdf;
pub mod select;
pub mod spectral;
pub mod stack;
pub mod sur;
pub mod table;
pub mod text;
pub mod units;
pub mod x3p;
pub mod zarr;

pub use channel::{ChannelError, ChannelSelector, describe_channels};
pub use map::{
    MapError, MapFormat, ReadMapError, WriteMapError, list_channels, list_channels_bytes,
    read_bytes, read_intensity, read_intensity_bytes, read_map, read_map_bytes, write_intensity,
    write_map,
};
pub use reader::{Channel, Confidence, DecimalMark, ReadOptions, ValueKind};
pub use select::{SelectedRead, read_selected, read_selected_bytes};
pub use stack::{
    PageOrder, ReadStackError, SampleType, StackError, StackFormat, StackInfo, StackOptions,
    StackReader,
};
pub use table::TableError;
pub use units::ZUnit;

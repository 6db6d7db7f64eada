//! The format dispatcher on arbitrary bytes: detection, the extension check (second
//! byte: which extension the "file" has), channel listing and every reader behind it.
#![no_main]

use flakescatter_io::{MapFormat, list_channels_bytes, read_bytes};
use libfuzzer_sys::fuzz_target;

#[path = "options.rs"]
mod options;

const EXTENSIONS: [Option<&str>; 12] = [
    None,
    Some("x3p"),
    Some("sdf"),
    Some("txt"),
    Some("CSV"),
    Some("dat"),
    Some("gwy"),
    Some("plu"),
    Some("opd"),
    Some("sur"),
    Some("al3d"),
    Some("FRT"),
];

fuzz_target!(|data: &[u8]| {
    if let Some((options, kind, rest)) = options::split(data)
        && let Some((&e, bytes)) = rest.split_first()
    {
        let ext = EXTENSIONS[usize::from(e) % EXTENSIONS.len()];
        let _ = MapFormat::detect(bytes);
        let _ = list_channels_bytes(bytes, ext, &options);
        if let Ok((map, _)) = read_bytes(bytes, ext, &options, kind) {
            // What a reader returns is a well-formed map.
            assert_eq!(map.heights().len(), map.nx() * map.ny());
            assert!(map.dx().is_finite() && map.dx() > 0.0);
            assert!(map.dy().is_finite() && map.dy() > 0.0);
        }
    }
});

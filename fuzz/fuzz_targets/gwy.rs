//! The gwy reader (Gwyddion GWY) on arbitrary bytes (first byte: reader options):
//! detection, channel listing and reads return a value or an error, never panic, hang
//! or allocate beyond what the input can hold, and a map a read returns is well-formed.
//! Besides the read the options ask for, every listed channel (up to 8) is read as the
//! options' kind, so that the image, intensity and later-object paths are reached
//! (the options byte alone only asks for channel 0 or the default).
#![no_main]

use flakescatter_io::gwy;
use libfuzzer_sys::fuzz_target;

#[path = "options.rs"]
mod options;

fuzz_target!(|data: &[u8]| {
    if let Some((mut options, kind, bytes)) = options::split(data) {
        let _ = gwy::detect(bytes);
        let count = gwy::channels(bytes, &options).map_or(0, |c| c.len());
        let mut asked = vec![options.channel];
        asked.extend((0..count.min(8)).map(Some));
        for channel in asked {
            options.channel = channel;
            if let Ok(map) = gwy::read(bytes, &options, kind) {
                assert_eq!(map.heights().len(), map.nx() * map.ny());
                assert!(map.dx().is_finite() && map.dx() > 0.0);
                assert!(map.dy().is_finite() && map.dy() > 0.0);
            }
        }
    }
});

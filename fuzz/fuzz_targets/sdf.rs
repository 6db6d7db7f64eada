//! The sdf reader on arbitrary bytes (first byte: reader options): it returns a map or
//! an error, never panics, hangs or allocates beyond what the input can hold.
#![no_main]

use flakescatter_io::sdf;
use libfuzzer_sys::fuzz_target;

#[path = "options.rs"]
mod options;

fuzz_target!(|data: &[u8]| {
    if let Some((options, kind, bytes)) = options::split(data) {
        let _ = sdf::read(bytes, &options, kind);
        let _ = sdf::channels(bytes, &options);
    }
});

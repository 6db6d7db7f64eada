//! The x3p reader on arbitrary bytes (first byte: reader options): it returns a map or
//! an error, never panics, hangs or allocates beyond what the input can hold.
#![no_main]

use flakescatter_io::x3p;
use libfuzzer_sys::fuzz_target;

#[path = "options.rs"]
mod options;

fuzz_target!(|data: &[u8]| {
    if let Some((options, kind, bytes)) = options::split(data) {
        let _ = x3p::read(bytes, &options, kind);
        let _ = x3p::channels(bytes, &options);
    }
});

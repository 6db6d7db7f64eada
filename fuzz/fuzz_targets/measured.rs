//! The measured CSV reader on arbitrary bytes: a table or an error naming the file, never a
//! panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Err(e) = flakescatter_io::measured::read_measured_from(data, "fuzz.csv") {
        // Every message names the file.
        assert!(e.to_string().contains("fuzz.csv"), "{e}");
    }
});

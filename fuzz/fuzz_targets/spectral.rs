//! The spectral file readers (optical constants, coat index, binder absorption, spectra,
//! measured multi-angle colour) on arbitrary bytes, the first byte choosing the reader:
//! a table or an error naming the file, never a panic.
#![no_main]

use flakescatter_io::spectral;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&which, bytes)) = data.split_first() else {
        return;
    };
    let name = "fuzz.csv";
    let err = match which % 5 {
        0 => spectral::read_complex_index_from(bytes, name).err(),
        1 => spectral::read_coat_index_from(bytes, name).err(),
        2 => spectral::read_absorption_from(bytes, name).err(),
        3 => spectral::read_spectra_from(bytes, name).err(),
        _ => spectral::read_multiangle_from(bytes, name).err(),
    };
    if let Some(e) = err {
        // Every message names the file.
        assert!(e.to_string().contains(name), "{e}");
    }
});

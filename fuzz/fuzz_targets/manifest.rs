//! The `analyze` sample manifest (TOML) on arbitrary bytes: a manifest whose every key
//! passed its checks (and passes them again), or an error naming the file, never a panic.
#![no_main]

use flakescatter::analyze::Manifest;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    match Manifest::from_toml(&text, "fuzz.toml") {
        Ok(m) => {
            assert!(m.validate("fuzz.toml").is_ok());
            // An accepted channel key resolves to a selector or says why not.
            for key in [&m.maps.channel, &m.maps.intensity_channel].into_iter().flatten() {
                if let Err(e) = key.selector() {
                    assert!(!e.is_empty());
                }
            }
        }
        Err(e) => assert!(e.to_string().starts_with("fuzz.toml: "), "{e}"),
    }
});

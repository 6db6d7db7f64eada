//! Shared by the io tests and the `read_x3p` bench (included with `#[path]`): an X3P
//! archive re-packed with every member deflated, as other software writes one.

use std::io::{Read, Write};

/// The archive `x3p` with every member deflated at level 1 by the zip crate (the
/// writer's own level; it stores a `data.bin` of noisy heights, which this deflates).
pub fn deflate_members(x3p: &[u8]) -> Vec<u8> {
    let mut archive = zip::ZipArchive::new(std::io::Cursor::new(x3p)).expect("zip archive");
    let mut out = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let opts = zip::write::SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated)
        .compression_level(Some(1));
    for k in 0..archive.len() {
        let mut member = archive.by_index(k).expect("member");
        let name = member.name().expect("member name").into_owned();
        let mut bytes = Vec::new();
        member.read_to_end(&mut bytes).expect("member bytes");
        out.start_file(name.as_str(), opts).expect("start member");
        out.write_all(&bytes).expect("write member");
    }
    out.finish().expect("finish archive").into_inner()
}

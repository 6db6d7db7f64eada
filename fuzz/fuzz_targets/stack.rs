//! The z-stack reader on arbitrary bytes (first byte: which voxel sizes the options
//! supply): it opens the stack and streams every slice, or gives an error; never panics,
//! hangs or allocates beyond what the header allows after its plausibility checks. A
//! slice that is returned has the stack's `nx × ny` samples.
#![no_main]

use std::io::Cursor;

use flakescatter_io::{PageOrder, StackOptions, StackReader};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&flags, bytes)) = data.split_first() else {
        return;
    };
    let options = StackOptions {
        pixel_um: (flags & 1 != 0).then_some((0.2, 0.25)),
        z_step_um: (flags & 2 != 0).then_some(0.3),
        first_page: match (flags >> 2) & 3 {
            1 => Some(PageOrder::TopFirst),
            2 => Some(PageOrder::BottomFirst),
            _ => None,
        },
    };
    if let Ok(mut r) = StackReader::new(Cursor::new(bytes), &options) {
        let n = r.info().nx * r.info().ny;
        while let Ok(Some(slice)) = r.next_slice() {
            assert_eq!(slice.len(), n);
        }
    }
});

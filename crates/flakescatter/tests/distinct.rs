//! Maps that are the same data (issue 52, item 7): copies, hard links and `..` found,
//! files of equal length but other bytes not.

use std::path::PathBuf;

use flakescatter::distinct::{Sameness, find_duplicate_maps};
use flakescatter::inputs::MapSource;

#[test]
fn copies_links_and_distinct_files() {
    let d = std::env::temp_dir().join(format!("fs-distinct-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    let w = |n: &str, b: &[u8]| {
        let p = d.join(n);
        std::fs::write(&p, b).unwrap();
        p
    };
    let a = w("a.txt", b"1 2\n3 4\n");
    let copy = w("copy.txt", b"1 2\n3 4\n");
    // Same length, other bytes: not a duplicate.
    let other = w("other.txt", b"1 2\n3 5\n");
    let hard = d.join("hard.txt");
    std::fs::hard_link(&a, &hard).unwrap();
    let dotted = d.join("sub/../a.txt");
    std::fs::create_dir_all(d.join("sub")).unwrap();
    let src = |p: &PathBuf| MapSource::new(p, None);
    let found =
        find_duplicate_maps(&[src(&a), src(&other), src(&copy), src(&hard), src(&dotted)]).unwrap();
    let pairs: Vec<(usize, usize, bool)> = found
        .iter()
        .map(|f| (f.first, f.second, f.why == Sameness::SameFile))
        .collect();
    // The copy repeats `a` by content; the hard link and `sub/..` are `a` itself.
    assert_eq!(pairs, [(0, 2, false), (0, 3, true), (0, 4, true)]);
    // SHA-256 of the bytes, computed independently (FIPS 180-2 engine in `io`).
    let expect = flakescatter_io::files::sha256_bytes(b"1 2\n3 4\n");
    assert_eq!(found[0].why, Sameness::SameContent(expect));
    assert!(found[0].to_string().contains("copy.txt"));
    assert!(
        find_duplicate_maps(&[src(&a), src(&other)])
            .unwrap()
            .is_empty()
    );
    std::fs::remove_dir_all(&d).unwrap();
}

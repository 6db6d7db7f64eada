//! The committed fixtures are exactly what `cargo xtask fixtures` produces now.

#[test]
fn committed_fixtures_are_byte_identical_to_a_fresh_generation() {
    let dir = xtask::workspace_root().join("fixtures");
    let stale = xtask::fixtures::stale_files(&dir).unwrap();
    assert!(
        stale.is_empty(),
        "out of date: {stale:?}; run `cargo xtask fixtures` and commit the result"
    );
}

#[test]
fn fixture_truth_tables_match_their_maps() {
    // Independent of the generator's own bookkeeping: the truth table's pixel counts must
    // add up to the number of bright pixels in the committed intensity map (midpoint
    // cutoff 0.49, levels 0.9 / 0.08 with noise sd 0.03 are 13.7 sd apart).
    let dir = xtask::workspace_root().join("fixtures");
    for f in xtask::fixtures::FIXTURES {
        let truth = std::fs::read_to_string(dir.join(format!("{}.truth.csv", f.name))).unwrap();
        let mut lines = truth.lines();
        let header: Vec<&str> = lines.next().unwrap().split(',').collect();
        let col = header.iter().position(|h| *h == "visible_pixels").unwrap();
        let visible: usize = lines
            .map(|l| l.split(',').nth(col).unwrap().parse::<usize>().unwrap())
            .sum();
        let (map, _) = flakescatter_io::read_intensity(
            dir.join(format!("{}.intensity.x3p", f.name)),
            &flakescatter_io::ReadOptions::default(),
        )
        .unwrap();
        let bright = map.heights().iter().filter(|v| **v >= 0.49).count();
        assert_eq!(bright, visible, "{}", f.name);
    }
}

//! Peak memory of `topo` and `stats --pixel-normals-only` streaming a map larger than
//! 2 GB (issue 49: at most 0.25× the map's float64 size, whatever the map's size).
//!
//! [`measure`] builds the release CLI, writes a [`SIDE`]² synthetic height map (tilted
//! square facets of 16 pixels with a little noise, 0.5 µm pitch: 2.1 GB of float64) as
//! a Zarr store in chunks of 1024² points (zstd) under `<target>/bench-streamed/`, runs
//! each command of [`COMMANDS`] on it under `/usr/bin/time -v` (as [`super::memory`])
//! and deletes the store. Writing the map holds it whole in this process, which is not
//! the one measured. `cargo xtask bench --streamed` runs this alone
//! (`--streamed=LABEL` only the rows whose label starts with `LABEL`, e.g.
//! `--streamed=stats`); the full bench adds its table to `docs/benchmarks.md`.

use std::fmt::Write as _;
use std::path::Path;

use super::memory::MemoryRow;

/// Map side of the streamed runs, pixels.
pub const SIDE: usize = 16_384;

/// The commands measured: a label and the arguments after `flakescatter` (`{map}` and
/// `{dir}` are replaced by paths). `stats` is measured with `--pixel-normals-only`:
/// with `--pixel-normals` it segments each map whole, so it reads the store into
/// memory.
pub const COMMANDS: [(&str, &str); 3] = [
    (
        "topo, streamed",
        "topo {map} --theta-i 45 --out {dir}/topo.csv",
    ),
    (
        "topo --isotropic, streamed",
        "topo {map} --isotropic --theta-i 45 --out {dir}/iso.csv",
    ),
    (
        "stats --pixel-normals-only, streamed",
        "stats --map {map} --pixel-normals-only --out {dir}/pixels.csv",
    ),
];

/// Bytes of the map's heights as float64.
#[must_use]
pub fn map_bytes() -> f64 {
    (SIDE * SIDE * 8) as f64
}

/// The limit of issue 49: a quarter of the map's float64 size.
#[must_use]
pub fn limit_bytes() -> f64 {
    0.25 * map_bytes()
}

/// Writes the synthetic map as the Zarr store `store`.
///
/// # Errors
/// The store cannot be written.
pub fn write_store(store: &Path) -> anyhow::Result<()> {
    use flakescatter_io::zarr::{ZarrWriteOptions, write_zarr};
    use flakescatter_stats::heightmap::HeightMap;
    // A seeded hash per facet and point (splitmix64), so that the map needs no state.
    let unit = |i: u64| -> f64 {
        let mut z = i.wrapping_add(0x9E37_79B9_7F4A_7C15);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        (z ^ (z >> 31)) as f64 / 2f64.powi(64)
    };
    let pitch = 0.5;
    let mut z = vec![0.0; SIDE * SIDE];
    for (r, row) in z.chunks_mut(SIDE).enumerate() {
        for (c, v) in row.iter_mut().enumerate() {
            let facet = ((r / 16) * (SIDE / 16) + c / 16) as u64;
            let (a, b) = (0.3 * unit(facet) - 0.15, 0.3 * unit(facet ^ 0xABCD) - 0.15);
            *v = a * (c % 16) as f64 * pitch
                + b * (r % 16) as f64 * pitch
                + 0.01 * unit((r * SIDE + c) as u64 + (1 << 40));
        }
    }
    let map = HeightMap::new(SIDE, SIDE, pitch, pitch, z)?;
    let options = ZarrWriteOptions {
        chunk: (1024, 1024),
        ..ZarrWriteOptions::default()
    };
    write_zarr(&map, None, store, &options)?;
    Ok(())
}

/// Builds the release CLI, writes the store, measures every command whose label
/// starts with `only` (all with `None`) and deletes the store.
///
/// # Errors
/// No command's label starts with `only`, the CLI does not build or the store cannot
/// be written.
pub fn measure(
    cargo: &str,
    root: &Path,
    target: &Path,
    only: Option<&str>,
) -> anyhow::Result<Vec<MemoryRow>> {
    use anyhow::Context;
    let chosen: Vec<(&'static str, &'static str)> = COMMANDS
        .into_iter()
        .filter(|(label, _)| only.is_none_or(|o| label.starts_with(o)))
        .collect();
    if chosen.is_empty() {
        let labels: Vec<&str> = COMMANDS.iter().map(|c| c.0).collect();
        anyhow::bail!(
            "--streamed={}: no streamed row's label starts with it (rows: {})",
            only.unwrap_or_default(),
            labels.join("; ")
        );
    }
    let cli = super::memory::release_cli(cargo, root, target)?;
    let dir = target.join("bench-streamed");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let store = dir.join("big.zarr");
    write_store(&store).with_context(|| format!("cannot write {}", store.display()))?;
    let mut rows = Vec::new();
    for (label, args) in chosen {
        let command = args.replace("{map}", "big.zarr").replace("{dir}", ".");
        let peak_bytes = super::memory::peak_rss(&cli, &command, &dir)?;
        rows.push(MemoryRow {
            label,
            command: format!("flakescatter {command}"),
            peak_bytes,
        });
    }
    std::fs::remove_dir_all(&dir).with_context(|| format!("cannot remove {}", dir.display()))?;
    Ok(rows)
}

/// The streamed-memory section of `docs/benchmarks.md`.
#[must_use]
pub fn render(rows: &[MemoryRow]) -> String {
    let (map, limit) = (map_bytes(), limit_bytes());
    let mut s = format!(
        "\n## Peak memory, streamed\n\n\
         Commands on a {SIDE}² map written as a Zarr store in chunks of 1024² points \
         (synthetic tilted facets, 0.5 µm pitch), read band by band; peak resident set \
         size from `/usr/bin/time -v`. The map's heights as float64 are {:.0} MB; the \
         target (issue 49) is at most 0.25× that, {:.0} MB.\n\n\
         | Command | Peak memory | × map float64 | Target | Met |\n|---|---:|---:|---|:---:|\n",
        map / 1e6,
        limit / 1e6
    );
    for r in rows {
        let (peak, times, met) = match &r.peak_bytes {
            Ok(b) => (
                format!("{:.0} MB", b / 1e6),
                format!("{:.3}×", b / map),
                if *b <= limit { "yes" } else { "no" },
            ),
            Err(why) => (format!("not measured ({why})"), "—".to_owned(), "—"),
        };
        let _ = writeln!(
            s,
            "| {} (`{}`) | {peak} | {times} | ≤ {:.0} MB | {met} |",
            r.label,
            r.command,
            limit / 1e6
        );
    }
    s
}

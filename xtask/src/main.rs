//! Project automation, run as `cargo xtask <task>`.

fn main() -> anyhow::Result<()> {
    let task = std::env::args().nth(1);
    match task.as_deref() {
        None | Some("help" | "--help" | "-h") => {
            println!("usage: cargo xtask <task>\n\ntasks:\n  help   this text");
            Ok(())
        }
        Some(other) => anyhow::bail!("unknown xtask `{other}` (try `cargo xtask help`)"),
    }
}

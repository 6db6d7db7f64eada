//! One module per subcommand: each has `Args` (clap) and `run(Args) -> anyhow::Result<()>`.
pub mod analyze;
pub mod colour;
pub mod compare;
pub mod convert;
pub mod export;
pub mod film;
pub mod fit;
pub mod info;
pub mod model;
pub mod paint;
pub mod reproduce;
pub mod segment;
pub mod stack;
pub mod stats;
pub mod synth;
pub mod topo;
pub mod volume;

//! File formats for flakescatter.

pub mod flakes;

//! Flake tables (CSV).

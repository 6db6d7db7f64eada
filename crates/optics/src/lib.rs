//! Optics primitives.

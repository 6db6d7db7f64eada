//! Height maps with an explicit validity mask.

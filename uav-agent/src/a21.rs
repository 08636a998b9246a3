//! The A21 controller (seed 003 section III). Placeholder.

//! Onboard relative sensing (seed 003 UVDAR). Placeholder.

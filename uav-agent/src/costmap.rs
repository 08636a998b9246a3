//! Costmap with inflation and a social layer (seed 004). Placeholder.

//! Formation topologies of seed 004 (M23). Placeholder.

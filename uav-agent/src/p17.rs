//! The P17 flocking controller (seed 001 chapter 3). Placeholder.

//! Occupancy grid built from scans, and A* on it. Placeholder.

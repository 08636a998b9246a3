//! Planning on the agent's own maps, in its odometry frame.
//!
//! - `grid`: an occupancy grid built from the agent's scans, and A* on it (A21, seed 003 IV-C).
//! - `costmap`: the seed 004 costmap on the same grid, with inflation and a social layer for the
//!   neighbours, read through [`CostQuery`] (M23).
//!
//! Below control, above geometry: controllers use these maps; nothing here knows a controller.

mod costmap;
mod grid;

pub(crate) use costmap::{CostQuery, Costmap, SocialAgent, INSCRIBED_INFLATED_OBSTACLE, LETHAL_OBSTACLE, NO_INFORMATION};
pub(crate) use grid::{GridParams, Heuristic, OccupancyGrid, PlanParams};

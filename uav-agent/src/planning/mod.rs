//! Planning on the agent's own maps, in its odometry frame.
//!
//! - `grid`: an occupancy grid built from the agent's scans, and the A21 planner on it (seed 003
//!   IV-C).
//! - `costmap`: the seed 004 costmap on the same grid, with inflation and a social layer for the
//!   neighbours, read through [`CostQuery`] (M23).
//! - `astar`: A* on cells, the one search both planners run, with the escape from a start that
//!   cannot be entered.
//! - `cells`: cell indices, boxes of cells, the deterministic hasher and the tiled storage that
//!   the grid, the costmap and A* all index by.
//!
//! Below control, above geometry: controllers use these maps; nothing here knows a controller.
//! Inside, dependencies run costmap → grid → astar → cells (and costmap → astar, cells).

mod astar;
mod cells;
mod costmap;
mod grid;

pub(crate) use costmap::{
    CostQuery, Costmap, SocialAgent, INSCRIBED_INFLATED_OBSTACLE, LETHAL_OBSTACLE, NO_INFORMATION,
};
pub(crate) use grid::{GridParams, Heuristic, OccupancyGrid, PlanParams};

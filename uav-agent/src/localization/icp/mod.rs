//! The `icp` localization mode (seed 000 "K21", chapters 3 and 5): agents share the obstacle
//! centres they see, and each places its neighbours by aligning their sets with its own. Split by
//! concern, from the bottom up:
//!
//! - `network`: the full grid's first-pass scores eight starts at a time, their distances sorted
//!   by a sorting network on SIMD lanes (the same scores as a sort, without its branches).
//! - `nearest`: the full grid's table of the reference points that can be nearest to each
//!   stretch of a grid column, so the first pass searches a few points instead of all.
//! - `pairing`: the nearest-neighbour pairing of an ICP iteration, sorted by distance; a later
//!   iteration tries each point's previous partner first and starts its sort from their order.
//! - `alignment`: the ICP itself (Algorithm 1 with FRMSD outlier rejection, seed 000 3.1 and
//!   3.3) and its result: how well a received obstacle set fits our own near a given place, pure
//!   geometry.
//! - `grid`: the full-grid initial estimate (seed 000 5.1): the first pass that scores every
//!   start of the grid on SIMD lanes (`multiversion` dispatch), bit for bit a start-by-start
//!   loop, then the alignment from its best starts, and the runner-up alignment.
//! - `placement`: the policy on a full-grid result (place an unknown neighbour, or let a tracked
//!   one jump), with its measured thresholds; shared by the database and `swarm icp-eval`.
//! - `gate`: which database entries a received set is matched against first (the ones placed
//!   near where its sender is expected), so identification stays about linear in the neighbours.
//! - `database`: the neighbour database (seed 000 5.2–5.3, Algorithms 5 and 6, the scheduling of
//!   6.2 and the crowd rules): which entry each set belongs to, which ICP runs on it, and the
//!   entries' estimates; it calls the ICP through its `Matcher` trait.
//! - `localizer`: the mode's localizer: the shares in and out, our circles as the reference set,
//!   the database's entries as the localization's estimates, and the real ICP as the `Matcher`.
//!
//! Why split so: each part changes for its own reasons and is tested alone. The alignment is a
//! numerical method, tested by properties of rigid motions and benchmarked on its own; the full
//! grid's first pass is tuned for speed and tested by bit equality with the plain loop; the
//! placement is a decision with thresholds measured on runs, tested by its rules; the gate is a
//! geometric shortcut; the database is bookkeeping, tested with scripted matchers and no ICP at
//! all; the localizer is the thin layer joining them to the agent. Each part uses only parts
//! listed before it (the network, the table and the gate none), never one listed after it.
//!
//! The public surface is what the ICP benchmark and `swarm icp-eval` use (`uav_agent::icp`):
//! the alignment, the full grid and the placement policy, re-exported here so no caller names a
//! submodule.

mod alignment;
mod database;
mod gate;
mod grid;
mod localizer;
mod nearest;
mod network;
mod pairing;
mod placement;

pub use alignment::{fit, fit_near_middle, icp, AgentFromNeighbour, Match, NoEstimate, DISTINCT_M, DISTINCT_RAD};
pub use grid::{initial_icp, initial_icp_ranked, Ranked};
pub(crate) use localizer::IcpLocalizer;
pub use placement::{
    judge_initial, judge_long, place_unknown, Placement, Recheck, AMBIGUITY_RATIO, INITIAL_FRMSD_MAX_M,
};

//! ICP relative localization (seed 000 "K21", sections 3.1, 3.3 and 5.1), split by concern:
//!
//! - `alignment`: the ICP itself (Algorithm 1 with FRMSD outlier rejection, the full-grid
//!   initial estimate and its kernels, the runner-up alignment): how well a received obstacle
//!   set fits our own at each place, pure geometry.
//! - `placement`: the policy on a full-grid result (place an unknown neighbour, or let a tracked
//!   one jump), with its measured thresholds; shared by the neighbour database and
//!   `swarm icp-eval`.
//!
//! Why split so: the alignment is a numerical method, tested by properties of rigid motions and
//! benchmarked alone; the placement is a decision with thresholds measured on runs, tested by its
//! rules. They change for different reasons. The public surface is what the benchmark and
//! `swarm icp-eval` use (`uav_agent::icp`), re-exported here so no caller names a submodule.

mod alignment;
mod placement;

pub use alignment::{icp, initial_icp, initial_icp_ranked, AgentFromNeighbour, Match, NoEstimate, Ranked, DISTINCT_M, DISTINCT_RAD};
pub use placement::{judge_initial, judge_long, place_unknown, Placement, Recheck, AMBIGUITY_RATIO, INITIAL_FRMSD_MAX_M};

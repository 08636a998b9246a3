//! What a run leaves behind, and how it is judged: everything that turns the messages of a run
//! into its folder. In a crate of its own so the processes that fly (`swarm-node`) link no MCAP,
//! Foxglove or figures, and so the live view (`swarm-view`) and the command (`swarm`) share one
//! recorder.
//!
//! - [`recorder`]: subscribes to ground truth and agent states, writes trajectories (CSV),
//!   `run.mcap` and the journal, folds the metrics of [`summary`] (pure, in `recorder::metrics`);
//!   `swarm record` runs it alone and `swarm recover` makes a killed run's folder whole.
//! - `checks`: the run's invariants (no collision, separation, no stale or phantom neighbour,
//!   reconnection after heals, connected at the end, the goal), judged from what the recorder
//!   sees, with the first failing moment of each; `summary.json`'s `checks[]`.
//! - `liveness`: which UAVs' agents came, and which came and went (lost), folded once for the
//!   metrics and the checks alike.
//! - [`scene`]: the run as a Foxglove scene (the SDK's schemas on an explicit context): what the
//!   recorder writes to `run.mcap` and the live view serves.
//! - [`summary`]: the `summary.json` schema (`swarm.summary.v1`) and its human rendering, for
//!   programs that read run folders too.
//!
//! `recorder` feeds `checks` beside its metrics, folds into `summary` and logs into `scene`;
//! `checks` writes `summary`'s check results; both keep a `liveness`; `scene` imports nothing of
//! the crate.
//!
//! Invariant: the recorder is the only reader of `truth/**` besides tools a person points at it.

mod checks;
mod liveness;
pub mod recorder;
pub mod scene;
pub mod summary;

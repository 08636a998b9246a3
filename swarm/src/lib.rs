//! The `swarm` command: run a scenario end to end, start the pieces by hand, inspect a run.
//!
//! - [`cli`]: argument parsing and dispatch (`swarm run | hub | agent | record | tap | put | netem | scenarios | check`).
//! - [`launch`]: `swarm run`: starts the hub, one agent process per UAV and the recorder, shows
//!   progress, stops at the end condition, writes the run folder.
//! - [`recorder`]: subscribes to ground truth and agent states, writes trajectories (CSV) and
//!   accumulates the metrics of [`summary`].
//! - [`netem_cli`]: `swarm netem`: change the faults of a running swarm.
//! - [`proxy`]: the TCP proxy `swarm run` puts between an agent and the hub for link-level faults
//!   (stall, close, restore) that Zenoh itself sees.
//! - [`study`]: `swarm compare` (one scenario, each controller) and `swarm sweep-error` (seed 001's
//!   broadcast error study), each a series of full runs with a table and a plot.
//! - [`plot`]: `run.svg`, the map of the run and distances over time.
//! - [`summary`]: the `summary.json` schema (`swarm.summary.v1`) and its human rendering.
//! - [`tap`]: subscribe to any key expression of a run and print decoded messages as JSON lines;
//!   `swarm put` publishes one.
//!
//! Architecture invariant: the launcher only starts processes and watches; all simulation lives
//! in `physics-hub`, all onboard logic in `uav-agent`. The recorder is the only reader of
//! `truth/**` besides tools a person points at it.

pub mod cli;
pub mod launch;
pub mod netem_cli;
pub mod plot;
pub mod proxy;
pub mod recorder;
pub mod study;
pub mod summary;
pub mod tap;

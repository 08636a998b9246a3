//! The `swarm` command: run a scenario end to end, start the pieces by hand, inspect a run.
//!
//! - [`cli`]: argument parsing and dispatch, nothing else (`swarm run | hub | agent | record |
//!   router | view | replay | tap | put | keys | netem | ros2 | compare | formations | sweep-error |
//!   sweep-seeds | icp-eval | scale | mesh | plot | credentials | fuzz | scenarios | check`).
//! - [`launch`]: `swarm run`: starts the hub, the agents (one process per UAV, or agent hosts for large
//!   swarms) and a recording, applies
//!   the kills, restarts and link faults of `[[failures]]`, stops the children at the end.
//! - [`checks`]: the run's invariants (no collision, separation, no stale or phantom neighbour,
//!   reconnection after heals, connected at the end, the goal), judged from what the recorder
//!   sees, with the first failing moment of each; `summary.json`'s `checks[]`.
//! - [`recorder`]: subscribes to ground truth and agent states, writes trajectories (CSV), folds
//!   the metrics of [`summary`] (pure, in `recorder::metrics`); `swarm record` runs it alone.
//! - [`proxy`]: the TCP proxy `swarm run` puts between an agent and the hub for link-level faults
//!   (stall, close, restore) that Zenoh itself sees.
//! - [`netem_cli`]: `swarm netem`: change the faults of a running swarm.
//! - [`tap`]: subscribe to any key expression of a run and print decoded messages as JSON lines;
//!   `swarm put` publishes one.
//! - [`ros2`]: `swarm ros2` (and `swarm run --ros2`): the UAVs as ROS 2 nodes on rmw_zenoh's
//!   wire, scan and odometry out, cmd_vel in for external UAVs.
//! - [`keyspace`]: `swarm keys`: the live key space of a run from the routers' admin space (who
//!   publishes and subscribes to each key family, per session) with rates and bandwidth.
//! - [`study`]: `swarm compare` (one scenario, each controller), `swarm formations` (seed 004's
//!   topologies) and `swarm sweep-error` (seed 001's broadcast error study), each a series of
//!   full runs with a table and a plot.
//! - [`sweep_seeds`]: `swarm sweep-seeds`: one scenario over many seeds, several runs at once and
//!   resumable, every headline metric as a mean with its 95 % interval (Student t) and the success
//!   rate with its Wilson interval, a table and a plot of the distributions.
//! - [`icp_eval`]: `swarm icp-eval`: pairs of views (generated from a seed, or a JSON file) run
//!   through the neighbour database's own initial-placement decision; right / no estimate /
//!   wrong-but-accepted rates by shared trees, ms per case.
//! - [`scale`]: `swarm scale`: a series of growing swarms (5 to 1000 UAVs) flown in turn, with
//!   x real time, hub tick and agent step percentiles and resident memory in a table and a plot.
//! - [`mesh`]: `swarm mesh`: a run spread over machines made of network namespaces, the hub on
//!   one and agent hosts behind their own routers on others; each host's link bytes as the
//!   kernel counts them, and the shares that crossed into it beside its radio neighbours across.
//! - [`fuzz`]: `swarm fuzz`: generated scenarios with nemesis schedules flown through the
//!   `study` runner, judged by [`checks`], each failure shrunk to a minimal scenario file.
//! - [`scenarios`]: `swarm scenarios` and `swarm check`: the built-in scenarios, and what a file
//!   resolves to.
//! - [`scene`]: the run as a Foxglove scene (the SDK's schemas on an explicit context): what the
//!   recorder writes to `run.mcap`.
//! - [`view`]: `swarm view` (and `swarm run --view`): a live web page and the Foxglove
//!   WebSocket of a running swarm.
//! - [`summary`]: the `summary.json` schema (`swarm.summary.v1`) and its human rendering.
//!
//! Public surface: [`cli::main`] (what the `swarm` binary and the end-to-end tests' copy of it
//! call) and [`summary`] (the `summary.json` schema, for programs that read run folders); every
//! other module is private.
//!
//! Dependencies run one way: `cli` → the commands → what they share (`recorder`, `proxy`,
//! `summary`, `plot`, `args`); no command imports `cli`, and `args` imports nothing of the crate.
//!
//! Architecture invariant: the launcher only starts processes and watches them; all simulation
//! lives in `physics-hub`, all onboard logic in `uav-agent`. The recorder is the only reader of
//! `truth/**` besides tools a person points at it.

mod checks;
pub mod cli;
mod fuzz;
mod icp_eval;
mod keyspace;
mod launch;
mod mesh;
mod netem_cli;
mod proxy;
mod recorder;
mod ros2;
mod scale;
mod scene;
mod scenarios;
mod study;
mod sweep_seeds;
pub mod summary;
mod tap;
mod view;

//! The `swarm` command: run a scenario end to end, start the pieces by hand, inspect a run. The
//! top floor of the workspace: it holds the command line, the launcher, the studies and the tools,
//! and reaches down to the crates below it for the rest: `swarm-node` (the hub, agent and router
//! commands, shared arguments, access control), `swarm-record` (the recorder, checks, summary,
//! Foxglove scene), `swarm-plot` (figures) and `swarm-view` (the live page and replay).
//!
//! - [`cli`]: argument parsing and dispatch, nothing else (`swarm run | hub | agent | record |
//!   router | view | replay | tap | put | keys | netem | ros2 | compare | formations | sweep-error |
//!   sweep-seeds | icp-eval | scale | floor | mesh | plot | credentials | fuzz | scenarios | check`);
//!   `hub`, `agent`, `router` and `credentials` are `swarm-node`'s commands, flattened in.
//! - [`launch`]: `swarm run`: starts the hub, the agents (one process per UAV, or agent hosts for large
//!   swarms) and a recording, applies
//!   the kills, restarts and link faults of `[[failures]]`, stops the children at the end.
//! - [`proxy`]: the TCP proxy `swarm run` puts between an agent and the hub for link-level faults
//!   (stall, close, restore) that Zenoh itself sees.
//! - [`netem_cli`]: `swarm netem`: change the faults of a running swarm.
//! - [`tap`]: subscribe to any key expression of a run and print decoded messages as JSON lines;
//!   `swarm put` publishes one.
//! - [`ros2`]: `swarm ros2` (and `swarm run --ros2`, `--dds`): a run as a ROS 2 graph on DDS or
//!   rmw_zenoh, and the bodies of agents that run on ROS topics.
//! - [`gym`]: `swarm run --gym`: the run as a step function over standard input and output,
//!   for a learning loop (the Python package `uavswarm`).
//! - [`keyspace`]: `swarm keys`: the live key space of a run from the routers' admin space (who
//!   publishes and subscribes to each key family, per session) with rates and bandwidth.
//! - [`study`]: `swarm compare` (one scenario, each controller), `swarm formations` (seed 004's
//!   topologies) and `swarm sweep-error` (seed 001's broadcast error study), each a series of
//!   full runs with a table and a plot.
//! - [`sweep_seeds`]: `swarm sweep-seeds`: one scenario over many seeds, several runs at once and
//!   resumable, every headline metric as a mean with its 95 % interval (Student t) and the success
//!   rate with its Wilson interval, a table and a plot of the distributions.
//! - [`stats`]: the studies' statistics (Student-t means with 95 % intervals, Wilson intervals)
//!   and how a table prints them, below `study` and `sweep_seeds`, which both use them.
//! - [`icp_eval`]: `swarm icp-eval`: pairs of views (generated from a seed, or a JSON file) run
//!   through the neighbour database's own initial-placement decision; right / no estimate /
//!   wrong-but-accepted rates by shared trees, ms per case.
//! - [`scale`]: `swarm scale`: a series of growing swarms (5 to 1000 UAVs) flown in turn, with
//!   x real time, hub tick and agent step percentiles and resident memory in a table and a plot.
//! - [`floor`]: `swarm floor`: the whole swarm flown in this process on one thread with no
//!   messages (`physics-hub`'s simulation, `uav-agent`'s `Onboard`), the same flight as in
//!   lockstep, for the computation per tick under a distributed run's wall time.
//! - [`mesh`]: `swarm mesh`: a run spread over machines made of network namespaces, the hub on
//!   one and agent hosts behind their own routers on others; each host's link bytes as the
//!   kernel counts them, and the shares that crossed into it beside its radio neighbours across.
//! - [`fuzz`]: `swarm fuzz`: generated scenarios with nemesis schedules flown through the
//!   `study` runner, judged by `swarm_record::checks`, each failure shrunk to a minimal scenario file.
//! - [`scenarios`]: `swarm scenarios` and `swarm check`: the built-in scenarios, and what a file
//!   resolves to.
//!
//! Public surface: [`cli::main`] (what the `swarm` binary and the end-to-end tests' copy of it
//! call) and [`summary`] (the `summary.json` schema, for programs that read run folders); every
//! other module is private.
//!
//! Dependencies run one way: `cli` → the commands → what they share (`proxy`, and the crates
//! below); no command imports `cli`.
//!
//! Architecture invariant: the launcher only starts processes and watches them (the floor steps the same pieces in
//! process); all simulation
//! lives in `physics-hub`, all onboard logic in `uav-agent`.

pub mod cli;
mod floor;
mod fuzz;
mod gym;
mod icp_eval;
mod keyspace;
mod launch;
mod mesh;
mod netem_cli;
mod proxy;
mod ros2;
mod scale;
mod scenarios;
mod stats;
mod study;
mod sweep_seeds;
/// The `summary.json` schema, for programs that read run folders (it lives in `swarm-record`).
pub use swarm_record::summary;
mod tap;

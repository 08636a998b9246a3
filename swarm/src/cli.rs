//! Argument parsing and dispatch, and nothing else: each subcommand's args live beside the
//! command (the shared [`ZenohArgs`](swarm_args::ZenohArgs) in [`swarm_args`]), and doc
//! comments are the help text.

use clap::{Parser, Subcommand};
use std::process::ExitCode;
use uav_agent::Controllers;

/// Zenoh-networked UAV swarm: physics hub, one agent per UAV, recorder.
#[derive(Parser, Debug)]
#[command(name = "swarm", version, about)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub cmd: Cmd,
}

/// Subcommands.
#[derive(Subcommand, Debug)]
pub enum Cmd {
    /// Run a scenario end to end: hub, agents (a process per UAV or agent hosts), recorder; write
    /// the run folder.
    Run(crate::launch::RunArgs),
    /// `hub`, `agent`, `router` and `credentials`: the processes a run is made of, the same
    /// commands as the `swarm-node` binary's.
    #[command(flatten)]
    Node(swarm_node::command::NodeCmd),
    /// Record a run started by hand: write the run folder when the hub ends the run.
    Record(swarm_record::recorder::RecordArgs),
    /// Make a killed run's folder whole: summary, CSVs and figures from its journal, run.mcap
    /// rewritten from its whole chunks (at most the last sim second is lost).
    Recover(swarm_record::recorder::RecoverArgs),
    /// Watch a running swarm: a web page and the Foxglove WebSocket, on loopback.
    View(swarm_view::ViewArgs),
    /// Replay a recorded run (`run.mcap` or its run folder) on the view's page and the Foxglove
    /// WebSocket, with play, pause, seek and speed.
    Replay(swarm_view::ReplayArgs),
    /// Print every message on a key expression as JSON lines.
    Tap(crate::tap::TapArgs),
    /// Publish one message (as JSON, or raw hex) on a key.
    Put(crate::tap::PutArgs),
    /// The live key space of a run: each key family, who publishes and who subscribes (per
    /// session, from the routers' admin space), message rate and bandwidth.
    Keys(crate::keyspace::KeysArgs),
    /// Change the network faults of a running swarm (loss, delay, partition, isolate, heal).
    Netem(crate::netem_cli::NetemArgs),
    /// Show a running swarm's UAVs to ROS 2 (rmw_zenoh): /uav{id}/scan, /uav{id}/odom, and
    /// /uav{id}/cmd_vel for external UAVs.
    Ros2(crate::ros2::Ros2Args),
    /// Fly one scenario with each controller and print the comparison (seed 000 section 6.5).
    Compare(crate::study::CompareArgs),
    /// Fly seed 004's formation topologies and print its Table 8 beside ours.
    Formations(crate::study::FormationsArgs),
    /// Sweep the broadcast-position error δa (seed 001 section 6): print and plot min distances.
    SweepError(crate::study::SweepArgs),
    /// Fly one scenario over many seeds, in parallel and resumably: every headline metric as a
    /// mean with its 95 % confidence interval, success rate with its Wilson interval, a plot.
    SweepSeeds(crate::sweep_seeds::SweepSeedsArgs),
    /// Measure the initial ICP decision on generated or given pairs of views: right, no
    /// estimate, wrong but accepted.
    IcpEval(crate::icp_eval::IcpEvalArgs),
    /// Fly a swarm spread over machines (Linux network namespaces, root): the hub on one, agent
    /// hosts behind their own routers on others; report each host's link bytes and the shares
    /// that crossed into it.
    Mesh(crate::mesh::MeshArgs),
    /// Fly swarms of growing size and print (and plot) speed, tick and step times and memory.
    Scale(crate::scale::ScaleArgs),
    /// Fly scenarios with the whole swarm in this process, on one thread, with no messages: the
    /// computation a tick cannot do without, the floor under a distributed run's wall time.
    Floor(crate::floor::FloorArgs),
    /// Draw a run folder's figures (map, distances, K21 vectors, localization, connectivity) as
    /// SVG and PNG.
    Plot(swarm_plot::PlotArgs),
    /// Generate scenarios with nemesis schedules from a seed, fly them, check the invariants,
    /// and shrink each failure to a minimal scenario file.
    Fuzz(crate::fuzz::FuzzArgs),
    /// List the built-in scenarios.
    Scenarios,
    /// Validate a scenario file and say what it flies (`--json`: every field resolved).
    Check {
        /// Scenario file or built-in name.
        scenario: String,
        /// The resolved scenario as JSON (what programs read).
        #[arg(long)]
        json: bool,
    },
}

/// With this variable set, the command line is parsed (and refused as usual) but not run.
pub const PARSE_ONLY: &str = "SWARM_PARSE_ONLY";

/// Entry point of the binary: parse, set up logging and the runtime, dispatch.
pub fn main() -> ExitCode {
    main_with(Controllers::builtin())
}

/// The whole command line with `controllers`: the entry point of a program that adds its own
/// controllers to the built-in ones (`Controllers::builtin().with(name, make)`). The agents a run
/// starts are this same executable, so they know the same controllers.
pub fn main_with(controllers: Controllers) -> ExitCode {
    let cli = Cli::parse();
    // The docs' test checks that every command line the docs show parses, without running it.
    if std::env::var_os(PARSE_ONLY).is_some() {
        return ExitCode::SUCCESS;
    }
    let workers = match &cli.cmd {
        Cmd::Node(c) => {
            swarm_node::command::zenoh_threads(c);
            swarm_node::command::workers(c)
        }
        _ => swarm_node::process::DEFAULT_WORKERS,
    };
    swarm_node::process::run_on(workers, dispatch(cli, controllers))
}

async fn dispatch(cli: Cli, controllers: Controllers) -> anyhow::Result<ExitCode> {
    match cli.cmd {
        Cmd::Run(a) => crate::launch::run(a, &controllers).await,
        Cmd::Node(c) => swarm_node::command::dispatch(c, controllers).await,
        Cmd::Record(a) => swarm_record::recorder::record(a).await,
        Cmd::Recover(a) => swarm_record::recorder::recover(a),
        Cmd::View(a) => swarm_view::view(a).await,
        Cmd::Replay(a) => swarm_view::replay(a).await,
        Cmd::Tap(a) => crate::tap::tap(a).await,
        Cmd::Put(a) => crate::tap::put(a).await,
        Cmd::Keys(a) => crate::keyspace::keys(a).await,
        Cmd::Netem(a) => crate::netem_cli::netem(a).await,
        Cmd::Ros2(a) => crate::ros2::ros2(a).await,
        Cmd::Compare(a) => crate::study::compare(a).await,
        Cmd::SweepError(a) => crate::study::sweep_error(a).await,
        Cmd::SweepSeeds(a) => crate::sweep_seeds::sweep_seeds(a, &controllers).await,
        Cmd::Formations(a) => crate::study::formations(a).await,
        Cmd::IcpEval(a) => crate::icp_eval::icp_eval(a).await,
        Cmd::Scale(a) => crate::scale::scale(a, &controllers).await,
        Cmd::Floor(a) => crate::floor::floor(&a, &controllers),
        Cmd::Mesh(a) => crate::mesh::mesh(a).await,
        Cmd::Plot(a) => swarm_plot::plot(a),
        Cmd::Fuzz(a) => crate::fuzz::fuzz(a).await,
        Cmd::Scenarios => crate::scenarios::list(),
        Cmd::Check { scenario, json } => crate::scenarios::check(&scenario, json, &controllers),
    }
}

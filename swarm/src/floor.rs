//! `swarm floor`: the whole swarm flown in this one process, on one thread, with no message at
//! all: the hub's simulation computes every UAV's sensors, every agent steps on its frame and on
//! the shares it would have received ([`uav_agent::Onboard`], the node's own order), the
//! simulation integrates their commands. That is the computation a lockstep run cannot do
//! without, so its time per tick is the floor under any distributed run's: `swarm scale
//! --floor` quotes each run's wall time per tick as a multiple of it.
//!
//! Why one thread: the floor is then the CPU work of a tick, comparable across machines with
//! the same core; on a machine with c cores a perfectly spread lockstep run could at best take
//! floor / c per tick.
//!
//! Why it can be trusted to be the same work: it flies the same flight. Its `trajectories.csv`
//! (the recorder's own writer) is byte for byte the lockstep run's (`tests/tests/floor.rs`), as
//! long as every agent lives the whole flight: the floor has no processes to kill, and refuses a
//! scenario that kills some, or one with external controllers (they answer from outside).

use anyhow::{ensure, Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use physics_hub::sim::Sim;
use serde::Serialize;
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use swarm_config::{FailureKind, Scenario};
use swarm_types::UavId;
use swarm_wire::{Cmd, HubTiming};
use uav_agent::{Controllers, Onboard, Outgoing};

/// The five scenarios issue 48 quotes the floor for.
pub const DEFAULT_SCENARIOS: &str = "forest-5,forest-40-icp,forest-100-icp,open-1000,forest-1000-icp";

/// `swarm floor`.
#[derive(Args, Debug, Clone)]
pub struct FloorArgs {
    /// Scenarios to fly, comma-separated files or built-in names.
    #[arg(long, default_value = DEFAULT_SCENARIOS)]
    pub scenarios: String,
    /// Cap every flight's sim time [s] (default: each scenario's own `end.time_limit_s`).
    #[arg(long)]
    pub time_limit: Option<f64>,
    /// Write each flight's `trajectories.csv` (the recorder's format) under this folder, as
    /// `<scenario>/trajectories.csv`.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print the rows as JSON on stdout instead of the table.
    #[arg(long)]
    pub json: bool,
}

/// One in-process flight and what its ticks cost.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FloorRow {
    /// Scenario name.
    pub scenario: String,
    /// UAVs.
    pub uavs: usize,
    /// Ticks flown.
    pub ticks: u64,
    /// Sim seconds flown.
    pub sim_time_s: f64,
    /// Why the flight ended (`goal`, `time_limit`).
    pub end_reason: String,
    /// When the goal was reached [sim s].
    pub goal_s: Option<f64>,
    /// Collisions (contacts begun).
    pub collisions: usize,
    /// The simulation's work per tick: sensors, then integration [CPU ms].
    pub hub_ms_per_tick: f64,
    /// Every agent's step per tick, summed [CPU ms].
    pub agents_ms_per_tick: f64,
    /// The two: the floor of a tick [CPU ms].
    pub floor_ms_per_tick: f64,
    /// The floor per sim second [CPU s / sim s].
    pub cpu_s_per_sim_s: f64,
}

/// Runs `swarm floor`.
pub fn floor(a: &FloorArgs, controllers: &Controllers) -> Result<ExitCode> {
    let mut rows = Vec::new();
    for name in a.scenarios.split(',').map(str::trim).filter(|n| !n.is_empty()) {
        let (mut sc, _) = Scenario::from_arg(name)?;
        if let Some(t) = a.time_limit {
            sc.end.time_limit_s = t;
        }
        let trajectories = a.out.as_ref().map(|dir| dir.join(&sc.name).join("trajectories.csv"));
        rows.push(fly(&sc, controllers, trajectories.as_deref())?);
    }
    if a.json {
        swarm_node::process::out(&serde_json::to_string_pretty(&rows)?);
    } else {
        print!("{}", table(&rows));
    }
    Ok(ExitCode::SUCCESS)
}

/// Flies `sc` in this process (see the module doc), writing its trajectories to `trajectories`
/// when given, under a progress bar on stderr.
pub fn fly(sc: &Scenario, controllers: &Controllers, trajectories: Option<&std::path::Path>) -> Result<FloorRow> {
    ensure!(sc.controller.external.is_empty(), "{}: the floor flies no external controller", sc.name);
    ensure!(
        sc.failures.iter().all(|f| f.kind == FailureKind::Freeze),
        "{}: the floor flies freezes only (it has no agent processes or links to fail)",
        sc.name
    );
    let mut csv = trajectories.map(open_trajectories).transpose()?;
    let ids: Vec<UavId> = sc.uav_ids().collect();
    let mut agents = ids
        .iter()
        .map(|&id| Onboard::new(id, sc, controllers))
        .collect::<Result<Vec<_>, _>>()
        .context(sc.name.clone())?;
    let mut sim = Sim::new(sc);
    let alive = vec![true; ids.len()];
    // Each UAV's share of the last tick, and whom each agent listened to at it.
    let mut shares: Vec<Option<Outgoing>> = vec![None; ids.len()];
    let mut listening: Vec<Vec<UavId>> = vec![Vec::new(); ids.len()];
    let (mut hub_s, mut agents_s, mut collisions) = (0.0, 0.0, 0usize);
    let pb = progress(sc);
    let (ended, goal_s) = loop {
        let started = thread_cpu_s();
        let frames = sim.sensors_all_on(&ids, 1);
        let sensed = thread_cpu_s();
        let mut cmds: Vec<Option<Cmd>> = vec![None; ids.len()];
        let mut next: Vec<Option<Outgoing>> = vec![None; ids.len()];
        for (i, frame) in frames.into_iter().enumerate() {
            for &from in &listening[i] {
                if let Some(o) = &shares[from.index()] {
                    agents[i].on_share(from, Arc::clone(&o.share), o.len);
                }
            }
            listening[i].clone_from(&frame.radio.in_range);
            let (out, outgoing) = agents[i].on_sense(frame).with_context(|| format!("{}: UAV {}", sc.name, ids[i]))?;
            cmds[i] = Some(out.cmd);
            next[i] = outgoing;
        }
        shares = next;
        let stepped = thread_cpu_s();
        let step = sim.step(&cmds, &alive, 0.0);
        let integrated = thread_cpu_s();
        hub_s += (sensed - started) + (integrated - stepped);
        agents_s += stepped - sensed;
        collisions += step.collisions.len();
        pb.set_position(step.tick);
        let (ended, goal_s) = (step.ended, step.goal_reached_at);
        if let Some(csv) = csv.as_mut() {
            swarm_record::recorder::write_trajectory_rows(csv, &step.with_timing(HubTiming::default()))?;
        }
        if let Some(end) = ended {
            break (end, goal_s);
        }
    };
    pb.finish_and_clear();
    if let Some(mut csv) = csv {
        csv.flush()?;
    }
    let ticks = sim.tick().max(1);
    let floor_s = hub_s + agents_s;
    Ok(FloorRow {
        scenario: sc.name.clone(),
        uavs: ids.len(),
        ticks,
        sim_time_s: sim.t_s(),
        end_reason: ended.name().to_string(),
        goal_s,
        collisions,
        hub_ms_per_tick: 1e3 * hub_s / ticks as f64,
        agents_ms_per_tick: 1e3 * agents_s / ticks as f64,
        floor_ms_per_tick: 1e3 * floor_s / ticks as f64,
        cpu_s_per_sim_s: floor_s / sim.t_s().max(f64::MIN_POSITIVE),
    })
}

/// `trajectories.csv` at `path`, its folder made, its header written.
fn open_trajectories(path: &std::path::Path) -> Result<std::io::BufWriter<std::fs::File>> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    let file = std::fs::File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
    let mut out = std::io::BufWriter::new(file);
    writeln!(out, "{}", swarm_record::recorder::TRAJECTORY_HEADER)?;
    Ok(out)
}

/// A bar over the flight's ticks.
fn progress(sc: &Scenario) -> ProgressBar {
    let pb = ProgressBar::new((sc.end.time_limit_s / sc.dt_s()).round() as u64);
    pb.set_style(
        ProgressStyle::with_template("{prefix} [{bar:30}] tick {pos}/{len} ({elapsed}, eta {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    pb.set_prefix(format!("floor {}", sc.name));
    pb
}

/// CPU time of this thread so far [s] (`/proc/thread-self/schedstat`, nanoseconds on CPU; NaN
/// off Linux), so a tick's cost is measured apart from the machine's other load.
fn thread_cpu_s() -> f64 {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").unwrap_or_default();
    text.split_whitespace().next().and_then(|ns| ns.parse::<f64>().ok()).map_or(f64::NAN, |ns| ns * 1e-9)
}

/// The table of `rows`, in Markdown.
pub fn table(rows: &[FloorRow]) -> String {
    let mut t = String::new();
    let _ = writeln!(t, "# swarm floor: a tick's computation in one process, on one thread, no messages\n");
    let _ = writeln!(
        t,
        "| scenario | UAVs | ticks | end | collisions | hub CPU ms per tick | agents CPU ms per tick | floor CPU ms per tick | CPU s per sim s |"
    );
    let _ = writeln!(t, "|---|---|---|---|---|---|---|---|---|");
    for r in rows {
        let _ = writeln!(
            t,
            "| {} | {} | {} | {} | {} | {:.3} | {:.3} | {:.3} | {:.3} |",
            r.scenario,
            r.uavs,
            r.ticks,
            r.goal_s.map_or_else(|| r.end_reason.clone(), |g| format!("goal at {g:.1} s")),
            r.collisions,
            r.hub_ms_per_tick,
            r.agents_ms_per_tick,
            r.floor_ms_per_tick,
            r.cpu_s_per_sim_s,
        );
    }
    t
}

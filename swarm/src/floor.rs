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
use physics_hub::sim::Sim;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use swarm_config::{FailureKind, Scenario};
use swarm_record::recorder::Offline;
use swarm_types::UavId;
use swarm_wire::{Cmd, HubTiming, SenseFrame};
use uav_agent::{Controllers, Onboard, Outgoing, StepReport};

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
    /// Record each flight into a run folder under this one, `<scenario>/` (what `swarm run`
    /// writes, but `run.mcap`): its time per tick then includes none of the recording.
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
        let folder = a.out.as_ref().map(|dir| dir.join(&sc.name));
        rows.push(fly(&sc, controllers, folder.as_deref(), false)?);
    }
    if a.json {
        swarm_node::process::out(&serde_json::to_string_pretty(&rows)?);
    } else {
        print!("{}", table(&rows));
    }
    Ok(ExitCode::SUCCESS)
}

/// Flies `sc` in this process (see the module doc); with `out`, records it into that run
/// folder as `swarm run` would (no `run.mcap`). `quiet`: no progress bar of its own (a study
/// shows its own).
pub fn fly(sc: &Scenario, controllers: &Controllers, out: Option<&Path>, quiet: bool) -> Result<FloorRow> {
    ensure!(sc.controller.external.is_empty(), "{}: the floor flies no external controller", sc.name);
    ensure!(
        sc.failures.iter().all(|f| f.kind == FailureKind::Freeze),
        "{}: the floor flies freezes only (it has no agent processes or links to fail)",
        sc.name
    );
    let ids: Vec<UavId> = sc.uav_ids().collect();
    let mut agents = Agents::new(sc, controllers)?;
    let mut sim = Sim::new(sc);
    let pb = swarm_record::recorder::progress_bar(sc, quiet);
    pb.set_prefix(format!("floor {}", sc.name));
    let mut rec = out.map(|dir| Offline::new(dir, sc, &pb, &format!("floor-{}", sc.name))).transpose()?;
    if let Some(dir) = out {
        // The scenario flown, beside its recording as `swarm run` leaves it (the folder is the
        // recording's).
        let path = dir.join("scenario.toml");
        std::fs::write(&path, toml::to_string(sc).context("cannot serialize the scenario")?)
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    if let Some(rec) = rec.as_mut() {
        rec.world(sim.truth_world())?;
    }
    let alive = vec![true; ids.len()];
    let mut cost = Cost::default();
    let mut collisions = 0usize;
    // The flight's own wall clock, for the recording's x real time (nothing flown depends on it).
    let began = std::time::Instant::now();
    let (ended, goal_s) = loop {
        let started = thread_cpu_s();
        let frames = sim.sensors_all_on(&ids, 1);
        let sensed = thread_cpu_s();
        let (cmds, reports) = agents.step(frames).with_context(|| sc.name.clone())?;
        let stepped = thread_cpu_s();
        let step = sim.step(&cmds, &alive, began.elapsed().as_secs_f64());
        cost.add(sensed - started, stepped - sensed, thread_cpu_s() - stepped);
        collisions += step.collisions.len();
        let (ended, goal_s) = (step.ended, step.goal_reached_at);
        match rec.as_mut() {
            Some(rec) => {
                for (agent, report) in agents.onboard.iter_mut().zip(reports) {
                    rec.state(agent.state(report))?;
                }
                rec.step(step.with_timing(HubTiming::default()))?;
            }
            None => pb.set_position(step.tick),
        }
        if let Some(end) = ended {
            break (end, goal_s);
        }
    };
    pb.finish_and_clear();
    if let Some(rec) = rec {
        rec.finish()?;
    }
    Ok(cost.row(sc, sim.tick(), sim.t_s(), (ended.name(), goal_s, collisions)))
}

/// Every UAV's onboard stack, and the shares between them.
struct Agents {
    onboard: Vec<Onboard>,
    /// Each UAV's share of the last tick, by index.
    shares: Vec<Option<Outgoing>>,
    /// Whom each agent listened to at the last tick: its radio set.
    listening: Vec<Vec<UavId>>,
}

impl Agents {
    fn new(sc: &Scenario, controllers: &Controllers) -> Result<Agents> {
        let onboard = sc
            .uav_ids()
            .map(|id| Onboard::new(id, sc, controllers))
            .collect::<Result<Vec<_>, _>>()
            .context(sc.name.clone())?;
        let n = onboard.len();
        Ok(Agents { onboard, shares: vec![None; n], listening: vec![Vec::new(); n] })
    }

    /// Steps every agent on its frame of this tick (in id order, as `frames` come), after
    /// handing it the last tick's shares of the UAVs it listened to then; returns the commands
    /// and the reports.
    fn step(&mut self, frames: Vec<SenseFrame>) -> Result<(Vec<Option<Cmd>>, Vec<StepReport>)> {
        let mut cmds = Vec::with_capacity(frames.len());
        let mut reports = Vec::with_capacity(frames.len());
        let mut next = Vec::with_capacity(frames.len());
        for (i, frame) in frames.into_iter().enumerate() {
            let agent = &mut self.onboard[i];
            for &from in &self.listening[i] {
                if let Some(o) = &self.shares[from.index()] {
                    agent.on_share(from, Arc::clone(&o.share), o.len);
                }
            }
            self.listening[i].clone_from(&frame.radio.in_range);
            let id = frame.radio.id;
            let (out, outgoing) = agent.on_sense(frame).with_context(|| format!("UAV {id}"))?;
            cmds.push(Some(out.cmd));
            reports.push(out.report);
            next.push(outgoing);
        }
        self.shares = next;
        Ok((cmds, reports))
    }
}

/// The thread's CPU time spent so far on each part of a tick [s].
#[derive(Debug, Default)]
struct Cost {
    /// The simulation: sensors and integration.
    hub_s: f64,
    /// Every agent's step.
    agents_s: f64,
}

impl Cost {
    fn add(&mut self, sensors_s: f64, agents_s: f64, integrate_s: f64) {
        self.hub_s += sensors_s + integrate_s;
        self.agents_s += agents_s;
    }

    /// The row of a flight of `ticks` ticks to `t_s`, that ended so.
    fn row(
        &self,
        sc: &Scenario,
        ticks: u64,
        t_s: f64,
        (end, goal_s, collisions): (&str, Option<f64>, usize),
    ) -> FloorRow {
        let per_tick = |s: f64| 1e3 * s / ticks.max(1) as f64;
        let floor_s = self.hub_s + self.agents_s;
        FloorRow {
            scenario: sc.name.clone(),
            uavs: sc.count(),
            ticks,
            sim_time_s: t_s,
            end_reason: end.to_string(),
            goal_s,
            collisions,
            hub_ms_per_tick: per_tick(self.hub_s),
            agents_ms_per_tick: per_tick(self.agents_s),
            floor_ms_per_tick: per_tick(floor_s),
            cpu_s_per_sim_s: floor_s / t_s.max(f64::MIN_POSITIVE),
        }
    }
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

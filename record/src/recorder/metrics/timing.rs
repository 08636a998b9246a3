//! Timing: the wall-clock costs of the run (the hub's work per tick, each agent step's time) and
//! the commands that came late. Why its own part: these are measured, not simulated, so they
//! differ from run to run even in lockstep; kept apart, they are the one part of the summary a
//! repeated run is not expected to reproduce.

use super::stats::quantile;
use crate::summary::{AgentSummary, TimingSummary};
use std::collections::BTreeMap;
use swarm_types::UavId;
use swarm_wire::{AgentState, TruthStep};

/// One agent's step times and late commands.
#[derive(Debug, Clone, Default)]
struct UavTiming {
    step_us_sum: f64,
    step_us_max: f64,
    /// States folded.
    steps: u64,
    /// Ticks its agent, alive, sent its command too late for the hub.
    late: u64,
}

/// The run's timing, folded from the truth steps (the hub's side) and the states (the agents').
#[derive(Debug, Default)]
pub(super) struct Timing {
    /// Per UAV that sent a state or a late command.
    uavs: BTreeMap<UavId, UavTiming>,
    /// The hub's own work of each tick [µs].
    hub_work_us: Vec<f64>,
    /// Every agent step's wall time [µs].
    step_us: Vec<f64>,
    /// Commands the hub took.
    commands: u64,
    /// How late each late command was [ms].
    late_ms: Vec<f64>,
}

impl Timing {
    /// Folds one ground-truth step.
    pub(super) fn on_step(&mut self, s: &TruthStep) {
        if s.ended.is_none() {
            // The hub's last word (a stopped run) measures no work.
            self.hub_work_us.push(f64::from(s.timing.work_us));
        }
        self.commands += u64::from(s.timing.cmds);
        self.late_ms.extend(s.timing.late_ms.iter().map(|&ms| f64::from(ms)));
        for b in s.bodies.iter().filter(|b| b.alive && !b.cmd_on_time && s.ended.is_none()) {
            self.uavs.entry(b.id).or_default().late += 1;
        }
    }

    /// Folds one agent state.
    pub(super) fn on_state(&mut self, st: &AgentState) {
        let a = self.uavs.entry(st.id).or_default();
        let us = f64::from(st.step_time_us);
        self.step_us.push(us);
        a.step_us_sum += us;
        a.step_us_max = a.step_us_max.max(us);
        a.steps += 1;
    }

    /// The UAVs that sent a state (or a late command), in id order.
    pub(super) fn uavs(&self) -> impl Iterator<Item = UavId> + '_ {
        self.uavs.keys().copied()
    }

    /// Fills in `a`'s step times and late ticks.
    pub(super) fn fill(&self, a: &mut AgentSummary) {
        let blank = UavTiming::default();
        let t = self.uavs.get(&a.id).unwrap_or(&blank);
        let steps = t.steps.max(1) as f64;
        a.mean_step_time_ms = t.step_us_sum / steps / 1000.0;
        a.max_step_time_ms = t.step_us_max / 1000.0;
        a.late_ticks = t.late;
    }

    /// Percentiles of the hub's and the agents' wall times, and the late commands.
    pub(super) fn summary(&self) -> TimingSummary {
        let late = self.late_ms.len() as u64;
        TimingSummary {
            hub_tick_p50_ms: quantile(&self.hub_work_us, 0.5) / 1000.0,
            hub_tick_p99_ms: quantile(&self.hub_work_us, 0.99) / 1000.0,
            agent_step_p50_ms: quantile(&self.step_us, 0.5) / 1000.0,
            agent_step_p99_ms: quantile(&self.step_us, 0.99) / 1000.0,
            commands: self.commands,
            late_commands: late,
            late_share: if self.commands > 0 { late as f64 / self.commands as f64 } else { 0.0 },
            late_p99_ms: quantile(&self.late_ms, 0.99),
        }
    }
}

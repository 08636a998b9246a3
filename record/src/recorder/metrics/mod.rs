//! The recorder's pure half: [`Metrics`] folds ground truth and agent states, message by
//! message, into a [`Summary`] (distances, paths, collisions, localization errors, connectivity,
//! formation quality) when the hub marks the last step. No IO and no clock, so it is tested
//! without a network.
//!
//! [`Metrics`] is one fold per concern, each with its own state, its own fold of the messages it
//! reads and its own part of the summary; it hands every message to each and puts the summary
//! together:
//! - `motion`: the bodies' distances, paths, tracks ([`TrackSample`]), collisions, lattice
//!   spacing and the run's end, from the truth alone;
//! - `scoring`: each estimate against the truth of its tick ([`Scored`], `localization.csv`),
//!   false estimates, contacts lost and regained; it keeps the recent truth and the states
//!   waiting for theirs;
//! - `connectivity`: the estimate graph's components per tick ([`ComponentsRow`],
//!   `connectivity.csv`), settled tick by tick;
//! - `traffic`: what each agent session and each agent received;
//! - `links`: the netem links' counters and delays, per class, across restarts;
//! - `timing`: the hub's and the agents' wall times and the late commands;
//! - `stats`: the mean and quantile they all take.

mod connectivity;
#[cfg(test)]
mod fixtures;
mod links;
mod motion;
mod scoring;
mod stats;
mod timing;
mod traffic;

pub use connectivity::ComponentsRow;
pub use motion::TrackSample;
pub use scoring::{Scored, ALONE_M, FALSE_ESTIMATE_M};
/// `tally`'s tests check its mean and quantile against these.
#[cfg(test)]
pub(super) use stats::{mean_finite, quantile};

use crate::summary::{AgentSummary, LostUav, Summary, SCHEMA};
use connectivity::EstimateGraph;
use links::Links;
use motion::Motion;
use scoring::Scoring;
use std::collections::BTreeSet;
use swarm_types::{Hysteresis, UavId};
use swarm_wire::{AgentState, EndReason, TruthStep, TruthWorld};
use timing::Timing;
use traffic::Sessions;

/// Everything the summary needs, folded message by message: one fold per concern (see the
/// module docs).
#[derive(Debug, Default)]
pub struct Metrics {
    motion: Motion,
    scoring: Scoring,
    graph: EstimateGraph,
    traffic: Sessions,
    links: Links,
    timing: Timing,
    /// Whose agents came, and which came and went (`never_joined`, `lost`).
    liveness: crate::liveness::Liveness,
}

impl Metrics {
    /// Metrics that settle each tick of the estimate graph once it is older than every truth step
    /// kept (the last [`TRUTH_KEPT`](scoring::TRUTH_KEPT): no state that late can be scored
    /// either): its connectivity row and its estimates across blocked links (by `sc`'s timeline,
    /// as [`Metrics::summary`] counts them) are kept, its graph dropped. At open-1000 the graph
    /// of a tick is 110-150 kB (the run's peak memory over its 400 settled ticks), and it was
    /// held for every tick of a run. The summary, `connectivity.csv` and the checks are the same
    /// as with [`Metrics::default`], which keeps every tick, as long as no state comes for a
    /// settled tick (it is counted, `connectivity.states_left_out`, and left out).
    pub fn settling(sc: &swarm_config::Scenario) -> Metrics {
        Metrics { graph: EstimateGraph::settling(sc), ..Metrics::default() }
    }

    /// Notes the static world; paths are measured from the start poses.
    pub fn on_world(&mut self, w: TruthWorld) {
        self.motion.on_world(w);
    }

    /// Folds one ground-truth step.
    pub fn on_step(&mut self, s: &TruthStep) {
        self.liveness.on_step(s);
        self.timing.on_step(s);
        self.motion.on_step(s);
        self.scoring.on_step(s);
        self.graph.settle(self.scoring.oldest_kept());
    }

    /// Folds one agent state.
    pub fn on_state(&mut self, st: AgentState) {
        self.timing.on_state(&st);
        self.links.on_state(&st);
        self.graph.on_state(&st);
        self.traffic.on_state(&st);
        self.scoring.on_state(st);
    }

    /// Whether the hub has marked the last step.
    pub fn ended(&self) -> Option<EndReason> {
        self.motion.ended()
    }

    /// The static world, once known.
    pub fn world(&self) -> Option<&TruthWorld> {
        self.motion.world()
    }

    /// The states scored since the last call, for `localization.csv`.
    pub fn take_scored(&mut self) -> Vec<Scored> {
        self.scoring.take_scored()
    }

    /// The components of the estimate graph at each tick agents reported, in tick order.
    pub fn components_series(&self) -> Vec<ComponentsRow> {
        self.graph.series()
    }

    /// Collisions so far.
    pub fn collision_count(&self) -> usize {
        self.motion.collision_count()
    }

    /// Whether an agent whose command closed the last step has not yet reported the state of
    /// that command's tick (it sends it right after the command, so it is on its way). The
    /// run's last states are waited for on this, so the summary never depends on how fast they
    /// came.
    pub fn awaiting_last_states(&self) -> bool {
        let Some(last) = self.motion.last_step() else { return false };
        let tick = last.tick.saturating_sub(1);
        last.bodies.iter().filter(|b| b.cmd_on_time).any(|b| self.links.last_state_tick(b.id).is_none_or(|t| t < tick))
    }

    /// The last step seen.
    pub fn last_step(&self) -> Option<&TruthStep> {
        self.motion.last_step()
    }

    /// Every UAV the world's starts, a truth step or a state named: the summary's agents, in id
    /// order.
    fn uavs(&self) -> BTreeSet<UavId> {
        self.motion.uavs().chain(self.timing.uavs()).collect()
    }

    /// The summary of what was folded so far.
    pub fn summary(&self, run_id: &str, scenario: &swarm_config::Scenario) -> Summary {
        let uavs = self.uavs();
        let radio = Hysteresis::new(scenario.radio.range_m, scenario.radio.hysteresis_m);
        let agents: Vec<AgentSummary> = uavs
            .iter()
            .map(|&id| {
                let mut a = AgentSummary { id, ..AgentSummary::default() };
                self.motion.fill(&mut a, radio);
                self.links.fill(&mut a);
                self.timing.fill(&mut a);
                self.scoring.fill(&mut a);
                a
            })
            .collect();
        let run = self.motion.summary(&agents);
        let localization = self.scoring.summary(scenario, &agents);
        Summary {
            schema: SCHEMA.into(),
            run_id: run_id.into(),
            scenario: scenario.name.clone(),
            time_mode: scenario.time.mode.name().to_string(),
            uav_count: scenario.count(),
            trees: run.trees,
            end_reason: run.end_reason.into(),
            reached_goal: run.time_to_goal_s.is_some(),
            time_to_goal_s: run.time_to_goal_s,
            sim_time_s: run.sim_time_s,
            wall_time_s: run.wall_time_s,
            sim_speed: run.sim_speed,
            ticks: run.ticks,
            collisions: run.collision_events.len(),
            collision_events: run.collision_events,
            min_obstacle_distance_m: run.min_obstacle_distance_m,
            min_agent_distance_m: run.min_agent_distance_m,
            lattice_spacing_m: run.lattice_spacing_m,
            lattice_spacing_std_m: run.lattice_spacing_std_m,
            localization,
            connectivity: self.graph.summary(scenario),
            network: self.links.summary(),
            formation: run.formation,
            agents,
            timing: self.timing.summary(),
            checks: Vec::new(),
            traffic: self.traffic.summary(),
            never_joined: scenario
                .agent_ids()
                .filter(|&id| uavs.contains(&id) && !self.liveness.ever_alive(id) && self.motion.last_step().is_some())
                .collect(),
            lost: self.liveness.lost().map(|(id, at_s)| LostUav { id, at_s }).collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::fixtures::body;
    use super::*;

    #[test]
    fn the_last_states_are_awaited_for_agents_whose_command_closed_the_last_step() {
        let mut m = Metrics::default();
        assert!(!m.awaiting_last_states(), "no step yet");
        let last = TruthStep {
            tick: 7,
            t_s: 0.7,
            bodies: vec![body(1, 0.0, 5.0, 2.0, true), body(2, 2.0, 5.0, 2.0, false)],
            collisions: vec![],
            goal_reached_at: None,
            ended: Some(EndReason::TimeLimit),
            wall_s: 0.0,
            timing: Default::default(),
        };
        m.on_step(&last);
        assert!(m.awaiting_last_states(), "UAV 1 sent its command of tick 6: its state is due");
        let mut st = AgentState { id: UavId::new(1), tick: 6, t_s: 0.6, step_time_us: 1, ..AgentState::default() };
        st.tick = 5;
        m.on_state(st.clone());
        assert!(m.awaiting_last_states(), "an older state is not the last");
        st.tick = 6;
        m.on_state(st);
        assert!(!m.awaiting_last_states(), "UAV 2's command was late: nothing more is promised");
    }
}

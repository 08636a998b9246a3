//! The run's invariants (issue 15, after Jepsen's checkers): a [`Checker`] is fed the same
//! ground-truth steps and agent states as the recorder's metrics, keeps only what it needs to
//! name the *first* failing moment of each invariant (sim time, UAVs, positions), and at the end
//! turns them, with the finished [`Summary`], into `summary.json`'s `checks[]`. Which checks apply
//! and with what bounds is the scenario's `[expect]` (`swarm_config::Expect`); `swarm run --check`
//! and `swarm fuzz` fail on any failed check.
//!
//! Pure: no IO, no clock, so it is tested with hand-made steps and states. [`Checker`] folds the
//! run; `verdicts` judges each check at the end (those judged only then: connected at the end,
//! the goal, reconnection after each heal).

mod verdicts;

use crate::summary::{CheckFailure, CheckResult, Summary, UavAt};
use std::collections::BTreeMap;
use swarm_config::{Bounds, CheckName, LocalizationMode, Scenario};
use swarm_types::UavId;
use swarm_wire::{AgentState, TruthBody, TruthStep};

/// Ticks of positions kept to place a failure found in a state that arrived late.
const RECENT_TICKS: usize = 64;

/// The sim times of the heals of a scenario's `[[netem]]` timeline: a per-link rule with no
/// impairment, or the end of a partition (several at one instant count once).
pub(crate) fn heal_times(sc: &Scenario) -> Vec<f64> {
    let is_heal = |r: &&swarm_config::NetemRule| match &r.partition {
        None => r.rule.is_identity(),
        Some(p) => *p == swarm_config::Partition::Healed {},
    };
    let mut t: Vec<f64> = sc.netem.iter().filter(is_heal).map(|r| r.at_s).collect();
    t.sort_by(f64::total_cmp);
    t.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
    t
}

/// A heal and what the graph and the UAVs looked like when its reconnection deadline passed.
#[derive(Debug, Clone)]
struct Deadline {
    heal_s: f64,
    due_s: f64,
    /// The tick of the first agent state at or after `due_s`, and the estimate graph then.
    tick: Option<u64>,
    graph: BTreeMap<UavId, Vec<UavId>>,
    positions: Option<Vec<UavAt>>,
}

/// A state that reported neighbours, waiting for the truth of its tick to judge "alone".
#[derive(Debug, Clone, Copy)]
struct Reported {
    id: UavId,
    tick: u64,
    t_s: f64,
    count: usize,
}

/// Folds a run into its checks' first failures.
#[derive(Debug)]
pub struct Checker {
    bounds: Bounds,
    timeline: netem::Timeline,
    /// UVDAR senses bodies, not shares: link cuts do not stale its estimates, and any body is
    /// company.
    senses_bodies: bool,
    collision: Option<CheckFailure>,
    separation: Option<CheckFailure>,
    stale: Option<CheckFailure>,
    alone: Option<CheckFailure>,
    /// Per UAV, the intervals `[from, to)` it was truly alone (`to` infinite while it lasts).
    alone_spans: BTreeMap<UavId, Vec<(f64, f64)>>,
    pending: Vec<Reported>,
    recent: BTreeMap<u64, Vec<UavAt>>,
    /// The last step's tick and its live UAVs (agent alive, not frozen): all the checks need of
    /// it, kept instead of a copy of the whole step every tick.
    last: Option<(u64, Vec<UavAt>)>,
    deadlines: Vec<Deadline>,
    /// Whose agents came and went: a UAV whose agent, alive before, is gone (killed, crashed, cut
    /// off) says nothing from then on, as over a cut link, and its neighbours must drop it as
    /// they drop a silent UAV.
    liveness: crate::liveness::Liveness,
}

fn at(b: &TruthBody) -> UavAt {
    UavAt { id: b.id, x_m: b.x, y_m: b.y }
}

fn failure(t_s: f64, what: String, uavs: Vec<UavAt>) -> Option<CheckFailure> {
    Some(CheckFailure { t_s, what, uavs })
}

impl Checker {
    /// A checker for `sc`'s `[expect]`.
    pub fn new(sc: &Scenario) -> Checker {
        let bounds = sc.bounds();
        let deadlines = heal_times(sc)
            .into_iter()
            .map(|h| Deadline {
                heal_s: h,
                due_s: h + bounds.reconnect_within_s,
                tick: None,
                graph: BTreeMap::new(),
                positions: None,
            })
            .collect();
        Checker {
            bounds,
            timeline: netem::Timeline::from_scenario(sc),
            senses_bodies: sc.localization.mode == LocalizationMode::Uvdar,
            collision: None,
            separation: None,
            stale: None,
            alone: None,
            alone_spans: BTreeMap::new(),
            pending: Vec::new(),
            recent: BTreeMap::new(),
            last: None,
            deadlines,
            liveness: crate::liveness::Liveness::default(),
        }
    }

    /// Whether body `b` counts as company at `t_s`: it is there to be sensed (UVDAR), or its
    /// agent is alive and not frozen, so it can share.
    fn company(&self, b: &TruthBody, t_s: f64) -> bool {
        self.senses_bodies || (b.alive && !self.timeline.frozen_at(b.id, t_s))
    }

    /// Folds one ground-truth step.
    pub fn on_step(&mut self, s: &TruthStep) {
        if self.collision.is_none() {
            if let Some(c) = s.collisions.first() {
                let mut uavs = vec![UavAt { id: c.id, x_m: c.x, y_m: c.y }];
                uavs.extend(c.other_uav.and_then(|o| s.bodies.iter().find(|b| b.id == o)).map(at));
                let with = c.other_uav.map_or("an obstacle".to_string(), |o| format!("UAV {o}"));
                self.collision = failure(s.t_s, format!("UAV {} touched {with}", c.id), uavs);
            }
        }
        if self.separation.is_none() {
            self.separation = self.closest_pair_below(s);
        }
        self.track_alone(s);
        self.liveness.on_step(s);
        self.recent.insert(s.tick, s.bodies.iter().map(at).collect());
        while self.recent.len() > RECENT_TICKS {
            self.recent.pop_first();
        }
        for d in self.deadlines.iter_mut().filter(|d| d.positions.is_none() && s.t_s >= d.due_s - 1e-9) {
            d.positions = Some(s.bodies.iter().map(at).collect());
        }
        let live = s.bodies.iter().filter(|b| b.alive && !self.timeline.frozen_at(b.id, s.t_s)).map(at).collect();
        self.last = Some((s.tick, live));
        let pending = std::mem::take(&mut self.pending);
        let (ready, waiting): (Vec<_>, Vec<_>) = pending.into_iter().partition(|r| r.tick <= s.tick);
        self.pending = waiting;
        for r in ready {
            self.judge_alone(r);
        }
    }

    /// The closest pair of UAVs, when closer than the bound.
    fn closest_pair_below(&self, s: &TruthStep) -> Option<CheckFailure> {
        let b = s
            .bodies
            .iter()
            .filter(|b| b.agent_distance_m < self.bounds.min_separation_m)
            .min_by(|a, b| a.agent_distance_m.total_cmp(&b.agent_distance_m))?;
        let other = s
            .bodies
            .iter()
            .filter(|o| o.id != b.id)
            .min_by(|p, q| (p.x - b.x).hypot(p.y - b.y).total_cmp(&(q.x - b.x).hypot(q.y - b.y)))?;
        let what = format!(
            "UAVs {} and {} {:.2} m apart (bound {:.2} m)",
            b.id, other.id, b.agent_distance_m, self.bounds.min_separation_m
        );
        failure(s.t_s, what, vec![at(b), at(other)])
    }

    /// Opens and closes each UAV's spans of being truly alone.
    fn track_alone(&mut self, s: &TruthStep) {
        let all_company = s.bodies.iter().all(|b| self.company(b, s.t_s));
        for b in &s.bodies {
            // The nearest body of any kind is the quick answer; only when some bodies are no
            // company (dead, frozen) is the UAV's company looked up one by one.
            let alone = b.agent_distance_m > self.bounds.alone_m
                || (!all_company
                    && !s.bodies.iter().any(|o| {
                        o.id != b.id && self.company(o, s.t_s) && (o.x - b.x).hypot(o.y - b.y) <= self.bounds.alone_m
                    }));
            let spans = self.alone_spans.entry(b.id).or_default();
            let open = spans.last().is_some_and(|&(_, to)| to.is_infinite());
            if alone && !open {
                spans.push((s.t_s, f64::INFINITY));
            } else if !alone && open {
                if let Some(last) = spans.last_mut() {
                    last.1 = s.t_s;
                }
            }
        }
    }

    /// Whether `id` was alone all through `[t_s - grace, t_s]`.
    fn alone_through(&self, id: UavId, t_s: f64) -> bool {
        let from = t_s - self.bounds.stale_grace_s;
        self.alone_spans.get(&id).is_some_and(|v| v.iter().any(|&(a, b)| a <= from + 1e-9 && b > t_s + 1e-9))
    }

    fn judge_alone(&mut self, r: Reported) {
        if self.alone.is_none() && self.alone_through(r.id, r.t_s) {
            let what = format!(
                "UAV {} reported {} neighbour(s) with no UAV within {:.1} m for {:.2} s",
                r.id, r.count, self.bounds.alone_m, self.bounds.stale_grace_s
            );
            self.alone = failure(r.t_s, what, self.positions(r.tick, &[r.id]));
        }
    }

    /// Where `ids` were at `tick` (or at the last step, if that tick is no longer kept).
    fn positions(&self, tick: u64, ids: &[UavId]) -> Vec<UavAt> {
        let bodies = self.recent.get(&tick).or_else(|| self.recent.values().next_back());
        bodies.map_or_else(Vec::new, |v| v.iter().filter(|u| ids.contains(&u.id)).cloned().collect())
    }

    /// Whether the link from `from` to `to` is cut (blocked, held, a frozen sender, or one whose
    /// agent is gone) at `t_s`.
    fn cut(&self, from: UavId, to: UavId, t_s: f64) -> bool {
        self.liveness.lost_since(from).is_some_and(|t0| t0 <= t_s + 1e-9)
            || self.timeline.rule_at(t_s, from, to).is_some_and(|r| r.blocked || r.hold)
    }

    /// Folds one agent state.
    pub fn on_state(&mut self, st: &AgentState) {
        let ids: Vec<UavId> = st.neighbours.iter().filter_map(|e| e.id).collect();
        for d in self.deadlines.iter_mut().filter(|d| st.t_s >= d.due_s - 1e-9) {
            if d.tick.is_none() {
                d.tick = Some(st.tick);
            }
            // A frozen agent is a failed individual: the swarm's components are judged without it,
            // as in the recorder's estimate graph.
            if d.tick == Some(st.tick) && !self.timeline.frozen_at(st.id, st.t_s) {
                d.graph.insert(st.id, ids.clone());
            }
        }
        if self.stale.is_none() && !self.senses_bodies {
            let g = self.bounds.stale_grace_s;
            // Cut at the state's time, a grace ago, and half way: cut through the whole grace.
            let across = ids.iter().find(|&&j| [0.0, 0.5 * g, g].iter().all(|dt| self.cut(j, st.id, st.t_s - dt)));
            if let Some(&j) = across {
                let what = format!("UAV {} held an estimate of UAV {j} over a link cut for more than {g:.2} s", st.id);
                self.stale = failure(st.t_s, what, self.positions(st.tick, &[st.id, j]));
            }
        }
        if !st.neighbours.is_empty() && self.alone.is_none() {
            let r = Reported { id: st.id, tick: st.tick, t_s: st.t_s, count: st.neighbours.len() };
            if self.last.as_ref().is_some_and(|&(tick, _)| tick >= st.tick) {
                self.judge_alone(r);
            } else {
                self.pending.push(r);
            }
        }
    }

    /// The checks of `sc`'s `[expect]`, judged over the run summarized by `summary`.
    pub fn finish(self, sc: &Scenario, summary: &Summary) -> Vec<CheckResult> {
        CheckName::ALL.iter().filter(|&&c| sc.expects(c)).map(|&c| self.verdict(c, sc, summary)).collect()
    }
}

#[cfg(test)]
mod tests;

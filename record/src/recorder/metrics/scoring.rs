//! Scoring: every neighbour estimate an agent held, placed against the ground truth of the
//! state's tick in the agent's body frame (localization errors, false estimates, how often a UAV
//! was placed right by the others), and the contacts lost and regained. Why its own part: it is
//! the one fold that joins the two streams, so it keeps recent truth by tick and holds the states
//! whose truth has not come yet, and every state is scored against its own tick's truth however
//! far the recorder lags; `localization.csv` is its rows.

use super::stats::{mean_finite, quantile};
use crate::recorder::tally::Tally;
use crate::summary::{AgentSummary, ContactEvent, LocalizationSummary};
use std::collections::{BTreeMap, HashMap};
use swarm_types::UavId;
use swarm_wire::{AgentState, TruthBody, TruthStep};

/// One agent state's neighbour estimates scored against the truth of its tick: a row of
/// `localization.csv`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scored {
    /// Tick of the state.
    pub tick: u64,
    /// Sim time of the state [s].
    pub t_s: f64,
    /// Agent id.
    pub id: UavId,
    /// Estimates it held.
    pub neighbours: usize,
    /// Estimates that could be scored (with a sender id, of a UAV in the truth).
    pub scored: usize,
    /// Mean distance between estimate and truth [m] (NaN when none was scored).
    pub mean_error_m: f64,
    /// Largest distance between estimate and truth [m] (NaN when none was scored).
    pub max_error_m: f64,
}

/// An estimate farther than this from the truth places a neighbour where none is.
pub const FALSE_ESTIMATE_M: f64 = 1.0;

/// A UAV with no live UAV closer than this is alone: any neighbour it reports is false (seed 000
/// 6.2: the separated UAV lost its last neighbour at about 6.7 m and then reported none).
pub const ALONE_M: f64 = 8.0;

/// Ticks of truth kept for scoring states that arrive late.
pub(super) const TRUTH_KEPT: u64 = 200;

/// One agent's estimates, as held and as scored.
#[derive(Debug, Clone, Default)]
struct UavScoring {
    /// States folded.
    steps: u64,
    /// Estimates held, summed over its states.
    neighbours_sum: u64,
    /// How many steps had each neighbour count.
    neighbour_counts: BTreeMap<usize, u64>,
    /// Age of each neighbour estimate it held [s].
    ages: Tally,
    /// Distance between each neighbour estimate and the truth at the same tick [m].
    loc_errors: Vec<f64>,
    /// Estimates farther than [`FALSE_ESTIMATE_M`] from the truth.
    false_estimates: u64,
    /// Neighbour count at the last scored state.
    last_count: Option<usize>,
    /// Times it lost all neighbours or found one again.
    contacts: Vec<ContactEvent>,
    /// Neighbours it reported while alone (no live UAV within [`ALONE_M`]).
    reported_while_alone: u64,
    /// Steps it spent alone.
    steps_alone: u64,
}

/// The scoring of every agent's estimates, folded from the truth steps and the states.
#[derive(Debug, Default)]
pub(super) struct Scoring {
    /// Per UAV that sent a state.
    uavs: BTreeMap<UavId, UavScoring>,
    /// Recent ground truth by tick, to score agents' estimates against.
    truth: BTreeMap<u64, TickTruth>,
    /// The tick of the last truth step folded.
    last_tick: Option<u64>,
    /// States whose tick's truth has not arrived yet, by tick, each with its arrival number: a
    /// truth step takes the states of its tick and before without touching the later ones (a
    /// recorder lagging behind the agents holds thousands; re-sorting them all at every step
    /// made its catching up quadratic), and scores them in arrival order, as they came.
    pending: BTreeMap<u64, Vec<(u64, AgentState)>>,
    /// States held in `pending` so far (the next arrival number).
    pending_arrivals: u64,
    /// States scored since the last [`Scoring::take_scored`].
    scored: Vec<Scored>,
    /// Per UAV, estimates of it by others within [`FALSE_ESTIMATE_M`] of the truth. Kept apart
    /// from [`UavScoring`] in a hash map: every placed estimate counts one (about 18 000 a tick
    /// at open-1000), and a search of the ordered map of every agent's accumulator was the
    /// largest part of scoring. Every UAV counted here was a body of a truth step (scoring needs
    /// its tick's truth), so the summary lists it.
    placed_by_others: HashMap<UavId, u64>,
}

/// Where neighbour `j` truly is in `i`'s body frame, given `(sin, cos)` of `i`'s yaw (taken once
/// per state: a state scores about 18 estimates, and `sin_cos` per estimate was most of the
/// recorder's arithmetic at 1000 UAVs).
fn true_relative(i: &TruthBody, (s, c): (f64, f64), j: &TruthBody) -> (f64, f64) {
    let (dx, dy) = (j.x - i.x, j.y - i.y);
    (c * dx + s * dy, -s * dx + c * dy)
}

/// UAV `id`'s body in a truth step's `bodies` (listed in id order, so found by index; searched
/// only if that ever changes).
fn body_of(bodies: &[TruthBody], id: UavId) -> Option<&TruthBody> {
    let at = id.try_index().and_then(|i| bodies.get(i)).filter(|b| b.id == id);
    at.or_else(|| bodies.iter().find(|b| b.id == id))
}

/// One tick's ground truth, kept for scoring the states of that tick.
#[derive(Debug)]
struct TickTruth {
    bodies: Vec<TruthBody>,
    /// Whether every body's agent is alive: found once per tick, not once per state (at 1000
    /// UAVs that test per state was O(n²) a tick).
    all_alive: bool,
}

impl TickTruth {
    fn of(bodies: Vec<TruthBody>) -> TickTruth {
        let all_alive = bodies.iter().all(|b| b.alive);
        TickTruth { bodies, all_alive }
    }
}

/// The distance from `me` to the nearest other live UAV of `bodies`, centre to centre [m].
/// Scanning every body for every agent state cost O(n²) per tick (most of the recorder's time
/// at 1000 UAVs); the hub's `agent_distance_m` (nearest UAV of any kind, computed with a
/// different rounding) answers "farther than a bound?" when every UAV is alive and it is not
/// within 1e-9 m of the bound, and the exact scan is made only otherwise, so every answer is
/// the scan's, bit for bit.
struct NearestLive<'a> {
    bodies: &'a [TruthBody],
    me: &'a TruthBody,
    /// Whether every body of `bodies` is alive ([`TickTruth::all_alive`]).
    all_alive: bool,
}

impl NearestLive<'_> {
    /// The exact distance: min over the other live bodies of `hypot(dx, dy)`.
    fn exact(&self) -> f64 {
        let me = self.me;
        self.bodies
            .iter()
            .filter(|b| b.id != me.id && b.alive)
            .map(|b| (b.x - me.x).hypot(b.y - me.y))
            .fold(f64::INFINITY, f64::min)
    }

    /// Whether [`NearestLive::exact`] is greater than `bound_m`.
    fn beyond(&self, bound_m: f64) -> bool {
        let hub_m = self.me.agent_distance_m;
        if hub_m.is_finite() && (hub_m - bound_m).abs() > 1e-9 && self.all_alive {
            hub_m > bound_m
        } else {
            self.exact() > bound_m
        }
    }
}

impl Scoring {
    /// Keeps the truth of one step (the last [`TRUTH_KEPT`] ticks are kept) and scores the
    /// states held for its tick and before, in arrival order.
    pub(super) fn on_step(&mut self, s: &TruthStep) {
        self.truth.insert(s.tick, TickTruth::of(s.bodies.clone()));
        while self.truth.len() as u64 > TRUTH_KEPT {
            self.truth.pop_first();
        }
        let later = self.pending.split_off(&s.tick.saturating_add(1));
        let mut ready: Vec<(u64, AgentState)> =
            std::mem::replace(&mut self.pending, later).into_values().flatten().collect();
        ready.sort_unstable_by_key(|&(arrival, _)| arrival);
        for (_, st) in ready {
            self.score(&st);
        }
        self.last_tick = Some(s.tick);
    }

    /// The oldest tick of truth kept once [`TRUTH_KEPT`] are: no state older than it can be
    /// scored any more (`None` while fewer are kept).
    pub(super) fn oldest_kept(&self) -> Option<u64> {
        self.truth.keys().next().copied().filter(|_| self.truth.len() as u64 >= TRUTH_KEPT)
    }

    /// Folds one agent state: notes the estimates it held, and scores it if its tick's truth is
    /// here, or holds it until it comes (a state older than the last truth step and without its
    /// truth is not scored: tick 0, or a tick whose truth is no longer kept).
    pub(super) fn on_state(&mut self, st: AgentState) {
        let a = self.uavs.entry(st.id).or_default();
        a.steps += 1;
        a.neighbours_sum += st.neighbours.len() as u64;
        *a.neighbour_counts.entry(st.neighbours.len()).or_default() += 1;
        st.neighbours.iter().for_each(|e| a.ages.push(f64::from(e.age_s)));
        if self.truth.contains_key(&st.tick) {
            self.score(&st);
        } else if self.last_tick.is_none_or(|tick| st.tick > tick) {
            self.pending.entry(st.tick).or_default().push((self.pending_arrivals, st));
            self.pending_arrivals += 1;
        }
    }

    /// Scores a state's neighbour estimates against the truth of its tick (estimates without a
    /// sender id cannot be scored). Tick 0 has no truth step: its states are not scored.
    fn score(&mut self, st: &AgentState) {
        let Some(TickTruth { bodies, all_alive }) = self.truth.get(&st.tick) else { return };
        let Some(me) = body_of(bodies, st.id) else { return };
        let turn = me.yaw.sin_cos();
        let placed: Vec<(UavId, f64)> = st
            .neighbours
            .iter()
            .filter_map(|e| {
                let id = e.id?;
                let other = body_of(bodies, id)?;
                let (x, y) = true_relative(me, turn, other);
                Some((id, (f64::from(e.x) - x).hypot(f64::from(e.y) - y)))
            })
            .collect();
        for &(id, _) in placed.iter().filter(|(_, e)| *e <= FALSE_ESTIMATE_M) {
            *self.placed_by_others.entry(id).or_default() += 1;
        }
        let errors: Vec<f64> = placed.iter().map(|&(_, e)| e).collect();
        // Contact lost (some neighbours -> none) or regained, with the true distance to the
        // nearest other live UAV at that moment (seed 000 6.2: lost at ~6.7 m, regained at
        // ~6.3 m). A failed UAV shares nothing, so it is no company.
        let count = st.neighbours.len();
        let nearest = NearestLive { bodies, me, all_alive: *all_alive };
        let alone = nearest.beyond(ALONE_M);
        let a = self.uavs.entry(st.id).or_default();
        if alone {
            a.steps_alone += 1;
            a.reported_while_alone += count as u64;
        }
        // The first acquisition at start is not a regain: only a contact lost can be regained.
        let lost_before = a.contacts.last().is_some_and(|c| !c.regained);
        if let Some(prev) = a.last_count {
            let lost = prev > 0 && count == 0;
            let regained = prev == 0 && count > 0 && lost_before;
            if lost || regained {
                a.contacts.push(ContactEvent { t_s: st.t_s, regained, nearest_uav_m: nearest.exact() });
            }
        }
        a.last_count = Some(count);
        let mean_error_m = if errors.is_empty() { f64::NAN } else { errors.iter().sum::<f64>() / errors.len() as f64 };
        let max_error_m = errors.iter().copied().reduce(f64::max).unwrap_or(f64::NAN);
        self.scored.push(Scored {
            tick: st.tick,
            t_s: st.t_s,
            id: st.id,
            neighbours: count,
            scored: errors.len(),
            mean_error_m,
            max_error_m,
        });
        a.false_estimates += errors.iter().filter(|&&e| e > FALSE_ESTIMATE_M).count() as u64;
        a.loc_errors.extend(errors);
    }

    /// The states scored since the last call, for `localization.csv`.
    pub(super) fn take_scored(&mut self) -> Vec<Scored> {
        std::mem::take(&mut self.scored)
    }

    /// Fills in `a`'s neighbour counts, localization errors, contacts and information ages.
    pub(super) fn fill(&self, a: &mut AgentSummary) {
        let blank = UavScoring::default();
        let s = self.uavs.get(&a.id).unwrap_or(&blank);
        let steps = s.steps.max(1) as f64;
        a.mean_neighbours = s.neighbours_sum as f64 / steps;
        a.mean_localization_error_m = if s.loc_errors.is_empty() {
            f64::NAN
        } else {
            s.loc_errors.iter().sum::<f64>() / s.loc_errors.len() as f64
        };
        a.p95_localization_error_m = quantile(&s.loc_errors, 0.95);
        a.stable_neighbour_share = s.neighbour_counts.values().max().map_or(f64::NAN, |&m| m as f64 / steps);
        a.false_estimates = s.false_estimates;
        a.placed_by_others = self.placed_by_others.get(&a.id).copied().unwrap_or(0);
        a.contact_events = s.contacts.clone();
        a.steps_alone = s.steps_alone;
        a.neighbours_reported_while_alone = s.reported_while_alone;
        a.mean_info_age_s = s.ages.mean_finite();
        a.p95_info_age_s = s.ages.quantile(0.95);
    }

    /// The localization part of the summary, for `sc`, over the agents' summaries `agents`
    /// (filled in by every part: the bytes per share message are the links').
    pub(super) fn summary(&self, sc: &swarm_config::Scenario, agents: &[AgentSummary]) -> LocalizationSummary {
        let all_errors: Vec<f64> = self.uavs.values().flat_map(|a| a.loc_errors.iter().copied()).collect();
        let all_ages = self.uavs.values().fold(Tally::default(), |mut t, a| {
            t.merge(&a.ages);
            t
        });
        let (sent_msgs, sent_bytes) = agents.iter().fold((0, 0), |(m, b), a| (m + a.messages_sent, b + a.bytes_sent));
        LocalizationSummary {
            mode: sc.localization.mode.name().to_string(),
            estimates_scored: all_errors.len() as u64,
            mean_error_m: mean_finite(all_errors.iter().copied()),
            p95_error_m: quantile(&all_errors, 0.95),
            stable_neighbour_share: mean_finite(agents.iter().map(|a| a.stable_neighbour_share)),
            bytes_per_share_message: if sent_msgs > 0 { sent_bytes as f64 / sent_msgs as f64 } else { f64::NAN },
            false_estimates: agents.iter().map(|a| a.false_estimates).sum(),
            mean_info_age_s: all_ages.mean_finite(),
            p95_info_age_s: all_ages.quantile(0.95),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::fixtures::{blank_state, body};
    use super::super::Metrics;
    use super::*;
    use swarm_wire::NeighbourEstimate;

    #[test]
    fn the_nearest_live_uav_answers_as_the_full_scan_does() {
        // UAVs on the x axis at 0, 8 and 20 m; the hub's nearest distances are exact here.
        let mk = |x: f64, ad: f64| {
            let mut b = body(1, x, 5.0, ad, true);
            b.id = UavId::new((x as u32) + 1);
            b
        };
        let bodies = vec![mk(0.0, 8.0), mk(8.0, 8.0), mk(20.0, 12.0)];
        let all_alive = TickTruth::of(bodies.clone()).all_alive;
        assert!(all_alive);
        for me in &bodies {
            let n = NearestLive { bodies: &bodies, me, all_alive };
            for bound in [7.0, 8.0, 8.0 + 1e-12, 11.0, 12.5] {
                assert_eq!(n.beyond(bound), n.exact() > bound, "UAV {} bound {bound}", me.id);
            }
        }
        // A dead neighbour is no company: the hub's distance (any UAV) would say 8 m.
        let mut with_dead = bodies.clone();
        with_dead[1].alive = false;
        let all_alive = TickTruth::of(with_dead.clone()).all_alive;
        assert!(!all_alive, "one body's agent is dead");
        let n = NearestLive { bodies: &with_dead, me: &with_dead[0], all_alive };
        assert_eq!(n.exact(), 20.0);
        assert!(n.beyond(10.0), "the scan decides when some UAV is not alive");
        assert_eq!(body_of(&bodies, UavId::new(9)).map(|b| b.x), Some(8.0), "ids need not be 1..=n in order");
        assert!(body_of(&bodies, UavId::new(4)).is_none());
    }

    #[test]
    fn estimates_are_scored_against_truth_of_their_tick_in_the_body_frame() {
        let sc = swarm_config::builtin("open-field-5").expect("builtin");
        let mut m = Metrics::default();
        // UAV 1 at the origin facing +y; UAV 2 two metres to its front (world (0, 2)).
        let mut b1 = body(1, 0.0, 5.0, 2.0, true);
        b1.yaw = std::f64::consts::FRAC_PI_2;
        let mut b2 = body(2, 0.0, 5.0, 2.0, true);
        b2.y = 2.0;
        let truth = |tick| TruthStep { tick, t_s: 0.1 * tick as f64, bodies: vec![b1, b2], ..Default::default() };
        let state = |tick, x: f32, n: usize| AgentState {
            tick,
            neighbours: vec![NeighbourEstimate { id: Some(UavId::new(2)), x, y: 0.0, heading: 0.0, age_s: 0.0 }; n],
            in_radio_range: 1,
            ..blank_state(1)
        };
        m.on_step(&truth(1));
        m.on_state(state(1, 2.1, 1)); // truth first: scored at once, error 0.1
        m.on_state(state(2, 1.7, 1)); // before its truth: held
        m.on_step(&truth(2)); // now scored, error 0.3
        m.on_state(state(3, 2.0, 2)); // a step with two estimates (the count changes)
        m.on_step(&truth(3));
        let rows = m.take_scored();
        assert_eq!(
            rows.iter().map(|r| (r.tick, r.scored)).collect::<Vec<_>>(),
            vec![(1, 1), (2, 1), (3, 2)],
            "one row per scored state, in scoring order"
        );
        assert!((rows[1].mean_error_m - 0.3).abs() < 1e-6 && (rows[1].max_error_m - 0.3).abs() < 1e-6);
        assert!(m.take_scored().is_empty(), "taken once");
        let comps = m.components_series();
        assert_eq!(
            comps.iter().map(|c| (c.tick, c.reporting, c.components)).collect::<Vec<_>>(),
            vec![(1, 1, 1), (2, 1, 1), (3, 1, 1)]
        );
        let s = m.summary("r", &sc);
        assert_eq!(s.localization.estimates_scored, 4);
        assert!((s.localization.mean_error_m - 0.1).abs() < 1e-6, "{}", s.localization.mean_error_m);
        assert!((s.localization.p95_error_m - 0.3).abs() < 1e-6);
        assert!((s.agents[0].stable_neighbour_share - 2.0 / 3.0).abs() < 1e-12);
        assert_eq!(s.localization.false_estimates, 0);
        // Alone at tick 4, with a wildly wrong estimate at tick 5: one loss, one regain, one false.
        m.on_step(&truth(4));
        m.on_state(state(4, 0.0, 0));
        m.on_step(&truth(5));
        m.on_state(state(5, -8.0, 1));
        let s = m.summary("r", &sc);
        let c = &s.agents[0].contact_events;
        assert_eq!(c.len(), 2);
        assert!(!c[0].regained && c[1].regained);
        assert_eq!(c[0].nearest_uav_m, 2.0, "true distance at that moment");
        assert_eq!(s.localization.false_estimates, 1);
        assert_eq!(s.agents[0].steps_alone, 0);
        // Neighbour 2 flies 10 m away: UAV 1 is alone, and a neighbour it reports then is false.
        b2.y = 10.0;
        // As the hub would report it: each one's nearest UAV is now 10 m away.
        (b1.agent_distance_m, b2.agent_distance_m) = (10.0, 10.0);
        let far = |tick| TruthStep { tick, t_s: 0.1 * tick as f64, bodies: vec![b1, b2], ..Default::default() };
        m.on_step(&far(6));
        m.on_state(state(6, 10.0, 1));
        let s = m.summary("r", &sc);
        assert_eq!((s.agents[0].steps_alone, s.agents[0].neighbours_reported_while_alone), (1, 1));
    }
}

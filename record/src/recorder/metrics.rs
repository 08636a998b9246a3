//! The recorder's pure half: [`Metrics`] folds ground truth and agent states, message by
//! message, into a [`Summary`] (distances, paths, collisions, localization errors, connectivity,
//! formation quality) when the hub marks the last step. No IO and no clock, so it is tested
//! without a network.

use super::solitude::solitude;
use super::tally::Tally;
use crate::summary::{
    AgentSummary, ClassSummary, CollisionRecord, ComponentsAt, Connectivity, ContactEvent, FormationMetrics,
    LocalizationSummary, LostUav, Reconnection, SessionTrafficSummary, Summary, TimingSummary, TrafficSummary, SCHEMA,
};
use std::collections::{BTreeMap, HashMap};
use swarm_wire::{AgentState, ClassCounts, EndReason, LinkCounters, Traffic, TruthBody, TruthStep, TruthWorld};

/// One UAV's samples over the run.
#[derive(Debug, Clone, Default)]
struct Track {
    /// `(t_s, x_m, y_m, obstacle_distance_m, agent_distance_m)` per tick.
    samples: Vec<[f64; 5]>,
}

/// One agent state's neighbour estimates scored against the truth of its tick: a row of
/// `localization.csv`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scored {
    /// Tick of the state.
    pub tick: u64,
    /// Sim time of the state [s].
    pub t_s: f64,
    /// Agent id.
    pub id: u32,
    /// Estimates it held.
    pub neighbours: usize,
    /// Estimates that could be scored (with a sender id, of a UAV in the truth).
    pub scored: usize,
    /// Mean distance between estimate and truth [m] (NaN when none was scored).
    pub mean_error_m: f64,
    /// Largest distance between estimate and truth [m] (NaN when none was scored).
    pub max_error_m: f64,
}

/// The estimate graph at one tick: a row of `connectivity.csv`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ComponentsRow {
    /// Tick.
    pub tick: u64,
    /// Sim time [s].
    pub t_s: f64,
    /// Agents that reported at that tick.
    pub reporting: usize,
    /// Its weakly connected components.
    pub components: usize,
}

/// The window at the end of a run over which the lattice spacing is reported [s].
const LATTICE_WINDOW_S: f64 = 10.0;

#[derive(Debug, Clone)]
struct Acc {
    min_obst: f64,
    sum_obst: f64,
    min_agent: f64,
    sum_agent: f64,
    n: u64,
    path: f64,
    last: Option<(f64, f64)>,
    late: u64,
    step_us_sum: f64,
    step_us_max: f64,
    steps: u64,
    neighbours_sum: u64,
    /// The tick and link counters of its latest state (all that is kept of it: the state itself
    /// waits in `pending` for its tick's truth, moved, not copied).
    last_state: Option<(u64, LinkCounters)>,
    /// Distance between each neighbour estimate and the truth at the same tick [m].
    loc_errors: Vec<f64>,
    /// How many steps had each neighbour count.
    neighbour_counts: BTreeMap<usize, u64>,
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
    /// Age of each neighbour estimate it held [s].
    ages: Tally,
    /// Link class counts of its earlier incarnations (a restarted agent counts from zero).
    link_base: [ClassCounts; 3],
}

impl Default for Acc {
    fn default() -> Self {
        Acc {
            min_obst: f64::INFINITY,
            sum_obst: 0.0,
            min_agent: f64::INFINITY,
            sum_agent: 0.0,
            n: 0,
            path: 0.0,
            last: None,
            late: 0,
            step_us_sum: 0.0,
            step_us_max: 0.0,
            steps: 0,
            neighbours_sum: 0,
            last_state: None,
            loc_errors: Vec::new(),
            neighbour_counts: BTreeMap::new(),
            false_estimates: 0,
            last_count: None,
            contacts: Vec::new(),
            reported_while_alone: 0,
            steps_alone: 0,
            ages: Tally::default(),
            link_base: [ClassCounts::default(); 3],
        }
    }
}

impl Acc {
    /// Its link class counts over every incarnation so far.
    fn link_classes(&self) -> [ClassCounts; 3] {
        let last = self.last_state.map(|(_, link)| link.classes).unwrap_or_default();
        std::array::from_fn(|i| self.link_base[i] + last[i])
    }
}

/// Everything the summary needs, folded message by message.
#[derive(Debug, Default)]
pub struct Metrics {
    world: Option<TruthWorld>,
    agents: BTreeMap<u32, Acc>,
    collisions: Vec<CollisionRecord>,
    last_step: Option<TruthStep>,
    ticks: u64,
    tracks: BTreeMap<u32, Track>,
    /// Whose agents came, and which came and went (`never_joined`, `lost`).
    liveness: crate::liveness::Liveness,
    /// Recent ground truth by tick, to score agents' estimates against.
    truth: BTreeMap<u64, TickTruth>,
    /// States whose tick's truth has not arrived yet, by tick, each with its arrival number: a
    /// truth step takes the states of its tick and before without touching the later ones (a
    /// recorder lagging behind the agents holds thousands; re-sorting them all at every step
    /// made its catching up quadratic), and scores them in arrival order, as they came.
    pending: BTreeMap<u64, Vec<(u64, AgentState)>>,
    /// States held in `pending` so far (the next arrival number).
    pending_arrivals: u64,
    /// Per tick: (sim time, for each agent that reported, the ids it has an estimate of). With
    /// [`Metrics::settling`], only the ticks not yet settled.
    known: BTreeMap<u64, (f64, BTreeMap<u32, Vec<u32>>)>,
    /// What [`Metrics::settling`] keeps of the ticks it settled, in tick order.
    settled: Vec<SettledTick>,
    /// The scenario's netem timeline and staleness grace [s], to settle ticks with.
    settle_by: Option<(netem::Timeline, f64)>,
    /// States that came for a tick already settled (left out of the connectivity series).
    settled_late: u64,
    /// Delay applied to each delivered copy, per link class [s].
    delays: [Tally; 3],
    /// Mean nearest-neighbour distance over the UAVs at each tick: (sim time, metres).
    spacing: Vec<(f64, f64)>,
    /// The hub's own work of each tick [µs].
    hub_work_us: Vec<f64>,
    /// Every agent step's wall time [µs].
    step_us: Vec<f64>,
    /// Commands the hub took.
    commands: u64,
    /// How late each late command was [ms].
    late_ms: Vec<f64>,
    /// States scored since the last [`Metrics::take_scored`].
    scored: Vec<Scored>,
    /// Per UAV, estimates of it by others within [`FALSE_ESTIMATE_M`] of the truth. Kept apart
    /// from [`Acc`] in a hash map: every placed estimate counts one (about 18 000 a tick at
    /// open-1000), and a search of the ordered map of every agent's accumulator was the largest
    /// part of scoring. Every UAV counted here has its [`Acc`] (scoring needs its tick's truth,
    /// which [`Metrics::on_step`] took body by body).
    placed_by_others: HashMap<u32, u64>,
    /// What each agent session received, by session id.
    sessions: BTreeMap<String, SessionAcc>,
}

/// One agent session's traffic, folded from its agents' states.
#[derive(Debug, Default)]
struct SessionAcc {
    /// Its counts as of the latest state (each field the largest seen: counts only grow, and
    /// its agents' states arrive in any order).
    last: Traffic,
    /// Each of its agents' own counts.
    agents: BTreeMap<u32, AgentTraffic>,
    /// Subscriptions summed over the states, and the states.
    subscriptions: (u64, u64),
}

/// One agent's own counts as of its latest state, and the ticks it reported.
#[derive(Debug, Default, Clone, Copy)]
struct AgentTraffic {
    ticks: Option<(u64, u64)>,
    /// Shares its link counted (inside a neighbour's window).
    counted: u64,
    /// Shares that reached it, and the payload bytes it received.
    shares: u64,
    bytes: u64,
}

impl AgentTraffic {
    fn span(&self) -> u64 {
        self.ticks.map_or(0, |(a, b)| b - a + 1)
    }
}

/// `(first, last)` widened to take `tick`.
fn widen(span: Option<(u64, u64)>, tick: u64) -> Option<(u64, u64)> {
    Some(span.map_or((tick, tick), |(a, b)| (a.min(tick), b.max(tick))))
}

impl SessionAcc {
    fn fold(&mut self, st: &AgentState) {
        let (t, l) = (&st.traffic, &mut self.last);
        l.shares = l.shares.max(t.shares);
        l.bytes = l.bytes.max(t.bytes);
        l.remote_shares = l.remote_shares.max(t.remote_shares);
        l.remote_share_bytes = l.remote_share_bytes.max(t.remote_share_bytes);
        let a = self.agents.entry(st.id).or_default();
        a.ticks = widen(a.ticks, st.tick);
        a.counted = a.counted.max(st.link.recv_msgs);
        a.shares = a.shares.max(t.agent_shares);
        a.bytes = a.bytes.max(t.agent_bytes);
        self.subscriptions.0 += u64::from(t.subscriptions);
        self.subscriptions.1 += 1;
    }

    /// Its summary, for session `session`.
    fn summary(&self, session: &str) -> SessionTrafficSummary {
        // First and last tick any of its agents reported.
        let span = self.agents.values().filter_map(|a| a.ticks).reduce(|(a, b), (c, d)| (a.min(c), b.max(d)));
        let ticks = span.map_or(0, |(a, b)| b - a + 1);
        let per_tick = |v: u64| if ticks > 0 { v as f64 / ticks as f64 } else { 0.0 };
        SessionTrafficSummary {
            session: session.to_string(),
            agents: self.agents.len(),
            uavs: self.agents.keys().copied().collect(),
            ticks,
            shares_arrived_per_tick: per_tick(self.last.shares),
            shares_counted_per_tick: per_tick(self.agents.values().map(|a| a.counted).sum()),
            bytes_per_tick: per_tick(self.last.bytes),
            remote_shares_per_tick: per_tick(self.last.remote_shares),
            remote_share_bytes_per_tick: per_tick(self.last.remote_share_bytes),
            subscriptions_mean: self.subscriptions.0 as f64 / self.subscriptions.1.max(1) as f64,
        }
    }
}

/// An estimate farther than this from the truth places a neighbour where none is.
pub const FALSE_ESTIMATE_M: f64 = 1.0;

/// A UAV with no live UAV closer than this is alone: any neighbour it reports is false (seed 000
/// 6.2: the separated UAV lost its last neighbour at about 6.7 m and then reported none).
pub const ALONE_M: f64 = 8.0;

/// Ticks of truth kept for scoring states that arrive late.
const TRUTH_KEPT: u64 = 200;

/// Where neighbour `j` truly is in `i`'s body frame, given `(sin, cos)` of `i`'s yaw (taken once
/// per state: a state scores about 18 estimates, and `sin_cos` per estimate was most of the
/// recorder's arithmetic at 1000 UAVs).
fn true_relative(i: &TruthBody, (s, c): (f64, f64), j: &TruthBody) -> (f64, f64) {
    let (dx, dy) = (j.x - i.x, j.y - i.y);
    (c * dx + s * dy, -s * dx + c * dy)
}

/// Weakly connected components of the estimate graph over the agents that reported.
fn components(known: &BTreeMap<u32, Vec<u32>>) -> usize {
    // Union-find over the reporting ids by index, with path halving and union by size, so a
    // 1000-UAV run's hundreds of ticks cost about O(edges) each (plain parent links made chains
    // as long as the swarm: minutes of summary after open-1000).
    let index = IdIndex::new(known.keys().copied());
    let mut parent: Vec<usize> = (0..known.len()).collect();
    let mut size = vec![1usize; known.len()];
    fn root(parent: &mut [usize], mut x: usize) -> usize {
        while parent[x] != x {
            parent[x] = parent[parent[x]];
            x = parent[x];
        }
        x
    }
    let mut count = known.len();
    // `known` goes in id order, so an id's index is its place in that order.
    for (i, js) in known.values().enumerate() {
        for &j in js {
            let Some(b) = index.get(j) else { continue };
            let (mut a, mut b) = (root(&mut parent, i), root(&mut parent, b));
            if a == b {
                continue;
            }
            if size[a] < size[b] {
                std::mem::swap(&mut a, &mut b);
            }
            parent[b] = a;
            size[a] += size[b];
            count -= 1;
        }
    }
    count
}

/// The place of each id in an ascending list of distinct ids, by id: what [`components`] looks
/// up once per estimate (about 18 000 a tick at open-1000, where an ordered map's search was
/// most of settling a tick, `perf`). A table indexed by id when the largest id is not much more
/// than the count (a run's UAVs are 1..=N), a binary search of the list otherwise.
enum IdIndex {
    /// `table[id]`: the place of `id`, or `u32::MAX` for an id not in the list.
    Table(Vec<u32>),
    /// The ids, ascending.
    Sorted(Vec<u32>),
}

impl IdIndex {
    /// The index of `ids`, which must be ascending and distinct.
    fn new(ids: impl Iterator<Item = u32>) -> IdIndex {
        let ids: Vec<u32> = ids.collect();
        debug_assert!(ids.windows(2).all(|w| w[0] < w[1]), "ascending, distinct");
        let top = ids.last().map_or(0, |&id| id as usize);
        if top > 4 * ids.len() + 64 {
            return IdIndex::Sorted(ids);
        }
        let mut table = vec![u32::MAX; top + 1];
        for (k, &id) in ids.iter().enumerate() {
            table[id as usize] = k as u32;
        }
        IdIndex::Table(table)
    }

    /// The place of `id` in the list, if it is there.
    fn get(&self, id: u32) -> Option<usize> {
        match self {
            IdIndex::Table(table) => table.get(id as usize).filter(|&&k| k != u32::MAX).map(|&k| k as usize),
            IdIndex::Sorted(ids) => ids.binary_search(&id).ok(),
        }
    }
}

/// Tick `tick`'s row of the connectivity series, at sim time `t`, from its estimate graph.
fn components_row(tick: u64, t: f64, known: &BTreeMap<u32, Vec<u32>>) -> ComponentsRow {
    ComponentsRow { tick, t_s: t, reporting: known.len(), components: components(known) }
}

/// A tick of the estimate graph, settled: its row of the connectivity series and its estimates
/// across blocked links.
#[derive(Debug, Clone, Copy)]
struct SettledTick {
    row: ComponentsRow,
    across: u64,
}

/// What counts an estimate as held across a blocked link: `sc`'s netem timeline, and the grace
/// (the estimate staleness and a tick) for which the link must have been blocked already.
fn blocked_links(sc: &swarm_config::Scenario) -> (netem::Timeline, f64) {
    (netem::Timeline::from_scenario(sc), sc.localization.stale_after_s + sc.dt_secs())
}

/// Estimates at sim time `t` across a link that `timeline` had blocked both then and `grace`
/// before (held over a cut longer than the staleness allows).
fn across_blocked(timeline: &netem::Timeline, grace: f64, t: f64, known: &BTreeMap<u32, Vec<u32>>) -> u64 {
    let blocked = |from: u32, to: u32, at: f64| timeline.rule_at(at, from, to).is_some_and(|r| r.blocked);
    known
        .iter()
        .map(|(&i, ids)| ids.iter().filter(|&&j| blocked(j, i, t) && blocked(j, i, t - grace)).count() as u64)
        .sum()
}

/// UAV `id`'s body in a truth step's `bodies` (listed in id order, so found by index; searched
/// only if that ever changes).
fn body_of(bodies: &[TruthBody], id: u32) -> Option<&TruthBody> {
    let at = (id as usize).checked_sub(1).and_then(|i| bodies.get(i)).filter(|b| b.id == id);
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

/// Mean of the finite values (agents with no steps, such as failed UAVs, have NaN), NaN if none.
pub(super) fn mean_finite(v: impl Iterator<Item = f64>) -> f64 {
    let (sum, n) = v.filter(|x| x.is_finite()).fold((0.0, 0u32), |(s, n), x| (s + x, n + 1));
    if n == 0 {
        f64::NAN
    } else {
        sum / f64::from(n)
    }
}

/// The `q`-quantile (nearest rank) of unsorted values.
pub(super) fn quantile(v: &[f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s[((q * s.len() as f64).ceil() as usize).clamp(1, s.len()) - 1]
}

fn finite_or_inf(v: f64) -> f64 {
    if v.is_finite() {
        v
    } else {
        f64::INFINITY
    }
}

impl Metrics {
    /// Metrics that settle each tick of the estimate graph once it is older than every truth step
    /// kept (the last [`TRUTH_KEPT`]: no state that late can be scored either): its connectivity
    /// row and its estimates across blocked links (by `sc`'s timeline, as
    /// [`Metrics::summary`] counts them) are kept, its graph dropped. At open-1000 the graph of a
    /// tick is 110-150 kB (the run's peak memory over its 400 settled ticks), and it was held for
    /// every tick of a run. The summary, `connectivity.csv` and the checks are the same as with
    /// [`Metrics::default`], which keeps every tick, as long as no state comes for a settled tick
    /// (it is counted, `connectivity.states_left_out`, and left out).
    pub fn settling(sc: &swarm_config::Scenario) -> Metrics {
        Metrics { settle_by: Some(blocked_links(sc)), ..Metrics::default() }
    }

    /// Settles the ticks of the estimate graph older than every truth step kept (see
    /// [`Metrics::settling`]); nothing while fewer than [`TRUTH_KEPT`] are kept.
    fn settle(&mut self) {
        let Some((timeline, grace)) = self.settle_by.as_ref() else { return };
        let Some(&oldest) = self.truth.keys().next().filter(|_| self.truth.len() as u64 >= TRUTH_KEPT) else { return };
        while let Some(entry) = self.known.first_entry().filter(|e| *e.key() < oldest) {
            let (tick, (t, known)) = entry.remove_entry();
            let row = components_row(tick, t, &known);
            self.settled.push(SettledTick { row, across: across_blocked(timeline, *grace, t, &known) });
        }
    }

    /// Notes the static world; paths are measured from the start poses.
    pub fn on_world(&mut self, w: TruthWorld) {
        for (i, s) in w.starts.iter().enumerate() {
            let a = self.agents.entry(i as u32 + 1).or_default();
            if a.last.is_none() {
                a.last = Some((s[0], s[1]));
            }
        }
        self.world = Some(w);
    }

    /// Folds one ground-truth step.
    pub fn on_step(&mut self, s: &TruthStep) {
        self.ticks += 1;
        self.liveness.on_step(s);
        if s.ended.is_none() {
            // The hub's last word (a stopped run) measures no work.
            self.hub_work_us.push(f64::from(s.timing.work_us));
        }
        self.commands += u64::from(s.timing.cmds);
        self.late_ms.extend(s.timing.late_ms.iter().map(|&ms| f64::from(ms)));
        for b in &s.bodies {
            let a = self.agents.entry(b.id).or_default();
            let (od, ad) = (finite_or_inf(b.obstacle_distance_m), finite_or_inf(b.agent_distance_m));
            a.min_obst = a.min_obst.min(od);
            a.min_agent = a.min_agent.min(ad);
            if od.is_finite() {
                a.sum_obst += od;
            }
            if ad.is_finite() {
                a.sum_agent += ad;
            }
            a.n += 1;
            if let Some((x, y)) = a.last {
                a.path += (b.x - x).hypot(b.y - y);
            }
            a.last = Some((b.x, b.y));
            if b.alive && !b.cmd_on_time && s.ended.is_none() {
                a.late += 1;
            }
            let t = self.tracks.entry(b.id).or_default();
            t.samples.push([s.t_secs, b.x, b.y, b.obstacle_distance_m, b.agent_distance_m]);
        }
        let nn: Vec<f64> = s.bodies.iter().map(|b| b.agent_distance_m).filter(|d| d.is_finite()).collect();
        if !nn.is_empty() {
            self.spacing.push((s.t_secs, nn.iter().sum::<f64>() / nn.len() as f64));
        }
        for c in &s.collisions {
            self.collisions.push(CollisionRecord {
                t_s: s.t_secs,
                id: c.id,
                other_uav: c.other_uav,
                x_m: c.x,
                y_m: c.y,
            });
        }
        self.truth.insert(s.tick, TickTruth::of(s.bodies.clone()));
        while self.truth.len() as u64 > TRUTH_KEPT {
            self.truth.pop_first();
        }
        self.settle();
        let later = self.pending.split_off(&s.tick.saturating_add(1));
        let mut ready: Vec<(u64, AgentState)> =
            std::mem::replace(&mut self.pending, later).into_values().flatten().collect();
        ready.sort_unstable_by_key(|&(arrival, _)| arrival);
        for (_, st) in ready {
            self.score(&st);
        }
        self.last_step = Some(s.clone());
    }

    /// Scores a state's neighbour estimates against the truth of its tick (estimates without a
    /// sender id cannot be scored). Tick 0 has no truth step: its states are not scored.
    fn score(&mut self, st: &AgentState) {
        let Some(TickTruth { bodies, all_alive }) = self.truth.get(&st.tick) else { return };
        let Some(me) = body_of(bodies, st.id) else { return };
        let turn = me.yaw.sin_cos();
        let placed: Vec<(u32, f64)> = st
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
        let a = self.agents.entry(st.id).or_default();
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
                a.contacts.push(ContactEvent { t_s: st.t_secs, regained, nearest_uav_m: nearest.exact() });
            }
        }
        a.last_count = Some(count);
        let mean_error_m = if errors.is_empty() { f64::NAN } else { errors.iter().sum::<f64>() / errors.len() as f64 };
        let max_error_m = errors.iter().copied().reduce(f64::max).unwrap_or(f64::NAN);
        self.scored.push(Scored {
            tick: st.tick,
            t_s: st.t_secs,
            id: st.id,
            neighbours: count,
            scored: errors.len(),
            mean_error_m,
            max_error_m,
        });
        a.false_estimates += errors.iter().filter(|&&e| e > FALSE_ESTIMATE_M).count() as u64;
        a.loc_errors.extend(errors);
    }

    /// Folds one agent state.
    pub fn on_state(&mut self, st: AgentState) {
        let a = self.agents.entry(st.id).or_default();
        let us = f64::from(st.step_time_us);
        self.step_us.push(us);
        a.step_us_sum += us;
        a.step_us_max = a.step_us_max.max(us);
        a.steps += 1;
        a.neighbours_sum += st.neighbours.len() as u64;
        *a.neighbour_counts.entry(st.neighbours.len()).or_default() += 1;
        st.neighbours.iter().for_each(|e| a.ages.push(f64::from(e.age_secs)));
        for d in &st.delays {
            if let Some(v) = self.delays.get_mut(usize::from(d.class)) {
                v.push(f64::from(d.delay_s));
            }
        }
        if let Some((_, prev)) = a.last_state.filter(|(_, p)| {
            st.link.classes.iter().map(|c| c.offered).sum::<u64>() < p.classes.iter().map(|c| c.offered).sum::<u64>()
        }) {
            // A new incarnation (restart): its counters start again from zero.
            let before = prev.classes;
            a.link_base = std::array::from_fn(|i| a.link_base[i] + before[i]);
        }
        a.last_state = Some((st.tick, st.link));
        if self.settled.last().is_some_and(|s| st.tick <= s.row.tick) {
            self.settled_late += 1;
            if self.settled_late == 1 {
                tracing::warn!(
                    tick = st.tick,
                    id = st.id,
                    "a state for a settled tick: left out of the connectivity series"
                );
            }
        } else {
            let ids = st.neighbours.iter().filter_map(|e| e.id).collect();
            self.known.entry(st.tick).or_insert_with(|| (st.t_secs, BTreeMap::new())).1.insert(st.id, ids);
        }
        if !st.traffic.session.is_empty() {
            // Looked up by reference: the id is copied only for a session seen the first time.
            match self.sessions.get_mut(st.traffic.session.as_str()) {
                Some(acc) => acc.fold(&st),
                None => self.sessions.entry(st.traffic.session.clone()).or_default().fold(&st),
            }
        }
        if self.truth.contains_key(&st.tick) {
            self.score(&st);
        } else if self.last_step.as_ref().is_none_or(|s| st.tick > s.tick) {
            self.pending.entry(st.tick).or_default().push((self.pending_arrivals, st));
            self.pending_arrivals += 1;
        }
    }

    /// Whether the hub has marked the last step.
    pub fn ended(&self) -> Option<EndReason> {
        self.last_step.as_ref().and_then(|s| s.ended)
    }

    /// The static world, once known.
    pub fn world(&self) -> Option<&TruthWorld> {
        self.world.as_ref()
    }

    /// The states scored since the last call, for `localization.csv`.
    pub fn take_scored(&mut self) -> Vec<Scored> {
        std::mem::take(&mut self.scored)
    }

    /// The components of the estimate graph at each tick agents reported, in tick order.
    pub fn components_series(&self) -> Vec<ComponentsRow> {
        let live = self.known.iter().map(|(&tick, (t, known))| components_row(tick, *t, known));
        self.settled.iter().map(|s| s.row).chain(live).collect()
    }

    /// Collisions so far.
    pub fn collision_count(&self) -> usize {
        self.collisions.len()
    }

    /// Whether an agent whose command closed the last step has not yet reported the state of
    /// that command's tick (it sends it right after the command, so it is on its way). The
    /// run's last states are waited for on this, so the summary never depends on how fast they
    /// came.
    pub fn awaiting_last_states(&self) -> bool {
        let Some(last) = self.last_step.as_ref() else { return false };
        let tick = last.tick.saturating_sub(1);
        last.bodies
            .iter()
            .filter(|b| b.cmd_on_time)
            .any(|b| self.agents.get(&b.id).and_then(|a| a.last_state).is_none_or(|(t, _)| t < tick))
    }

    /// The last step seen.
    pub fn last_step(&self) -> Option<&TruthStep> {
        self.last_step.as_ref()
    }

    /// The summary of what was folded so far.
    pub fn summary(&self, run_id: &str, scenario: &swarm_config::Scenario) -> Summary {
        let last = self.last_step.as_ref();
        let (sim_time_s, wall_time_s) = last.map_or((0.0, 0.0), |s| (s.t_secs, s.wall_secs));
        let end_reason = match self.ended() {
            Some(EndReason::Goal) => "goal",
            Some(EndReason::TimeLimit) => "time_limit",
            Some(EndReason::NoAgents) => "no_agents",
            Some(EndReason::Stopped) => "stopped",
            None => "incomplete",
        };
        let goal_at = last.and_then(|s| s.goal_reached_at);
        let mut agents: Vec<AgentSummary> = self
            .agents
            .iter()
            .map(|(&id, a)| agent_summary(id, a, self.placed_by_others.get(&id).copied().unwrap_or(0)))
            .collect();
        for a in &mut agents {
            if let Some(t) = self.tracks.get(&a.id) {
                a.blocking_time_s = blocking_time(&t.samples);
                a.agent_distance_std_m = std_dev(t.samples.iter().map(|s| s[4]));
                let alone = solitude(&t.samples, scenario.radio.range_m, scenario.radio.hysteresis_m);
                a.time_alone_s = alone.time_alone_s;
                a.alone_spells = alone.spells;
                a.rejoined = alone.rejoined;
                a.rejoined_at_s = alone.rejoined_at_s;
                a.max_nearest_uav_m = alone.max_nearest_uav_m;
            }
        }
        let formation = formation_metrics(&agents);
        let all_errors: Vec<f64> = self.agents.values().flat_map(|a| a.loc_errors.iter().copied()).collect();
        let all_ages = self.agents.values().fold(Tally::default(), |mut t, a| {
            t.merge(&a.ages);
            t
        });
        let (sent_msgs, sent_bytes) = agents.iter().fold((0, 0), |(m, b), a| (m + a.messages_sent, b + a.bytes_sent));
        let localization = LocalizationSummary {
            mode: format!("{:?}", scenario.localization.mode).to_lowercase(),
            estimates_scored: all_errors.len() as u64,
            mean_error_m: mean_finite(all_errors.iter().copied()),
            p95_error_m: quantile(&all_errors, 0.95),
            stable_neighbour_share: mean_finite(agents.iter().map(|a| a.stable_neighbour_share)),
            bytes_per_share_message: if sent_msgs > 0 { sent_bytes as f64 / sent_msgs as f64 } else { f64::NAN },
            false_estimates: agents.iter().map(|a| a.false_estimates).sum(),
            mean_info_age_s: all_ages.mean_finite(),
            p95_info_age_s: all_ages.quantile(0.95),
        };
        let min = |f: fn(&AgentSummary) -> f64| agents.iter().map(f).fold(f64::INFINITY, f64::min);
        let connectivity = self.connectivity(scenario);
        let network = self.network();
        let (lattice_spacing_m, lattice_spacing_std_m) = self.lattice_spacing();
        Summary {
            schema: SCHEMA.into(),
            run_id: run_id.into(),
            scenario: scenario.name.clone(),
            time_mode: format!("{:?}", scenario.time.mode).to_lowercase(),
            uav_count: scenario.count(),
            trees: self.world.as_ref().map_or(0, |w| w.trees.len()),
            end_reason: end_reason.into(),
            reached_goal: goal_at.is_some(),
            time_to_goal_s: goal_at,
            sim_time_s,
            wall_time_s,
            sim_speed: if wall_time_s > 0.0 { sim_time_s / wall_time_s } else { 0.0 },
            ticks: self.ticks,
            collisions: self.collisions.len(),
            collision_events: self.collisions.clone(),
            min_obstacle_distance_m: min(|a| a.min_obstacle_distance_m),
            min_agent_distance_m: min(|a| a.min_agent_distance_m),
            lattice_spacing_m,
            lattice_spacing_std_m,
            localization,
            connectivity,
            network,
            formation,
            agents,
            timing: self.timing(),
            checks: Vec::new(),
            traffic: self.traffic(),
            never_joined: scenario
                .agent_ids()
                .filter(|&id| {
                    self.agents.contains_key(&id) && !self.liveness.ever_alive(id) && self.last_step.is_some()
                })
                .collect(),
            lost: self.liveness.lost().map(|(id, at_s)| LostUav { id, at_s }).collect(),
        }
    }

    /// What the agent sessions received, per session, and what the agents received, per agent
    /// and tick over all of them.
    fn traffic(&self) -> TrafficSummary {
        let agents: Vec<&AgentTraffic> = self.sessions.values().flat_map(|s| s.agents.values()).collect();
        let agent_ticks: u64 = agents.iter().map(|a| a.span()).sum();
        let per_agent_tick = |f: fn(&AgentTraffic) -> u64| {
            let total: u64 = agents.iter().map(|a| f(a)).sum();
            if agent_ticks > 0 {
                total as f64 / agent_ticks as f64
            } else {
                0.0
            }
        };
        TrafficSummary {
            sessions: self.sessions.len(),
            shares_arrived_per_agent_tick: per_agent_tick(|a| a.shares),
            shares_counted_per_agent_tick: per_agent_tick(|a| a.counted),
            bytes_per_agent_tick: per_agent_tick(|a| a.bytes),
            per_session: self.sessions.iter().map(|(id, s)| s.summary(id)).collect(),
        }
    }

    /// Percentiles of the hub's and the agents' wall times, and the late commands.
    fn timing(&self) -> TimingSummary {
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

    /// Mean and standard deviation over the last [`LATTICE_WINDOW_S`] of sim time of the mean
    /// nearest-neighbour distance (seed 001 4.1 reports the equilibrium spacing ξ this way).
    fn lattice_spacing(&self) -> (f64, f64) {
        let Some(&(t_end, _)) = self.spacing.last() else { return (f64::NAN, f64::NAN) };
        let tail = || self.spacing.iter().filter(move |(t, _)| *t >= t_end - LATTICE_WINDOW_S).map(|&(_, d)| d);
        (mean_finite(tail()), std_dev(tail()))
    }

    /// What the links did, per class, over every agent.
    fn network(&self) -> Vec<ClassSummary> {
        let totals = self
            .agents
            .values()
            .map(Acc::link_classes)
            .fold([ClassCounts::default(); 3], |t, c| std::array::from_fn(|i| t[i] + c[i]));
        netem::LinkClass::ALL
            .iter()
            .map(|&class| {
                let c = totals[class as usize];
                let d = &self.delays[class as usize];
                ClassSummary {
                    class: class.name().into(),
                    counts: c,
                    mean_delay_s: d.mean_finite(),
                    p95_delay_s: d.quantile(0.95),
                }
            })
            .collect()
    }

    /// Connectivity of the "i has a current estimate of j" graph over time, reconnection after
    /// each heal, and estimates across links that have been blocked longer than the staleness.
    fn connectivity(&self, sc: &swarm_config::Scenario) -> Connectivity {
        let mut changes: Vec<ComponentsAt> = Vec::new();
        let mut series: Vec<(f64, usize)> = Vec::new();
        let mut across = 0u64;
        let (timeline, grace) = blocked_links(sc);
        let settled = self.settled.iter().map(|s| (s.row, s.across));
        let live = self
            .known
            .iter()
            .map(|(&tick, (t, known))| (components_row(tick, *t, known), across_blocked(&timeline, grace, *t, known)));
        for (row, blocked) in settled.chain(live) {
            let (t, n) = (row.t_s, row.components);
            if changes.last().is_none_or(|c| c.components != n) {
                changes.push(ComponentsAt { t_s: t, components: n });
            }
            series.push((t, n));
            across += blocked;
        }
        let reconnections = crate::checks::heal_times(sc)
            .iter()
            .map(|&h| {
                let after: Vec<&(f64, usize)> = series.iter().filter(|(t, _)| *t >= h - 1e-9).collect();
                // From the last sample that was not one component on, it stays connected.
                let last_split = after.iter().rposition(|(_, n)| *n != 1);
                let stays = match last_split {
                    None => after.first().map(|(t, _)| t - h),
                    Some(i) => after.get(i + 1).map(|(t, _)| t - h),
                };
                Reconnection {
                    heal_at_s: h,
                    reconnected_after_s: after.iter().find(|(_, n)| *n == 1).map(|(t, _)| t - h),
                    stays_connected_after_s: stays,
                }
            })
            .collect();
        Connectivity {
            components_changes: changes,
            reconnections,
            estimates_across_blocked_links: across,
            states_left_out: self.settled_late,
        }
    }
}

/// Window and distance of seed 004's blocking rule: blocked while it moved less than 0.1 m
/// during the last 1 s.
const BLOCKING_WINDOW_S: f64 = 1.0;
const BLOCKING_DISTANCE_M: f64 = 0.1;

/// Seconds a UAV was blocked, from its track `(t, x, y, ..)` (seed 004 3.5).
fn blocking_time(samples: &[[f64; 5]]) -> f64 {
    let mut blocked = 0.0;
    let mut back = 0;
    for i in 1..samples.len() {
        let [t, x, y, ..] = samples[i];
        while back < i && samples[back + 1][0] <= t - BLOCKING_WINDOW_S + 1e-9 {
            back += 1;
        }
        let [t0, x0, y0, ..] = samples[back];
        if t - t0 >= BLOCKING_WINDOW_S - 1e-9 && (x - x0).hypot(y - y0) < BLOCKING_DISTANCE_M {
            blocked += t - samples[i - 1][0];
        }
    }
    blocked
}

/// Standard deviation of the finite values (NaN when there are none).
fn std_dev(values: impl Iterator<Item = f64>) -> f64 {
    let v: Vec<f64> = values.filter(|x| x.is_finite()).collect();
    let mean = mean_finite(v.iter().copied());
    mean_finite(v.iter().map(|x| (x - mean).powi(2))).sqrt()
}

fn formation_metrics(agents: &[AgentSummary]) -> FormationMetrics {
    let mean = |f: fn(&AgentSummary) -> f64| mean_finite(agents.iter().map(f));
    FormationMetrics {
        mean_neighbour_distance_m: mean(|a| a.mean_agent_distance_m),
        neighbour_distance_deviation_m: mean(|a| a.agent_distance_std_m),
        mean_blocking_time_s: mean(|a| a.blocking_time_s),
        mean_trajectory_length_m: mean(|a| a.path_length_m),
        mean_obstacle_distance_m: mean(|a| a.mean_obstacle_distance_m),
    }
}

fn agent_summary(id: u32, a: &Acc, placed_by_others: u64) -> AgentSummary {
    let n = a.n.max(1) as f64;
    let steps = a.steps.max(1) as f64;
    let link = a.last_state.map(|(_, link)| link).unwrap_or_default();
    AgentSummary {
        id,
        min_obstacle_distance_m: a.min_obst,
        mean_obstacle_distance_m: if a.min_obst.is_finite() { a.sum_obst / n } else { f64::INFINITY },
        min_agent_distance_m: a.min_agent,
        // Filled in from the track by `Metrics::summary`.
        agent_distance_std_m: f64::NAN,
        blocking_time_s: 0.0,
        mean_agent_distance_m: if a.min_agent.is_finite() { a.sum_agent / n } else { f64::INFINITY },
        path_length_m: a.path,
        messages_sent: link.sent_msgs,
        bytes_sent: link.sent_bytes,
        messages_received: link.recv_msgs,
        bytes_received: link.recv_bytes,
        messages_delivered: link.delivered_msgs,
        malformed_messages: link.malformed,
        mean_step_time_ms: a.step_us_sum / steps / 1000.0,
        max_step_time_ms: a.step_us_max / 1000.0,
        mean_neighbours: a.neighbours_sum as f64 / steps,
        late_ticks: a.late,
        mean_localization_error_m: if a.loc_errors.is_empty() {
            f64::NAN
        } else {
            a.loc_errors.iter().sum::<f64>() / a.loc_errors.len() as f64
        },
        p95_localization_error_m: quantile(&a.loc_errors, 0.95),
        stable_neighbour_share: a.neighbour_counts.values().max().map_or(f64::NAN, |&m| m as f64 / steps),
        false_estimates: a.false_estimates,
        placed_by_others,
        contact_events: a.contacts.clone(),
        steps_alone: a.steps_alone,
        neighbours_reported_while_alone: a.reported_while_alone,
        mean_info_age_s: a.ages.mean_finite(),
        p95_info_age_s: a.ages.quantile(0.95),
        // Filled in from the track by `Metrics::summary`.
        time_alone_s: 0.0,
        alone_spells: 0,
        rejoined: None,
        rejoined_at_s: None,
        max_nearest_uav_m: f64::NAN,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocking_counts_the_time_spent_moving_less_than_10_cm_per_second() {
        // 0.1 s ticks: moving at 0.5 m/s for 3 s, then still for 2 s, then 0.05 m/s for 2 s.
        let mut samples = Vec::new();
        let mut x = 0.0;
        for k in 0..=70 {
            let t = f64::from(k) * 0.1;
            samples.push([t, x, 0.0, 1.0, 1.0]);
            x += if t < 3.0 - 1e-9 {
                0.05
            } else if t < 5.0 - 1e-9 {
                0.0
            } else {
                0.005
            };
        }
        // Still from 3.0 s: blocked once the last second moved < 0.1 m, i.e. from 3.9 s (at 3.9
        // it moved 0.05 m since 2.9) through 7.0 s: 3.1 s (the crawl moves 0.05 m per second).
        let b = blocking_time(&samples);
        assert!((b - 3.1).abs() < 0.11, "{b}");
        assert_eq!(blocking_time(&samples[..31]), 0.0, "moving: never blocked");
        assert!((std_dev([1.0, 3.0].into_iter()) - 1.0).abs() < 1e-12);
        assert!(std_dev([f64::NAN].into_iter()).is_nan());
    }
    use swarm_wire::{CollisionEvent, NeighbourEstimate};

    fn body(id: u32, x: f64, od: f64, ad: f64, on_time: bool) -> TruthBody {
        TruthBody {
            id,
            x,
            y: 0.0,
            yaw: 0.0,
            vx: 0.0,
            vy: 0.0,
            alive: true,
            cmd_on_time: on_time,
            obstacle_distance_m: od,
            agent_distance_m: ad,
            colliding: false,
        }
    }

    #[test]
    fn the_nearest_live_uav_answers_as_the_full_scan_does() {
        // UAVs on the x axis at 0, 8 and 20 m; the hub's nearest distances are exact here.
        let mk = |x: f64, ad: f64| {
            let mut b = body(1, x, 5.0, ad, true);
            b.id = (x as u32) + 1;
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
        assert_eq!(body_of(&bodies, 9).map(|b| b.x), Some(8.0), "ids need not be 1..=n in order");
        assert!(body_of(&bodies, 4).is_none());
    }

    #[test]
    fn the_last_states_are_awaited_for_agents_whose_command_closed_the_last_step() {
        let mut m = Metrics::default();
        assert!(!m.awaiting_last_states(), "no step yet");
        let last = TruthStep {
            tick: 7,
            t_secs: 0.7,
            bodies: vec![body(1, 0.0, 5.0, 2.0, true), body(2, 2.0, 5.0, 2.0, false)],
            collisions: vec![],
            goal_reached_at: None,
            ended: Some(EndReason::TimeLimit),
            wall_secs: 0.0,
            timing: Default::default(),
        };
        m.on_step(&last);
        assert!(m.awaiting_last_states(), "UAV 1 sent its command of tick 6: its state is due");
        let mut st = AgentState { id: 1, tick: 6, t_secs: 0.6, step_time_us: 1, ..AgentState::default() };
        st.tick = 5;
        m.on_state(st.clone());
        assert!(m.awaiting_last_states(), "an older state is not the last");
        st.tick = 6;
        m.on_state(st);
        assert!(!m.awaiting_last_states(), "UAV 2's command was late: nothing more is promised");
    }

    #[test]
    fn components_of_the_estimate_graph() {
        let g = |edges: &[(u32, &[u32])]| components(&edges.iter().map(|(i, js)| (*i, js.to_vec())).collect());
        assert_eq!(g(&[(1, &[2]), (2, &[]), (3, &[4]), (4, &[3])]), 2);
        assert_eq!(g(&[(1, &[2]), (2, &[3]), (3, &[])]), 1, "weakly connected");
        assert_eq!(g(&[(1, &[]), (2, &[]), (3, &[9])]), 3, "ids that did not report are not nodes");
        // A long chain in the worst order for plain parent links, and pairs beside it.
        let chain: BTreeMap<u32, Vec<u32>> =
            (1..=3000u32).map(|i| (i, if i > 1 { vec![i - 1] } else { vec![] })).collect();
        assert_eq!(components(&chain), 1);
        let pairs: BTreeMap<u32, Vec<u32>> =
            (1..=3000u32).map(|i| (i, vec![if i % 2 == 0 { i - 1 } else { i + 1 }])).collect();
        assert_eq!(components(&pairs), 1500);
        // Ids far apart (the index's binary search) and the largest id.
        assert_eq!(g(&[(2, &[4_000_000_000]), (4_000_000_000, &[]), (9, &[u32::MAX]), (u32::MAX, &[])]), 2, "sparse");
    }

    /// Checks [`IdIndex`] against the places of `ids` (ascending, distinct) in an ordered map,
    /// for every id of the list, its neighbours and the extremes.
    fn check_id_index(ids: &[u32]) {
        let index = IdIndex::new(ids.iter().copied());
        let places: BTreeMap<u32, usize> = ids.iter().enumerate().map(|(k, &id)| (id, k)).collect();
        let probes = ids.iter().flat_map(|&id| [id.saturating_sub(1), id, id.saturating_add(1)]).chain([0, u32::MAX]);
        for id in probes {
            assert_eq!(index.get(id), places.get(&id).copied(), "id {id} of {ids:?}");
        }
    }

    #[test]
    fn the_id_index_finds_each_place_as_a_table_or_a_search() {
        let dense: Vec<u32> = (1..=100).filter(|i| i % 7 != 3).collect();
        assert!(matches!(IdIndex::new(dense.iter().copied()), IdIndex::Table(_)));
        check_id_index(&dense);
        let sparse = [0, 5, 1 << 20, u32::MAX];
        assert!(matches!(IdIndex::new(sparse.into_iter()), IdIndex::Sorted(_)));
        check_id_index(&sparse);
        check_id_index(&[]);
        check_id_index(&[0]);
    }

    proptest::proptest! {
        #[test]
        fn prop_the_id_index_is_the_ordered_places(ids in proptest::collection::btree_set(0u32..300, 0..200),
                                                    far in proptest::collection::btree_set(proptest::num::u32::ANY, 0..4)) {
            let ids: Vec<u32> = ids.into_iter().collect();
            check_id_index(&ids);
            let all: Vec<u32> = ids.iter().copied().chain(far).collect::<std::collections::BTreeSet<u32>>().into_iter().collect();
            check_id_index(&all);
        }
    }

    #[test]
    fn metrics_fold_min_mean_path_collisions_and_end() {
        let sc = swarm_config::builtin("open-field-5").expect("builtin");
        let mut m = Metrics::default();
        let step = |tick, x, od, ad, ended, goal| TruthStep {
            tick,
            t_secs: tick as f64 * 0.1,
            bodies: vec![body(1, x, od, ad, tick != 2)],
            collisions: if tick == 2 { vec![CollisionEvent { id: 1, other_uav: None, x, y: 0.0 }] } else { vec![] },
            goal_reached_at: goal,
            ended,
            wall_secs: tick as f64 * 0.01,
            timing: Box::new(swarm_wire::HubTiming {
                work_us: 1000 * tick as u32,
                cmds: 2,
                late_ms: if tick == 2 { vec![5.0, 40.0] } else { vec![] },
            }),
        };
        m.on_step(&step(1, 0.0, 2.0, 3.0, None, None));
        m.on_step(&step(2, 3.0, 1.0, 5.0, None, None));
        assert_eq!(m.ended(), None);
        m.on_step(&step(3, 7.0, 3.0, 1.0, Some(EndReason::Goal), Some(0.3)));
        let s = m.summary("r", &sc);
        assert_eq!(s.end_reason, "goal");
        assert!(s.reached_goal);
        assert_eq!(s.time_to_goal_s, Some(0.3));
        assert_eq!(s.collisions, 1);
        assert!((s.sim_speed - 10.0).abs() < 1e-9);
        let a = &s.agents[0];
        assert_eq!((a.min_obstacle_distance_m, a.min_agent_distance_m), (1.0, 1.0));
        assert!((a.mean_obstacle_distance_m - 2.0).abs() < 1e-12);
        assert!((a.mean_agent_distance_m - 3.0).abs() < 1e-12);
        assert!((a.path_length_m - 7.0).abs() < 1e-12);
        assert_eq!(a.late_ticks, 1);
        let t = &s.timing;
        assert_eq!((t.commands, t.late_commands), (6, 2));
        assert!((t.late_share - 1.0 / 3.0).abs() < 1e-12);
        assert_eq!(t.late_p99_ms, 40.0, "nearest rank of two: the larger");
        assert_eq!((t.hub_tick_p50_ms, t.hub_tick_p99_ms), (1.0, 2.0), "the last (ended) step measures no work");
        assert!(t.agent_step_p50_ms.is_nan(), "no agent state folded");
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
        let truth = |tick| TruthStep { tick, t_secs: 0.1 * tick as f64, bodies: vec![b1, b2], ..Default::default() };
        let state = |tick, x: f32, n: usize| AgentState {
            tick,
            neighbours: vec![NeighbourEstimate { id: Some(2), x, y: 0.0, heading: 0.0, age_secs: 0.0 }; n],
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
        let far = |tick| TruthStep { tick, t_secs: 0.1 * tick as f64, bodies: vec![b1, b2], ..Default::default() };
        m.on_step(&far(6));
        m.on_state(state(6, 10.0, 1));
        let s = m.summary("r", &sc);
        assert_eq!((s.agents[0].steps_alone, s.agents[0].neighbours_reported_while_alone), (1, 1));
    }

    /// The settling metrics against the ones that keep every tick, over a partition and its heal
    /// (estimates held across the cut, components splitting and joining) and far more ticks than
    /// [`TRUTH_KEPT`]: the same summary and connectivity series, and a bounded graph.
    #[test]
    fn settled_ticks_give_the_same_summary_as_kept_ones() {
        let sc = swarm_config::builtin("open-field-7-partition").expect("builtin");
        let (mut kept, mut settling) = (Metrics::default(), Metrics::settling(&sc));
        let ticks = 3 * TRUTH_KEPT + 17;
        let mut most_known = 0;
        for tick in 1..=ticks {
            let t = 0.1 * tick as f64;
            let bodies: Vec<TruthBody> = (1..=7u32)
                .map(|id| {
                    let mut b = body(id, f64::from(id) * 2.0 + 0.01 * tick as f64, 5.0, 2.0, true);
                    b.y = if id <= 3 { 0.0 } else { 1.5 };
                    b
                })
                .collect();
            let cut = (10.0..30.0).contains(&t);
            for me in 1..=7u32 {
                // Across the cut, UAV 1 still holds UAV 4 until 12 s (a stale estimate); the
                // groups otherwise estimate only each other, and UAV 7 none every fifth tick.
                let ids: Vec<u32> = (1..=7u32)
                    .filter(|&j| j != me)
                    .filter(|&j| !cut || (j <= 3) == (me <= 3) || (me == 1 && j == 4 && t < 12.0))
                    .filter(|_| !(me == 7 && tick % 5 == 0))
                    .collect();
                let neighbours = ids
                    .iter()
                    .map(|&j| NeighbourEstimate {
                        id: Some(j),
                        x: (f64::from(j) - f64::from(me)) as f32 * 2.0,
                        y: 0.0,
                        heading: 0.0,
                        age_secs: 0.1,
                    })
                    .collect();
                let st = AgentState { tick, t_secs: t, neighbours, in_radio_range: 6, ..blank_state(me) };
                kept.on_state(st.clone());
                settling.on_state(st);
            }
            let step = TruthStep { tick, t_secs: t, bodies, ..Default::default() };
            kept.on_step(&step);
            settling.on_step(&step);
            most_known = most_known.max(settling.known.len());
        }
        assert_eq!(kept.components_series(), settling.components_series());
        assert!(kept.components_series().iter().any(|r| r.components == 2), "the cut splits the graph");
        let (a, b) = (kept.summary("r", &sc), settling.summary("r", &sc));
        assert!(a.connectivity.estimates_across_blocked_links > 0, "the stale estimate is counted");
        let json = |s: &crate::summary::Summary| serde_json::to_string(s).expect("a summary serializes");
        assert_eq!(json(&a), json(&b));
        assert_eq!(settling.settled.len() as u64, ticks - TRUTH_KEPT);
        assert!(most_known as u64 <= TRUTH_KEPT + 1, "the graph is bounded: {most_known} ticks held");
        assert_eq!(kept.known.len() as u64, ticks, "the default keeps every tick");
        // A state for a settled tick is counted and left out; a later tick still counts.
        settling.on_state(AgentState { tick: 3, ..blank_state(1) });
        assert_eq!(settling.settled_late, 1);
        assert_eq!(settling.summary("r", &sc).connectivity.states_left_out, 1);
        assert_eq!(settling.components_series().len() as u64, ticks);
    }

    /// A state of UAV `id` with no estimate, at tick 0.
    fn blank_state(id: u32) -> AgentState {
        AgentState { id, step_time_us: 10, ..AgentState::default() }
    }

    #[test]
    fn traffic_is_per_session_and_per_agent_tick() {
        // (id, tick, session, session shares, session bytes, counted, agent shares, agent bytes)
        let state =
            |id: u32, tick: u64, session: &str, shares: u64, bytes: u64, counted: u64, mine: (u64, u64)| AgentState {
                id,
                tick,
                t_secs: 0.1 * tick as f64,
                step_time_us: 1,
                link: swarm_wire::LinkCounters { recv_msgs: counted, ..Default::default() },
                traffic: Traffic {
                    session: session.into(),
                    agents: 2,
                    shares,
                    share_bytes: shares * 10,
                    bytes,
                    subscriptions: 4,
                    remote_shares: shares / 2,
                    remote_share_bytes: shares * 5,
                    agent_shares: mine.0,
                    agent_bytes: mine.1,
                },
                ..AgentState::default()
            };
        let mut m = Metrics::default();
        // A host "h" of agents 1 and 2 over ticks 0..=9, and agent 3 alone on "a" over ticks 5..=9;
        // the host's states arrive out of order, as they may.
        m.on_state(state(1, 9, "h", 200, 5000, 30, (35, 3000)));
        m.on_state(state(1, 0, "h", 2, 50, 0, (1, 40)));
        m.on_state(state(2, 0, "h", 4, 100, 0, (1, 50)));
        m.on_state(state(2, 9, "h", 190, 4900, 50, (55, 4000)));
        m.on_state(state(3, 5, "a", 1, 10, 0, (1, 10)));
        m.on_state(state(3, 9, "a", 25, 600, 20, (25, 600)));
        let sc = swarm_config::builtin("forest-5").expect("builtin");
        let t = m.summary("r", &sc).traffic;
        assert_eq!(t.sessions, 2);
        let (a, h) = (&t.per_session[0], &t.per_session[1]);
        assert_eq!((a.session.as_str(), a.agents, a.ticks), ("a", 1, 5));
        assert_eq!((h.session.as_str(), h.agents, h.ticks, h.uavs.clone()), ("h", 2, 10, vec![1, 2]));
        assert_eq!((h.shares_arrived_per_tick, h.shares_counted_per_tick, h.bytes_per_tick), (20.0, 8.0, 500.0));
        assert_eq!(h.subscriptions_mean, 4.0);
        assert_eq!((h.remote_shares_per_tick, h.remote_share_bytes_per_tick), (10.0, 100.0));
        // Agents 1 and 2 reported ticks 0 to 9, agent 3 ticks 5 to 9: 25 agent-ticks.
        assert_eq!(t.shares_arrived_per_agent_tick, (35.0 + 55.0 + 25.0) / 25.0);
        assert_eq!(t.shares_counted_per_agent_tick, (30.0 + 50.0 + 20.0) / 25.0);
        assert_eq!(t.bytes_per_agent_tick, (3000.0 + 4000.0 + 600.0) / 25.0);
    }
}

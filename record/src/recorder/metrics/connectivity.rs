//! Connectivity of the estimate graph ("agent i holds an estimate of j") over the agents that
//! report and are not frozen (a frozen UAV is a failed individual that can share nothing, so the
//! swarm's connectivity and its reconnection after a heal are judged without it, as the goal rule
//! judges the flying UAVs): its weakly connected components at each tick (`connectivity.csv`),
//! the reconnection after each heal, and the estimates held across a link blocked longer than
//! the staleness allows. Why its own part: the
//! graph of a tick is the largest thing the recorder holds (110-150 kB a tick at open-1000), so
//! it is settled into its row once no state for that tick can still count, and the graph held
//! does not grow with the run.

use crate::summary::{ComponentsAt, Connectivity, Reconnection};
use std::collections::BTreeMap;
use swarm_types::UavId;
use swarm_wire::AgentState;

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

/// The estimate graph over the run, folded state by state.
#[derive(Debug, Default)]
pub(super) struct EstimateGraph {
    /// Per tick: (sim time, for each agent that reported, the ids it has an estimate of). With
    /// [`EstimateGraph::settling`], only the ticks not yet settled.
    known: BTreeMap<u64, (f64, BTreeMap<UavId, Vec<UavId>>)>,
    /// What [`EstimateGraph::settle`] keeps of the ticks it settled, in tick order.
    settled: Vec<SettledTick>,
    /// The scenario's netem timeline and staleness grace [s], to settle ticks with.
    settle_by: Option<(netem::Timeline, f64)>,
    /// States that came for a tick already settled (left out of the connectivity series).
    settled_late: u64,
}

/// Weakly connected components of the estimate graph over the agents that reported.
fn components(known: &BTreeMap<UavId, Vec<UavId>>) -> usize {
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
    Sorted(Vec<UavId>),
}

impl IdIndex {
    /// The index of `ids`, which must be ascending and distinct.
    fn new(ids: impl Iterator<Item = UavId>) -> IdIndex {
        let ids: Vec<UavId> = ids.collect();
        debug_assert!(ids.windows(2).all(|w| w[0] < w[1]), "ascending, distinct");
        let top = ids.last().map_or(0, |&id| id.get() as usize);
        if top > 4 * ids.len() + 64 {
            return IdIndex::Sorted(ids);
        }
        let mut table = vec![u32::MAX; top + 1];
        for (k, &id) in ids.iter().enumerate() {
            table[id.get() as usize] = k as u32;
        }
        IdIndex::Table(table)
    }

    /// The place of `id` in the list, if it is there.
    fn get(&self, id: UavId) -> Option<usize> {
        match self {
            IdIndex::Table(table) => table.get(id.get() as usize).filter(|&&k| k != u32::MAX).map(|&k| k as usize),
            IdIndex::Sorted(ids) => ids.binary_search(&id).ok(),
        }
    }
}

/// Tick `tick`'s row of the connectivity series, at sim time `t`, from its estimate graph.
fn components_row(tick: u64, t: f64, known: &BTreeMap<UavId, Vec<UavId>>) -> ComponentsRow {
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
    (netem::Timeline::from_scenario(sc), sc.localization.stale_after_s + sc.dt_s())
}

/// Estimates at sim time `t` across a link that `timeline` had blocked both then and `grace`
/// before (held over a cut longer than the staleness allows).
fn across_blocked(timeline: &netem::Timeline, grace: f64, t: f64, known: &BTreeMap<UavId, Vec<UavId>>) -> u64 {
    let blocked = |from: UavId, to: UavId, at: f64| timeline.rule_at(at, from, to).is_some_and(|r| r.blocked);
    known
        .iter()
        .map(|(&i, ids)| ids.iter().filter(|&&j| blocked(j, i, t) && blocked(j, i, t - grace)).count() as u64)
        .sum()
}

impl EstimateGraph {
    /// A graph that settles each tick once it is older than `before` of [`EstimateGraph::settle`],
    /// counting its estimates across blocked links by `sc`'s timeline (as
    /// [`EstimateGraph::summary`] does).
    pub(super) fn settling(sc: &swarm_config::Scenario) -> EstimateGraph {
        EstimateGraph { settle_by: Some(blocked_links(sc)), ..EstimateGraph::default() }
    }

    /// Settles the ticks older than `before` (none when `None`, or when made by
    /// [`EstimateGraph::default`]): keeps each one's row and estimates across blocked links,
    /// drops its graph.
    pub(super) fn settle(&mut self, before: Option<u64>) {
        let Some((timeline, grace)) = self.settle_by.as_ref() else { return };
        let Some(oldest) = before else { return };
        while let Some(entry) = self.known.first_entry().filter(|e| *e.key() < oldest) {
            let (tick, (t, known)) = entry.remove_entry();
            let row = components_row(tick, t, &known);
            self.settled.push(SettledTick { row, across: across_blocked(timeline, *grace, t, &known) });
        }
    }

    /// Folds one agent state: the ids it has an estimate of, at its tick (or, for a tick already
    /// settled, a count of it); a frozen agent's is left out.
    pub(super) fn on_state(&mut self, st: &AgentState) {
        if self.settle_by.as_ref().is_some_and(|(timeline, _)| timeline.frozen_at(st.id, st.t_s)) {
            return;
        }
        if self.settled.last().is_some_and(|s| st.tick <= s.row.tick) {
            self.settled_late += 1;
            if self.settled_late == 1 {
                tracing::warn!(
                    tick = st.tick,
                    id = %st.id,
                    "a state for a settled tick: left out of the connectivity series"
                );
            }
        } else {
            let ids = st.neighbours.iter().filter_map(|e| e.id).collect();
            self.known.entry(st.tick).or_insert_with(|| (st.t_s, BTreeMap::new())).1.insert(st.id, ids);
        }
    }

    /// The components of the estimate graph at each tick agents reported, in tick order.
    pub(super) fn series(&self) -> Vec<ComponentsRow> {
        let live = self.known.iter().map(|(&tick, (t, known))| components_row(tick, *t, known));
        self.settled.iter().map(|s| s.row).chain(live).collect()
    }

    /// Connectivity of the "i has a current estimate of j" graph over time, reconnection after
    /// each heal, and estimates across links that have been blocked longer than the staleness.
    pub(super) fn summary(&self, sc: &swarm_config::Scenario) -> Connectivity {
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

#[cfg(test)]
mod tests {
    use super::super::fixtures::{blank_state, body};
    use super::super::scoring::TRUTH_KEPT;
    use super::super::Metrics;
    use super::*;
    use swarm_wire::{NeighbourEstimate, TruthBody, TruthStep};

    #[test]
    fn components_of_the_estimate_graph() {
        let typed = |i: u32, js: &[u32]| (UavId::new(i), js.iter().copied().map(UavId::new).collect::<Vec<_>>());
        let g = |edges: &[(u32, &[u32])]| components(&edges.iter().map(|&(i, js)| typed(i, js)).collect());
        assert_eq!(g(&[(1, &[2]), (2, &[]), (3, &[4]), (4, &[3])]), 2);
        assert_eq!(g(&[(1, &[2]), (2, &[3]), (3, &[])]), 1, "weakly connected");
        assert_eq!(g(&[(1, &[]), (2, &[]), (3, &[9])]), 3, "ids that did not report are not nodes");
        // A long chain in the worst order for plain parent links, and pairs beside it.
        let chain: BTreeMap<UavId, Vec<UavId>> =
            (1..=3000u32).map(|i| typed(i, &[i - 1][..usize::from(i > 1)])).collect();
        assert_eq!(components(&chain), 1);
        let pairs: BTreeMap<UavId, Vec<UavId>> =
            (1..=3000u32).map(|i| typed(i, &[if i % 2 == 0 { i - 1 } else { i + 1 }])).collect();
        assert_eq!(components(&pairs), 1500);
        // Ids far apart (the index's binary search) and the largest id.
        assert_eq!(g(&[(2, &[4_000_000_000]), (4_000_000_000, &[]), (9, &[u32::MAX]), (u32::MAX, &[])]), 2, "sparse");
    }

    /// Two UAVs, the second frozen at 1 s: from then on it holds no estimate and the first drops
    /// it. The graph is judged without the frozen agent: one component throughout, where counting
    /// it as a node would split the swarm in two.
    #[test]
    fn a_frozen_agent_is_left_out_of_the_graph() {
        let mut sc = swarm_config::builtin("open-field-5").expect("builtin");
        sc.failures.push(serde_json::from_str(r#"{"at_s": 1.0, "uav": 2, "kind": "freeze"}"#).expect("a freeze"));
        let mut g = EstimateGraph::settling(&sc);
        for tick in 1..=20u64 {
            let t_s = 0.1 * tick as f64;
            for (me, other) in [(1u32, 2u32), (2, 1)] {
                let holds = t_s < 1.0;
                let neighbours = if holds {
                    vec![NeighbourEstimate { id: Some(UavId::new(other)), x: 1.0, y: 0.0, heading: 0.0, age_s: 0.1 }]
                } else {
                    vec![]
                };
                g.on_state(&AgentState { tick, t_s, neighbours, ..blank_state(me) });
            }
        }
        let rows = g.series();
        assert_eq!(rows.len(), 20);
        assert!(rows.iter().all(|r| r.components == 1), "{rows:?}");
        assert_eq!((rows[8].reporting, rows[12].reporting), (2, 1), "the frozen agent's states left out from 1 s");
    }

    /// Checks [`IdIndex`] against the places of `ids` (ascending, distinct) in an ordered map,
    /// for every id of the list, its neighbours and the extremes.
    fn check_id_index(ids: &[u32]) {
        let index = IdIndex::new(ids.iter().copied().map(UavId::new));
        let places: BTreeMap<u32, usize> = ids.iter().enumerate().map(|(k, &id)| (id, k)).collect();
        let probes = ids.iter().flat_map(|&id| [id.saturating_sub(1), id, id.saturating_add(1)]).chain([0, u32::MAX]);
        for id in probes {
            assert_eq!(index.get(UavId::new(id)), places.get(&id).copied(), "id {id} of {ids:?}");
        }
    }

    #[test]
    fn the_id_index_finds_each_place_as_a_table_or_a_search() {
        let dense: Vec<u32> = (1..=100).filter(|i| i % 7 != 3).collect();
        assert!(matches!(IdIndex::new(dense.iter().copied().map(UavId::new)), IdIndex::Table(_)));
        check_id_index(&dense);
        let sparse = [0, 5, 1 << 20, u32::MAX];
        assert!(matches!(IdIndex::new(sparse.into_iter().map(UavId::new)), IdIndex::Sorted(_)));
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
                        id: Some(UavId::new(j)),
                        x: (f64::from(j) - f64::from(me)) as f32 * 2.0,
                        y: 0.0,
                        heading: 0.0,
                        age_s: 0.1,
                    })
                    .collect();
                let st = AgentState { tick, t_s: t, neighbours, in_radio_range: 6, ..blank_state(me) };
                kept.on_state(st.clone());
                settling.on_state(st);
            }
            let step = TruthStep { tick, t_s: t, bodies, ..Default::default() };
            kept.on_step(&step);
            settling.on_step(&step);
            most_known = most_known.max(settling.graph.known.len());
        }
        assert_eq!(kept.components_series(), settling.components_series());
        assert!(kept.components_series().iter().any(|r| r.components == 2), "the cut splits the graph");
        let (a, b) = (kept.summary("r", &sc), settling.summary("r", &sc));
        assert!(a.connectivity.estimates_across_blocked_links > 0, "the stale estimate is counted");
        let json = |s: &crate::summary::Summary| serde_json::to_string(s).expect("a summary serializes");
        assert_eq!(json(&a), json(&b));
        assert_eq!(settling.graph.settled.len() as u64, ticks - TRUTH_KEPT);
        assert!(most_known as u64 <= TRUTH_KEPT + 1, "the graph is bounded: {most_known} ticks held");
        assert_eq!(kept.graph.known.len() as u64, ticks, "the default keeps every tick");
        // A state for a settled tick is counted and left out; a later tick still counts.
        settling.on_state(AgentState { tick: 3, ..blank_state(1) });
        assert_eq!(settling.graph.settled_late, 1);
        assert_eq!(settling.summary("r", &sc).connectivity.states_left_out, 1);
        assert_eq!(settling.components_series().len() as u64, ticks);
    }
}

//! The end of a run: each check's pass or fail, with the bound in words and the first failing
//! moment; the checks judged only at the end (connected at the end, the goal, reconnection after
//! each heal) are found here from the last step and the summary.

use super::{failure, Checker};
use crate::summary::{CheckFailure, CheckResult, Summary, UavAt};
use std::collections::{BTreeMap, BTreeSet};
use swarm_config::{CheckName, GoalRule, Scenario};
use swarm_types::UavId;

fn result(c: CheckName, detail: String, first_failure: Option<CheckFailure>) -> CheckResult {
    CheckResult { name: c.as_str().into(), passed: first_failure.is_none(), detail, first_failure }
}

/// The ids of the weakly connected components of an estimate graph, largest first.
fn component_sets(graph: &BTreeMap<UavId, Vec<UavId>>) -> Vec<BTreeSet<UavId>> {
    let mut adjacent: BTreeMap<UavId, BTreeSet<UavId>> = graph.keys().map(|&i| (i, BTreeSet::new())).collect();
    for (&i, js) in graph {
        for &j in js.iter().filter(|j| graph.contains_key(j)) {
            adjacent.entry(i).or_default().insert(j);
            adjacent.entry(j).or_default().insert(i);
        }
    }
    let mut seen = BTreeSet::new();
    let mut sets = Vec::new();
    for &start in graph.keys() {
        if !seen.insert(start) {
            continue;
        }
        let (mut set, mut todo) = (BTreeSet::from([start]), vec![start]);
        while let Some(i) = todo.pop() {
            for &j in &adjacent[&i] {
                if seen.insert(j) {
                    set.insert(j);
                    todo.push(j);
                }
            }
        }
        sets.push(set);
    }
    sets.sort_by_key(|s| std::cmp::Reverse(s.len()));
    sets
}

impl Checker {
    pub(super) fn verdict(&self, c: CheckName, sc: &Scenario, s: &Summary) -> CheckResult {
        let b = &self.bounds;
        match c {
            CheckName::Collision => {
                result(c, "no contact with an obstacle or another UAV".into(), self.collision.clone())
            }
            CheckName::MinSeparation => {
                result(c, format!("no two UAVs closer than {:.2} m", b.min_separation_m), self.separation.clone())
            }
            CheckName::StaleEstimate if self.senses_bodies => {
                result(c, "uvdar senses bodies: no estimate crosses a link (vacuous)".into(), None)
            }
            CheckName::StaleEstimate => result(
                c,
                format!("no estimate held over a cut link for more than {:.2} s", b.stale_grace_s),
                self.stale.clone(),
            ),
            CheckName::NeighbourWhileAlone => result(
                c,
                format!(
                    "no neighbour reported {:.2} s after the last UAV within {:.1} m left",
                    b.stale_grace_s, b.alone_m
                ),
                self.alone.clone(),
            ),
            CheckName::Reconnect => self.reconnect(s),
            CheckName::ConnectedAtEnd => self.connected_at_end(sc, s),
            CheckName::Goal => self.goal(sc, s),
        }
    }

    /// After every heal, one component again within the bound (a deadline after the end of the
    /// run cannot fail, and neither can a heal before which the graph was never one component:
    /// there is nothing to come back to, e.g. ICP in an open field localizes no one).
    fn reconnect(&self, s: &Summary) -> CheckResult {
        let c = CheckName::Reconnect;
        let within = self.bounds.reconnect_within_s;
        if self.deadlines.is_empty() {
            return result(c, "no heal in the timeline (vacuous)".into(), None);
        }
        let detail = format!("one component again within {within:.1} s of each of {} heal(s)", self.deadlines.len());
        for d in &self.deadlines {
            let r = s.connectivity.reconnections.iter().find(|r| (r.heal_at_s - d.heal_s).abs() < 1e-9);
            let late = r.is_none_or(|r| r.reconnected_after_s.is_none_or(|a| a > within + 1e-9));
            let was_connected = s.connectivity.components_changes.iter().any(|c| c.t_s < d.heal_s && c.components == 1);
            if late && was_connected && d.due_s <= s.sim_time_s + 1e-9 {
                let sets = component_sets(&d.graph);
                let apart: Vec<UavId> = sets.iter().skip(1).flatten().copied().collect();
                let what = format!(
                    "{} component(s) {within:.1} s after the heal at {:.1} s; outside the largest: {apart:?}",
                    sets.len(),
                    d.heal_s
                );
                let uavs = d
                    .positions
                    .as_ref()
                    .map_or_else(Vec::new, |p| p.iter().filter(|u| apart.contains(&u.id)).cloned().collect());
                return result(c, detail, failure(d.due_s, what, uavs));
            }
        }
        result(c, detail, None)
    }

    /// The live UAVs at the end (agent alive, not frozen), with their positions.
    fn live_at_end(&self) -> Vec<UavAt> {
        self.last.as_ref().map_or_else(Vec::new, |(_, live)| live.clone())
    }

    fn connected_at_end(&self, _sc: &Scenario, s: &Summary) -> CheckResult {
        let c = CheckName::ConnectedAtEnd;
        let range = self.bounds.end_range_m;
        let live = self.live_at_end();
        let detail = format!("every live UAV within {range:.1} m of another at the end");
        if live.len() < 2 {
            return result(c, format!("{detail} (vacuous: {} live)", live.len()), None);
        }
        let nearest = |u: &UavAt| {
            live.iter()
                .filter(|o| o.id != u.id)
                .map(|o| (o.x_m - u.x_m).hypot(o.y_m - u.y_m))
                .fold(f64::INFINITY, f64::min)
        };
        let lonely: Vec<UavAt> = live.iter().filter(|u| nearest(u) > range).cloned().collect();
        let f = (!lonely.is_empty()).then(|| CheckFailure {
            t_s: s.sim_time_s,
            what: format!("{} UAV(s) with no live UAV within {range:.1} m", lonely.len()),
            uavs: lonely,
        });
        result(c, detail, f)
    }

    fn goal(&self, sc: &Scenario, s: &Summary) -> CheckResult {
        let c = CheckName::Goal;
        let rule = match sc.end.goal_rule {
            GoalRule::All => "every UAV",
            GoalRule::Centroid => "the centroid",
        };
        let detail = format!("{rule} within {:.1} m of the goal by {:.0} s", sc.end.goal_radius_m, sc.end.time_limit_s);
        if s.reached_goal {
            return result(c, detail, None);
        }
        let g = sc.swarm.goal;
        let live = self.live_at_end();
        let out: Vec<UavAt> =
            live.iter().filter(|u| (u.x_m - g[0]).hypot(u.y_m - g[1]) > sc.end.goal_radius_m).cloned().collect();
        // UAVs whose agent was lost hover where it went, and the hub's rule still waits for them
        // (it cannot tell a crash from a link that will come back): a run that flew to its time
        // limit is judged over the rest, so a lost UAV is not a goal failure of theirs.
        if !s.lost.is_empty() && s.end_reason == "time_limit" && !live.is_empty() && rest_arrived(sc, &live, &out) {
            let ids: Vec<String> = s.lost.iter().map(|l| l.id.to_string()).collect();
            return result(c, format!("{detail} (judged without the lost UAVs {})", ids.join(", ")), None);
        }
        let what = format!("goal not reached ({}); {} live UAV(s) outside the goal disc", s.end_reason, out.len());
        result(c, detail, failure(s.sim_time_s, what, out))
    }
}

/// Whether the goal rule holds at the end over the `live` UAVs alone (`out`: those of them
/// outside the goal disc).
fn rest_arrived(sc: &Scenario, live: &[UavAt], out: &[UavAt]) -> bool {
    match sc.end.goal_rule {
        GoalRule::All => out.is_empty(),
        GoalRule::Centroid => {
            let n = live.len() as f64;
            let (cx, cy) = live.iter().fold((0.0, 0.0), |(x, y), u| (x + u.x_m / n, y + u.y_m / n));
            (cx - sc.swarm.goal[0]).hypot(cy - sc.swarm.goal[1]) <= sc.end.goal_radius_m
        }
    }
}

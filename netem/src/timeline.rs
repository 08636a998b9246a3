//! The netem timeline of a run: which rule is in force on a link at a sim time, and who is frozen.
//!
//! Why a type of its own: the hub keeps the timeline (the scenario's `[[netem]]` and
//! `[[failures]]`, plus what `swarm netem` adds while running) and republishes it on
//! `netem/rules`; every agent applies it to each share it receives; the recorder reads it back to
//! judge estimates across cut links. All of them must answer "which rule holds from i to j at t"
//! the same way, so the answer lives here, once, next to the model that applies it, and the
//! scenario (`swarm_config`) stays pure data.
//!
//! The order of the lookup, and its tie-breaking, are the contract ([`Timeline::rule_at`]): a
//! frozen sender first, then the partition in force, then the latest per-link rule (the later in
//! list order among equal times). Times are sim seconds, compared with a nanosecond of slack for
//! the float rounding of tick times.
//!
//! On the wire the timeline is its data as JSON (`{"netem": [...], "failures": [...]}`), exactly
//! as `swarm_config::Timeline` serializes, so it can be (de)serialized directly.

use serde::{Deserialize, Serialize};
use swarm_config::{Failure, FailureKind, Impairment, NetemRule, Scenario};
use swarm_types::UavId;

/// Slack on "at or before `t`" [s], for the float rounding of tick times.
const DUE_SLACK_S: f64 = 1e-9;

/// The `[[netem]]` rules and `[[failures]]` in force in a run, and the lookups over them.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(transparent)]
pub struct Timeline {
    data: swarm_config::Timeline,
}

impl From<swarm_config::Timeline> for Timeline {
    fn from(data: swarm_config::Timeline) -> Timeline {
        Timeline { data }
    }
}

impl Timeline {
    /// The scenario's own timeline: its `[[netem]]` rules and its `[[failures]]`.
    pub fn from_scenario(sc: &Scenario) -> Timeline {
        Timeline::from(swarm_config::Timeline { netem: sc.netem.clone(), failures: sc.failures.clone() })
    }

    /// Adds rules and failures (already checked, times already absolute) after the ones there.
    pub fn extend(&mut self, more: swarm_config::Timeline) {
        self.data.netem.extend(more.netem);
        self.data.failures.extend(more.failures);
    }

    /// The network rules and partition events, in list order.
    pub fn rules(&self) -> &[NetemRule] {
        &self.data.netem
    }

    /// The failures, in list order (only freezes matter to the lookups).
    pub fn failures(&self) -> &[Failure] {
        &self.data.failures
    }

    /// Whether UAV `id` is frozen at sim time `t_s` (a `freeze` failure at or before it).
    pub fn frozen_at(&self, id: UavId, t_s: f64) -> bool {
        self.failures().iter().any(|f| f.uav == id && f.kind == FailureKind::Freeze && f.at_s <= t_s + DUE_SLACK_S)
    }

    /// The worse class of the link between `i` and `j` at `t_s`, over both directions (cut
    /// beats impaired beats clean): what a picture of the link shows.
    pub fn class_between(&self, t_s: f64, i: UavId, j: UavId) -> crate::LinkClass {
        let (a, b) = (crate::LinkClass::of(self.rule_at(t_s, i, j)), crate::LinkClass::of(self.rule_at(t_s, j, i)));
        if (a as u8) >= (b as u8) {
            a
        } else {
            b
        }
    }

    /// The netem rule in force at sim time `t_s` for messages from `from` to `to`. A frozen
    /// sender says nothing: its links are blocked from its freeze on. Then the partition in force
    /// (the latest partition event at or before `t_s`) blocks, or holds, the links it cuts.
    /// Otherwise the last per-link rule (in list order among equal times) with `at_s <= t_s`
    /// that covers the link applies; none = identity.
    pub fn rule_at(&self, t_s: f64, from: UavId, to: UavId) -> Option<&Impairment> {
        if self.frozen_at(from, t_s) {
            return Some(&Impairment::BLOCKED);
        }
        let due = |r: &&NetemRule| r.at_s <= t_s + DUE_SLACK_S;
        let latest = |a: &&NetemRule, b: &&NetemRule| a.at_s.total_cmp(&b.at_s);
        let partition = self.rules().iter().filter(due).filter(|r| r.partition.is_some()).max_by(latest);
        if let Some(r) = partition {
            if r.partition.as_ref().is_some_and(|p| crate::impair::blocked(p, from, to)) {
                return Some(if r.rule.hold { &Impairment::HOLD } else { &Impairment::BLOCKED });
            }
        }
        self.rules()
            .iter()
            .filter(due)
            .filter(|r| r.partition.is_none() && r.from.contains(from) && r.to.contains(to))
            .max_by(latest)
            .map(|r| &r.rule)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A timeline from `[[netem]]` and `[[failures]]` tables, as in a scenario file.
    fn timeline(tables: &str) -> Timeline {
        Timeline::from(toml::from_str::<swarm_config::Timeline>(tables).expect("valid tables"))
    }

    #[test]
    fn netem_rules_in_force_follow_time_and_links() {
        let tl = timeline(
            "[[netem]]\nat_s = 0.0\nrule = { delay_s = 0.1 }\n\n[[netem]]\nat_s = 5.0\nfrom = [2]\nrule = { loss = { model = \"random\", p = 0.3 } }\n\n[[netem]]\nat_s = 9.0\nfrom = [2]\n",
        );
        assert_eq!(tl.rule_at(1.0, UavId::new(2), UavId::new(1)).map(|r| r.delay_s), Some(0.1));
        assert!(
            tl.rule_at(6.0, UavId::new(2), UavId::new(1)).is_some_and(|r| r.delay_s == 0.0 && !r.is_identity()),
            "the later rule replaces"
        );
        assert_eq!(
            tl.rule_at(6.0, UavId::new(1), UavId::new(2)).map(|r| r.delay_s),
            Some(0.1),
            "other links keep the first rule"
        );
        assert!(tl.rule_at(9.5, UavId::new(2), UavId::new(1)).is_some_and(|r| r.is_identity()), "an empty rule heals");
    }

    #[test]
    fn a_frozen_sender_is_mute_from_its_freeze_on() {
        let tl = timeline("[[failures]]\nat_s = 3.0\nuav = 2\nkind = \"freeze\"\n");
        assert!(!tl.frozen_at(UavId::new(2), 2.9) && tl.frozen_at(UavId::new(2), 3.0));
        assert!(tl.rule_at(2.9, UavId::new(2), UavId::new(1)).is_none());
        assert!(tl.rule_at(3.5, UavId::new(2), UavId::new(1)).is_some_and(|r| r.blocked), "mute");
        assert!(tl.rule_at(3.5, UavId::new(1), UavId::new(2)).is_none(), "others still reach it");
    }

    #[test]
    fn a_partition_event_cuts_its_links_over_per_link_rules_until_healed() {
        let tl = timeline(
            r#"
[[netem]]
at_s = 1.0
rule = { delay_s = 0.2 }
[[netem]]
at_s = 2.0
partition = { scheme = "halves", nodes = [1, 2, 3, 4] }
[[netem]]
at_s = 3.0
partition = { scheme = "bridge", nodes = [1, 2, 3, 4] }
rule = { hold = true }
[[netem]]
at_s = 4.0
partition = { scheme = "healed" }
"#,
        );
        let rule = |t, a, b| tl.rule_at(t, a, b).cloned();
        assert_eq!(rule(1.5, UavId::new(1), UavId::new(3)).map(|r| r.delay_s), Some(0.2));
        // Halves {1,2} | {3,4}: across is blocked, within keeps the per-link rule.
        assert!(rule(2.5, UavId::new(1), UavId::new(3)).is_some_and(|r| r.blocked));
        assert_eq!(rule(2.5, UavId::new(1), UavId::new(2)).map(|r| r.delay_s), Some(0.2));
        // Bridge {1,2} | 3 | {4}: the new partition replaces the old one, and holds instead of drops.
        assert!(rule(3.5, UavId::new(1), UavId::new(4)).is_some_and(|r| r.hold && !r.blocked));
        assert_eq!(rule(3.5, UavId::new(1), UavId::new(3)).map(|r| r.delay_s), Some(0.2), "3 is the bridge");
        // Healed: only the per-link rule is left.
        assert_eq!(rule(4.5, UavId::new(1), UavId::new(4)).map(|r| r.delay_s), Some(0.2));
    }

    #[test]
    fn equal_times_go_to_the_later_in_list_order_and_additions_extend_the_list() {
        let mut tl = timeline("[[netem]]\nat_s = 1.0\nrule = { delay_s = 0.1 }\n");
        let added = |delay_s| swarm_config::Timeline {
            netem: vec![NetemRule::link(
                1.0,
                Default::default(),
                Default::default(),
                Impairment { delay_s, ..Impairment::IDENTITY },
            )],
            failures: vec![Failure { at_s: 2.0, uav: UavId::new(1), kind: FailureKind::Freeze }],
        };
        tl.extend(added(0.3));
        assert_eq!(
            tl.rule_at(1.0, UavId::new(1), UavId::new(2)).map(|r| r.delay_s),
            Some(0.3),
            "same time: the later one wins"
        );
        assert!(
            tl.frozen_at(UavId::new(1), 2.0)
                && tl.rule_at(2.0, UavId::new(1), UavId::new(2)).is_some_and(|r| r.blocked)
        );
        assert_eq!((tl.rules().len(), tl.failures().len()), (2, 1));
    }

    #[test]
    fn on_the_wire_it_is_exactly_the_scenarios_timeline_data() {
        let data = swarm_config::Timeline {
            netem: vec![NetemRule::partition(3.0, swarm_config::Partition::isolate(UavId::new(2)), true)],
            failures: vec![Failure { at_s: 1.0, uav: UavId::new(2), kind: FailureKind::Freeze }],
        };
        let json = serde_json::to_string(&data).expect("serializes");
        assert_eq!(serde_json::to_string(&Timeline::from(data.clone())).expect("serializes"), json);
        assert_eq!(serde_json::from_str::<Timeline>(&json).expect("parses"), Timeline::from(data));
    }
}

//! Links: what each agent's netem link did to the shares, from the counters its states carry
//! (messages and bytes sent and received, per link class offered, delivered, dropped, held) and
//! the delay given each delivered copy. Why its own part: the counters grow from zero in each
//! incarnation of an agent, so a restart must be noticed and the earlier counts kept, and only
//! the latest state's counters are needed (also to know whether an agent's last state is still
//! on its way).

use crate::recorder::tally::Tally;
use crate::summary::{AgentSummary, ClassSummary};
use std::collections::BTreeMap;
use swarm_types::UavId;
use swarm_wire::{AgentState, ClassCounts, LinkCounters};

/// One agent's link counters.
#[derive(Debug, Clone, Default)]
struct UavLinks {
    /// The tick and link counters of its latest state (all that is kept of it: the state itself
    /// waits for its tick's truth in the scoring, moved, not copied).
    last_state: Option<(u64, LinkCounters)>,
    /// Link class counts of its earlier incarnations (a restarted agent counts from zero).
    link_base: [ClassCounts; 3],
}

impl UavLinks {
    /// Its link class counts over every incarnation so far.
    fn link_classes(&self) -> [ClassCounts; 3] {
        let last = self.last_state.map(|(_, link)| link.classes).unwrap_or_default();
        std::array::from_fn(|i| self.link_base[i] + last[i])
    }
}

/// The links of every agent, folded state by state.
#[derive(Debug, Default)]
pub(super) struct Links {
    /// Per UAV that sent a state.
    uavs: BTreeMap<UavId, UavLinks>,
    /// Delay applied to each delivered copy, per link class [s].
    delays: [Tally; 3],
}

impl Links {
    /// Folds one agent state.
    pub(super) fn on_state(&mut self, st: &AgentState) {
        let a = self.uavs.entry(st.id).or_default();
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
    }

    /// The tick of UAV `id`'s latest state, if it sent one.
    pub(super) fn last_state_tick(&self, id: UavId) -> Option<u64> {
        self.uavs.get(&id).and_then(|a| a.last_state).map(|(tick, _)| tick)
    }

    /// Fills in `a`'s message counts, as of its latest state.
    pub(super) fn fill(&self, a: &mut AgentSummary) {
        let link = self.uavs.get(&a.id).and_then(|l| l.last_state).map(|(_, link)| link).unwrap_or_default();
        a.messages_sent = link.sent_msgs;
        a.bytes_sent = link.sent_bytes;
        a.messages_received = link.recv_msgs;
        a.bytes_received = link.recv_bytes;
        a.messages_delivered = link.delivered_msgs;
        a.malformed_messages = link.malformed;
    }

    /// What the links did, per class, over every agent.
    pub(super) fn summary(&self) -> Vec<ClassSummary> {
        let totals = self
            .uavs
            .values()
            .map(UavLinks::link_classes)
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
}

//! Traffic: what each agent session (an agent's own process, or a host's) received, and what
//! each agent received, per tick, from the counts every state carries. Why its own part: it is
//! the measure of whether traffic grows with the neighbours or with the swarm, and it is grouped
//! by session, not by UAV: the agents of a host share one session's counts and report them in
//! any order.

use crate::summary::{SessionTrafficSummary, TrafficSummary};
use std::collections::BTreeMap;
use swarm_types::UavId;
use swarm_wire::{AgentState, Traffic};

/// One agent session's traffic, folded from its agents' states.
#[derive(Debug, Default)]
struct SessionAcc {
    /// Its counts as of the latest state (each field the largest seen: counts only grow, and
    /// its agents' states arrive in any order).
    last: Traffic,
    /// Each of its agents' own counts.
    agents: BTreeMap<UavId, AgentTraffic>,
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
        l.remote_share_gaps = l.remote_share_gaps.max(t.remote_share_gaps);
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
            remote_share_gaps: self.last.remote_share_gaps,
            subscriptions_mean: self.subscriptions.0 as f64 / self.subscriptions.1.max(1) as f64,
        }
    }
}

/// What every agent session received, folded state by state.
#[derive(Debug, Default)]
pub(super) struct Sessions {
    /// By session id.
    sessions: BTreeMap<String, SessionAcc>,
}

impl Sessions {
    /// Folds one agent state (a state that names no session counts nowhere).
    pub(super) fn on_state(&mut self, st: &AgentState) {
        if !st.traffic.session.is_empty() {
            // Looked up by reference: the id is copied only for a session seen the first time.
            match self.sessions.get_mut(st.traffic.session.as_str()) {
                Some(acc) => acc.fold(st),
                None => self.sessions.entry(st.traffic.session.clone()).or_default().fold(st),
            }
        }
    }

    /// What the agent sessions received, per session, and what the agents received, per agent
    /// and tick over all of them.
    pub(super) fn summary(&self) -> TrafficSummary {
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
}

#[cfg(test)]
mod tests {
    use super::super::Metrics;
    use super::*;

    #[test]
    fn traffic_is_per_session_and_per_agent_tick() {
        // (id, tick, session, session shares, session bytes, counted, agent shares, agent bytes)
        let state =
            |id: u32, tick: u64, session: &str, shares: u64, bytes: u64, counted: u64, mine: (u64, u64)| AgentState {
                id: UavId::new(id),
                tick,
                t_s: 0.1 * tick as f64,
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
                    remote_share_gaps: shares / 20,
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
        assert_eq!(
            (h.session.as_str(), h.agents, h.ticks, h.uavs.clone()),
            ("h", 2, 10, vec![UavId::new(1), UavId::new(2)])
        );
        assert_eq!((h.shares_arrived_per_tick, h.shares_counted_per_tick, h.bytes_per_tick), (20.0, 8.0, 500.0));
        assert_eq!(h.subscriptions_mean, 4.0);
        assert_eq!((h.remote_shares_per_tick, h.remote_share_bytes_per_tick), (10.0, 100.0));
        assert_eq!(h.remote_share_gaps, 10, "the latest count: 200 / 20");
        // Agents 1 and 2 reported ticks 0 to 9, agent 3 ticks 5 to 9: 25 agent-ticks.
        assert_eq!(t.shares_arrived_per_agent_tick, (35.0 + 55.0 + 25.0) / 25.0);
        assert_eq!(t.shares_counted_per_agent_tick, (30.0 + 50.0 + 20.0) / 25.0);
        assert_eq!(t.bytes_per_agent_tick, (3000.0 + 4000.0 + 600.0) / 25.0);
    }
}

//! The one seam every inter-agent message passes through.
//!
//! An agent hands each outgoing share message to [`Link::on_send`] and each incoming one to
//! [`Link::on_receive`], which decides when (and, later, whether) it is delivered; delivered
//! messages wait in an [`Inbox`] until their sim-time delivery instant and are taken out at the
//! tick that reaches it. Today the link passes everything with the minimum latency of one tick
//! and only counts messages and bytes; delay, jitter, loss, burst loss, partitions and the rest
//! plug into [`Link`] later without touching the agents.
//!
//! Architecture invariant: pure logic, no IO, no clock of its own. Time is sim time handed in by
//! the caller, so a run is as lossy at 50× real time as at 1×, and every decision is repeatable.
//! Onboard wiring (sensor and command keys) never passes through here.
//!
//! Modules: [`impair`], the pure impairment core (delay, jitter, loss and burst loss, duplication,
//! reordering, rate, partitions) following Linux netem, not yet wired into [`Link`].

use serde::{Deserialize, Serialize};

pub mod impair;

/// Counters of one agent's inter-agent traffic.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Counters {
    /// Messages this agent published to neighbours.
    pub sent_msgs: u64,
    /// Bytes this agent published to neighbours.
    pub sent_bytes: u64,
    /// Messages that arrived from neighbours.
    pub recv_msgs: u64,
    /// Bytes that arrived from neighbours.
    pub recv_bytes: u64,
    /// Messages handed to the agent (after the link's decisions).
    pub delivered_msgs: u64,
    /// Messages the link dropped (none yet: the link passes everything).
    pub dropped_msgs: u64,
}

/// What the link decided for one incoming message.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Verdict {
    /// Deliver at this sim time.
    DeliverAt(f64),
    /// Duplicated: deliver a copy at each of these sim times.
    DeliverTwice(f64, f64),
    /// Drop it.
    Drop,
}

/// The receive side of one agent's inter-agent links: one seeded [`impair::LinkSim`] per sender,
/// and the counters.
#[derive(Debug, Clone, Default)]
pub struct Link {
    counters: Counters,
    seed: u64,
    me: u32,
    sims: std::collections::BTreeMap<u32, impair::LinkSim>,
}

impl Link {
    /// A link that passes everything.
    pub fn new() -> Link {
        Link::default()
    }

    /// The links into agent `me`, whose random streams derive from the run's `seed`.
    pub fn with_seed(seed: u64, me: u32) -> Link {
        Link { seed, me, ..Link::default() }
    }

    /// Like [`Link::on_receive`], under `rule` (the impairment in force for the link from `from`
    /// at the send time; `None` = identity). The rule is applied at the send instant, as netem
    /// applies it at enqueue; every message still takes at least one tick.
    pub fn on_receive_with(
        &mut self,
        rule: Option<&impair::Impairment>,
        from: u32,
        sent_at: f64,
        now: f64,
        dt: f64,
        bytes: usize,
    ) -> Verdict {
        let Some(rule) = rule.filter(|r| !r.is_identity()) else {
            return self.on_receive(from, sent_at, now, dt, bytes);
        };
        self.counters.recv_msgs += 1;
        self.counters.recv_bytes += bytes as u64;
        let (seed, me) = (self.seed, self.me);
        let sim = self.sims.entry(from).or_insert_with(|| impair::LinkSim::new(seed, from, me));
        let at = |t: f64| t.max(sent_at + dt).max(now);
        match sim.decide(rule, sent_at, bytes) {
            impair::Decision::Lost(_) => {
                self.counters.dropped_msgs += 1;
                Verdict::Drop
            }
            impair::Decision::Deliver(t) => Verdict::DeliverAt(at(t)),
            impair::Decision::Duplicate(a, b) => Verdict::DeliverTwice(at(a), at(b)),
        }
    }

    /// Accounts for an outgoing message of `bytes` bytes. Returns whether to publish it.
    pub fn on_send(&mut self, bytes: usize) -> bool {
        self.counters.sent_msgs += 1;
        self.counters.sent_bytes += bytes as u64;
        true
    }

    /// Decides the fate of a message from `from`, sent at sim time `sent_at`, arriving as the
    /// receiver is at sim time `now` with tick length `dt`. A message sent at t_k is delivered no
    /// earlier than t_{k+1}, as over a real radio (SPEC section 2, lockstep protocol).
    pub fn on_receive(&mut self, _from: u32, sent_at: f64, now: f64, dt: f64, bytes: usize) -> Verdict {
        self.counters.recv_msgs += 1;
        self.counters.recv_bytes += bytes as u64;
        Verdict::DeliverAt((sent_at + dt).max(now))
    }

    /// Notes that `n` messages were handed to the agent.
    pub fn on_delivered(&mut self, n: usize) {
        self.counters.delivered_msgs += n as u64;
    }

    /// Counters since start.
    pub fn counters(&self) -> Counters {
        self.counters
    }
}

/// Messages waiting for their delivery instant, in arrival order.
#[derive(Debug)]
pub struct Inbox<T> {
    waiting: Vec<(f64, T)>,
}

impl<T> Default for Inbox<T> {
    fn default() -> Self {
        Inbox { waiting: Vec::new() }
    }
}

impl<T> Inbox<T> {
    /// An empty inbox.
    pub fn new() -> Self {
        Inbox::default()
    }

    /// Holds `msg` until sim time `deliver_at`.
    pub fn push(&mut self, deliver_at: f64, msg: T) {
        self.waiting.push((deliver_at, msg));
    }

    /// Takes every message due at or before `now` (sim time), in arrival order. A microsecond of
    /// slack absorbs the float rounding of tick times (`0.3 + 0.1` vs `4.0 * 0.1`).
    pub fn take_due(&mut self, now: f64) -> Vec<T> {
        let mut due = Vec::new();
        let mut i = 0;
        while i < self.waiting.len() {
            if self.waiting[i].0 <= now + 1e-6 {
                due.push(self.waiting.remove(i).1);
            } else {
                i += 1;
            }
        }
        due
    }

    /// Keeps only the waiting messages for which `keep` is true (a link that went down takes
    /// its undelivered messages with it).
    pub fn retain(&mut self, mut keep: impl FnMut(&T) -> bool) {
        self.waiting.retain(|(_, m)| keep(m));
    }

    /// Messages still waiting.
    pub fn len(&self) -> usize {
        self.waiting.len()
    }

    /// Whether nothing is waiting.
    pub fn is_empty(&self) -> bool {
        self.waiting.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_messages_and_bytes_both_ways() {
        let mut l = Link::new();
        assert!(l.on_send(100));
        assert!(l.on_send(50));
        let _ = l.on_receive(2, 0.0, 0.0, 0.1, 70);
        l.on_delivered(1);
        let c = l.counters();
        assert_eq!((c.sent_msgs, c.sent_bytes), (2, 150));
        assert_eq!((c.recv_msgs, c.recv_bytes, c.delivered_msgs), (1, 70, 1));
    }

    #[test]
    fn a_message_is_never_delivered_in_the_tick_it_was_sent() {
        let mut l = Link::new();
        let dt = 0.1;
        let mut inbox = Inbox::new();
        let Verdict::DeliverAt(at) = l.on_receive(1, 0.3, 0.3, dt, 10) else { panic!("passes") };
        inbox.push(at, "m");
        assert!(inbox.take_due(0.3).is_empty(), "not in the sending tick");
        // 0.3 + 0.1 computed in floats is 0.4000000000000001; tick 4 is 4.0 * 0.1 = 0.4.
        assert_eq!(inbox.take_due(4.0 * dt), vec!["m"]);
        assert!(inbox.is_empty());
    }

    #[test]
    fn late_arrivals_are_delivered_at_once() {
        let mut l = Link::new();
        let Verdict::DeliverAt(at) = l.on_receive(1, 0.1, 0.5, 0.1, 10) else { panic!("passes") };
        assert!(at <= 0.5);
    }

    #[test]
    fn rules_drop_delay_and_count_but_never_beat_one_tick() {
        use impair::{Impairment, LossModel};
        let mut l = Link::with_seed(7, 1);
        let lossy = Impairment { loss: LossModel::Random { p: 0.3 }, delay_s: 0.25, ..Impairment::IDENTITY };
        let (mut dropped, mut delivered) = (0, 0);
        for i in 0..10_000 {
            let t = f64::from(i) * 0.1;
            match l.on_receive_with(Some(&lossy), 2, t, t, 0.1, 50) {
                Verdict::Drop => dropped += 1,
                Verdict::DeliverAt(at) => {
                    delivered += 1;
                    assert!((at - (t + 0.25)).abs() < 1e-9, "delayed by the rule");
                }
                Verdict::DeliverTwice(..) => panic!("no duplication configured"),
            }
        }
        assert!((2_800..3_200).contains(&dropped), "{dropped}");
        assert_eq!(l.counters().dropped_msgs, dropped);
        assert_eq!(delivered + dropped, 10_000);
        // A 10 ms delay still takes the one-tick minimum.
        let short = Impairment { delay_s: 0.01, ..Impairment::IDENTITY };
        assert_eq!(l.on_receive_with(Some(&short), 3, 1.0, 1.0, 0.1, 50), Verdict::DeliverAt(1.1));
        // The same seed repeats the same decisions.
        let mut a = Link::with_seed(7, 1);
        let mut b = Link::with_seed(7, 1);
        for i in 0..100 {
            let t = f64::from(i) * 0.1;
            assert_eq!(a.on_receive_with(Some(&lossy), 2, t, t, 0.1, 50), b.on_receive_with(Some(&lossy), 2, t, t, 0.1, 50));
        }
    }

    #[test]
    fn inbox_keeps_arrival_order_and_holds_future_messages() {
        let mut inbox = Inbox::new();
        inbox.push(0.2, 1);
        inbox.push(0.5, 2);
        inbox.push(0.1, 3);
        assert_eq!(inbox.take_due(0.3), vec![1, 3]);
        assert_eq!(inbox.len(), 1);
        assert_eq!(inbox.take_due(1.0), vec![2]);
    }

    #[test]
    fn retain_drops_what_it_is_told_to() {
        let mut inbox = Inbox::new();
        inbox.push(0.2, (1, 5));
        inbox.push(0.2, (2, 5));
        inbox.retain(|&(from, _)| from != 1);
        assert_eq!(inbox.take_due(1.0), vec![(2, 5)]);
    }
}

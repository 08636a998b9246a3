//! The one seam every inter-agent message passes through.
//!
//! An agent hands each outgoing share message to [`Link::on_send`] and each incoming one to
//! [`Link::on_receive_with`], under the rule its [`Timeline`] says is in force on that link at the
//! send instant; the link decides whether and when the message is delivered (delay, jitter, loss
//! and burst loss, duplication, reordering, rate, the radio's distance loss, partitions that block
//! or hold), never sooner than one tick after it was sent. Delivered messages wait in an [`Inbox`]
//! until their sim-time delivery instant and are taken out at the tick that reaches it; held ones
//! wait until their link stops holding.
//!
//! Architecture invariant: pure logic, no IO, no clock of its own. Time is sim time handed in by
//! the caller, so a run is as lossy at 50× real time as at 1×, and every decision is repeatable.
//! Onboard wiring (sensor and command keys) never passes through here. The rules are the
//! scenario's data (`swarm_config`: [`impair::Impairment`], [`impair::Partition`], the
//! `[[netem]]` and `[[failures]]` tables); this crate is their behaviour.
//!
//! Modules: [`impair`], the pure impairment core (delay, jitter, loss and burst loss, duplication,
//! reordering, rate, partitions, hold) following Linux netem; `timeline` ([`Timeline`]: which rule
//! is in force on a link at a sim time, who is frozen); [`nemesis`], Jepsen's vocabulary of
//! generated faults (partitions by scheme, loss and bursts, delay, duplication, freezes, kills,
//! link stalls) in seeded random schedules, rendered into `[[netem]]` and `[[failures]]`. [`Link`] runs one seeded
//! [`impair::LinkSim`] per sender under the rule the caller looked up.
//!
//! Metrics: every message is counted under the class of the rule in force on its link when it was
//! sent ([`LinkClass`]: clean, impaired, blocked/held), one count per [`Outcome`] in
//! [`ClassCounters`], and the delay actually applied to every delivered copy (delivery instant −
//! send instant, the one-tick floor included) is kept until the caller takes it with
//! [`Link::take_delays`], so a recorder can report mean and p95 per class.

use serde::{Deserialize, Serialize};
use swarm_types::UavId;

pub mod impair;
pub mod nemesis;
mod timeline;

pub use timeline::Timeline;

/// Counters of one agent's inter-agent traffic.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
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
    /// Messages the link dropped.
    pub dropped_msgs: u64,
    /// Per [`LinkClass`] (indexed by `class as usize`).
    pub classes: [ClassCounters; 3],
}

/// The class of a link at the instant a message was sent, by the rule in force on it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum LinkClass {
    /// No rule, or a rule that changes nothing.
    Clean = 0,
    /// Delay, loss, duplication, reordering or rate (anything but a cut).
    Impaired = 1,
    /// Blocked or held (partition, isolation, frozen sender).
    Cut = 2,
}

impl LinkClass {
    /// The class of `rule` (`None` = no rule).
    pub fn of(rule: Option<&impair::Impairment>) -> LinkClass {
        match rule {
            None => LinkClass::Clean,
            Some(r) if r.blocked || r.hold => LinkClass::Cut,
            Some(r) if r.is_identity() => LinkClass::Clean,
            Some(_) => LinkClass::Impaired,
        }
    }

    /// Lower-case name, as in `summary.json`.
    pub fn name(self) -> &'static str {
        match self {
            LinkClass::Clean => "clean",
            LinkClass::Impaired => "impaired",
            LinkClass::Cut => "cut",
        }
    }

    /// Every class, in index order.
    pub const ALL: [LinkClass; 3] = [LinkClass::Clean, LinkClass::Impaired, LinkClass::Cut];
}

/// What can happen to a message arriving on a link, each counted per [`LinkClass`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// It arrived on a link of this class.
    Offered = 0,
    /// A copy was scheduled for delivery (duplicates and released messages included).
    Delivered = 1,
    /// It was dropped (loss model, radio loss, cut).
    Dropped = 2,
    /// It was duplicated.
    Duplicated = 3,
    /// It was stored by a holding link.
    Held = 4,
    /// Stored earlier, it was delivered when its link released.
    Released = 5,
}

/// What the links of one class did to incoming messages: a count per [`Outcome`].
///
/// `delivered = offered − dropped − held + duplicated + released`. The wire carries these under
/// names of its own (`swarm_wire::ClassCounts`); netem only counts.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ClassCounters([u64; 6]);

impl ClassCounters {
    /// How many messages had `outcome`.
    pub fn get(&self, outcome: Outcome) -> u64 {
        self.0[outcome as usize]
    }

    /// Counts `n` more messages with `outcome`.
    fn add(&mut self, outcome: Outcome, n: u64) {
        self.0[outcome as usize] += n;
    }
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
    /// Store it until the link releases (see [`Inbox::push_held`] and [`Link::on_released`]).
    Hold,
}

/// The receive side of one agent's inter-agent links: one seeded [`impair::LinkSim`] per sender,
/// and the counters.
#[derive(Debug, Clone, Default)]
pub struct Link {
    counters: Counters,
    seed: u64,
    me: UavId,
    sims: std::collections::BTreeMap<UavId, impair::LinkSim>,
    delays: Vec<AppliedDelay>,
}

/// The delay one delivered copy was given: delivery instant − send instant [s].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AppliedDelay {
    /// The class of its link at the send instant.
    pub class: LinkClass,
    /// The delay [s].
    pub delay_s: f64,
}

impl Link {
    /// A link that passes everything.
    pub fn new() -> Link {
        Link::default()
    }

    /// The links into agent `me`, whose random streams derive from the run's `seed`.
    pub fn with_seed(seed: u64, me: UavId) -> Link {
        Link { seed, me, ..Link::default() }
    }

    /// Like [`Link::on_receive`], under `rule` (the impairment in force for the link from `from`
    /// at the send time; `None` = identity) after the radio's distance-dependent loss
    /// `radio_loss` (a probability; 0 = none). The rule is applied at the send instant, as netem
    /// applies it at enqueue; every message still takes at least one tick.
    #[allow(clippy::too_many_arguments)]
    pub fn on_receive_with(
        &mut self,
        rule: Option<&impair::Impairment>,
        radio_loss: f64,
        from: UavId,
        sent_at: f64,
        now: f64,
        dt: f64,
        bytes: usize,
    ) -> Verdict {
        let class = LinkClass::of(rule);
        let rule = rule.filter(|r| !r.is_identity());
        if rule.is_none() && radio_loss <= 0.0 {
            return self.on_receive(from, sent_at, now, dt, bytes);
        }
        self.counters.recv_msgs += 1;
        self.counters.recv_bytes += bytes as u64;
        self.counters.classes[class as usize].add(Outcome::Offered, 1);
        let (seed, me) = (self.seed, self.me);
        let sim = self.sims.entry(from).or_insert_with(|| impair::LinkSim::new(seed, from, me));
        let decision = if sim.radio_loss(radio_loss) {
            impair::Decision::Lost(impair::LossCause::Radio)
        } else {
            sim.decide(rule.unwrap_or(&impair::Impairment::IDENTITY), sent_at, bytes)
        };
        let at = |t: f64| t.max(sent_at + dt).max(now);
        let verdict = match decision {
            impair::Decision::Lost(_) => Verdict::Drop,
            impair::Decision::Held => Verdict::Hold,
            impair::Decision::Deliver(t) => Verdict::DeliverAt(at(t)),
            impair::Decision::Duplicate(a, b) => Verdict::DeliverTwice(at(a), at(b)),
        };
        self.account(class, sent_at, verdict);
        verdict
    }

    /// Counts one verdict under `class` and keeps the delays it applies.
    fn account(&mut self, class: LinkClass, sent_at: f64, verdict: Verdict) {
        let c = &mut self.counters.classes[class as usize];
        let delay =
            |at: f64, delays: &mut Vec<AppliedDelay>| delays.push(AppliedDelay { class, delay_s: at - sent_at });
        match verdict {
            Verdict::Drop => {
                c.add(Outcome::Dropped, 1);
                self.counters.dropped_msgs += 1;
            }
            Verdict::Hold => c.add(Outcome::Held, 1),
            Verdict::DeliverAt(a) => {
                c.add(Outcome::Delivered, 1);
                delay(a, &mut self.delays);
            }
            Verdict::DeliverTwice(a, b) => {
                c.add(Outcome::Delivered, 2);
                c.add(Outcome::Duplicated, 1);
                delay(a, &mut self.delays);
                delay(b, &mut self.delays);
            }
        }
    }

    /// Notes that a message held since `sent_at` on a link of class `class` was released at
    /// sim time `now` (it is delivered now).
    pub fn on_released(&mut self, class: LinkClass, sent_at: f64, now: f64) {
        let c = &mut self.counters.classes[class as usize];
        c.add(Outcome::Released, 1);
        c.add(Outcome::Delivered, 1);
        self.delays.push(AppliedDelay { class, delay_s: now - sent_at });
    }

    /// The delays applied since the last call, oldest first.
    pub fn take_delays(&mut self) -> Vec<AppliedDelay> {
        std::mem::take(&mut self.delays)
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
    pub fn on_receive(&mut self, _from: UavId, sent_at: f64, now: f64, dt: f64, bytes: usize) -> Verdict {
        self.counters.recv_msgs += 1;
        self.counters.recv_bytes += bytes as u64;
        self.counters.classes[LinkClass::Clean as usize].add(Outcome::Offered, 1);
        let verdict = Verdict::DeliverAt((sent_at + dt).max(now));
        self.account(LinkClass::Clean, sent_at, verdict);
        verdict
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

/// Messages waiting for their delivery instant, in arrival order. Held messages
/// ([`Verdict::Hold`]) wait with no instant until [`Inbox::release`] gives them one.
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

    /// Holds `msg` until [`Inbox::release`] lets it go.
    pub fn push_held(&mut self, msg: T) {
        self.waiting.push((f64::INFINITY, msg));
    }

    /// Gives every held message for which `release` is true the delivery instant `now` (it is
    /// taken out by the next [`Inbox::take_due`]); returns how many were released. `release`
    /// sees each held message once, so it may also note what it lets go.
    pub fn release(&mut self, now: f64, mut release: impl FnMut(&T) -> bool) -> usize {
        let mut n = 0;
        for (at, m) in &mut self.waiting {
            if at.is_infinite() && release(m) {
                *at = now;
                n += 1;
            }
        }
        n
    }

    /// The held messages (waiting for a release).
    pub fn held(&self) -> impl Iterator<Item = &T> {
        self.waiting.iter().filter(|(at, _)| at.is_infinite()).map(|(_, m)| m)
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
    use Outcome::{Delivered, Dropped, Held, Offered, Released};

    #[test]
    fn counts_messages_and_bytes_both_ways() {
        let mut l = Link::new();
        assert!(l.on_send(100));
        assert!(l.on_send(50));
        let _ = l.on_receive(UavId::new(2), 0.0, 0.0, 0.1, 70);
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
        let Verdict::DeliverAt(at) = l.on_receive(UavId::new(1), 0.3, 0.3, dt, 10) else { panic!("passes") };
        inbox.push(at, "m");
        assert!(inbox.take_due(0.3).is_empty(), "not in the sending tick");
        // 0.3 + 0.1 computed in floats is 0.4000000000000001; tick 4 is 4.0 * 0.1 = 0.4.
        assert_eq!(inbox.take_due(4.0 * dt), vec!["m"]);
        assert!(inbox.is_empty());
    }

    #[test]
    fn late_arrivals_are_delivered_at_once() {
        let mut l = Link::new();
        let Verdict::DeliverAt(at) = l.on_receive(UavId::new(1), 0.1, 0.5, 0.1, 10) else { panic!("passes") };
        assert!(at <= 0.5);
    }

    #[test]
    fn rules_drop_delay_and_count_but_never_beat_one_tick() {
        use impair::{Impairment, LossModel};
        let mut l = Link::with_seed(7, UavId::new(1));
        let lossy = Impairment { loss: LossModel::Random { p: 0.3 }, delay_s: 0.25, ..Impairment::IDENTITY };
        let (mut dropped, mut delivered) = (0, 0);
        for i in 0..10_000 {
            let t = f64::from(i) * 0.1;
            match l.on_receive_with(Some(&lossy), 0.0, UavId::new(2), t, t, 0.1, 50) {
                Verdict::Drop => dropped += 1,
                Verdict::DeliverAt(at) => {
                    delivered += 1;
                    assert!((at - (t + 0.25)).abs() < 1e-9, "delayed by the rule");
                }
                Verdict::DeliverTwice(..) | Verdict::Hold => panic!("no duplication or hold configured"),
            }
        }
        assert!((2_800..3_200).contains(&dropped), "{dropped}");
        assert_eq!(l.counters().dropped_msgs, dropped);
        assert_eq!(delivered + dropped, 10_000);
        // A 10 ms delay still takes the one-tick minimum.
        let short = Impairment { delay_s: 0.01, ..Impairment::IDENTITY };
        assert_eq!(l.on_receive_with(Some(&short), 0.0, UavId::new(3), 1.0, 1.0, 0.1, 50), Verdict::DeliverAt(1.1));
        // The same seed repeats the same decisions.
        let mut a = Link::with_seed(7, UavId::new(1));
        let mut b = Link::with_seed(7, UavId::new(1));
        for i in 0..100 {
            let t = f64::from(i) * 0.1;
            assert_eq!(
                a.on_receive_with(Some(&lossy), 0.0, UavId::new(2), t, t, 0.1, 50),
                b.on_receive_with(Some(&lossy), 0.0, UavId::new(2), t, t, 0.1, 50)
            );
        }
    }

    #[test]
    fn classes_count_and_delays_are_kept_per_class() {
        use impair::{Impairment, LossModel};
        let mut l = Link::with_seed(3, UavId::new(1));
        let delayed = Impairment { delay_s: 0.3, loss: LossModel::Random { p: 0.5 }, ..Impairment::IDENTITY };
        for i in 0..1000 {
            let t = f64::from(i) * 0.1;
            let _ = l.on_receive_with(None, 0.0, UavId::new(2), t, t, 0.1, 10);
            let _ = l.on_receive_with(Some(&delayed), 0.0, UavId::new(3), t, t, 0.1, 10);
            let _ = l.on_receive_with(Some(&Impairment::BLOCKED), 0.0, UavId::new(4), t, t, 0.1, 10);
        }
        let c = l.counters();
        let [clean, impaired, cut] = c.classes;
        assert_eq!((clean.get(Offered), clean.get(Delivered), clean.get(Dropped)), (1000, 1000, 0));
        assert_eq!(impaired.get(Offered), 1000);
        assert!((430..570).contains(&impaired.get(Dropped)), "{impaired:?}");
        assert_eq!(impaired.get(Delivered) + impaired.get(Dropped), 1000);
        assert_eq!((cut.get(Offered), cut.get(Dropped), cut.get(Delivered)), (1000, 1000, 0));
        assert_eq!(c.dropped_msgs, impaired.get(Dropped) + cut.get(Dropped));
        let delays = l.take_delays();
        assert_eq!(delays.len() as u64, clean.get(Delivered) + impaired.get(Delivered));
        for d in &delays {
            let want = if d.class == LinkClass::Clean { 0.1 } else { 0.3 };
            assert!((d.delay_s - want).abs() < 1e-9, "{d:?}");
        }
        assert!(l.take_delays().is_empty(), "taken once");
    }

    #[test]
    fn radio_loss_drops_its_share_before_netem_and_repeats() {
        let run = |seed| {
            let mut l = Link::with_seed(seed, UavId::new(1));
            (0..4000)
                .map(|i| l.on_receive_with(None, 0.25, UavId::new(2), f64::from(i), f64::from(i), 0.1, 10))
                .collect::<Vec<_>>()
        };
        let a = run(9);
        let dropped = a.iter().filter(|v| **v == Verdict::Drop).count();
        assert!((880..1120).contains(&dropped), "{dropped}");
        assert_eq!(a, run(9));
        assert_ne!(a, run(10));
    }

    #[test]
    fn held_messages_wait_for_release_and_count_their_whole_wait() {
        let mut l = Link::with_seed(1, UavId::new(1));
        let mut inbox = Inbox::new();
        for i in 0..5 {
            let t = f64::from(i);
            match l.on_receive_with(Some(&impair::Impairment::HOLD), 0.0, UavId::new(2), t, t, 0.1, 10) {
                Verdict::Hold => inbox.push_held((2, t)),
                v => panic!("{v:?}"),
            }
        }
        assert!(inbox.take_due(100.0).is_empty(), "held, not due");
        assert_eq!(inbox.held().count(), 5);
        let released = inbox.release(10.0, |&(from, _)| from == 2);
        assert_eq!(released, 5);
        assert_eq!(inbox.held().count(), 0, "all released");
        let due = inbox.take_due(10.0);
        for &(_, sent) in &due {
            l.on_released(LinkClass::Cut, sent, 10.0);
        }
        assert_eq!(due.len(), 5);
        let cut = l.counters().classes[LinkClass::Cut as usize];
        assert_eq!((cut.get(Offered), cut.get(Held), cut.get(Released), cut.get(Delivered)), (5, 5, 5, 5));
        let waits: Vec<f64> = l.take_delays().iter().map(|d| d.delay_s).collect();
        assert_eq!(waits, vec![10.0, 9.0, 8.0, 7.0, 6.0]);
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

//! Which of the shares that reach an agent count, and when each is delivered: the pure half of
//! the agent's share path. The Zenoh half (`net`) hands in what arrived and the hub's messages;
//! this type decides, with no IO and no clock of its own, so lockstep runs repeat and every rule
//! is unit-tested here.
//!
//! - **Windows.** An agent listens to the UAVs of its radio set. A neighbour's share counts only
//!   if it was sent inside the neighbour's window: from the second tick after the radio set that
//!   brought it into range ([`WINDOW_OPENS_AFTER`]) up to the tick before the radio set that took
//!   it out. The agent declares its subscription while handling that radio set k; the neighbour
//!   sends its share of tick k+2 only after the hub had every command of tick k+1, and the
//!   agent's command of tick k+1 leaves its session after the declaration (ARCHITECTURE.md, "Who
//!   receives which shares"). So the first share that counts always finds the subscription in
//!   place, and what counts never depends on when a declaration or undeclaration reached a
//!   router, nor on which other agents of a host happened to subscribe already.
//! - **Early shares.** A neighbour's share of tick k may arrive before or after this agent's own
//!   step k, depending on which process ran first. One that arrives before waits in `early` and
//!   is admitted at the hub's next message, which comes after every share of tick k: what each
//!   state message counts is then the same in every run. Delivery is unchanged (a share sent at
//!   t_k is due at t_{k+1} at the earliest, whenever it is admitted).
//! - **The netem link.** An admitted share passes [`netem::Link`] under the rule the timeline in
//!   force gives for its link at the send time, after the radio's distance loss of the sender,
//!   and waits in a [`netem::Inbox`] for its delivery instant (or its link's release).
//! - **Leaving range.** A neighbour's window closes with the radio set that took it out of
//!   range: its later shares never count. The ones admitted before were sent in range and are
//!   delivered as due (at that radio set, only shares of ticks already stepped have been
//!   admitted).

use crate::agent::LinkReport;
use crate::localization::Share;
use std::collections::{BTreeMap, BTreeSet};
use std::sync::Arc;
use swarm_types::{SimTime, UavId};
use tracing::{debug, trace};

/// Ticks from the radio set that brings a neighbour into range to the first tick whose share
/// counts. Two, not one: Zenoh sends a declaration at its control priority and a command at its
/// data priority, each from its own queue of the link, so the agent's command of tick k may leave
/// just before the declaration made while handling tick k's radio set, but its command of tick
/// k+1, put only after the hub had the one of tick k, always leaves after it (the link's sender
/// takes the control queue first).
pub(crate) const WINDOW_OPENS_AFTER: u64 = 2;

/// A share as an agent's session received it, decoded once and handed to every agent of the
/// session listening to its sender.
#[derive(Debug, Clone)]
pub(crate) struct Arrived {
    /// The sender's id (from the key it came on).
    pub(crate) from: UavId,
    /// The share, `None` when the payload was malformed.
    pub(crate) share: Option<Arc<Share>>,
    /// The payload's size on the wire [bytes], for the link.
    pub(crate) len: usize,
}

/// Who entered and who left an agent's radio set: whom to start and stop listening to.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub(crate) struct RadioChange {
    /// Left range, in id order.
    pub(crate) left: Vec<UavId>,
    /// Entered range, in the radio set's order (ids ascending).
    pub(crate) entered: Vec<UavId>,
}

/// The hub's ticks went backwards: from the last tick stepped to this one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct WentBack {
    /// The last tick stepped.
    pub(crate) last: u64,
    /// The tick offered now.
    pub(crate) tick: u64,
}

/// One agent's share admission: windows, early shares, the netem link and its inbox.
pub(crate) struct Admission {
    me: UavId,
    dt: f64,
    /// Whether the localization mode shares at all (`uvdar` does not: nobody to listen to).
    shares: bool,
    link: netem::Link,
    inbox: netem::Inbox<Arc<Share>>,
    /// Shares sent at a tick this agent has not stepped yet, in arrival order, with their size.
    early: Vec<(Arc<Share>, usize)>,
    /// The netem timeline in force (the scenario's, then the hub's).
    timeline: netem::Timeline,
    /// First tick whose share is accepted, per neighbour in radio range.
    windows: BTreeMap<UavId, u64>,
    /// The radio's distance-dependent loss probability per neighbour in range.
    radio_loss: BTreeMap<UavId, f64>,
    /// Malformed payloads received (shares, sensors, rules), counted and dropped.
    malformed: u64,
    /// Last tick stepped, `None` before the first.
    last_tick: Option<u64>,
}

impl Admission {
    /// The admission of agent `me`: tick length `dt`, netem draws seeded from the run's `seed`,
    /// `timeline` the scenario's; `shares` whether the mode has shares.
    pub(crate) fn new(me: UavId, seed: u64, dt: f64, timeline: netem::Timeline, shares: bool) -> Admission {
        Admission {
            me,
            dt,
            shares,
            link: netem::Link::with_seed(seed, me),
            inbox: netem::Inbox::new(),
            early: Vec::new(),
            timeline,
            windows: BTreeMap::new(),
            radio_loss: BTreeMap::new(),
            malformed: 0,
            last_tick: None,
        }
    }

    /// The last tick stepped, `None` before the first.
    pub(crate) fn last_tick(&self) -> Option<u64> {
        self.last_tick
    }

    /// Counts a malformed payload of any kind (it is dropped).
    pub(crate) fn count_malformed(&mut self) {
        self.malformed += 1;
    }

    /// The netem timeline in force changed (`swarm netem`).
    pub(crate) fn set_timeline(&mut self, timeline: netem::Timeline) {
        self.timeline = timeline;
    }

    /// The radio set of `tick` (`in_range` ascending, `loss` each one's distance loss, or empty):
    /// moves the windows and says whom to stop and start listening to.
    pub(crate) fn on_radio(&mut self, tick: u64, in_range: &[UavId], loss: &[f32]) -> RadioChange {
        self.radio_loss = in_range.iter().zip(loss).map(|(&id, &p)| (id, f64::from(p))).collect();
        let left: Vec<UavId> = self.windows.keys().copied().filter(|id| !in_range.contains(id)).collect();
        for &id in &left {
            self.windows.remove(&id);
            debug!(neighbour = %id, "stopped listening");
        }
        if !self.shares {
            return RadioChange { left, entered: Vec::new() };
        }
        let mut entered = Vec::new();
        for &id in in_range {
            if id != self.me && !self.windows.contains_key(&id) {
                debug!(neighbour = %id, "listening");
                self.windows.insert(id, tick.saturating_add(WINDOW_OPENS_AFTER));
                entered.push(id);
            }
        }
        RadioChange { left, entered }
    }

    /// A share message arrived. One sent at a tick this agent has not stepped yet waits in
    /// `early` for [`Admission::admit_early`]; the others are admitted now.
    pub(crate) fn on_arrived(&mut self, arrived: Arrived) {
        let Arrived { from, share, len } = arrived;
        let Some(share) = share else {
            self.malformed += 1;
            debug!(%from, len, "dropped malformed share");
            return;
        };
        if self.last_tick.is_none_or(|last| share.tick() > last) {
            self.early.push((share, len));
        } else {
            self.admit(share, len);
        }
    }

    /// Admits the early shares of ticks this agent has stepped by now (called at each hub
    /// message, which comes after every share of the ticks before it).
    pub(crate) fn admit_early(&mut self) {
        let Some(last) = self.last_tick else { return };
        if self.early.iter().all(|(share, _)| share.tick() > last) {
            return;
        }
        let (due, later) = std::mem::take(&mut self.early).into_iter().partition(|(share, _)| share.tick() <= last);
        self.early = later;
        for (share, len) in due {
            self.admit(share, len);
        }
    }

    /// Counts a share, keeps it only inside its sender's window, lets the link decide, holds it
    /// in the inbox.
    fn admit(&mut self, share: Arc<Share>, len: usize) {
        let from = share.from();
        if self.windows.get(&from).is_none_or(|&first| share.tick() < first) {
            trace!(%from, tick = share.tick(), "share outside the neighbour's window");
            return;
        }
        let now = SimTime::of_tick(self.last_tick.unwrap_or(0), self.dt).s();
        let rule = self.timeline.rule_at(share.t_s(), from, self.me);
        let radio_loss = self.radio_loss.get(&from).copied().unwrap_or(0.0);
        match self.link.on_receive_with(rule, radio_loss, from, share.t_s(), now, self.dt, len) {
            netem::Verdict::DeliverAt(at) => self.inbox.push(at, share),
            netem::Verdict::DeliverTwice(a, b) => {
                self.inbox.push(a, share.clone());
                self.inbox.push(b, share);
            }
            netem::Verdict::Drop => trace!(%from, "share dropped by netem"),
            netem::Verdict::Hold => self.inbox.push_held(share),
        }
    }

    /// Starts the step of `tick` at sim time `now`: the shares due by then (held ones whose link
    /// released included), in delivery order; an error when the ticks went backwards.
    pub(crate) fn begin_step(&mut self, tick: u64, now: f64) -> Result<Vec<Arc<Share>>, WentBack> {
        if let Some(last) = self.last_tick.filter(|&last| tick <= last) {
            return Err(WentBack { last, tick });
        }
        self.last_tick = Some(tick);
        self.release_held(now);
        let due = self.inbox.take_due(now);
        self.link.on_delivered(due.len());
        Ok(due)
    }

    /// Delivers, at `now`, every held share whose link no longer holds.
    fn release_held(&mut self, now: f64) {
        if self.inbox.held().next().is_none() {
            return;
        }
        // One rule lookup per sender that has held messages.
        let (timeline, me) = (&self.timeline, self.me);
        let senders: BTreeSet<UavId> = self.inbox.held().map(|m| m.from()).collect();
        let open: Vec<UavId> =
            senders.into_iter().filter(|&from| !timeline.rule_at(now, from, me).is_some_and(|r| r.hold)).collect();
        let mut released = Vec::new();
        self.inbox.release(now, |m| {
            let go = open.contains(&m.from());
            if go {
                released.push(m.t_s());
            }
            go
        });
        for sent_at in released {
            self.link.on_released(netem::LinkClass::Cut, sent_at, now);
        }
    }

    /// Accounts for this agent's own share of `len` bytes; whether to publish it.
    pub(crate) fn on_send(&mut self, len: usize) -> bool {
        self.link.on_send(len)
    }

    /// What the link measured: its counters since start, the delays applied since the last
    /// report (taken), and the neighbours listened to.
    pub(crate) fn report(&mut self) -> LinkReport {
        let c = self.link.counters();
        let counters = swarm_wire::LinkCounters {
            sent_msgs: c.sent_msgs,
            sent_bytes: c.sent_bytes,
            recv_msgs: c.recv_msgs,
            recv_bytes: c.recv_bytes,
            delivered_msgs: c.delivered_msgs,
            malformed: self.malformed,
            classes: c.classes.map(class_counts),
        };
        let delays = self
            .link
            .take_delays()
            .into_iter()
            .map(|d| swarm_wire::DelaySample { class: d.class as u8, delay_s: d.delay_s as f32 })
            .collect();
        LinkReport { in_radio_range: self.windows.len() as u32, counters, delays, ..LinkReport::default() }
    }
}

/// netem's counts of one link class in the wire's shape.
fn class_counts(c: netem::ClassCounters) -> swarm_wire::ClassCounts {
    use netem::Outcome::*;
    swarm_wire::ClassCounts {
        offered: c.get(Offered),
        delivered: c.get(Delivered),
        dropped: c.get(Dropped),
        duplicated: c.get(Duplicated),
        held: c.get(Held),
        released: c.get(Released),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use swarm_wire::{Msg, PoseShare};

    const DT: f64 = 0.1;

    fn admission() -> Admission {
        Admission::new(UavId::new(1), 7, DT, netem::Timeline::default(), true)
    }

    fn share(from: UavId, tick: u64) -> Arrived {
        let pose = PoseShare {
            from,
            tick,
            t_s: tick as f64 * DT,
            x: 0.0,
            y: 0.0,
            yaw: 0.0,
            vx: 0.0,
            vy: 0.0,
            hops: 0,
            arrival: 0,
        };
        let share = Share::from_msg(Msg::Pose(pose), from).expect("a share");
        Arrived { from, share: Some(Arc::new(share)), len: 50 }
    }

    /// The (sender, tick) of each share delivered at the step of `tick`.
    fn step(a: &mut Admission, tick: u64) -> Vec<(UavId, u64)> {
        a.admit_early();
        a.begin_step(tick, tick as f64 * DT).expect("ticks go forward").iter().map(|s| (s.from(), s.tick())).collect()
    }

    #[test]
    fn a_neighbour_counts_from_the_second_tick_after_it_entered_until_it_left() {
        let mut a = admission();
        assert_eq!(
            a.on_radio(4, &[UavId::new(1), UavId::new(2), UavId::new(3)], &[]),
            RadioChange { left: vec![], entered: vec![UavId::new(2), UavId::new(3)] },
            "never itself"
        );
        a.on_arrived(share(UavId::new(2), 4));
        step(&mut a, 4);
        a.on_arrived(share(UavId::new(2), 5));
        a.on_arrived(share(UavId::new(3), 5));
        step(&mut a, 5);
        a.on_arrived(share(UavId::new(2), 6));
        a.on_arrived(share(UavId::new(3), 6));
        assert_eq!(step(&mut a, 6), vec![], "ticks 4 and 5 are before the window; tick 6's is due at tick 7");
        assert_eq!(step(&mut a, 7), vec![(UavId::new(2), 6), (UavId::new(3), 6)]);
        a.on_arrived(share(UavId::new(2), 7));
        // The node admits what arrived at every hub message, before it offers the message.
        a.admit_early();
        assert_eq!(
            a.on_radio(8, &[UavId::new(1), UavId::new(3)], &[]),
            RadioChange { left: vec![UavId::new(2)], entered: vec![] }
        );
        a.on_arrived(share(UavId::new(2), 8));
        assert_eq!(
            step(&mut a, 8),
            vec![(UavId::new(2), 7)],
            "its last share in range still counts; the one after does not"
        );
        assert_eq!(step(&mut a, 9), vec![]);
        let report = a.report();
        assert_eq!(report.in_radio_range, 1);
        assert_eq!(report.counters.recv_msgs, 3, "only shares inside a window are counted");
    }

    #[test]
    fn a_share_that_arrives_before_its_tick_is_stepped_waits_and_is_delivered_alike() {
        let (mut early, mut late) = (admission(), admission());
        for a in [&mut early, &mut late] {
            a.on_radio(0, &[UavId::new(2)], &[]);
            step(a, 0);
            step(a, 1);
        }
        early.on_arrived(share(UavId::new(2), 2));
        assert_eq!(early.report().counters.recv_msgs, 0, "not counted before this agent stepped tick 2");
        step(&mut early, 2);
        step(&mut late, 2);
        late.on_arrived(share(UavId::new(2), 2));
        let (e, l) = (step(&mut early, 3), step(&mut late, 3));
        assert_eq!((e.clone(), e), (l, vec![(UavId::new(2), 2)]));
        assert_eq!(early.report().counters, late.report().counters);
    }

    #[test]
    fn malformed_shares_are_counted_and_dropped_and_ticks_may_not_go_back() {
        let mut a = admission();
        a.on_radio(0, &[UavId::new(2)], &[]);
        a.on_arrived(Arrived { from: UavId::new(2), share: None, len: 3 });
        a.count_malformed();
        assert_eq!(a.report().counters.malformed, 2);
        step(&mut a, 3);
        assert!(matches!(a.begin_step(3, 0.3), Err(WentBack { last: 3, tick: 3 })));
    }

    #[test]
    fn a_mode_without_shares_listens_to_nobody() {
        let mut a = Admission::new(UavId::new(1), 7, DT, netem::Timeline::default(), false);
        assert_eq!(
            a.on_radio(0, &[UavId::new(1), UavId::new(2), UavId::new(3)], &[0.0, 0.1, 0.2]),
            RadioChange::default()
        );
        assert_eq!(a.report().in_radio_range, 0);
    }

    #[test]
    fn a_neighbour_that_comes_back_counts_again_from_the_second_tick_after() {
        let mut a = admission();
        a.on_radio(0, &[UavId::new(2)], &[]);
        step(&mut a, 0);
        step(&mut a, 1);
        a.on_arrived(share(UavId::new(2), 2));
        step(&mut a, 2);
        a.admit_early();
        assert_eq!(a.on_radio(3, &[], &[]), RadioChange { left: vec![UavId::new(2)], entered: vec![] });
        assert_eq!(step(&mut a, 3), vec![(UavId::new(2), 2)], "sent in range: delivered though it left since");
        a.on_arrived(share(UavId::new(2), 3));
        a.admit_early();
        assert_eq!(a.on_radio(4, &[UavId::new(2)], &[]), RadioChange { left: vec![], entered: vec![UavId::new(2)] });
        a.on_arrived(share(UavId::new(2), 4));
        step(&mut a, 4);
        a.on_arrived(share(UavId::new(2), 5));
        step(&mut a, 5);
        a.on_arrived(share(UavId::new(2), 6));
        assert_eq!(
            step(&mut a, 6),
            vec![],
            "tick 3's share was sent out of range, ticks 4 and 5's before the window reopened"
        );
        assert_eq!(step(&mut a, 7), vec![(UavId::new(2), 6)]);
        assert_eq!(a.report().counters.recv_msgs, 2, "ticks 2 and 6");
    }

    #[test]
    fn a_holding_link_keeps_shares_until_it_releases() {
        let json = r#"{"netem":[{"at_s":0.0,"rule":{"hold":true}},{"at_s":0.45}],"failures":[]}"#;
        let mut a = admission();
        a.set_timeline(serde_json::from_str(json).expect("a timeline"));
        a.on_radio(0, &[UavId::new(2)], &[]);
        step(&mut a, 0);
        step(&mut a, 1);
        for t in 2..=4 {
            a.on_arrived(share(UavId::new(2), t));
            assert_eq!(step(&mut a, t), vec![], "held at tick {t}");
        }
        assert_eq!(
            step(&mut a, 5),
            vec![(UavId::new(2), 2), (UavId::new(2), 3), (UavId::new(2), 4)],
            "released together once the rule stops holding"
        );
        let cut = a.report().counters.classes[2];
        assert_eq!((cut.held, cut.released), (3, 3));
    }

    #[test]
    fn the_radio_loss_and_netem_rules_apply_at_admission() {
        let in_window = |a: &mut Admission| {
            step(a, 0);
            step(a, 1);
            a.on_arrived(share(UavId::new(2), 2));
            step(a, 2);
            step(a, 3)
        };
        let mut lossy = admission();
        lossy.on_radio(0, &[UavId::new(2)], &[1.0]);
        assert_eq!(in_window(&mut lossy), vec![], "a certain radio loss drops it");
        assert_eq!(
            (lossy.report().counters.recv_msgs, lossy.report().counters.delivered_msgs),
            (1, 0),
            "counted, then lost"
        );
        let json = r#"{"netem":[{"at_s":0.0,"rule":{"blocked":true}}],"failures":[]}"#;
        let mut cut = admission();
        cut.set_timeline(serde_json::from_str(json).expect("a timeline"));
        cut.on_radio(0, &[UavId::new(2)], &[]);
        assert_eq!(in_window(&mut cut), vec![], "the rule in force drops it");
        assert_eq!(cut.report().counters.classes[2].dropped, 1, "counted on a cut link");
    }
}

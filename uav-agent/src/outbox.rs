//! An agent host's commands and states in one message each a lockstep tick, and its agents'
//! shares of the tick held back to go just before them: which of its agents' steps a tick's
//! messages wait for, and when they are complete. Pure (a share is whatever the caller puts,
//! `S`), so the host's session ([`super::frames`]) only puts what this hands back.
//!
//! Why: a command and a state a UAV cost the host two puts, the router two routes and the hub
//! and the recorder a delivery each; at 500 agents a host that is 1000 of each a tick, two of
//! each here. The hub waits for every command of a lockstep tick anyway, so holding a host's
//! commands until its last agent has stepped costs the hub nothing.
//!
//! What a tick's messages wait for: the agents whose frames came in the host's one message of
//! that tick ([`Outbox::expect`]), as only those step on it. An agent whose frame came alone, or
//! that answers a tick it was not expected in, sends alone, as does an agent with an external
//! controller (its controller may keep it past the hub's tick timeout, and the host's others
//! must not wait with it). An agent that does not step on its frame (a malformed frame) or goes
//! away is let off ([`Outbox::skip`], [`Outbox::leave`]). When a later tick's step comes while an
//! earlier tick still waits (the hub went on after its tick timeout), the earlier tick's
//! messages go out as they are: their commands are late, as one agent's would be.
//!
//! Why the shares too: each share stays on its sender's own key (subscriptions are scoped per
//! sender), but put the moment its agent had stepped, the host's 500 shares of a tick left one
//! by one, about 100 µs apart: each woke the session's sending thread and went in a batch of its
//! own, and the router's receiving and sending threads woke for each again (in forest-1000-icp
//! about 2 000 context switches of the hub's Zenoh threads a tick). Put together, they leave
//! in a few full batches. No agent needs them earlier: a share of tick k counts at tick k+1.
//!
//! Order: a tick's shares go out before its commands (an agent's share alone before its
//! command alone), so every share of the host's tick leaves before its commands, as the lockstep
//! protocol needs (ARCHITECTURE, "Who receives which shares").

use std::collections::{BTreeMap, BTreeSet};
use swarm_types::UavId;
use swarm_wire::{AgentState, Cmd, UavCmd};

/// The commands and states of one tick of a host's agents, to put as one message each, and
/// their shares, to put each on its own key before them.
#[derive(Debug, PartialEq)]
pub(crate) struct Batch<S> {
    /// The shares of the agents that had one, in the order offered.
    pub(crate) shares: Vec<S>,
    /// Each agent's command, in the order offered.
    pub(crate) cmds: Vec<UavCmd>,
    /// Each agent's state, in the same order.
    pub(crate) states: Vec<AgentState>,
}

impl<S> Default for Batch<S> {
    fn default() -> Self {
        Batch { shares: Vec::new(), cmds: Vec::new(), states: Vec::new() }
    }
}

/// What became of an offered step.
#[derive(Debug, PartialEq)]
pub(crate) enum Offered<S> {
    /// Not awaited: the agent sends it alone (its share first).
    Alone(Option<S>, Cmd, Box<AgentState>),
    /// Taken; these messages are complete now (oldest tick first; maybe none).
    Taken(Vec<Batch<S>>),
}

/// A tick whose steps are not all in.
#[derive(Debug)]
struct Open<S> {
    waiting: BTreeSet<UavId>,
    batch: Batch<S>,
}

impl<S> Default for Open<S> {
    fn default() -> Self {
        Open { waiting: BTreeSet::new(), batch: Batch::default() }
    }
}

/// The ticks a host's messages wait on.
#[derive(Debug)]
pub(crate) struct Outbox<S> {
    open: BTreeMap<u64, Open<S>>,
}

impl<S> Default for Outbox<S> {
    fn default() -> Self {
        Outbox { open: BTreeMap::new() }
    }
}

impl<S> Outbox<S> {
    /// The frames of `tick` came to the agents `ids` in one message: their steps of `tick` are
    /// awaited.
    pub(crate) fn expect(&mut self, tick: u64, ids: impl IntoIterator<Item = UavId>) {
        self.open.entry(tick).or_default().waiting.extend(ids);
    }

    /// Agent `id`'s share (if it sends one), command and state of tick `cmd.tick`.
    pub(crate) fn offer(&mut self, id: UavId, share: Option<S>, cmd: Cmd, state: Box<AgentState>) -> Offered<S> {
        let tick = cmd.tick;
        let Some(open) = self.open.get_mut(&tick).filter(|o| o.waiting.contains(&id)) else {
            return Offered::Alone(share, cmd, state);
        };
        open.waiting.remove(&id);
        open.batch.shares.extend(share);
        open.batch.cmds.push(UavCmd { id, cmd });
        open.batch.states.push(*state);
        // A step of `tick` means every earlier tick is over: the hub went on without them.
        let mut done = self.take_before(tick);
        done.extend(self.take_if_complete(tick));
        Offered::Taken(done)
    }

    /// Agent `id` will not step on its frame of `tick`.
    pub(crate) fn skip(&mut self, id: UavId, tick: u64) -> Vec<Batch<S>> {
        let awaited = self.open.get_mut(&tick).is_some_and(|open| open.waiting.remove(&id));
        match awaited {
            true => self.take_if_complete(tick).into_iter().collect(),
            false => Vec::new(),
        }
    }

    /// Agent `id` is gone: no tick waits for it any more.
    pub(crate) fn leave(&mut self, id: UavId) -> Vec<Batch<S>> {
        let ticks: Vec<u64> = self.open.keys().copied().collect();
        ticks.into_iter().flat_map(|tick| self.skip(id, tick)).collect()
    }

    /// The ticks before `tick`, as they are (none, but after a tick timeout: nothing is moved
    /// then, as this runs for every step).
    fn take_before(&mut self, tick: u64) -> Vec<Batch<S>> {
        if self.open.first_key_value().is_none_or(|(&first, _)| first >= tick) {
            return Vec::new();
        }
        let later = self.open.split_off(&tick);
        let earlier = std::mem::replace(&mut self.open, later);
        earlier.into_values().map(|o| o.batch).filter(|b| !b.cmds.is_empty()).collect()
    }

    /// `tick`'s messages, if no step of it is awaited any more.
    fn take_if_complete(&mut self, tick: u64) -> Option<Batch<S>> {
        if self.open.get(&tick)?.waiting.is_empty() {
            self.open.remove(&tick).map(|o| o.batch).filter(|b| !b.cmds.is_empty())
        } else {
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn id(i: u32) -> UavId {
        UavId::new(i)
    }

    fn step(i: u32, tick: u64) -> (UavId, Cmd, Box<AgentState>) {
        let state = AgentState { id: id(i), tick, ..AgentState::default() };
        (id(i), Cmd::hover(tick), Box::new(state))
    }

    /// UAV `i`'s step of `tick`, its share the number 100 i + tick (none for UAV 5).
    fn offer(o: &mut Outbox<u64>, i: u32, tick: u64) -> Offered<u64> {
        let (id, cmd, state) = step(i, tick);
        let share = (i != 5).then_some(100 * u64::from(i) + tick);
        o.offer(id, share, cmd, state)
    }

    fn ids_of<S>(b: &Batch<S>) -> Vec<u32> {
        b.cmds.iter().map(|c| c.id.get()).collect()
    }

    /// A batch's tick, as its commands answer it.
    fn tick_of<S>(b: &Batch<S>) -> u64 {
        b.cmds[0].cmd.tick
    }

    #[test]
    fn a_tick_goes_out_once_its_last_expected_agent_has_stepped() {
        let mut o = Outbox::default();
        o.expect(4, [id(1), id(2), id(5), id(3)]);
        assert_eq!(offer(&mut o, 2, 4), Offered::Taken(vec![]));
        assert_eq!(offer(&mut o, 1, 4), Offered::Taken(vec![]));
        assert_eq!(offer(&mut o, 5, 4), Offered::Taken(vec![]));
        let Offered::Taken(done) = offer(&mut o, 3, 4) else { panic!("expected") };
        assert_eq!(done.len(), 1);
        assert_eq!(ids_of(&done[0]), vec![2, 1, 5, 3], "in the order offered");
        assert_eq!(done[0].shares, vec![204, 104, 304], "the shares held back with them, UAV 5 had none");
        let states: Vec<u32> = done[0].states.iter().map(|s| s.id.get()).collect();
        assert_eq!(states, vec![2, 1, 5, 3]);
        assert!(o.open.is_empty());
    }

    #[test]
    fn a_step_not_awaited_goes_alone() {
        let mut o = Outbox::default();
        o.expect(4, [id(1)]);
        assert!(matches!(offer(&mut o, 2, 4), Offered::Alone(Some(204), ..)), "its frame came alone, its share too");
        assert!(matches!(offer(&mut o, 1, 5), Offered::Alone(..)), "a tick it was not expected in");
        assert_eq!(o.open.len(), 1, "tick 4 still waits for UAV 1");
        assert!(matches!(offer(&mut o, 1, 4), Offered::Taken(ref d) if d.len() == 1));
        assert!(matches!(offer(&mut o, 1, 4), Offered::Alone(..)), "a second answer of the same tick");
    }

    #[test]
    fn an_agent_let_off_no_longer_holds_its_tick() {
        let mut o = Outbox::default();
        o.expect(7, [id(1), id(2), id(3)]);
        assert_eq!(offer(&mut o, 1, 7), Offered::Taken(vec![]));
        assert!(o.skip(id(2), 8).is_empty(), "another tick");
        assert!(o.skip(id(2), 7).is_empty(), "UAV 3 still to come");
        let done = o.leave(id(3));
        assert_eq!(done.iter().map(ids_of).collect::<Vec<_>>(), vec![vec![1]]);
        o.expect(8, [id(4)]);
        assert!(o.leave(id(4)).is_empty(), "a tick with no step sends nothing");
        assert!(o.open.is_empty());
    }

    #[test]
    fn a_later_step_sends_an_earlier_tick_as_it_is() {
        let mut o = Outbox::default();
        o.expect(3, [id(1), id(2)]);
        assert_eq!(offer(&mut o, 1, 3), Offered::Taken(vec![]));
        // The hub timed out waiting for UAV 2 and sent tick 4.
        o.expect(4, [id(1), id(2)]);
        let Offered::Taken(done) = offer(&mut o, 1, 4) else { panic!("expected") };
        assert_eq!(done.iter().map(|b| (tick_of(b), ids_of(b))).collect::<Vec<_>>(), vec![(3, vec![1])]);
        assert_eq!(done[0].shares, vec![103], "an earlier tick's shares go with it");
        assert!(matches!(offer(&mut o, 2, 3), Offered::Alone(Some(203), ..)), "the late step goes alone");
        let Offered::Taken(done) = offer(&mut o, 2, 4) else { panic!("expected") };
        assert_eq!(done.iter().map(|b| (tick_of(b), ids_of(b))).collect::<Vec<_>>(), vec![(4, vec![1, 2])]);
    }
}

//! What the agents of one Zenoh session share: the key expressions they all use, declared once,
//! and one subscription to every UAV's share key that hands each share to the agents listening
//! to its sender.
//!
//! Why: an agent host of hundreds of agents used to hold one share subscription per agent and
//! neighbour (about 9 000 at 1000 UAVs on two hosts). A share arriving from the router on a key
//! the session has not declared is tested against every subscriber of the session, and each
//! declaration or undeclaration walks them all, so the host's cost per share grew with its
//! agents. Here the session subscribes once to `uav/*/share/{pose|obstacles}` and declares every
//! UAV's share key once, before any agent starts: the router then sends each share under the id
//! the session declared, the session finds this one subscriber on that key's resource, and
//! [`ShareFeed`] hands the share to the agents that listen to its sender (a map lookup).
//! It decodes each share once, and only when some agent of the session listens to its sender,
//! and hands every listener the same [`Arc`]: no copy of the payload and no decode per listener
//! (at 40 ICP UAVs a session took about 800 shares per tick, each once per listener). What the
//! listener does with it is unchanged: its own netem link decides, with its own seeded draws.
//! Shares still cross Zenoh: a share of an agent of the same host goes through the session's
//! own routing, never through memory of this crate, and each agent keeps its own netem link and
//! neighbour windows (see [`crate::node`]).
//!
//! Declaring each key once per session, before the agents run, is also what keeps lockstep runs
//! repeatable: Zenoh 1.10's session hands out a key expression's id to a second declaration of
//! the same key before the first has sent its `DeclareKeyExpr` (`declare_prefix` with `force`),
//! and undeclares it when the last holder drops it, so agents declaring and undeclaring the
//! same neighbour's key concurrently could reach the router with a subscriber on an id it did
//! not know yet, and that agent never heard that neighbour. (That is why declared per-agent
//! share subscriptions made runs of 200 UAVs differ.)
//!
//! Listening is plain memory of this process (who wants whose shares), not a Zenoh
//! declaration, so it takes effect at once: an agent that starts listening to a neighbour while
//! handling the radio set of tick k gets every share the neighbour sends from tick k+1 on (the
//! neighbour can only send it after the hub had this agent's command of tick k), which is all
//! the node's window accepts.

use crate::localization::Share;
use crate::node::AgentError;
use std::collections::HashMap;
use std::sync::{Arc, Mutex, PoisonError};
use swarm_config::Scenario;
use swarm_wire::plumbing::Subscription;
use swarm_wire::{Keys, Msg, WireError};
use zenoh::key_expr::KeyExpr;

/// A share as the session received it, decoded once and handed to every agent listening to its
/// sender.
#[derive(Debug, Clone)]
pub(crate) struct Arrived {
    /// The sender's id (from the key).
    pub(crate) from: u32,
    /// The share, `None` when the payload was malformed (every listener counts it so).
    pub(crate) share: Option<Arc<Share>>,
    /// The payload's size on the wire [bytes], for the listener's link.
    pub(crate) len: usize,
}

impl Arrived {
    /// Decodes `bytes`, received on sender `from`'s share key.
    fn decode(from: u32, bytes: &[u8]) -> Arrived {
        let share = match Msg::decode(bytes).map(|m| Share::from_msg(m, from)) {
            Ok(Ok(share)) => Some(Arc::new(share)),
            Ok(Err(other)) => {
                tracing::debug!(from, ?other, "not a share of its sender");
                None
            }
            Err(e) => {
                tracing::debug!(from, error = %e, "undecodable share");
                None
            }
        };
        Arrived { from, share, len: bytes.len() }
    }
}

/// Where the feed leaves an agent's shares, in arrival order, until the agent takes them.
///
/// Posting does not wake the agent: it needs its shares only when the hub's next message comes
/// (see [`crate::node`]), and waking an agent task for each of its about 40 shares per tick
/// cost a context switch each on a loaded host.
#[derive(Clone, Default)]
pub(crate) struct Mailbox(Arc<Mutex<Vec<Arrived>>>);

impl Mailbox {
    fn post(&self, arrived: Arrived) {
        self.0.lock().unwrap_or_else(PoisonError::into_inner).push(arrived);
    }

    /// Moves what was posted into `out` (empty, its buffer is reused), in arrival order.
    pub(crate) fn take_into(&self, out: &mut Vec<Arrived>) {
        debug_assert!(out.is_empty(), "the last take was not drained");
        std::mem::swap(&mut *self.0.lock().unwrap_or_else(PoisonError::into_inner), out);
    }
}

/// Who listens to whom: per sender, the listening agents' ids and their mailboxes.
#[derive(Default)]
struct Listeners {
    by_sender: HashMap<u32, Vec<(u32, Mailbox)>>,
}

/// The shares of every UAV, received once per session and handed to the agents that listen.
pub(crate) struct ShareFeed {
    listeners: Arc<Mutex<Listeners>>,
    /// Whether the localization mode shares at all (`uvdar` does not).
    active: bool,
    _sub: Option<Subscription>,
}

/// An agent listening to one sender's shares; dropping it stops the delivery.
pub(crate) struct Listening {
    listeners: Arc<Mutex<Listeners>>,
    from: u32,
    me: u32,
}

impl Drop for Listening {
    fn drop(&mut self) {
        let mut l = self.listeners.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some(v) = l.by_sender.get_mut(&self.from) {
            v.retain(|(id, _)| *id != self.me);
            if v.is_empty() {
                l.by_sender.remove(&self.from);
            }
        }
    }
}

impl Listeners {
    /// Hands sender `from`'s share to every agent listening to it, decoded once (not at all when
    /// no one listens).
    fn deliver(&self, from: u32, bytes: &[u8]) {
        // A sender's entry goes when its last listener does (see `Listening::drop`).
        let Some(listening) = self.by_sender.get(&from) else { return };
        let arrived = Arrived::decode(from, bytes);
        for (_, mailbox) in listening {
            mailbox.post(arrived.clone());
        }
    }
}

impl ShareFeed {
    /// Subscribes `s` once to `any_key`, every UAV's share key of the mode (`None`: the mode does
    /// not share, nothing is subscribed).
    async fn open(s: &zenoh::Session, keys: &Keys, any_key: Option<String>) -> Result<ShareFeed, WireError> {
        let listeners = Arc::new(Mutex::new(Listeners::default()));
        let Some(any_key) = any_key else {
            return Ok(ShareFeed { listeners, active: false, _sub: None });
        };
        let (l, keys) = (listeners.clone(), keys.clone());
        let sub = s
            .declare_subscriber(any_key)
            .callback(move |sample| {
                let Some(from) = keys.uav_id_of(sample.key_expr().as_str()) else { return };
                // Borrowed when the payload is contiguous (one share is): no copy.
                let bytes = sample.payload().to_bytes();
                l.lock().unwrap_or_else(PoisonError::into_inner).deliver(from, &bytes);
            })
            .await
            .map_err(WireError::zenoh)?;
        Ok(ShareFeed { listeners, active: true, _sub: Some(sub) })
    }

    /// Agent `me` listens to `from`'s shares from now on, posted to `mailbox`, until the returned
    /// guard is dropped; `None` when the mode has no shares.
    pub(crate) fn listen(&self, from: u32, me: u32, mailbox: &Mailbox) -> Option<Listening> {
        if !self.active {
            return None;
        }
        let mut l = self.listeners.lock().unwrap_or_else(PoisonError::into_inner);
        l.by_sender.entry(from).or_default().push((me, mailbox.clone()));
        Some(Listening { listeners: self.listeners.clone(), from, me })
    }
}

/// What every agent of a session uses, made once per session before any agent starts.
pub(crate) struct SessionShared {
    /// The shares, for every agent of the session.
    pub(crate) feed: ShareFeed,
    /// `netem/rules`, declared once (every agent subscribes to it).
    pub(crate) netem_rules: KeyExpr<'static>,
    /// Every UAV's share key, declared once and kept declared for the session's life.
    _share_keys: Vec<KeyExpr<'static>>,
}

impl SessionShared {
    /// Declares the keys and the share subscription of scenario `sc` on `s`.
    pub(crate) async fn open(s: &zenoh::Session, keys: &Keys, sc: &Scenario) -> Result<Arc<SessionShared>, AgentError> {
        let key_of = |id: u32| crate::localization::share_key(sc.localization.mode, keys, id);
        let mut share_keys = Vec::with_capacity(sc.swarm.count as usize);
        for id in 1..=sc.swarm.count {
            if let Some(key) = key_of(id) {
                share_keys.push(s.declare_keyexpr(key).await.map_err(WireError::zenoh)?);
            }
        }
        let netem_rules = s.declare_keyexpr(keys.netem_rules()).await.map_err(WireError::zenoh)?;
        let feed = ShareFeed::open(s, keys, crate::localization::share_key_any(sc.localization.mode, keys)).await?;
        Ok(Arc::new(SessionShared { feed, netem_rules, _share_keys: share_keys }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What `mailbox` holds now, taken.
    fn taken(mailbox: &Mailbox) -> Vec<Arrived> {
        let mut out = Vec::new();
        mailbox.take_into(&mut out);
        out
    }

    #[test]
    fn a_listener_gets_its_senders_shares_until_it_stops() {
        let feed = ShareFeed { listeners: Arc::default(), active: true, _sub: None };
        let mailbox = Mailbox::default();
        let listening = feed.listen(3, 1, &mailbox);
        let deliver = |from: u32| {
            let bytes = Msg::Pose(pose(from)).encode().expect("encode");
            feed.listeners.lock().expect("lock").deliver(from, &bytes);
        };
        deliver(3);
        deliver(4);
        drop(listening);
        deliver(3);
        let got = taken(&mailbox);
        assert_eq!(got.len(), 1, "only sender 3's share, and only while listening");
        assert!(matches!(got[0].share.as_deref(), Some(Share::Pose(p)) if *p == pose(3)), "decoded: {:?}", got[0]);
        assert!(taken(&mailbox).is_empty(), "taking empties the mailbox");
        assert!(feed.listeners.lock().expect("lock").by_sender.is_empty(), "the listener is gone");
        let off = ShareFeed { listeners: Arc::default(), active: false, _sub: None };
        assert!(off.listen(3, 1, &mailbox).is_none(), "a mode without shares has no one to listen to");
    }

    #[test]
    fn every_listener_gets_the_same_decoded_share_and_a_bad_one_as_malformed() {
        let feed = ShareFeed { listeners: Arc::default(), active: true, _sub: None };
        let mailboxes: Vec<Mailbox> = (0..3).map(|_| Mailbox::default()).collect();
        let _l: Vec<Listening> = (1..=3).zip(&mailboxes).map(|(me, m)| feed.listen(7, me, m).expect("listening")).collect();
        let bytes = Msg::Pose(pose(7)).encode().expect("encode");
        feed.listeners.lock().expect("lock").deliver(7, &bytes);
        let lying = Msg::Pose(pose(8)).encode().expect("encode");
        feed.listeners.lock().expect("lock").deliver(7, &lying);
        feed.listeners.lock().expect("lock").deliver(7, &[0xff, 0xff]);
        let got: Vec<Vec<Arrived>> = mailboxes.iter().map(taken).collect();
        assert!(got.iter().all(|g| g.len() == 3), "each listener gets all three: {got:?}");
        let first = got[0][0].share.clone().expect("a good share");
        assert!(got.iter().all(|g| g[0].share.as_ref().is_some_and(|s| Arc::ptr_eq(s, &first)) && g[0].len == bytes.len()), "one decode, shared");
        assert!(got.iter().all(|g| g[1..].iter().all(|a| a.share.is_none() && a.from == 7)), "a share whose sender is not its key's, or garbage, is malformed for each");
    }

    fn pose(from: u32) -> swarm_wire::PoseShare {
        swarm_wire::PoseShare { from, tick: 4, t_secs: 0.4, x: 1.0, y: 2.0, yaw: 0.3, vx: 0.1, vy: 0.0 }
    }
}

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
//! [`ShareFeed`] hands the payload to the agents that listen to its sender (a map lookup).
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

use crate::node::AgentError;
use std::collections::HashMap;
use std::sync::{Arc, Mutex, PoisonError};
use swarm_config::Scenario;
use swarm_wire::plumbing::{self, Subscription};
use swarm_wire::{Keys, WireError};
use zenoh::key_expr::KeyExpr;

/// Where a listening agent wants a share: called with the sender's id and the raw payload.
type Deliver = Box<dyn Fn(u32, Vec<u8>) + Send + Sync>;

/// Who listens to whom: per sender, the listening agents' ids and their delivery.
#[derive(Default)]
struct Listeners {
    by_sender: HashMap<u32, Vec<(u32, Deliver)>>,
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
    /// Hands sender `from`'s share to every agent listening to it.
    fn deliver(&self, from: u32, bytes: &[u8]) {
        for (_, deliver) in self.by_sender.get(&from).into_iter().flatten() {
            deliver(from, bytes.to_vec());
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
                let bytes = plumbing::payload(&sample);
                l.lock().unwrap_or_else(PoisonError::into_inner).deliver(from, &bytes);
            })
            .await
            .map_err(WireError::zenoh)?;
        Ok(ShareFeed { listeners, active: true, _sub: Some(sub) })
    }

    /// Agent `me` listens to `from`'s shares from now on, until the returned guard is dropped;
    /// `None` when the mode has no shares.
    pub(crate) fn listen(&self, from: u32, me: u32, deliver: impl Fn(u32, Vec<u8>) + Send + Sync + 'static) -> Option<Listening> {
        if !self.active {
            return None;
        }
        let mut l = self.listeners.lock().unwrap_or_else(PoisonError::into_inner);
        l.by_sender.entry(from).or_default().push((me, Box::new(deliver)));
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

    #[test]
    fn a_listener_gets_its_senders_shares_until_it_stops() {
        let feed = ShareFeed { listeners: Arc::default(), active: true, _sub: None };
        let got = Arc::new(Mutex::new(Vec::new()));
        let g = got.clone();
        let listening = feed.listen(3, 1, move |from, b| g.lock().expect("lock").push((from, b)));
        let deliver = |from: u32| feed.listeners.lock().expect("lock").deliver(from, &[from as u8]);
        deliver(3);
        deliver(4);
        drop(listening);
        deliver(3);
        assert_eq!(*got.lock().expect("lock"), vec![(3, vec![3])], "only sender 3's share, and only while listening");
        assert!(feed.listeners.lock().expect("lock").by_sender.is_empty(), "the listener is gone");
        let off = ShareFeed { listeners: Arc::default(), active: false, _sub: None };
        assert!(off.listen(3, 1, |_, _| {}).is_none(), "a mode without shares has no one to listen to");
    }
}

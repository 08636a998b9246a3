//! The shares an agent session receives: one Zenoh subscription per sender that some agent of
//! the session listens to, declared when the first of them starts listening and undeclared when
//! the last one stops. A session's subscriptions are thus the union of its agents' radio sets,
//! and the router sends it the shares of those UAVs and no others: traffic grows with the
//! neighbours, not with the swarm.
//!
//! Why one subscription per sender and session, counted, rather than one per agent and
//! neighbour: an agent host of hundreds of agents would hold thousands, and Zenoh 1.10's session
//! does not order two declarations of the same key made concurrently (it hands a key
//! expression's id to the second before the first has sent its `DeclareKeyExpr`, so the router
//! could see a subscriber on an id it did not know yet, and an agent never hear that
//! neighbour). Here every declaration of the session's share keys is made under one lock
//! ([`Declared`]): each sender's key expression is declared once, the first time the session
//! needs it (to listen to the sender, or to publish its own shares), and kept for the session's
//! life, and its subscription is declared on that expression, so the router sends each share
//! under the session's id for it and the session finds its one subscriber at once. The
//! subscription's callback decodes a share once and posts the same [`Arc`] to the mailboxes of
//! the agents listening to its sender, without waking them (each takes its mailbox when it
//! handles the hub's next message, see [`crate::net::node`]).
//!
//! Ordering: an agent starts listening while it handles the radio set of tick k. Zenoh sends the
//! declaration at its control priority, and a link's sender always takes the control queue before
//! the data queue, so the declaration leaves the session before anything put after it was queued
//! and before the agent's command of tick k+1 at the latest (that command is put only after the
//! hub had the one of tick k, which may have left first). Each router handles a link's messages
//! in order, so it holds the subscription (and has passed it on along a mesh of routers) before
//! it hands that command to the hub; and the sender publishes its share of tick k+2 only after
//! the hub had every command of tick k+1 (the sender's session sends every put to its router,
//! which routes it by the subscriptions it holds). So the first share that counts, the one of tick
//! k+2 (see [`crate::admission`]), always finds the subscription in place, as long as the hub
//! waits for each command: a tick that runs into `tick_timeout_ms`, or an agent that lost its
//! liveliness token, lets the hub go on without it, and lockstep runs then differ anyway.
//!
//! The declarations are blocking Zenoh calls made on the agent's task while the lock is held:
//! each takes microseconds, and a session whose link stalls stalls its agents either way.
//!
//! The session also counts what it receives ([`SessionCounts`]): every sample of its share
//! subscriptions, and, through [`SessionCounts::count`], the node's own sensor subscriptions.

use super::AgentError;
use crate::admission::Arrived;
use crate::localization::Share;
use std::collections::HashMap;
use std::sync::atomic::{AtomicU32, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use swarm_config::{LocalizationMode, Scenario};
use swarm_types::UavId;
use swarm_wire::plumbing::Subscription;
use swarm_wire::{Keys, Msg, Traffic, WireError};
use zenoh::key_expr::KeyExpr;
use zenoh::Wait;

impl Arrived {
    /// Decodes `bytes`, received on sender `from`'s share key.
    fn decode(from: UavId, bytes: &[u8]) -> Arrived {
        let share = match Msg::decode(bytes).map(|m| Share::from_msg(m, from)) {
            Ok(Ok(share)) => Some(Arc::new(share)),
            Ok(Err(other)) => {
                tracing::debug!(%from, ?other, "not a share of its sender");
                None
            }
            Err(e) => {
                tracing::debug!(%from, error = %e, "undecodable share");
                None
            }
        };
        Arrived { from, share, len: bytes.len() }
    }
}

/// Where the feed leaves an agent's shares, in arrival order, until the agent takes them.
///
/// Posting does not wake the agent: it needs its shares only when the hub's next message comes
/// (see [`crate::net::node`]), and waking an agent task for each of its about 40 shares per
/// tick cost a context switch each on a loaded host.
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

/// What the session received since it opened, counted by its subscriptions' callbacks.
#[derive(Debug, Default)]
pub(crate) struct SessionCounts {
    shares: AtomicU64,
    share_bytes: AtomicU64,
    bytes: AtomicU64,
    agents: AtomicU32,
    subscriptions: AtomicU32,
    remote_shares: AtomicU64,
    remote_share_bytes: AtomicU64,
    remote_share_gaps: AtomicU64,
}

impl SessionCounts {
    /// Counts a sample of `len` payload bytes on any of the session's subscriptions.
    pub(crate) fn count(&self, len: usize) {
        self.bytes.fetch_add(len as u64, Ordering::Relaxed);
    }

    /// Counts a share of `len` payload bytes, `remote` when its sender flies on another session.
    fn count_share(&self, len: usize, remote: bool) {
        self.shares.fetch_add(1, Ordering::Relaxed);
        self.share_bytes.fetch_add(len as u64, Ordering::Relaxed);
        if remote {
            self.remote_shares.fetch_add(1, Ordering::Relaxed);
            self.remote_share_bytes.fetch_add(len as u64, Ordering::Relaxed);
        }
        self.count(len);
    }

    /// Counts `n` shares of a remote sender that never came between two that did.
    fn count_gaps(&self, n: u64) {
        if n > 0 {
            self.remote_share_gaps.fetch_add(n, Ordering::Relaxed);
        }
    }

    /// An agent started (`true`) or stopped flying on the session.
    pub(crate) fn agent(&self, flying: bool) {
        if flying {
            self.agents.fetch_add(1, Ordering::Relaxed);
        } else {
            self.agents.fetch_sub(1, Ordering::Relaxed);
        }
    }

    /// The counts now, for session `session` (its Zenoh id), with an agent's own `(shares,
    /// bytes)`.
    pub(crate) fn snapshot(&self, session: &str, agent: (u64, u64)) -> Traffic {
        Traffic {
            agent_shares: agent.0,
            agent_bytes: agent.1,
            session: session.to_string(),
            agents: self.agents.load(Ordering::Relaxed),
            shares: self.shares.load(Ordering::Relaxed),
            share_bytes: self.share_bytes.load(Ordering::Relaxed),
            bytes: self.bytes.load(Ordering::Relaxed),
            subscriptions: self.subscriptions.load(Ordering::Relaxed),
            remote_shares: self.remote_shares.load(Ordering::Relaxed),
            remote_share_bytes: self.remote_share_bytes.load(Ordering::Relaxed),
            remote_share_gaps: self.remote_share_gaps.load(Ordering::Relaxed),
        }
    }
}

/// Who listens to whom: per sender, the listening agents' ids and their mailboxes. The
/// subscriptions' callbacks read it; no Zenoh call is ever made while it is locked.
#[derive(Default)]
struct Listeners {
    by_sender: HashMap<UavId, Vec<(UavId, Mailbox)>>,
}

impl Listeners {
    /// Agent `me` no longer listens to `from` (a sender's entry goes with its last listener).
    fn remove(&mut self, from: UavId, me: UavId) {
        if let Some(v) = self.by_sender.get_mut(&from) {
            v.retain(|(id, _)| *id != me);
            if v.is_empty() {
                self.by_sender.remove(&from);
            }
        }
    }

    /// Hands sender `from`'s share to every agent listening to it, decoded once (not at all when
    /// no one listens); returns the tick it was sent at, when it decoded.
    fn deliver(&self, from: UavId, bytes: &[u8]) -> Option<u64> {
        let listening = self.by_sender.get(&from)?;
        let arrived = Arrived::decode(from, bytes);
        let tick = arrived.share.as_ref().map(|s| s.tick());
        for (_, mailbox) in listening {
            mailbox.post(arrived.clone());
        }
        tick
    }
}

/// The ticks of one sender's shares as one subscription receives them: how many never came
/// between two that did. A flying sender shares once per tick, so a gap is a share the network
/// (a writer's congestion policy, a mailbox, a relay) or the sender (a tick it did not step, a
/// share its netem dropped) lost. Out of order, a late share fills no gap and opens none.
#[derive(Debug, Default)]
struct Sequence {
    /// One past the latest tick received; 0 before the first.
    next: AtomicU64,
}

impl Sequence {
    /// The shares skipped before this one, sent at `tick`.
    fn gaps(&self, tick: u64) -> u64 {
        match self.next.fetch_max(tick + 1, Ordering::Relaxed) {
            0 => 0,
            next => tick.saturating_sub(next),
        }
    }
}

/// Every declaration the session makes on share keys, made under this one lock.
#[derive(Default)]
struct Declared {
    /// Each UAV's share key, declared the first time the session needed it, kept for its life.
    keys: HashMap<UavId, KeyExpr<'static>>,
    /// Per sender listened to: the subscription and how many of the session's agents listen.
    subs: HashMap<UavId, (Subscription, usize)>,
}

/// What the feed's handles share.
struct Inner {
    session: zenoh::Session,
    keys: Keys,
    mode: LocalizationMode,
    /// The UAVs this session flies: their shares reach it without crossing the network.
    local: Vec<UavId>,
    listeners: Arc<Mutex<Listeners>>,
    declared: Mutex<Declared>,
    traffic: Arc<SessionCounts>,
}

/// The shares of the UAVs the session's agents listen to, received once per session and handed
/// to the agents that listen.
#[derive(Clone)]
pub(crate) struct ShareFeed(Arc<Inner>);

/// An agent listening to one sender's shares; dropping it stops the delivery (and the session's
/// subscription, when it was the last listener).
pub(crate) struct Listening {
    feed: ShareFeed,
    from: UavId,
    me: UavId,
}

impl Drop for Listening {
    fn drop(&mut self) {
        let inner = &self.feed.0;
        inner.listeners.lock().unwrap_or_else(PoisonError::into_inner).remove(self.from, self.me);
        let mut d = inner.declared.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some((_, count)) = d.subs.get_mut(&self.from) {
            *count -= 1;
            if *count == 0 {
                // Dropping the subscriber undeclares it.
                d.subs.remove(&self.from);
                inner.traffic.subscriptions.fetch_sub(1, Ordering::Relaxed);
            }
        }
    }
}

impl ShareFeed {
    /// The feed of session `s`, which flies the UAVs `local`, for scenario `sc`'s localization
    /// mode.
    pub(crate) fn new(s: &zenoh::Session, keys: &Keys, sc: &Scenario, local: &[UavId]) -> ShareFeed {
        ShareFeed(Arc::new(Inner {
            session: s.clone(),
            keys: keys.clone(),
            mode: sc.localization.mode,
            local: local.to_vec(),
            listeners: Arc::default(),
            declared: Mutex::default(),
            traffic: Arc::default(),
        }))
    }

    /// What the session received.
    pub(crate) fn traffic(&self) -> &Arc<SessionCounts> {
        &self.0.traffic
    }

    /// UAV `id`'s share key, declared on the session (once for its life); `None` when the mode
    /// has no shares.
    pub(crate) fn key(&self, id: UavId) -> Result<Option<KeyExpr<'static>>, AgentError> {
        let mut d = self.0.declared.lock().unwrap_or_else(PoisonError::into_inner);
        self.key_locked(&mut d, id)
    }

    fn key_locked(&self, d: &mut Declared, id: UavId) -> Result<Option<KeyExpr<'static>>, AgentError> {
        if let Some(k) = d.keys.get(&id) {
            return Ok(Some(k.clone()));
        }
        let Some(key) = self.0.keys.share_of(self.0.mode, id) else { return Ok(None) };
        let declared = self.0.session.declare_keyexpr(key).wait().map_err(WireError::zenoh)?;
        d.keys.insert(id, declared.clone());
        Ok(Some(declared))
    }

    /// Agent `me` listens to `from`'s shares from now on, posted to `mailbox`, until the returned
    /// guard is dropped; `None` when the mode has no shares. The session's subscription to
    /// `from` is declared before this returns (when it is the first listener).
    pub(crate) fn listen(&self, from: UavId, me: UavId, mailbox: &Mailbox) -> Result<Option<Listening>, AgentError> {
        let inner = &self.0;
        let mut d = inner.declared.lock().unwrap_or_else(PoisonError::into_inner);
        let Some(key) = self.key_locked(&mut d, from)? else { return Ok(None) };
        // The listener first: a share that arrives as soon as the subscription exists finds it.
        inner
            .listeners
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .by_sender
            .entry(from)
            .or_default()
            .push((me, mailbox.clone()));
        if let Some((_, count)) = d.subs.get_mut(&from) {
            *count += 1;
            return Ok(Some(Listening { feed: self.clone(), from, me }));
        }
        let (l, traffic, remote) = (inner.listeners.clone(), inner.traffic.clone(), !inner.local.contains(&from));
        let sequence = Sequence::default();
        let declared = inner.session.declare_subscriber(key).callback(move |sample| {
            // Borrowed when the payload is contiguous (one share is): no copy.
            let bytes = sample.payload().to_bytes();
            traffic.count_share(bytes.len(), remote);
            let tick = l.lock().unwrap_or_else(PoisonError::into_inner).deliver(from, &bytes);
            if let Some(tick) = tick.filter(|_| remote) {
                traffic.count_gaps(sequence.gaps(tick));
            }
        });
        match declared.wait() {
            Ok(sub) => {
                d.subs.insert(from, (sub, 1));
                inner.traffic.subscriptions.fetch_add(1, Ordering::Relaxed);
                Ok(Some(Listening { feed: self.clone(), from, me }))
            }
            Err(e) => {
                // Undone under the same lock, so no other agent's count is touched.
                inner.listeners.lock().unwrap_or_else(PoisonError::into_inner).remove(from, me);
                Err(WireError::zenoh(e).into())
            }
        }
    }
}

/// What every agent of a session uses, made once per session before any agent starts.
pub(crate) struct SessionShared {
    /// The shares, for every agent of the session.
    pub(crate) feed: ShareFeed,
    /// `netem/rules`, declared once (every agent subscribes to it).
    pub(crate) netem_rules: KeyExpr<'static>,
    /// The session's Zenoh id, as the router's admin space names it.
    pub(crate) zid: String,
    /// An agent host's frames in one message a tick (`None`: a one-agent process, whose frames
    /// come on its own key).
    pub(crate) frames: Option<Arc<super::frames::HostFrames>>,
}

impl SessionShared {
    /// Declares the keys every agent of session `s` uses, for scenario `sc`; the session flies
    /// the UAVs `ids`, as an agent host (taking their frames in one message) when `host`.
    pub(crate) async fn open(
        s: &zenoh::Session,
        keys: &Keys,
        sc: &Scenario,
        ids: &[UavId],
        host: bool,
    ) -> Result<Arc<SessionShared>, AgentError> {
        let netem_rules = s.declare_keyexpr(keys.netem_rules()).await.map_err(WireError::zenoh)?;
        let feed = ShareFeed::new(s, keys, sc, ids);
        let frames = match host {
            true => {
                let traffic = feed.traffic().clone();
                Some(Arc::new(super::frames::HostFrames::open(s, keys, sc, ids, move |len| traffic.count(len)).await?))
            }
            false => None,
        };
        Ok(Arc::new(SessionShared { feed, netem_rules, zid: s.zid().to_string(), frames }))
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

    fn listeners(pairs: &[(UavId, UavId, &Mailbox)]) -> Listeners {
        let mut l = Listeners::default();
        for &(from, me, mailbox) in pairs {
            l.by_sender.entry(from).or_default().push((me, mailbox.clone()));
        }
        l
    }

    #[test]
    fn a_listener_gets_only_its_senders_shares() {
        let mailbox = Mailbox::default();
        let l = listeners(&[(UavId::new(3), UavId::new(1), &mailbox)]);
        l.deliver(UavId::new(3), &Msg::Pose(pose(UavId::new(3))).encode().expect("encode"));
        l.deliver(UavId::new(4), &Msg::Pose(pose(UavId::new(4))).encode().expect("encode"));
        let got = taken(&mailbox);
        assert_eq!(got.len(), 1, "only sender 3's share");
        assert!(
            matches!(got[0].share.as_deref(), Some(Share::Pose(p)) if *p == pose(UavId::new(3))),
            "decoded: {:?}",
            got[0]
        );
        assert!(taken(&mailbox).is_empty(), "taking empties the mailbox");
    }

    #[test]
    fn every_listener_gets_the_same_decoded_share_and_a_bad_one_as_malformed() {
        let mailboxes: Vec<Mailbox> = (0..3).map(|_| Mailbox::default()).collect();
        let l = listeners(&[
            (UavId::new(7), UavId::new(1), &mailboxes[0]),
            (UavId::new(7), UavId::new(2), &mailboxes[1]),
            (UavId::new(7), UavId::new(3), &mailboxes[2]),
        ]);
        let bytes = Msg::Pose(pose(UavId::new(7))).encode().expect("encode");
        l.deliver(UavId::new(7), &bytes);
        l.deliver(UavId::new(7), &Msg::Pose(pose(UavId::new(8))).encode().expect("encode"));
        l.deliver(UavId::new(7), &[0xff, 0xff]);
        let got: Vec<Vec<Arrived>> = mailboxes.iter().map(taken).collect();
        assert!(got.iter().all(|g| g.len() == 3), "each listener gets all three: {got:?}");
        let first = got[0][0].share.clone().expect("a good share");
        assert!(
            got.iter().all(|g| g[0].share.as_ref().is_some_and(|s| Arc::ptr_eq(s, &first)) && g[0].len == bytes.len()),
            "one decode, shared"
        );
        assert!(
            got.iter().all(|g| g[1..].iter().all(|a| a.share.is_none() && a.from == UavId::new(7))),
            "a share whose sender is not its key's, or garbage, is malformed for each"
        );
    }

    #[test]
    fn traffic_counts_shares_apart_from_other_samples() {
        let t = SessionCounts::default();
        t.count_share(40, true);
        t.count_share(30, false);
        t.count(100);
        t.agent(true);
        t.agent(true);
        t.agent(false);
        let s = t.snapshot("ab", (4, 500));
        assert_eq!((s.shares, s.share_bytes, s.bytes, s.agents, s.session.as_str()), (2, 70, 170, 1, "ab"));
        assert_eq!((s.remote_shares, s.remote_share_bytes), (1, 40), "the local share crossed no network");
        assert_eq!((s.agent_shares, s.agent_bytes), (4, 500), "the agent's own counts, as given");
        t.count_gaps(0);
        t.count_gaps(3);
        assert_eq!(t.snapshot("ab", (0, 0)).remote_share_gaps, 3);
    }

    #[test]
    fn a_sequence_counts_the_shares_between_two_that_came() {
        let s = Sequence::default();
        assert_eq!(s.gaps(10), 0, "the first share opens the sequence");
        assert_eq!(s.gaps(11), 0, "the next tick");
        assert_eq!(s.gaps(14), 2, "12 and 13 never came");
        assert_eq!(s.gaps(12), 0, "a late one fills nothing");
        assert_eq!(s.gaps(15), 0, "and opens nothing");
        assert_eq!(s.gaps(15), 0, "a duplicate neither");
    }

    /// A Zenoh router in this process and a client session of it, as an agent host has.
    async fn router_and_client() -> (zenoh::Session, zenoh::Session) {
        use swarm_wire::session::{self, Role};
        let router = session::open(Role::Router, &["tcp/127.0.0.1:0".to_string()], &[], &[]).await.expect("router");
        let at = session::locators(&router).await;
        let client = session::open(Role::Client, &[], &at, &[]).await.expect("client");
        (router, client)
    }

    /// Waits (at most `tries` x 10 ms) until `mailbox` has received `n` shares sent at `tick`
    /// (any tick: `None`), and takes them; shares of other ticks are taken and left out.
    async fn wait_for(mailbox: &Mailbox, tick: Option<u64>, n: usize, tries: u32) -> Vec<Arrived> {
        let mut got = Vec::new();
        for _ in 0..tries {
            let mut more = Vec::new();
            mailbox.take_into(&mut more);
            got.extend(more.into_iter().filter(|a| tick.is_none() || a.share.as_ref().map(|s| s.tick()) == tick));
            if got.len() >= n {
                break;
            }
            tokio::time::sleep(std::time::Duration::from_millis(10)).await;
        }
        got
    }

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_session_subscribes_once_per_sender_while_any_of_its_agents_listens() {
        let (router, client) = router_and_client().await;
        let keys = Keys::new("feedtest").expect("run id");
        let sc = swarm_config::builtin("open-field-5").expect("builtin");
        let feed = ShareFeed::new(&client, &keys, &sc, &[UavId::new(1), UavId::new(2)]);
        let (m1, m2) = (Mailbox::default(), Mailbox::default());
        let a = feed.listen(UavId::new(3), UavId::new(1), &m1).expect("declared").expect("broadcast shares");
        let b = feed.listen(UavId::new(3), UavId::new(2), &m2).expect("declared").expect("broadcast shares");
        let c = feed.listen(UavId::new(4), UavId::new(1), &m1).expect("declared").expect("broadcast shares");
        let subs = || feed.traffic().snapshot("s", (0, 0)).subscriptions;
        assert_eq!(subs(), 2, "one subscription per sender, however many agents listen");
        let put = |from: UavId, tick: u64| {
            let bytes = Msg::Pose(swarm_wire::PoseShare { tick, ..pose(from) }).encode().expect("encode");
            router.put(keys.share_pose(from), bytes).wait().expect("put");
        };
        // The router has the client's subscriptions once it has handled their declarations,
        // which this test cannot see: put until a share of each sender arrives, then count only
        // tick 100's.
        for from in [UavId::new(3), UavId::new(4)] {
            for _ in 0..500 {
                put(from, 0);
                if !wait_for(&m1, None, 1, 5).await.is_empty() {
                    break;
                }
            }
        }
        put(UavId::new(3), 100);
        put(UavId::new(4), 100);
        let (one, two) = (wait_for(&m1, Some(100), 2, 500).await, wait_for(&m2, Some(100), 1, 500).await);
        assert_eq!(
            one.iter().map(|a| a.from).collect::<Vec<_>>(),
            [UavId::new(3), UavId::new(4)],
            "agent 1 hears 3 and 4"
        );
        assert_eq!(two.iter().map(|a| a.from).collect::<Vec<_>>(), [UavId::new(3)], "agent 2 hears 3 only");
        assert!(
            Arc::ptr_eq(one[0].share.as_ref().expect("share"), two[0].share.as_ref().expect("share")),
            "decoded once for both"
        );
        drop(a);
        assert_eq!(subs(), 2, "agent 2 still listens to 3");
        drop(b);
        assert_eq!(subs(), 1, "nobody listens to 3: its subscription is gone");
        drop(c);
        assert_eq!(subs(), 0);
        put(UavId::new(3), 200);
        put(UavId::new(4), 200);
        assert!(
            wait_for(&m1, Some(200), 1, 30).await.is_empty() && wait_for(&m2, Some(200), 1, 1).await.is_empty(),
            "nobody hears anything any more"
        );
        let t = feed.traffic().snapshot("s", (0, 0));
        assert!(t.shares >= 3 && t.remote_shares == t.shares, "3 and 4 fly on other sessions: {t:?}");
        let _ = client.close().await;
        let _ = router.close().await;
    }

    fn pose(from: UavId) -> swarm_wire::PoseShare {
        swarm_wire::PoseShare {
            from,
            tick: 4,
            t_s: 0.4,
            x: 1.0,
            y: 2.0,
            yaw: 0.3,
            vx: 0.1,
            vy: 0.0,
            hops: 0,
            arrival: 0,
        }
    }
}

//! An agent host's side of its one message a tick each way.
//!
//! In: the session subscribes to `host/{ids}/sense` once, and hands each frame of the hub's
//! `Msg::Senses` to its agent's channel, where a frame on the agent's own `uav/{id}/sense` would
//! have gone. Out, in a lockstep run: the agents' commands and states of a tick go as one
//! `Msg::Cmds` on `host/{ids}/cmd` and one `Msg::States` on `host/{ids}/state` once every agent
//! that took its frame from the host's message has stepped, each agent's share of the tick put
//! on its own key just before them ([`crate::outbox`]).
//!
//! Why: a frame, a command and a state a UAV cost a put, a route and a delivery each; at 500
//! agents a host that is 1500 of each a tick, three here. What the agents see does not
//! change: each frame is the one the hub would have sent alone, handed over in the same Zenoh
//! callback order as the netem rules (the agents' one channel keeps wire order), and the host
//! declares `alive/host/{ids}` only once it is subscribed, so the hub batches only to a host
//! that takes the batch. The agents keep their own `uav/{id}/sense` subscriptions, so a frame
//! the hub sends alone (before it saw the token, or to a host it does not batch to) still
//! arrives; the hub sends each frame one way only. What the hub and the recorder take does not
//! change either: each command and state is the one the agent would have put alone, and a step
//! the host's message does not wait for (a frame that came alone, an external controller's, a
//! realtime run's) is put alone.

use super::AgentError;
use crate::outbox::{Batch, Offered, Outbox};
use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use swarm_config::{Scenario, TimeMode};
use swarm_types::UavId;
use swarm_wire::session::Writer;
use swarm_wire::{plumbing, AgentState, Cmd, Keys, Msg, WireError};
use tokio::sync::mpsc;
use tracing::{debug, warn};
use zenoh::qos::CongestionControl;

/// Where one agent's frames go: its node's channel (`None`: malformed) and its byte count;
/// whether the host's messages wait for its steps.
struct Inbox {
    tx: mpsc::UnboundedSender<Option<Msg>>,
    own_bytes: Arc<AtomicU64>,
    awaited: bool,
}

/// A share held back for the host's messages of its tick: its agent's writer and bytes.
pub(crate) type HeldShare = (Arc<Writer>, Vec<u8>);

/// The host's shares, commands and states out, in a lockstep run.
struct Out {
    outbox: Mutex<Outbox<HeldShare>>,
    cmds: Writer,
    states: Writer,
}

/// The agents of the host that take frames now, by UAV.
type Inboxes = Arc<Mutex<HashMap<UavId, Inbox>>>;

/// The host's subscription to its frames and its token, and the agents' inboxes.
pub(crate) struct HostFrames {
    inboxes: Inboxes,
    /// `None` in a realtime run: each agent's command goes alone the moment it has it, so one
    /// slow agent never holds back the host's others.
    out: Option<Arc<Out>>,
    _sub: plumbing::Subscription,
    _token: zenoh::liveliness::LivelinessToken,
}

impl HostFrames {
    /// Subscribes session `s` to the frames of `ids` (their host key) and then declares the
    /// host's token; in a lockstep run of `sc`, makes the writers of its commands and states.
    /// `count(len)` counts each message's bytes in the session's traffic.
    pub(crate) async fn open(
        s: &zenoh::Session,
        keys: &Keys,
        sc: &Scenario,
        ids: &[UavId],
        count: impl Fn(usize) + Send + Sync + 'static,
    ) -> Result<HostFrames, AgentError> {
        let mut ascending = ids.to_vec();
        ascending.sort_unstable();
        let out = match sc.time.mode {
            TimeMode::Lockstep => Some(Arc::new(Out {
                outbox: Mutex::default(),
                cmds: Writer::new(s, keys.host_cmd(&ascending), CongestionControl::Block).await?,
                states: Writer::new(s, keys.host_state(&ascending), CongestionControl::Block).await?,
            })),
            TimeMode::Realtime => None,
        };
        let inboxes: Inboxes = Arc::default();
        let (to, expect) = (inboxes.clone(), out.clone());
        let sub = s
            .declare_subscriber(keys.host_sense(&ascending))
            .callback(move |sample| {
                let len = sample.payload().len();
                count(len);
                deliver(&to, expect.as_deref().map(|o| &o.outbox), plumbing::decode(&sample), len);
            })
            .await
            .map_err(WireError::zenoh)?;
        let token = s.liveliness().declare_token(keys.alive_host(&ascending)).await.map_err(WireError::zenoh)?;
        Ok(HostFrames { inboxes, out, _sub: sub, _token: token })
    }

    /// Hands UAV `id`'s frames to `tx` (counting their bytes in `own_bytes`) until the returned
    /// guard is dropped; the host's messages wait for its steps when `awaited`.
    pub(crate) fn register(
        self: &Arc<Self>,
        id: UavId,
        tx: mpsc::UnboundedSender<Option<Msg>>,
        own_bytes: Arc<AtomicU64>,
        awaited: bool,
    ) -> Registered {
        self.inboxes.lock().unwrap_or_else(PoisonError::into_inner).insert(id, Inbox { tx, own_bytes, awaited });
        Registered { frames: self.clone(), id }
    }

    /// Agent `id`'s share (if it sends one), command and state of a step: taken into the host's
    /// messages (and those now complete put), or handed back to be put alone.
    pub(crate) async fn offer(
        &self,
        id: UavId,
        share: Option<HeldShare>,
        cmd: Cmd,
        state: Box<AgentState>,
    ) -> Result<Option<Alone>, AgentError> {
        let Some(out) = &self.out else { return Ok(Some((share, cmd, state))) };
        let offered = out.outbox.lock().unwrap_or_else(PoisonError::into_inner).offer(id, share, cmd, state);
        match offered {
            Offered::Alone(share, cmd, state) => Ok(Some((share, cmd, state))),
            Offered::Taken(done) => {
                out.put(done).await?;
                Ok(None)
            }
        }
    }

    /// Agent `id` will not step on its frame of `tick` (it was malformed).
    pub(crate) async fn skip(&self, id: UavId, tick: u64) -> Result<(), AgentError> {
        let Some(out) = &self.out else { return Ok(()) };
        let done = out.outbox.lock().unwrap_or_else(PoisonError::into_inner).skip(id, tick);
        out.put(done).await
    }
}

/// A step the host's messages do not take: its share, command and state, to put alone.
pub(crate) type Alone = (Option<HeldShare>, Cmd, Box<AgentState>);

impl Out {
    /// Puts each complete tick's shares (each on its sender's key), then its commands, then its
    /// states.
    async fn put(&self, done: Vec<Batch<HeldShare>>) -> Result<(), AgentError> {
        for b in done {
            for (writer, bytes) in b.shares {
                writer.put(bytes).await?;
            }
            self.cmds.put(Msg::Cmds(b.cmds).encode()?).await?;
            self.states.put(Msg::States(b.states).encode()?).await?;
        }
        Ok(())
    }
}

/// Hands each frame of a decoded host message to its agent as a `Msg::Sense`, each counted
/// with an even part of the message's `len` bytes, and has `outbox` (a lockstep run's) await the
/// steps of the agents whose steps it waits for. A frame for an agent not taking frames (not
/// started, ended) is dropped; a malformed message reaches every agent as one malformed
/// message, as a malformed frame of its own would.
fn deliver(
    inboxes: &Mutex<HashMap<UavId, Inbox>>,
    outbox: Option<&Mutex<Outbox<HeldShare>>>,
    msg: Result<Msg, WireError>,
    len: usize,
) {
    let inboxes = inboxes.lock().unwrap_or_else(PoisonError::into_inner);
    match msg {
        Ok(Msg::Senses(frames)) => {
            // Awaited before any agent has its frame, so none can step before its tick waits.
            if let (Some(outbox), Some(first)) = (outbox, frames.first()) {
                let awaited = frames.iter().filter(|u| inboxes.get(&u.id).is_some_and(|i| i.awaited)).map(|u| u.id);
                outbox.lock().unwrap_or_else(PoisonError::into_inner).expect(first.frame.radio.tick, awaited);
            }
            let each = (len / frames.len().max(1)) as u64;
            for u in frames {
                match inboxes.get(&u.id) {
                    Some(inbox) => {
                        inbox.own_bytes.fetch_add(each, Ordering::Relaxed);
                        let _ = inbox.tx.send(Some(Msg::Sense(Box::new(u.frame))));
                    }
                    None => debug!(uav_id = %u.id, "a frame for an agent not flying here dropped"),
                }
            }
        }
        _ => {
            for inbox in inboxes.values() {
                let _ = inbox.tx.send(None);
            }
        }
    }
}

/// An agent taking its host's frames; dropping it stops them.
pub(crate) struct Registered {
    frames: Arc<HostFrames>,
    id: UavId,
}

impl Drop for Registered {
    fn drop(&mut self) {
        self.frames.inboxes.lock().unwrap_or_else(PoisonError::into_inner).remove(&self.id);
        // The ticks that waited for it go out without it.
        let Some(out) = self.frames.out.clone() else { return };
        let done = out.outbox.lock().unwrap_or_else(PoisonError::into_inner).leave(self.id);
        if done.is_empty() {
            return;
        }
        match tokio::runtime::Handle::try_current() {
            Ok(rt) => {
                rt.spawn(async move {
                    if let Err(e) = out.put(done).await {
                        warn!("the host's commands without a departed agent were not sent: {e}");
                    }
                });
            }
            Err(_) => warn!(uav_id = %self.id, "no runtime to send the host's commands without a departed agent"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use swarm_wire::msg::{Odom, RadioSet, Scan, SenseFrame, UavSense};

    fn frame(id: u32) -> SenseFrame {
        let tick = 3;
        SenseFrame {
            radio: RadioSet { tick, id: UavId::new(id), in_range: vec![], loss: vec![] },
            odom: Odom { tick, t_s: 0.3, x: 0.0, y: 0.0, yaw: 0.0, vx: 0.0, vy: 0.0, goal: None, goal_vel: None },
            gnss: None,
            uvdar: None,
            scan: Scan { tick, t_s: 0.3, angle_min: 0.0, angle_increment: 0.1, max_range_m: 5.0, ranges_m: vec![1.0] },
        }
    }

    fn inbox(inboxes: &Inboxes, id: u32) -> (mpsc::UnboundedReceiver<Option<Msg>>, Arc<AtomicU64>) {
        let (tx, rx) = mpsc::unbounded_channel();
        let bytes = Arc::new(AtomicU64::new(0));
        inboxes.lock().expect("lock").insert(UavId::new(id), Inbox { tx, own_bytes: bytes.clone(), awaited: id != 2 });
        (rx, bytes)
    }

    #[test]
    fn each_agent_gets_its_own_frame_as_if_sent_alone() {
        let inboxes: Inboxes = Arc::default();
        let (mut rx1, bytes1) = inbox(&inboxes, 1);
        let (mut rx2, _) = inbox(&inboxes, 2);
        let frames = [1, 2, 9].map(|id| UavSense { id: UavId::new(id), frame: frame(id) }).to_vec();
        let outbox: Mutex<Outbox<HeldShare>> = Mutex::new(Outbox::default());
        deliver(&inboxes, Some(&outbox), Ok(Msg::Senses(frames)), 300);
        for (rx, id) in [(&mut rx1, 1), (&mut rx2, 2)] {
            let got = rx.try_recv().expect("a frame");
            assert_eq!(got, Some(Msg::Sense(Box::new(frame(id)))));
            assert!(rx.try_recv().is_err(), "one frame each");
        }
        assert_eq!(bytes1.load(Ordering::Relaxed), 100, "an even part of the message");
        // The tick waits for UAV 1 alone: UAV 2's steps are not awaited, UAV 9 flies elsewhere.
        let mut outbox = outbox.into_inner().expect("lock");
        let state = |id: u32| Box::new(AgentState { id: UavId::new(id), tick: 3, ..AgentState::default() });
        assert!(matches!(outbox.offer(UavId::new(2), None, Cmd::hover(3), state(2)), Offered::Alone(..)));
        let Offered::Taken(done) = outbox.offer(UavId::new(1), None, Cmd::hover(3), state(1)) else {
            panic!("awaited")
        };
        assert_eq!(done.len(), 1, "complete with UAV 1's step");
        let outbox = Mutex::new(outbox);
        deliver(&inboxes, Some(&outbox), Err(WireError::BadKey("x".into())), 10);
        assert_eq!(rx1.try_recv().expect("the malformed message"), None);
        assert_eq!(rx2.try_recv().expect("the malformed message"), None);
    }
}

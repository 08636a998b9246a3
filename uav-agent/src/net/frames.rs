//! An agent host's sensor frames in one message a tick: the session subscribes to
//! `host/{ids}/sense` once, and hands each frame of the hub's `Msg::Senses` to its agent's
//! channel, where a frame on the agent's own `uav/{id}/sense` would have gone.
//!
//! Why: a frame a UAV costs the hub a put, the router a route and the host a delivery each; at
//! 500 agents a host that is 500 of each a tick, one of each here. What the agents see does not
//! change: each frame is the one the hub would have sent alone, handed over in the same Zenoh
//! callback order as the netem rules (the agents' one channel keeps wire order), and the host
//! declares `alive/host/{ids}` only once it is subscribed, so the hub batches only to a host
//! that takes the batch. The agents keep their own `uav/{id}/sense` subscriptions, so a frame
//! the hub sends alone (before it saw the token, or to a host it does not batch to) still
//! arrives; the hub sends each frame one way only.

use super::AgentError;
use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use swarm_types::UavId;
use swarm_wire::{plumbing, Keys, Msg, WireError};
use tokio::sync::mpsc;
use tracing::debug;

/// Where one agent's frames go: its node's channel (`None`: malformed) and its byte count.
struct Inbox {
    tx: mpsc::UnboundedSender<Option<Msg>>,
    own_bytes: Arc<AtomicU64>,
}

/// The agents of the host that take frames now, by UAV.
type Inboxes = Arc<Mutex<HashMap<UavId, Inbox>>>;

/// The host's subscription to its frames and its token, and the agents' inboxes.
pub(crate) struct HostFrames {
    inboxes: Inboxes,
    _sub: plumbing::Subscription,
    _token: zenoh::liveliness::LivelinessToken,
}

impl HostFrames {
    /// Subscribes session `s` to the frames of `ids` (their host key) and then declares the
    /// host's token. `count(len)` counts each message's bytes in the session's traffic.
    pub(crate) async fn open(
        s: &zenoh::Session,
        keys: &Keys,
        ids: &[UavId],
        count: impl Fn(usize) + Send + Sync + 'static,
    ) -> Result<HostFrames, AgentError> {
        let mut ascending = ids.to_vec();
        ascending.sort_unstable();
        let inboxes: Inboxes = Arc::default();
        let to = inboxes.clone();
        let sub = s
            .declare_subscriber(keys.host_sense(&ascending))
            .callback(move |sample| {
                let len = sample.payload().len();
                count(len);
                deliver(&to, plumbing::decode(&sample), len);
            })
            .await
            .map_err(WireError::zenoh)?;
        let token = s.liveliness().declare_token(keys.alive_host(&ascending)).await.map_err(WireError::zenoh)?;
        Ok(HostFrames { inboxes, _sub: sub, _token: token })
    }

    /// Hands UAV `id`'s frames to `tx` (counting their bytes in `own_bytes`) until the returned
    /// guard is dropped.
    pub(crate) fn register(
        self: &Arc<Self>,
        id: UavId,
        tx: mpsc::UnboundedSender<Option<Msg>>,
        own_bytes: Arc<AtomicU64>,
    ) -> Registered {
        self.inboxes.lock().unwrap_or_else(PoisonError::into_inner).insert(id, Inbox { tx, own_bytes });
        Registered { frames: self.clone(), id }
    }
}

/// Hands each frame of a decoded host message to its agent as a `Msg::Sense`, each counted
/// with an even part of the message's `len` bytes. A frame for an agent not taking frames (not
/// started, ended) is dropped; a malformed message reaches every agent as one malformed
/// message, as a malformed frame of its own would.
fn deliver(inboxes: &Mutex<HashMap<UavId, Inbox>>, msg: Result<Msg, WireError>, len: usize) {
    let inboxes = inboxes.lock().unwrap_or_else(PoisonError::into_inner);
    match msg {
        Ok(Msg::Senses(frames)) => {
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
        inboxes.lock().expect("lock").insert(UavId::new(id), Inbox { tx, own_bytes: bytes.clone() });
        (rx, bytes)
    }

    #[test]
    fn each_agent_gets_its_own_frame_as_if_sent_alone() {
        let inboxes: Inboxes = Arc::default();
        let (mut rx1, bytes1) = inbox(&inboxes, 1);
        let (mut rx2, _) = inbox(&inboxes, 2);
        let frames = [1, 2, 9].map(|id| UavSense { id: UavId::new(id), frame: frame(id) }).to_vec();
        deliver(&inboxes, Ok(Msg::Senses(frames)), 300);
        for (rx, id) in [(&mut rx1, 1), (&mut rx2, 2)] {
            let got = rx.try_recv().expect("a frame");
            assert_eq!(got, Some(Msg::Sense(Box::new(frame(id)))));
            assert!(rx.try_recv().is_err(), "one frame each");
        }
        assert_eq!(bytes1.load(Ordering::Relaxed), 100, "an even part of the message");
        deliver(&inboxes, Err(WireError::BadKey("x".into())), 10);
        assert_eq!(rx1.try_recv().expect("the malformed message"), None);
        assert_eq!(rx2.try_recv().expect("the malformed message"), None);
    }
}

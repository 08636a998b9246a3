//! What a scene needs beyond the recorder's truth and states: every UAV's scan, every radio
//! set and the netem timeline in force, subscribed on an existing session into one channel.
//! Plain callbacks into an unbounded channel: the subscriber never pushes back on the hub.

use super::Scene;
use anyhow::Result;
use swarm_wire::msg::{RadioSet, Scan};
use swarm_wire::plumbing::{self, Subscription};
use swarm_wire::{Keys, Msg};
use tokio::sync::mpsc;

/// One message for the scene.
pub enum Extra {
    /// A scan the hub sent UAV `.0`.
    Scan(u32, Scan),
    /// A radio set.
    Radio(RadioSet),
    /// The netem timeline in force.
    Timeline(swarm_config::Timeline),
}

/// The subscriptions and the channel they fill.
pub struct Feed {
    /// Messages in arrival order.
    pub rx: mpsc::UnboundedReceiver<Extra>,
    _subs: [Subscription; 3],
}

impl Feed {
    /// Subscribes to scans, radio sets and `netem/rules` of the run `keys` on `session`.
    pub async fn subscribe(session: &zenoh::Session, keys: &Keys) -> Result<Feed> {
        let (tx, rx) = mpsc::unbounded_channel();
        let k = keys.clone();
        let scans = plumbing::subscribe(session, keys.scan_any(), tx.clone(), move |s| {
            let id = k.uav_id_of(s.key_expr().as_str())?;
            match plumbing::decode(s) {
                Ok(Msg::Scan(scan)) => Some(Extra::Scan(id, scan)),
                _ => None,
            }
        })
        .await?;
        let radio = plumbing::subscribe(session, keys.radio_any(), tx.clone(), |s| match plumbing::decode(s) {
            Ok(Msg::Radio(r)) => Some(Extra::Radio(r)),
            _ => None,
        })
        .await?;
        let rules = plumbing::subscribe(session, keys.netem_rules(), tx, |s| match plumbing::decode(s) {
            Ok(Msg::NetemRules(json)) => serde_json::from_str(&json).ok().map(Extra::Timeline),
            _ => None,
        })
        .await?;
        Ok(Feed { rx, _subs: [scans, radio, rules] })
    }
}

impl Scene {
    /// Takes one message of a [`Feed`].
    pub fn on_extra(&mut self, e: Extra) {
        match e {
            Extra::Scan(id, s) => self.on_scan(id, &s),
            Extra::Radio(r) => self.on_radio(&r),
            Extra::Timeline(t) => self.on_timeline(t),
        }
    }
}

//! What a scene needs beyond the recorder's truth and states: every UAV's sensor frame (its scan
//! and radio set, sent alone or in an agent host's message) and the netem timeline in force, subscribed on an existing session into one
//! channel.
//! Plain callbacks into an unbounded channel: the subscriber never pushes back on the hub.

use super::Scene;
use anyhow::Result;
use swarm_types::UavId;
use swarm_wire::msg::SenseFrame;
use swarm_wire::plumbing::{self, Subscription};
use swarm_wire::{Keys, Msg};
use tokio::sync::mpsc;

/// One message for the scene.
pub enum Extra {
    /// The sensor frame the hub sent UAV `.0`.
    Sense(UavId, Box<SenseFrame>),
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
    /// Subscribes to sensor frames and `netem/rules` of the run `keys` on `session`.
    pub async fn subscribe(session: &zenoh::Session, keys: &Keys) -> Result<Feed> {
        let (tx, rx) = mpsc::unbounded_channel();
        let [alone, hosts] =
            plumbing::subscribe_frames(session, keys, tx.clone(), |id, frame, _| Some(Extra::Sense(id, frame))).await?;
        let rules = plumbing::subscribe(session, keys.netem_rules(), tx, |s| match plumbing::decode(s) {
            Ok(Msg::NetemRules(json)) => serde_json::from_str(&json).ok().map(Extra::Timeline),
            _ => None,
        })
        .await?;
        Ok(Feed { rx, _subs: [alone, hosts, rules] })
    }
}

impl Scene {
    /// Takes one message of a [`Feed`].
    pub fn on_extra(&mut self, e: Extra) {
        match e {
            Extra::Sense(id, f) => {
                self.on_radio(&f.radio);
                self.on_scan(id, &f.scan);
            }
            Extra::Timeline(t) => self.on_timeline(t),
        }
    }
}

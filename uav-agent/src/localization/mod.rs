//! Relative localization: where the neighbours are, in this UAV's body frame. Three modes, one
//! localizer each, chosen once when the agent is built ([`Localizer::new`]):
//!
//! - `broadcast` (`broadcast`, SPEC section 5): share the own GNSS pose, subtract it from the
//!   neighbours' poses.
//! - `icp` ([`icp`]: the alignment, the full-grid initial estimate, the placement policy, the
//!   neighbour database and its gate, the localizer; seed 000 chapters 3 and 5): share the obstacle set, place each neighbour by
//!   matching its set to our own, remembered in the neighbour database.
//! - `uvdar` (`uvdar`): onboard relative sensing, no communication.
//!
//! Each localizer says what share it sends, what it does with the shares it receives, and what it
//! makes of a sensor frame: the same [`Estimate`]s whatever the mode.

mod broadcast;
pub mod icp;
mod uvdar;

use crate::sensing::{Needs, SensorFrame};
use crate::world_model::{Circle, Estimate};
use nalgebra::Point2;
use std::sync::Arc;
use std::time::Instant;
use swarm_config::{LocalizationMode, Scenario, TimeMode};
use swarm_types::UavId;
use swarm_wire::{IcpCounts, Msg, ObstacleShare, PoseShare};

/// What agents tell their neighbours: a pose (`broadcast`) or an obstacle set (`icp`).
#[derive(Debug, Clone, PartialEq)]
pub enum Share {
    /// Broadcast mode.
    Pose(PoseShare),
    /// ICP mode.
    Obstacles(ObstacleSet),
}

/// An obstacle share with its centres in metres, decoded once where the share is made or
/// arrives. Why: in a crowd each share reaches dozens of agents of one host (about 70 a tick in
/// forest-1000-icp), and each of them keeps the set; they now hold the one decoded set rather
/// than each dividing its centimetres by 100 into a copy of its own (seed 000 3.2's set, as the
/// ICP takes it).
///
/// Built only by [`ObstacleSet::new`], so the centres are always `wire`'s (outside the crate its
/// fields are out of reach; inside, only the hop counts of `wire` change, which the centres do
/// not depend on).
#[derive(Debug, Clone, PartialEq)]
pub struct ObstacleSet {
    /// The share as it goes on the wire.
    pub(crate) wire: ObstacleShare,
    /// `wire`'s centres in metres ([`ObstacleShare::centres_m`]), sender's body frame.
    pub(crate) centres_m: Arc<[Point2<f64>]>,
}

impl ObstacleSet {
    /// The set of a wire share, its centres decoded.
    pub fn new(wire: ObstacleShare) -> ObstacleSet {
        let centres_m = wire.centres_m().map(|c| Point2::new(c[0], c[1])).collect();
        ObstacleSet { wire, centres_m }
    }
}

impl Share {
    /// Sender id.
    pub fn from(&self) -> UavId {
        match self {
            Share::Pose(p) => p.from,
            Share::Obstacles(o) => o.wire.from,
        }
    }
    /// Tick it was sent at.
    pub fn tick(&self) -> u64 {
        match self {
            Share::Pose(p) => p.tick,
            Share::Obstacles(o) => o.wire.tick,
        }
    }
    /// Sim time it was sent at [s].
    pub fn t_s(&self) -> f64 {
        match self {
            Share::Pose(p) => p.t_s,
            Share::Obstacles(o) => o.wire.t_s,
        }
    }
    /// The sender's hop count to the nearest informed UAV ([`swarm_wire::NO_PATH`]: none).
    pub fn hops(&self) -> u8 {
        match self {
            Share::Pose(p) => p.hops,
            Share::Obstacles(o) => o.wire.hops,
        }
    }
    /// The sender's hop count to the nearest arrived UAV ([`swarm_wire::NO_PATH`]: none).
    pub fn arrival(&self) -> u8 {
        match self {
            Share::Pose(p) => p.arrival,
            Share::Obstacles(o) => o.wire.arrival,
        }
    }
    /// The share with our hop counts to the nearest informed and the nearest arrived UAV.
    pub fn with_counts(mut self, hops: u8, arrival: u8) -> Share {
        match &mut self {
            Share::Pose(p) => (p.hops, p.arrival) = (hops, arrival),
            Share::Obstacles(o) => (o.wire.hops, o.wire.arrival) = (hops, arrival),
        }
        self
    }
    /// The wire message.
    pub fn into_msg(self) -> Msg {
        match self {
            Share::Pose(p) => Msg::Pose(p),
            Share::Obstacles(o) => Msg::Obstacles(o.wire),
        }
    }
    /// The share in a wire message, if it is one signed by `from` (the sender its key names).
    pub fn from_msg(msg: Msg, from: UavId) -> Result<Share, Msg> {
        match msg {
            Msg::Pose(p) if p.from == from => Ok(Share::Pose(p)),
            Msg::Obstacles(o) if o.from == from => Ok(Share::Obstacles(ObstacleSet::new(o))),
            other => Err(other),
        }
    }
}

/// What localization made of one sensor frame.
#[derive(Debug, Clone, Default)]
pub(crate) struct Localized {
    /// The neighbours, body frame.
    pub(crate) estimates: Vec<Estimate>,
    /// The ICP work it took (`icp` mode; zero otherwise).
    pub(crate) icp: IcpCounts,
}

/// The localizer of the scenario's mode, with the state it keeps between steps.
#[derive(Debug)]
pub(crate) enum Localizer {
    /// `broadcast`.
    Broadcast(broadcast::Broadcast),
    /// `icp` (boxed: the database is large).
    Icp(Box<icp::IcpLocalizer>),
    /// `uvdar`: keeps nothing.
    Uvdar,
}

impl Localizer {
    /// The localizer of UAV `id` for the scenario's mode.
    pub(crate) fn new(id: UavId, sc: &Scenario) -> Localizer {
        let stale_after_s = sc.localization.stale_after_s;
        match sc.localization.mode {
            LocalizationMode::Broadcast => Localizer::Broadcast(broadcast::Broadcast::new(id, stale_after_s)),
            LocalizationMode::Icp => {
                let realtime = sc.time.mode == TimeMode::Realtime;
                let icp = icp::IcpLocalizer::new(id, sc.localization.icp.clone(), stale_after_s, realtime);
                Localizer::Icp(Box::new(icp))
            }
            LocalizationMode::Uvdar => Localizer::Uvdar,
        }
    }

    /// The sensors a step needs besides scan and odometry.
    pub(crate) fn needs(&self) -> Needs {
        match self {
            Localizer::Broadcast(_) => Needs { gnss: true, uvdar: false },
            Localizer::Icp(_) => Needs::default(),
            Localizer::Uvdar => Needs { gnss: false, uvdar: true },
        }
    }

    /// Takes a neighbour's share that the link has delivered.
    pub(crate) fn receive(&mut self, share: &Share) {
        match self {
            Localizer::Broadcast(b) => b.receive(share),
            Localizer::Icp(i) => i.receive(share),
            Localizer::Uvdar => {}
        }
    }

    /// The radio links to `senders` came up at sim time `t_s` (they entered our radio set).
    pub(crate) fn links_came_up(&mut self, senders: &[UavId], t_s: f64) {
        if let Localizer::Icp(i) = self {
            i.links_came_up(senders, t_s);
        }
    }

    /// The neighbours in this frame; `circles` are our own obstacles, `started` when the step
    /// began (wall clock).
    pub(crate) fn localize(&mut self, frame: &SensorFrame, circles: &[Circle], started: Instant) -> Localized {
        match self {
            Localizer::Broadcast(b) => Localized { estimates: b.estimates(frame), icp: IcpCounts::default() },
            Localizer::Icp(i) => {
                let (estimates, icp) = i.estimates(frame, circles, started);
                Localized { estimates, icp }
            }
            Localizer::Uvdar => Localized { estimates: uvdar::estimates(frame), icp: IcpCounts::default() },
        }
    }

    /// What this agent tells its neighbours of this frame, if anything.
    pub(crate) fn share(&self, frame: &SensorFrame, circles: &[Circle]) -> Option<Share> {
        match self {
            Localizer::Broadcast(b) => b.share(frame),
            Localizer::Icp(i) => Some(i.share(frame, circles)),
            Localizer::Uvdar => None,
        }
    }
}

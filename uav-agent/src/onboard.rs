//! One agent's tick with no IO at all: the hub's sensor message and the neighbours' shares in,
//! the step out. [`Onboard`] joins the [`Agent`] and its [`Admission`] in the order the node
//! keeps for every hub message (shares that came first admitted, the radio set, the shares due,
//! the step), so a program that holds the whole swarm in one process, the hub's simulation
//! included, flies exactly what a lockstep run over Zenoh flies, message for message, without a
//! single message: `swarm floor` measures that in-process compute, the floor under any
//! distributed run's wall time per tick.
//!
//! Why not the node itself: the node is that same order plus Zenoh (subscriptions that follow
//! the radio set, the session's share feed, liveliness, an external controller's round trip);
//! what it decides is decided here and in [`Admission`], both pure.

use crate::admission::{Admission, Arrived};
use crate::agent::{Agent, StepOutput, StepReport};
use crate::control::{Controllers, UnknownController};
use crate::localization::Share;
use crate::sensing::{MalformedFrame, Needs, SensorFrame};
use std::sync::Arc;
use swarm_config::Scenario;
use swarm_types::UavId;
use swarm_wire::{AgentState, SenseFrame, WireError};

/// Why [`Onboard::on_sense`] did not step.
#[derive(Debug, thiserror::Error)]
pub enum OnboardError {
    /// The frame is not one to step on (counted as malformed, as the node counts it).
    #[error("malformed sensor frame: {0}")]
    Malformed(#[from] MalformedFrame),
    /// The hub's ticks went backwards.
    #[error("the ticks went back from {last} to {tick}")]
    TickWentBack {
        /// The last tick stepped.
        last: u64,
        /// The tick offered.
        tick: u64,
    },
    /// The agent's own share could not be encoded (its size is what the link accounts for).
    #[error(transparent)]
    Wire(#[from] WireError),
}

/// A share as it leaves an agent: what every listener receives, and its size on the wire.
#[derive(Debug, Clone)]
pub struct Outgoing {
    /// The share, as the receivers decode it.
    pub share: Arc<Share>,
    /// Its encoded size [bytes].
    pub len: usize,
}

/// One agent and its share admission, stepped by hand (see the module doc).
pub struct Onboard {
    agent: Agent,
    admission: Admission,
    needs: Needs,
}

impl Onboard {
    /// UAV `id`'s onboard stack under `sc`, with the controller of `controllers` it names.
    pub fn new(id: UavId, sc: &Scenario, controllers: &Controllers) -> Result<Onboard, UnknownController> {
        let agent = Agent::new(id, sc.clone(), controllers)?;
        let needs = agent.needs();
        let shares = sc.localization.mode.share().is_some();
        let admission = Admission::new(id, sc.seed, sc.dt_s(), netem::Timeline::from_scenario(sc), shares);
        Ok(Onboard { agent, admission, needs })
    }

    /// A neighbour's share reached this agent (the node's share feed does this for every UAV of
    /// the radio set it listens to; the admission decides whether it counts, and when).
    pub fn on_share(&mut self, from: UavId, share: Arc<Share>, len: usize) {
        self.admission.on_arrived(Arrived { from, share: Some(share), len });
    }

    /// The hub's sensor message of a tick: steps on it and returns the step, with the share as
    /// it goes out through the link (`None` when the mode has no share or the link holds it back).
    pub fn on_sense(&mut self, wire: SenseFrame) -> Result<(StepOutput, Option<Outgoing>), OnboardError> {
        self.admission.admit_early();
        let (radio, frame) =
            SensorFrame::from_wire(wire, self.needs).inspect_err(|_| self.admission.count_malformed())?;
        // Whom to listen to is the caller's to follow (the radio set it just handed in).
        let change = self.admission.on_radio(radio.tick, &radio.in_range, &radio.loss);
        self.agent.links_came_up(&change.entered, frame.scan.t_s);
        let due = self
            .admission
            .begin_step(frame.tick(), frame.scan.t_s)
            .map_err(|w| OnboardError::TickWentBack { last: w.last, tick: w.tick })?;
        for share in due {
            self.agent.on_share(&share);
        }
        let mut out = self.agent.step(&frame);
        let outgoing = match out.share.take() {
            Some(share) => {
                let len = share.clone().into_msg().encode()?.len();
                self.admission.on_send(len).then(|| Outgoing { share: Arc::new(share), len })
            }
            None => None,
        };
        Ok((out, outgoing))
    }

    /// The state message of a step's `report`, with what the link counted so far (and no
    /// traffic: nothing crossed a session).
    pub fn state(&mut self, report: StepReport) -> AgentState {
        report.into_state(self.admission.report())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensing::tests::broadcast_wire;
    use swarm_config::LocalizationMode;
    use swarm_wire::PoseShare;

    fn broadcast() -> Onboard {
        let mut sc = swarm_config::builtin("forest-5").expect("built in");
        sc.localization.mode = LocalizationMode::Broadcast;
        Onboard::new(UavId::new(1), &sc, &Controllers::builtin()).expect("a built-in controller")
    }

    fn pose_of_2(tick: u64) -> Arc<Share> {
        let p = PoseShare {
            from: UavId::new(2),
            tick,
            t_s: tick as f64 * 0.1,
            x: 3.0,
            y: 2.0,
            yaw: 0.0,
            vx: 0.0,
            vy: 0.0,
            hops: swarm_wire::NO_PATH,
            arrival: swarm_wire::NO_PATH,
        };
        Arc::new(Share::Pose(p))
    }

    /// The admission's window, through the hand-stepped seam: UAV 2 is in range from tick 0, so
    /// its shares count from tick 2 on, each due at the tick after it was sent.
    #[test]
    fn a_neighbours_share_counts_from_the_second_tick_after_it_came_into_range() {
        let mut me = broadcast();
        let mut seen = Vec::new();
        for tick in 0..5 {
            if tick > 0 {
                me.on_share(UavId::new(2), pose_of_2(tick - 1), 60);
            }
            let (out, share) = me.on_sense(broadcast_wire(tick)).expect("steps");
            assert_eq!(out.cmd.tick, tick);
            assert!(share.is_some_and(|o| o.len > 0 && o.share.from() == UavId::new(1)), "its own share goes out");
            seen.push(out.report.neighbours.len());
        }
        assert_eq!(seen, vec![0, 0, 0, 1, 1]);
    }

    /// A frame it cannot step on is refused and counted, and the ticks may not go back.
    #[test]
    fn a_bad_frame_is_counted_and_the_ticks_may_not_go_back() {
        let mut me = broadcast();
        let no_gnss = SenseFrame { gnss: None, ..broadcast_wire(0) };
        assert!(matches!(me.on_sense(no_gnss), Err(OnboardError::Malformed(MalformedFrame::NoGnss))));
        let (out, _) = me.on_sense(broadcast_wire(1)).expect("steps");
        assert_eq!(me.state(out.report).link.malformed, 1);
        assert!(matches!(me.on_sense(broadcast_wire(1)), Err(OnboardError::TickWentBack { last: 1, tick: 1 })));
    }
}

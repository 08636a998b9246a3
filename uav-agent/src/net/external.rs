//! An agent whose controller runs outside our processes, in any language: each tick the agent
//! still perceives and localizes (and still shares, so its neighbours localize it), publishes
//! the view as JSON on `uav/{id}/ext/view`, and waits for the controller's command for that tick
//! on `uav/{id}/ext/cmd` (encoding in `swarm_wire::external`).
//!
//! The wait is bounded to answer before the hub gives up: 80 % of the tick timeout in lockstep
//! (the hub's clock started when it sent the sensors), one tick period in realtime. A command
//! that does not come in time is counted, and the UAV hovers (a hover command, which the hub
//! takes even late, so its state and share still go out). A controller whose token went away
//! is not waited for at all: its UAV hovers at once, tick after tick. Before the agent says it
//! is up (its liveliness token, which the hub waits for), it waits for the controller's own
//! token `alive/ext/{id}`, so a lockstep run does not start without it.

use super::AgentError;
use crate::control::neighbour_velocity::VelocityTracker;
use crate::control::{Command, View};
use nalgebra::Vector2;
use std::time::Duration;
use swarm_config::{Scenario, TimeMode};
use swarm_types::UavId;
use swarm_wire::external::{ExtCmd, ExtCmdKind, ExtNeighbour, ExtOdom, ExtTree, ExtView, ExtWall};
use swarm_wire::plumbing::{self, Subscription};
use swarm_wire::{CmdKind, Keys, VectorMagnitudes, WireError};
use tokio::sync::{mpsc, watch};
use tracing::{debug, info, warn};
use zenoh::bytes::Encoding;
use zenoh::qos::CongestionControl;

/// A neighbour not estimated for this long starts its velocity afresh [s].
const VELOCITY_FORGET_S: f64 = 1.0;

/// The share of the hub's tick timeout an agent waits for its external controller in lockstep,
/// so that its hover reaches the hub before the hub's own deadline.
const LOCKSTEP_SHARE: f64 = 0.8;

/// The link of one agent to its external controller.
pub(super) struct ExternalLink {
    session: zenoh::Session,
    view_key: zenoh::key_expr::KeyExpr<'static>,
    cmds: mpsc::UnboundedReceiver<Option<ExtCmd>>,
    _cmd_sub: Subscription,
    controller_alive: watch::Receiver<bool>,
    _alive_sub: Subscription,
    /// How long a tick waits for its command.
    wait: Duration,
    /// Lockstep blocks rather than drop a view under congestion (the tick would wait for a
    /// command its controller never had the view of); realtime drops, as every realtime put.
    congestion: CongestionControl,
    /// How long the agent waits for the controller to come (the scenario's startup timeout).
    startup_wait: Duration,
    /// Ticks whose command did not come in time.
    pub(super) missed: u64,
    /// Messages on the command key that were not a command.
    pub(super) malformed: u64,
    /// Each neighbour id's velocity from its successive estimates, for the view.
    velocities: VelocityTracker,
}

impl ExternalLink {
    /// Subscribes to UAV `id`'s command key and watches its controller's token.
    pub(super) async fn open(
        s: &zenoh::Session,
        keys: &Keys,
        id: UavId,
        sc: &Scenario,
    ) -> Result<ExternalLink, AgentError> {
        let (tx, cmds) = mpsc::unbounded_channel();
        let cmd_sub =
            plumbing::subscribe(s, keys.ext_cmd(id), tx, |sample| Some(ExtCmd::parse(&plumbing::payload(sample))))
                .await?;
        let (controller_alive, alive_sub) = plumbing::watch_token(s, keys.alive_ext(id)).await?;
        let view_key = s.declare_keyexpr(keys.ext_view(id)).await.map_err(WireError::zenoh)?;
        let wait = match sc.time.mode {
            TimeMode::Lockstep => Duration::from_millis(sc.time.tick_timeout_ms).mul_f64(LOCKSTEP_SHARE),
            TimeMode::Realtime => Duration::from_secs_f64(sc.dt_s() / sc.time.realtime_factor.max(1e-9)),
        };
        let startup_wait = Duration::from_secs_f64(sc.time.startup_timeout_s.max(0.0));
        Ok(ExternalLink {
            session: s.clone(),
            view_key,
            cmds,
            _cmd_sub: cmd_sub,
            controller_alive,
            _alive_sub: alive_sub,
            wait,
            congestion: swarm_wire::session::congestion(sc.time.mode),
            startup_wait,
            missed: 0,
            malformed: 0,
            velocities: VelocityTracker::new(VELOCITY_FORGET_S),
        })
    }

    /// Waits until the external controller's token is alive, at most the startup timeout.
    pub(super) async fn wait_for_controller(&mut self, id: UavId) -> Result<(), AgentError> {
        let limit = self.startup_wait;
        info!(uav_id = %id, "waiting for the external controller (alive/ext/{id})");
        match tokio::time::timeout(limit, self.controller_alive.wait_for(|up| *up)).await {
            Ok(Ok(_)) => Ok(()),
            _ => Err(AgentError::NoExternalController(id, limit.as_secs())),
        }
    }

    /// Publishes the view of `tick` and waits for its command; a hover if none comes in time.
    /// `counts`: the hop counts (to the nearest informed and arrived UAV) of the last step.
    pub(super) async fn ask(&mut self, tick: u64, view: &View<'_>, counts: (u8, u8)) -> Result<Command, AgentError> {
        if !*self.controller_alive.borrow() {
            self.missed += 1;
            if self.missed == 1 || self.missed.is_power_of_two() {
                warn!(tick, missed = self.missed, "the external controller is gone: hovering");
            }
            return Ok(Command::hover());
        }
        // serde_json writes a non-finite number as null; a view has none (see `finite`).
        let mut ext = ext_view(tick, view);
        (ext.hops_informed, ext.hops_arrived) = counts;
        self.velocities.forget_stale(view.t_s);
        for (n, e) in ext.neighbours.iter_mut().zip(view.neighbours) {
            n.vel =
                e.id.and_then(|id| self.velocities.update(id, e.pos_in_body, view.t_s))
                    .map(|v| [finite(v.x), finite(v.y)]);
        }
        let text = serde_json::to_vec(&ext).expect("a view serializes");
        self.session
            .put(self.view_key.clone(), text)
            .encoding(Encoding::APPLICATION_JSON)
            .congestion_control(self.congestion)
            .await
            .map_err(WireError::zenoh)?;
        let deadline = tokio::time::Instant::now() + self.wait;
        loop {
            // A controller that goes while a tick waits for it (its program stopped) ends the wait.
            let cmd = tokio::select! {
                c = tokio::time::timeout_at(deadline, self.cmds.recv()) => c,
                _ = self.controller_alive.wait_for(|up| !*up) => {
                    warn!(tick, "the external controller went while its tick waited: hovering");
                    return Ok(Command::hover());
                }
            };
            match cmd {
                Ok(Some(Some(c))) if c.tick == tick => return Ok(command_of(&c)),
                Ok(Some(Some(c))) => debug!(tick, cmd_tick = c.tick, "external command for another tick dropped"),
                Ok(Some(None)) => self.malformed += 1,
                Ok(None) | Err(_) => {
                    self.missed += 1;
                    debug!(tick, "no external command in time: hovering");
                    return Ok(Command::hover());
                }
            }
        }
    }
}

/// The view as the external controller reads it: neither the scan points nor `near_bodies`,
/// which are K21's barrier's, go on the wire.
fn ext_view(tick: u64, v: &View) -> ExtView {
    let o = v.odom;
    ExtView {
        tick,
        t_s: finite(v.t_s),
        // The JSON view's ids are plain numbers (`swarm_wire::external`).
        id: v.id.get(),
        odom: ExtOdom { x: finite(o.x), y: finite(o.y), yaw: finite(o.yaw), vx: finite(o.vx), vy: finite(o.vy) },
        goal: o.goal.map(|[x, y]| [finite(x), finite(y)]),
        neighbours: v
            .neighbours
            .iter()
            .map(|e| ExtNeighbour {
                id: e.id.map(UavId::get),
                x: finite(e.pos_in_body.x),
                y: finite(e.pos_in_body.y),
                heading: finite(e.heading),
                age_s: finite(e.age_s),
                vel: None,
            })
            .collect(),
        trees: v
            .trees
            .iter()
            .map(|c| ExtTree { x: finite(c.center.x), y: finite(c.center.y), r: finite(c.radius) })
            .collect(),
        walls: v
            .walls
            .iter()
            .map(|w| ExtWall { ax: finite(w.a.x), ay: finite(w.a.y), bx: finite(w.b.x), by: finite(w.b.y) })
            .collect(),
        hops_informed: u8::MAX,
        hops_arrived: u8::MAX,
    }
}

fn command_of(c: &ExtCmd) -> Command {
    let kind = match c.kind {
        ExtCmdKind::Velocity => CmdKind::Velocity,
        ExtCmdKind::Acceleration => CmdKind::Acceleration,
    };
    // Beyond f32 the wire's command would be infinite; nothing flies that fast anyway.
    let clamp = |v: f64| v.clamp(-1e6, 1e6);
    let xy = Vector2::new(clamp(c.x), clamp(c.y));
    Command {
        kind,
        xy,
        yaw_rate: clamp(c.yaw_rate),
        vectors: VectorMagnitudes { output: xy.norm() as f32, ..VectorMagnitudes::default() },
    }
}

/// `v`, or 0 where it is not a number a JSON reader can take.
fn finite(v: f64) -> f64 {
    if v.is_finite() {
        v
    } else {
        0.0
    }
}

impl Drop for ExternalLink {
    fn drop(&mut self) {
        if self.missed > 0 || self.malformed > 0 {
            info!(
                missed = self.missed,
                malformed = self.malformed,
                "external controller: ticks without its command, and payloads that were not one"
            );
        }
    }
}

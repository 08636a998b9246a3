//! An agent whose controller runs outside our processes, in any language: each tick the agent
//! still perceives and localizes (and still shares, so its neighbours localize it), publishes
//! the view as JSON on `uav/{id}/ext/view`, and waits for the controller's command for that tick
//! on `uav/{id}/ext/cmd` (encoding in `swarm_wire::external`).
//!
//! The wait is bounded by what the hub would wait: the tick timeout in lockstep, one tick
//! period in realtime. A command that does not come in time is counted, and the UAV hovers for
//! that tick (a hover command, so its state and share still go out). Before the agent says it
//! is up (its liveliness token, which the hub waits for), it waits for the controller's own
//! token `alive/ext/{id}`, so a lockstep run does not start without it.

use super::AgentError;
use crate::control::{Command, View};
use nalgebra::Vector2;
use std::time::Duration;
use swarm_config::{Scenario, TimeMode};
use swarm_wire::external::{ExtCmd, ExtCmdKind, ExtNeighbour, ExtOdom, ExtTree, ExtView, ExtWall};
use swarm_wire::plumbing::{self, Subscription};
use swarm_wire::{CmdKind, Keys, VectorMagnitudes, WireError};
use tokio::sync::{mpsc, watch};
use tracing::{debug, info};
use zenoh::bytes::Encoding;

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
    /// Ticks whose command did not come in time.
    pub(super) missed: u64,
    /// Messages on the command key that were not a command.
    pub(super) malformed: u64,
}

impl ExternalLink {
    /// Subscribes to UAV `id`'s command key and watches its controller's token.
    pub(super) async fn open(s: &zenoh::Session, keys: &Keys, id: u32, sc: &Scenario) -> Result<ExternalLink, AgentError> {
        let (tx, cmds) = mpsc::unbounded_channel();
        let cmd_sub = plumbing::subscribe(s, keys.ext_cmd(id), tx, |sample| Some(ExtCmd::parse(&plumbing::payload(sample)))).await?;
        let (controller_alive, alive_sub) = plumbing::watch_token(s, keys.alive_ext(id)).await?;
        let view_key = s.declare_keyexpr(keys.ext_view(id)).await.map_err(WireError::zenoh)?;
        let wait = match sc.time.mode {
            TimeMode::Lockstep => Duration::from_millis(sc.time.tick_timeout_ms),
            TimeMode::Realtime => Duration::from_secs_f64(sc.dt_secs() / sc.time.realtime_factor.max(1e-9)),
        };
        Ok(ExternalLink { session: s.clone(), view_key, cmds, _cmd_sub: cmd_sub, controller_alive, _alive_sub: alive_sub, wait, missed: 0, malformed: 0 })
    }

    /// Waits until the external controller's token is alive, at most `limit`.
    pub(super) async fn wait_for_controller(&mut self, id: u32, limit: Duration) -> Result<(), AgentError> {
        info!(uav_id = id, "waiting for the external controller (alive/ext/{id})");
        match tokio::time::timeout(limit, self.controller_alive.wait_for(|up| *up)).await {
            Ok(Ok(_)) => Ok(()),
            _ => Err(AgentError::NoExternalController(id, limit.as_secs())),
        }
    }

    /// Publishes the view of `tick` and waits for its command; a hover if none comes in time.
    pub(super) async fn ask(&mut self, tick: u64, view: &View<'_>) -> Result<Command, AgentError> {
        let text = serde_json::to_vec(&ext_view(tick, view)).expect("a view serializes");
        self.session.put(self.view_key.clone(), text).encoding(Encoding::APPLICATION_JSON).await.map_err(WireError::zenoh)?;
        let deadline = tokio::time::Instant::now() + self.wait;
        loop {
            match tokio::time::timeout_at(deadline, self.cmds.recv()).await {
                Ok(Some(Some(c))) if c.tick == tick => return Ok(command_of(&c)),
                Ok(Some(Some(c))) => debug!(tick, cmd_tick = c.tick, "external command for another tick dropped"),
                Ok(Some(None)) => self.malformed += 1,
                Ok(None) | Err(_) => {
                    self.missed += 1;
                    debug!(tick, "no external command in time: hovering");
                    return Ok(hover());
                }
            }
        }
    }
}

/// The view as the external controller reads it.
fn ext_view(tick: u64, v: &View) -> ExtView {
    let o = v.odom;
    ExtView {
        tick,
        t_s: v.t_secs,
        id: v.id,
        odom: ExtOdom { x: o.x, y: o.y, yaw: o.yaw, vx: o.vx, vy: o.vy },
        goal: o.goal,
        neighbours: v
            .neighbours
            .iter()
            .map(|e| ExtNeighbour { id: e.id, x: e.pos_in_body.x, y: e.pos_in_body.y, heading: e.heading, age_s: e.age_secs })
            .collect(),
        trees: v.trees.iter().map(|c| ExtTree { x: c.center.x, y: c.center.y, r: c.radius }).collect(),
        walls: v.walls.iter().map(|w| ExtWall { ax: w.a.x, ay: w.a.y, bx: w.b.x, by: w.b.y }).collect(),
    }
}

fn command_of(c: &ExtCmd) -> Command {
    let kind = match c.kind {
        ExtCmdKind::Velocity => CmdKind::Velocity,
        ExtCmdKind::Acceleration => CmdKind::Acceleration,
    };
    let xy = Vector2::new(c.x, c.y);
    Command { kind, xy, yaw_rate: c.yaw_rate, vectors: VectorMagnitudes { output: xy.norm() as f32, ..VectorMagnitudes::default() } }
}

/// Zero velocity: what a UAV does for a tick its controller did not answer.
fn hover() -> Command {
    Command { kind: CmdKind::Velocity, xy: Vector2::zeros(), yaw_rate: 0.0, vectors: VectorMagnitudes::default() }
}

//! One agent's node: a Zenoh client of the hub that feeds [`Agent`] and publishes what it
//! decides.
//!
//! - It fetches the scenario from the hub (`swarm/{run}/scenario`) unless given one, so an agent
//!   on another machine needs only the hub's endpoint, the run id and its UAV id.
//! - It subscribes to its own `sense` key (the tick's sensor frame: radio set, odometry, GNSS or
//!   UVDAR by mode, and the scan, in one message), through a declared key expression
//!   ([`subscribe_declared`]), so an agent host's session hands each frame to its subscriber
//!   without testing every subscriber of the session; in an agent host it also takes its frames
//!   out of the host's one message a tick ([`super::frames`]), into the same channel.
//! - It listens to the shares (`share/pose` or `share/obstacles`, by localization mode) of
//!   exactly the UAVs in its radio set, starting and stopping as the set changes: the session's
//!   [`ShareFeed`] holds one Zenoh subscription per sender its agents listen to, and posts each
//!   share to the mailboxes of the agents listening, without waking them.
//! - Determinism in lockstep: the node's own subscriptions feed one channel, so hub messages are
//!   handled in wire order, and the shares posted meanwhile are taken, in arrival order, when the
//!   next hub message is handled ([`Node::take_shares`]); which of them count, and when each is
//!   delivered, is decided by the pure [`Admission`] (neighbour windows, early shares, the netem
//!   link, the inbox), so it depends on neither timing nor the process layout.
//! - It declares its `alive/uav/{id}` token after its subscriptions (so the hub, seeing the
//!   token, knows the agent will get tick 0) and watches `alive/hub`: when the hub goes, the agent
//!   commands hover and exits cleanly.

use super::external::ExternalLink;
use super::feed::{Listening, Mailbox, SessionShared};
use super::ros::{RosLink, Sensors};
use super::AgentError;
use crate::admission::{Admission, Arrived};
use crate::agent::{Agent, StepOutput};
use crate::control::Controllers;
use crate::sensing::{Needs, SensorFrame};
use std::collections::BTreeMap;
use std::future::Future;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;
use swarm_config::Scenario;
use swarm_types::{SimTime, UavId};
use swarm_wire::plumbing::{self, Subscription as Subscriber};
use swarm_wire::session::{self, Role, Writer};
use swarm_wire::{Cmd, Keys, Msg, WireError};
use tokio::sync::{mpsc, watch};
use tracing::{debug, info, info_span, trace, warn, Instrument};
use zenoh::qos::CongestionControl;

/// Which UAV, which run, which hub.
#[derive(Debug, Clone, Default)]
pub struct AgentOptions {
    /// Run id.
    pub run: String,
    /// UAV id, 1-based.
    pub id: UavId,
    /// Hub endpoints, e.g. `tcp/10.0.0.5:7447`.
    pub connect: Vec<String>,
    /// `KEY:JSON5` Zenoh config overrides.
    pub zenoh_cfg: Vec<String>,
    /// Use this scenario instead of fetching it from the hub.
    pub scenario: Option<Scenario>,
    /// How long to wait for a hub whose liveliness token went away before giving up [s]: its link
    /// may come back (Zenoh clients reconnect by themselves) or it may have stopped for good.
    pub hub_grace_s: f64,
    /// The controllers the scenario may name (default: the built-in ones).
    pub controllers: Controllers,
    /// Where its sensor frames come from and where its commands go: the hub's keys (default),
    /// or ROS 2 topics ([`super::ros`]).
    pub sensors: Sensors,
}

/// How an agent's run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AgentExit {
    /// The hub's liveliness token went away.
    HubGone,
    /// Asked to stop.
    Stopped,
}

/// Runs the agent until the hub goes away or `shutdown` resolves.
pub async fn run(opts: AgentOptions, shutdown: impl Future<Output = ()>) -> Result<AgentExit, AgentError> {
    let keys = Keys::new(&opts.run)?;
    let s = session::open(Role::Client, &[], &opts.connect, &opts.zenoh_cfg).await?;
    let span = info_span!("agent", uav_id = %opts.id, run = %opts.run);
    let result = async {
        let sc = match opts.scenario.clone() {
            Some(sc) => sc,
            None => fetch_scenario(&s, &keys, &opts.run).await?,
        };
        let shared = SessionShared::open(&s, &keys, &sc, &[opts.id], false).await?;
        let flight = Flight {
            sc,
            hub_grace_s: opts.hub_grace_s,
            controllers: opts.controllers.clone(),
            sensors: opts.sensors.clone(),
        };
        fly(s.clone(), keys, shared, opts.id, flight, shutdown).await
    }
    .instrument(span)
    .await;
    let _ = s.close().await;
    result
}

/// What every agent of a run flies with, whichever process it runs in.
#[derive(Debug, Clone)]
pub(crate) struct Flight {
    /// The scenario.
    pub sc: Scenario,
    /// See [`AgentOptions::hub_grace_s`].
    pub hub_grace_s: f64,
    /// See [`AgentOptions::controllers`].
    pub controllers: Controllers,
    /// See [`AgentOptions::sensors`].
    pub sensors: Sensors,
}

/// Flies UAV `id` of the flight's scenario on session `s` (its own or shared with other agents
/// of a host, with what the session's agents share) until the hub goes away or `shutdown`
/// resolves.
pub(crate) async fn fly(
    s: zenoh::Session,
    keys: Keys,
    shared: Arc<SessionShared>,
    id: UavId,
    flight: Flight,
    shutdown: impl Future<Output = ()>,
) -> Result<AgentExit, AgentError> {
    if !id.within(flight.sc.swarm.count as usize) {
        return Err(AgentError::BadId(id, flight.sc.swarm.count));
    }
    let agent = Agent::new(id, flight.sc.clone(), &flight.controllers)?;
    let mut node = Node::start(s, keys, shared, agent, flight.sc, &flight.sensors).await?;
    node.hub_grace_s = flight.hub_grace_s;
    node.run_loop(shutdown).await
}

/// The scenario the hub serves, waited for up to 30 s.
pub(crate) async fn fetch_scenario(s: &zenoh::Session, keys: &Keys, run: &str) -> Result<Scenario, AgentError> {
    const WAIT_SECS: u64 = 30;
    let text = plumbing::fetch_scenario_text(s, keys, Duration::from_secs(WAIT_SECS)).await.map_err(|e| match e {
        WireError::NoReply { .. } => AgentError::NoHub(run.to_string(), WAIT_SECS),
        e => e.into(),
    })?;
    Ok(Scenario::from_toml_str(&text, &format!("hub:{}", keys.scenario()))?)
}

/// What the node's own subscriptions deliver, in one channel so wire order is kept: a sensor
/// frame or netem-rules message (`None`: malformed). Shares come through the [`Mailbox`].
type Incoming = Option<Msg>;

/// The subscriptions a node holds for its whole life (dropping one undeclares it).
struct Inputs {
    /// The hub's sensor frames (none for an agent on ROS topics).
    _sense: Option<Subscriber>,
    /// Its frames out of its host's message (an agent host's agents).
    _host_frames: Option<super::frames::Registered>,
    _rules: Subscriber,
    _hub_watch: Subscriber,
}

/// The node's writers.
struct Outputs {
    /// The command to the hub (none for an agent on ROS topics: its commands go to `ros`).
    cmd: Option<Writer>,
    /// Shared with the host's messages, which may put a share held back (see [`super::frames`]).
    share: Arc<Writer>,
    state: Writer,
}

struct Node {
    s: zenoh::Session,
    /// See [`AgentOptions::hub_grace_s`].
    hub_grace_s: f64,
    /// The control period [s].
    dt_s: f64,
    keys: Keys,
    id: UavId,
    agent: Agent,
    /// The sensors a frame must carry for this agent's localizer.
    needs: Needs,
    /// Which shares count and when each is delivered (pure).
    admission: Admission,
    /// Kept so the channel stays open for the node's life.
    _tx: mpsc::UnboundedSender<Incoming>,
    rx: mpsc::UnboundedReceiver<Incoming>,
    /// Where the session's share feed leaves the shares of the neighbours listened to.
    mailbox: Mailbox,
    /// The mailbox's last contents, drained (kept to reuse the buffer).
    posted: Vec<Arrived>,
    hub_alive: watch::Receiver<bool>,
    /// What the agents of this session share (the share feed, declared keys).
    shared: Arc<SessionShared>,
    /// Listening to each neighbour in radio range (dropping one stops it).
    listening: BTreeMap<UavId, Listening>,
    publish: Outputs,
    _inputs: Inputs,
    /// The link to this UAV's external controller, when it has one instead of ours.
    external: Option<ExternalLink>,
    /// Its ROS 2 side, when its sensors and commands are ROS topics.
    ros: Option<RosLink>,
    _token: Option<zenoh::liveliness::LivelinessToken>,
    /// Counted among the session's agents while the node lives.
    _flying: Flying,
    /// Payload bytes of this agent's own samples (sensor frames, rules), counted by their
    /// subscriptions' callbacks.
    own_bytes: Arc<AtomicU64>,
    /// Shares posted to this agent's mailbox so far, and their bytes.
    arrived: (u64, u64),
}

/// An agent counted among its session's agents until dropped.
struct Flying(Arc<super::feed::SessionCounts>);

impl Flying {
    fn new(traffic: &Arc<super::feed::SessionCounts>) -> Flying {
        traffic.agent(true);
        Flying(traffic.clone())
    }
}

impl Drop for Flying {
    fn drop(&mut self) {
        self.0.agent(false);
    }
}

/// Subscribes to the exact key `key` into `tx` (as [`plumbing::subscribe`]) through a key
/// expression declared on the session. Zenoh then routes each sample to this session by the
/// expression's id, and the session hands it to the subscribers cached on that resource; a
/// sample on an undeclared key is instead tested against every subscriber of the session, which
/// on an agent host of hundreds of agents was most of the host's time. Only for this agent's
/// own keys: the keys several agents of a session use are declared by the session's
/// [`SessionShared`], once (Zenoh does not order concurrent declarations of one key).
async fn subscribe_declared<T: Send + 'static>(
    s: &zenoh::Session,
    key: String,
    tx: mpsc::UnboundedSender<T>,
    map: impl Fn(&zenoh::sample::Sample) -> Option<T> + Send + Sync + 'static,
) -> Result<Subscriber, WireError> {
    let declared = s.declare_keyexpr(key).await.map_err(WireError::zenoh)?;
    plumbing::subscribe(s, declared, tx, map).await
}

/// Subscribes the node's own sensor-frame (when `from_hub`) and netem-rule keys into `tx`, and
/// watches the hub's liveliness token. Every sample's bytes are counted in the session's
/// traffic and `own_bytes`. In an agent host, the host's messages wait for its steps when
/// `awaited` (see [`super::frames`]).
async fn declare_inputs(
    s: &zenoh::Session,
    keys: &Keys,
    shared: &SessionShared,
    (id, from_hub, awaited): (UavId, bool, bool),
    tx: &mpsc::UnboundedSender<Incoming>,
    own_bytes: &Arc<AtomicU64>,
) -> Result<(Inputs, watch::Receiver<bool>), AgentError> {
    let traffic = shared.feed.traffic().clone();
    let own = own_bytes.clone();
    // Decoded from the payload in place when it is contiguous (no copy of each scan).
    let decode = move |sample: &zenoh::sample::Sample| {
        let len = sample.payload().len();
        traffic.count(len);
        own.fetch_add(len as u64, Ordering::Relaxed);
        Some(plumbing::decode(sample).ok())
    };
    let sense = match from_hub {
        true => Some(subscribe_declared(s, keys.sense(id), tx.clone(), decode.clone()).await?),
        false => None,
    };
    let host_frames = match (&shared.frames, from_hub) {
        (Some(frames), true) => Some(frames.register(id, tx.clone(), own_bytes.clone(), awaited)),
        _ => None,
    };
    // The rules in force, republished by the hub whenever `swarm netem` changes them; on the key
    // the session declared once for all its agents.
    let rules_sub = plumbing::subscribe(s, shared.netem_rules.clone(), tx.clone(), decode).await?;
    let (hub_alive, hub_watch) = plumbing::watch_token(s, keys.alive_hub()).await?;
    Ok((Inputs { _sense: sense, _host_frames: host_frames, _rules: rules_sub, _hub_watch: hub_watch }, hub_alive))
}

/// The command (when `to_hub`), share and state writers of UAV `id`.
async fn declare_outputs(
    s: &zenoh::Session,
    keys: &Keys,
    shared: &SessionShared,
    (id, to_hub): (UavId, bool),
    sc: &Scenario,
) -> Result<Outputs, AgentError> {
    let cc = swarm_wire::session::congestion(sc.time.mode);
    // The share key as the session declared it (once, for every agent of the session). `uvdar`
    // never shares (no communication): its writer is on the pose key, and stays silent.
    let share = Arc::new(match shared.feed.key(id)? {
        Some(key) => Writer::new(s, key, cc).await?,
        None => Writer::new(s, keys.share_pose(id), cc).await?,
    });
    Ok(Outputs {
        cmd: match to_hub {
            true => Some(Writer::new(s, keys.cmd(id), CongestionControl::Block).await?),
            false => None,
        },
        share,
        state: Writer::new(s, keys.state(id), cc).await?,
    })
}

impl Node {
    async fn start(
        s: zenoh::Session,
        keys: Keys,
        shared: Arc<SessionShared>,
        agent: Agent,
        sc: Scenario,
        sensors: &Sensors,
    ) -> Result<Node, AgentError> {
        let id = agent.id();
        let needs = agent.needs();
        let hub = *sensors == Sensors::Hub;
        if !hub && (needs.gnss || needs.uvdar) {
            return Err(AgentError::RosNeedsIcp(id));
        }
        let (tx, rx) = mpsc::unbounded_channel();
        let own_bytes = Arc::new(AtomicU64::new(0));
        // An external controller may keep its agent past the hub's tick timeout: such an agent's
        // commands go alone, so the host's others never wait with it.
        let awaited = !sc.controller.external.contains(&id);
        let (inputs, hub_alive) = declare_inputs(&s, &keys, &shared, (id, hub, awaited), &tx, &own_bytes).await?;
        let publish = declare_outputs(&s, &keys, &shared, (id, hub), &sc).await?;
        let ros = match hub {
            true => None,
            false => Some(RosLink::open(&s, &keys, &sc, id, sensors, tx.clone()).await?),
        };
        let external = if sc.controller.external.contains(&id) {
            Some(ExternalLink::open(&s, &keys, id, &sc).await?)
        } else {
            None
        };
        let shares = keys.share_of(sc.localization.mode, id).is_some();
        Ok(Node {
            needs,
            ros,
            admission: Admission::new(id, sc.seed, sc.dt_s(), netem::Timeline::from_scenario(&sc), shares),
            agent,
            _tx: tx,
            rx,
            mailbox: Mailbox::default(),
            posted: Vec::new(),
            hub_grace_s: 0.0,
            dt_s: sc.dt_s(),
            hub_alive,
            _flying: Flying::new(shared.feed.traffic()),
            own_bytes,
            arrived: (0, 0),
            shared,
            listening: BTreeMap::new(),
            publish,
            _inputs: inputs,
            external,
            _token: None,
            s,
            keys,
            id,
        })
    }

    async fn run_loop(mut self, shutdown: impl Future<Output = ()>) -> Result<AgentExit, AgentError> {
        tokio::pin!(shutdown);
        if let Some(ext) = self.external.as_mut() {
            ext.wait_for_controller(self.id).await?;
        }
        // Subscriptions are in place: now tell the hub we are here.
        let token = self.s.liveliness().declare_token(self.keys.alive_uav(self.id)).await.map_err(WireError::zenoh)?;
        self._token = Some(token);
        info!("agent up");
        let hub_deadline = tokio::time::sleep(Duration::from_secs(30));
        tokio::pin!(hub_deadline);
        let mut hub = HubWatch { seen: *self.hub_alive.borrow(), lost: false };
        // While the hub is lost: when to give up.
        let grace = Duration::from_secs_f64(self.hub_grace_s.max(0.0));
        let lost_deadline = tokio::time::sleep(Duration::ZERO);
        tokio::pin!(lost_deadline);
        loop {
            tokio::select! {
                m = self.rx.recv() => match m {
                    Some(Some(msg)) => self.on_hub(msg).await?,
                    Some(None) => { self.admission.count_malformed(); debug!("dropped malformed sensor message"); }
                    None => return Ok(AgentExit::Stopped),
                },
                changed = self.hub_alive.changed() => {
                    let up = changed.is_ok() && *self.hub_alive.borrow();
                    match hub.on_change(up, changed.is_err(), grace) {
                        HubEvent::None => {}
                        HubEvent::Gone => return self.hub_gone().await,
                        HubEvent::Lost => {
                            warn!(grace_s = grace.as_secs_f64(), "hub lost: hovering, waiting for it to come back");
                            self.hover().await;
                            lost_deadline.as_mut().reset(tokio::time::Instant::now() + grace);
                        }
                    }
                },
                _ = &mut lost_deadline, if hub.lost => return self.hub_gone().await,
                _ = &mut hub_deadline, if !hub.seen => return Err(AgentError::NoHub(self.keys.prefix().to_string(), 30)),
                _ = &mut shutdown => { self.hover().await; return Ok(AgentExit::Stopped); }
            }
        }
    }

    async fn hub_gone(&mut self) -> Result<AgentExit, AgentError> {
        warn!("hub gone: hovering and exiting");
        self.hover().await;
        Ok(AgentExit::HubGone)
    }

    async fn hover(&mut self) {
        let tick = self.admission.last_tick().map_or(0, |t| t.saturating_add(1));
        let cmd = Cmd::hover(tick);
        let _ = self.command(&cmd, SimTime::of_tick(tick, self.dt_s).s()).await;
    }

    /// Sends a command of the tick at `t_s`: to the hub, or on ROS.
    async fn command(&mut self, cmd: &Cmd, t_s: f64) -> Result<(), AgentError> {
        if let Some(ros) = self.ros.as_mut() {
            return ros.command(cmd, t_s).await;
        }
        if let Some(w) = &self.publish.cmd {
            w.put(Msg::Cmd(*cmd).encode()?).await?;
        }
        Ok(())
    }

    /// Hands the shares posted since the last look to the admission, in arrival order, as each
    /// had been handled when it arrived. Taking them only when a hub message comes changes
    /// nothing the agent sees: every share of tick k arrives before any hub message of tick k+1
    /// (the sender's share goes out before its command, which the hub awaits), so each is handled
    /// before the radio set of tick k+1 moves the windows and before step k+1 takes what is due.
    fn take_shares(&mut self) {
        let mut posted = std::mem::take(&mut self.posted);
        self.mailbox.take_into(&mut posted);
        for arrived in posted.drain(..) {
            self.arrived = (self.arrived.0 + 1, self.arrived.1 + arrived.len as u64);
            self.admission.on_arrived(arrived);
        }
        self.posted = posted;
    }

    /// A message from the hub: a sensor frame (this tick's radio set, then the step) or the
    /// netem rules in force.
    async fn on_hub(&mut self, msg: Msg) -> Result<(), AgentError> {
        self.take_shares();
        self.admission.admit_early();
        match msg {
            Msg::Sense(wire) => {
                let tick = wire.radio.tick;
                match SensorFrame::from_wire(*wire, self.needs) {
                    Ok((radio, frame)) => {
                        self.on_radio(radio.tick, &radio.in_range, &radio.loss, frame.scan.t_s)?;
                        self.step(frame).await?;
                    }
                    Err(why) => {
                        self.admission.count_malformed();
                        debug!("dropped a malformed sensor frame: {why}");
                        if let Some(frames) = &self.shared.frames {
                            frames.skip(self.id, tick).await?;
                        }
                    }
                }
            }
            Msg::NetemRules(json) => self.on_netem_rules(&json),
            other => trace!(kind = other.kind(), "ignored"),
        }
        Ok(())
    }

    /// The radio set of `tick` (sim time `t_s`): listens to the shares of exactly the UAVs in
    /// range (see [`crate::admission`] for which of them count), and tells the agent whose links
    /// came up.
    fn on_radio(&mut self, tick: u64, in_range: &[UavId], loss: &[f32], t_s: f64) -> Result<(), AgentError> {
        let change = self.admission.on_radio(tick, in_range, loss);
        self.agent.links_came_up(&change.entered, t_s);
        for id in change.left {
            self.listening.remove(&id);
        }
        for id in change.entered {
            if let Some(listening) = self.shared.feed.listen(id, self.id, &self.mailbox)? {
                self.listening.insert(id, listening);
            }
        }
        Ok(())
    }

    /// The netem timeline in force changed (`swarm netem`).
    fn on_netem_rules(&mut self, json: &str) {
        match serde_json::from_str::<netem::Timeline>(json) {
            Ok(t) => {
                debug!(rules = t.rules().len(), failures = t.failures().len(), "netem timeline in force updated");
                self.admission.set_timeline(t);
            }
            Err(e) => {
                self.admission.count_malformed();
                warn!("malformed netem rules dropped: {e}");
            }
        }
    }

    /// Steps on the sensor frame of a tick.
    async fn step(&mut self, frame: SensorFrame) -> Result<(), AgentError> {
        let tick = frame.tick();
        let due =
            self.admission.begin_step(tick, frame.scan.t_s).map_err(|w| AgentError::TickWentBack(w.last, w.tick))?;
        for share in due {
            self.agent.on_share(&share);
        }
        let out = match self.external.as_mut() {
            None => self.agent.step(&frame),
            Some(ext) => {
                let counts = self.agent.counts();
                let seen = self.agent.perceive(&frame);
                let command = ext.ask(tick, &seen.view(self.id, &frame), counts).await?;
                self.agent.finish(&frame, seen, command)
            }
        };
        self.publish_step(out, frame.scan.t_s).await?;
        trace!(tick, "stepped");
        Ok(())
    }

    /// Publishes a step's share (through the link), command and state, in that order; in an
    /// agent host, the three into the host's messages of the tick when they wait for this step
    /// ([`super::frames`]).
    async fn publish_step(&mut self, out: StepOutput, t_s: f64) -> Result<(), AgentError> {
        let share = match out.share {
            Some(share) => {
                let bytes = share.into_msg().encode()?;
                self.admission.on_send(bytes.len()).then(|| (self.publish.share.clone(), bytes))
            }
            None => None,
        };
        let mut link = self.admission.report();
        let own = (self.arrived.0, self.arrived.1 + self.own_bytes.load(Ordering::Relaxed));
        link.traffic = self.shared.feed.traffic().snapshot(&self.shared.zid, own);
        let state = Box::new(out.report.into_state(link));
        let alone = match (&self.shared.frames, self.ros.is_none()) {
            (Some(frames), true) => frames.offer(self.id, share, out.cmd, state).await?,
            _ => Some((share, out.cmd, state)),
        };
        if let Some((share, cmd, state)) = alone {
            if let Some((writer, bytes)) = share {
                writer.put(bytes).await?;
                if let Some(ros) = &self.ros {
                    ros.order_after_share().await?;
                }
            }
            self.command(&cmd, t_s).await?;
            self.publish.state.put(Msg::State(state).encode()?).await?;
        }
        Ok(())
    }
}

/// What the run loop knows of the hub's liveliness.
struct HubWatch {
    /// The hub's token has been seen.
    seen: bool,
    /// The token went away and the grace period runs.
    lost: bool,
}

/// What a change of the hub's liveliness means for the run loop.
enum HubEvent {
    /// Nothing to do (the hub came, or came back).
    None,
    /// The hub is gone for good: hover and exit.
    Gone,
    /// The hub went away: hover and wait for it during the grace period.
    Lost,
}

impl HubWatch {
    /// The hub's token is now `up`; `closed` when the watch itself ended.
    fn on_change(&mut self, up: bool, closed: bool, grace: Duration) -> HubEvent {
        if up {
            if self.lost {
                info!("hub back");
            }
            self.seen = true;
            self.lost = false;
            HubEvent::None
        } else if closed || (self.seen && grace.is_zero()) {
            HubEvent::Gone
        } else if self.seen && !self.lost {
            self.lost = true;
            HubEvent::Lost
        } else {
            HubEvent::None
        }
    }
}

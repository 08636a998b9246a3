//! The agent on the network: a Zenoh client of the hub that feeds [`Agent`] and publishes what
//! it decides.
//!
//! - It fetches the scenario from the hub (`swarm/{run}/scenario`) unless given one, so an agent
//!   on another machine needs only the hub's endpoint, the run id and its UAV id.
//! - It subscribes to its own `sense/{scan,odom,gnss,uvdar}` and `radio/{id}` keys, and listens
//!   to the shares (`share/pose` or `share/obstacles`, by localization mode) of exactly the UAVs
//!   in its radio set, starting and stopping as the set changes. Its own keys are subscribed
//!   through declared key expressions ([`subscribe_declared`]), so an agent host's session hands
//!   each sensor message to its subscriber without testing every subscriber of the session. The
//!   shares come from the session's one subscription to every UAV's share key
//!   ([`crate::shared`]), which decodes each once and posts it to the mailboxes of the agents
//!   of the session listening to its sender, without waking them.
//! - Determinism in lockstep: the node's own subscriptions feed one channel, so hub messages are
//!   handled in wire order, and the shares posted meanwhile are taken, in arrival order, when the
//!   next hub message is handled ([`Node::take_shares`]); and a neighbour's share counts only if it was sent inside the neighbour's
//!   window: from the tick after this agent started listening to it (see [`crate::shared`]: every
//!   later share reaches the session's one subscription) to the tick before it left radio range. Which shares arrive no longer depends on timing. A share sent at
//!   a tick this agent has not stepped yet waits for the hub's next message before it is counted
//!   and passed to netem, so what each state message counts does not depend on timing either.
//! - Every share message in or out passes the [`netem::Link`] seam, which applies the scenario's
//!   `[[netem]]` rule in force for that link at the send time (loss, delay, jitter, ...); the
//!   survivors wait in an [`netem::Inbox`] until their sim-time delivery instant.
//! - It declares its `alive/uav/{id}` token after its subscriptions (so the hub, seeing the
//!   token, knows the agent will get tick 0) and watches `alive/hub`: when the hub goes, the agent
//!   commands hover and exits cleanly.

use crate::agent::{Agent, LinkReport, StepOutput};
use crate::localization::Share;
use crate::sensing::FrameCollector;
use crate::shared::{Arrived, Listening, Mailbox, SessionShared};
use std::collections::BTreeMap;
use std::future::Future;
use std::sync::Arc;
use std::time::Duration;
use swarm_config::{Scenario, ScenarioError, TimeMode};
use swarm_wire::plumbing::{self, Subscription as Subscriber};
use swarm_wire::session::{self, publisher, Role};
use swarm_wire::{Cmd, CmdKind, Keys, Msg, WireError};
use tokio::sync::{mpsc, watch};
use tracing::{debug, info, info_span, trace, warn, Instrument};
use zenoh::qos::CongestionControl;

/// Errors of an agent.
#[derive(Debug, thiserror::Error)]
pub enum AgentError {
    /// Zenoh or encoding trouble.
    #[error(transparent)]
    Wire(#[from] WireError),
    /// The scenario the hub served (or the one given) is invalid.
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    /// No hub answered in time.
    #[error("no hub for run `{0}` answered within {1} s")]
    NoHub(String, u64),
    /// The UAV id is not in the scenario.
    #[error("UAV id {0} is not in this scenario (ids 1..={1})")]
    BadId(u32, u32),
    /// The hub's ticks went backwards: another hub run took over the keys.
    #[error("tick went back from {0} to {1}: the hub restarted; start the agent again for the new run")]
    TickWentBack(u64, u64),
    /// An agent's task of an agent host panicked.
    #[error("the agent's task panicked: {0}")]
    Panicked(String),
}

/// Which UAV, which run, which hub.
#[derive(Debug, Clone, Default)]
pub struct AgentOptions {
    /// Run id.
    pub run: String,
    /// UAV id, 1-based.
    pub id: u32,
    /// Hub endpoints, e.g. `tcp/10.0.0.5:7447`.
    pub connect: Vec<String>,
    /// `KEY:JSON5` Zenoh config overrides.
    pub zenoh_cfg: Vec<String>,
    /// Use this scenario instead of fetching it from the hub.
    pub scenario: Option<Scenario>,
    /// How long to wait for a hub whose liveliness token went away before giving up [s]: its link
    /// may come back (Zenoh clients reconnect by themselves) or it may have stopped for good.
    pub hub_grace_s: f64,
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
    let span = info_span!("agent", uav_id = opts.id, run = %opts.run);
    let result = async {
        let sc = match opts.scenario.clone() {
            Some(sc) => sc,
            None => fetch_scenario(&s, &keys, &opts.run).await?,
        };
        let shared = SessionShared::open(&s, &keys, &sc).await?;
        fly(s.clone(), keys, shared, opts.id, sc, opts.hub_grace_s, shutdown).await
    }
    .instrument(span)
    .await;
    let _ = s.close().await;
    result
}

/// Flies UAV `id` of `sc` on session `s` (its own or shared with other agents of a host, with
/// what the session's agents share) until the hub goes away or `shutdown` resolves.
pub(crate) async fn fly(
    s: zenoh::Session,
    keys: Keys,
    shared: Arc<SessionShared>,
    id: u32,
    sc: Scenario,
    hub_grace_s: f64,
    shutdown: impl Future<Output = ()>,
) -> Result<AgentExit, AgentError> {
    if id == 0 || id > sc.swarm.count {
        return Err(AgentError::BadId(id, sc.swarm.count));
    }
    let mut node = Node::start(s, keys, shared, id, sc).await?;
    node.hub_grace_s = hub_grace_s;
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

type Publisher = zenoh::pubsub::Publisher<'static>;

/// What the node's own subscriptions deliver, in one channel so wire order is kept: a sensor,
/// radio or netem-rules message (`None`: malformed). Shares come through the [`Mailbox`].
type Incoming = Option<Msg>;

/// The subscriptions a node holds for its whole life (dropping one undeclares it).
struct Inputs {
    _sense: Vec<Subscriber>,
    _radio: Subscriber,
    _rules: Subscriber,
    _hub_watch: Subscriber,
}

/// The node's publishers.
struct Outputs {
    cmd: Publisher,
    share: Publisher,
    state: Publisher,
}

struct Node {
    s: zenoh::Session,
    /// See [`AgentOptions::hub_grace_s`].
    hub_grace_s: f64,
    keys: Keys,
    id: u32,
    dt: f64,
    agent: Agent,
    /// Assembles each tick's sensor frame from the sensor messages.
    sensors: FrameCollector,
    link: netem::Link,
    /// Shares are shared with the other listeners of the session (decoded once, see
    /// [`crate::shared`]) until one is delivered to the agent.
    inbox: netem::Inbox<Arc<Share>>,
    /// Shares sent at a tick this agent has not stepped yet, in arrival order, with their size.
    early: Vec<(Arc<Share>, usize)>,
    /// The netem timeline in force (the scenario's, then the hub's), applied to every share this
    /// agent receives.
    netem_rules: netem::Timeline,
    malformed: u64,
    /// Kept so the channel stays open for the node's life.
    _tx: mpsc::UnboundedSender<Incoming>,
    rx: mpsc::UnboundedReceiver<Incoming>,
    /// Where the session's share feed leaves the shares of the neighbours listened to.
    mailbox: Mailbox,
    /// The mailbox's last contents, drained (kept to reuse the buffer).
    posted: Vec<Arrived>,
    /// First tick whose share is accepted, per neighbour in radio range.
    windows: BTreeMap<u32, u64>,
    /// The radio's distance-dependent loss probability per neighbour in range.
    radio_loss: BTreeMap<u32, f64>,
    hub_alive: watch::Receiver<bool>,
    /// What the agents of this session share (the share feed, declared keys).
    shared: Arc<SessionShared>,
    neighbour_subs: BTreeMap<u32, Listening>,
    publish: Outputs,
    /// Last tick stepped, `None` before the first.
    last_tick: Option<u64>,
    _inputs: Inputs,
    _token: Option<zenoh::liveliness::LivelinessToken>,
}

/// Subscribes to the exact key `key` into `tx` (as [`plumbing::subscribe`]) through a key
/// expression declared on the session. Zenoh then routes each sample to this session by the
/// expression's id, and the session hands it to the subscribers cached on that resource; a
/// sample on an undeclared key is instead tested against every subscriber of the session, which
/// on an agent host of hundreds of agents (thousands of share subscriptions) was most of the
/// host's time. Only for this agent's own keys: a key several agents of a session declare
/// concurrently can reach the router out of order (see [`crate::shared`], which declares the
/// keys they share once for the whole session).
async fn subscribe_declared<T: Send + 'static>(
    s: &zenoh::Session,
    key: String,
    tx: mpsc::UnboundedSender<T>,
    map: impl Fn(&zenoh::sample::Sample) -> Option<T> + Send + Sync + 'static,
) -> Result<Subscriber, WireError> {
    let declared = s.declare_keyexpr(key).await.map_err(WireError::zenoh)?;
    plumbing::subscribe(s, declared, tx, map).await
}

/// Subscribes the node's own sensor, radio and netem-rule keys into `tx`, and watches the hub's
/// liveliness token.
async fn declare_inputs(
    s: &zenoh::Session,
    keys: &Keys,
    shared: &SessionShared,
    id: u32,
    tx: &mpsc::UnboundedSender<Incoming>,
) -> Result<(Inputs, watch::Receiver<bool>), AgentError> {
    // Decoded from the payload in place when it is contiguous (no copy of each scan).
    let decode = |sample: &zenoh::sample::Sample| Some(plumbing::decode(sample).ok());
    let mut sense_subs = Vec::with_capacity(4);
    for key in [keys.scan(id), keys.odom(id), keys.gnss(id), keys.uvdar(id)] {
        sense_subs.push(subscribe_declared(s, key, tx.clone(), decode).await?);
    }
    let radio_sub = subscribe_declared(s, keys.radio(id), tx.clone(), decode).await?;
    // The rules in force, republished by the hub whenever `swarm netem` changes them; on the key
    // the session declared once for all its agents.
    let rules_sub = plumbing::subscribe(s, shared.netem_rules.clone(), tx.clone(), decode).await?;
    let (hub_alive, hub_watch) = plumbing::watch_token(s, keys.alive_hub()).await?;
    Ok((Inputs { _sense: sense_subs, _radio: radio_sub, _rules: rules_sub, _hub_watch: hub_watch }, hub_alive))
}

/// Declares the command, share and state publishers of UAV `id`.
async fn declare_outputs(s: &zenoh::Session, keys: &Keys, id: u32, sc: &Scenario) -> Result<Outputs, AgentError> {
    let cc = match sc.time.mode {
        TimeMode::Lockstep => CongestionControl::Block,
        TimeMode::Realtime => CongestionControl::Drop,
    };
    // `uvdar` never shares (no communication): its publisher is on the pose key, and stays silent.
    let share_key = crate::localization::share_key(sc.localization.mode, keys, id).unwrap_or_else(|| keys.share_pose(id));
    Ok(Outputs {
        cmd: publisher(s, keys.cmd(id), CongestionControl::Block).await?,
        share: publisher(s, share_key, cc).await?,
        state: publisher(s, keys.state(id), cc).await?,
    })
}

impl Node {
    async fn start(s: zenoh::Session, keys: Keys, shared: Arc<SessionShared>, id: u32, sc: Scenario) -> Result<Node, AgentError> {
        let (tx, rx) = mpsc::unbounded_channel();
        let (inputs, hub_alive) = declare_inputs(&s, &keys, &shared, id, &tx).await?;
        let agent = Agent::new(id, sc.clone());
        let publish = declare_outputs(&s, &keys, id, &sc).await?;
        Ok(Node {
            sensors: agent.frame_collector(),
            link: netem::Link::with_seed(sc.seed, id),
            dt: sc.dt_secs(),
            netem_rules: netem::Timeline::from_scenario(&sc),
            agent,
            inbox: netem::Inbox::new(),
            early: Vec::new(),
            malformed: 0,
            _tx: tx,
            rx,
            mailbox: Mailbox::default(),
            posted: Vec::new(),
            windows: BTreeMap::new(),
            radio_loss: BTreeMap::new(),
            hub_grace_s: 0.0,
            hub_alive,
            shared,
            neighbour_subs: BTreeMap::new(),
            publish,
            last_tick: None,
            _inputs: inputs,
            _token: None,
            s,
            keys,
            id,
        })
    }

    async fn run_loop(mut self, shutdown: impl Future<Output = ()>) -> Result<AgentExit, AgentError> {
        tokio::pin!(shutdown);
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
                    Some(Some(msg)) => self.on_sense(msg).await?,
                    Some(None) => { self.malformed += 1; debug!("dropped malformed sensor message"); }
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
        let tick = self.last_tick.map_or(0, |t| t.saturating_add(1));
        let cmd = Cmd { tick, kind: CmdKind::Hover, x: 0.0, y: 0.0, yaw_rate: 0.0 };
        if let Ok(b) = Msg::Cmd(cmd).encode() {
            let _ = self.publish.cmd.put(b).await;
        }
    }

    /// Handles the shares posted since the last look, in arrival order, as each had been handled
    /// when it arrived. Taking them only when a hub message comes changes nothing the agent
    /// sees: every share of tick k arrives before any hub message of tick k+1 (the sender's
    /// share goes out before its command, which the hub awaits), so each is handled before the
    /// radio set of tick k+1 moves the windows and before step k+1 takes what is due, as it was;
    /// one taken before a message of tick k that it followed goes to `early` instead of being
    /// admitted after step k, and is admitted at the first message of tick k+1, with the same
    /// windows, radio loss and instant (see [`Node::admit_early`]).
    fn take_shares(&mut self) {
        let mut posted = std::mem::take(&mut self.posted);
        self.mailbox.take_into(&mut posted);
        for arrived in posted.drain(..) {
            self.on_share(arrived);
        }
        self.posted = posted;
    }

    /// A share message arrived from `from`. One sent at a tick this agent has not stepped yet
    /// waits in `early` for the hub's next message (see [`Node::admit_early`]); the others are
    /// admitted now.
    fn on_share(&mut self, arrived: Arrived) {
        let Arrived { from, share, len } = arrived;
        let Some(share) = share else {
            self.malformed += 1;
            debug!(from, len, "dropped malformed share");
            return;
        };
        if self.last_tick.is_none_or(|last| share.tick() > last) {
            self.early.push((share, len));
        } else {
            self.admit(share, len);
        }
    }

    /// Admits the shares that arrived before this agent stepped the tick they were sent at, once
    /// it has. A neighbour's share of tick k may reach us before or after our own step k,
    /// depending on which process ran first; counting it only after our step k (at the hub's
    /// next message, which comes after every share of tick k) makes what each state message
    /// counts the same in every lockstep run. Delivery is unchanged: a share is due one tick
    /// after it was sent at the earliest, whenever it is admitted.
    fn admit_early(&mut self) {
        let Some(last) = self.last_tick else { return };
        if self.early.iter().all(|(share, _)| share.tick() > last) {
            return;
        }
        let (due, later) = std::mem::take(&mut self.early).into_iter().partition(|(share, _)| share.tick() <= last);
        self.early = later;
        for (share, len) in due {
            self.admit(share, len);
        }
    }

    /// Counts a share, keeps it only inside the neighbour's window, lets the link decide, holds
    /// it in the inbox.
    fn admit(&mut self, share: Arc<Share>, len: usize) {
        let from = share.from();
        if self.windows.get(&from).is_none_or(|&first| share.tick() < first) {
            trace!(from, tick = share.tick(), "share outside the neighbour's window");
            return;
        }
        let now = self.last_tick.unwrap_or(0) as f64 * self.dt;
        let rule = self.netem_rules.rule_at(share.t_secs(), from, self.id);
        let radio_loss = self.radio_loss.get(&from).copied().unwrap_or(0.0);
        match self.link.on_receive_with(rule, radio_loss, from, share.t_secs(), now, self.dt, len) {
            netem::Verdict::DeliverAt(at) => self.inbox.push(at, share),
            netem::Verdict::DeliverTwice(a, b) => {
                self.inbox.push(a, share.clone());
                self.inbox.push(b, share);
            }
            netem::Verdict::Drop => trace!(from, "share dropped by netem"),
            netem::Verdict::Hold => self.inbox.push_held(share),
        }
    }

    /// Delivers, at `now`, every held share whose link no longer holds.
    fn release_held(&mut self, now: f64) {
        if self.inbox.held().next().is_none() {
            return;
        }
        // One rule lookup per sender that has held messages.
        let (rules, me) = (&self.netem_rules, self.id);
        let senders: std::collections::BTreeSet<u32> = self.inbox.held().map(|m| m.from()).collect();
        let open: Vec<u32> = senders.into_iter().filter(|&from| !rules.rule_at(now, from, me).is_some_and(|r| r.hold)).collect();
        let mut released = Vec::new();
        self.inbox.release(now, |m| {
            let go = open.contains(&m.from());
            if go {
                released.push(m.t_secs());
            }
            go
        });
        for sent_at in released {
            self.link.on_released(netem::LinkClass::Cut, sent_at, now);
        }
    }

    async fn on_sense(&mut self, msg: Msg) -> Result<(), AgentError> {
        self.take_shares();
        self.admit_early();
        match self.sensors.offer(msg) {
            None => {}
            Some(Msg::Radio(r)) => {
                self.radio_loss = r.in_range.iter().zip(&r.loss).map(|(&id, &p)| (id, f64::from(p))).collect();
                self.update_neighbour_subscriptions(r.tick, &r.in_range)
            }
            Some(Msg::NetemRules(json)) => self.on_netem_rules(&json),
            Some(other) => trace!(kind = other.kind(), "ignored"),
        }
        self.try_step().await
    }

    /// The netem timeline in force changed (`swarm netem`).
    fn on_netem_rules(&mut self, json: &str) {
        match serde_json::from_str::<netem::Timeline>(json) {
            Ok(t) => {
                debug!(rules = t.rules().len(), failures = t.failures().len(), "netem timeline in force updated");
                self.netem_rules = t;
            }
            Err(e) => {
                self.malformed += 1;
                warn!("malformed netem rules dropped: {e}");
            }
        }
    }

    /// Steps once the sensor frame of a tick is complete.
    async fn try_step(&mut self) -> Result<(), AgentError> {
        let Some(frame) = self.sensors.take_ready() else { return Ok(()) };
        let tick = frame.tick();
        if let Some(last) = self.last_tick.filter(|&last| tick <= last) {
            return Err(AgentError::TickWentBack(last, tick));
        }
        self.last_tick = Some(tick);
        self.deliver_due(frame.scan.t_secs);
        let out = self.agent.step(&frame);
        self.publish_step(out).await?;
        trace!(tick, "stepped");
        Ok(())
    }

    /// Hands the agent every share due by `now`.
    fn deliver_due(&mut self, now: f64) {
        self.release_held(now);
        let due = self.inbox.take_due(now);
        self.link.on_delivered(due.len());
        for share in due {
            self.agent.on_share(&share);
        }
    }

    /// Publishes a step's share (through the link), command and state, in that order.
    async fn publish_step(&mut self, out: StepOutput) -> Result<(), AgentError> {
        if let Some(share) = out.share {
            let bytes = share.into_msg().encode()?;
            if self.link.on_send(bytes.len()) {
                self.publish.share.put(bytes).await.map_err(WireError::zenoh)?;
            }
        }
        self.publish.cmd.put(Msg::Cmd(out.cmd).encode()?).await.map_err(WireError::zenoh)?;
        let state = out.report.into_state(self.link_report());
        self.publish.state.put(Msg::State(Box::new(state)).encode()?).await.map_err(WireError::zenoh)?;
        Ok(())
    }

    /// What the link measured since the last step, for the state message.
    fn link_report(&mut self) -> LinkReport {
        let c = self.link.counters();
        let counters = swarm_wire::LinkCounters {
            sent_msgs: c.sent_msgs,
            sent_bytes: c.sent_bytes,
            recv_msgs: c.recv_msgs,
            recv_bytes: c.recv_bytes,
            delivered_msgs: c.delivered_msgs,
            malformed: self.malformed,
            classes: c.classes.map(class_counts),
        };
        let delays = self
            .link
            .take_delays()
            .into_iter()
            .map(|d| swarm_wire::DelaySample { class: d.class as u8, delay_s: d.delay_s as f32 })
            .collect();
        LinkReport { in_radio_range: self.neighbour_subs.len() as u32, counters, delays }
    }

    /// Listens to the shares of exactly the UAVs in radio range at `tick`, and moves their
    /// acceptance windows (see the module doc).
    fn update_neighbour_subscriptions(&mut self, tick: u64, in_range: &[u32]) {
        let gone: Vec<u32> = self.neighbour_subs.keys().copied().filter(|id| !in_range.contains(id)).collect();
        for id in gone {
            self.neighbour_subs.remove(&id);
            self.windows.remove(&id);
            self.inbox.retain(|m| !(m.from() == id && m.tick() >= tick));
            debug!(neighbour = id, "stopped listening");
        }
        for &id in in_range {
            if id == self.id || self.neighbour_subs.contains_key(&id) {
                continue;
            }
            // None: the mode has no communication at all, nobody to listen to.
            let Some(listening) = self.shared.feed.listen(id, self.id, &self.mailbox) else {
                continue;
            };
            debug!(neighbour = id, "listening");
            self.neighbour_subs.insert(id, listening);
            self.windows.insert(id, tick.saturating_add(1));
        }
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

/// netem's counts of one link class in the wire's shape.
fn class_counts(c: netem::ClassCounters) -> swarm_wire::ClassCounts {
    use netem::Outcome::*;
    swarm_wire::ClassCounts {
        offered: c.get(Offered),
        delivered: c.get(Delivered),
        dropped: c.get(Dropped),
        duplicated: c.get(Duplicated),
        held: c.get(Held),
        released: c.get(Released),
    }
}

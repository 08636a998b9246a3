//! The agent on the network: a Zenoh client of the hub that feeds [`Agent`] and publishes what
//! it decides.
//!
//! - It fetches the scenario from the hub (`swarm/{run}/scenario`) unless given one, so an agent
//!   on another machine needs only the hub's endpoint, the run id and its UAV id.
//! - It subscribes to its own `sense/**` and `radio/{id}` keys, and to the share key of its
//!   localization mode (`share/pose` or `share/obstacles`) of exactly the UAVs in its radio set,
//!   declaring and undeclaring as the set changes.
//! - Determinism in lockstep: all subscriptions feed one channel, so messages are handled in
//!   wire order; and a neighbour's share counts only if it was sent inside the neighbour's
//!   window: from the tick after its subscription was declared (every later share is sure to be
//!   routed to us, since the declaration reached the router before our command did) to the tick
//!   before it left radio range. Which shares arrive no longer depends on timing.
//! - Every share message in or out passes the [`netem::Link`] seam, which applies the scenario's
//!   `[[netem]]` rule in force for that link at the send time (loss, delay, jitter, ...); the
//!   survivors wait in an [`netem::Inbox`] until their sim-time delivery instant.
//! - It declares its `alive/uav/{id}` token after its subscriptions (so the hub, seeing the
//!   token, knows the agent will get tick 0) and watches `alive/hub`: when the hub goes, the agent
//!   commands hover and exits cleanly.

use crate::agent::{Agent, Share};
use std::collections::BTreeMap;
use std::future::Future;
use std::time::Duration;
use swarm_config::{LocalizationMode, Scenario, ScenarioError, TimeMode};
use swarm_wire::session::{self, Role};
use swarm_wire::{Cmd, CmdKind, Gnss, Keys, Msg, Odom, Scan, WireError};
use tokio::sync::{mpsc, watch};
use tracing::{debug, info, info_span, trace, warn, Instrument};
use swarm_wire::session::publisher;
use zenoh::qos::CongestionControl;
use zenoh::sample::SampleKind;

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
        if opts.id == 0 || opts.id > sc.swarm.count {
            return Err(AgentError::BadId(opts.id, sc.swarm.count));
        }
        let mut node = Node::start(s.clone(), keys, opts.id, sc).await?;
        node.hub_grace_s = opts.hub_grace_s;
        node.run_loop(shutdown).await
    }
    .instrument(span)
    .await;
    let _ = s.close().await;
    result
}

async fn fetch_scenario(s: &zenoh::Session, keys: &Keys, run: &str) -> Result<Scenario, AgentError> {
    const WAIT_SECS: u64 = 30;
    let deadline = tokio::time::Instant::now() + Duration::from_secs(WAIT_SECS);
    while tokio::time::Instant::now() < deadline {
        let replies = s
            .get(keys.scenario())
            .timeout(Duration::from_secs(2))
            .await
            .map_err(WireError::zenoh)?;
        while let Ok(reply) = replies.recv_async().await {
            if let Ok(sample) = reply.result() {
                let text = String::from_utf8_lossy(&sample.payload().to_bytes()).into_owned();
                return Ok(Scenario::from_toml_str(&text, &format!("hub:{}", keys.scenario()))?);
            }
        }
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
    Err(AgentError::NoHub(run.to_string(), WAIT_SECS))
}

type Publisher = zenoh::pubsub::Publisher<'static>;

/// Everything the subscriptions deliver, in one channel so wire order is kept.
enum Incoming {
    /// A sensor or radio message (`None`: malformed).
    Sense(Option<Msg>),
    /// A neighbour's share: sender id and raw payload.
    Share(u32, Vec<u8>),
}

struct Node {
    s: zenoh::Session,
    /// See [`AgentOptions::hub_grace_s`].
    hub_grace_s: f64,
    keys: Keys,
    id: u32,
    dt: f64,
    agent: Agent,
    link: netem::Link,
    inbox: netem::Inbox<Share>,
    mode: LocalizationMode,
    /// The netem timeline in force (the scenario's, then the hub's), applied to every share this
    /// agent receives.
    netem_rules: netem::Timeline,
    malformed: u64,
    tx: mpsc::UnboundedSender<Incoming>,
    rx: mpsc::UnboundedReceiver<Incoming>,
    /// First tick whose share is accepted, per neighbour in radio range.
    windows: BTreeMap<u32, u64>,
    /// The radio's distance-dependent loss probability per neighbour in range.
    radio_loss: BTreeMap<u32, f64>,
    hub_alive: watch::Receiver<bool>,
    neighbour_subs: BTreeMap<u32, zenoh::pubsub::Subscriber<()>>,
    cmd_pub: Publisher,
    share_pub: Publisher,
    state_pub: Publisher,
    odom: Option<Odom>,
    gnss: Option<Gnss>,
    scan: Option<Scan>,
    needs_gnss: bool,
    /// `uvdar` mode: a step waits for the tick's onboard relative sensing too.
    needs_uvdar: bool,
    uvdar: Option<swarm_wire::Uvdar>,
    /// Last tick stepped, `None` before the first.
    last_tick: Option<u64>,
    _sense_sub: zenoh::pubsub::Subscriber<()>,
    _radio_sub: zenoh::pubsub::Subscriber<()>,
    _rules_sub: zenoh::pubsub::Subscriber<()>,
    _hub_watch: zenoh::pubsub::Subscriber<()>,
    _token: Option<zenoh::liveliness::LivelinessToken>,
}

impl Node {
    async fn start(s: zenoh::Session, keys: Keys, id: u32, sc: Scenario) -> Result<Node, AgentError> {
        let cc = match sc.time.mode {
            TimeMode::Lockstep => CongestionControl::Block,
            TimeMode::Realtime => CongestionControl::Drop,
        };
        let (tx, rx) = mpsc::unbounded_channel();
        let (sense_tx, radio_tx, rules_tx) = (tx.clone(), tx.clone(), tx.clone());
        let decode = |bytes: &[u8]| Incoming::Sense(Msg::decode(bytes).ok());
        let sense_sub = s
            .declare_subscriber(keys.sense_all(id))
            .callback(move |sample| {
                let _ = sense_tx.send(decode(&sample.payload().to_bytes()));
            })
            .await
            .map_err(WireError::zenoh)?;
        let radio_sub = s
            .declare_subscriber(keys.radio(id))
            .callback(move |sample| {
                let _ = radio_tx.send(decode(&sample.payload().to_bytes()));
            })
            .await
            .map_err(WireError::zenoh)?;
        // The rules in force, republished by the hub whenever `swarm netem` changes them.
        let rules_sub = s
            .declare_subscriber(keys.netem_rules())
            .callback(move |sample| {
                let _ = rules_tx.send(decode(&sample.payload().to_bytes()));
            })
            .await
            .map_err(WireError::zenoh)?;
        let (hub_tx, hub_alive) = watch::channel(false);
        let hub_watch = s
            .liveliness()
            .declare_subscriber(keys.alive_hub())
            .history(true)
            .callback(move |sample| {
                let _ = hub_tx.send(sample.kind() == SampleKind::Put);
            })
            .await
            .map_err(WireError::zenoh)?;
        let node = Node {
            cmd_pub: publisher(&s, keys.cmd(id), CongestionControl::Block).await?,
            share_pub: match sc.localization.mode {
                // `uvdar` never shares (no communication): the pose key stays silent.
                LocalizationMode::Broadcast | LocalizationMode::Uvdar => publisher(&s, keys.share_pose(id), cc).await?,
                LocalizationMode::Icp => publisher(&s, keys.share_obstacles(id), cc).await?,
            },
            needs_uvdar: sc.localization.mode == LocalizationMode::Uvdar,
            uvdar: None,
            state_pub: publisher(&s, keys.state(id), cc).await?,
            needs_gnss: sc.localization.mode == LocalizationMode::Broadcast,
            mode: sc.localization.mode,
            netem_rules: netem::Timeline::from_scenario(&sc),
            link: netem::Link::with_seed(sc.seed, id),
            dt: sc.dt_secs(),
            agent: Agent::new(id, sc),
            inbox: netem::Inbox::new(),
            malformed: 0,
            tx,
            rx,
            windows: BTreeMap::new(),
            radio_loss: BTreeMap::new(),
            hub_grace_s: 0.0,
            hub_alive,
            neighbour_subs: BTreeMap::new(),
            odom: None,
            gnss: None,
            scan: None,
            last_tick: None,
            _sense_sub: sense_sub,
            _radio_sub: radio_sub,
            _rules_sub: rules_sub,
            _hub_watch: hub_watch,
            _token: None,
            s,
            keys,
            id,
        };
        Ok(node)
    }

    async fn run_loop(mut self, shutdown: impl Future<Output = ()>) -> Result<AgentExit, AgentError> {
        tokio::pin!(shutdown);
        // Subscriptions are in place: now tell the hub we are here.
        let token = self.s.liveliness().declare_token(self.keys.alive_uav(self.id)).await.map_err(WireError::zenoh)?;
        self._token = Some(token);
        info!("agent up");
        let hub_deadline = tokio::time::sleep(Duration::from_secs(30));
        tokio::pin!(hub_deadline);
        let mut hub_seen = *self.hub_alive.borrow();
        // While the hub is lost: when to give up.
        let grace = Duration::from_secs_f64(self.hub_grace_s.max(0.0));
        let lost_deadline = tokio::time::sleep(Duration::ZERO);
        tokio::pin!(lost_deadline);
        let mut hub_lost = false;
        loop {
            tokio::select! {
                m = self.rx.recv() => match m {
                    Some(Incoming::Sense(Some(msg))) => self.on_sense(msg).await?,
                    Some(Incoming::Sense(None)) => { self.malformed += 1; debug!("dropped malformed sensor message"); }
                    Some(Incoming::Share(from, bytes)) => self.on_share(from, &bytes),
                    None => return Ok(AgentExit::Stopped),
                },
                changed = self.hub_alive.changed() => {
                    let up = changed.is_ok() && *self.hub_alive.borrow();
                    if up {
                        if hub_lost { info!("hub back"); }
                        hub_seen = true;
                        hub_lost = false;
                    } else if changed.is_err() || (hub_seen && grace.is_zero()) {
                        return self.hub_gone().await;
                    } else if hub_seen && !hub_lost {
                        warn!(grace_s = grace.as_secs_f64(), "hub lost: hovering, waiting for it to come back");
                        self.hover().await;
                        hub_lost = true;
                        lost_deadline.as_mut().reset(tokio::time::Instant::now() + grace);
                    }
                },
                _ = &mut lost_deadline, if hub_lost => return self.hub_gone().await,
                _ = &mut hub_deadline, if !hub_seen => return Err(AgentError::NoHub(self.keys.prefix().to_string(), 30)),
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
            let _ = self.cmd_pub.put(b).await;
        }
    }

    /// A share message arrived from `from`: count it, keep it only inside the neighbour's
    /// window, let the link decide, hold it in the inbox.
    fn on_share(&mut self, from: u32, bytes: &[u8]) {
        let share = match Msg::decode(bytes) {
            Ok(Msg::Pose(p)) if p.from == from => Share::Pose(p),
            Ok(Msg::Obstacles(o)) if o.from == from => Share::Obstacles(o),
            other => {
                self.malformed += 1;
                debug!(from, ?other, "dropped malformed share");
                return;
            }
        };
        if self.windows.get(&from).is_none_or(|&first| share.tick() < first) {
            trace!(from, tick = share.tick(), "share outside the neighbour's window");
            return;
        }
        let now = self.last_tick.unwrap_or(0) as f64 * self.dt;
        let rule = self.netem_rules.rule_at(share.t_secs(), from, self.id);
        let radio_loss = self.radio_loss.get(&from).copied().unwrap_or(0.0);
        match self.link.on_receive_with(rule, radio_loss, from, share.t_secs(), now, self.dt, bytes.len()) {
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
        let senders: std::collections::BTreeSet<u32> = self.inbox.held().map(Share::from).collect();
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
        match msg {
            Msg::Radio(r) => {
                self.radio_loss = r.in_range.iter().zip(&r.loss).map(|(&id, &p)| (id, f64::from(p))).collect();
                self.update_neighbour_subscriptions(r.tick, &r.in_range).await?
            }
            Msg::Odom(o) => self.odom = Some(o),
            Msg::Gnss(g) => self.gnss = Some(g),
            Msg::Uvdar(u) => self.uvdar = Some(u),
            Msg::Scan(s) => self.scan = Some(s),
            Msg::NetemRules(json) => match serde_json::from_str::<netem::Timeline>(&json) {
                Ok(t) => {
                    debug!(rules = t.rules().len(), failures = t.failures().len(), "netem timeline in force updated");
                    self.netem_rules = t;
                }
                Err(e) => {
                    self.malformed += 1;
                    warn!("malformed netem rules dropped: {e}");
                }
            },
            other => trace!(kind = other.kind(), "ignored"),
        }
        self.try_step().await
    }

    /// Steps once the scan, odometry (and GNSS in broadcast mode) of the same tick are in.
    async fn try_step(&mut self) -> Result<(), AgentError> {
        let Some(scan) = &self.scan else { return Ok(()) };
        let tick = scan.tick;
        let odom_ready = self.odom.as_ref().is_some_and(|o| o.tick == tick);
        let gnss_ready = !self.needs_gnss || self.gnss.as_ref().is_some_and(|g| g.tick == tick);
        let uvdar_ready = !self.needs_uvdar || self.uvdar.as_ref().is_some_and(|u| u.tick == tick);
        if !(odom_ready && gnss_ready && uvdar_ready) {
            return Ok(());
        }
        let Some(scan) = self.scan.take() else { return Ok(()) };
        if let Some(last) = self.last_tick.filter(|&last| tick <= last) {
            return Err(AgentError::TickWentBack(last, tick));
        }
        self.last_tick = Some(tick);
        self.release_held(scan.t_secs);
        let due = self.inbox.take_due(scan.t_secs);
        self.link.on_delivered(due.len());
        for share in due {
            self.agent.on_share(share);
        }
        let Some(odom) = self.odom else { return Ok(()) };
        let gnss = self.gnss.filter(|g| g.tick == tick);
        if let Some(u) = self.uvdar.take().filter(|u| u.tick == tick) {
            self.agent.on_uvdar(u);
        }
        let mut out = self.agent.step(&scan, &odom, gnss.as_ref());
        if let Some(share) = out.share {
            let bytes = share.into_msg().encode()?;
            if self.link.on_send(bytes.len()) {
                self.share_pub.put(bytes).await.map_err(WireError::zenoh)?;
            }
        }
        self.cmd_pub.put(Msg::Cmd(out.cmd).encode()?).await.map_err(WireError::zenoh)?;
        let c = self.link.counters();
        out.state.in_radio_range = self.neighbour_subs.len() as u32;
        out.state.link = swarm_wire::LinkCounters {
            sent_msgs: c.sent_msgs,
            sent_bytes: c.sent_bytes,
            recv_msgs: c.recv_msgs,
            recv_bytes: c.recv_bytes,
            delivered_msgs: c.delivered_msgs,
            malformed: self.malformed,
            classes: c.classes.map(class_counts),
        };
        out.state.delays = self
            .link
            .take_delays()
            .into_iter()
            .map(|d| swarm_wire::DelaySample { class: d.class as u8, delay_s: d.delay_s as f32 })
            .collect();
        self.state_pub.put(Msg::State(Box::new(out.state)).encode()?).await.map_err(WireError::zenoh)?;
        trace!(tick, "stepped");
        Ok(())
    }

    /// Subscribes to the share keys of exactly the UAVs in radio range at `tick`, and moves their
    /// acceptance windows (see the module doc).
    async fn update_neighbour_subscriptions(&mut self, tick: u64, in_range: &[u32]) -> Result<(), AgentError> {
        let gone: Vec<u32> = self.neighbour_subs.keys().copied().filter(|id| !in_range.contains(id)).collect();
        for id in gone {
            self.neighbour_subs.remove(&id);
            self.windows.remove(&id);
            self.inbox.retain(|m| !(m.from() == id && m.tick() >= tick));
            debug!(neighbour = id, "unsubscribed");
        }
        for &id in in_range {
            if id == self.id || self.neighbour_subs.contains_key(&id) {
                continue;
            }
            let tx = self.tx.clone();
            let key = match self.mode {
                LocalizationMode::Broadcast => self.keys.share_pose(id),
                LocalizationMode::Icp => self.keys.share_obstacles(id),
                // No communication at all: nobody to subscribe to.
                LocalizationMode::Uvdar => continue,
            };
            let sub = self
                .s
                .declare_subscriber(key)
                .callback(move |sample| {
                    let _ = tx.send(Incoming::Share(id, sample.payload().to_bytes().into_owned()));
                })
                .await
                .map_err(WireError::zenoh)?;
            debug!(neighbour = id, "subscribed");
            self.neighbour_subs.insert(id, sub);
            self.windows.insert(id, tick.saturating_add(1));
        }
        Ok(())
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

//! The hub on the network: a Zenoh router that runs [`Sim`] and speaks the lockstep protocol.
//!
//! One tick k in `lockstep` mode (SPEC section 2, refined):
//! 1. publish the clock, then every UAV's sensor frame (radio set, odometry, GNSS in broadcast
//!    mode, UVDAR in uvdar mode and the scan, in one message on `uav/{id}/sense`; the frames of
//!    an agent host holding `alive/host/{ids}` together on `host/{ids}/sense`, [`crate::batch`]);
//! 2. wait until every agent holding a liveliness token has sent its command for tick k (alone on
//!    `uav/{id}/cmd`, or among an agent host's in one message on `host/{ids}/cmd`), or
//!    `time.tick_timeout_ms` passes (a missing agent keeps its last command; a UAV whose agent
//!    lost its liveliness token hovers);
//! 3. integrate to t_{k+1} and publish `truth/step` (the last one carries `ended`).
//!
//! In `realtime` mode step 2 is a wall-clock wait of dt / `realtime_factor`, and whatever
//! commands arrived meanwhile are used. The hub holds the `alive/hub` token, which agents watch,
//! and answers `swarm/{run}/scenario` with the scenario text so agents elsewhere need no file.
//!
//! The hub's session is its router's own, so the keys it declares are resources of the router
//! (see [`declare_agent_keys`]): besides its own, it declares every key the agents publish on, so
//! the router routes each agent's put from a cached route instead of matching its key against
//! the whole key space every time (agents write without declaring publishers; see
//! `swarm_wire::session::Writer`).

use crate::batch::{Batches, Route};
use crate::lateness::Lateness;
use crate::sim::{Sim, Stepped};
use std::collections::{BTreeMap, BTreeSet};
use std::future::Future;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use swarm_config::{Scenario, TimeMode};
use swarm_types::UavId;
use swarm_wire::plumbing::{self, Subscription};
use swarm_wire::session::{self, Role, Writer};
use swarm_wire::{Cmd, CmdKind, EndReason, HubTiming, Keys, Msg, TruthStep, WireError};
use tokio::sync::{mpsc, Notify};
use tracing::{debug, info, info_span, trace, warn, Instrument};
use zenoh::qos::CongestionControl;
use zenoh::Wait;

/// Errors of the hub.
#[derive(Debug, thiserror::Error)]
pub enum HubError {
    /// Zenoh or encoding trouble.
    #[error(transparent)]
    Wire(#[from] WireError),
    /// Not one agent came alive before the startup timeout.
    #[error("no agent came alive within {0:.0} s (is `swarm agent` pointed at this hub and run id?)")]
    NoAgents(f64),
}

/// Where the hub listens and which run it serves.
#[derive(Debug, Clone, Default)]
pub struct HubOptions {
    /// Run id: every key is under `swarm/{run}`.
    pub run: String,
    /// Endpoints to listen on, e.g. `tcp/127.0.0.1:0`.
    pub listen: Vec<String>,
    /// Other routers to connect to (optional).
    pub connect: Vec<String>,
    /// `KEY:JSON5` Zenoh config overrides.
    pub zenoh_cfg: Vec<String>,
}

/// What a finished run looked like from the hub.
#[derive(Debug, Clone)]
pub struct HubReport {
    /// Ticks integrated.
    pub ticks: u64,
    /// Sim time at the end [s].
    pub t_s: f64,
    /// Why it ended.
    pub end: EndReason,
    /// Malformed command payloads dropped.
    pub malformed: u64,
    /// Well-formed commands no agent of this run could have sent, dropped: for a UAV id outside
    /// the scenario, or (not a hover) for a tick the hub has not opened yet.
    pub ignored: u64,
}

/// Realtime pacing: the wall-clock instant of each next tick, `real_dt` apart.
struct Pacer {
    next_wall: tokio::time::Instant,
    real_dt: Duration,
}

impl Pacer {
    fn new(real_dt_secs: f64) -> Pacer {
        Pacer { next_wall: tokio::time::Instant::now(), real_dt: Duration::from_secs_f64(real_dt_secs) }
    }

    /// When the next tick is due. After a stall, pacing starts again from now instead of
    /// bursting the missed ticks.
    fn next(&mut self) -> tokio::time::Instant {
        self.next_wall = (self.next_wall + self.real_dt).max(tokio::time::Instant::now());
        self.next_wall
    }
}

struct Net {
    session: zenoh::Session,
    keys: Keys,
    clock: Writer,
    truth_world: Writer,
    truth_step: Writer,
    /// Each UAV's `uav/{id}/sense` writer, in id order.
    sense: Vec<Writer>,
    /// The agent hosts holding `alive/host/{ids}` now, each its UAVs (see [`crate::batch`]).
    hosts: Arc<Mutex<BTreeSet<Vec<UavId>>>>,
    /// Each host's `host/{ids}/sense` writer, made when it first gets frames.
    host_writers: BTreeMap<Vec<UavId>, Writer>,
    /// The scenario's time mode (the sensor writers' congestion control).
    time_mode: TimeMode,
    alive: Arc<Mutex<BTreeSet<UavId>>>,
    /// Bumped (under the `alive` lock) on every change of `alive`: the barrier re-reads the set
    /// only when this moved, so its cost per command does not grow with the agents.
    alive_gen: Arc<AtomicU64>,
    alive_changed: Arc<Notify>,
    /// The commands of each message (one, or an agent host's), each with the wall instant it
    /// arrived.
    cmds: mpsc::UnboundedReceiver<Vec<Incoming>>,
    lateness: Lateness,
    malformed: Arc<AtomicU64>,
    ignored: Arc<AtomicU64>,
    netem_rules: Writer,
    netem_added: mpsc::UnboundedReceiver<Vec<u8>>,
}

async fn put(p: &Writer, msg: &Msg) -> Result<(), WireError> {
    p.put(msg.encode()?).await
}

/// Runs the hub until the scenario's end condition or `shutdown`. `on_listening` receives the
/// locators the router listens on (with real ports) as soon as they are known. Needs a
/// multi-thread Tokio runtime: a tick publishes its sensors inside `block_in_place`.
pub async fn run(
    sc: Scenario,
    scenario_text: String,
    opts: HubOptions,
    on_listening: impl FnOnce(&[String]),
    shutdown: impl Future<Output = ()>,
) -> Result<HubReport, HubError> {
    let keys = Keys::new(&opts.run)?;
    let s = session::open(Role::Router, &opts.listen, &opts.connect, &opts.zenoh_cfg).await?;
    on_listening(&session::locators(&s).await);
    let _token = s.liveliness().declare_token(keys.alive_hub()).await.map_err(WireError::zenoh)?;
    let _scenario_q = declare_scenario_queryable(&s, &keys, scenario_text).await?;
    let mut sim = Sim::new(&sc);
    let _world_q = declare_world_queryable(&s, &keys, Msg::TruthWorld(sim.truth_world()).encode()?).await?;
    let (net, _subs) = Net::declare(s, keys, &sc).await?;
    let span = info_span!("hub", run = %opts.run);
    let session = net.session.clone();
    let result = net.run_loop(&sc, &mut sim, shutdown).instrument(span).await;
    // Let the last truth step drain to the recorder before the router goes away.
    tokio::time::sleep(Duration::from_millis(300)).await;
    session.close().await.map_err(WireError::zenoh)?;
    result
}

async fn declare_scenario_queryable(
    s: &zenoh::Session,
    keys: &Keys,
    text: String,
) -> Result<zenoh::query::Queryable<()>, WireError> {
    s.declare_queryable(keys.scenario())
        .callback(move |q| {
            if let Err(e) = q.reply(q.key_expr().clone(), text.clone()).wait() {
                warn!("scenario reply failed: {e}");
            }
        })
        .await
        .map_err(WireError::zenoh)
}

async fn declare_world_queryable(
    s: &zenoh::Session,
    keys: &Keys,
    bytes: Vec<u8>,
) -> Result<zenoh::query::Queryable<()>, WireError> {
    s.declare_queryable(keys.truth_world())
        .callback(move |q| {
            if let Err(e) = q.reply(q.key_expr().clone(), bytes.clone()).encoding(session::encoding()).wait() {
                warn!("world reply failed: {e}");
            }
        })
        .await
        .map_err(WireError::zenoh)
}

/// Subscriptions that must live as long as the loop.
struct Subs {
    _cmd: [Subscription; 2],
    _alive: Subscription,
    _hosts: Subscription,
    _netem: Subscription,
    /// See [`declare_agent_keys`].
    _agent_keys: Vec<zenoh::key_expr::KeyExpr<'static>>,
}

/// The sensor-frame writer of every UAV of the scenario, in id order.
async fn sense_writers(s: &zenoh::Session, keys: &Keys, sc: &Scenario) -> Result<Vec<Writer>, WireError> {
    let sensors_cc = swarm_wire::session::congestion(sc.time.mode);
    let mut writers = Vec::with_capacity(sc.count());
    for id in sc.uav_ids() {
        writers.push(Writer::new(s, keys.sense(id), sensors_cc).await?);
    }
    Ok(writers)
}

/// The UAV id in `key` when it is one of the scenario's `1..=count`: ids are checked at the door,
/// so only those ever reach the loop.
fn valid_id(keys: &Keys, count: usize, key: &str) -> Option<UavId> {
    keys.uav_id_of(key).filter(|&id| id.within(count))
}

/// Whether `c` answers a tick after `tick` without being a hover (an agent's parting word may
/// carry any tick): no agent can have seen that tick's sensors, so it is counted in `ignored`
/// and dropped.
fn from_the_future(ignored: &AtomicU64, tick: u64, c: &Cmd) -> bool {
    let future = c.tick > tick && c.kind != CmdKind::Hover;
    if future {
        ignored.fetch_add(1, Ordering::Relaxed);
        debug!(cmd_tick = c.tick, tick, "command for a tick not yet opened ignored");
    }
    future
}

/// A command, its UAV and when it came.
type Incoming = (UavId, Cmd, Instant);

/// Every agent's commands, decoded, into one channel, a message's at once: each UAV's alone
/// (`uav/*/cmd`) and an agent host's in one message (`host/*/cmd`). Malformed messages are
/// counted in `bad`; commands for UAVs outside the scenario, or in a host's message for a UAV
/// its key does not name, in `ignored`.
///
/// Why a host's commands go as one item: sent one by one, each send could wake the tick's
/// barrier ([`Net::collect_lockstep`]) parked on the channel, which took them one or a few at a
/// time while the receiving thread went on sending (forest-1000-icp after the placements: 8 390
/// wake-ups of the hub's main thread in 5 s, most of them by Zenoh's receiving threads; 2 167
/// with one item a message).
async fn subscribe_cmds(
    s: &zenoh::Session,
    keys: &Keys,
    count: usize,
    bad: Arc<AtomicU64>,
    ignored: Arc<AtomicU64>,
) -> Result<([Subscription; 2], mpsc::UnboundedReceiver<Vec<Incoming>>), WireError> {
    let (cmd_tx, cmds) = mpsc::unbounded_channel();
    let k = keys.clone();
    let (bad2, ignored2, tx2) = (bad.clone(), ignored.clone(), cmd_tx.clone());
    let alone = plumbing::subscribe(s, keys.cmd_any(), cmd_tx, move |sample| {
        let id = valid_id(&k, count, sample.key_expr().as_str());
        match (id, plumbing::decode(sample)) {
            (Some(id), Ok(Msg::Cmd(c))) => Some(vec![(id, c, Instant::now())]),
            (None, _) => {
                ignored.fetch_add(1, Ordering::Relaxed);
                debug!(key = %sample.key_expr(), "command for a UAV not in this scenario ignored");
                None
            }
            (_, other) => {
                bad.fetch_add(1, Ordering::Relaxed);
                debug!(key = %sample.key_expr(), ?other, "dropped malformed command");
                None
            }
        }
    })
    .await?;
    let k = keys.clone();
    let host = s
        .declare_subscriber(keys.host_cmd_any())
        .callback(move |sample| {
            let at = Instant::now();
            let ids = k.host_ids_of(sample.key_expr().as_str());
            match (ids, plumbing::decode(&sample)) {
                (Some(ids), Ok(Msg::Cmds(cmds))) => {
                    let mut taken = Vec::with_capacity(cmds.len());
                    for u in cmds {
                        if u.id.within(count) && ids.binary_search(&u.id).is_ok() {
                            taken.push((u.id, u.cmd, at));
                        } else {
                            ignored2.fetch_add(1, Ordering::Relaxed);
                            debug!(key = %sample.key_expr(), uav_id = %u.id, "a host's command for a UAV it does not fly ignored");
                        }
                    }
                    if !taken.is_empty() {
                        let _ = tx2.send(taken);
                    }
                }
                (ids, other) => {
                    bad2.fetch_add(1, Ordering::Relaxed);
                    debug!(key = %sample.key_expr(), named = ids.is_some(), ?other, "dropped malformed host commands");
                }
            }
        })
        .await
        .map_err(WireError::zenoh)?;
    Ok(([alone, host], cmds))
}

/// Declares, on the hub's session, every key the agents of `sc` publish on: each UAV's command,
/// state and share keys. The hub's session lives in its router, so each declaration makes the key
/// a resource of the router with its matching subscriptions computed and its route cached; an
/// agent's put arrives with the key spelled out (its session declared the key to itself, not to
/// the router), finds that resource, and takes the cached route. Without it, the router matched
/// every command and state message of 1000 agents against its whole key space (53 % of the
/// hub's CPU in `Resource::get_matches`, `perf`, open-1000 in 100 processes). Kept for the
/// hub's life.
async fn declare_agent_keys(
    s: &zenoh::Session,
    keys: &Keys,
    sc: &Scenario,
) -> Result<Vec<zenoh::key_expr::KeyExpr<'static>>, WireError> {
    let mut declared = Vec::with_capacity(sc.count() * 3);
    for id in sc.uav_ids() {
        let share = keys.share_of(sc.localization.mode, id);
        for key in [Some(keys.cmd(id)), Some(keys.state(id)), share].into_iter().flatten() {
            declared.push(s.declare_keyexpr(key).await.map_err(WireError::zenoh)?);
        }
    }
    Ok(declared)
}

/// Keeps `alive` equal to the set of agents holding a liveliness token, and notifies `changed`
/// on every change.
async fn watch_agents(
    s: &zenoh::Session,
    keys: &Keys,
    count: usize,
    alive: Arc<Mutex<BTreeSet<UavId>>>,
    alive_gen: Arc<AtomicU64>,
    changed: Arc<Notify>,
) -> Result<Subscription, WireError> {
    let k = keys.clone();
    plumbing::on_tokens(s, keys.alive_uav_any(), move |key, up| {
        let Some(id) = valid_id(&k, count, key) else {
            warn!(key = %key, "liveliness token of a UAV not in this scenario ignored");
            return;
        };
        let mut set = alive.lock().unwrap_or_else(|p| p.into_inner());
        if up {
            info!(uav_id = %id, "agent alive");
            set.insert(id);
        } else {
            info!(uav_id = %id, "agent gone");
            set.remove(&id);
        }
        alive_gen.fetch_add(1, Ordering::SeqCst);
        changed.notify_one();
    })
    .await
}

/// Keeps `hosts` equal to the agent hosts holding an `alive/host/{ids}` token, each its UAVs as
/// its key names them (those outside the scenario are never sensed, so never sent there).
async fn watch_hosts(
    s: &zenoh::Session,
    keys: &Keys,
    hosts: Arc<Mutex<BTreeSet<Vec<UavId>>>>,
) -> Result<Subscription, WireError> {
    let k = keys.clone();
    plumbing::on_tokens(s, keys.alive_host_any(), move |key, up| {
        let Some(ids) = k.host_ids_of(key) else {
            warn!(key = %key, "a host token that names no UAVs ignored");
            return;
        };
        info!(uavs = ids.len(), up, "agent host");
        let mut set = hosts.lock().unwrap_or_else(|p| p.into_inner());
        match up {
            true => set.insert(ids),
            false => set.remove(&ids),
        };
    })
    .await
}

impl Net {
    async fn declare(s: zenoh::Session, keys: Keys, sc: &Scenario) -> Result<(Net, Subs), WireError> {
        let sense = sense_writers(&s, &keys, sc).await?;
        let agent_keys = declare_agent_keys(&s, &keys, sc).await?;
        let malformed = Arc::new(AtomicU64::new(0));
        let ignored = Arc::new(AtomicU64::new(0));
        let (cmd_sub, cmds) = subscribe_cmds(&s, &keys, sc.count(), malformed.clone(), ignored.clone()).await?;
        let alive = Arc::new(Mutex::new(BTreeSet::new()));
        let alive_changed = Arc::new(Notify::new());
        let alive_gen = Arc::new(AtomicU64::new(0));
        let alive_sub =
            watch_agents(&s, &keys, sc.count(), alive.clone(), alive_gen.clone(), alive_changed.clone()).await?;
        let hosts = Arc::new(Mutex::new(BTreeSet::new()));
        let hosts_sub = watch_hosts(&s, &keys, hosts.clone()).await?;
        let (added_tx, netem_added) = mpsc::unbounded_channel();
        let netem_sub = plumbing::subscribe_payloads(&s, keys.netem_add(), added_tx).await?;
        let net = Net {
            netem_rules: Writer::new(&s, keys.netem_rules(), CongestionControl::Block).await?,
            netem_added,
            clock: Writer::new(&s, keys.clock(), CongestionControl::Block).await?,
            truth_world: Writer::new(&s, keys.truth_world(), CongestionControl::Block).await?,
            truth_step: Writer::new(&s, keys.truth_step(), CongestionControl::Block).await?,
            session: s,
            keys,
            sense,
            hosts,
            host_writers: BTreeMap::new(),
            time_mode: sc.time.mode,
            alive,
            alive_gen,
            alive_changed,
            cmds,
            lateness: Lateness::default(),
            malformed,
            ignored,
        };
        Ok((
            net,
            Subs { _cmd: cmd_sub, _alive: alive_sub, _hosts: hosts_sub, _netem: netem_sub, _agent_keys: agent_keys },
        ))
    }

    fn alive_now(&self) -> BTreeSet<UavId> {
        self.alive.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }

    async fn wait_for_agents(&self, sc: &Scenario) -> Result<(), HubError> {
        let deadline = Instant::now() + Duration::from_secs_f64(sc.time.startup_timeout_s);
        let expected = sc.agent_ids().count();
        info!(expected, "waiting for agents");
        loop {
            let n = self.alive_now().len();
            if n >= expected {
                info!(alive = n, "all agents alive");
                return Ok(());
            }
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return if n == 0 {
                    Err(HubError::NoAgents(sc.time.startup_timeout_s))
                } else {
                    warn!(alive = n, expected, "starting without every agent");
                    Ok(())
                };
            }
            let _ = tokio::time::timeout(left.min(Duration::from_millis(200)), self.alive_changed.notified()).await;
        }
    }

    async fn run_loop(
        mut self,
        sc: &Scenario,
        sim: &mut Sim,
        shutdown: impl Future<Output = ()>,
    ) -> Result<HubReport, HubError> {
        tokio::pin!(shutdown);
        tokio::select! {
            r = self.wait_for_agents(sc) => r?,
            _ = &mut shutdown => return self.finish(sim, EndReason::Stopped, Instant::now()).await,
        }
        put(&self.truth_world, &Msg::TruthWorld(sim.truth_world())).await?;
        self.publish_rules(sim).await?;
        let started = Instant::now();
        let mut pacer = Pacer::new(sim.clock().dt_s / sc.time.realtime_factor);
        loop {
            let next_t = sim.t_s() + sim.clock().dt_s;
            self.take_added_rules(sc, sim, next_t).await?;
            let sent = self.alive_now();
            if sent.is_empty() {
                warn!("no agent alive");
                return self.finish(sim, EndReason::NoAgents, started).await;
            }
            let sensors_from = Instant::now();
            self.publish_sensors(sim, &sent).await?;
            let sensors = sensors_from.elapsed();
            let got = tokio::select! {
                got = self.collect(sc, sim.tick(), &sent, &mut pacer) => got,
                _ = &mut shutdown => return self.finish(sim, EndReason::Stopped, started).await,
            };
            let integrate_from = Instant::now();
            self.lateness.close(sim.tick(), integrate_from);
            let step = self.integrate(sc, sim, &got, started);
            let ended = step.ended;
            let timing = self.lateness.take(sensors + integrate_from.elapsed());
            self.publish_step(step.with_timing(timing)).await?;
            if let Some(end) = ended {
                return self.report(sim, end);
            }
        }
    }

    /// Step 2 of a tick: the commands to integrate, by the scenario's time mode.
    async fn collect(
        &mut self,
        sc: &Scenario,
        tick: u64,
        sent: &BTreeSet<UavId>,
        pacer: &mut Pacer,
    ) -> BTreeMap<UavId, Cmd> {
        match sc.time.mode {
            TimeMode::Lockstep => {
                self.collect_lockstep(tick, sent, Duration::from_millis(sc.time.tick_timeout_ms)).await
            }
            TimeMode::Realtime => {
                tokio::time::sleep_until(pacer.next()).await;
                self.collect_available(tick)
            }
        }
    }

    /// Step 3 of a tick: integrate the commands `got` (a UAV without one keeps its last).
    fn integrate(&self, sc: &Scenario, sim: &mut Sim, got: &BTreeMap<UavId, Cmd>, started: Instant) -> Stepped {
        let cmds: Vec<Option<Cmd>> = sc.uav_ids().map(|id| got.get(&id).copied()).collect();
        let alive = self.alive_now();
        let alive_flags: Vec<bool> = sc.uav_ids().map(|id| alive.contains(&id)).collect();
        let step = sim.step(&cmds, &alive_flags, started.elapsed().as_secs_f64());
        trace!(tick = step.tick, "stepped");
        for c in &step.collisions {
            warn!(uav_id = %c.id, other = ?c.other_uav, t = step.t_s, "collision");
        }
        step
    }

    /// Timelines added by `swarm netem` count their times from `not_before` (the next tick);
    /// every change is published on `netem/rules` before this tick's sensors, so agents apply it
    /// in wire order, and added freezes reach the simulation. Invalid additions are counted,
    /// logged and dropped whole.
    async fn take_added_rules(&mut self, sc: &Scenario, sim: &mut Sim, not_before: f64) -> Result<(), WireError> {
        let mut changed = false;
        while let Ok(bytes) = self.netem_added.try_recv() {
            let (json, parsed) = match Msg::decode(&bytes) {
                Ok(Msg::NetemRules(json)) => {
                    let t = serde_json::from_str::<swarm_config::Timeline>(&json).map_err(|e| e.to_string());
                    (Some(json), t)
                }
                other => (None, Err(format!("not a NetemRules message: {other:?}"))),
            };
            let checked = parsed.and_then(|t| sc.check_timeline(&t, true).map(|()| t));
            if let Some(json) = json {
                self.acknowledge(json, checked.as_ref().err().map(String::as_str), not_before).await;
            }
            let mut t = match checked {
                Ok(t) => t,
                Err(e) => {
                    self.malformed.fetch_add(1, Ordering::Relaxed);
                    warn!("netem timeline refused: {e}");
                    continue;
                }
            };
            t.netem.iter_mut().for_each(|r| r.at_s += not_before);
            t.failures.iter_mut().for_each(|f| f.at_s += not_before);
            info!(rules = t.netem.len(), failures = t.failures.len(), from_s = not_before, "netem timeline added");
            sim.extend_timeline(t);
            changed = true;
        }
        if changed {
            self.publish_rules(sim).await?;
        }
        Ok(())
    }

    /// Answers a timeline that came on `netem/add` on `netem/ack`: accepted from sim time `from_s`,
    /// or refused and why (`swarm netem` waits for it). A failed answer is only logged: the
    /// timeline stands.
    async fn acknowledge(&self, timeline: String, refused: Option<&str>, from_s: f64) {
        let ack = swarm_wire::NetemAck {
            timeline,
            accepted: refused.is_none(),
            reason: refused.unwrap_or_default().to_string(),
            from_s: refused.is_none().then_some(from_s),
        };
        let Ok(json) = serde_json::to_vec(&ack) else { return };
        let put = self.session.put(self.keys.netem_ack(), json).encoding(zenoh::bytes::Encoding::APPLICATION_JSON);
        if let Err(e) = put.await {
            warn!("cannot answer a netem timeline: {e}");
        }
    }

    /// Publishes the timeline in force (the simulation's: the scenario's plus every addition).
    async fn publish_rules(&self, sim: &Sim) -> Result<(), WireError> {
        let json = serde_json::to_string(sim.timeline()).map_err(|e| WireError::zenoh(e.to_string()))?;
        put(&self.netem_rules, &Msg::NetemRules(json)).await
    }

    /// Step 1 of a tick: the clock, then every live UAV's sensors, an agent host's in one
    /// message ([`crate::batch`]): those that go alone first, then the hosts' UAVs in turn
    /// ([`Batches::order`]). The sensors are computed and encoded on worker threads
    /// while this thread publishes the UAVs already done ([`Sim::sensors_each`]); the puts are
    /// synchronous, inside `block_in_place`, so the runtime's other worker keeps taking commands
    /// meanwhile.
    async fn publish_sensors(&mut self, sim: &mut Sim, alive: &BTreeSet<UavId>) -> Result<(), WireError> {
        put(&self.clock, &Msg::Clock(sim.clock())).await?;
        let ids: Vec<UavId> = alive.iter().copied().filter(|&id| id.within(self.sense.len())).collect();
        let hosts: Vec<Vec<UavId>> = self.hosts.lock().unwrap_or_else(|p| p.into_inner()).iter().cloned().collect();
        for host in &hosts {
            if !self.host_writers.contains_key(host) {
                let cc = swarm_wire::session::congestion(self.time_mode);
                let w = Writer::new(&self.session, self.keys.host_sense(host), cc).await?;
                self.host_writers.insert(host.clone(), w);
            }
        }
        let mut batches = Batches::new(&hosts, &ids);
        let order = batches.order(&ids);
        let this = &*self;
        tokio::task::block_in_place(|| {
            sim.sensors_each(
                &order,
                |_, s| Msg::Sense(Box::new(s)).encode(),
                |id, e| match batches.take(id, e?) {
                    // Blocking puts (the caller is inside `block_in_place`), unlike `put` above.
                    Route::Alone(frame) => this.sense[id.index()].put_now(frame),
                    Route::Held => Ok(()),
                    Route::Complete(h, frames) => match this.host_writers.get(&hosts[h]) {
                        Some(w) => w.put_now(Msg::senses_from_encoded(&frames)?),
                        None => Ok(()),
                    },
                },
            )
        })
    }

    /// Waits for the command of tick `tick` from every agent that was `sent` this tick's sensors
    /// and is still alive, or the timeout. Commands already queued are taken before each check,
    /// so an agent's last word (its hover) is never lost to the liveliness change that follows it.
    /// The set still awaited is kept up to date per command, and recomputed from the live set
    /// only when that changed, so a tick costs O(agents · log agents), not O(agents²).
    async fn collect_lockstep(&mut self, tick: u64, sent: &BTreeSet<UavId>, timeout: Duration) -> BTreeMap<UavId, Cmd> {
        let deadline = tokio::time::Instant::now() + timeout;
        let mut got = BTreeMap::new();
        let mut waiting = BTreeSet::new();
        let mut seen_gen = None;
        let ignored = self.ignored.clone();
        // The commands of one message (one agent's, or an agent host's).
        let take = |got: &mut BTreeMap<UavId, Cmd>,
                    waiting: &mut BTreeSet<UavId>,
                    lateness: &mut Lateness,
                    message: Vec<Incoming>| {
            for (id, c, at) in message {
                if from_the_future(&ignored, tick, &c) {
                    continue;
                }
                lateness.command(c.tick, at);
                // A hover is an agent's last word before it leaves: it counts whatever its tick.
                if c.tick == tick || (c.kind == CmdKind::Hover && c.tick > tick) {
                    got.insert(id, c);
                    waiting.remove(&id);
                } else {
                    trace!(uav_id = %id, cmd_tick = c.tick, tick, "late command ignored");
                }
            }
        };
        loop {
            while let Ok(message) = self.cmds.try_recv() {
                take(&mut got, &mut waiting, &mut self.lateness, message);
            }
            let generation = self.alive_gen.load(Ordering::SeqCst);
            if seen_gen != Some(generation) {
                // Read the generation before the set: a change after this read is seen next time.
                seen_gen = Some(generation);
                let alive = self.alive_now();
                waiting = sent.intersection(&alive).copied().filter(|id| !got.contains_key(id)).collect();
            }
            if waiting.is_empty() {
                return got;
            }
            tokio::select! {
                message = self.cmds.recv() => match message {
                    Some(message) => take(&mut got, &mut waiting, &mut self.lateness, message),
                    None => return got,
                },
                _ = self.alive_changed.notified() => {},
                _ = tokio::time::sleep_until(deadline) => {
                    debug!(tick, missing = ?waiting, "tick timeout");
                    return got;
                }
            }
        }
    }

    /// Realtime: the newest command of each agent that arrived since the last tick (a late one
    /// is used too, and counted by [`Lateness`]).
    fn collect_available(&mut self, tick: u64) -> BTreeMap<UavId, Cmd> {
        let mut got = BTreeMap::new();
        while let Ok(message) = self.cmds.try_recv() {
            for (id, c, at) in message {
                if from_the_future(&self.ignored, tick, &c) {
                    continue;
                }
                self.lateness.command(c.tick, at);
                got.insert(id, c);
            }
        }
        got
    }

    /// Publishes a truth step (moved into the message: at 1000 UAVs a copy is a thousand bodies).
    async fn publish_step(&self, step: TruthStep) -> Result<(), WireError> {
        put(&self.truth_step, &Msg::TruthStep(step)).await
    }

    /// Ends the run where it stands: the last truth step is the current state, not integrated.
    async fn finish(&self, sim: &mut Sim, end: EndReason, started: Instant) -> Result<HubReport, HubError> {
        let alive = self.alive_now();
        let alive_flags: Vec<bool> = UavId::all(sim.bodies().len()).map(|id| alive.contains(&id)).collect();
        let step = sim.observe(&[], &alive_flags, Vec::new(), Some(end), started.elapsed().as_secs_f64());
        self.publish_step(step.with_timing(HubTiming::default())).await?;
        self.report(sim, end)
    }

    fn report(&self, sim: &Sim, end: EndReason) -> Result<HubReport, HubError> {
        info!(?end, ticks = sim.tick(), t = sim.t_s(), keys = self.keys.prefix(), "run ended");
        Ok(HubReport {
            ticks: sim.tick(),
            t_s: sim.t_s(),
            end,
            malformed: self.malformed.load(Ordering::Relaxed),
            ignored: self.ignored.load(Ordering::Relaxed),
        })
    }
}

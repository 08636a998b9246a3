//! The bridge of one run: one more client of the hub's router (logged in as `bridge`) that reads
//! the run's keys and writes the ROS 2 graph a ROS user expects, on DDS or on rmw_zenoh
//! ([`swarm_ros2::Graph`]), and takes the commands that come back.
//!
//! Out, per tick: `/clock` from the hub's clock; per UAV from its sensor frame `/uav{id}/goal`
//! (informed UAVs), `/uav{id}/odom`, `/uav{id}/scan` and its `/tf` (`uav{id}/odom` ->
//! `uav{id}/base_link`); from its agent's state `/uav{id}/neighbours`. With truth: `/tf_static`
//! and `/world/markers`, sent again every few seconds (rmw_zenoh has no transient local here).
//!
//! In: for an external UAV (the scenario's `controller.external`) the bridge is its external
//! controller and answers each view with the newest `/uav{id}/cmd_vel` (Twist or TwistStamped),
//! zero before the first and once the newest is older than half a second (a ROS driver's usual
//! guard: a teleop that stops must not leave the UAV flying). For a vehicle (a UAV whose agent
//! reads its sensors from these topics, `swarm agent --sensors ros2`) the bridge is the body's
//! driver: each stamped command (`cmd_vel` TwistStamped, `cmd_accel` AccelStamped) becomes the
//! UAV's command on `uav/{id}/cmd` for the tick its stamp names, which is what keeps such a run
//! in lockstep.

use super::world;
use anyhow::{Context, Result};
use std::collections::{BTreeMap, BTreeSet};
use std::time::{Duration, Instant};
use swarm_config::Scenario;
use swarm_ros2::msgs::command::{pose_stamped, Stamped, Twist};
use swarm_ros2::msgs::frames::{clock, pose_array, tf_message, Transform};
use swarm_ros2::msgs::sensor::{laser_scan, odometry};
use swarm_ros2::msgs::Header;
use swarm_ros2::types::{
    ACCEL_STAMPED, CLOCK, LASER_SCAN, MARKER_ARRAY, ODOMETRY, POSE_ARRAY, POSE_STAMPED, TF_MESSAGE, TWIST,
    TWIST_STAMPED,
};
use swarm_ros2::{Graph, Middleware, NodeRef, Publisher, Qos, SubscriptionGuard};
use swarm_types::UavId;
use swarm_wire::external::{ExtCmd, ExtCmdKind};
use swarm_wire::plumbing::{self, Subscription};
use swarm_wire::session::{self, Role};
use swarm_wire::{AgentState, Cmd, CmdKind, Keys, Msg, SenseFrame, TruthWorld, WireError};
use tokio::sync::{mpsc, watch};
use tracing::{info, warn};
use zenoh::liveliness::LivelinessToken;
use zenoh::qos::CongestionControl;

/// What a bridge is asked to do.
#[derive(Debug, Clone, Default)]
pub struct BridgeOptions {
    /// Run id.
    pub run: String,
    /// The hub's endpoints.
    pub connect: Vec<String>,
    /// Zenoh overrides (the login among them).
    pub cfg: Vec<String>,
    /// ROS domain.
    pub domain: u32,
    /// DDS instead of rmw_zenoh; on loopback only if `localhost_only`.
    pub dds: bool,
    /// See `dds`.
    pub localhost_only: bool,
    /// Publish the truth topics on DDS too (rmw_zenoh's router lets only logins that may read
    /// truth have them; DDS lets anyone).
    pub truth: bool,
    /// The UAVs whose bodies this bridge drives for agents on ROS topics.
    pub vehicles: Vec<UavId>,
}

/// What reaches the bridge, in one channel.
enum Event {
    /// The hub's clock, and when the hub put it (ns since the Unix epoch; see [`source_ns`]).
    Clock(swarm_wire::Clock, Option<i64>),
    /// A UAV's sensor frame, and when the hub put it.
    Sense(UavId, Box<SenseFrame>, Option<i64>),
    /// An agent's state, and when the agent put it.
    State(UavId, Box<AgentState>, Option<i64>),
    /// An external UAV's view (JSON).
    View(UavId, Vec<u8>),
    /// A command from ROS for UAV `id`.
    Command(UavId, CommandTopic, Vec<u8>),
}

/// The ROS topics a command comes on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum CommandTopic {
    /// `cmd_vel`, `geometry_msgs/msg/Twist`.
    Twist,
    /// `cmd_vel`, `geometry_msgs/msg/TwistStamped`.
    TwistStamped,
    /// `cmd_accel`, `geometry_msgs/msg/AccelStamped`.
    AccelStamped,
}

impl CommandTopic {
    fn name(self) -> &'static str {
        match self {
            CommandTopic::Twist => "cmd_vel Twist",
            CommandTopic::TwistStamped => "cmd_vel TwistStamped",
            CommandTopic::AccelStamped => "cmd_accel AccelStamped",
        }
    }
}

/// One UAV's publishers.
struct UavTopics {
    scan: Publisher,
    odom: Publisher,
    goal: Option<Publisher>,
    neighbours: Publisher,
}

/// The bridge of one run.
pub struct Bridge {
    session: zenoh::Session,
    keys: Keys,
    sc: Scenario,
    graph: Graph,
    rx: mpsc::UnboundedReceiver<Event>,
    hub_alive: watch::Receiver<bool>,
    _subs: Vec<Subscription>,
    _ros_subs: Vec<SubscriptionGuard>,
    _tokens: Vec<LivelinessToken>,
    clock: Publisher,
    tf: Publisher,
    /// `/tf_static` and `/world/markers`, with the world they show, when truth may go out.
    truth: Option<(Publisher, Publisher, Box<TruthWorld>)>,
    uavs: BTreeMap<UavId, UavTopics>,
    vehicles: BTreeSet<UavId>,
    /// The newest Twist of each external UAV, and when it came.
    twists: BTreeMap<UavId, (Twist, Instant)>,
    /// The newest tick each vehicle's sensor frame named (a plain Twist for a vehicle answers it).
    vehicle_ticks: BTreeMap<UavId, u64>,
    /// Payloads on a command or view key that were not their message.
    malformed: u64,
    /// Messages published on ROS so far.
    published: u64,
}

/// How long a cmd_vel Twist holds (wall clock).
const CMD_VEL_TIMEOUT: Duration = Duration::from_millis(500);

/// How long a vehicle's sensor topics wait for its agent's subscription.
const MATCH_WAIT: Duration = Duration::from_secs(3);

/// How often the latched truth topics are sent again.
const TRUTH_PERIOD: Duration = Duration::from_secs(2);

/// The one field of a view the bridge needs.
#[derive(serde::Deserialize)]
struct ViewTick {
    tick: u64,
}

impl Bridge {
    /// Connects, fetches the run's scenario (and, for truth, its world), declares the ROS graph
    /// and subscribes to what it bridges.
    pub async fn start(o: &BridgeOptions) -> Result<Bridge> {
        let keys = Keys::new(&o.run)?;
        let s =
            session::open(Role::Client, &[], &o.connect, &o.cfg).await.context("the bridge cannot open its session")?;
        let text = plumbing::fetch_scenario_text(&s, &keys, Duration::from_secs(30)).await?;
        let sc = Scenario::from_toml_str(&text, &format!("hub:{}", keys.scenario()))?;
        for &id in &o.vehicles {
            anyhow::ensure!(
                sc.uav_ids().any(|u| u == id),
                "vehicle UAV {id} is not in the scenario (ids 1..={})",
                sc.count()
            );
        }
        let middleware =
            if o.dds { Middleware::Dds { localhost_only: o.localhost_only } } else { Middleware::Zenoh(s.clone()) };
        let mw = middleware.name();
        let mut graph = Graph::open(middleware, o.domain).await?;
        let (tx, rx) = mpsc::unbounded_channel();
        let mut subs = run_subscriptions(&s, &keys, &tx).await?;
        let vehicles: BTreeSet<UavId> = o.vehicles.iter().copied().collect();

        let root = graph.node("/", "swarm_bridge").await?;
        let clock = graph.publisher(root, "/clock", CLOCK, Qos::CLOCK).await?;
        let tf = graph.publisher(root, "/tf", TF_MESSAGE, Qos::TF).await?;
        let truth = if o.truth || !o.dds {
            let world = fetch_world(&s, &keys).await?;
            let tf_static = graph.publisher(root, "/tf_static", TF_MESSAGE, Qos::LATCHED).await?;
            let markers = graph.publisher(root, "/world/markers", MARKER_ARRAY, Qos::LATCHED).await?;
            Some((tf_static, markers, world))
        } else {
            None
        };
        let mut uavs = BTreeMap::new();
        let mut ros_subs = Vec::new();
        let mut tokens = Vec::new();
        let lockstep = sc.time.mode == swarm_config::TimeMode::Lockstep;
        for id in sc.uav_ids() {
            let node = graph.node(&format!("/uav{id}"), "swarm").await?;
            uavs.insert(id, uav_topics(&mut graph, node, (id, lockstep), sc.is_informed(id)).await?);
            let external = sc.controller.external.contains(&id);
            if external || vehicles.contains(&id) {
                ros_subs.extend(command_subscriptions(&mut graph, node, id, vehicles.contains(&id), &tx).await?);
            }
            if external {
                subs.push(
                    plumbing::subscribe(&s, keys.ext_view(id), tx.clone(), move |x| {
                        Some(Event::View(id, plumbing::payload(x)))
                    })
                    .await?,
                );
                tokens.push(s.liveliness().declare_token(keys.alive_ext(id)).await.map_err(WireError::zenoh)?);
            }
        }
        graph.announce()?;
        let (hub_alive, hub_sub) = plumbing::watch_token(&s, keys.alive_hub()).await?;
        subs.push(hub_sub);
        info!(
            middleware = mw,
            domain = o.domain,
            uavs = sc.count(),
            external = ?sc.controller.external,
            vehicles = ?o.vehicles,
            truth = truth.is_some(),
            "ROS 2 bridge up"
        );
        Ok(Bridge {
            session: s,
            keys,
            sc,
            graph,
            rx,
            hub_alive,
            _subs: subs,
            _ros_subs: ros_subs,
            _tokens: tokens,
            clock,
            tf,
            truth,
            uavs,
            vehicles,
            twists: BTreeMap::new(),
            vehicle_ticks: BTreeMap::new(),
            malformed: 0,
            published: 0,
        })
    }

    /// Bridges until the hub's token goes away (after it was seen).
    pub async fn run(mut self) -> Result<()> {
        let mut truth_timer = tokio::time::interval(TRUTH_PERIOD);
        loop {
            tokio::select! {
                ev = self.rx.recv() => match ev {
                    // One failed put must not take every external UAV's controller with it.
                    Some(ev) => if let Err(e) = self.on_event(ev).await {
                        warn!("ROS 2 bridge: {e:#}");
                    },
                    None => break,
                },
                _ = truth_timer.tick() => if let Err(e) = self.publish_truth().await {
                    warn!("ROS 2 bridge: {e:#}");
                },
                // The token only ever goes down after it was up: a change to down is the end.
                changed = self.hub_alive.changed() => {
                    if changed.is_err() || !*self.hub_alive.borrow() {
                        break;
                    }
                }
            }
        }
        info!(
            malformed = self.malformed,
            published = self.published,
            domain = self.graph.domain(),
            "ROS 2 bridge done: the hub is gone"
        );
        let _ = self.session.close().await;
        Ok(())
    }

    async fn publish_truth(&mut self) -> Result<()> {
        let Some((tf_static, markers, world)) = &self.truth else { return Ok(()) };
        tf_static.put(world::static_transforms(world, 0.0)).await?;
        markers.put(world::markers(world, self.sc.end.goal_radius_m, 0.0)).await?;
        self.published += 2;
        Ok(())
    }

    async fn on_event(&mut self, ev: Event) -> Result<()> {
        match ev {
            Event::Clock(c, at) => {
                self.clock.put_at(clock(c.t_s), at).await?;
                self.published += 1;
            }
            Event::Sense(id, f, at) => self.on_sense(id, &f, at).await?,
            Event::State(id, st, at) => {
                if let Some(u) = self.uavs.get(&id) {
                    let poses: Vec<(f64, f64, f64)> =
                        st.neighbours.iter().map(|n| (f64::from(n.x), f64::from(n.y), f64::from(n.heading))).collect();
                    let header = Header::new(st.t_s, format!("uav{id}/base_link"));
                    u.neighbours.put_at(pose_array(&header, &poses), at).await?;
                    self.published += 1;
                }
            }
            Event::Command(id, topic, bytes) => self.on_command(id, topic, &bytes).await?,
            Event::View(id, bytes) => match serde_json::from_slice::<ViewTick>(&bytes) {
                Ok(v) => self.answer(id, v.tick).await?,
                Err(_) => self.dropped(id, "ext/view"),
            },
        }
        Ok(())
    }

    /// A UAV's sensor frame: its goal, odometry, scan and transform, in that order (an agent on
    /// ROS topics steps once it has all of a tick).
    async fn on_sense(&mut self, id: UavId, f: &SenseFrame, at: Option<i64>) -> Result<()> {
        let Some(u) = self.uavs.get(&id) else { return Ok(()) };
        if self.vehicles.contains(&id) {
            // Its agent steps on what it gets: a volatile sample written before the agent's
            // subscription matched would never reach it (DDS discovery takes a moment at the
            // start), and the hub waits for the tick meanwhile.
            for p in [Some(&u.scan), Some(&u.odom), u.goal.as_ref()].into_iter().flatten() {
                if !p.wait_matched(MATCH_WAIT).await {
                    warn!(uav_id = %id, "no agent subscribes to this vehicle's sensor topics yet");
                }
            }
        }
        let (odom_frame, base) = (format!("uav{id}/odom"), format!("uav{id}/base_link"));
        let t = f.odom.t_s;
        if let (Some(p), Some(g)) = (&u.goal, f.odom.goal) {
            p.put_at(pose_stamped(&Header::new(t, odom_frame.clone()), g[0], g[1], 0.0), at).await?;
        }
        u.odom.put_at(odometry(&f.odom, &odom_frame, &base), at).await?;
        u.scan.put_at(laser_scan(&f.scan, &base, self.sc.dt_s() as f32), at).await?;
        let tf =
            Transform { header: Header::new(t, odom_frame), child: base, x: f.odom.x, y: f.odom.y, yaw: f.odom.yaw };
        self.tf.put_at(tf_message(&[tf]), at).await?;
        self.published += 3 + u64::from(u.goal.is_some());
        if self.vehicles.contains(&id) {
            self.vehicle_ticks.insert(id, f.tick());
        }
        Ok(())
    }

    /// A command from ROS: kept for an external UAV's next view, or sent to the hub at once
    /// for a vehicle.
    async fn on_command(&mut self, id: UavId, topic: CommandTopic, bytes: &[u8]) -> Result<()> {
        let (twist, stamp) = match topic {
            CommandTopic::Twist => (Twist::decode(bytes).ok(), None),
            CommandTopic::TwistStamped | CommandTopic::AccelStamped => match Stamped::decode(bytes) {
                Ok(s) => (Some(s.twist), Some(s.header.stamp_s)),
                Err(_) => (None, None),
            },
        };
        let Some(twist) = twist.filter(Twist::is_finite) else {
            self.dropped(id, topic.name());
            return Ok(());
        };
        if !self.vehicles.contains(&id) {
            if topic != CommandTopic::AccelStamped {
                self.twists.insert(id, (twist, Instant::now()));
            }
            return Ok(());
        }
        let tick = match stamp {
            Some(t) => (t / self.sc.dt_s()).round() as u64,
            None => self.vehicle_ticks.get(&id).copied().unwrap_or(0),
        };
        let kind = if topic == CommandTopic::AccelStamped { CmdKind::Acceleration } else { CmdKind::Velocity };
        let cmd =
            Cmd { tick, kind, x: twist.linear[0] as f32, y: twist.linear[1] as f32, yaw_rate: twist.angular[2] as f32 };
        plumbing::put_once(&self.session, &self.keys.cmd(id), Msg::Cmd(cmd).encode()?, CongestionControl::Block)
            .await?;
        Ok(())
    }

    /// Counts a payload that was not its message; says so the first time, then every 1000th.
    fn dropped(&mut self, id: UavId, what: &str) {
        self.malformed += 1;
        if self.malformed % 1000 == 1 {
            warn!(
                uav_id = %id,
                malformed = self.malformed,
                "malformed {what} payload dropped (counted; said every 1000th)"
            );
        }
    }

    /// Answers the view of `tick` of external UAV `id` with its newest Twist, or zero when none
    /// came in the last [`CMD_VEL_TIMEOUT`].
    async fn answer(&self, id: UavId, tick: u64) -> Result<()> {
        let fresh = self.twists.get(&id).filter(|(_, at)| at.elapsed() <= CMD_VEL_TIMEOUT);
        let t = fresh.map(|(t, _)| *t).unwrap_or_default();
        let cmd = ExtCmd { tick, kind: ExtCmdKind::Velocity, x: t.linear[0], y: t.linear[1], yaw_rate: t.angular[2] };
        let json = serde_json::to_vec(&cmd)?;
        Ok(self.session.put(self.keys.ext_cmd(id), json).await.map_err(WireError::zenoh)?)
    }
}

/// The run keys the bridge reads: the clock, every sensor frame, every agent's state.
async fn run_subscriptions(
    s: &zenoh::Session,
    keys: &Keys,
    tx: &mpsc::UnboundedSender<Event>,
) -> Result<Vec<Subscription>> {
    let [alone, hosts] =
        plumbing::subscribe_frames(s, keys, tx.clone(), |id, f, x| Some(Event::Sense(id, f, source_ns(x)))).await?;
    let [state, host_states] =
        plumbing::subscribe_states(s, keys, tx.clone(), |id, st, x| Some(Event::State(id, st, source_ns(x)))).await?;
    let clock = plumbing::subscribe(s, keys.clock(), tx.clone(), |x| match plumbing::decode(x) {
        Ok(Msg::Clock(c)) => Some(Event::Clock(c, source_ns(x))),
        _ => None,
    })
    .await?;
    Ok(vec![alone, hosts, state, host_states, clock])
}

/// When a sample was put, from its Zenoh timestamp (the hub's router stamps what it publishes,
/// from the machine's clock), in ns since the Unix epoch: the ROS messages made from it carry it
/// as their source time, so a ROS reader can measure the time from the hub's put to itself.
fn source_ns(sample: &zenoh::sample::Sample) -> Option<i64> {
    let t = sample.timestamp()?.get_time().to_system_time();
    t.duration_since(std::time::UNIX_EPOCH).ok().map(|d| d.as_nanos() as i64)
}

/// The static world, asked of the hub.
async fn fetch_world(s: &zenoh::Session, keys: &Keys) -> Result<Box<TruthWorld>> {
    let bytes = plumbing::fetch(s, &keys.truth_world(), Duration::from_secs(30)).await?;
    match Msg::decode(&bytes)? {
        Msg::TruthWorld(w) => Ok(Box::new(w)),
        other => anyhow::bail!("truth/world answered a {} message", other.kind()),
    }
}

/// UAV `id`'s publishers on its node.
/// Its scan and odometry are reliable in a lockstep run (`lockstep`; see [`Qos::sensor`]).
async fn uav_topics(
    graph: &mut Graph,
    node: NodeRef,
    (id, lockstep): (UavId, bool),
    informed: bool,
) -> Result<UavTopics> {
    let ns = format!("/uav{id}");
    let goal = match informed {
        true => Some(graph.publisher(node, &format!("{ns}/goal"), POSE_STAMPED, Qos::DEFAULT).await?),
        false => None,
    };
    Ok(UavTopics {
        scan: graph.publisher(node, &format!("{ns}/scan"), LASER_SCAN, Qos::sensor(lockstep)).await?,
        odom: graph.publisher(node, &format!("{ns}/odom"), ODOMETRY, Qos::sensor(lockstep)).await?,
        goal,
        neighbours: graph.publisher(node, &format!("{ns}/neighbours"), POSE_ARRAY, Qos::DEFAULT).await?,
    })
}

/// The command subscriptions of UAV `id`: an external UAV's `cmd_vel` as Twist and as
/// TwistStamped (a teleop sends the one, Jazzy's navigation stack the other), a vehicle's
/// `cmd_vel` as TwistStamped and `cmd_accel` (its agent stamps each command with its tick).
///
/// Two types on one topic: DDS peers that check types (Fast DDS) match each publisher with the
/// reader of its type only; RustDDS does not, so a RustDDS publisher's TwistStamped also reaches
/// the Twist reader, where the strict decoders refuse it (a payload must be its message whole).
async fn command_subscriptions(
    graph: &mut Graph,
    node: NodeRef,
    id: UavId,
    vehicle: bool,
    tx: &mpsc::UnboundedSender<Event>,
) -> Result<Vec<SubscriptionGuard>> {
    let ns = format!("/uav{id}");
    let topics = match vehicle {
        false => vec![("cmd_vel", TWIST, CommandTopic::Twist), ("cmd_vel", TWIST_STAMPED, CommandTopic::TwistStamped)],
        true => vec![
            ("cmd_vel", TWIST_STAMPED, CommandTopic::TwistStamped),
            ("cmd_accel", ACCEL_STAMPED, CommandTopic::AccelStamped),
        ],
    };
    let mut guards = Vec::new();
    for (topic, t, which) in topics {
        let map = move |b| Event::Command(id, which, b);
        guards.push(graph.subscribe(node, &format!("{ns}/{topic}"), t, Qos::DEFAULT, tx.clone(), map).await?);
    }
    Ok(guards)
}

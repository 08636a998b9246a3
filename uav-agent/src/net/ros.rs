//! An agent whose sensors and commands are ROS 2 topics, the way from here to a vehicle: it reads
//! its LaserScan (`/uav{id}/scan`), Odometry (`/uav{id}/odom`) and, for an informed UAV, its goal
//! (`/uav{id}/goal`, a PoseStamped in the odometry frame) from ROS 2, on DDS or on rmw_zenoh, and
//! publishes its command on `/uav{id}/cmd_vel` (TwistStamped, body frame) or, for a controller
//! that commands an acceleration, `/uav{id}/cmd_accel` (AccelStamped); everything else (shares
//! with the other agents, its state, the netem rules, the hub's liveliness) stays on the run's
//! Zenoh keys as for any agent.
//!
//! - A tick's frame is complete when a scan, an odometry and (informed UAV) a goal with the same
//!   stamp have come; a part whose exact stamp never comes (a vehicle's odometry runs at its own
//!   rate) is the newest one older than the scan once a newer one has come. The tick is the
//!   scan's stamp over the control period; the command carries the scan's stamp, so whoever
//!   drives the body (our bridge, a vehicle's driver) knows which tick it answers.
//! - Lockstep stays byte for byte: the bridge stamps every part with its tick, and a part newer
//!   than the tick never comes before the tick's command (the hub waits for it).
//! - The radio: a vehicle hears whoever its radio hears, so this agent listens to the shares of
//!   every UAV of the scenario (the set never changes); in a simulated run the hub's radio range
//!   does not scope what it receives (docs/ros2.md).
//! - Order on DDS: the command reaches the hub, and the next frame reaches the agent, by another
//!   path than the shares, so the agent asks the hub's router a query on the shares' priority
//!   and waits for the answer twice a tick. Before it publishes its command: the router then has
//!   routed its share, which is thus queued to every neighbour before the hub's next tick can
//!   be. Before it steps on a frame: the answer comes behind every share the router queued to
//!   it before the hub published that frame (each neighbour's share of the last tick, which the
//!   hub awaited). On rmw_zenoh both go on the agent's own link to the router, in order already.

use super::AgentError;
use std::collections::BTreeMap;
use std::time::Duration;
use swarm_config::Scenario;
use swarm_ros2::msgs::command::{read_pose_stamped, Stamped, Twist};
use swarm_ros2::msgs::sensor::{LaserScan, Odometry};
use swarm_ros2::msgs::{stamp_ns, Header};
use swarm_ros2::types::{ACCEL_STAMPED, LASER_SCAN, ODOMETRY, POSE_STAMPED, TWIST_STAMPED};
use swarm_ros2::{Graph, Middleware, Publisher, Qos, SubscriptionGuard};
use swarm_types::UavId;
use swarm_wire::{Cmd, CmdKind, Keys, Msg, RadioSet, SenseFrame, WireError};
use tokio::sync::mpsc;
use tracing::{debug, info, warn};
use zenoh::qos::Priority;

/// How long a command waits for its topic's first subscriber.
const MATCH_WAIT: Duration = Duration::from_secs(3);

/// Where an agent's sensors come from.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub enum Sensors {
    /// The hub's sensor frames on `uav/{id}/sense`.
    #[default]
    Hub,
    /// ROS 2 topics in `domain`, over DDS (on loopback only if `localhost_only`) or over
    /// rmw_zenoh on the agent's own session.
    Ros {
        /// Over DDS (else rmw_zenoh).
        dds: bool,
        /// DDS on 127.0.0.1 only.
        localhost_only: bool,
        /// ROS domain id.
        domain: u32,
        /// Scan and odometry asked for reliably ([`swarm_ros2::Qos::sensor`]): matches only a
        /// reliable writer, as the bridge's is in a lockstep run (else best effort, which every
        /// writer matches).
        reliable: bool,
    },
}

impl From<swarm_ros2::Ros2Error> for AgentError {
    fn from(e: swarm_ros2::Ros2Error) -> AgentError {
        AgentError::Ros2(e.to_string())
    }
}

/// The ROS side of one agent: its subscriptions feed the node's channel with sensor frames, its
/// publishers take the commands.
pub(crate) struct RosLink {
    _graph: Graph,
    _subs: Vec<SubscriptionGuard>,
    cmd_vel: Publisher,
    cmd_accel: Publisher,
    base_link: String,
    /// The command topic has had a subscriber.
    matched: bool,
    /// DDS: the query that orders the command behind the share.
    order: Option<Order>,
    /// Frames assembled (kept so the task's channel outlives the link's start).
    _assembler: tokio::task::JoinHandle<()>,
}

/// A query to the hub through its router on the shares' priority: its answer comes back behind
/// whatever the router queued to this session before (see the module docs).
#[derive(Clone)]
struct Order {
    session: zenoh::Session,
    key: String,
}

impl Order {
    async fn round_trip(&self) -> Result<(), AgentError> {
        let replies = self
            .session
            .get(self.key.as_str())
            .priority(Priority::Data)
            .timeout(Duration::from_secs(2))
            .await
            .map_err(WireError::zenoh)?;
        while replies.recv_async().await.is_ok() {}
        Ok(())
    }
}

/// A payload from one of the three topics.
enum Part {
    Scan(Vec<u8>),
    Odom(Vec<u8>),
    Goal(Vec<u8>),
}

impl RosLink {
    /// Opens UAV `id`'s ROS side: the frames it assembles go into `tx` as the hub's would
    /// (`None` for a payload that is not its message).
    pub(crate) async fn open(
        s: &zenoh::Session,
        keys: &Keys,
        sc: &Scenario,
        id: UavId,
        sensors: &Sensors,
        tx: mpsc::UnboundedSender<Option<Msg>>,
    ) -> Result<RosLink, AgentError> {
        let Sensors::Ros { dds, localhost_only, domain, reliable } = *sensors else {
            unreachable!("a ROS link for an agent on the hub's sensors")
        };
        let middleware = if dds { Middleware::Dds { localhost_only } } else { Middleware::Zenoh(s.clone()) };
        let name = middleware.name();
        let mut graph = Graph::open(middleware, domain).await?;
        let ns = format!("/uav{id}");
        let node = graph.node(&ns, "agent").await?;
        let (ptx, prx) = mpsc::unbounded_channel::<Part>();
        let mut subs = Vec::new();
        let sensor = Qos::sensor(reliable);
        for (topic, t, qos, part) in [
            ("scan", LASER_SCAN, sensor, Part::Scan as fn(Vec<u8>) -> Part),
            ("odom", ODOMETRY, sensor, Part::Odom),
            ("goal", POSE_STAMPED, Qos::DEFAULT, Part::Goal),
        ] {
            subs.push(graph.subscribe(node, &format!("{ns}/{topic}"), t, qos, ptx.clone(), part).await?);
        }
        let cmd_vel = graph.publisher(node, &format!("{ns}/cmd_vel"), TWIST_STAMPED, Qos::DEFAULT).await?;
        let cmd_accel = graph.publisher(node, &format!("{ns}/cmd_accel"), ACCEL_STAMPED, Qos::DEFAULT).await?;
        graph.announce()?;
        let order = dds.then(|| Order { session: s.clone(), key: keys.scenario() });
        let assembly = Assembly::new(sc, id);
        let assembler = tokio::spawn(assembly.run(prx, tx, order.clone()));
        info!(middleware = name, domain, "sensors and commands on ROS 2 topics");
        Ok(RosLink {
            _graph: graph,
            _subs: subs,
            cmd_vel,
            cmd_accel,
            base_link: format!("uav{id}/base_link"),
            matched: false,
            order,
            _assembler: assembler,
        })
    }

    /// Makes sure the share just put has been routed before the command goes out another way
    /// (DDS; see the module docs).
    pub(crate) async fn order_after_share(&self) -> Result<(), AgentError> {
        match &self.order {
            Some(o) => o.round_trip().await,
            None => Ok(()),
        }
    }

    /// Publishes the command of the tick stamped `t_s`.
    pub(crate) async fn command(&mut self, cmd: &Cmd, t_s: f64) -> Result<(), AgentError> {
        let header = Header::new(t_s, self.base_link.clone());
        let (x, y, w) = (f64::from(cmd.x), f64::from(cmd.y), f64::from(cmd.yaw_rate));
        let (publisher, twist) = match cmd.kind {
            CmdKind::Velocity => (&self.cmd_vel, Twist::planar(x, y, w)),
            CmdKind::Acceleration => (&self.cmd_accel, Twist::planar(x, y, w)),
            CmdKind::Hover => (&self.cmd_vel, Twist::default()),
        };
        // A volatile command written before the driver's subscription matched would never reach
        // it (DDS discovery takes a moment at the start); once it has, a driver that goes away
        // (the run is over) is no reason to wait.
        if !self.matched {
            self.matched = publisher.wait_matched(MATCH_WAIT).await;
            if !self.matched {
                warn!("no subscription to this UAV's command topic yet: is a driver (swarm ros2) up?");
            }
        }
        publisher.put(Stamped { header, twist }.encode()).await?;
        Ok(())
    }
}

/// The parts of the frames not yet complete, by stamp.
struct Assembly {
    id: UavId,
    dt_s: f64,
    informed: bool,
    /// Every other UAV of the scenario: the radio set of every frame.
    others: Vec<UavId>,
    scans: BTreeMap<i64, LaserScan>,
    odoms: BTreeMap<i64, Odometry>,
    goals: BTreeMap<i64, [f64; 2]>,
    /// The stamp of the last frame handed on.
    last: Option<i64>,
}

impl Assembly {
    fn new(sc: &Scenario, id: UavId) -> Assembly {
        Assembly {
            id,
            dt_s: sc.dt_s(),
            informed: sc.is_informed(id),
            others: sc.uav_ids().filter(|&o| o != id).collect(),
            scans: BTreeMap::new(),
            odoms: BTreeMap::new(),
            goals: BTreeMap::new(),
            last: None,
        }
    }

    async fn run(
        mut self,
        mut rx: mpsc::UnboundedReceiver<Part>,
        tx: mpsc::UnboundedSender<Option<Msg>>,
        order: Option<Order>,
    ) {
        while let Some(part) = rx.recv().await {
            let ok = self.take(part);
            if !ok && tx.send(None).is_err() {
                break;
            }
            while let Some(frame) = self.next_frame() {
                if let Some(o) = &order {
                    if let Err(e) = o.round_trip().await {
                        warn!(uav_id = %self.id, "cannot order the frame behind the shares: {e}");
                    }
                }
                if tx.send(Some(Msg::Sense(Box::new(frame)))).is_err() {
                    return;
                }
            }
        }
    }

    /// Files a payload by its stamp; false when it was not its message.
    fn take(&mut self, part: Part) -> bool {
        let newer = |stamp: i64, last: Option<i64>| last.is_none_or(|l| stamp > l);
        match part {
            Part::Scan(b) => LaserScan::decode(&b).map(|m| {
                let s = stamp_ns(m.header.stamp_s);
                if newer(s, self.last) {
                    self.scans.insert(s, m);
                }
            }),
            Part::Odom(b) => Odometry::decode(&b).map(|m| {
                self.odoms.insert(stamp_ns(m.header.stamp_s), m);
            }),
            Part::Goal(b) => read_pose_stamped(&b).map(|(h, (x, y, _))| {
                self.goals.insert(stamp_ns(h.stamp_s), [x, y]);
            }),
        }
        .map_err(|e| debug!(uav_id = %self.id, "dropped a malformed ROS message: {e}"))
        .is_ok()
    }

    /// The part for stamp `s` of `parts`: the exact one, or once a newer one came, the newest
    /// older one.
    fn part_for<T: Clone>(parts: &BTreeMap<i64, T>, s: i64) -> Option<T> {
        if let Some(p) = parts.get(&s) {
            return Some(p.clone());
        }
        parts.range(s + 1..).next()?;
        parts.range(..s).next_back().map(|(_, p)| p.clone())
    }

    /// The oldest scan's frame, once its parts are there.
    fn next_frame(&mut self) -> Option<SenseFrame> {
        let (&s, _) = self.scans.iter().next()?;
        let odom = Self::part_for(&self.odoms, s)?;
        let goal = if self.informed { Some(Self::part_for(&self.goals, s)?) } else { None };
        let scan = self.scans.remove(&s).expect("the oldest scan");
        self.last = Some(s);
        // Keep the newest older part of each kind: the next frame may need it.
        for parts in [&mut self.odoms as &mut dyn Prune, &mut self.goals] {
            parts.prune_before(s);
        }
        let tick = (scan.header.stamp_s / self.dt_s).round() as u64;
        let radio = RadioSet { tick, id: self.id, in_range: self.others.clone(), loss: Vec::new() };
        let (mut odom, mut scan) = (odom.into_odom(tick, goal), scan.into_scan(tick));
        (odom.t_s, scan.t_s) = (self.on_tick(odom.t_s), self.on_tick(scan.t_s));
        Some(SenseFrame { radio, odom, gnss: None, uvdar: None, scan })
    }
}

impl Assembly {
    /// A stamp's time, as the hub has it when it names a tick: tick × dt exactly (a stamp's
    /// nanoseconds give it back only to the nearest bit or so, and the stack's arithmetic
    /// would not repeat the hub-fed agent's).
    fn on_tick(&self, t_s: f64) -> f64 {
        let on = (t_s / self.dt_s).round() * self.dt_s;
        if (t_s - on).abs() < 1e-6 {
            on
        } else {
            t_s
        }
    }
}

/// Forgetting parts no frame will need.
trait Prune {
    /// Drops every part older than `s` but the newest of them.
    fn prune_before(&mut self, s: i64);
}

impl<T> Prune for BTreeMap<i64, T> {
    fn prune_before(&mut self, s: i64) {
        let Some((&keep, _)) = self.range(..=s).next_back() else { return };
        let newer = self.split_off(&keep);
        *self = newer;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use swarm_ros2::msgs::command::pose_stamped;
    use swarm_ros2::msgs::sensor::{laser_scan, odometry};
    use swarm_wire::{Odom, Scan};

    fn scan(t: f64) -> Part {
        let s = Scan { tick: 0, t_s: t, angle_min: 0.0, angle_increment: 0.1, max_range_m: 10.0, ranges_m: vec![1.0] };
        Part::Scan(laser_scan(&s, "b", 0.1))
    }

    fn odom(t: f64, x: f64) -> Part {
        let o = Odom { tick: 0, t_s: t, x, y: 0.0, yaw: 0.0, vx: 0.0, vy: 0.0, goal: None, goal_vel: None };
        Part::Odom(odometry(&o, "o", "b"))
    }

    fn assembly(informed: bool) -> Assembly {
        let sc = Scenario::from_arg("forest-5").expect("built-in").0;
        let mut a = Assembly::new(&sc, UavId::new(3));
        a.informed = informed;
        a
    }

    #[test]
    fn a_frame_waits_for_its_parts_of_the_same_stamp() {
        let mut a = assembly(true);
        assert!(a.take(scan(0.2)));
        assert!(a.next_frame().is_none(), "no odometry yet");
        assert!(a.take(odom(0.2, 1.5)));
        assert!(a.next_frame().is_none(), "an informed UAV waits for its goal");
        assert!(a.take(Part::Goal(pose_stamped(&Header::new(0.2, "o"), 30.0, 0.0, 0.0))));
        let f = a.next_frame().expect("complete");
        assert_eq!((f.tick(), f.odom.tick, f.radio.tick), (2, 2, 2));
        assert_eq!((f.scan.t_s, f.odom.t_s), (2.0 * 0.1, 2.0 * 0.1), "the hub's tick time, bit for bit");
        assert_eq!((f.odom.x, f.odom.goal), (1.5, Some([30.0, 0.0])));
        assert_eq!(
            f.radio.in_range,
            vec![UavId::new(1), UavId::new(2), UavId::new(4), UavId::new(5)],
            "every other UAV"
        );
        assert!(a.next_frame().is_none());
        assert!(!a.take(Part::Scan(vec![1, 2, 3])), "not a LaserScan");
    }

    #[test]
    fn a_vehicles_odometry_at_its_own_rate_pairs_with_the_newest_older_one() {
        let mut a = assembly(false);
        a.take(odom(0.095, 1.0));
        a.take(scan(0.1));
        assert!(a.next_frame().is_none(), "an exact odometry may still come");
        a.take(odom(0.105, 2.0));
        let f = a.next_frame().expect("paired with the older one");
        assert_eq!((f.tick(), f.odom.x, f.odom.goal), (1, 1.0, None));
        a.take(scan(0.2));
        a.take(odom(0.205, 3.0));
        assert_eq!(a.next_frame().map(|f| f.odom.x), Some(2.0), "the newest older than 0.2");
        a.take(scan(0.15));
        assert!(a.next_frame().is_none() && a.scans.is_empty(), "a scan older than the last frame is dropped");
    }
}

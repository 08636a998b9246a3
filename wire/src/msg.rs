//! Every payload of a run, in one postcard-encoded envelope.
//!
//! Postcard is positional and not self-describing, so the rules are: variants of [`Msg`] are only
//! ever appended; a struct may only grow at its end. The golden-bytes test below pins the
//! encoding of every variant so an accidental reorder fails CI. Times are sim seconds; frames are
//! named in field docs (world, odom = the UAV's own start frame, body = the UAV's rotational
//! frame, seed 000 section 2.4).

use crate::WireError;
use serde::{Deserialize, Serialize};
pub use swarm_types::UavId;

/// Schema name put into the Zenoh encoding of every payload.
pub const SCHEMA: &str = "swarm.Msg.v1";

/// The envelope of every payload on a `swarm/**` key.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Msg {
    /// `swarm/{run}/clock`
    Clock(Clock),
    /// Not published since the sensors travel as one [`Msg::Sense`]; kept so that the variants
    /// after it keep their numbers (postcard numbers variants by position).
    Scan(Scan),
    /// Not published (see [`Msg::Scan`]).
    Odom(Odom),
    /// Not published (see [`Msg::Scan`]).
    Gnss(Gnss),
    /// Not published (see [`Msg::Scan`]).
    Radio(RadioSet),
    /// `.../cmd`
    Cmd(Cmd),
    /// `.../share/pose`
    Pose(PoseShare),
    /// `.../state`
    State(Box<AgentState>),
    /// `swarm/{run}/truth/world`
    TruthWorld(TruthWorld),
    /// `swarm/{run}/truth/step`
    TruthStep(TruthStep),
    /// `.../share/obstacles`
    Obstacles(ObstacleShare),
    /// `swarm/{run}/netem/rules` (the rules in force, hub -> all) and `swarm/{run}/netem/add`
    /// (a timeline to add, tools -> hub): JSON text of a timeline of `[[netem]]` rules and
    /// `[[failures]]`, since the rule types are self-describing serde enums that postcard cannot
    /// carry.
    NetemRules(String),
    /// Not published (see [`Msg::Scan`]).
    Uvdar(Uvdar),
    /// `.../uav/{id}/sense`: one UAV's sensor frame of one tick (hub -> agent).
    Sense(Box<SenseFrame>),
    /// `.../host/{ids}/sense`: the sensor frames of one tick of an agent host's UAVs, in id
    /// order (hub -> host): one put, route and wake-up a tick for the host instead of one per
    /// UAV. Each frame is the one [`Msg::Sense`] would carry.
    Senses(Vec<UavSense>),
    /// `.../host/{ids}/cmd`: the commands of one lockstep tick of an agent host's UAVs, in the
    /// order they were given (host -> hub): one put, route and wake-up of the hub a tick for
    /// the host instead of one per UAV. Each is the command [`Msg::Cmd`] would carry.
    Cmds(Vec<UavCmd>),
    /// `.../host/{ids}/state`: the states of one lockstep tick of an agent host's UAVs (host ->
    /// recorder, tools). Each is the state [`Msg::State`] would carry; it names its UAV.
    States(Vec<AgentState>),
}

impl Msg {
    /// Postcard bytes of this message.
    pub fn encode(&self) -> Result<Vec<u8>, WireError> {
        postcard::to_allocvec(self).map_err(WireError::Encode)
    }

    /// Decodes a payload; a malformed one is an error to count and drop, never a panic. Bytes
    /// after the end of a message make it malformed (postcard alone would ignore them).
    pub fn decode(bytes: &[u8]) -> Result<Msg, WireError> {
        let (msg, rest) =
            postcard::take_from_bytes(bytes).map_err(|source| WireError::Decode { len: bytes.len(), source })?;
        if rest.is_empty() {
            Ok(msg)
        } else {
            Err(WireError::Trailing { len: bytes.len(), extra: rest.len() })
        }
    }

    /// Short name of the variant, for logs and counters.
    pub fn kind(&self) -> &'static str {
        match self {
            Msg::Clock(_) => "clock",
            Msg::Scan(_) => "scan",
            Msg::Odom(_) => "odom",
            Msg::Gnss(_) => "gnss",
            Msg::Radio(_) => "radio",
            Msg::Cmd(_) => "cmd",
            Msg::Pose(_) => "pose",
            Msg::State(_) => "state",
            Msg::TruthWorld(_) => "truth_world",
            Msg::TruthStep(_) => "truth_step",
            Msg::Obstacles(_) => "obstacles",
            Msg::NetemRules(_) => "netem_rules",
            Msg::Uvdar(_) => "uvdar",
            Msg::Sense(_) => "sense",
            Msg::Senses(_) => "senses",
            Msg::Cmds(_) => "cmds",
            Msg::States(_) => "states",
        }
    }

    /// The bytes of `Msg::Senses` of `frames`, each given as its UAV and its encoded
    /// [`Msg::Sense`], without decoding them: what the hub's workers encoded per UAV is copied
    /// into one message (postcard writes an enum as its variant's number and then its fields, a
    /// `Vec` as its length and then its items, so this is `Msg::Senses(..).encode()` byte for
    /// byte). A part that is not an encoded `Msg::Sense` is an error.
    pub fn senses_from_encoded(frames: &[(UavId, Vec<u8>)]) -> Result<Vec<u8>, WireError> {
        let total: usize = frames.iter().map(|(_, b)| b.len() + 5).sum();
        let mut out = Vec::with_capacity(total + 10);
        put_varint(&mut out, SENSES_TAG);
        put_varint(&mut out, frames.len() as u64);
        for (id, bytes) in frames {
            let Some(frame) = bytes.strip_prefix(&[SENSE_TAG as u8]) else {
                return Err(WireError::NotSense { len: bytes.len() });
            };
            put_varint(&mut out, u64::from(id.get()));
            out.extend_from_slice(frame);
        }
        Ok(out)
    }
}

/// Postcard's variant numbers of [`Msg::Sense`] and [`Msg::Senses`] (one byte each as a
/// varint: below 128), pinned by the golden bytes.
const SENSE_TAG: u64 = 13;
const SENSES_TAG: u64 = 14;

/// Appends `v` as postcard's varint (LEB128: seven bits a byte, low first).
fn put_varint(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push((v as u8 & 0x7f) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

/// One UAV's sensor frame in an agent host's [`Msg::Senses`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UavSense {
    /// The UAV it is for.
    pub id: UavId,
    /// Its frame of the tick.
    pub frame: SenseFrame,
}

/// One UAV's command in an agent host's [`Msg::Cmds`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct UavCmd {
    /// The UAV it is for.
    pub id: UavId,
    /// Its command of the tick.
    pub cmd: Cmd,
}

/// What a UAV's onboard relative sensing (UVDAR, seed 003) saw at one tick: each neighbour in
/// range and field of view and not occluded, by its marker id, with noisy range and bearing.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Uvdar {
    /// Tick.
    pub tick: u64,
    /// Sim time [s].
    pub t_s: f64,
    /// What was seen.
    pub seen: Vec<UvdarSeen>,
}

/// One neighbour seen by UVDAR.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct UvdarSeen {
    /// Its id (the blinking code of its markers).
    pub id: UavId,
    /// Range [m].
    pub range_m: f32,
    /// Bearing in the observer's body frame [rad], counter-clockwise from its heading.
    pub bearing_rad: f32,
}

/// Sim clock at tick `tick`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Clock {
    /// Tick number, from 0.
    pub tick: u64,
    /// Sim time of this tick [s].
    pub t_s: f64,
    /// Tick length [s].
    pub dt_s: f64,
}

/// One 360° LIDAR scan in the body frame. Beam `i` points at `angle_min + i·angle_increment`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Scan {
    /// Tick of the scan.
    pub tick: u64,
    /// Sim time [s].
    pub t_s: f64,
    /// Angle of beam 0 [rad], body frame.
    pub angle_min: f32,
    /// Angle between beams [rad].
    pub angle_increment: f32,
    /// Maximum range [m].
    pub max_range_m: f32,
    /// Range of each beam [m]; `+inf` (JSON `null`) where nothing was hit.
    pub ranges_m: Vec<f32>,
}

/// Own pose and velocity in the UAV's odometry frame (its start pose).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Odom {
    /// Tick.
    pub tick: u64,
    /// Sim time [s].
    pub t_s: f64,
    /// Position x in the odom frame [m].
    pub x: f64,
    /// Position y in the odom frame [m].
    pub y: f64,
    /// Heading in the odom frame [rad].
    pub yaw: f64,
    /// Velocity x in the odom frame [m/s].
    pub vx: f64,
    /// Velocity y in the odom frame [m/s].
    pub vy: f64,
    /// The goal in the odom frame, for informed UAVs (a mission waypoint from the ground station).
    pub goal: Option<[f64; 2]>,
    /// The goal's velocity in the odom frame [m/s] when it moves (a dynamic goal).
    pub goal_vel: Option<[f64; 2]>,
}

/// A GNSS-like pose in the shared world frame; published only in `broadcast` localization mode.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Gnss {
    /// Tick.
    pub tick: u64,
    /// Sim time [s].
    pub t_s: f64,
    /// World x [m].
    pub x: f64,
    /// World y [m].
    pub y: f64,
    /// World heading [rad].
    pub yaw: f64,
    /// World velocity x [m/s].
    pub vx: f64,
    /// World velocity y [m/s].
    pub vy: f64,
}

/// The UAVs that UAV `id` can hear now (radio range with hysteresis).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RadioSet {
    /// Tick.
    pub tick: u64,
    /// Whose set this is.
    pub id: UavId,
    /// UAV ids in radio range, sorted.
    pub in_range: Vec<UavId>,
    /// Distance-dependent loss probability of each link in `in_range` (same order; empty when
    /// the scenario has no distance loss).
    pub loss: Vec<f32>,
}

/// Everything the hub senses for one UAV at one tick, in one message on `uav/{id}/sense`: the
/// agent steps on it whole. One message rather than one per sensor because every message costs
/// the hub a put, the router a route and access check, and the agent a wake-up, whatever its
/// size: at 1000 UAVs the hub put 4000 messages a tick, now 1000. Every part is of the same tick.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SenseFrame {
    /// The UAVs it can hear now.
    pub radio: RadioSet,
    /// Own odometry (own start frame).
    pub odom: Odom,
    /// Own GNSS-like fix (world frame), only in `broadcast` localization mode.
    pub gnss: Option<Gnss>,
    /// Onboard relative sensing, only in `uvdar` localization mode.
    pub uvdar: Option<Uvdar>,
    /// The LIDAR scan (body frame).
    pub scan: Scan,
}

impl SenseFrame {
    /// Tick of the frame (its scan's).
    pub fn tick(&self) -> u64 {
        self.scan.tick
    }
}

/// What a command asks of the body.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum CmdKind {
    /// `x, y` are a desired velocity [m/s], body frame.
    Velocity,
    /// `x, y` are a desired acceleration [m/s²], body frame.
    Acceleration,
    /// Hold position (the agent has lost its hub or is shutting down).
    Hover,
}

/// An agent's command for tick `tick`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Cmd {
    /// The tick this command answers.
    pub tick: u64,
    /// Velocity, acceleration or hover.
    pub kind: CmdKind,
    /// Body-frame x component.
    pub x: f32,
    /// Body-frame y component.
    pub y: f32,
    /// Yaw rate [rad/s].
    pub yaw_rate: f32,
}

impl Cmd {
    /// Hold position, answering tick `tick`: what an agent sends when it has nothing better (no
    /// hub, shutting down) and what the hub holds for a UAV that has sent nothing yet.
    pub const fn hover(tick: u64) -> Cmd {
        Cmd { tick, kind: CmdKind::Hover, x: 0.0, y: 0.0, yaw_rate: 0.0 }
    }
}

/// `broadcast` mode: a UAV's own pose in the shared (GNSS-like) frame, sent to its neighbours.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PoseShare {
    /// Sender id (routing and metrics; K21 agents stay anonymous in `icp` mode).
    pub from: UavId,
    /// Tick the pose belongs to.
    pub tick: u64,
    /// Sim time of the pose [s].
    pub t_s: f64,
    /// World x [m].
    pub x: f64,
    /// World y [m].
    pub y: f64,
    /// World heading [rad].
    pub yaw: f64,
    /// World velocity x [m/s].
    pub vx: f64,
    /// World velocity y [m/s].
    pub vy: f64,
    /// The sender's hop count to the nearest informed UAV (0: it is informed; [`NO_PATH`]: it
    /// knows of none). Carries no id: see `swarm_config::LostContactParams`.
    pub hops: u8,
    /// The sender's hop count to the nearest UAV that has arrived at the goal (0: it is an
    /// informed UAV inside the arrival disc; [`NO_PATH`]: it knows of none): how a K21 swarm
    /// learns to settle (see `swarm_config::K21Params::arrival_radius_m`).
    pub arrival: u8,
}

/// The hop count of a sender that knows of no path to an informed UAV.
pub const NO_PATH: u8 = u8::MAX;

/// `icp` mode: a UAV's obstacle centres in its body frame, sent to its neighbours (seed 000 3.2:
/// "only lower tens of coordinates"). Coordinates are whole centimetres (postcard varints: about
/// 4 bytes a point); the rounding (≤ 5 mm) is well below the circle fit's own error.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ObstacleShare {
    /// Sender id (routing and metrics; identity only with `identify = "key"`).
    pub from: UavId,
    /// Tick of the scan the centres come from.
    pub tick: u64,
    /// Sim time of that scan [s].
    pub t_s: f64,
    /// Obstacle centres `[x, y]` in the sender's body frame [cm].
    pub centres_cm: Vec<[i16; 2]>,
    /// The sender's hop count to the nearest informed UAV (see [`PoseShare::hops`]).
    pub hops: u8,
    /// The sender's hop count to the nearest arrived UAV (see [`PoseShare::arrival`]).
    pub arrival: u8,
}

impl ObstacleShare {
    /// Rounds body-frame centres in metres to the wire's centimetres (saturating at ±327 m).
    pub fn quantize(points_m: impl IntoIterator<Item = [f64; 2]>) -> Vec<[i16; 2]> {
        let cm = |v: f64| (v * 100.0).round().clamp(f64::from(i16::MIN), f64::from(i16::MAX)) as i16;
        points_m.into_iter().filter(|p| p[0].is_finite() && p[1].is_finite()).map(|p| [cm(p[0]), cm(p[1])]).collect()
    }

    /// The centres in metres.
    pub fn centres_m(&self) -> impl Iterator<Item = [f64; 2]> + '_ {
        self.centres_cm.iter().map(|c| [f64::from(c[0]) / 100.0, f64::from(c[1]) / 100.0])
    }
}

/// ICP work of one control step and the size of the neighbour database (seed 000 5.1, 6.2).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct IcpCounts {
    /// Short ICPs (from the last estimate).
    pub short: u32,
    /// Long ICPs (full grid, periodic check).
    pub long: u32,
    /// Initial ICPs (full grid, new entry).
    pub initial: u32,
    /// Long or initial ICPs deferred by the per-step cap or the step-time failsafe.
    pub deferred: u32,
    /// Entries in the database.
    pub entries: u32,
    /// Of those, suspended (neighbour out of ICP range).
    pub suspended: u32,
}

/// One neighbour as an agent believes it to be, in the agent's body frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct NeighbourEstimate {
    /// The neighbour's id where known (its key), for metrics only.
    pub id: Option<UavId>,
    /// Relative position x [m], body frame.
    pub x: f32,
    /// Relative position y [m], body frame.
    pub y: f32,
    /// Relative heading [rad].
    pub heading: f32,
    /// Age of the information [s].
    pub age_s: f32,
}

/// Message and byte counts of one agent's inter-agent link (the netem seam).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct LinkCounters {
    /// Messages published to neighbours.
    pub sent_msgs: u64,
    /// Bytes published to neighbours.
    pub sent_bytes: u64,
    /// Messages received from neighbours.
    pub recv_msgs: u64,
    /// Bytes received from neighbours.
    pub recv_bytes: u64,
    /// Messages delivered to the controller (after netem).
    pub delivered_msgs: u64,
    /// Received payloads that failed to decode (counted and dropped).
    pub malformed: u64,
    /// Per link class (clean, impaired, cut: the rule in force on the link at the send instant).
    pub classes: [ClassCounts; 3],
}

/// What the links of one class did to the messages an agent received (netem counts them; this
/// is their shape on the wire and in `summary.json`).
///
/// `delivered = offered − dropped − held + duplicated + released`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ClassCounts {
    /// Messages that arrived on links of this class.
    pub offered: u64,
    /// Copies scheduled for delivery (duplicates and released messages included).
    pub delivered: u64,
    /// Messages dropped (loss model, radio loss, cut).
    pub dropped: u64,
    /// Messages duplicated.
    pub duplicated: u64,
    /// Messages stored by a holding link.
    pub held: u64,
    /// Stored messages delivered when their link released.
    pub released: u64,
}

impl std::ops::Add for ClassCounts {
    type Output = ClassCounts;
    fn add(self, o: ClassCounts) -> ClassCounts {
        ClassCounts {
            offered: self.offered + o.offered,
            delivered: self.delivered + o.delivered,
            dropped: self.dropped + o.dropped,
            duplicated: self.duplicated + o.duplicated,
            held: self.held + o.held,
            released: self.released + o.released,
        }
    }
}

/// The delay one delivered copy got: delivery instant − send instant.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DelaySample {
    /// Link class index (0 clean, 1 impaired, 2 cut).
    pub class: u8,
    /// Delay [s].
    pub delay_s: f32,
}

/// Magnitudes of the K21 vectors of one step (seed 000 eq. 4.1), for plots and diagnostics.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct VectorMagnitudes {
    /// |v_c|
    pub cohesion: f32,
    /// |v_s|
    pub separation: f32,
    /// |v_o|
    pub avoidance: f32,
    /// |v_n|
    pub navigation: f32,
    /// |v_f|, the command [m/s]
    pub output: f32,
}

/// An agent's diagnostics for one step. `Default` is a state of UAV 0 at tick 0 with nothing in
/// it, for tests and benches to fill in.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct AgentState {
    /// Agent id.
    pub id: UavId,
    /// Tick of the step.
    pub tick: u64,
    /// Sim time [s].
    pub t_s: f64,
    /// Wall time the step took (perception + localization + control) [µs].
    pub step_time_us: u32,
    /// Obstacles extracted from this scan.
    pub obstacles: u32,
    /// Current neighbour estimates.
    pub neighbours: Vec<NeighbourEstimate>,
    /// UAVs in radio range (subscribed to).
    pub in_radio_range: u32,
    /// Controller vector magnitudes.
    pub vectors: VectorMagnitudes,
    /// Link counters since start.
    pub link: LinkCounters,
    /// ICP work of this step (`icp` mode; zero otherwise). Appended in v1: old readers skip it.
    pub icp: IcpCounts,
    /// Delays applied to the copies scheduled for delivery since the previous state.
    pub delays: Vec<DelaySample>,
    /// What the agent and its Zenoh session received since they started. Appended: the wire's
    /// measure of whether traffic grows with the neighbours or with the swarm.
    pub traffic: Traffic,
}

/// What an agent and its Zenoh session (the agent's own process, or a host's) received since
/// they started. The session's counts are the same in the state of every agent of a host (readers
/// group them by `session`); the agent's own (`agent_*`) are what it would receive on a session
/// of its own, so they read alike however agents share sessions.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Traffic {
    /// The session's Zenoh id, as the router's admin space names it.
    pub session: String,
    /// Agents flying on the session.
    pub agents: u32,
    /// Share messages the session received (every sample of its share subscriptions).
    pub shares: u64,
    /// Their payload bytes.
    pub share_bytes: u64,
    /// Payload bytes of every sample the session received: sensors, radio sets, netem rules and
    /// shares (Zenoh's framing not included).
    pub bytes: u64,
    /// Senders whose shares the session subscribes to now (the union of its agents' radio sets).
    pub subscriptions: u32,
    /// Of `shares`, those from UAVs flown by other sessions: what crossed the network to reach
    /// this one (a host's agents hear each other through the session itself).
    pub remote_shares: u64,
    /// Their payload bytes.
    pub remote_share_bytes: u64,
    /// Shares that reached this agent: every one its session received from a UAV it listened to
    /// (counted or not by its windows).
    pub agent_shares: u64,
    /// Payload bytes this agent received: its own sensor, radio and rules samples and those
    /// shares.
    pub agent_bytes: u64,
    /// Of the senders of `remote_shares`, the shares that never came between two that did, while
    /// subscribed: the ticks one sender's received shares skip (lost on the way, or never sent:
    /// a tick the sender did not step, a share its netem dropped). Last, so the layout before it
    /// is unchanged.
    pub remote_share_gaps: u64,
}

/// The static world, published once by the hub for the recorder.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TruthWorld {
    /// Trees `[x, y, r]` [m].
    pub trees: Vec<[f64; 3]>,
    /// Walls `[x1, y1, x2, y2, thickness]` [m].
    pub walls: Vec<[f64; 5]>,
    /// Start poses `[x, y, yaw]`, index = id − 1.
    pub starts: Vec<[f64; 3]>,
    /// The goal [m].
    pub goal: [f64; 2],
    /// Body radius [m].
    pub body_radius_m: f64,
}

/// Ground truth of one body after a tick.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TruthBody {
    /// UAV id.
    pub id: UavId,
    /// World x [m].
    pub x: f64,
    /// World y [m].
    pub y: f64,
    /// World heading [rad].
    pub yaw: f64,
    /// World velocity x [m/s].
    pub vx: f64,
    /// World velocity y [m/s].
    pub vy: f64,
    /// Its agent holds a liveliness token.
    pub alive: bool,
    /// Its command for this tick arrived before the tick closed.
    pub cmd_on_time: bool,
    /// Distance from the UAV centre to the nearest obstacle surface [m].
    pub obstacle_distance_m: f64,
    /// Distance to the nearest other UAV, centre to centre [m].
    pub agent_distance_m: f64,
    /// In collision now.
    pub colliding: bool,
}

/// Why a run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum EndReason {
    /// The goal rule was met.
    Goal,
    /// The sim-time limit passed.
    TimeLimit,
    /// No agent was alive any more.
    NoAgents,
    /// The hub was told to stop.
    Stopped,
}

impl EndReason {
    /// Its name in `summary.json`'s `end_reason`.
    pub const fn name(self) -> &'static str {
        match self {
            EndReason::Goal => "goal",
            EndReason::TimeLimit => "time_limit",
            EndReason::NoAgents => "no_agents",
            EndReason::Stopped => "stopped",
        }
    }
}

/// A collision that started this tick.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CollisionEvent {
    /// The UAV.
    pub id: UavId,
    /// The other UAV, or `None` for an obstacle.
    pub other_uav: Option<UavId>,
    /// World position [m].
    pub x: f64,
    /// World position [m].
    pub y: f64,
}

/// Ground truth after tick `tick`, for the recorder. `Default` is tick 0 with no body, for tests
/// that set only what they look at.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TruthStep {
    /// Tick just integrated.
    pub tick: u64,
    /// Sim time at the end of the tick [s].
    pub t_s: f64,
    /// Every body.
    pub bodies: Vec<TruthBody>,
    /// Collisions that began this tick.
    pub collisions: Vec<CollisionEvent>,
    /// Sim time the goal rule was first met, if it was.
    pub goal_reached_at: Option<f64>,
    /// Set on the last step of the run.
    pub ended: Option<EndReason>,
    /// Wall seconds since tick 0.
    pub wall_s: f64,
    /// The hub's own wall-clock cost of this tick and the commands it took. Appended in v1;
    /// boxed (same bytes on the wire) so that `Msg` stays small.
    pub timing: Box<HubTiming>,
}

/// What one tick cost the hub on the wall clock, and how its commands arrived. Measured, so it
/// differs from run to run even in lockstep; the recorder folds it into summary.json's `timing`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct HubTiming {
    /// Wall time of the hub's own work this tick: sensors, integration (not the wait for
    /// commands) [µs].
    pub work_us: u32,
    /// Commands taken since the previous step, on time or late.
    pub cmds: u32,
    /// How late each command that arrived after its tick had closed was [ms] (`realtime` mode:
    /// arrival − the wall instant its tick closed).
    pub late_ms: Vec<f32>,
}

/// The hub's answer to a timeline put on `netem/add`, published as JSON (not a [`Msg`]) on
/// `netem/ack`, so that `swarm netem` knows whether its change was applied.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NetemAck {
    /// The timeline's JSON as it came (what the sender matches its request by).
    pub timeline: String,
    /// Whether it was added to the timeline in force.
    pub accepted: bool,
    /// Why not, when refused.
    pub reason: String,
    /// The sim time its times count from (the hub's next tick), when accepted. Appended: an old
    /// hub's answer has none.
    #[serde(default)]
    pub from_s: Option<f64>,
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// The variant names of `Msg`, read from its own `Deserialize` impl (serde hands them to
    /// `deserialize_enum`), so the count cannot be hand-kept wrong.
    fn msg_variants() -> &'static [&'static str] {
        use serde::de::{self, Deserializer, Visitor};
        struct Names(Option<&'static [&'static str]>);
        impl<'de> Deserializer<'de> for &mut Names {
            type Error = de::value::Error;
            fn deserialize_any<V: Visitor<'de>>(self, _: V) -> Result<V::Value, Self::Error> {
                Err(de::Error::custom("only an enum is asked for"))
            }
            fn deserialize_enum<V: Visitor<'de>>(
                self,
                _: &'static str,
                variants: &'static [&'static str],
                _: V,
            ) -> Result<V::Value, Self::Error> {
                self.0 = Some(variants);
                Err(de::Error::custom("names taken"))
            }
            serde::forward_to_deserialize_any! {
                bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string bytes byte_buf
                option unit unit_struct newtype_struct seq tuple tuple_struct map struct identifier
                ignored_any
            }
        }
        let mut names = Names(None);
        let _ = Msg::deserialize(&mut names);
        names.0.expect("Msg deserializes as an enum")
    }

    /// Variant index of `m`, by an exhaustive match: a new variant does not compile here until it
    /// has an index, and [`golden_bytes`] fails until it has golden bytes in [`golden`].
    fn variant_index(m: &Msg) -> u8 {
        match m {
            Msg::Clock(_) => 0,
            Msg::Scan(_) => 1,
            Msg::Odom(_) => 2,
            Msg::Gnss(_) => 3,
            Msg::Radio(_) => 4,
            Msg::Cmd(_) => 5,
            Msg::Pose(_) => 6,
            Msg::State(_) => 7,
            Msg::TruthWorld(_) => 8,
            Msg::TruthStep(_) => 9,
            Msg::Obstacles(_) => 10,
            Msg::NetemRules(_) => 11,
            Msg::Uvdar(_) => 12,
            Msg::Sense(_) => 13,
            Msg::Senses(_) => 14,
            Msg::Cmds(_) => 15,
            Msg::States(_) => 16,
        }
    }

    /// One representative value of every variant and its exact postcard bytes (hex). Values use
    /// small integers, exact binary fractions, `Some` and non-empty vectors so every field shows
    /// in the bytes.
    /// The sensor frame of the golden `Sense` and `Senses`.
    fn sense_frame() -> SenseFrame {
        SenseFrame {
            radio: RadioSet { tick: 4, id: UavId::new(2), in_range: vec![UavId::new(1)], loss: vec![] },
            odom: Odom {
                tick: 4,
                t_s: 0.5,
                x: 1.0,
                y: -2.0,
                yaw: 0.5,
                vx: 0.25,
                vy: 0.0,
                goal: None,
                goal_vel: Some([0.5, 0.0]),
            },
            gnss: Some(Gnss { tick: 4, t_s: 0.5, x: 1.0, y: -2.0, yaw: 0.5, vx: 0.25, vy: 0.0 }),
            uvdar: None,
            scan: Scan {
                tick: 4,
                t_s: 0.5,
                angle_min: 0.0,
                angle_increment: 0.5,
                max_range_m: 12.0,
                ranges_m: vec![1.0],
            },
        }
    }

    pub(crate) fn golden() -> Vec<(Msg, &'static str)> {
        let state = AgentState {
            id: UavId::new(2),
            tick: 7,
            t_s: 0.5,
            step_time_us: 300,
            obstacles: 4,
            neighbours: vec![NeighbourEstimate {
                id: Some(UavId::new(3)),
                x: 1.5,
                y: -2.0,
                heading: 0.25,
                age_s: 0.125,
            }],
            in_radio_range: 1,
            vectors: VectorMagnitudes { cohesion: 0.5, separation: 1.0, avoidance: 2.0, navigation: 0.25, output: 1.5 },
            link: LinkCounters {
                sent_msgs: 1,
                sent_bytes: 200,
                recv_msgs: 3,
                recv_bytes: 4,
                delivered_msgs: 5,
                malformed: 6,
                classes: [
                    ClassCounts { offered: 7, delivered: 8, dropped: 9, duplicated: 10, held: 11, released: 12 },
                    ClassCounts { offered: 13, delivered: 14, dropped: 15, duplicated: 16, held: 17, released: 18 },
                    ClassCounts { offered: 19, delivered: 20, dropped: 21, duplicated: 22, held: 23, released: 24 },
                ],
            },
            icp: IcpCounts { short: 1, long: 2, initial: 3, deferred: 4, entries: 5, suspended: 6 },
            delays: vec![DelaySample { class: 1, delay_s: 0.5 }],
            traffic: Traffic {
                session: "a1".into(),
                agents: 2,
                shares: 3,
                share_bytes: 300,
                bytes: 5,
                subscriptions: 6,
                remote_shares: 7,
                remote_share_bytes: 8,
                agent_shares: 9,
                agent_bytes: 10,
                remote_share_gaps: 11,
            },
        };
        let body = |id: u32, colliding: bool| TruthBody {
            id: UavId::new(id),
            x: 1.0,
            y: -1.0,
            yaw: 0.5,
            vx: 0.25,
            vy: 0.0,
            alive: true,
            cmd_on_time: !colliding,
            obstacle_distance_m: 2.0,
            agent_distance_m: 4.0,
            colliding,
        };
        vec![
            (Msg::Clock(Clock { tick: 3, t_s: 0.25, dt_s: 0.125 }), "0003000000000000d03f000000000000c03f"),
            (
                Msg::Scan(Scan {
                    tick: 1,
                    t_s: 0.125,
                    angle_min: 0.0,
                    angle_increment: 0.5,
                    max_range_m: 12.0,
                    ranges_m: vec![1.0, f32::INFINITY],
                }),
                "0101000000000000c03f000000000000003f00004041020000803f0000807f",
            ),
            (
                Msg::Odom(Odom {
                    tick: 2,
                    t_s: 0.25,
                    x: 1.0,
                    y: -2.0,
                    yaw: 0.5,
                    vx: 0.25,
                    vy: -0.125,
                    goal: Some([30.0, 0.0]),
                    goal_vel: None,
                }),
                "0202000000000000d03f000000000000f03f00000000000000c0000000000000e03f000000000000d03f000000000000c0bf010000000000003e40000000000000000000",
            ),
            (
                Msg::Gnss(Gnss { tick: 2, t_s: 0.25, x: 1.0, y: -2.0, yaw: 0.5, vx: 0.25, vy: -0.125 }),
                "0302000000000000d03f000000000000f03f00000000000000c0000000000000e03f000000000000d03f000000000000c0bf",
            ),
            (Msg::Radio(RadioSet { tick: 4, id: UavId::new(2), in_range: vec![UavId::new(1), UavId::new(3)], loss: vec![0.0, 0.25] }), "04040202010302000000000000803e"),
            (Msg::Cmd(Cmd { tick: 2, kind: CmdKind::Velocity, x: 0.25, y: -0.5, yaw_rate: 0.0 }), "0502000000803e000000bf00000000"),
            (
                Msg::Pose(PoseShare { from: UavId::new(3), tick: 5, t_s: 0.5, x: 1.0, y: -2.0, yaw: 0.5, vx: 0.25, vy: -0.125, hops: 0, arrival: 7 }),
                "060305000000000000e03f000000000000f03f00000000000000c0000000000000e03f000000000000d03f000000000000c0bf0007",
            ),
            (Msg::State(Box::new(state.clone())), "070207000000000000e03fac02040101030000c03f000000c00000803e0000003e010000003f0000803f000000400000803e0000c03f01c801030405060708090a0b0c0d0e0f10111213141516171801020304050601010000003f0261310203ac0205060708090a0b"),
            (
                Msg::TruthWorld(TruthWorld {
                    trees: vec![[1.0, 2.0, 0.25]],
                    walls: vec![[0.0, 0.0, 4.0, 0.0, 0.5]],
                    starts: vec![[0.0, 1.0, 0.5]],
                    goal: [30.0, 0.0],
                    body_radius_m: 0.25,
                }),
                "0801000000000000f03f0000000000000040000000000000d03f010000000000000000000000000000000000000000000010400000000000000000000000000000e03f010000000000000000000000000000f03f000000000000e03f0000000000003e400000000000000000000000000000d03f",
            ),
            (
                Msg::TruthStep(TruthStep {
                    tick: 9,
                    t_s: 1.0,
                    bodies: vec![body(1, false), body(2, true)],
                    collisions: vec![CollisionEvent { id: UavId::new(2), other_uav: None, x: 1.0, y: -1.0 }],
                    goal_reached_at: Some(0.5),
                    ended: Some(EndReason::Goal),
                    wall_s: 2.0,
                    timing: Box::new(HubTiming { work_us: 300, cmds: 2, late_ms: vec![1.5] }),
                }),
                "0909000000000000f03f0201000000000000f03f000000000000f0bf000000000000e03f000000000000d03f00000000000000000101000000000000004000000000000010400002000000000000f03f000000000000f0bf000000000000e03f000000000000d03f000000000000000001000000000000000040000000000000104001010200000000000000f03f000000000000f0bf01000000000000e03f01000000000000000040ac0202010000c03f",
            ),
            (Msg::Obstacles(ObstacleShare { from: UavId::new(3), tick: 100, t_s: 10.0, centres_cm: vec![[150, -200], [-1, 0]], hops: 0, arrival: 7 }), "0a0364000000000000244002ac028f0301000007"),
            (Msg::NetemRules(r#"{"netem":[],"failures":[]}"#.to_string()), "0b1a7b226e6574656d223a5b5d2c226661696c75726573223a5b5d7d"),
            (
                Msg::Uvdar(Uvdar { tick: 6, t_s: 0.5, seen: vec![UvdarSeen { id: UavId::new(4), range_m: 2.5, bearing_rad: -0.5 }] }),
                "0c06000000000000e03f010400002040000000bf",
            ),
            (Msg::Sense(Box::new(sense_frame())), "0d040201010004000000000000e03f000000000000f03f00000000000000c0000000000000e03f000000000000d03f00000000000000000001000000000000e03f00000000000000000104000000000000e03f000000000000f03f00000000000000c0000000000000e03f000000000000d03f00000000000000000004000000000000e03f000000000000003f00004041010000803f"),
            (
                Msg::Senses(vec![UavSense { id: UavId::new(2), frame: sense_frame() }]),
                "0e0102040201010004000000000000e03f000000000000f03f00000000000000c0000000000000e03f000000000000d03f00000000000000000001000000000000e03f00000000000000000104000000000000e03f000000000000f03f00000000000000c0000000000000e03f000000000000d03f00000000000000000004000000000000e03f000000000000003f00004041010000803f",
            ),
            (
                Msg::Cmds(vec![UavCmd {
                    id: UavId::new(3),
                    cmd: Cmd { tick: 2, kind: CmdKind::Velocity, x: 0.25, y: -0.5, yaw_rate: 0.0 },
                }]),
                "0f010302000000803e000000bf00000000",
            ),
            (Msg::States(vec![state]), "10010207000000000000e03fac02040101030000c03f000000c00000803e0000003e010000003f0000803f000000400000803e0000c03f01c801030405060708090a0b0c0d0e0f10111213141516171801020304050601010000003f0261310203ac0205060708090a0b"),
        ]
    }

    fn hex(bytes: &[u8]) -> String {
        bytes.iter().map(|b| format!("{b:02x}")).collect()
    }

    #[test]
    fn a_hosts_frames_are_copied_into_one_message_as_it_would_encode_them() {
        let frame = |id: u32, tick: u64| {
            let mut f = sense_frame();
            f.radio.id = UavId::new(id);
            f.scan.tick = tick;
            f
        };
        // Ids past one varint byte, and none at all.
        for ids in [vec![], vec![3], vec![1, 2, 130, 70_000]] {
            let frames: Vec<UavSense> =
                ids.iter().map(|&id| UavSense { id: UavId::new(id), frame: frame(id, u64::from(id)) }).collect();
            let parts: Vec<(UavId, Vec<u8>)> = frames
                .iter()
                .map(|u| (u.id, Msg::Sense(Box::new(u.frame.clone())).encode().expect("encodes")))
                .collect();
            let want = Msg::Senses(frames).encode().expect("encodes");
            assert_eq!(Msg::senses_from_encoded(&parts).expect("sensor frames"), want, "ids {ids:?}");
        }
        let clock = Msg::Clock(Clock { tick: 1, t_s: 0.1, dt_s: 0.1 }).encode().expect("encodes");
        assert!(Msg::senses_from_encoded(&[(UavId::new(1), clock)]).is_err(), "not a sensor frame");
    }

    #[test]
    fn roundtrip() {
        for (m, _) in golden() {
            let b = m.encode().expect("encodes");
            assert_eq!(Msg::decode(&b).expect("decodes"), m);
        }
    }

    /// Pins the layout of every variant: a reordered variant or field, a changed integer width or
    /// a new field in the middle changes these bytes.
    #[test]
    fn golden_bytes() {
        let table = golden();
        let indices: Vec<u8> = table.iter().map(|(m, _)| variant_index(m)).collect();
        let all: Vec<u8> = (0..msg_variants().len() as u8).collect();
        assert_eq!(indices, all, "one golden value per Msg variant, in variant order");
        let wrong: Vec<String> = table
            .iter()
            .filter_map(|(m, want)| {
                let got = hex(&m.encode().expect("encodes"));
                (got != *want)
                    .then(|| format!("{} (variant {}):\n  want {want}\n  got  {got}", m.kind(), variant_index(m)))
            })
            .collect();
        assert!(wrong.is_empty(), "wire shape changed; append, never reorder:\n{}", wrong.join("\n"));
    }

    /// Pins the link counters of `AgentState`: six varints in field order.
    #[test]
    fn class_counts_golden_bytes() {
        let c = ClassCounts { offered: 1, delivered: 2, dropped: 3, duplicated: 4, held: 5, released: 300 };
        assert_eq!(postcard::to_stdvec(&c).expect("encodes"), vec![1, 2, 3, 4, 5, 172, 2]);
    }

    #[test]
    fn obstacle_shares_are_compact_and_round_to_centimetres() {
        let pts: Vec<[f64; 2]> = (0..20).map(|i| [f64::from(i) * 0.5 - 5.0, 7.123 - f64::from(i) * 0.3]).collect();
        let share = ObstacleShare {
            from: UavId::new(3),
            tick: 100,
            t_s: 10.0,
            centres_cm: ObstacleShare::quantize(pts.clone()),
            hops: 0,
            arrival: 0,
        };
        let bytes = Msg::Obstacles(share.clone()).encode().expect("encodes");
        assert!(bytes.len() < 110, "20 centres in {} bytes", bytes.len());
        for (a, b) in share.centres_m().zip(&pts) {
            assert!((a[0] - b[0]).abs() <= 0.005 && (a[1] - b[1]).abs() <= 0.005);
        }
        assert_eq!(ObstacleShare::quantize([[f64::NAN, 1.0], [1e9, -1e9]]), vec![[i16::MAX, i16::MIN]]);
    }

    #[test]
    fn malformed_payloads_are_errors_not_panics() {
        for bad in [&[][..], &[200u8][..], &[1, 1][..], &[5, 2, 9][..], &[255; 64][..]] {
            assert!(Msg::decode(bad).is_err(), "{bad:?}");
        }
    }
}

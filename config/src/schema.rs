//! The scenario structs. Field docs are the schema documentation; `scenarios/example.toml` shows
//! every field with a comment and is parsed by a test, so the two cannot drift apart.

use serde::{Deserialize, Serialize};
use swarm_types::{LocalizationMode, TimeMode, UavId};

/// A whole scenario file.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Short name, `[A-Za-z0-9_-]`; used in run folder names.
    pub name: String,
    /// Free text.
    #[serde(default)]
    pub description: String,
    /// Master seed: every random draw of the run (forest, start area, sensor noise) derives from it.
    #[serde(default)]
    pub seed: u64,
    /// Obstacles.
    #[serde(default)]
    pub world: World,
    /// The UAVs, their start and their goal.
    pub swarm: Swarm,
    /// Body limits shared by every UAV.
    #[serde(default)]
    pub body: Body,
    /// 2D LIDAR of every UAV.
    #[serde(default)]
    pub lidar: Lidar,
    /// Who can hear whom.
    #[serde(default)]
    pub radio: Radio,
    /// Lockstep or realtime, control rate.
    #[serde(default)]
    pub time: Time,
    /// The flocking controller.
    #[serde(default)]
    pub controller: Controller,
    /// Obstacle extraction from the scan.
    #[serde(default)]
    pub perception: PerceptionParams,
    /// How agents learn where their neighbours are.
    #[serde(default)]
    pub localization: Localization,
    /// What an agent does when it has lost every neighbour (every controller).
    #[serde(default)]
    pub lost_contact: crate::LostContactParams,
    /// When the run ends.
    #[serde(default)]
    pub end: End,
    /// Network faults on inter-agent messages, in force from their `at_s` on (a later rule for
    /// the same link replaces an earlier one; a rule with no impairment heals).
    #[serde(default)]
    pub netem: Vec<NetemRule>,
    /// Failures of individuals during the run (seed 000 1.2, requirement 4).
    #[serde(default)]
    pub failures: Vec<Failure>,
    /// Goal changes during the run: from `at_s` on, the listed (informed) UAVs fly to `goal`
    /// instead of `swarm.goal`. The end condition always uses `swarm.goal`.
    #[serde(default)]
    pub mission: Vec<GoalChange>,
    /// What the run must show (`swarm run --check`, `swarm fuzz`): which invariants apply and
    /// with what bounds.
    #[serde(default)]
    pub expect: crate::Expect,
}

/// A new goal for some UAVs from some time on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GoalChange {
    /// Sim time it takes effect [s].
    pub at_s: f64,
    /// Which UAVs (only informed ones act on a goal).
    #[serde(default)]
    pub uavs: UavSet,
    /// The goal `[x, y]`, world frame, at `at_s`.
    pub goal: [f64; 2],
    /// A moving goal: its velocity `[vx, vy]` [m/s], world frame, from `at_s` on (P17 flies it with
    /// seed 001's dynamic-goal navigation, eq. 39; the others chase its position).
    #[serde(default)]
    pub velocity_mps: [f64; 2],
}

/// What happens to a failing UAV.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FailureKind {
    /// From `at_s` on the UAV hovers where it is (an obstacle to the others) and says nothing:
    /// the hub ignores its commands and its shares reach no one.
    Freeze,
    /// Its agent process is killed at `at_s` (`swarm run` only): its token goes, the hub stops
    /// waiting for it, and its body keeps its last command.
    Kill,
    /// A new agent process is started for it at `at_s` (`swarm run` only; an old one is killed
    /// first): it fetches the scenario, joins, and is localized again.
    Restart,
    /// Its Zenoh link to the hub stalls silently at `at_s` (`swarm run`, realtime mode only):
    /// nothing crosses it, nothing is closed, and the sessions' leases expire, as with a radio
    /// that fades out.
    #[serde(rename = "link_stall")]
    LinkStall,
    /// Its Zenoh link to the hub is closed at `at_s` and reconnection is refused until restored
    /// (`swarm run`, realtime mode only).
    #[serde(rename = "link_close")]
    LinkClose,
    /// Its Zenoh link to the hub works again from `at_s`: the agent's session reconnects by itself.
    #[serde(rename = "link_restore")]
    LinkRestore,
}

impl FailureKind {
    /// Its name as a scenario file writes it (`freeze`, `link_stall`), for people's reading.
    pub fn name(self) -> &'static str {
        match self {
            FailureKind::Freeze => "freeze",
            FailureKind::Kill => "kill",
            FailureKind::Restart => "restart",
            FailureKind::LinkStall => "link_stall",
            FailureKind::LinkClose => "link_close",
            FailureKind::LinkRestore => "link_restore",
        }
    }

    /// Whether this is a link-level fault (carried out by `swarm run`'s TCP proxy).
    pub fn is_link(self) -> bool {
        matches!(self, FailureKind::LinkStall | FailureKind::LinkClose | FailureKind::LinkRestore)
    }
}

/// One failure of one UAV.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Failure {
    /// Sim time it fails [s].
    pub at_s: f64,
    /// Which UAV.
    pub uav: UavId,
    /// How.
    pub kind: FailureKind,
}

/// Which UAVs a netem rule applies to: `"all"` or a list of ids.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum UavSet {
    /// Every UAV (the string must be `"all"`).
    All(AllMarker),
    /// These ids.
    Ids(Vec<UavId>),
}

impl Default for UavSet {
    fn default() -> Self {
        UavSet::All(AllMarker::All)
    }
}

impl UavSet {
    /// Whether `id` is in the set.
    pub fn contains(&self, id: UavId) -> bool {
        match self {
            UavSet::All(_) => true,
            UavSet::Ids(ids) => ids.contains(&id),
        }
    }
}

/// One timed network rule: from `at_s` on, messages from a UAV in `from` to one in `to` pass
/// `rule` (Linux netem semantics, modelled by `netem::impair`).
///
/// With `partition` set instead, the event is a partition (Jepsen's schemes, see
/// [`crate::Partition`]): from `at_s` on it replaces the partition in force, the links it
/// cuts are blocked (or held, with `rule = { hold = true }`) whatever other rules say, and the
/// rest keep their per-link rules. `partition = { scheme = "healed" }` ends it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NetemRule {
    /// Sim time the rule takes effect [s].
    #[serde(default)]
    pub at_s: f64,
    /// Senders it applies to.
    #[serde(default)]
    pub from: UavSet,
    /// Receivers it applies to.
    #[serde(default)]
    pub to: UavSet,
    /// The impairment.
    #[serde(default)]
    pub rule: crate::Impairment,
    /// A partition event instead of a per-link rule (then `from`/`to` must stay `"all"` and
    /// `rule` may only set `hold`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub partition: Option<crate::Partition>,
}

impl NetemRule {
    /// A per-link rule.
    pub fn link(at_s: f64, from: UavSet, to: UavSet, rule: crate::Impairment) -> NetemRule {
        NetemRule { at_s, from, to, rule, partition: None }
    }

    /// A partition event; `hold` stores the cut links' messages instead of dropping them.
    pub fn partition(at_s: f64, partition: crate::Partition, hold: bool) -> NetemRule {
        let rule = if hold { crate::Impairment::HOLD } else { crate::Impairment::IDENTITY };
        NetemRule { at_s, from: UavSet::default(), to: UavSet::default(), rule, partition: Some(partition) }
    }
}

/// Timed network rules and failures: the `[[netem]]` and `[[failures]]` of a scenario, or of a
/// separate experiment file (`swarm run --experiment`, `swarm netem apply`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Timeline {
    /// Network rules and partition events.
    #[serde(default)]
    pub netem: Vec<NetemRule>,
    /// Failures of individuals.
    #[serde(default)]
    pub failures: Vec<Failure>,
}

/// Obstacles: explicit trees and walls, plus an optional generated forest.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct World {
    /// Explicit trees (circles).
    #[serde(default)]
    pub trees: Vec<Tree>,
    /// Explicit walls (segments with a thickness).
    #[serde(default)]
    pub walls: Vec<Wall>,
    /// A generated forest, added to the explicit trees.
    #[serde(default)]
    pub forest: Option<Forest>,
}

/// A tree trunk: a circle in the plane of flight.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tree {
    /// Centre x [m].
    pub x: f64,
    /// Centre y [m].
    pub y: f64,
    /// Trunk radius [m].
    pub r: f64,
}

/// A wall: the segment (x1,y1)-(x2,y2) thickened to `thickness`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Wall {
    /// First end x [m].
    pub x1: f64,
    /// First end y [m].
    pub y1: f64,
    /// Second end x [m].
    pub x2: f64,
    /// Second end y [m].
    pub y2: f64,
    /// Full thickness [m].
    #[serde(default = "d_wall_thickness")]
    pub thickness: f64,
}
fn d_wall_thickness() -> f64 {
    0.2
}

/// A forest generated by seeded Poisson-disc-like rejection sampling.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Forest {
    /// The rectangle trees are placed in.
    pub region: Region,
    /// Trees per 100 m² (before rejection by spacing; the generator reports the achieved value).
    pub density_per_100m2: f64,
    /// Minimum centre-to-centre distance between trees [m].
    #[serde(default = "d_min_spacing")]
    pub min_spacing_m: f64,
    /// Trunk radius range [min, max] in metres, drawn uniformly.
    #[serde(default = "d_trunk")]
    pub trunk_radius_m: [f64; 2],
    /// Seed of the forest; defaults to the scenario seed.
    #[serde(default)]
    pub seed: Option<u64>,
    /// Discs where no tree may stand (start and goal areas).
    #[serde(default)]
    pub keep_clear: Vec<Tree>,
}
fn d_min_spacing() -> f64 {
    2.5
}
fn d_trunk() -> [f64; 2] {
    [0.1, 0.4]
}

/// An axis-aligned rectangle.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Region {
    /// Left edge [m].
    pub x_min: f64,
    /// Right edge [m].
    pub x_max: f64,
    /// Bottom edge [m].
    pub y_min: f64,
    /// Top edge [m].
    pub y_max: f64,
}

/// The UAVs: how many, where they start, where they go.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Swarm {
    /// Number of UAVs; their ids are 1..=count.
    pub count: u32,
    /// Explicit start positions `[[x, y], ...]`, one per UAV.
    #[serde(default)]
    pub start_positions: Option<Vec<[f64; 2]>>,
    /// Or a disc to draw start positions from (seeded).
    #[serde(default)]
    pub start_area: Option<StartArea>,
    /// Initial heading of every UAV [deg], world frame.
    #[serde(default)]
    pub start_heading_deg: f64,
    /// Goal `[x, y]` in the world frame; informed UAVs receive it in their own odometry frame.
    pub goal: [f64; 2],
    /// Which UAVs know the goal: `"all"` or a list of ids.
    #[serde(default = "d_informed")]
    pub informed: Informed,
    /// UAVs that have failed before the start (seed 000 6.2): their bodies hover where they
    /// start, obstacles to the others, and no agent runs for them.
    #[serde(default)]
    pub failed: Vec<UavId>,
}
fn d_informed() -> Informed {
    Informed::All(AllMarker::All)
}

/// `informed = "all"` or `informed = [1, 3]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Informed {
    /// Every UAV knows the goal (the string must be `"all"`).
    All(AllMarker),
    /// Only these UAV ids know the goal.
    Ids(Vec<UavId>),
}

/// The literal string `"all"`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AllMarker {
    /// `"all"`
    All,
}

/// A disc of start positions.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StartArea {
    /// Centre `[x, y]` [m].
    pub center: [f64; 2],
    /// Radius [m].
    pub radius_m: f64,
    /// Minimum distance between two start positions [m].
    #[serde(default = "d_start_spacing")]
    pub min_spacing_m: f64,
}
fn d_start_spacing() -> f64 {
    1.5
}

/// How a UAV body follows its command.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CommandKind {
    /// The command is a desired velocity (body frame) plus a yaw rate (K21).
    Velocity,
    /// The command is a desired acceleration (body frame) plus a yaw rate (A21).
    Acceleration,
}

/// What happens to a UAV after it collides.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum OnCollision {
    /// Record it and keep flying.
    Continue,
    /// Record it and stop the UAV where it is (it stays an obstacle).
    Stop,
}

/// Body limits.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Body {
    /// Body radius [m] (collision and LIDAR footprint).
    #[serde(default = "d_radius")]
    pub radius_m: f64,
    /// Speed limit [m/s].
    #[serde(default = "d_speed")]
    pub max_speed_mps: f64,
    /// Acceleration limit [m/s²].
    #[serde(default = "d_accel")]
    pub max_accel_mps2: f64,
    /// Yaw-rate limit [deg/s].
    #[serde(default = "d_yaw_rate")]
    pub max_yaw_rate_dps: f64,
    /// Velocity or acceleration commands.
    #[serde(default = "d_command")]
    pub command: CommandKind,
    /// Behaviour after a collision.
    #[serde(default = "d_on_collision")]
    pub on_collision: OnCollision,
}
fn d_radius() -> f64 {
    0.3
}
fn d_speed() -> f64 {
    1.0
}
fn d_accel() -> f64 {
    2.0
}
fn d_yaw_rate() -> f64 {
    90.0
}
fn d_command() -> CommandKind {
    CommandKind::Velocity
}
fn d_on_collision() -> OnCollision {
    OnCollision::Continue
}
impl Default for Body {
    fn default() -> Self {
        Body {
            radius_m: d_radius(),
            max_speed_mps: d_speed(),
            max_accel_mps2: d_accel(),
            max_yaw_rate_dps: d_yaw_rate(),
            command: d_command(),
            on_collision: d_on_collision(),
        }
    }
}

/// A 360° 2D LIDAR (RPLIDAR A3-like).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Lidar {
    /// Beams over 360°.
    #[serde(default = "d_beams")]
    pub beams: u32,
    /// Maximum range [m].
    #[serde(default = "d_range")]
    pub max_range_m: f64,
    /// Gaussian range noise σ [m].
    #[serde(default = "d_noise")]
    pub noise_std_m: f64,
    /// Probability that a beam returns nothing.
    #[serde(default)]
    pub dropout: f64,
}
fn d_beams() -> u32 {
    750
}
fn d_range() -> f64 {
    12.0
}
fn d_noise() -> f64 {
    0.02
}
impl Default for Lidar {
    fn default() -> Self {
        Lidar { beams: d_beams(), max_range_m: d_range(), noise_std_m: d_noise(), dropout: 0.0 }
    }
}

/// Radio range with hysteresis, from ground truth in the hub.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Radio {
    /// Two UAVs closer than this hear each other [m].
    #[serde(default = "d_radio_range")]
    pub range_m: f64,
    /// A link, once up, drops only beyond `range_m + hysteresis_m`.
    #[serde(default = "d_hysteresis")]
    pub hysteresis_m: f64,
    /// Distance-dependent loss on links that are up (none by default).
    #[serde(default)]
    pub distance_loss: Option<DistanceLoss>,
}

/// Distance-dependent loss of inter-agent messages, from ground truth: 0 up to `from_m`, rising
/// linearly to `at_range` at `range_m`, and on at the same slope (capped at 1) through the
/// hysteresis band. Applied per message, before the netem rules, from the link's seeded stream.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DistanceLoss {
    /// Distance below which nothing is lost [m].
    pub from_m: f64,
    /// Loss probability at `radio.range_m`.
    pub at_range: f64,
}

impl DistanceLoss {
    /// The loss probability at distance `d` for a radio of range `range_m`.
    pub fn at(&self, d: f64, range_m: f64) -> f64 {
        if d.is_nan() || d <= self.from_m {
            return 0.0;
        }
        (self.at_range * (d - self.from_m) / (range_m - self.from_m)).clamp(0.0, 1.0)
    }
}
fn d_radio_range() -> f64 {
    10.0
}
fn d_hysteresis() -> f64 {
    1.0
}
impl Default for Radio {
    fn default() -> Self {
        Radio { range_m: d_radio_range(), hysteresis_m: d_hysteresis(), distance_loss: None }
    }
}

/// Clock settings.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Time {
    /// `lockstep` or `realtime`.
    #[serde(default = "d_mode")]
    pub mode: TimeMode,
    /// Control (and simulation) rate [Hz].
    #[serde(default = "d_hz")]
    pub control_hz: f64,
    /// Lockstep: how long the hub waits for a live agent's command before moving on [ms]. Killed
    /// agents are noticed at once through liveliness; this bounds the wait for a hung one.
    #[serde(default = "d_tick_timeout")]
    pub tick_timeout_ms: u64,
    /// Realtime: sim seconds per wall second.
    #[serde(default = "d_factor")]
    pub realtime_factor: f64,
    /// How long the hub waits for all agents to come alive before tick 0 [s].
    #[serde(default = "d_startup")]
    pub startup_timeout_s: f64,
}
fn d_mode() -> TimeMode {
    TimeMode::Lockstep
}
fn d_hz() -> f64 {
    10.0
}
fn d_tick_timeout() -> u64 {
    5000
}
fn d_factor() -> f64 {
    1.0
}
fn d_startup() -> f64 {
    60.0
}
impl Default for Time {
    fn default() -> Self {
        Time {
            mode: d_mode(),
            control_hz: d_hz(),
            tick_timeout_ms: d_tick_timeout(),
            realtime_factor: d_factor(),
            startup_timeout_s: d_startup(),
        }
    }
}

/// Which controller flies the swarm: one of the four built in, or one a program registered
/// under its own name (`uav_agent::Controllers::with`; the run checks that it knows the name).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(try_from = "String", into = "String")]
pub enum ControllerKind {
    /// Seed 000 chapter 4: Boids with tangential obstacle avoidance; velocity output.
    K21,
    /// Seed 001 chapter 3: Reynolds flocking with virtual β-agents for obstacles; velocity output.
    P17,
    /// Seed 003 section III: proximal control plus A* navigation; acceleration output.
    A21,
    /// Seed 004 chapter 3: formation topologies on top of a costmap planner; velocity output.
    M23,
    /// A controller registered by the program that flies the scenario, by its name.
    Own(String),
}

impl ControllerKind {
    /// The name a scenario gives (`k21`, `p17`, `a21`, `m23`, or the registered one).
    pub fn name(&self) -> &str {
        match self {
            ControllerKind::K21 => "k21",
            ControllerKind::P17 => "p17",
            ControllerKind::A21 => "a21",
            ControllerKind::M23 => "m23",
            ControllerKind::Own(name) => name,
        }
    }
}

impl TryFrom<String> for ControllerKind {
    type Error = String;
    fn try_from(name: String) -> Result<Self, String> {
        let valid = name.starts_with(|c: char| c.is_ascii_lowercase() || c.is_ascii_digit())
            && name.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-' || c == '_');
        Ok(match name.as_str() {
            "k21" => ControllerKind::K21,
            "p17" => ControllerKind::P17,
            "a21" => ControllerKind::A21,
            "m23" => ControllerKind::M23,
            _ if valid => ControllerKind::Own(name),
            _ => return Err(format!("`{name}` is not a controller name: k21, p17, a21, m23, or a registered name of lower-case letters, digits, `-` and `_`")),
        })
    }
}

impl From<ControllerKind> for String {
    fn from(k: ControllerKind) -> String {
        k.name().to_string()
    }
}

/// Controller choice and parameters.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Controller {
    /// The controller.
    #[serde(default = "d_controller")]
    pub kind: ControllerKind,
    /// UAVs flown by an external controller instead of `kind`: their agents publish each tick's
    /// view on `uav/{id}/ext/view` (JSON) and wait for a command on `uav/{id}/ext/cmd`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub external: Vec<UavId>,
    /// K21 parameters.
    #[serde(default)]
    pub k21: K21Params,
    /// P17 parameters.
    #[serde(default)]
    pub p17: crate::P17Params,
    /// A21 parameters.
    #[serde(default)]
    pub a21: crate::A21Params,
    /// M23 parameters.
    #[serde(default)]
    pub m23: crate::M23Params,
}
fn d_controller() -> ControllerKind {
    ControllerKind::K21
}
impl Default for Controller {
    fn default() -> Self {
        Controller {
            kind: d_controller(),
            external: Vec::new(),
            k21: K21Params::default(),
            p17: crate::P17Params::default(),
            a21: crate::A21Params::default(),
            m23: crate::M23Params::default(),
        }
    }
}

/// K21 parameters (seed 000 chapter 4). Where the seed gives a number it is the default.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct K21Params {
    /// Cohesion weight kc (eq. 4.1).
    #[serde(default = "one")]
    pub kc: f64,
    /// Separation weight ks (eq. 4.1).
    #[serde(default = "one")]
    pub ks: f64,
    /// Avoidance weight ko (eq. 4.1).
    #[serde(default = "one")]
    pub ko: f64,
    /// Navigation weight kn (eq. 4.1).
    #[serde(default = "one")]
    pub kn: f64,
    /// Speed scale kf (eq. 4.2) [m/s]; seed 000 Fig. 6.4 caps the final magnitude at 0.4.
    #[serde(default = "d_kf")]
    pub kf: f64,
    /// Cohesion dead radius, the 2.5 of eq. 4.4 [m].
    #[serde(default = "d_coh")]
    pub cohesion_radius_m: f64,
    /// Separation is active within this distance, the 2 of eq. 4.8 [m].
    #[serde(default = "d_sep_r")]
    pub separation_radius_m: f64,
    /// Separation scale, the 3 of eq. 4.7 [m].
    #[serde(default = "d_sep_s")]
    pub separation_scale_m: f64,
    /// Obstacle avoidance is active within this distance of the obstacle centre [m].
    #[serde(default = "d_avoid_r")]
    pub avoidance_radius_m: f64,
    /// Avoidance magnitude gain, the 2 of eq. 4.12 [m].
    #[serde(default = "d_avoid_g")]
    pub avoidance_gain_m: f64,
    /// Obstacles more than this angle from the desired direction are ignored (seed 000 4.4) [deg].
    #[serde(default = "d_avoid_ignore")]
    pub avoidance_ignore_deg: f64,
    /// "An obstacle nearby" for cohesion (seed 000 4.2): nearest obstacle centre closer than this [m].
    #[serde(default = "d_near")]
    pub obstacle_near_m: f64,
    /// Heading alignment: yaw rate = heading_gain · α (eq. 4.14) [1/s].
    #[serde(default = "one")]
    pub heading_gain: f64,
    /// K21 uses only the neighbours closer than this (cohesion, separation, alignment) [m].
    /// Seed 000 does not give the reach of its 40-UAV controller-only run (section 6.4); its ICP
    /// held a neighbour to about 6.5 m (section 6.2). 5 m keeps cohesion quiet inside a crowd:
    /// the centroid of a half disc of uniformly spread neighbours lies 4R/(3π) = 2.1 m away,
    /// inside the 2.5 m dead radius of eq. 4.4, so only a UAV with a gap beside it is pulled.
    #[serde(default = "d_nb_r")]
    pub neighbour_radius_m: f64,
    /// Neighbours closer than this count in separation whatever their direction [m]. Section
    /// 4.3's 180° sector alone leaves two UAVs flying side by side with slightly different
    /// headings each just behind the other's beam, blind to each other (forest-100 came to 0.78 m).
    #[serde(default = "d_sep_all")]
    pub separation_all_around_m: f64,
    /// How the separation terms v_i of eq. 4.8 combine into v_s (eq. 4.9).
    #[serde(default)]
    pub separation_combine: SeparationCombine,
    /// Cohesion and separation may not push towards "an obstacle nearby" (section 4.2's
    /// `obstacle_near_m`): their component along the closest obstacle is removed, so avoidance
    /// keeps the priority section 4.6 gives it.
    #[serde(default = "d_true")]
    pub obstacle_priority: bool,
    /// Every obstacle centre and every neighbour closer than this [m] is a barrier: the final
    /// velocity (eq. 4.2) loses its component towards each of them, so avoiding the closest
    /// obstacle (eq. 4.10-4.13) never pushes the UAV into a second one (a frozen UAV on one
    /// side, a trunk on the other), nor separation into another neighbour. Our extension; 0
    /// turns it off, the bodies of `barrier_surface_m` with it. At 1 m it never engages in seed
    /// 000's section 6.1 flights, whose UAVs keep more than 1.1 m from every trunk's surface and
    /// 1.3 m from each other.
    #[serde(default = "one")]
    pub barrier_m: f64,
    /// The barrier's reach for the nearest point of a body inside a scan group that joins
    /// several [m]. Seed 000's grouping (Algorithm 2) joins points less than 1 m apart, so UAVs
    /// packed closer than about 1.6 m, or a UAV beside a trunk, make one group whose circle can
    /// lie off every body in it: the barrier on centres missed a UAV 0.42 m from its surface
    /// (centre 0.72 m; forest-100-icp's goal-point contacts). Such a group is split into its
    /// bodies (`uav-agent/src/perception/bodies.rs`): each body is a barrier by the centre of its
    /// circle under `barrier_m` where one fits, else by its nearest point under this. 0.7 m is
    /// `barrier_m` less a UAV's 0.3 m radius. Our extension; 0 turns the split off (and so does
    /// `barrier_m = 0`, with the rest of the barrier).
    #[serde(default = "d_barrier_surface")]
    pub barrier_surface_m: f64,
    /// The barrier's graded band [m]: within the outer `barrier_ramp_m` of each reach
    /// (`barrier_m` for centres, `barrier_surface_m` for nearest points) the UAV may still
    /// approach, at a speed falling linearly from kf at the reach to 0 at the reach less this
    /// (a control-barrier-function form, v·ŷ ≤ kf·(d − d_stop)/ramp), and not at all deeper in.
    /// A hard barrier (0) stops a UAV that is already within reach of two points less than 180°
    /// apart, as in a gap between a trunk and a UAV whose agent died: every direction through
    /// the gap approaches both, and it waited there for good (issue 46). 0.15 m stops the
    /// approach of a UAV's centre at 0.85 m, above the separation invariant's 0.8 m. Our
    /// extension.
    #[serde(default = "d_barrier_ramp")]
    pub barrier_ramp_m: f64,
    /// Arrival, our extension (seed 000 is silent on it): an informed UAV within this distance
    /// of its goal [m] has arrived, and slows towards the goal's centre. Once one has, every UAV
    /// with a path of shares to it turns to what is closer to the arrival (an informed UAV to the
    /// goal, the others to their nearest neighbour with a lower arrival count, stopping within
    /// `cohesion_radius_m` of it), so the swarm settles around the goal instead of flying on past
    /// it (`uav-agent/src/control/arrival.rs`). Default (none): the scenario's
    /// `end.goal_radius_m`; 0 turns it off (the swarm orbits its goal, as before issue 25).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub arrival_radius_m: Option<f64>,
    /// The detour, our extension (opt-in; 0, the default, turns it off): a UAV whose K21
    /// velocity the barrier has held under a tenth of kf for this long [s], while K21 wanted at
    /// least half of kf, is at the mouth of a gap the barrier shuts (a frozen UAV on one side, a
    /// trunk on the other), and every direction K21 wants points into it (issue 46: it waited
    /// there for good). It then flies, for `detour_s`, the direction closest to K21's that the
    /// barrier lets through, turning always to the side it first found free, so that repeated
    /// detours walk it round the blockage (`uav-agent/src/control/detour.rs`).
    #[serde(default)]
    pub detour_after_s: f64,
    /// How long one detour lasts [s] (`detour_after_s`).
    #[serde(default = "d_detour")]
    pub detour_s: f64,
}

/// How K21's separation terms combine (seed 000 eq. 4.9).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SeparationCombine {
    /// The mean of eq. 4.9 as written: in a crowd, pushes from several sides dilute the push
    /// from the closest neighbour (forest-40: contacts).
    Mean,
    /// The sum of the v_i, clipped to unit length like eq. 4.6 and 4.13: one close neighbour
    /// pushes as hard as it would alone, and several never push harder than 1.
    #[default]
    ClippedSum,
}
fn d_sep_all() -> f64 {
    1.2
}
fn d_nb_r() -> f64 {
    5.0
}
fn d_true() -> bool {
    true
}
fn one() -> f64 {
    1.0
}
fn d_barrier_surface() -> f64 {
    0.7
}
fn d_barrier_ramp() -> f64 {
    0.15
}
fn d_kf() -> f64 {
    0.4
}
fn d_detour() -> f64 {
    10.0
}
fn d_coh() -> f64 {
    2.5
}
fn d_sep_r() -> f64 {
    2.0
}
fn d_sep_s() -> f64 {
    3.0
}
fn d_avoid_r() -> f64 {
    4.0
}
fn d_avoid_g() -> f64 {
    2.0
}
fn d_avoid_ignore() -> f64 {
    135.0
}
fn d_near() -> f64 {
    2.5
}
impl Default for K21Params {
    fn default() -> Self {
        K21Params {
            kc: 1.0,
            ks: 1.0,
            ko: 1.0,
            kn: 1.0,
            kf: d_kf(),
            cohesion_radius_m: d_coh(),
            separation_radius_m: d_sep_r(),
            separation_scale_m: d_sep_s(),
            avoidance_radius_m: d_avoid_r(),
            avoidance_gain_m: d_avoid_g(),
            avoidance_ignore_deg: d_avoid_ignore(),
            obstacle_near_m: d_near(),
            heading_gain: 1.0,
            neighbour_radius_m: d_nb_r(),
            separation_all_around_m: d_sep_all(),
            separation_combine: SeparationCombine::ClippedSum,
            obstacle_priority: true,
            barrier_m: one(),
            barrier_surface_m: d_barrier_surface(),
            barrier_ramp_m: d_barrier_ramp(),
            arrival_radius_m: None,
            detour_after_s: 0.0,
            detour_s: d_detour(),
        }
    }
}

impl K21Params {
    /// Whether the barrier keeps off the bodies of a scan group that joins several: both
    /// `barrier_m` and `barrier_surface_m` above 0.
    pub fn barrier_on_bodies(&self) -> bool {
        self.barrier_m > 0.0 && self.barrier_surface_m > 0.0
    }
}

/// Obstacle extraction (seed 000 section 3.2).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PerceptionParams {
    /// A new group starts where consecutive points are farther apart than this (Algorithm 2: 1 m).
    #[serde(default = "d_gap")]
    pub group_gap_m: f64,
    /// Groups with fewer points are dropped (3: a circle has 3 unknowns).
    #[serde(default = "d_min_points")]
    pub min_points: u32,
    /// Fitted circles outside [min, max] radius are rejected as implausible [m].
    #[serde(default = "d_radius_range")]
    pub radius_range_m: [f64; 2],
    /// An obstacle within this distance of a localized neighbour is that neighbour, not a tree [m].
    #[serde(default = "d_match")]
    pub neighbour_match_m: f64,
}
fn d_gap() -> f64 {
    1.0
}
fn d_min_points() -> u32 {
    3
}
fn d_radius_range() -> [f64; 2] {
    [0.03, 1.5]
}
fn d_match() -> f64 {
    0.6
}
impl Default for PerceptionParams {
    fn default() -> Self {
        PerceptionParams {
            group_gap_m: d_gap(),
            min_points: d_min_points(),
            radius_range_m: d_radius_range(),
            neighbour_match_m: d_match(),
        }
    }
}

/// How the neighbour database tells neighbours apart in `icp` mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Identify {
    /// By the obstacle set itself: agents stay anonymous (seed 000 5.2).
    Scan,
    /// By the sender id in the key, for comparison.
    Key,
}

/// When a tracked neighbour's re-check (lICP) is due in a crowd (`[localization.icp]
/// crowd_rechecks`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CrowdRechecks {
    /// Every `long_every_s`, whatever the fit: seed 000's clock, which the crowd's full-grid rate
    /// then spreads (the default).
    #[default]
    Clock,
    /// As outside a crowd: a neighbour whose short ICPs all fit tightly since its last full grid
    /// waits `tight_long_every_s`, so the rate goes first to the tracks in doubt.
    TightWait,
}

/// Localization settings.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Localization {
    /// The mode.
    #[serde(default = "d_loc")]
    pub mode: LocalizationMode,
    /// A neighbour estimate older than this is dropped [s] (seed 000 5.3: 0.5 s).
    #[serde(default = "d_stale")]
    pub stale_after_s: f64,
    /// ICP parameters (`icp` mode).
    #[serde(default)]
    pub icp: IcpParams,
    /// Onboard relative sensing (`uvdar` mode, seed 003).
    #[serde(default)]
    pub uvdar: crate::UvdarParams,
    /// Artificial error on the broadcast position (`broadcast` mode; seed 001 section 6).
    #[serde(default)]
    pub broadcast_error: Option<BroadcastError>,
}

/// The artificial localization error of seed 001 section 6 (eq. 45–46): from `from_s` until
/// `until_s`, the GNSS-like position of each UAV in `uavs` is off by a fresh error vector every
/// tick, uniform in direction and with its length uniform in [0, `delta_a_m`]. The UAV flies on
/// and broadcasts the wrong position, as with a degraded GPS.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BroadcastError {
    /// δa, the largest error [m].
    pub delta_a_m: f64,
    /// Which UAVs are affected.
    #[serde(default)]
    pub uavs: UavSet,
    /// Start [s].
    #[serde(default)]
    pub from_s: f64,
    /// End [s] (none: to the end of the run).
    #[serde(default)]
    pub until_s: Option<f64>,
}

impl BroadcastError {
    /// Whether UAV `id` is affected at sim time `t`.
    pub fn active(&self, id: UavId, t: f64) -> bool {
        self.uavs.contains(id) && t + 1e-9 >= self.from_s && self.until_s.is_none_or(|u| t < u - 1e-9)
    }
}
fn d_loc() -> LocalizationMode {
    LocalizationMode::Broadcast
}
fn d_stale() -> f64 {
    0.5
}
impl Default for Localization {
    fn default() -> Self {
        Localization {
            mode: d_loc(),
            stale_after_s: d_stale(),
            icp: IcpParams::default(),
            uvdar: crate::UvdarParams::default(),
            broadcast_error: None,
        }
    }
}

/// ICP with FRMSD outlier rejection and the neighbour database (seed 000 3.1, 3.3, 5.1–5.3).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IcpParams {
    /// FRMSD exponent λ (eq. 3.16; 1.3 in 2D).
    #[serde(default = "d_lambda")]
    pub lambda: f64,
    /// Iteration cap of one ICP run.
    #[serde(default = "d_iters")]
    pub max_iterations: u32,
    /// Stop when the error falls below this [m].
    #[serde(default = "d_icp_tol")]
    pub tolerance_m: f64,
    /// Initial-estimate grid: (2·half_cells + 1)² points (seed 000 5.1: 21×21) ...
    #[serde(default = "d_half_cells")]
    pub grid_half_cells: u32,
    /// ... spaced this far apart [m] (0.5).
    #[serde(default = "d_grid_spacing")]
    pub grid_spacing_m: f64,
    /// Relative headings tried at every grid point.
    #[serde(default = "d_headings")]
    pub grid_headings: u32,
    /// A received set matches an entry when FRMSD ≤ this (seed 000 5.3: 1) ...
    #[serde(default = "one_f")]
    pub match_frmsd: f64,
    /// ... and the alignment to the entry's last set shifts it at most this far [m] ...
    #[serde(default = "one_f")]
    pub match_shift_m: f64,
    /// ... and turns it at most this much [deg] (the neighbour's own motion between its scans).
    #[serde(default = "d_turn")]
    pub match_turn_deg: f64,
    /// An entry whose neighbour could not be placed is left alone this long [s] (5).
    #[serde(default = "d_five")]
    pub suspend_s: f64,
    /// An entry gets a long ICP (full grid, lICP) this often [s] (seed 000 5.1, Algorithm 6: 5) ...
    #[serde(default = "d_five")]
    pub long_every_s: f64,
    /// ... unless every short ICP since its last full grid fit tightly (FRMSD ≤ 0.3 m, the fit a
    /// first placement needs): then this often [s] (30; our choice, seed 000 re-checks on the
    /// clock alone). Equal to `long_every_s` gives seed 000's schedule.
    #[serde(default = "d_tight_long_every")]
    pub tight_long_every_s: f64,
    /// At most this many long or initial ICPs per control step (seed 000 6.2: 2).
    #[serde(default = "d_max_long")]
    pub max_long_per_step: u32,
    /// Failsafe: no further long or initial ICP once the step has taken this long [ms]. Realtime
    /// mode only: in lockstep the hub waits, and a wall-clock decision would break repeatability.
    #[serde(default = "d_budget")]
    pub step_budget_ms: f64,
    /// Fewer points on either side, or fewer pairs kept by FRMSD, give no estimate. 3 is the
    /// geometric minimum; 5 rejects most wrong alignments in a forest, where any few trees can be
    /// made to line up (forest-5, three seeds: false estimates 117–315 at 3, 0–33 at 5).
    #[serde(default = "d_min_points_icp")]
    pub min_points: u32,
    /// How neighbours are told apart.
    #[serde(default = "d_identify")]
    pub identify: Identify,
    /// The localization budget (issue 48), our extension of seed 000 6.2's cap on full-grid
    /// ICPs to every ICP that updates an estimate: at most this many per control step (the
    /// full-grid ones, still at most `max_long_per_step`, first), the short ones to the
    /// neighbours whose new set does not fit where their track (odometry frame, constant
    /// velocity) predicts it, then the longest unchecked. A neighbour left over is listed at its
    /// prediction, confirmed by its set if that fit within the noise, else ageing until its turn
    /// (`uav-agent/src/localization/icp/database.rs`). 0 (the default): no budget,
    /// every neighbour's short ICP in every step, as seed 000 schedules them. For large swarms
    /// (`forest-1000-icp`).
    #[serde(default)]
    pub budget_per_step: u32,
    /// In a crowd (10 or more usable sets in a step), the re-checks (lICP) and retries of
    /// unplaced entries share this many full-grid ICPs per second of sim time [1/s], saved up to
    /// four (`uav-agent/src/localization/icp/database.rs`, "Fewer ICPs in a crowd"). 1 (the
    /// default) is what the crowd lab chose at 40 UAVs; a new neighbour's placement is outside
    /// it. Lower spends less on large swarms, whose agents have many more neighbours wanting a
    /// check than any rate serves, but re-places lost neighbours more slowly: `forest-1000-icp`
    /// at 0.1 halved its agents' step and lost most of its neighbours in the forest
    /// (docs/performance.md, "The crowd's full-grid rate"). 0: none in a crowd.
    #[serde(default = "one_f")]
    pub crowd_full_grids_per_s: f64,
    /// In a crowd, the retries of neighbours not placed (new ones whose first placement failed,
    /// lost ones) take the full-grid ICPs of `crowd_full_grids_per_s` before the re-checks (lICP)
    /// of tracked ones, which get what the retries leave. false (the default): all wait their
    /// turn, most overdue first. A large swarm's unplaced neighbours are where the full grids
    /// count: each one that comes within the grid's reach is a neighbour more in the
    /// controller's view, while a crowd's re-check seldom changes a track
    /// (`docs/performance.md`, "Retries first").
    #[serde(default)]
    pub crowd_retries_first: bool,
    /// In a crowd, a neighbour whose radio link came up less than `suspend_s` ago is taken as out
    /// of the full grid's reach: its new entry starts suspended (seed 000 5.3's out of range),
    /// so its first full grid is a retry in `crowd_full_grids_per_s`, `suspend_s` after the link
    /// came up, instead of a placement outside the rate that almost never places. A link comes
    /// up at the radio range's edge (10 m by default), twice the grid's reach (±5 m); the links
    /// of an agent's first radio set are not waited for. false (the default): every new
    /// neighbour is placed at once, as seed 000 does (`docs/performance.md`, "New links wait").
    #[serde(default)]
    pub crowd_new_links_wait: bool,
    /// In a crowd, when a tracked neighbour's re-check is due in `crowd_full_grids_per_s`:
    /// `"clock"` (the default: every `long_every_s`, most overdue first) or `"tight_wait"` (one
    /// whose short ICPs all fit tightly since its last full grid waits `tight_long_every_s`, as
    /// outside a crowd). A false track's short ICPs fit poorly, so a scarce rate goes first where
    /// a track may be wrong (`docs/performance.md`, "Re-checks by need in a crowd").
    #[serde(default)]
    pub crowd_rechecks: CrowdRechecks,
    /// In a crowd, a full grid that places a neighbour scores the whole grid of positions but
    /// only this many of the `grid_headings` headings, the ones nearest where the neighbour is
    /// expected to be turned: a lost track's last relative heading, or for a neighbour never
    /// placed the placed neighbours' mean one, when at least three agree within about 26° (K21
    /// aligns a swarm's headings). A placement with nothing to go by keeps every heading, as a
    /// re-check does (but see `crowd_recheck_headings`). 0 (the default): every heading, as
    /// seed 000's full grid (`docs/performance.md`, "Placements at the expected heading").
    #[serde(default)]
    pub crowd_placement_headings: u32,
    /// In a crowd, a re-check of a tracked neighbour scores the whole grid of positions but only
    /// this many of the `grid_headings` headings, the ones nearest the placed neighbours' mean
    /// relative heading when at least three agree within about 26° (K21 aligns a swarm's
    /// headings), so a track locked onto a place turned away from the swarm is still found
    /// out. With nothing to go by the re-check keeps every heading. 0 (the default): every
    /// heading, as seed 000's lICP (`docs/performance.md`, "Re-checks at the swarm's heading").
    #[serde(default)]
    pub crowd_recheck_headings: u32,
}
fn d_lambda() -> f64 {
    1.3
}
fn d_iters() -> u32 {
    30
}
fn d_icp_tol() -> f64 {
    1e-4
}
fn d_half_cells() -> u32 {
    10
}
fn d_grid_spacing() -> f64 {
    0.5
}
fn d_headings() -> u32 {
    16
}
fn one_f() -> f64 {
    1.0
}
fn d_five() -> f64 {
    5.0
}
fn d_tight_long_every() -> f64 {
    30.0
}
fn d_turn() -> f64 {
    30.0
}
fn d_max_long() -> u32 {
    2
}
fn d_budget() -> f64 {
    20.0
}
fn d_min_points_icp() -> u32 {
    5
}
fn d_identify() -> Identify {
    Identify::Scan
}
impl Default for IcpParams {
    fn default() -> Self {
        IcpParams {
            lambda: d_lambda(),
            max_iterations: d_iters(),
            tolerance_m: d_icp_tol(),
            grid_half_cells: d_half_cells(),
            grid_spacing_m: d_grid_spacing(),
            grid_headings: d_headings(),
            match_frmsd: 1.0,
            match_shift_m: 1.0,
            match_turn_deg: d_turn(),
            suspend_s: 5.0,
            long_every_s: 5.0,
            tight_long_every_s: d_tight_long_every(),
            max_long_per_step: d_max_long(),
            step_budget_ms: d_budget(),
            min_points: d_min_points_icp(),
            identify: d_identify(),
            budget_per_step: 0,
            crowd_full_grids_per_s: 1.0,
            crowd_retries_first: false,
            crowd_new_links_wait: false,
            crowd_rechecks: CrowdRechecks::Clock,
            crowd_placement_headings: 0,
            crowd_recheck_headings: 0,
        }
    }
}

/// Which UAVs must be inside the goal radius for the goal to count as reached.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum GoalRule {
    /// Every UAV.
    All,
    /// The swarm's centroid.
    Centroid,
}

/// End conditions.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct End {
    /// Goal radius [m].
    #[serde(default = "d_goal_r")]
    pub goal_radius_m: f64,
    /// Who must be inside it.
    #[serde(default = "d_goal_rule")]
    pub goal_rule: GoalRule,
    /// Sim-time limit [s].
    #[serde(default = "d_limit")]
    pub time_limit_s: f64,
    /// The goal rule must hold this long without a break before the run ends with the goal [s]
    /// (0: as soon as it holds); the time to goal is the start of that streak. A swarm that
    /// reaches its goal and flies on past it does not count as arrived.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub hold_s: f64,
}
fn is_zero(v: &f64) -> bool {
    *v == 0.0
}
fn d_goal_r() -> f64 {
    4.0
}
fn d_goal_rule() -> GoalRule {
    GoalRule::All
}
fn d_limit() -> f64 {
    300.0
}
impl Default for End {
    fn default() -> Self {
        End { goal_radius_m: d_goal_r(), goal_rule: d_goal_rule(), time_limit_s: d_limit(), hold_s: 0.0 }
    }
}

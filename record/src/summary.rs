//! `summary.json`, schema `swarm.summary.v1`. Fields are only ever added, never renamed or
//! removed; docs/watching-and-recording.md documents each one. Distances are in metres, times in sim seconds unless
//! a name says wall.

use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::fmt::Write as _;
use swarm_types::UavId;

/// Numbers that can be undefined (infinite distances with no obstacle or no other UAV, NaN means
/// of nothing) are `null` in JSON.
mod inf_as_null {
    use super::*;
    pub fn serialize<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
        if v.is_finite() {
            s.serialize_f64(*v)
        } else {
            s.serialize_none()
        }
    }
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::INFINITY))
    }
}

/// Schema id written into every summary.
pub const SCHEMA: &str = "swarm.summary.v1";

/// The summary of one run.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Summary {
    /// Always [`SCHEMA`].
    pub schema: String,
    /// Run id (the `{run}` of every key).
    pub run_id: String,
    /// Scenario name.
    pub scenario: String,
    /// `lockstep` or `realtime`.
    pub time_mode: String,
    /// Number of UAVs.
    pub uav_count: usize,
    /// Trees in the world.
    pub trees: usize,
    /// `goal`, `time_limit`, `no_agents`, `stopped`, or `incomplete` if the hub vanished.
    pub end_reason: String,
    /// Whether the goal rule was met.
    pub reached_goal: bool,
    /// Sim time the goal rule was first met.
    pub time_to_goal_s: Option<f64>,
    /// Sim time at the end.
    pub sim_time_s: f64,
    /// Wall time from tick 0 to the end.
    pub wall_time_s: f64,
    /// Sim seconds per wall second.
    pub sim_speed: f64,
    /// Ticks recorded.
    pub ticks: u64,
    /// Collisions (contacts begun), UAV–obstacle plus UAV–UAV.
    pub collisions: usize,
    /// Each collision.
    pub collision_events: Vec<CollisionRecord>,
    /// Smallest distance from any UAV centre to an obstacle surface.
    #[serde(with = "inf_as_null")]
    pub min_obstacle_distance_m: f64,
    /// Smallest centre-to-centre distance between two UAVs.
    #[serde(with = "inf_as_null")]
    pub min_agent_distance_m: f64,
    /// Mean nearest-neighbour distance between UAVs over the last 10 s of the run (the lattice
    /// spacing ξ of seed 001 4.1) [m].
    #[serde(with = "inf_as_null")]
    pub lattice_spacing_m: f64,
    /// Its standard deviation over those 10 s: small when the lattice has settled [m].
    #[serde(with = "inf_as_null")]
    pub lattice_spacing_std_m: f64,
    /// Seed 004 section 3.5's metrics over every UAV: mean distance to the nearest neighbour, its
    /// deviation, blocking time (mean per UAV), trajectory length (mean per UAV), mean distance to
    /// the nearest obstacle; the mission time is `time_to_goal_s`.
    pub formation: FormationMetrics,
    /// How well agents knew where their neighbours were.
    pub localization: LocalizationSummary,
    /// Who knew of whom, over time.
    pub connectivity: Connectivity,
    /// What the inter-agent links did to the messages, per link class (the rule in force on the
    /// link at the send instant: `clean`, `impaired`, `cut` = blocked or held).
    pub network: Vec<ClassSummary>,
    /// Per UAV.
    pub agents: Vec<AgentSummary>,
    /// Wall-clock costs and late commands (measured: they differ from run to run, even in
    /// lockstep). Appended; absent (zero) in older summaries.
    #[serde(default)]
    pub timing: TimingSummary,
    /// The invariants of the scenario's `[expect]`, each passed or failed with its first failing
    /// moment (issue 15). Appended; empty in older summaries.
    #[serde(default)]
    pub checks: Vec<CheckResult>,
    /// What the agent sessions received: shares per tick that reached each session and those
    /// that counted, and bytes per tick (issue 22). Measured: it depends on how the agents share
    /// sessions and on when a subscription's undeclaration reached the router. Appended; absent
    /// (zero) in older summaries.
    #[serde(default)]
    pub traffic: TrafficSummary,
    /// The UAVs whose agent never came (never held its liveliness token in any tick): the hub
    /// flew them without one, hovering. Appended; empty in older summaries.
    #[serde(default)]
    pub never_joined: Vec<UavId>,
    /// The UAVs whose agent came and was gone at the end (killed, crashed, its host gone, cut off
    /// for good), with when it went: their bodies hovered from then on; the goal check of a run
    /// that flew to its time limit judges the rest without them, and the checks count their links
    /// as cut. Appended; empty in older summaries.
    #[serde(default)]
    pub lost: Vec<LostUav>,
}

/// A UAV whose agent was lost, and since when.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LostUav {
    /// Its id.
    pub id: UavId,
    /// The sim time of the first tick its agent no longer held its token [s].
    pub at_s: f64,
}

/// What the agents and their sessions (one agent's process, or a host's) received, from the
/// counts each agent's state carries. Per agent and tick: each agent's own counts (what it would
/// receive on a session of its own, so one agent per process and hosts read alike) over the
/// ticks it reported; per session: what the session received once for all its agents.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TrafficSummary {
    /// Agent sessions that reported.
    pub sessions: usize,
    /// Shares that reached an agent (from the UAVs it listened to: what it would receive on a
    /// session of its own), per agent and tick.
    pub shares_arrived_per_agent_tick: f64,
    /// Shares that counted (sent inside a neighbour's window), per agent and tick: what the
    /// agents needed.
    pub shares_counted_per_agent_tick: f64,
    /// Payload bytes an agent received (its sensors, radio sets, rules and those shares), per
    /// agent and tick.
    pub bytes_per_agent_tick: f64,
    /// Each session.
    pub per_session: Vec<SessionTrafficSummary>,
}

/// What one agent session received.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SessionTrafficSummary {
    /// The session's Zenoh id.
    pub session: String,
    /// Agents that flew on it.
    pub agents: usize,
    /// Their UAV ids.
    #[serde(default)]
    pub uavs: Vec<UavId>,
    /// Ticks its agents reported, first to last.
    pub ticks: u64,
    /// Shares that reached it per tick.
    pub shares_arrived_per_tick: f64,
    /// Shares that counted per tick, summed over its agents.
    pub shares_counted_per_tick: f64,
    /// Payload bytes received per tick (everything).
    pub bytes_per_tick: f64,
    /// Shares from UAVs of other sessions per tick: what crossed the network.
    pub remote_shares_per_tick: f64,
    /// Their payload bytes per tick.
    pub remote_share_bytes_per_tick: f64,
    /// Shares of those senders that never came between two that did, while subscribed, over the
    /// whole run (lost on the way or never sent; see the wire's `Traffic::remote_share_gaps`).
    #[serde(default)]
    pub remote_share_gaps: u64,
    /// Share subscriptions it held, mean over its agents' states (the union of their radio sets).
    pub subscriptions_mean: f64,
}

/// One invariant evaluated over a run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CheckResult {
    /// The check's name (`collision`, `min_separation`, ... as in `[expect]`).
    pub name: String,
    /// Whether it held.
    pub passed: bool,
    /// What was checked, with the bound (and why it passed vacuously, when it did).
    pub detail: String,
    /// The first moment it failed (null when it passed).
    pub first_failure: Option<CheckFailure>,
}

/// The first moment an invariant failed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CheckFailure {
    /// Sim time.
    pub t_s: f64,
    /// What went wrong, in words.
    pub what: String,
    /// The UAVs involved, each with its world position then.
    pub uavs: Vec<UavAt>,
}

/// UAVs of a failed check named in the terminal summary; summary.json keeps them all.
pub const SHOWN_UAVS: usize = 8;

/// A UAV and where it was.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UavAt {
    /// UAV id.
    pub id: UavId,
    /// World x.
    pub x_m: f64,
    /// World y.
    pub y_m: f64,
}

/// What a run cost on the wall clock, and how well the agents kept up (issue 11: the `swarm
/// scale` table's hub tick and agent step percentiles, and item 6's late commands).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct TimingSummary {
    /// Median of the hub's own work per tick (sensors and integration, not the wait for
    /// commands) [wall ms].
    #[serde(with = "inf_as_null")]
    pub hub_tick_p50_ms: f64,
    /// Its 99th percentile [wall ms].
    #[serde(with = "inf_as_null")]
    pub hub_tick_p99_ms: f64,
    /// Median over every step of every agent of the control step (perception + localization +
    /// control) [wall ms].
    #[serde(with = "inf_as_null")]
    pub agent_step_p50_ms: f64,
    /// Its 99th percentile [wall ms].
    #[serde(with = "inf_as_null")]
    pub agent_step_p99_ms: f64,
    /// Commands the hub took.
    pub commands: u64,
    /// Those that arrived after their tick had closed (in `realtime` mode the tick closes on the
    /// wall clock; in `lockstep` only a tick timeout makes a command late).
    pub late_commands: u64,
    /// `late_commands / commands` (0 with no command).
    pub late_share: f64,
    /// 99th percentile of how late the late ones were: arrival − the instant their tick closed
    /// (null: none late) [wall ms].
    #[serde(with = "inf_as_null")]
    pub late_p99_ms: f64,
}

/// Neighbour estimates scored against ground truth at the same tick (seed 000 6.1 reports a
/// mean ICP distance error of 0.052 m and a stable neighbour count 89 % of the time).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct LocalizationSummary {
    /// `broadcast` or `icp`.
    pub mode: String,
    /// Estimates scored (those carrying the sender's id).
    pub estimates_scored: u64,
    /// Mean distance between an estimated and the true relative position (null if none).
    #[serde(with = "inf_as_null")]
    pub mean_error_m: f64,
    /// Its 95th percentile.
    #[serde(with = "inf_as_null")]
    pub p95_error_m: f64,
    /// Mean over agents of the share of steps at which the agent's neighbour count was at its
    /// most common value.
    #[serde(with = "inf_as_null")]
    pub stable_neighbour_share: f64,
    /// Mean size of an inter-agent share message [bytes].
    #[serde(with = "inf_as_null")]
    pub bytes_per_share_message: f64,
    /// Estimates more than 1 m from the truth: neighbours placed where none is.
    pub false_estimates: u64,
    /// Mean age of the newest information agents held about their neighbours [s].
    #[serde(with = "inf_as_null")]
    pub mean_info_age_s: f64,
    /// Its 95th percentile [s].
    #[serde(with = "inf_as_null")]
    pub p95_info_age_s: f64,
}

/// Connectivity of the graph "agent i has a current estimate of j" (weakly connected components
/// over the agents that reported at a tick).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Connectivity {
    /// Each time the number of components changed (the first entry is the start).
    pub components_changes: Vec<ComponentsAt>,
    /// For each heal of the `[[netem]]` timeline (a rule with no impairment), how long until the
    /// graph was one component again (null: never).
    pub reconnections: Vec<Reconnection>,
    /// Estimates an agent held of a neighbour whose link to it had been blocked for longer than
    /// the estimate staleness: information that crossed a partition (should be 0).
    pub estimates_across_blocked_links: u64,
    /// States that came for a tick the recorder had already settled (older than every truth
    /// step it keeps, 200 ticks), left out of the components and the count above (should be 0;
    /// absent from summaries written before it was added).
    #[serde(default)]
    pub states_left_out: u64,
}

/// Seed 004 section 3.5's metrics (Table 8 compares LF, PF and TNPF with them).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct FormationMetrics {
    /// Mean over UAVs and ticks of the distance to the nearest other UAV [m].
    #[serde(with = "inf_as_null")]
    pub mean_neighbour_distance_m: f64,
    /// Mean over UAVs of the standard deviation over ticks of that distance [m] ("deviation from
    /// neighbours").
    #[serde(with = "inf_as_null")]
    pub neighbour_distance_deviation_m: f64,
    /// Mean over UAVs of the blocking time [s].
    pub mean_blocking_time_s: f64,
    /// Mean over UAVs of the trajectory length [m].
    pub mean_trajectory_length_m: f64,
    /// Mean over UAVs and ticks of the distance to the nearest obstacle surface [m].
    #[serde(with = "inf_as_null")]
    pub mean_obstacle_distance_m: f64,
}

/// Messages received on links of one class, over every agent, and the delay actually applied
/// to the delivered copies (delivery instant − send instant; at least one tick).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ClassSummary {
    /// `clean`, `impaired` or `cut`.
    pub class: String,
    /// `offered`, `delivered`, `dropped`, `duplicated`, `held`, `released` (netem's counters).
    #[serde(flatten)]
    pub counts: swarm_wire::ClassCounts,
    /// Mean applied delay [s] (null: nothing delivered).
    #[serde(with = "inf_as_null")]
    pub mean_delay_s: f64,
    /// 95th percentile of the applied delay [s].
    #[serde(with = "inf_as_null")]
    pub p95_delay_s: f64,
}

/// The number of components from a time on.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ComponentsAt {
    /// Sim time.
    pub t_s: f64,
    /// Components.
    pub components: usize,
}

/// Reconnection after one heal.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Reconnection {
    /// Sim time of the heal.
    pub heal_at_s: f64,
    /// Time from the heal to one component again (null: never).
    pub reconnected_after_s: Option<f64>,
    /// Time from the heal until the graph is one component and stays so to the end of the run
    /// (null: it does not).
    pub stays_connected_after_s: Option<f64>,
}

/// A UAV lost all its neighbours (`regained` false) or found one again.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ContactEvent {
    /// Sim time.
    pub t_s: f64,
    /// Found again (true) or lost (false).
    pub regained: bool,
    /// True distance to the nearest other live UAV at that moment.
    #[serde(with = "inf_as_null")]
    pub nearest_uav_m: f64,
}

/// One collision.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CollisionRecord {
    /// Sim time.
    pub t_s: f64,
    /// UAV id.
    pub id: UavId,
    /// Other UAV, or null for an obstacle.
    pub other_uav: Option<UavId>,
    /// World x.
    pub x_m: f64,
    /// World y.
    pub y_m: f64,
}

/// Per-UAV metrics.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct AgentSummary {
    /// UAV id.
    pub id: UavId,
    /// Minimum distance from its centre to an obstacle surface.
    #[serde(with = "inf_as_null")]
    pub min_obstacle_distance_m: f64,
    /// Mean over ticks of that distance.
    #[serde(with = "inf_as_null")]
    pub mean_obstacle_distance_m: f64,
    /// Minimum distance to the nearest other UAV (centre to centre).
    #[serde(with = "inf_as_null")]
    pub min_agent_distance_m: f64,
    /// Standard deviation over ticks of the distance to the nearest other UAV (seed 004 3.5's
    /// deviation from neighbours).
    #[serde(with = "inf_as_null")]
    pub agent_distance_std_m: f64,
    /// Time it was blocked: moved less than 0.1 m during the preceding 1 s (seed 004 3.5) [s].
    pub blocking_time_s: f64,
    /// Mean over ticks of the distance to the nearest other UAV.
    #[serde(with = "inf_as_null")]
    pub mean_agent_distance_m: f64,
    /// Length of its path.
    pub path_length_m: f64,
    /// Share messages it published.
    pub messages_sent: u64,
    /// Bytes of those.
    pub bytes_sent: u64,
    /// Share messages it received from neighbours.
    pub messages_received: u64,
    /// Bytes of those.
    pub bytes_received: u64,
    /// Share messages handed to its localization after netem (lost ones are not; duplicates
    /// count twice).
    pub messages_delivered: u64,
    /// Payloads it dropped as malformed.
    pub malformed_messages: u64,
    /// Mean wall time of its control step (perception + localization + control).
    pub mean_step_time_ms: f64,
    /// Longest control step.
    pub max_step_time_ms: f64,
    /// Mean number of neighbours it had an estimate of.
    pub mean_neighbours: f64,
    /// Ticks its command missed (hub timeout) while it was alive.
    pub late_ticks: u64,
    /// Mean error of its neighbour estimates against ground truth (null if none).
    #[serde(with = "inf_as_null")]
    pub mean_localization_error_m: f64,
    /// 95th percentile of those errors.
    #[serde(with = "inf_as_null")]
    pub p95_localization_error_m: f64,
    /// Share of its steps at which its neighbour count was at its most common value.
    #[serde(with = "inf_as_null")]
    pub stable_neighbour_share: f64,
    /// Its estimates more than 1 m from the truth.
    pub false_estimates: u64,
    /// Estimates other agents made of it, by its id, within 1 m of the truth: how its
    /// neighbours localized it.
    pub placed_by_others: u64,
    /// Each time it lost all neighbours or found one again.
    pub contact_events: Vec<ContactEvent>,
    /// Steps at which no live UAV was within 8 m of it.
    pub steps_alone: u64,
    /// Neighbours it reported during those steps: all false.
    pub neighbours_reported_while_alone: u64,
    /// Mean age of the newest information it held about each neighbour [s].
    #[serde(with = "inf_as_null")]
    pub mean_info_age_s: f64,
    /// Its 95th percentile [s].
    #[serde(with = "inf_as_null")]
    pub p95_info_age_s: f64,
    /// Sim time it spent alone: no other UAV within radio range, by ground truth (alone once
    /// beyond `range_m + hysteresis_m` of every UAV, back once within `range_m` of one) [s].
    #[serde(default)]
    pub time_alone_s: f64,
    /// Times it became alone.
    #[serde(default)]
    pub alone_spells: u32,
    /// Null if never alone; else whether its last time alone ended before the run did.
    #[serde(default)]
    pub rejoined: Option<bool>,
    /// When its last time alone ended (null: never alone, or alone at the end) [s].
    #[serde(default)]
    pub rejoined_at_s: Option<f64>,
    /// Its largest distance to the nearest other UAV over the run [m].
    #[serde(default, with = "inf_as_null")]
    pub max_nearest_uav_m: f64,
}

/// The `rejoined` column: `-` never alone, `no` alone at the end, else when it came back [s].
fn rejoined(a: &AgentSummary) -> String {
    match (a.rejoined, a.rejoined_at_s) {
        (None, _) => "-".into(),
        (Some(true), Some(t)) => format!("{t:.1}"),
        _ => "no".into(),
    }
}

fn f3(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.3}")
    } else {
        "-".into()
    }
}

/// Two decimals, or `-` for a value that is not finite.
pub fn f(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.2}")
    } else {
        "-".into()
    }
}

impl Summary {
    /// The exit status of `swarm run` / `swarm record`: 0 for a run that ended by its own rule
    /// (goal or time limit) with the hub exiting cleanly (`hub_ok`), 130 for one stopped by
    /// Ctrl-C, 1 otherwise (hub failed, vanished, no agents).
    pub fn exit_code(&self, hub_ok: bool) -> std::process::ExitCode {
        match self.end_reason.as_str() {
            "goal" | "time_limit" if hub_ok => std::process::ExitCode::SUCCESS,
            "stopped" => std::process::ExitCode::from(130),
            _ => std::process::ExitCode::FAILURE,
        }
    }

    /// The checks that failed.
    pub fn failed_checks(&self) -> impl Iterator<Item = &CheckResult> {
        self.checks.iter().filter(|c| !c.passed)
    }

    /// The checks in a few lines: a count, then one line per failure with its first moment and
    /// the first [`SHOWN_UAVS`] UAVs involved (a thousand-UAV run would print them all on one line).
    pub fn checks_human(&self) -> String {
        let failed = self.failed_checks().count();
        let mut s = format!("checks: {} passed, {failed} failed", self.checks.len() - failed);
        for c in self.failed_checks() {
            let _ = write!(s, "\n  FAIL {}: {}", c.name, c.detail);
            if let Some(f) = &c.first_failure {
                let at: Vec<String> = f
                    .uavs
                    .iter()
                    .take(SHOWN_UAVS)
                    .map(|u| format!("{} at ({:.2}, {:.2})", u.id, u.x_m, u.y_m))
                    .collect();
                let more = f.uavs.len().saturating_sub(SHOWN_UAVS);
                let more =
                    if more > 0 { format!(" and {more} more (summary.json lists every one)") } else { String::new() };
                let _ = write!(s, "\n       first at t={:.1} s: {}; UAVs {}{more}", f.t_s, f.what, at.join(", "));
            }
        }
        s
    }

    /// A human rendering for the terminal.
    pub fn human(&self) -> String {
        let mut s = String::new();
        let goal = match (self.reached_goal, self.time_to_goal_s) {
            (true, Some(t)) => format!("reached in {t:.1} s"),
            _ => format!("NOT reached ({})", self.end_reason),
        };
        let _ = writeln!(
            s,
            "run {}  scenario {}  ({} UAVs, {} trees, {})",
            self.run_id, self.scenario, self.uav_count, self.trees, self.time_mode
        );
        if !self.never_joined.is_empty() {
            let _ = writeln!(
                s,
                "WARNING: the agents of UAVs {:?} never joined (they hovered, uncontrolled); see the run folder's logs/",
                self.never_joined
            );
        }
        if !self.lost.is_empty() {
            let lost: Vec<String> = self.lost.iter().map(|l| format!("{} at {:.1} s", l.id, l.at_s)).collect();
            let _ = writeln!(
                s,
                "lost: the agents of UAVs {} went away (they hovered from then on; the goal check judges the rest)",
                lost.join(", ")
            );
        }
        let _ = writeln!(s, "goal: {goal}");
        let _ = writeln!(s, "collisions: {}", self.collisions);
        let _ = writeln!(
            s,
            "sim {:.1} s in {:.1} s wall: {:.1}x real time ({} ticks)",
            self.sim_time_s, self.wall_time_s, self.sim_speed, self.ticks
        );
        let _ = writeln!(
            s,
            "{:>4} {:>9} {:>9} {:>9} {:>9} {:>8} {:>8} {:>9} {:>9} {:>9} {:>8} {:>8} {:>8} {:>9}",
            "uav",
            "obst min",
            "obst mean",
            "uav min",
            "uav mean",
            "path m",
            "msgs tx",
            "bytes tx",
            "msgs rx",
            "delivered",
            "step ms",
            "alone s",
            "rejoined",
            "uav max"
        );
        for a in &self.agents {
            let _ = writeln!(
                s,
                "{:>4} {:>9} {:>9} {:>9} {:>9} {:>8.1} {:>8} {:>9} {:>9} {:>9} {:>8.3} {:>8.1} {:>8} {:>9}",
                a.id,
                f(a.min_obstacle_distance_m),
                f(a.mean_obstacle_distance_m),
                f(a.min_agent_distance_m),
                f(a.mean_agent_distance_m),
                a.path_length_m,
                a.messages_sent,
                a.bytes_sent,
                a.messages_received,
                a.messages_delivered,
                a.mean_step_time_ms,
                a.time_alone_s,
                rejoined(a),
                f(a.max_nearest_uav_m)
            );
        }
        let l = &self.localization;
        let _ = writeln!(
            s,
            "localization ({}): mean error {} m, p95 {} m over {} estimates; neighbour count stable {}% of the time; {} bytes per share",
            l.mode,
            f3(l.mean_error_m),
            f3(l.p95_error_m),
            l.estimates_scored,
            f(100.0 * l.stable_neighbour_share),
            f(l.bytes_per_share_message)
        );
        let t = &self.timing;
        let _ = writeln!(
            s,
            "hub tick {} / {} ms, agent step {} / {} ms (p50 / p99); late commands {} of {} ({}%), p99 {} ms late",
            f3(t.hub_tick_p50_ms),
            f3(t.hub_tick_p99_ms),
            f3(t.agent_step_p50_ms),
            f3(t.agent_step_p99_ms),
            t.late_commands,
            t.commands,
            f(100.0 * t.late_share),
            f(t.late_p99_ms)
        );
        let w = &self.traffic;
        if w.sessions > 0 {
            let _ = writeln!(
                s,
                "traffic per agent and tick: {} shares arrived, {} counted, {} kB received; {} agent sessions",
                f(w.shares_arrived_per_agent_tick),
                f(w.shares_counted_per_agent_tick),
                f(w.bytes_per_agent_tick / 1000.0),
                w.sessions
            );
        }
        let _ = write!(
            s,
            "min distance to obstacles {} m, to other UAVs {} m",
            f(self.min_obstacle_distance_m),
            f(self.min_agent_distance_m)
        );
        if !self.checks.is_empty() {
            let _ = write!(s, "\n{}", self.checks_human());
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failed_check_names_a_few_uavs_and_counts_the_rest() {
        let uavs = |n: usize| UavId::all(n).map(|id| UavAt { id, x_m: 1.0, y_m: -2.0 }).collect::<Vec<_>>();
        let sc = swarm_config::builtin("forest-5").expect("builtin");
        let mut s = crate::recorder::metrics::Metrics::default().summary("r", &sc);
        for n in [3, 1000] {
            s.checks = vec![CheckResult {
                name: "goal".into(),
                passed: false,
                detail: "the centroid within 4.0 m of the goal by 60 s".into(),
                first_failure: Some(CheckFailure { t_s: 60.0, what: "goal not reached".into(), uavs: uavs(n) }),
            }];
            let text = s.checks_human();
            let named = text.matches(" at (1.00, -2.00)").count();
            assert_eq!(named, n.min(SHOWN_UAVS), "{text}");
            assert_eq!(text.contains("and 992 more (summary.json lists every one)"), n == 1000, "{text}");
        }
    }

    #[test]
    fn infinite_distances_are_null_and_read_back() {
        let a = AgentSummary {
            id: UavId::new(1),
            min_obstacle_distance_m: f64::INFINITY,
            min_agent_distance_m: 1.5,
            ..Default::default()
        };
        let json = serde_json::to_value(&a).expect("serializes");
        assert!(json["min_obstacle_distance_m"].is_null());
        assert_eq!(json["min_agent_distance_m"], 1.5);
        let back: AgentSummary = serde_json::from_value(json).expect("reads back");
        assert_eq!(back.min_obstacle_distance_m, f64::INFINITY);
        assert_eq!(back.min_agent_distance_m, 1.5);
    }
}

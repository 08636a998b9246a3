//! Scenario schema of a swarm run, parsed from TOML and validated.
//!
//! A scenario says everything a run needs: the world (explicit trees and walls, or a generated
//! forest), the swarm (count, start, goal, who is informed), body limits, the LIDAR, the radio,
//! the time mode, the controller with its parameters, the localization mode and the end
//! conditions. Every struct rejects unknown fields, and every error names the file, the field
//! (as a dotted path) and what is wrong, so a typo never silently falls back to a default.
//!
//! Entry points: [`Scenario::from_file`], [`Scenario::from_toml_str`], [`builtin`] (the scenarios
//! shipped in `scenarios/`, compiled in so `swarm run` works with no argument).
//!
//! Architecture invariant: this crate is pure data plus validation, and depends on no other crate
//! of the workspace. It knows nothing of Zenoh, of geometry libraries or of how the world is
//! simulated; forest generation lives in `physics-hub`, which is the only holder of ground truth.
//! The `[[netem]]` rules and `[[failures]]` are data here too ([`Impairment`], [`Partition`],
//! [`NetemRule`], [`Timeline`]); which rule is in force at a sim time, and what it does to a
//! message, is the `netem` crate's (`netem::Timeline`, `netem::impair`).
//!
//! Modules (private, their items re-exported at the root): `schema` (the scenario structs),
//! `impairment` (a netem rule's impairment and partition, and their validation), and one module
//! per controller or sensor with parameters of its own (`p17`, `a21`, `m23`, `costmap`, `uvdar`),
//! `lost_contact` (what every controller does once its swarm is out of reach) and `expect` (the `[expect]` table: which run invariants apply, with what bounds).

use serde::{Deserialize, Serialize};
use std::path::Path;

mod a21;
mod costmap;
mod expect;
mod impairment;
mod lost_contact;
mod m23;
mod p17;
mod schema;
mod uvdar;
pub use a21::*;
pub use costmap::*;
pub use expect::*;
pub use impairment::*;
pub use lost_contact::*;
pub use m23::*;
pub use p17::*;
pub use schema::*;
pub use uvdar::*;

/// A scenario could not be read or is invalid. Always names the source, the field and the problem.
#[derive(Debug, thiserror::Error)]
#[error("{source_name}: field `{field}`: {message}")]
pub struct ScenarioError {
    /// The file (or built-in name) the scenario came from.
    pub source_name: String,
    /// Dotted path of the offending field, or `(file)` when the file itself is the problem.
    pub field: String,
    /// What is wrong.
    pub message: String,
}

impl ScenarioError {
    fn new(source_name: &str, field: impl Into<String>, message: impl Into<String>) -> Self {
        ScenarioError { source_name: source_name.to_string(), field: field.into(), message: message.into() }
    }
}

/// Built-in scenarios, `(name, toml text)`: the files of `scenarios/`, compiled in.
pub const BUILTIN: &[(&str, &str)] = &[
    ("a21-forest-uvdar", include_str!("../../scenarios/a21-forest-uvdar.toml")),
    ("compare-4", include_str!("../../scenarios/compare-4.toml")),
    ("forest-5", include_str!("../../scenarios/forest-5.toml")),
    ("forest-5-burst-frozen", include_str!("../../scenarios/forest-5-burst-frozen.toml")),
    ("forest-5-linkloss", include_str!("../../scenarios/forest-5-linkloss.toml")),
    ("forest-5-lossy", include_str!("../../scenarios/forest-5-lossy.toml")),
    ("forest-7-failed", include_str!("../../scenarios/forest-7-failed.toml")),
    ("forest-9-dense", include_str!("../../scenarios/forest-9-dense.toml")),
    ("forest-9-stranded", include_str!("../../scenarios/forest-9-stranded.toml")),
    ("forest-9-cut-off", include_str!("../../scenarios/forest-9-cut-off.toml")),
    ("forest-40", include_str!("../../scenarios/forest-40.toml")),
    ("forest-100", include_str!("../../scenarios/forest-100.toml")),
    ("forest-40-arrive", include_str!("../../scenarios/forest-40-arrive.toml")),
    ("forest-100-arrive", include_str!("../../scenarios/forest-100-arrive.toml")),
    ("forest-40-icp", include_str!("../../scenarios/forest-40-icp.toml")),
    ("forest-100-icp", include_str!("../../scenarios/forest-100-icp.toml")),
    ("forest-1000-icp", include_str!("../../scenarios/forest-1000-icp.toml")),
    ("m23-indoor-lf", include_str!("../../scenarios/m23-indoor-lf.toml")),
    ("m23-indoor-none", include_str!("../../scenarios/m23-indoor-none.toml")),
    ("m23-indoor-pf", include_str!("../../scenarios/m23-indoor-pf.toml")),
    ("m23-indoor-tnpf", include_str!("../../scenarios/m23-indoor-tnpf.toml")),
    ("open-1000", include_str!("../../scenarios/open-1000.toml")),
    ("open-field-5", include_str!("../../scenarios/open-field-5.toml")),
    ("open-field-5-linkfault", include_str!("../../scenarios/open-field-5-linkfault.toml")),
    ("open-field-5-restart", include_str!("../../scenarios/open-field-5-restart.toml")),
    ("open-field-7-partition", include_str!("../../scenarios/open-field-7-partition.toml")),
    ("p17-error-forest", include_str!("../../scenarios/p17-error-forest.toml")),
    ("p17-error-free", include_str!("../../scenarios/p17-error-free.toml")),
    ("p17-free-4", include_str!("../../scenarios/p17-free-4.toml")),
    ("p17-gap", include_str!("../../scenarios/p17-gap.toml")),
    ("p17-moving-goal", include_str!("../../scenarios/p17-moving-goal.toml")),
    ("p17-wall", include_str!("../../scenarios/p17-wall.toml")),
    ("example", include_str!("../../scenarios/example.toml")),
];

/// The scenario `swarm run` uses when given none.
pub const DEFAULT_SCENARIO: &str = "forest-5";

/// Looks up a built-in scenario by name and parses it.
pub fn builtin(name: &str) -> Result<Scenario, ScenarioError> {
    let (_, text) = BUILTIN
        .iter()
        .find(|(n, _)| *n == name)
        .ok_or_else(|| ScenarioError::new(name, "(file)", format!("no built-in scenario named `{name}`")))?;
    Scenario::from_toml_str(text, &format!("builtin:{name}"))
}

/// Deserializes TOML, naming the dotted path of the field that fails.
fn parse_toml<T: serde::de::DeserializeOwned>(text: &str, source_name: &str) -> Result<T, ScenarioError> {
    let de = toml::Deserializer::new(text);
    serde_path_to_error::deserialize(de).map_err(|e| {
        let field = e.path().to_string();
        let field = if field == "." { "(top level)".to_string() } else { field };
        let inner = e.into_inner();
        // A syntax error has no field and, for some inputs, no message of its own: the full text
        // then says where (line, column) and what.
        let message = match inner.message().trim() {
            "" => inner.to_string().trim().to_string(),
            m => m.to_string(),
        };
        let message = match inner.span() {
            Some(span) => {
                let (line, column) = line_column(text, span.start);
                format!("{message} (line {line}, column {column})")
            }
            None => message,
        };
        ScenarioError::new(source_name, field, message)
    })
}

/// Listed start positions closer than `min_m` put two bodies into one another: refused, naming
/// the UAVs (ids are 1-based, in list order).
fn apart(field: &str, p: &[[f64; 2]], min_m: f64) -> Check {
    for (i, a) in p.iter().enumerate() {
        for (j, b) in p.iter().enumerate().skip(i + 1) {
            let d = (a[0] - b[0]).hypot(a[1] - b[1]);
            if d < min_m {
                return Err((
                    field.into(),
                    format!(
                        "UAVs {} and {} start {d:.2} m apart, closer than two body radii ({min_m:.2} m)",
                        i + 1,
                        j + 1
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// The 1-based line and column (in characters) of byte `at` of `text`.
fn line_column(text: &str, at: usize) -> (usize, usize) {
    let mut end = at.min(text.len());
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    let before = &text[..end];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, column)
}

impl Timeline {
    /// Reads an experiment file: a TOML timeline of `[[netem]]` and `[[failures]]` tables. Errors
    /// name the file and the field; ids are checked against a scenario by
    /// [`Scenario::check_timeline`].
    pub fn from_file(path: &Path) -> Result<Timeline, ScenarioError> {
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path)
            .map_err(|e| ScenarioError::new(&name, "(file)", format!("cannot read: {e}")))?;
        parse_toml(&text, &name)
    }
}

impl Scenario {
    /// Reads an experiment file (see [`Timeline::from_file`]) and checks it against this
    /// scenario. Errors name the file and the field.
    pub fn timeline_from_file(&self, path: &Path) -> Result<Timeline, ScenarioError> {
        let t = Timeline::from_file(path)?;
        let name = path.display().to_string();
        self.check_timeline(&t, false).map_err(|e| ScenarioError::new(&name, "(timeline)", e))?;
        Ok(t)
    }

    /// Reads and validates a scenario file.
    pub fn from_file(path: &Path) -> Result<Scenario, ScenarioError> {
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path)
            .map_err(|e| ScenarioError::new(&name, "(file)", format!("cannot read: {e}")))?;
        Scenario::from_toml_str(&text, &name)
    }

    /// Resolves a `swarm run` argument: a path to a TOML file, or the name of a built-in.
    pub fn from_arg(arg: &str) -> Result<(Scenario, String), ScenarioError> {
        let path = Path::new(arg);
        if path.exists() {
            let text = std::fs::read_to_string(path)
                .map_err(|e| ScenarioError::new(arg, "(file)", format!("cannot read: {e}")))?;
            let sc = Scenario::from_toml_str(&text, arg)?;
            return Ok((sc, text));
        }
        match BUILTIN.iter().find(|(n, _)| *n == arg) {
            Some((_, text)) => Ok((Scenario::from_toml_str(text, &format!("builtin:{arg}"))?, text.to_string())),
            None => Err(ScenarioError::new(
                arg,
                "(file)",
                format!(
                    "no such file, and no built-in scenario of that name (built-ins: {})",
                    BUILTIN.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ")
                ),
            )),
        }
    }

    /// Parses and validates scenario TOML; `source_name` is used in error messages.
    pub fn from_toml_str(text: &str, source_name: &str) -> Result<Scenario, ScenarioError> {
        let sc: Scenario = parse_toml(text, source_name)?;
        sc.validate().map_err(|(field, msg)| ScenarioError::new(source_name, field, msg))?;
        Ok(sc)
    }

    /// Number of UAVs.
    pub fn count(&self) -> usize {
        self.swarm.count as usize
    }

    /// The UAV ids of this scenario, `1..=count`.
    pub fn uav_ids(&self) -> impl Iterator<Item = u32> {
        1..=self.swarm.count
    }

    /// The ids that get an agent: every UAV but the failed ones.
    pub fn agent_ids(&self) -> impl Iterator<Item = u32> + '_ {
        self.uav_ids().filter(|id| !self.swarm.failed.contains(id))
    }

    /// Whether UAV `id` knows the goal.
    pub fn is_informed(&self, id: u32) -> bool {
        match &self.swarm.informed {
            Informed::All(_) => true,
            Informed::Ids(ids) => ids.contains(&id),
        }
    }

    /// Control period in seconds.
    pub fn dt_secs(&self) -> f64 {
        1.0 / self.time.control_hz
    }
}

/// `informed = "all"` or `informed = [1, 3]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Informed {
    /// Every UAV knows the goal (the string must be `"all"`).
    All(AllMarker),
    /// Only these UAV ids know the goal.
    Ids(Vec<u32>),
}

/// The literal string `"all"`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AllMarker {
    /// `"all"`
    All,
}

type Check = Result<(), (String, String)>;

fn positive(field: &str, v: f64) -> Check {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err((field.into(), format!("must be a finite number > 0, got {v}")))
    }
}

fn within(field: &str, v: f64, lo: f64, hi: f64) -> Check {
    if v.is_finite() && (lo..=hi).contains(&v) {
        Ok(())
    } else {
        Err((field.into(), format!("must be between {lo} and {hi}, got {v}")))
    }
}

fn non_negative(field: &str, v: f64) -> Check {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err((field.into(), format!("must be a finite number >= 0, got {v}")))
    }
}

fn finite(field: &str, v: &[f64]) -> Check {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err((field.into(), format!("must be finite numbers, got {v:?}")))
    }
}

impl Scenario {
    fn validate(&self) -> Check {
        if self.name.is_empty() || !self.name.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_') {
            return Err(("name".into(), format!("must be non-empty and use only [A-Za-z0-9_-], got {:?}", self.name)));
        }
        self.validate_world()?;
        self.validate_swarm()?;
        self.validate_sensors()?;
        within("time.control_hz", self.time.control_hz, 0.1, 1000.0)?;
        within("time.realtime_factor", self.time.realtime_factor, 1e-3, 1e4)?;
        within("time.startup_timeout_s", self.time.startup_timeout_s, 1e-3, 1e6)?;
        if self.time.tick_timeout_ms == 0 {
            return Err(("time.tick_timeout_ms".into(), "must be > 0".into()));
        }
        if let Some(bad) = self.controller.external.iter().find(|&&i| i == 0 || i > self.swarm.count) {
            return Err(("controller.external".into(), format!("UAV id {bad} is not in 1..={}", self.swarm.count)));
        }
        let ext = &self.controller.external;
        if let Some(twice) = ext.iter().enumerate().find(|(i, id)| ext[..*i].contains(id)).map(|(_, id)| id) {
            return Err(("controller.external".into(), format!("UAV {twice} is listed twice")));
        }
        self.controller.k21.validate("controller.k21")?;
        self.controller.p17.validate("controller.p17")?;
        self.controller.a21.validate("controller.a21")?;
        self.controller.m23.validate("controller.m23")?;
        self.controller.m23.costmap.validate("controller.m23.costmap")?;
        self.localization.uvdar.validate("localization.uvdar")?;
        self.perception.validate()?;
        positive("lost_contact.after_s", self.lost_contact.after_s)?;
        positive("lost_contact.speed_mps", self.lost_contact.speed_mps)?;
        positive("lost_contact.hold_radius_m", self.lost_contact.hold_radius_m)?;
        non_negative("lost_contact.regroup_after_s", self.lost_contact.regroup_after_s)?;
        if self.lost_contact.max_hops < 2 {
            return Err(("lost_contact.max_hops".into(), "must be at least 2".into()));
        }
        if let Some(r) = self.lost_contact.contact_radius_m {
            positive("lost_contact.contact_radius_m", r)?;
        }
        positive("localization.stale_after_s", self.localization.stale_after_s)?;
        self.localization.icp.validate()?;
        if let Some(e) = &self.localization.broadcast_error {
            non_negative("localization.broadcast_error.delta_a_m", e.delta_a_m)?;
            non_negative("localization.broadcast_error.from_s", e.from_s)?;
            if e.until_s.is_some_and(|u| !(u.is_finite() && u > e.from_s)) {
                return Err(("localization.broadcast_error.until_s".into(), "must be after from_s".into()));
            }
            self.check_uav_set("localization.broadcast_error.uavs", &e.uavs)?;
        }
        if let Some(l) = &self.radio.distance_loss {
            if !(l.from_m.is_finite() && l.from_m >= 0.0 && l.from_m < self.radio.range_m) {
                return Err(("radio.distance_loss.from_m".into(), "must be in [0, radio.range_m)".into()));
            }
            if !(0.0..=1.0).contains(&l.at_range) {
                return Err(("radio.distance_loss.at_range".into(), "must be a probability in [0, 1]".into()));
            }
        }
        self.validate_netem()?;
        self.validate_failures()?;
        self.validate_mission()?;
        self.validate_expect()?;
        positive("end.goal_radius_m", self.end.goal_radius_m)?;
        positive("end.time_limit_s", self.end.time_limit_s)?;
        non_negative("end.hold_s", self.end.hold_s)?;
        if self.end.hold_s >= self.end.time_limit_s {
            return Err((
                "end.hold_s".into(),
                format!(
                    "{} s: must be shorter than end.time_limit_s ({} s), or no run could end with the goal",
                    self.end.hold_s, self.end.time_limit_s
                ),
            ));
        }
        Ok(())
    }

    fn check_uav_set(&self, field: &str, set: &UavSet) -> Check {
        match set {
            UavSet::Ids(ids) => match ids.iter().find(|&&id| id == 0 || id > self.swarm.count) {
                Some(bad) => Err((field.into(), format!("UAV id {bad} is not in 1..={}", self.swarm.count))),
                None => Ok(()),
            },
            UavSet::All(_) => Ok(()),
        }
    }

    fn validate_mission(&self) -> Check {
        for (i, m) in self.mission.iter().enumerate() {
            non_negative(&format!("mission[{i}].at_s"), m.at_s)?;
            finite(&format!("mission[{i}].goal"), &m.goal)?;
            finite(&format!("mission[{i}].velocity_mps"), &m.velocity_mps)?;
            self.check_uav_set(&format!("mission[{i}].uavs"), &m.uavs)?;
        }
        Ok(())
    }

    fn validate_failures(&self) -> Check {
        self.failures.iter().enumerate().try_for_each(|(i, f)| self.check_failure(i, f))
    }

    /// Checks failure number `i` (of the scenario or of a timeline) against this scenario.
    fn check_failure(&self, i: usize, f: &Failure) -> Check {
        non_negative(&format!("failures[{i}].at_s"), f.at_s)?;
        if f.uav == 0 || f.uav > self.swarm.count {
            return Err((format!("failures[{i}].uav"), format!("UAV id {} is not in 1..={}", f.uav, self.swarm.count)));
        }
        if f.kind.is_link() && self.time.mode != TimeMode::Realtime {
            // Zenoh leases are wall-clock: a stall of sim seconds in lockstep would last a
            // few milliseconds of wall time, or stop the run for a tick timeout per tick.
            return Err((
                format!("failures[{i}].kind"),
                "link faults need time.mode = \"realtime\" (Zenoh leases run on wall time)".into(),
            ));
        }
        Ok(())
    }

    /// The goal UAV `id` flies to at sim time `t`: the latest `mission` change covering it, else
    /// `swarm.goal`.
    pub fn goal_of(&self, id: u32, t: f64) -> [f64; 2] {
        self.goal_motion_of(id, t).0
    }

    /// UAV `id`'s goal before any mission: `swarm.goal`, or its own one of `controller.m23.goals`
    /// (seed 004 Table 7) when M23 flies.
    fn static_goal_of(&self, id: u32) -> [f64; 2] {
        match self.controller.kind {
            ControllerKind::M23 => self.controller.m23.goal_of(id, self.swarm.goal),
            _ => self.swarm.goal,
        }
    }

    /// The goal of UAV `id` at sim time `t` and its velocity: a moving `mission` goal has moved
    /// by `velocity_mps · (t − at_s)`.
    pub fn goal_motion_of(&self, id: u32, t: f64) -> ([f64; 2], [f64; 2]) {
        self.mission
            .iter()
            .filter(|m| m.at_s <= t + 1e-9 && m.uavs.contains(id))
            .max_by(|a, b| a.at_s.total_cmp(&b.at_s))
            .map_or((self.static_goal_of(id), [0.0, 0.0]), |m| {
                let [vx, vy] = m.velocity_mps;
                let dt = t - m.at_s;
                ([m.goal[0] + vx * dt, m.goal[1] + vy * dt], m.velocity_mps)
            })
    }

    fn validate_netem(&self) -> Check {
        for (i, r) in self.netem.iter().enumerate() {
            self.check_rule(&format!("netem[{i}]."), r)?;
        }
        Ok(())
    }

    /// Checks one netem rule; `at` prefixes the field names (`netem[3].`).
    fn check_rule(&self, at: &str, r: &NetemRule) -> Check {
        non_negative(&format!("{at}at_s"), r.at_s)?;
        self.check_uav_set(&format!("{at}from"), &r.from)?;
        self.check_uav_set(&format!("{at}to"), &r.to)?;
        r.rule.validate().map_err(|e| (format!("{at}rule.{}", e.field), e.reason))?;
        if let Some(p) = &r.partition {
            if r.from != UavSet::default() || r.to != UavSet::default() {
                return Err((
                    format!("{at}partition"),
                    "a partition names its nodes itself: leave `from` and `to` out".into(),
                ));
            }
            let only_hold = Impairment { hold: r.rule.hold, ..Impairment::IDENTITY };
            if r.rule != only_hold {
                return Err((format!("{at}rule"), "with a partition, `rule` may only set `hold`".into()));
            }
            for id in p.nodes() {
                if id == 0 || id > self.swarm.count {
                    return Err((format!("{at}partition"), format!("UAV id {id} is not in 1..={}", self.swarm.count)));
                }
            }
        }
        Ok(())
    }

    /// Checks a timeline to be added to a running swarm (`swarm netem`) or merged into this
    /// scenario (`--experiment`): ids in range, valid impairments, only freezes among the failures
    /// when `running` (kill and restart are the launcher's). The error names the field.
    pub fn check_timeline(&self, t: &Timeline, running: bool) -> Result<(), String> {
        let check = || -> Check {
            for (i, r) in t.netem.iter().enumerate() {
                self.check_rule(&format!("netem[{i}]."), r)?;
            }
            for (i, f) in t.failures.iter().enumerate() {
                self.check_failure(i, f)?;
                if running && f.kind != FailureKind::Freeze {
                    return Err((
                        format!("failures[{i}].kind"),
                        "only `freeze` can be added to a running swarm".into(),
                    ));
                }
            }
            Ok(())
        };
        check().map_err(|(field, msg)| format!("field `{field}`: {msg}"))
    }

    fn validate_world(&self) -> Check {
        for (i, t) in self.world.trees.iter().enumerate() {
            finite(&format!("world.trees[{i}]"), &[t.x, t.y])?;
            positive(&format!("world.trees[{i}].r"), t.r)?;
        }
        for (i, w) in self.world.walls.iter().enumerate() {
            finite(&format!("world.walls[{i}]"), &[w.x1, w.y1, w.x2, w.y2])?;
            positive(&format!("world.walls[{i}].thickness"), w.thickness)?;
            if (w.x1 - w.x2).hypot(w.y1 - w.y2) < 1e-6 {
                return Err((format!("world.walls[{i}]"), "wall has zero length".into()));
            }
        }
        if let Some(f) = &self.world.forest {
            let r = &f.region;
            finite("world.forest.region", &[r.x_min, r.x_max, r.y_min, r.y_max])?;
            if r.x_min >= r.x_max || r.y_min >= r.y_max {
                return Err(("world.forest.region".into(), "needs x_min < x_max and y_min < y_max".into()));
            }
            positive("world.forest.density_per_100m2", f.density_per_100m2)?;
            non_negative("world.forest.min_spacing_m", f.min_spacing_m)?;
            let [lo, hi] = f.trunk_radius_m;
            if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && lo <= hi) {
                return Err(("world.forest.trunk_radius_m".into(), format!("needs 0 < min <= max, got [{lo}, {hi}]")));
            }
            for (i, c) in f.keep_clear.iter().enumerate() {
                finite(&format!("world.forest.keep_clear[{i}]"), &[c.x, c.y])?;
                positive(&format!("world.forest.keep_clear[{i}].r"), c.r)?;
            }
        }
        Ok(())
    }

    fn validate_swarm(&self) -> Check {
        let s = &self.swarm;
        if s.count == 0 || s.count > 1000 {
            return Err(("swarm.count".into(), format!("must be between 1 and 1000, got {}", s.count)));
        }
        match (&s.start_positions, &s.start_area) {
            (Some(_), Some(_)) => {
                return Err(("swarm.start_positions".into(), "give start_positions or start_area, not both".into()))
            }
            (None, None) => {
                return Err(("swarm".into(), "needs start_positions or start_area".into()));
            }
            (Some(p), None) => {
                if p.len() != s.count as usize {
                    return Err((
                        "swarm.start_positions".into(),
                        format!("has {} entries but swarm.count is {}", p.len(), s.count),
                    ));
                }
                for (i, xy) in p.iter().enumerate() {
                    finite(&format!("swarm.start_positions[{i}]"), xy)?;
                }
                apart("swarm.start_positions", p, 2.0 * self.body.radius_m)?;
            }
            (None, Some(a)) => {
                finite("swarm.start_area.center", &a.center)?;
                positive("swarm.start_area.radius_m", a.radius_m)?;
                positive("swarm.start_area.min_spacing_m", a.min_spacing_m)?;
            }
        }
        finite("swarm.goal", &s.goal)?;
        if let Some(bad) = s.failed.iter().find(|&&i| i == 0 || i > s.count) {
            return Err(("swarm.failed".into(), format!("UAV id {bad} is not in 1..={}", s.count)));
        }
        if s.failed.len() >= s.count as usize {
            return Err(("swarm.failed".into(), "at least one UAV must have an agent".into()));
        }
        finite("swarm.start_heading_deg", &[s.start_heading_deg])?;
        if let Informed::Ids(ids) = &s.informed {
            if let Some(bad) = ids.iter().find(|&&i| i == 0 || i > s.count) {
                return Err(("swarm.informed".into(), format!("UAV id {bad} is not in 1..={}", s.count)));
            }
        }
        let b = &self.body;
        positive("body.radius_m", b.radius_m)?;
        positive("body.max_speed_mps", b.max_speed_mps)?;
        positive("body.max_accel_mps2", b.max_accel_mps2)?;
        positive("body.max_yaw_rate_dps", b.max_yaw_rate_dps)?;
        Ok(())
    }

    fn validate_sensors(&self) -> Check {
        let l = &self.lidar;
        if l.beams < 3 || l.beams > 100_000 {
            return Err(("lidar.beams".into(), format!("must be between 3 and 100000, got {}", l.beams)));
        }
        positive("lidar.max_range_m", l.max_range_m)?;
        non_negative("lidar.noise_std_m", l.noise_std_m)?;
        if !(0.0..1.0).contains(&l.dropout) {
            return Err(("lidar.dropout".into(), format!("must be in [0, 1), got {}", l.dropout)));
        }
        positive("radio.range_m", self.radio.range_m)?;
        non_negative("radio.hysteresis_m", self.radio.hysteresis_m)?;
        Ok(())
    }
}

impl K21Params {
    /// Whether the barrier keeps off the bodies of a scan group that joins several: both
    /// `barrier_m` and `barrier_surface_m` above 0.
    pub fn barrier_on_bodies(&self) -> bool {
        self.barrier_m > 0.0 && self.barrier_surface_m > 0.0
    }

    fn validate(&self, at: &str) -> Check {
        for (name, v) in [("kc", self.kc), ("ks", self.ks), ("ko", self.ko), ("kn", self.kn)] {
            non_negative(&format!("{at}.{name}"), v)?;
        }
        non_negative(&format!("{at}.separation_all_around_m"), self.separation_all_around_m)?;
        non_negative(&format!("{at}.barrier_m"), self.barrier_m)?;
        non_negative(&format!("{at}.barrier_surface_m"), self.barrier_surface_m)?;
        non_negative(&format!("{at}.barrier_ramp_m"), self.barrier_ramp_m)?;
        if let Some(r) = self.arrival_radius_m {
            non_negative(&format!("{at}.arrival_radius_m"), r)?;
        }
        for (name, v) in [
            ("kf", self.kf),
            ("cohesion_radius_m", self.cohesion_radius_m),
            ("separation_radius_m", self.separation_radius_m),
            ("separation_scale_m", self.separation_scale_m),
            ("avoidance_radius_m", self.avoidance_radius_m),
            ("avoidance_gain_m", self.avoidance_gain_m),
            ("obstacle_near_m", self.obstacle_near_m),
            ("heading_gain", self.heading_gain),
            ("neighbour_radius_m", self.neighbour_radius_m),
        ] {
            positive(&format!("{at}.{name}"), v)?;
        }
        if !(0.0..=180.0).contains(&self.avoidance_ignore_deg) {
            return Err((format!("{at}.avoidance_ignore_deg"), "must be in [0, 180]".into()));
        }
        Ok(())
    }
}

impl IcpParams {
    fn validate(&self) -> Check {
        let at = "localization.icp";
        for (name, v) in [
            ("lambda", self.lambda),
            ("tolerance_m", self.tolerance_m),
            ("grid_spacing_m", self.grid_spacing_m),
            ("match_frmsd", self.match_frmsd),
            ("match_shift_m", self.match_shift_m),
            ("match_turn_deg", self.match_turn_deg),
            ("suspend_s", self.suspend_s),
            ("long_every_s", self.long_every_s),
            ("tight_long_every_s", self.tight_long_every_s),
            ("step_budget_ms", self.step_budget_ms),
        ] {
            positive(&format!("{at}.{name}"), v)?;
        }
        if self.tight_long_every_s < self.long_every_s {
            return Err((
                format!("{at}.tight_long_every_s"),
                format!(
                    "must be at least long_every_s ({}), got {}: a tight fit is re-checked less often, not more",
                    self.long_every_s, self.tight_long_every_s
                ),
            ));
        }
        if self.max_iterations == 0 || self.max_iterations > 1000 {
            return Err((
                format!("{at}.max_iterations"),
                format!("must be between 1 and 1000, got {}", self.max_iterations),
            ));
        }
        if self.grid_half_cells > 50 {
            return Err((format!("{at}.grid_half_cells"), format!("must be at most 50, got {}", self.grid_half_cells)));
        }
        if self.grid_headings == 0 || self.grid_headings > 360 {
            return Err((
                format!("{at}.grid_headings"),
                format!("must be between 1 and 360, got {}", self.grid_headings),
            ));
        }
        if self.min_points < 3 {
            return Err((
                format!("{at}.min_points"),
                "must be at least 3 (a rigid 2D transform needs 3 points)".into(),
            ));
        }
        Ok(())
    }
}

impl PerceptionParams {
    fn validate(&self) -> Check {
        positive("perception.group_gap_m", self.group_gap_m)?;
        if self.min_points < 3 {
            return Err(("perception.min_points".into(), "must be at least 3 (a circle has 3 unknowns)".into()));
        }
        let [lo, hi] = self.radius_range_m;
        if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && lo <= hi) {
            return Err(("perception.radius_range_m".into(), format!("needs 0 < min <= max, got [{lo}, {hi}]")));
        }
        non_negative("perception.neighbour_match_m", self.neighbour_match_m)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests;

#[cfg(test)]
mod fuzz;

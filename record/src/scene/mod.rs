//! The run as a Foxglove scene: what the recorder writes to `run.mcap` and what `swarm view`
//! serves on the Foxglove WebSocket, made by the same code from the messages the recorder
//! already receives (truth, agent states, scans, radio sets, the netem timeline). Every message
//! is stamped with its sim time, so a recording replays on the run's own clock.
//!
//! - `shapes`: the pure conversions to the SDK's schemas.
//! - `feed`: the subscriptions a scene needs beyond the recorder's (scans, radio sets, netem
//!   rules), as a [`Feed`].
//!
//! [`Scene`] owns an explicit [`foxglove::Context`] (never the SDK's global one: two scenes in
//! one process, a test's say, must not mix). Sinks are attached to that context: an MCAP file
//! ([`Scene::write_mcap`]) and/or a WebSocket server; with none, logging costs an `if`.
//!
//! The file is cut to what changes: its chunks are zstd-compressed (most of the bytes are scans,
//! whose ranges are f32 widened to doubles, and estimates whose shapes repeat), and each trail
//! message carries only the last second of path, as its own entity with a lifetime of
//! [`TRAIL_S`], so a viewer shows the last [`TRAIL_S`] of path without it being sent again every
//! second.
//!
//! Topics (frames: `world`, `uav{id}`):
//!
//! | topic | schema | when |
//! |---|---|---|
//! | `/world` | SceneUpdate (trees, walls, goal) | once |
//! | `/swarm/world` | JSON: the hub's `TruthWorld`, the tick length `dt_s`, the scenario's name (for `swarm replay`) | once |
//! | `/tf` | FrameTransforms (`world` -> `uav{id}`) | every truth step |
//! | `/uav/{id}/pose` | PoseInFrame (truth) | every truth step, per UAV |
//! | `/trails` | SceneUpdate (the second of path since the last, kept on screen [`TRAIL_S`]) | every sim second |
//! | `/uav/{id}/scan` | LaserScan (body frame) | every scan the hub sends |
//! | `/uav/{id}/estimates` | SceneUpdate (estimate dots, lines to the truth) | every agent state |
//! | `/radio` | SceneUpdate (links coloured clean/impaired/cut; metadata `links`: the ids at the ends) | every truth step |
//! | `/events` | Log (collisions, failures, netem rules) | as they happen |
//! | `/uav/{id}/numbers` | JSON (step time, neighbours, K21 vectors, localization error) | every agent state |

mod feed;
mod shapes;

pub use feed::{Extra, Feed};
pub use shapes::log_time_ns;

use anyhow::{Context as _, Result};
use foxglove::messages::log::Level;
use foxglove::messages::{FrameTransforms, LaserScan, Log, PoseInFrame, SceneUpdate};
use foxglove::{Channel, PartialMetadata, RawChannel, Schema};
use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::Path;
use std::sync::Arc;
use swarm_config::Scenario;
use swarm_types::UavId;
use swarm_wire::msg::{AgentState, RadioSet, Scan, TruthBody, TruthStep, TruthWorld};

/// How much of each UAV's path `/trails` shows [sim s]: each piece's lifetime.
pub const TRAIL_S: f64 = 20.0;

/// The JSON schema of `/uav/{id}/numbers`.
const NUMBERS_SCHEMA: &str = r#"{"type":"object","properties":{"t_s":{"type":"number"},"step_time_ms":{"type":"number"},"neighbours":{"type":"integer"},"in_radio_range":{"type":"integer"},"cohesion":{"type":"number"},"separation":{"type":"number"},"avoidance":{"type":"number"},"navigation":{"type":"number"},"output":{"type":"number"},"localization_error_m":{"type":["number","null"]}}}"#;

/// The JSON schema of `/swarm/world`.
const WORLD_SCHEMA: &str = r#"{"type":"object","properties":{"world":{"type":"object"},"dt_s":{"type":"number"},"name":{"type":"string"},"goal_radius_m":{"type":"number"},"controller":{"type":"string"}}}"#;

/// One UAV's channels.
struct UavChannels {
    pose: Channel<PoseInFrame>,
    scan: Channel<LaserScan>,
    estimates: Channel<SceneUpdate>,
    numbers: Arc<RawChannel>,
}

/// The scene of one run: the context, its channels, and what the conversions need to remember.
pub struct Scene {
    ctx: Arc<foxglove::Context>,
    world: Channel<SceneUpdate>,
    world_update: Option<SceneUpdate>,
    world_json: Arc<RawChannel>,
    dt_s: f64,
    /// The scenario's goal radius [m]: the hub's world does not carry it.
    goal_radius_m: f64,
    /// The scenario's controller by name: what `/uav/{id}/numbers`' magnitudes mean.
    controller: String,
    name: String,
    tf: Channel<FrameTransforms>,
    trails_ch: Channel<SceneUpdate>,
    radio_ch: Channel<SceneUpdate>,
    events: Channel<Log>,
    uavs: BTreeMap<UavId, UavChannels>,
    timeline: netem::Timeline,
    /// Latest truth of every UAV (the pose its next state's estimates are relative to).
    bodies: BTreeMap<UavId, TruthBody>,
    /// Each UAV's path since the last `/trails` piece, from that piece's last point on.
    trails: BTreeMap<UavId, Vec<[f64; 2]>>,
    radio: BTreeMap<UavId, Vec<UavId>>,
    last_t: Option<f64>,
    next_trail_t: f64,
    mcap: Option<foxglove::McapWriterHandle<BufWriter<File>>>,
    detail: Detail,
    /// Scans seen per UAV (for [`Detail::every`]).
    scans_seen: BTreeMap<UavId, u64>,
}

/// How much of each UAV a scene logs. Poses, transforms, trails and events are always logged;
/// the heavy topics (scans, estimates, numbers: about 3/4 of a recording's bytes; the radio
/// graph, most of the rest) can be thinned for large swarms.
#[derive(Debug, Clone, PartialEq)]
pub struct Detail {
    /// Log every `every`-th scan and state (estimates, numbers) of a UAV, and every `every`-th
    /// radio graph (at least 1: everything).
    pub every: u64,
    /// Log scans, estimates and numbers of these UAVs only (`None`: of every UAV).
    pub uavs: Option<std::collections::BTreeSet<UavId>>,
}

impl Default for Detail {
    fn default() -> Detail {
        Detail { every: 1, uavs: None }
    }
}

impl Detail {
    /// UAVs up to which a recording keeps everything by default; beyond, `every` grows so the
    /// heavy topics stay near this many UAVs' worth.
    pub const FULL_UP_TO_UAVS: u64 = 50;

    /// The default for `uavs` UAVs: everything up to [`Self::FULL_UP_TO_UAVS`], then every
    /// `ceil(uavs / FULL_UP_TO_UAVS)`-th.
    pub fn auto(uavs: u64) -> Detail {
        Detail { every: uavs.div_ceil(Self::FULL_UP_TO_UAVS).max(1), uavs: None }
    }

    /// Whether the `n`-th (0-based) heavy message of UAV `id` is logged.
    fn keeps(&self, id: UavId, n: u64) -> bool {
        n.is_multiple_of(self.every.max(1)) && self.uavs.as_ref().is_none_or(|u| u.contains(&id))
    }
}

impl Scene {
    /// A scene for `sc` on a fresh context, with no sink yet.
    pub fn new(sc: &Scenario) -> Result<Scene> {
        let ctx = foxglove::Context::new();
        let numbers_schema = Schema::new("swarm.AgentNumbers", "jsonschema", NUMBERS_SCHEMA.as_bytes());
        let mut uavs = BTreeMap::new();
        for id in sc.uav_ids() {
            let numbers = ctx
                .channel_builder(format!("/uav/{id}/numbers"))
                .message_encoding("json")
                .schema(numbers_schema.clone())
                .build_raw()
                .context("cannot make the numbers channel")?;
            uavs.insert(
                id,
                UavChannels {
                    pose: ctx.channel_builder(format!("/uav/{id}/pose")).build(),
                    scan: ctx.channel_builder(format!("/uav/{id}/scan")).build(),
                    estimates: ctx.channel_builder(format!("/uav/{id}/estimates")).build(),
                    numbers,
                },
            );
        }
        Ok(Scene {
            world: ctx.channel_builder("/world").build(),
            world_update: None,
            world_json: ctx
                .channel_builder("/swarm/world")
                .message_encoding("json")
                .schema(Schema::new("swarm.World", "jsonschema", WORLD_SCHEMA.as_bytes()))
                .build_raw()
                .context("cannot make the world channel")?,
            dt_s: sc.dt_s(),
            goal_radius_m: sc.end.goal_radius_m,
            controller: sc.controller.kind.name().to_string(),
            name: sc.name.clone(),
            tf: ctx.channel_builder("/tf").build(),
            trails_ch: ctx.channel_builder("/trails").build(),
            radio_ch: ctx.channel_builder("/radio").build(),
            events: ctx.channel_builder("/events").build(),
            ctx,
            uavs,
            timeline: netem::Timeline::from_scenario(sc),
            bodies: BTreeMap::new(),
            trails: BTreeMap::new(),
            radio: BTreeMap::new(),
            last_t: None,
            next_trail_t: 0.0,
            mcap: None,
            detail: Detail::default(),
            scans_seen: BTreeMap::new(),
        })
    }

    /// Thins what is logged from now on (see [`Detail`]).
    pub fn set_detail(&mut self, detail: Detail) {
        self.detail = detail;
    }

    /// The context sinks attach to (the WebSocket server of `swarm view`).
    pub fn context(&self) -> &Arc<foxglove::Context> {
        &self.ctx
    }

    /// Starts writing everything logged from now on to the MCAP file `path`.
    pub fn write_mcap(&mut self, path: &Path) -> Result<()> {
        let file = File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
        let options = foxglove::McapWriteOptions::new().compression(Some(foxglove::McapCompression::Zstd));
        let h = self
            .ctx
            .mcap_writer_with_options(options)
            .create(BufWriter::new(file))
            .context("cannot start the MCAP writer")?;
        self.mcap = Some(h);
        Ok(())
    }

    /// Ends the MCAP file's open chunk and hands it to the file system: a killed run keeps
    /// everything logged before (see `swarm recover`).
    pub fn flush(&self) -> Result<()> {
        if let Some(h) = &self.mcap {
            h.flush().context("cannot flush run.mcap")?;
        }
        Ok(())
    }

    /// Closes the MCAP file (its summary and index are written here).
    pub fn finish(&mut self) -> Result<()> {
        if let Some(h) = self.mcap.take() {
            h.close().context("cannot finish run.mcap")?;
        }
        Ok(())
    }

    /// The world, at sim time 0.
    pub fn on_world(&mut self, w: &TruthWorld) {
        let update = shapes::world(w, self.goal_radius_m);
        self.world.log_with_time(&update, 0u64);
        self.world_update = Some(update);
        let json = serde_json::json!({ "world": w, "dt_s": self.dt_s, "name": self.name, "goal_radius_m": self.goal_radius_m, "controller": self.controller });
        self.world_json.log_with_meta(json.to_string().as_bytes(), PartialMetadata::with_log_time(0u64));
    }

    /// The world again, at the latest sim time (for WebSocket clients that joined late).
    pub fn relog_world(&self) {
        if let Some(u) = &self.world_update {
            self.world.log_with_time(u, shapes::log_time_ns(self.last_t.unwrap_or(0.0)));
        }
    }

    /// The netem timeline in force (the hub's `netem/rules`), replacing the scenario's.
    pub fn on_timeline(&mut self, t: swarm_config::Timeline) {
        self.timeline = netem::Timeline::from(t);
    }

    /// One UAV's radio set (drawn with the next truth step).
    pub fn on_radio(&mut self, r: &RadioSet) {
        self.radio.insert(r.id, r.in_range.clone());
    }

    /// One scan the hub sent UAV `id`.
    pub fn on_scan(&mut self, id: UavId, s: &Scan) {
        let seen = self.scans_seen.entry(id).or_default();
        *seen += 1;
        if !self.detail.keeps(id, *seen - 1) {
            return;
        }
        if let Some(u) = self.uavs.get(&id) {
            u.scan.log_with_time(&shapes::laser_scan(id, s), shapes::log_time_ns(s.t_s));
        }
    }

    /// One truth step: poses, transforms, trails, the radio graph, and the step's events.
    pub fn on_step(&mut self, s: &TruthStep) {
        let t = s.t_s;
        let ns = shapes::log_time_ns(t);
        let transforms = s.bodies.iter().map(|b| shapes::transform(b, t)).collect();
        self.tf.log_with_time(&FrameTransforms { transforms }, ns);
        for b in &s.bodies {
            if let Some(u) = self.uavs.get(&b.id) {
                u.pose.log_with_time(&shapes::pose(b, t), ns);
            }
            self.trails.entry(b.id).or_default().push([b.x, b.y]);
        }
        self.events_of(s);
        for b in &s.bodies {
            self.bodies.insert(b.id, *b);
        }
        if s.tick.is_multiple_of(self.detail.every.max(1)) {
            self.radio_graph(t);
        }
        if t >= self.next_trail_t {
            self.next_trail_t = t.floor() + 1.0;
            self.draw_trails(t);
        }
        self.last_t = Some(t);
    }

    /// One agent's state: its neighbour estimates against the truth, and its numbers.
    pub fn on_state(&mut self, st: &AgentState) {
        let Some(u) = self.uavs.get(&st.id) else { return };
        if !self.detail.keeps(st.id, st.tick) {
            return;
        }
        let ns = shapes::log_time_ns(st.t_s);
        let (update, error) = self.estimates(st);
        u.estimates.log_with_time(&update, ns);
        let mut fields = numbers(st);
        fields.insert("t_s".into(), st.t_s.into());
        fields.insert("localization_error_m".into(), error.into());
        let numbers = serde_json::Value::Object(fields);
        u.numbers.log_with_meta(numbers.to_string().as_bytes(), PartialMetadata::with_log_time(ns));
    }

    /// The estimates of `st` in the world (placed by the agent's true pose), lines from each to
    /// its neighbour's truth, and their mean error [m] (estimates of known id only).
    fn estimates(&self, st: &AgentState) -> (SceneUpdate, Option<f64>) {
        let mut e = shapes::entity(format!("estimates{}", st.id), st.t_s);
        let Some(me) = self.bodies.get(&st.id) else {
            return (SceneUpdate { entities: vec![e], ..Default::default() }, None);
        };
        let points = estimates_in_world([me.x, me.y, me.yaw], st);
        let grey = shapes::rgb(0.5, 0.5, 0.5);
        let mut segs = Vec::new();
        let mut errors = Vec::new();
        for (n, p) in st.neighbours.iter().zip(&points) {
            if let Some(truth) = n.id.and_then(|id| self.bodies.get(&id)) {
                segs.push((*p, [truth.x, truth.y], grey));
                errors.push((p[0] - truth.x).hypot(p[1] - truth.y));
            }
        }
        e.spheres = shapes::dots(&points, shapes::rgb(0.2, 0.4, 0.95), 0.25);
        e.lines = vec![shapes::segments(&segs, 0.03)];
        let error = (!errors.is_empty()).then(|| errors.iter().sum::<f64>() / errors.len() as f64);
        (SceneUpdate { entities: vec![e], ..Default::default() }, error)
    }

    /// The radio links of the latest radio sets, each coloured by the worse netem class of its
    /// two directions at `t`.
    fn radio_graph(&self, t: f64) {
        let links = radio_links(&self.radio, &self.timeline, t, |id| self.bodies.get(&id).map(|b| [b.x, b.y]));
        let segs: Vec<_> = links.iter().map(|l| (l.ends[0], l.ends[1], class_color(l.class))).collect();
        let ends: Vec<String> = links.iter().flat_map(|l| l.ids).map(|id| id.to_string()).collect();
        let mut e = shapes::entity("radio".into(), t);
        e.lines = vec![shapes::segments(&segs, 0.04)];
        // The UAV ids at the segments' ends, in order (for `swarm replay`'s page).
        e.metadata = vec![foxglove::messages::KeyValuePair { key: "links".into(), value: ends.join(",") }];
        self.radio_ch.log_with_time(&SceneUpdate { entities: vec![e], ..Default::default() }, shapes::log_time_ns(t));
    }

    /// Logs the path since the last piece as a new entity that lives [`TRAIL_S`], and starts the
    /// next piece at each path's last point (so the pieces join).
    fn draw_trails(&mut self, t: f64) {
        let mut e = shapes::entity(format!("trails{}", shapes::log_time_ns(t)), t);
        e.lifetime = foxglove::messages::Duration::try_from_secs_f64(TRAIL_S).ok();
        e.lines = self
            .trails
            .values()
            .map(|tr| shapes::strip(tr.iter().copied(), shapes::rgb(0.3, 0.3, 0.8), 0.05))
            .collect();
        self.trails_ch.log_with_time(&SceneUpdate { entities: vec![e], ..Default::default() }, shapes::log_time_ns(t));
        for tr in self.trails.values_mut() {
            let last = tr.last().copied();
            tr.clear();
            tr.extend(last);
        }
    }

    /// Logs the step's collisions, UAVs lost, and the netem rules and failures that came due
    /// since the last step.
    fn events_of(&self, s: &TruthStep) {
        let t = s.t_s;
        let ns = shapes::log_time_ns(t);
        let log = |level, message: String| self.events.log_with_time(&shapes::log(t, level, "swarm", message), ns);
        for c in &s.collisions {
            let with = c.other_uav.map_or_else(|| "an obstacle".to_string(), |o| format!("UAV {o}"));
            log(Level::Warning, format!("collision: UAV {} with {with} at ({:.2}, {:.2})", c.id, c.x, c.y));
        }
        for b in s.bodies.iter().filter(|b| !b.alive && self.bodies.get(&b.id).is_some_and(|p| p.alive)) {
            log(Level::Error, format!("UAV {} lost (no longer alive)", b.id));
        }
        let due = |at: f64| self.last_t.map_or(at <= t + 1e-9, |l| at > l + 1e-9 && at <= t + 1e-9);
        for r in self.timeline.rules().iter().filter(|r| due(r.at_s)) {
            log(Level::Info, format!("netem at {:.2} s: {}", r.at_s, serde_json::to_string(r).unwrap_or_default()));
        }
        for f in self.timeline.failures().iter().filter(|f| due(f.at_s)) {
            log(
                Level::Warning,
                format!("failure at {:.2} s: {}", f.at_s, serde_json::to_string(f).unwrap_or_default()),
            );
        }
    }
}

/// The estimates of `st` in the world, placed by the agent's pose `[x, y, yaw]` (truth): what the
/// scene and the page's board both draw.
pub fn estimates_in_world(pose: [f64; 3], st: &AgentState) -> Vec<[f64; 2]> {
    let [x, y, yaw] = pose;
    let (sin, cos) = yaw.sin_cos();
    // Body to world: p_w = p_me + R(yaw) p_b.
    st.neighbours
        .iter()
        .map(|n| [x + cos * f64::from(n.x) - sin * f64::from(n.y), y + sin * f64::from(n.x) + cos * f64::from(n.y)])
        .collect()
}

/// One radio link to draw: its ends' ids (`ids[0] < ids[1]`), their positions [m, world] and the
/// worse netem class of its two directions.
pub struct RadioLink {
    /// The two UAVs, lower id first.
    pub ids: [UavId; 2],
    /// Their positions [m, world], in the order of `ids`.
    pub ends: [[f64; 2]; 2],
    /// The worse netem class of the link's two directions.
    pub class: netem::LinkClass,
}

/// The links of the latest radio sets (`radio`: each UAV's ids in range) between UAVs whose
/// position `at` knows, each once, classed by `timeline` at `t`.
pub fn radio_links(
    radio: &BTreeMap<UavId, Vec<UavId>>,
    timeline: &netem::Timeline,
    t: f64,
    at: impl Fn(UavId) -> Option<[f64; 2]>,
) -> Vec<RadioLink> {
    let mut links = Vec::new();
    for (&i, ids) in radio {
        for &j in ids.iter().filter(|&&j| j > i) {
            let (Some(a), Some(b)) = (at(i), at(j)) else { continue };
            links.push(RadioLink { ids: [i, j], ends: [a, b], class: timeline.class_between(t, i, j) });
        }
    }
    links
}

/// An agent's numbers (step time, neighbours, K21 vectors) as JSON fields: `/uav/{id}/numbers`
/// adds its time and localization error, the page's board shows them as they are.
pub fn numbers(st: &AgentState) -> serde_json::Map<String, serde_json::Value> {
    let v = &st.vectors;
    let fields: [(&str, serde_json::Value); 8] = [
        ("step_time_ms", (f64::from(st.step_time_us) / 1000.0).into()),
        ("neighbours", st.neighbours.len().into()),
        ("in_radio_range", st.in_radio_range.into()),
        ("cohesion", v.cohesion.into()),
        ("separation", v.separation.into()),
        ("avoidance", v.avoidance.into()),
        ("navigation", v.navigation.into()),
        ("output", v.output.into()),
    ];
    fields.into_iter().map(|(k, v)| (k.to_string(), v)).collect()
}

/// The class a link colour of [`class_color`] stands for (unknown colours: clean).
pub fn class_of_color(c: &foxglove::messages::Color) -> netem::LinkClass {
    netem::LinkClass::ALL.into_iter().find(|&k| class_color(k) == *c).unwrap_or(netem::LinkClass::Clean)
}

/// Green clean, orange impaired, red cut.
fn class_color(c: netem::LinkClass) -> foxglove::messages::Color {
    match c {
        netem::LinkClass::Clean => shapes::rgb(0.2, 0.7, 0.3),
        netem::LinkClass::Impaired => shapes::rgb(0.95, 0.6, 0.1),
        netem::LinkClass::Cut => shapes::rgb(0.85, 0.1, 0.1),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A scene of forest-5 recording to a fresh file in the temp folder named after `tag`.
    fn recording(tag: &str) -> (Scene, std::path::PathBuf) {
        let sc = Scenario::from_arg("forest-5").expect("built-in").0;
        let path = std::env::temp_dir().join(format!("scene-{tag}-{}.mcap", std::process::id()));
        let mut scene = Scene::new(&sc).expect("scene");
        scene.write_mcap(&path).expect("mcap");
        (scene, path)
    }

    /// Ends `scene` and returns its file's bytes, the file removed.
    fn finished(mut scene: Scene, path: &std::path::Path) -> Vec<u8> {
        scene.finish().expect("close");
        let bytes = std::fs::read(path).expect("read");
        let _ = std::fs::remove_file(path);
        bytes
    }

    /// The truth step `tick` with UAV 1 alone, at (x, y) heading `yaw`.
    fn one_uav_step(tick: u64, x: f64, y: f64, yaw: f64) -> TruthStep {
        let body = TruthBody {
            id: UavId::new(1),
            x,
            y,
            yaw,
            vx: 0.0,
            vy: 0.0,
            alive: true,
            cmd_on_time: true,
            obstacle_distance_m: 1.0,
            agent_distance_m: 1.0,
            colliding: false,
        };
        TruthStep { tick, t_s: tick as f64 * 0.1, bodies: vec![body], ..Default::default() }
    }

    #[test]
    fn detail_thins_heavy_topics_per_uav_and_grows_with_the_swarm() {
        assert_eq!(Detail::auto(40), Detail::default());
        assert_eq!(Detail::auto(1000).every, 20);
        let d = Detail { every: 3, uavs: Some([UavId::new(2), UavId::new(5)].into()) };
        let kept: Vec<u64> = (0..10).filter(|&n| d.keeps(UavId::new(2), n)).collect();
        assert_eq!(kept, vec![0, 3, 6, 9]);
        assert!(!d.keeps(UavId::new(1), 0), "UAV 1 is not chosen");
    }

    #[test]
    fn a_thinned_scene_keeps_every_pose_and_every_kth_scan() {
        let (mut scene, path) = recording("thin");
        scene.set_detail(Detail { every: 4, uavs: None });
        let scan = |tick: u64| Scan {
            tick,
            t_s: tick as f64 * 0.1,
            angle_min: 0.0,
            angle_increment: 0.1,
            max_range_m: 10.0,
            ranges_m: vec![1.0; 8],
        };
        for tick in 1..=12u64 {
            scene.on_step(&one_uav_step(tick, tick as f64, 0.0, 0.0));
            scene.on_scan(UavId::new(1), &scan(tick));
        }
        let bytes = finished(scene, &path);
        let count = |topic: &str| {
            mcap::MessageStream::new(&bytes)
                .expect("mcap")
                .filter(|m| m.as_ref().expect("record").channel.topic == topic)
                .count()
        };
        assert_eq!(count("/uav/1/pose"), 12);
        assert_eq!(count("/uav/1/scan"), 3, "scans 1, 5 and 9");
        assert_eq!(count("/radio"), 3, "ticks 4, 8 and 12");
    }

    #[test]
    fn a_scene_writes_an_mcap_with_its_topics() {
        let (mut scene, path) = recording("test");
        scene.on_step(&one_uav_step(1, 1.0, 2.0, 0.5));
        let bytes = finished(scene, &path);
        assert!(bytes.starts_with(b"\x89MCAP0\r\n"), "MCAP magic");
        let text = String::from_utf8_lossy(&bytes);
        assert!(text.contains("/uav/1/pose") && text.contains("/tf"), "channels recorded");
    }

    #[test]
    fn trails_are_sent_once_as_joined_pieces_that_live_trail_s() {
        use foxglove::Decode;
        let (mut scene, path) = recording("trails");
        for tick in 0..=25u64 {
            scene.on_step(&one_uav_step(tick, tick as f64, 0.0, 0.0));
        }
        let bytes = finished(scene, &path);
        let pieces: Vec<SceneUpdate> = mcap::MessageStream::new(&bytes)
            .expect("mcap")
            .map(|m| m.expect("record"))
            .filter(|m| m.channel.topic == "/trails")
            .map(|m| SceneUpdate::decode(&*m.data).expect("scene update"))
            .collect();
        // At 0, 1 and 2 s: three pieces, each its own entity living TRAIL_S.
        assert_eq!(pieces.len(), 3);
        let xs: Vec<Vec<f64>> =
            pieces.iter().map(|u| u.entities[0].lines[0].points.iter().map(|p| p.x).collect()).collect();
        assert_eq!(xs[0], vec![0.0]);
        assert_eq!(xs[1], (0..=10).map(f64::from).collect::<Vec<_>>(), "the second piece starts where the first ended");
        assert_eq!(xs[2], (10..=20).map(f64::from).collect::<Vec<_>>());
        for u in &pieces {
            assert_eq!(u.entities[0].lifetime.map(|d| d.sec()), Some(TRAIL_S as i32));
        }
        assert_ne!(pieces[1].entities[0].id, pieces[2].entities[0].id, "pieces do not replace each other");
    }
}

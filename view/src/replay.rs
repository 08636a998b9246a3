//! `swarm replay RUN`: a recorded run (`run.mcap`, or the run folder holding it) played back on
//! the live view's page, with play, pause, seek and speed, and on the Foxglove WebSocket (every
//! recorded message logged again, on its own channel, as the playback clock passes it).
//!
//! The page's frames are read back from the recording's own topics: `/swarm/world` (the world,
//! the tick length), `/tf` (every UAV's pose per tick), `/radio` (links, their class by colour),
//! `/uav/{id}/estimates`, `/uav/{id}/numbers` and `/events` (collisions, lost UAVs); each UAV's
//! speed is its `/tf` displacement over the time since its previous one. The selected UAV's scan,
//! when the page asks, is `/uav/{id}/scan` at the shown frame's time, placed by that UAV's `/tf`
//! of the same time; the trails a page starts with (as it connects, and after each seek) are the
//! frames' positions over the last seconds before the shown frame. The world tells the page the
//! first and last tick and the tick length, so the seek bar shows sim times, the goal radius and
//! the controller (from `/swarm/world`; for a recording made before it carried the radius, from
//! the `scenario.toml` beside it).

use super::http::{self, Command, Snapshot};
use super::scans::{ScanPicture, ScanSource};
use super::trails::{TrailSource, Trails};
use anyhow::{Context as _, Result};
use foxglove::messages::{FrameTransforms, LaserScan, Log, SceneUpdate};
use foxglove::{Decode, PartialMetadata, RawChannel, Schema};
use serde_json::{json, Value};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use swarm_record::scene::TRAIL_S;
use swarm_types::UavId;
use tokio::sync::{mpsc, watch};

/// `swarm replay`.
#[derive(clap::Args, Debug, Clone)]
pub struct ReplayArgs {
    /// A run folder, or its `run.mcap`.
    pub run: PathBuf,
    /// The page's HTTP port on 127.0.0.1 (0: any free port); the Foxglove WebSocket is on the
    /// next port (or any free port when this is 0).
    #[arg(long, default_value_t = 8765)]
    pub port: u16,
    /// Start paused (at the first tick).
    #[arg(long)]
    pub paused: bool,
}

/// One recorded message.
struct Rec {
    channel: usize,
    log_time_ns: u64,
    data: Vec<u8>,
}

/// A loaded recording: its channels, messages in log-time order, and the page's frames.
struct Recording {
    channels: Vec<(String, String, Option<Schema>)>,
    messages: Vec<Rec>,
    world: Value,
    /// (tick, log time [ns], frame) per tick.
    frames: Vec<(u64, u64, Value)>,
    /// Per UAV, the indices in `messages` of its `/uav/{id}/scan` messages, in time order.
    scans: BTreeMap<UavId, Vec<usize>>,
}

/// What the replay shows now, for the page's server: each UAV's latest scan and its recent trail
/// at the shown frame's time.
struct ReplayShown {
    rec: Arc<Recording>,
    /// The shown frame's log time [ns].
    shown_ns: AtomicU64,
}

impl ScanSource for ReplayShown {
    fn scan(&self, id: UavId) -> Option<ScanPicture> {
        let rec = &self.rec;
        let t_ns = self.shown_ns.load(Ordering::Relaxed);
        let idx = rec.scans.get(&id)?;
        let m =
            &rec.messages[*idx.get(idx.partition_point(|&i| rec.messages[i].log_time_ns <= t_ns).checked_sub(1)?)?];
        let l = LaserScan::decode(m.data.as_slice()).ok()?;
        let (tick, _, frame) = &rec.frames[rec.frames.binary_search_by_key(&m.log_time_ns, |f| f.1).ok()?];
        let u = frame["uavs"].as_array()?.iter().find(|u| u["id"] == id.get())?;
        let pose = [u["x"].as_f64()?, u["y"].as_f64()?, u["yaw"].as_f64()?];
        let n = l.ranges.len().max(2) as f64;
        let angle_increment = (l.end_angle - l.start_angle) / (n - 1.0);
        Some(ScanPicture {
            id,
            tick: *tick,
            t_s: m.log_time_ns as f64 * 1e-9,
            pose,
            angle_min: l.start_angle,
            angle_increment,
            ranges: l.ranges,
        })
    }
}

impl TrailSource for ReplayShown {
    fn trails(&self) -> Value {
        let rec = &self.rec;
        let t_ns = self.shown_ns.load(Ordering::Relaxed);
        let from_ns = t_ns.saturating_sub((TRAIL_S * 1e9) as u64);
        let frames =
            &rec.frames[rec.frames.partition_point(|f| f.1 < from_ns)..rec.frames.partition_point(|f| f.1 <= t_ns)];
        let mut trails = Trails::default();
        for (_, ns, frame) in frames {
            for u in frame["uavs"].as_array().into_iter().flatten() {
                let id = u["id"].as_u64().and_then(|id| u32::try_from(id).ok()).map(UavId::new);
                if let (Some(id), Some(x), Some(y)) = (id, u["x"].as_f64(), u["y"].as_f64()) {
                    trails.push(id, *ns as f64 * 1e-9, x, y);
                }
            }
        }
        trails.to_json()
    }
}

/// Runs `swarm replay` until Ctrl-C.
pub async fn replay(a: ReplayArgs) -> Result<ExitCode> {
    let path = if a.run.is_dir() { a.run.join("run.mcap") } else { a.run.clone() };
    let rec = Arc::new(load(&path)?);
    anyhow::ensure!(!rec.frames.is_empty(), "{} holds no /tf messages: nothing to replay", path.display());
    let ctx = foxglove::Context::new();
    let raw: Vec<Arc<RawChannel>> = rec
        .channels
        .iter()
        .map(|(topic, enc, schema)| {
            ctx.channel_builder(topic.clone()).message_encoding(enc.clone()).schema(schema.clone()).build_raw()
        })
        .collect::<Result<_, _>>()
        .context("cannot make the replay's channels")?;
    let (page, fox) = super::ports(a.port);
    let (_server, front) = super::foxglove_server(&ctx, format!("swarm replay {}", path.display()), fox).await?;
    let listener = tokio::net::TcpListener::bind(("127.0.0.1", page))
        .await
        .with_context(|| format!("cannot listen on port {page}"))?;
    println!("replay: http://127.0.0.1:{}/  foxglove: ws://127.0.0.1:{}", listener.local_addr()?.port(), front.port());
    use std::io::Write as _;
    let _ = std::io::stdout().flush();
    let (snap, snap_rx) = watch::channel(Snapshot::default());
    let (ctl_tx, ctl) = mpsc::unbounded_channel();
    let shown = Arc::new(ReplayShown { rec: rec.clone(), shown_ns: AtomicU64::new(rec.frames[0].1) });
    tokio::spawn(http::serve(
        listener,
        http::Sources { snap: snap_rx, control: Some(ctl_tx), scans: shown.clone(), trails: shown.clone() },
    ));
    tokio::select! {
        () = play(&rec, &raw, &snap, &shown.shown_ns, ctl, !a.paused) => {}
        _ = tokio::signal::ctrl_c() => {}
    }
    Ok(ExitCode::SUCCESS)
}

/// The playback clock: plays, pauses, seeks and changes speed on the page's commands.
async fn play(
    rec: &Recording,
    raw: &[Arc<RawChannel>],
    snap: &watch::Sender<Snapshot>,
    shown_ns: &AtomicU64,
    mut ctl: mpsc::UnboundedReceiver<Command>,
    playing: bool,
) {
    let world: Arc<str> = Arc::from(rec.world.to_string());
    let mut playing = playing;
    let mut speed = 1.0f64;
    let first_ns = rec.frames[0].1;
    let mut t_ns = first_ns;
    let mut sent = 0usize; // messages logged to the Foxglove side so far
    let mut shown = usize::MAX;
    let mut sought = false; // the next frame follows a seek: the page needs the trails again
    let mut every = tokio::time::interval(super::FRAME_EVERY);
    loop {
        tokio::select! {
            Some(cmd) = ctl.recv() => {
                let get = |k: &str| cmd.iter().find(|(a, _)| a == k).map(|(_, v)| v.as_str());
                match get("cmd") {
                    Some("play") => playing = true,
                    Some("pause") => playing = false,
                    Some("speed") => speed = get("x").and_then(|x| x.parse().ok()).filter(|x: &f64| *x > 0.0).unwrap_or(speed),
                    Some("seek") => if let Some(tick) = get("tick").and_then(|x| x.parse::<u64>().ok()) {
                        let i = rec.frames.partition_point(|f| f.0 < tick).min(rec.frames.len() - 1);
                        t_ns = rec.frames[i].1;
                        sent = rec.messages.partition_point(|m| m.log_time_ns < t_ns);
                        relog_world(rec, raw);
                        shown = usize::MAX;
                        sought = true;
                    },
                    _ => {}
                }
            }
            _ = every.tick() => {
                if playing {
                    t_ns = t_ns.saturating_add((super::FRAME_EVERY.as_secs_f64() * speed * 1e9) as u64);
                }
                while let Some(m) = rec.messages.get(sent).filter(|m| m.log_time_ns <= t_ns) {
                    raw[m.channel].log_with_meta(&m.data, PartialMetadata::with_log_time(m.log_time_ns));
                    sent += 1;
                }
                let i = rec.frames.partition_point(|f| f.1 <= t_ns).saturating_sub(1);
                if i != shown {
                    shown = i;
                    shown_ns.store(rec.frames[i].1, Ordering::Relaxed);
                    let frame: Arc<str> = Arc::from(rec.frames[i].2.to_string());
                    snap.send_modify(|s| {
                        s.world = Some(world.clone());
                        s.frame = Some(frame);
                        s.trails_epoch += u64::from(std::mem::take(&mut sought));
                    });
                }
                if i + 1 == rec.frames.len() && playing {
                    playing = false;
                }
            }
        }
    }
}

/// Logs the recording's world again (for a seek: Foxglove clears its scene).
fn relog_world(rec: &Recording, raw: &[Arc<RawChannel>]) {
    for m in rec
        .messages
        .iter()
        .filter(|m| rec.channels[m.channel].0 == "/world" || rec.channels[m.channel].0 == "/swarm/world")
    {
        raw[m.channel].log_with_meta(&m.data, PartialMetadata::with_log_time(m.log_time_ns));
    }
}

/// Reads `path` whole: channels, messages sorted by log time, and the page's frames.
fn load(path: &Path) -> Result<Recording> {
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    let mut channels: Vec<(String, String, Option<Schema>)> = Vec::new();
    let mut ids: BTreeMap<u16, usize> = BTreeMap::new();
    let mut messages = Vec::new();
    for m in mcap::MessageStream::new(&bytes).with_context(|| format!("{} is not an MCAP file", path.display()))? {
        let m = m.with_context(|| format!("{}: a bad record", path.display()))?;
        let next = channels.len();
        let channel = *ids.entry(m.channel.id).or_insert_with(|| {
            let schema =
                m.channel.schema.as_ref().map(|s| Schema::new(s.name.clone(), s.encoding.clone(), s.data.to_vec()));
            channels.push((m.channel.topic.clone(), m.channel.message_encoding.clone(), schema));
            next
        });
        messages.push(Rec { channel, log_time_ns: m.log_time, data: m.data.into_owned() });
    }
    messages.sort_by_key(|m| m.log_time_ns);
    let topic = |m: &Rec| channels[m.channel].0.as_str();
    let head: Value = messages
        .iter()
        .find(|m| topic(m) == "/swarm/world")
        .and_then(|m| serde_json::from_slice(&m.data).ok())
        .context("the recording has no /swarm/world")?;
    let dt = head["dt_s"].as_f64().filter(|d| *d > 0.0).context("/swarm/world has no dt_s")?;
    let mut world = head["world"].clone();
    world["kind"] = json!("world");
    world["run"] = json!(path.display().to_string());
    if let Some(r) = head["goal_radius_m"].as_f64().or_else(|| goal_radius_beside(path)) {
        world["goal_radius_m"] = json!(r);
    }
    world["controller"] = head["controller"].clone();
    let frames = frames(&messages, &|m| topic(m), dt);
    world["replay"] = replay_span(&frames, dt);
    let mut scans: BTreeMap<UavId, Vec<usize>> = BTreeMap::new();
    for (i, m) in messages.iter().enumerate() {
        let id = topic(m).strip_prefix("/uav/").and_then(|r| r.strip_suffix("/scan")).and_then(|id| id.parse().ok());
        if let Some(id) = id {
            scans.entry(id).or_default().push(i);
        }
    }
    Ok(Recording { channels, messages, world, frames, scans })
}

/// The goal radius [m] of the scenario beside the recording (`scenario.toml` in its run folder),
/// for recordings whose `/swarm/world` does not carry `goal_radius_m` (made before it did).
/// `None`, with a warning, when no readable scenario is there (the page then draws a 1 m disc and
/// says the radius is unknown).
fn goal_radius_beside(mcap: &Path) -> Option<f64> {
    let file = mcap.parent()?.join("scenario.toml");
    match swarm_config::Scenario::from_file(&file) {
        Ok(sc) => Some(sc.end.goal_radius_m),
        Err(e) => {
            tracing::warn!("the page draws the goal without its radius: {e}");
            None
        }
    }
}

/// What the seek bar needs: the first and last tick, their sim times [s] and the tick length [s].
fn replay_span(frames: &[(u64, u64, Value)], dt: f64) -> Value {
    let tick_t = |f: Option<&(u64, u64, Value)>| f.map_or((0, 0.0), |f| (f.0, f.1 as f64 * 1e-9));
    let ((first_tick, first_t), (last_tick, last_t)) = (tick_t(frames.first()), tick_t(frames.last()));
    json!({ "first_tick": first_tick, "last_tick": last_tick, "first_t": first_t, "last_t": last_t, "dt_s": dt })
}

/// Builds the page's frame for every `/tf` message, from it and the topics logged at or before
/// its time.
fn frames<'a>(messages: &'a [Rec], topic: &dyn Fn(&'a Rec) -> &'a str, dt: f64) -> Vec<(u64, u64, Value)> {
    let mut out = Vec::new();
    let mut links: Vec<Value> = Vec::new();
    let mut estimates = serde_json::Map::new();
    let mut numbers = serde_json::Map::new();
    let mut collisions: Vec<Value> = Vec::new();
    let mut lost = serde_json::Map::new();
    let mut pending_tf: Option<&Rec> = None;
    let mut speeds = Speeds::default();
    let mut emit = |tf: &Rec,
                    links: &[Value],
                    est: &serde_json::Map<String, Value>,
                    num: &serde_json::Map<String, Value>,
                    col: &[Value],
                    lost: &serde_json::Map<String, Value>| {
        let Ok(f) = FrameTransforms::decode(tf.data.as_slice()) else { return };
        let t = tf.log_time_ns as f64 * 1e-9;
        let tick = (t / dt).round() as u64;
        let uavs: Vec<Value> = f
            .transforms
            .iter()
            .filter_map(|x| {
                let id: UavId = x.child_frame_id.strip_prefix("uav")?.parse().ok()?;
                let p = x.translation?;
                let q = x.rotation?;
                // yaw = 2 atan2(z, w) for a rotation about z.
                let yaw = 2.0 * q.z.atan2(q.w);
                let v = speeds.at(id, t, p.x, p.y);
                Some(json!({"id": id, "x": p.x, "y": p.y, "yaw": yaw, "v": v, "alive": !lost.contains_key(&id.to_string()), "colliding": false}))
            })
            .collect();
        let frame = json!({"kind": "step", "tick": tick, "t": t, "speed": null, "ended": null, "uavs": uavs, "links": links,
                           "estimates": est, "numbers": num, "collisions": col, "lost": lost});
        out.push((tick, tf.log_time_ns, frame));
    };
    for m in messages {
        // A tick's frame is emitted once every message of its time has been read.
        if let Some(tf) = pending_tf.filter(|tf| m.log_time_ns > tf.log_time_ns) {
            emit(tf, &links, &estimates, &numbers, &collisions, &lost);
            pending_tf = None;
        }
        let name = topic(m);
        if name == "/tf" {
            pending_tf = Some(m);
        } else if name == "/radio" {
            links = SceneUpdate::decode(m.data.as_slice()).map(|u| radio_links(&u)).unwrap_or_default();
        } else if name == "/events" {
            if let Ok(l) = Log::decode(m.data.as_slice()) {
                event(&l, &mut collisions, &mut lost, m.log_time_ns as f64 * 1e-9);
            }
        } else if let Some(rest) = name.strip_prefix("/uav/") {
            let (id, what) = rest.split_once('/').unwrap_or((rest, ""));
            match what {
                "numbers" => {
                    if let Ok(v) = serde_json::from_slice::<Value>(&m.data) {
                        numbers.insert(id.to_string(), v);
                    }
                }
                "estimates" => {
                    if let Ok(u) = SceneUpdate::decode(m.data.as_slice()) {
                        let pts: Vec<Value> = u
                            .entities
                            .iter()
                            .flat_map(|e| &e.spheres)
                            .filter_map(|s| s.pose.and_then(|p| p.position))
                            .map(|p| json!([p.x, p.y]))
                            .collect();
                        estimates.insert(id.to_string(), Value::Array(pts));
                    }
                }
                _ => {}
            }
        }
    }
    if let Some(tf) = pending_tf {
        emit(tf, &links, &estimates, &numbers, &collisions, &lost);
    }
    out
}

/// Each UAV's speed from its recorded positions: the distance from its previous position over
/// the time between [m/s] (`/tf` holds no velocity), null at its first.
#[derive(Default)]
struct Speeds {
    last: BTreeMap<UavId, (f64, f64, f64)>,
}

impl Speeds {
    /// UAV `id` at (`x`, `y`) at `t` [s]: its speed since its previous position, if any.
    fn at(&mut self, id: UavId, t: f64, x: f64, y: f64) -> Option<f64> {
        let v = self.last.get(&id).filter(|(t0, ..)| t > *t0).map(|&(t0, x0, y0)| (x - x0).hypot(y - y0) / (t - t0));
        self.last.insert(id, (t, x, y));
        v
    }
}

/// The radio graph's links as `[i, j, class]`: each segment's ends are two UAVs' exact
/// positions, looked up by the labels the scene puts in the line's metadata-free form: the
/// colour says the class.
fn radio_links(u: &SceneUpdate) -> Vec<Value> {
    let mut out = Vec::new();
    for e in &u.entities {
        let ids: Vec<UavId> = e
            .metadata
            .iter()
            .filter(|kv| kv.key == "links")
            .flat_map(|kv| kv.value.split(',').filter_map(|x| x.parse().ok()))
            .collect();
        for l in &e.lines {
            for (k, c) in l.colors.iter().step_by(2).enumerate() {
                let (Some(&i), Some(&j)) = (ids.get(2 * k), ids.get(2 * k + 1)) else { continue };
                let class = swarm_record::scene::class_of_color(c).name();
                out.push(json!([i, j, class]));
            }
        }
    }
    out
}

/// Collisions and losses from the `/events` log lines the scene writes.
fn event(l: &Log, collisions: &mut Vec<Value>, lost: &mut serde_json::Map<String, Value>, t: f64) {
    let words: Vec<&str> = l.message.split_whitespace().collect();
    match words.as_slice() {
        ["collision:", "UAV", id, ..] => {
            let at =
                l.message.rsplit_once("at (").map(|(_, r)| r.trim_end_matches(')').to_string()).unwrap_or_default();
            let xy: Vec<f64> = at.split(',').filter_map(|v| v.trim().parse().ok()).collect();
            if let (Ok(id), [x, y]) = (id.parse::<UavId>(), xy.as_slice()) {
                collisions.push(json!([id, x, y, null]));
            }
        }
        ["UAV", id, "lost", ..] => {
            lost.insert((*id).to_string(), json!(t));
        }
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn events_give_collisions_and_losses() {
        let mut c = Vec::new();
        let mut lost = serde_json::Map::new();
        let log = |m: &str| Log { message: m.into(), ..Default::default() };
        event(&log("collision: UAV 3 with an obstacle at (1.50, -2.25)"), &mut c, &mut lost, 1.0);
        event(&log("UAV 4 lost (no longer alive)"), &mut c, &mut lost, 2.0);
        assert_eq!(c, vec![json!([3, 1.5, -2.25, null])]);
        assert_eq!(lost["4"], json!(2.0));
    }

    #[test]
    fn speeds_come_from_successive_positions() {
        let mut s = Speeds::default();
        assert_eq!(s.at(UavId::new(1), 0.0, 0.0, 0.0), None);
        assert_eq!(s.at(UavId::new(1), 0.5, 3.0, 4.0), Some(10.0));
        assert_eq!(s.at(UavId::new(2), 0.5, 1.0, 1.0), None, "each UAV its own");
        assert_eq!(s.at(UavId::new(1), 0.5, 9.0, 9.0), None, "no time between: no speed");
    }
}

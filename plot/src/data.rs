//! A run folder read back for the figures: `trajectories.csv`, `agent_states.csv`,
//! `localization.csv`, `connectivity.csv`, `world.json`, `summary.json` and `scenario.toml`, all
//! written by the recorder. Columns are found by their header name, so a column added later does
//! not break a reader; a file that is missing (a folder from before it existed) leaves its
//! figures empty, except the trajectories, without which there is nothing to draw.

use anyhow::{anyhow, Context, Result};
use std::collections::{BTreeMap, HashMap};
use std::path::Path;
use swarm_config::Scenario;
use swarm_types::UavId;
use swarm_wire::TruthWorld;

/// One UAV at one tick, from `trajectories.csv`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// Sim time [s].
    pub t_s: f64,
    /// World position [m].
    pub x_m: f64,
    /// World position [m].
    pub y_m: f64,
    /// Distance to the nearest obstacle surface [m] (infinite when none).
    pub obstacle_m: f64,
    /// Distance to the nearest other UAV [m] (infinite when none).
    pub agent_m: f64,
}

/// One agent's state at one tick, from `agent_states.csv`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StateSample {
    /// Sim time [s].
    pub t_s: f64,
    /// Neighbours it held an estimate of.
    pub neighbours: f64,
    /// K21 vector magnitudes, in [`VECTORS`] order.
    pub vectors: [f64; 5],
}

/// The K21 vectors of `agent_states.csv`, column and legend names (seed 000 eq. 4.1).
pub const VECTORS: [(&str, &str); 5] = [
    ("cohesion", "cohesion |v_c|"),
    ("separation", "separation |v_s|"),
    ("avoidance", "avoidance |v_o|"),
    ("navigation", "navigation |v_n|"),
    ("output_mps", "output |v| [m/s]"),
];

/// The estimate graph at one tick, from `connectivity.csv`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ComponentsSample {
    /// Sim time [s].
    pub t_s: f64,
    /// Agents that reported at that tick.
    pub reporting: f64,
    /// Weakly connected components of "i has an estimate of j" over them.
    pub components: f64,
}

/// Everything the figures draw.
#[derive(Debug, Default)]
pub struct Run {
    /// Scenario, run id and outcome.
    pub title: String,
    /// Trees, walls, starts, goal.
    pub world: Option<TruthWorld>,
    /// Goal disc radius [m] (0 when unknown).
    pub goal_radius_m: f64,
    /// Each UAV's poses in tick order.
    pub tracks: BTreeMap<UavId, Vec<Pose>>,
    /// Each agent's states in tick order.
    pub states: BTreeMap<UavId, Vec<StateSample>>,
    /// Each agent's mean localization error over its scored estimates, `(t_s, m)`.
    pub loc_error: BTreeMap<UavId, Vec<(f64, f64)>>,
    /// Components of the estimate graph per tick.
    pub components: Vec<ComponentsSample>,
    /// The scenario's `[[netem]]` and `[[failures]]`.
    pub timeline: netem::Timeline,
    /// UAV count of the scenario (0 when unknown).
    pub uavs: u32,
    /// The separation the run's invariant holds every pair of UAVs to, centre to centre [m]
    /// (`[expect]`'s, with its default), when the scenario is known.
    pub min_separation_m: Option<f64>,
    /// Collision points `[x, y]` [m].
    pub collisions: Vec<[f64; 2]>,
}

/// A CSV file of numbers with a header row.
struct Table {
    cols: HashMap<String, usize>,
    rows: Vec<Vec<f64>>,
    name: String,
}

impl Table {
    /// Reads `dir/name`; `None` when the file does not exist.
    fn read(dir: &Path, name: &str) -> Result<Option<Table>> {
        let path = dir.join(name);
        let text = match std::fs::read_to_string(&path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(e).with_context(|| format!("cannot read {}", path.display())),
        };
        let mut lines = text.lines();
        let cols =
            lines.next().unwrap_or_default().split(',').enumerate().map(|(i, c)| (c.trim().to_string(), i)).collect();
        let rows = lines
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty())
            .map(|(n, l)| {
                l.split(',')
                    .map(|v| v.trim().parse::<f64>())
                    .collect::<Result<Vec<f64>, _>>()
                    .with_context(|| format!("{}: line {} is not numbers", path.display(), n + 2))
            })
            .collect::<Result<_>>()?;
        Ok(Some(Table { cols, rows, name: name.into() }))
    }

    /// The index of column `name`.
    fn col(&self, name: &str) -> Result<usize> {
        self.cols.get(name).copied().ok_or_else(|| anyhow!("{} has no column {name}", self.name))
    }

    /// Rows grouped by their `id` column, each turned into a `T` by `f` (in file order).
    fn by_id<T>(&self, f: impl Fn(&[f64]) -> Option<T>) -> Result<BTreeMap<UavId, Vec<T>>> {
        let id = self.col("id")?;
        let mut out: BTreeMap<UavId, Vec<T>> = BTreeMap::new();
        for r in &self.rows {
            if let (Some(&i), Some(v)) = (r.get(id), f(r)) {
                out.entry(UavId::new(i as u32)).or_default().push(v);
            }
        }
        Ok(out)
    }
}

impl Run {
    /// Reads the run folder `dir`.
    pub fn read(dir: &Path) -> Result<Run> {
        let traj = Table::read(dir, "trajectories.csv")?
            .ok_or_else(|| anyhow!("{} has no trajectories.csv: not a run folder", dir.display()))?;
        let mut run = Run { tracks: tracks(&traj)?, ..Run::default() };
        if let Some(t) = Table::read(dir, "agent_states.csv")? {
            run.states = states(&t)?;
        }
        if let Some(t) = Table::read(dir, "localization.csv")? {
            let (c_t, c_e) = (t.col("t_s")?, t.col("mean_error_m")?);
            run.loc_error = t.by_id(|r| Some((*r.get(c_t)?, *r.get(c_e)?)))?;
        }
        if let Some(t) = Table::read(dir, "connectivity.csv")? {
            run.components = components(&t)?;
        }
        run.read_world(dir)?;
        run.read_scenario(dir)?;
        run.read_summary(dir)?;
        Ok(run)
    }

    fn read_world(&mut self, dir: &Path) -> Result<()> {
        let path = dir.join("world.json");
        if path.exists() {
            let text = std::fs::read_to_string(&path).with_context(|| format!("cannot read {}", path.display()))?;
            self.world =
                Some(serde_json::from_str(&text).with_context(|| format!("{} is not a world", path.display()))?);
        }
        Ok(())
    }

    fn read_scenario(&mut self, dir: &Path) -> Result<()> {
        let path = dir.join("scenario.toml");
        if path.exists() {
            let text = std::fs::read_to_string(&path).with_context(|| format!("cannot read {}", path.display()))?;
            let sc = Scenario::from_toml_str(&text, &path.display().to_string())?;
            self.goal_radius_m = sc.end.goal_radius_m;
            self.timeline = netem::Timeline::from_scenario(&sc);
            self.uavs = sc.swarm.count;
            self.min_separation_m = Some(sc.bounds().min_separation_m);
            self.title.clone_from(&sc.name);
        }
        Ok(())
    }

    /// The title (outcome and collisions) from `summary.json`, read as plain JSON so a summary
    /// with fields this build does not know still reads.
    fn read_summary(&mut self, dir: &Path) -> Result<()> {
        let path = dir.join("summary.json");
        if !path.exists() {
            if self.title.is_empty() {
                self.title = dir.file_name().map_or_else(String::new, |n| n.to_string_lossy().into_owned());
            }
            return Ok(());
        }
        let text = std::fs::read_to_string(&path).with_context(|| format!("cannot read {}", path.display()))?;
        let s: serde_json::Value =
            serde_json::from_str(&text).with_context(|| format!("{} is not JSON", path.display()))?;
        let outcome = match s["time_to_goal_s"].as_f64() {
            Some(t) => format!("goal in {t:.1} s"),
            None => format!("goal not reached ({})", s["end_reason"].as_str().unwrap_or("?")),
        };
        self.title = format!(
            "{} ({}): {outcome}, {} collisions",
            s["scenario"].as_str().unwrap_or(&self.title),
            s["run_id"].as_str().unwrap_or("?"),
            s["collisions"].as_u64().unwrap_or(0)
        );
        let events = s["collision_events"].as_array().map(Vec::as_slice).unwrap_or_default();
        self.collisions = events.iter().filter_map(|c| Some([c["x_m"].as_f64()?, c["y_m"].as_f64()?])).collect();
        Ok(())
    }

    /// The last sim time of the run, at least 1 s.
    pub fn t_end(&self) -> f64 {
        super::style::t_end(self.tracks.values().filter_map(|t| t.last()).map(|p| p.t_s))
    }
}

fn tracks(t: &Table) -> Result<BTreeMap<UavId, Vec<Pose>>> {
    let c = [t.col("t_s")?, t.col("x_m")?, t.col("y_m")?, t.col("obstacle_distance_m")?, t.col("agent_distance_m")?];
    t.by_id(|r| {
        let v = |k: usize| r.get(c[k]).copied();
        Some(Pose { t_s: v(0)?, x_m: v(1)?, y_m: v(2)?, obstacle_m: v(3)?, agent_m: v(4)? })
    })
}

fn states(t: &Table) -> Result<BTreeMap<UavId, Vec<StateSample>>> {
    let (c_t, c_n) = (t.col("t_s")?, t.col("neighbours")?);
    let c_v = VECTORS.map(|(name, _)| t.col(name));
    let c_v: Vec<usize> = c_v.into_iter().collect::<Result<_>>()?;
    let mut by_id = t.by_id(|r| {
        let vectors = [0, 1, 2, 3, 4].map(|k| r.get(c_v[k]).copied().unwrap_or(f64::NAN));
        Some(StateSample { t_s: *r.get(c_t)?, neighbours: *r.get(c_n)?, vectors })
    })?;
    // States arrive out of order across agents and, rarely, within one.
    by_id.values_mut().for_each(|v| v.sort_by(|a, b| a.t_s.total_cmp(&b.t_s)));
    Ok(by_id)
}

fn components(t: &Table) -> Result<Vec<ComponentsSample>> {
    let (c_t, c_r, c_c) = (t.col("t_s")?, t.col("reporting")?, t.col("components")?);
    Ok(t.rows
        .iter()
        .filter_map(|r| Some(ComponentsSample { t_s: *r.get(c_t)?, reporting: *r.get(c_r)?, components: *r.get(c_c)? }))
        .collect())
}

/// A small run folder for the figures' tests: two UAVs over 3 s among two trees and a wall, a
/// split and a merge of the estimate graph, a partition from 1 s to 2 s and a kill at 2.5 s.
#[cfg(test)]
pub fn synthetic_run_folder(dir: &Path) {
    use std::fmt::Write as _;
    std::fs::create_dir_all(dir).expect("dir");
    let (mut traj, mut states, mut loc, mut conn) = (
        String::from("tick,t_s,id,x_m,y_m,yaw_rad,vx_mps,vy_mps,obstacle_distance_m,agent_distance_m,colliding,alive,cmd_on_time\n"),
        String::from("tick,t_s,id,step_time_us,obstacles,neighbours,in_radio_range,cohesion,separation,avoidance,navigation,output_mps\n"),
        String::from("tick,t_s,id,neighbours,scored,mean_error_m,max_error_m\n"),
        String::from("tick,t_s,reporting,components\n"),
    );
    for tick in 1..=30u32 {
        let t = f64::from(tick) * 0.1;
        for id in 1..=2u32 {
            let y = f64::from(id);
            let ad = if tick == 30 { "inf".to_string() } else { "1.0000".into() };
            let _ = writeln!(traj, "{tick},{t:.3},{id},{:.4},{y:.4},0,0.5,0,{:.4},{ad},0,1,1", t * 2.0, 2.0 - t / 2.0);
            let n = u32::from(!(10..20).contains(&tick));
            let _ = writeln!(states, "{tick},{t:.3},{id},100,3,{n},1,0.25,0.5,0.125,0.75,0.4");
            let _ = writeln!(loc, "{tick},{t:.3},{id},{n},{n},{:.4},{:.4}", 0.05 * y, 0.1 * y);
        }
        let comps = if (10..20).contains(&tick) { 2 } else { 1 };
        let _ = writeln!(conn, "{tick},{t:.3},2,{comps}");
    }
    let world = TruthWorld {
        trees: vec![[2.0, 0.0, 0.3], [4.0, 3.0, 0.2]],
        walls: vec![[0.0, -1.0, 6.0, -1.0, 0.2]],
        starts: vec![[0.0, 1.0, 0.0], [0.0, 2.0, 0.0]],
        goal: [6.0, 1.5],
        body_radius_m: 0.3,
    };
    let mut sc = swarm_config::builtin("open-field-5").expect("builtin");
    sc.swarm.count = 2;
    let timeline = "[[netem]]\nat_s = 1.0\npartition = { scheme = \"halves\", nodes = [1, 2] }\n\n[[netem]]\nat_s = 2.0\npartition = { scheme = \"healed\" }\n\n[[failures]]\nat_s = 2.5\nuav = 2\nkind = \"kill\"\n";
    let timeline: swarm_config::Timeline = toml::from_str(timeline).expect("timeline");
    (sc.netem, sc.failures) = (timeline.netem, timeline.failures);
    let scenario = toml::to_string(&sc).expect("toml");
    let summary = r#"{"scenario": "synthetic <2>", "run_id": "r1", "time_to_goal_s": null, "end_reason": "time_limit", "collisions": 1, "collision_events": [{"x_m": 4.0, "y_m": 1.0}]}"#;
    for (name, text) in [
        ("trajectories.csv", traj),
        ("agent_states.csv", states),
        ("localization.csv", loc),
        ("connectivity.csv", conn),
        ("world.json", serde_json::to_string(&world).expect("json")),
        ("scenario.toml", scenario),
        ("summary.json", summary.to_string()),
    ] {
        std::fs::write(dir.join(name), text).expect("write");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_run_folder_reads_back() {
        let dir = std::env::temp_dir().join(format!("plot-data-{}", std::process::id()));
        synthetic_run_folder(&dir);
        let run = Run::read(&dir).expect("reads");
        assert_eq!(run.tracks.len(), 2);
        assert_eq!(run.tracks[&UavId::new(2)].len(), 30);
        assert!(run.tracks[&UavId::new(1)][29].agent_m.is_infinite(), "inf reads as infinity");
        assert_eq!(run.states[&UavId::new(1)][0].vectors, [0.25, 0.5, 0.125, 0.75, 0.4]);
        assert_eq!(run.loc_error[&UavId::new(2)][0], (0.1, 0.1));
        assert_eq!(run.components.iter().filter(|c| c.components == 2.0).count(), 10);
        assert_eq!(run.timeline.rules().len(), 2);
        assert_eq!(run.uavs, 2);
        assert_eq!(run.collisions, vec![[4.0, 1.0]]);
        assert!(
            run.title.starts_with("synthetic <2> (r1): goal not reached (time_limit), 1 collisions"),
            "{}",
            run.title
        );
        assert_eq!(run.world.as_ref().map(|w| w.trees.len()), Some(2));
        assert!((run.t_end() - 3.0).abs() < 1e-9);
        std::fs::remove_file(dir.join("trajectories.csv")).expect("rm");
        assert!(Run::read(&dir).is_err(), "no trajectories, no run folder");
        let _ = std::fs::remove_dir_all(&dir);
    }
}

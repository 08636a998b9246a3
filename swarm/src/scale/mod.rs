//! `swarm scale`: how the whole stack holds up as the swarm grows (issue 11, item 5). It flies a
//! series of scenarios of growing size, each a full `swarm run` under the study's folder, and
//! puts side by side what a user of a swarm simulator asks first: x real time, the hub's tick
//! and the agents' step on the wall clock (p50 / p99, from summary.json's `timing`), resident
//! memory in total and per UAV, and whether the swarm still flew well (collisions, goal).
//!
//! Resident memory is not in the run's summary: nothing inside a run can see every process of
//! it. While a run flies, this command samples `/proc` every [`RSS_SAMPLE`] for the processes
//! descending from its own (the hub and every agent process or agent host; the recorder lives in
//! this process and is left out) and keeps the peak of their summed `VmRSS` (Linux; elsewhere
//! the column reads 0). `tools/run_rss.py` does the same from outside for a single `swarm run`.
//!
//! Each row also says what an agent received per tick (summary.json's `traffic`, each agent's
//! own counts): shares from the UAVs it listened to, those it counted, and the payload bytes of
//! its samples and those shares; at constant density these stay flat as the
//! swarm grows, since a session hears only its agents' radio neighbours. `--sizes 100,300,1000`
//! flies each scenario at those sizes, its start disc scaled to keep the density (the world is
//! unchanged), for exactly that series.
//!
//! Writes `scale.md` (the table), `scale.json` (the rows), and `scale.svg` / `scale.png` (x real
//! time and RSS per UAV against the UAV count: [`chart`], drawn with plotters and an embedded
//! font, so no system font is needed). [`proc_fs`] reads `/proc`. With `--peer vmas`, [`peer`]
//! flies a peer simulator at each row's size right after it, for a ratio measured side by side. Speeds depend on the machine and its load: this is a measurement,
//! never a test assertion.

use crate::study::{run_variant, VariantRun};
use anyhow::{Context, Result};
use clap::Args;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;
use swarm_args::{scenario_value, unix_secs};
use swarm_config::Scenario;
use swarm_record::summary::Summary;

pub(crate) mod chart;
pub mod peer;

/// The default series: seed 000's 5, its section 6.4's 40 (controller alone and full ICP stack),
/// 100, and 1000 on the controller alone.
pub const DEFAULT_SCENARIOS: &str = "forest-5,forest-40,forest-40-icp,forest-100,open-1000";

/// How often the resident memory of a run's processes is sampled.
const RSS_SAMPLE: Duration = Duration::from_millis(200);

/// `swarm scale`.
#[derive(Args, Debug, Clone)]
pub struct ScaleArgs {
    /// Scenarios to fly, comma-separated files or built-in names; a name that is neither is
    /// skipped with a message.
    #[arg(long, default_value = DEFAULT_SCENARIOS)]
    pub scenarios: String,
    /// Cap every run's sim time [s] (default: each scenario's own `end.time_limit_s`).
    #[arg(long)]
    pub time_limit: Option<f64>,
    /// Override every run's time mode (`lockstep` or `realtime`).
    #[arg(long)]
    pub time_mode: Option<String>,
    /// Fly each scenario at these swarm sizes instead of its own (e.g. `100,300,1000`): its start
    /// disc is scaled to keep the density; the world and everything else stay.
    #[arg(long, value_delimiter = ',')]
    pub sizes: Vec<u32>,
    /// Agents per process for every run (default: as `swarm run` picks).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub agents_per_process: Option<u32>,
    /// Print the rows as JSON on stdout instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Study folder (default: runs/scale-<time>).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Fly this peer simulator at each row's size right after our run, and print its x real time
    /// and ours divided by it (see `--peer-cmd`).
    #[arg(long, value_enum, requires = "peer_cmd")]
    pub peer: Option<peer::Peer>,
    /// The peer's command: a Python and the script that drives it, e.g.
    /// `"/opt/vmas/bin/python vmas_flocking.py"` (docs/performance.md says how to install it).
    #[arg(long)]
    pub peer_cmd: Option<String>,
    /// Wall seconds a peer run may take: its steps are as many as fit, and a size whose probe
    /// overruns this is reported as out of the peer's reach.
    #[arg(long, default_value_t = 120.0)]
    pub peer_budget_s: f64,
    /// After each run, fly it again as `swarm floor` does (the whole swarm in this process, on
    /// one thread, no messages: the same flight in lockstep) and quote the run's wall time per
    /// tick as a multiple of that floor.
    #[arg(long)]
    pub floor: bool,
}

/// One row of the table: one run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScaleRow {
    /// Scenario name.
    pub scenario: String,
    /// UAVs.
    pub uavs: usize,
    /// Localization mode (`broadcast`, `icp`, `uvdar`).
    pub localization: String,
    /// `lockstep` or `realtime`.
    pub time_mode: String,
    /// Most processes of the run alive at once (hub + agent processes and hosts).
    pub processes: usize,
    /// Sim seconds per wall second.
    pub x_real_time: f64,
    /// The hub's own work per tick, median and 99th percentile [wall ms].
    pub hub_tick_p50_ms: f64,
    /// See `hub_tick_p50_ms`.
    pub hub_tick_p99_ms: f64,
    /// Agent control step, median and 99th percentile over every step of every agent [wall ms].
    pub agent_step_p50_ms: f64,
    /// See `agent_step_p50_ms`.
    pub agent_step_p99_ms: f64,
    /// Peak of the resident memory summed over the run's processes [MiB].
    pub rss_total_mib: f64,
    /// `rss_total_mib / uavs` [MiB].
    pub rss_per_uav_mib: f64,
    /// Collisions (contacts begun).
    pub collisions: usize,
    /// Sim time the goal was reached, if it was [s].
    pub goal_s: Option<f64>,
    /// Sim time flown [s].
    pub sim_time_s: f64,
    /// Share of commands that arrived after their tick closed.
    pub late_share: f64,
    /// Shares that reached an agent per tick, from the UAVs it listened to (summary.json's
    /// `traffic`).
    #[serde(default)]
    pub shares_arrived_per_tick: f64,
    /// Shares an agent counted (inside a neighbour's window) per tick.
    #[serde(default)]
    pub shares_counted_per_tick: f64,
    /// Payload kB an agent received per tick (its sensors, radio sets, rules and shares).
    #[serde(default)]
    pub kb_received_per_tick: f64,
    /// CPU seconds per sim second, user + system, by role: `hub`, `agents` (every agent process
    /// or host), `launcher` (this process: the recorder and the launcher).
    #[serde(default)]
    pub cpu_s_per_sim_s: BTreeMap<String, f64>,
    /// The run's wall time per tick [ms].
    #[serde(default)]
    pub wall_ms_per_tick: f64,
    /// The floor of the same flight (`--floor`): its CPU time per tick on one thread [ms].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub floor_ms_per_tick: Option<f64>,
    /// The peer flown at this row's size right after it (`--peer`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub peer: Option<peer::PeerRow>,
}

impl ScaleRow {
    /// The row of a finished run from its summary and the memory and CPU measured around it.
    pub fn new(s: &Summary, localization: &str, watched: &Watched) -> ScaleRow {
        let mem = watched.mem;
        let rss_total_mib = mem.rss_kib as f64 / 1024.0;
        let sim_s = s.sim_time_s.max(f64::MIN_POSITIVE);
        let t = &s.timing;
        ScaleRow {
            scenario: s.scenario.clone(),
            uavs: s.uav_count,
            localization: localization.to_string(),
            time_mode: s.time_mode.clone(),
            processes: mem.processes,
            x_real_time: s.sim_speed,
            hub_tick_p50_ms: t.hub_tick_p50_ms,
            hub_tick_p99_ms: t.hub_tick_p99_ms,
            agent_step_p50_ms: t.agent_step_p50_ms,
            agent_step_p99_ms: t.agent_step_p99_ms,
            rss_total_mib,
            rss_per_uav_mib: rss_total_mib / s.uav_count.max(1) as f64,
            collisions: s.collisions,
            goal_s: s.time_to_goal_s,
            sim_time_s: s.sim_time_s,
            late_share: t.late_share,
            shares_arrived_per_tick: s.traffic.shares_arrived_per_agent_tick,
            shares_counted_per_tick: s.traffic.shares_counted_per_agent_tick,
            kb_received_per_tick: s.traffic.bytes_per_agent_tick / 1000.0,
            cpu_s_per_sim_s: watched.cpu_s_by_role().into_iter().map(|(role, cpu)| (role, cpu / sim_s)).collect(),
            wall_ms_per_tick: 1e3 * s.wall_time_s / s.ticks.max(1) as f64,
            floor_ms_per_tick: None,
            peer: None,
        }
    }
}

/// Runs `swarm scale`.
pub async fn scale(a: ScaleArgs, controllers: &uav_agent::Controllers) -> Result<ExitCode> {
    let plan = plan(&a)?;
    let peer_cmd = a.peer.and(a.peer_cmd.as_deref()).map(peer::PeerCmd::parse).transpose()?;
    anyhow::ensure!(a.peer_budget_s > 0.0, "--peer-budget-s must be positive");
    let out = a.out.clone().unwrap_or_else(|| PathBuf::from("runs").join(format!("scale-{}", unix_secs())));
    std::fs::create_dir_all(&out).with_context(|| format!("cannot create {}", out.display()))?;
    let mut rows = Vec::new();
    for (i, sc) in plan.iter().enumerate() {
        let mode = sc.localization.mode.name();
        eprintln!(
            "[{}/{}] {}: {} UAVs, {mode}, {:.0} s of sim time",
            i + 1,
            plan.len(),
            sc.name,
            sc.count(),
            sc.end.time_limit_s
        );
        let me = std::process::id();
        let own_before = proc_fs::own_ticks();
        let sampler = proc_fs::Sampler::start(RSS_SAMPLE, Watched::default(), move |w: &mut Watched| {
            w.take(&proc_fs::descendants_now(me));
        });
        let how = VariantRun { per_process: a.agents_per_process, progress: true };
        let tag = format!("{:02}-{}", i + 1, sc.name);
        let summary = run_variant(sc, &out, &tag, how).await;
        let mut watched = sampler.stop().await;
        watched.launcher_ticks = proc_fs::own_ticks().saturating_sub(own_before);
        let mut row = ScaleRow::new(&summary?, mode, &watched);
        if a.floor {
            let floor = tokio::task::block_in_place(|| crate::floor::fly(sc, controllers, None, false))?;
            row.floor_ms_per_tick = Some(floor.floor_ms_per_tick);
        }
        if let Some(cmd) = &peer_cmd {
            let size = peer::PeerSize {
                agents: sc.count(),
                obstacles: peer::obstacles_in(&out.join(&tag))?,
                rays: sc.lidar.beams,
            };
            eprintln!("{tag}: peer at {} agents, {} obstacles, {} rays", size.agents, size.obstacles, size.rays);
            row.peer = Some(peer::fly(cmd, size, Duration::from_secs_f64(a.peer_budget_s)).await?);
        }
        rows.push(row);
    }
    let table = table(&rows);
    std::fs::write(out.join("scale.md"), &table)?;
    std::fs::write(out.join("scale.json"), serde_json::to_string_pretty(&rows)?)?;
    chart::write(&rows, &out.join("scale.svg"), &out.join("scale.png"))?;
    if a.json {
        swarm_node::process::out(&serde_json::to_string_pretty(&rows)?);
    } else {
        print!("{table}");
    }
    eprintln!("study folder: {} (scale.md, scale.json, scale.svg, scale.png)", out.display());
    Ok(ExitCode::SUCCESS)
}

/// The scenarios to fly, with the command line's overrides; names that are neither a file nor
/// a built-in are skipped with a message, any other error stops the study before it starts.
fn plan(a: &ScaleArgs) -> Result<Vec<Scenario>> {
    let mode: Option<swarm_config::TimeMode> =
        a.time_mode.as_deref().map(|m| scenario_value("--time-mode", m)).transpose()?;
    let mut plan = Vec::new();
    for name in a.scenarios.split(',').map(str::trim).filter(|n| !n.is_empty()) {
        let known = Path::new(name).exists() || swarm_config::BUILTIN.iter().any(|(n, _)| *n == name);
        if !known {
            eprintln!("{name}: no such file or built-in scenario, skipped");
            continue;
        }
        let (mut sc, _) = Scenario::from_arg(name)?;
        if let Some(t) = a.time_limit {
            sc.end.time_limit_s = t;
        }
        if let Some(m) = mode {
            sc.time.mode = m;
        }
        if a.sizes.is_empty() {
            plan.push(sc);
        } else {
            for &n in &a.sizes {
                plan.push(resized(&sc, n).with_context(|| format!("--sizes {n} of {name}"))?);
            }
        }
    }
    anyhow::ensure!(!plan.is_empty(), "--scenarios: none of `{}` exists", a.scenarios);
    Ok(plan)
}

/// `sc` with `n` UAVs at the same density: its start disc's area scaled by `n / count`, its name
/// `<name>-n<n>`. Needs a start disc (listed starts cannot be resized), and informed and failed
/// UAVs that all exist among the `n`.
pub fn resized(sc: &Scenario, n: u32) -> Result<Scenario> {
    anyhow::ensure!(n > 0, "a swarm needs a UAV");
    let mut out = sc.clone();
    let area = out
        .swarm
        .start_area
        .as_mut()
        .context("the scenario lists its start positions; only a start disc can be resized")?;
    area.radius_m *= (f64::from(n) / f64::from(sc.swarm.count)).sqrt();
    if let swarm_config::Informed::Ids(ids) = &sc.swarm.informed {
        anyhow::ensure!(ids.iter().all(|&i| i.get() <= n), "informed UAVs {ids:?} are not all among {n}");
    }
    anyhow::ensure!(
        sc.swarm.failed.iter().all(|&i| i.get() <= n),
        "failed UAVs {:?} are not all among {n}",
        sc.swarm.failed
    );
    out.swarm.count = n;
    out.name = format!("{}-n{n}", sc.name);
    Ok(out)
}

/// Two decimals or `-`; three below 1 (step and tick times are often fractions of a ms).
fn ms(v: f64) -> String {
    match v {
        v if !v.is_finite() => "-".into(),
        v if v < 1.0 => format!("{v:.3}"),
        v => format!("{v:.2}"),
    }
}

/// The table of `rows`, in Markdown, with the peers' figures beneath.
pub fn table(rows: &[ScaleRow]) -> String {
    let mut t = String::new();
    let _ = writeln!(t, "# swarm scale: the full stack as the swarm grows\n");
    let _ = writeln!(
        t,
        "| scenario | UAVs | localization | time | processes | x real time | hub tick p50 / p99 ms | agent step p50 / p99 ms | RSS total MiB | RSS per UAV MiB | shares in / used per agent tick | kB in per agent tick | collisions | goal s |"
    );
    let _ = writeln!(t, "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for r in rows {
        let _ = writeln!(
            t,
            "| {} | {} | {} | {} | {} | {:.2} | {} / {} | {} / {} | {:.0} | {:.1} | {:.1} / {:.1} | {:.2} | {} | {} |",
            r.scenario,
            r.uavs,
            r.localization,
            r.time_mode,
            r.processes,
            r.x_real_time,
            ms(r.hub_tick_p50_ms),
            ms(r.hub_tick_p99_ms),
            ms(r.agent_step_p50_ms),
            ms(r.agent_step_p99_ms),
            r.rss_total_mib,
            r.rss_per_uav_mib,
            r.shares_arrived_per_tick,
            r.shares_counted_per_tick,
            r.kb_received_per_tick,
            r.collisions,
            r.goal_s.map_or_else(|| format!("no ({:.0} s flown)", r.sim_time_s), |g| format!("{g:.1}")),
        );
    }
    cpu_table(&mut t, rows);
    peer_table(&mut t, rows);
    let _ = writeln!(
        t,
        "\nPeers: gym-pybullet-drones reports 10 drones at about 2x real time; MRS's lightweight simulator claims hundreds of UAVs in real time with no localization; Crazyswarm2's simulator runs 5 drones at 0.15x (its issue #890)."
    );
    t
}

/// Where each run's CPU went, by role, and its wall time per tick beside the floor's (`--floor`).
fn cpu_table(t: &mut String, rows: &[ScaleRow]) {
    let _ = writeln!(
        t,
        "\n| scenario | UAVs | CPU s per sim s: hub / agents / launcher | all | wall ms per tick | floor ms per tick | wall ÷ floor |"
    );
    let _ = writeln!(t, "|---|---|---|---|---|---|---|");
    for r in rows {
        let cpu = |role: &str| r.cpu_s_per_sim_s.get(role).copied().unwrap_or(0.0);
        let floor = r.floor_ms_per_tick.filter(|f| *f > 0.0);
        let _ = writeln!(
            t,
            "| {} | {} | {:.3} / {:.3} / {:.3} | {:.3} | {} | {} | {} |",
            r.scenario,
            r.uavs,
            cpu("hub"),
            cpu("agents"),
            cpu("launcher"),
            r.cpu_s_per_sim_s.values().sum::<f64>(),
            ms(r.wall_ms_per_tick),
            floor.map_or_else(|| "-".into(), ms),
            floor.map_or_else(|| "-".into(), |f| format!("{:.2}", r.wall_ms_per_tick / f)),
        );
    }
    let _ = writeln!(
        t,
        "\nThe floor is the same flight with the whole swarm in one process, on one thread, with no messages (`swarm floor`); on c cores a perfectly spread run could at best take floor / c per tick."
    );
}

/// The side-by-side table of the rows flown with `--peer`: each peer run came right after ours.
fn peer_table(t: &mut String, rows: &[ScaleRow]) {
    let with: Vec<(&ScaleRow, &peer::PeerRow)> = rows.iter().filter_map(|r| Some((r, r.peer.as_ref()?))).collect();
    if with.is_empty() {
        return;
    }
    let _ = writeln!(t, "\n## Side by side: a peer at each size, flown right after our run\n");
    let _ = writeln!(t, "| scenario | UAVs | obstacles | rays | ours x real time | peer | peer x real time | ours / peer | peer steps |");
    let _ = writeln!(t, "|---|---|---|---|---|---|---|---|---|");
    for (r, p) in with {
        let (px, ratio) = match p.x_real_time {
            Some(x) if x > 0.0 => (format!("{x:.4}"), format!("{:.0}x", r.x_real_time / x)),
            _ => (format!("out of reach ({})", p.note.as_deref().unwrap_or("no figure")), "-".into()),
        };
        let _ = writeln!(
            t,
            "| {} | {} | {} | {} | {:.2} | {} | {px} | {ratio} | {} |",
            r.scenario, r.uavs, p.obstacles, p.rays, r.x_real_time, p.peer, p.steps
        );
    }
}

/// Clock ticks per second of `/proc`'s times: Linux's `USER_HZ`, 100 on every architecture it
/// exports to user space.
pub(crate) const USER_HZ: f64 = 100.0;

/// What the sampler saw of a run's processes: the peak of their memory, and each one's CPU time
/// at its last sample (a process that ends loses at most its last [`RSS_SAMPLE`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Watched {
    /// Peak resident memory.
    pub mem: MemoryPeak,
    /// Role and user + system clock ticks of every process seen, by pid.
    pub cpu: BTreeMap<u32, (String, u64)>,
    /// This process's own clock ticks over the run (the launcher and recorder).
    pub launcher_ticks: u64,
}

impl Watched {
    /// Folds one sample of the run's processes in.
    fn take(&mut self, now: &[proc_fs::Proc]) {
        self.mem = self.mem.fold(now.iter().map(|p| p.rss_kib).sum(), now.iter().filter(|p| p.rss_kib > 0).count());
        for p in now {
            // A process that has exited and not yet been reaped has no command line any more:
            // it keeps the role it was seen with.
            let e = self.cpu.entry(p.pid).or_insert_with(|| (p.role.to_string(), 0));
            if p.role != "other" {
                e.0 = p.role.to_string();
            }
            e.1 = p.ticks;
        }
    }

    /// CPU seconds by role (`hub`, `agents`, `routers`, `launcher`).
    pub fn cpu_s_by_role(&self) -> BTreeMap<String, f64> {
        let mut by: BTreeMap<String, f64> = BTreeMap::new();
        for (role, ticks) in self.cpu.values() {
            *by.entry(role.clone()).or_default() += *ticks as f64 / USER_HZ;
        }
        by.insert("launcher".into(), self.launcher_ticks as f64 / USER_HZ);
        by
    }
}

/// The peak resident memory of a run's processes.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct MemoryPeak {
    /// Peak of the summed `VmRSS` [KiB].
    pub rss_kib: u64,
    /// Most processes alive at once.
    pub processes: usize,
}

impl MemoryPeak {
    /// Takes one sample into the peak.
    fn fold(self, rss_kib: u64, processes: usize) -> MemoryPeak {
        MemoryPeak { rss_kib: self.rss_kib.max(rss_kib), processes: self.processes.max(processes) }
    }
}

/// Reading `/proc`: who descends from whom, how much each holds resident, and the CPU time a
/// process and the machine used (`swarm mesh`'s CPU columns). The parsing is pure (tested on
/// text); [`descendants_now`] and [`own_ticks`] are the functions here that read the files.
pub mod proc_fs {
    use super::BTreeMap;
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::Arc;
    use std::time::Duration;

    /// Samples `/proc` into a state `T` on a blocking thread (the reads are file I/O) at once and
    /// then every `every`, until stopped: `swarm scale`'s memory peak, `swarm mesh`'s CPU times.
    pub struct Sampler<T> {
        stop: Arc<AtomicBool>,
        task: tokio::task::JoinHandle<T>,
    }

    impl<T: Default + Send + 'static> Sampler<T> {
        /// Starts sampling with `take` into `state`.
        pub fn start(every: Duration, mut state: T, mut take: impl FnMut(&mut T) + Send + 'static) -> Sampler<T> {
            let stop = Arc::new(AtomicBool::new(false));
            let flag = stop.clone();
            let task = tokio::task::spawn_blocking(move || loop {
                take(&mut state);
                if flag.load(Ordering::Relaxed) {
                    return state;
                }
                std::thread::sleep(every);
            });
            Sampler { stop, task }
        }

        /// Stops after one last sample and gives the state (its default if the thread died).
        pub async fn stop(self) -> T {
            self.stop.store(true, Ordering::Relaxed);
            self.task.await.unwrap_or_default()
        }
    }

    /// The fields of `/proc/<pid>/stat` after the command name in parentheses (a name may itself
    /// hold spaces and parentheses, so the last `)` ends it), the state (field 3) first.
    fn after_name(stat: &str) -> Option<Vec<&str>> {
        Some(stat[stat.rfind(')')? + 1..].split_whitespace().collect())
    }

    /// The parent pid in the text of `/proc/<pid>/stat`: the field after the state.
    pub fn parent_of(stat: &str) -> Option<u32> {
        after_name(stat)?.get(1)?.parse().ok()
    }

    /// User + system time [clock ticks] in the text of `/proc/<pid>/stat`: fields 14 and 15.
    pub fn process_ticks(stat: &str) -> Option<u64> {
        let f = after_name(stat)?;
        // `f[0]` is field 3, so field k is `f[k - 3]`.
        Some(f.get(11)?.parse::<u64>().ok()? + f.get(12)?.parse::<u64>().ok()?)
    }

    /// (busy, total) clock ticks of all cores in the text of `/proc/stat` (its `cpu` line), busy
    /// being everything but idle and iowait, and the cores it counts (its `cpuN` lines).
    pub fn machine_ticks(stat: &str) -> Option<(u64, u64, usize)> {
        let line = stat.lines().find(|l| l.starts_with("cpu "))?;
        let v: Vec<u64> = line.split_whitespace().skip(1).map(|f| f.parse().ok()).collect::<Option<_>>()?;
        let total: u64 = v.iter().take(8).sum();
        let idle = v.get(3)? + v.get(4).copied().unwrap_or(0);
        let cores = stat
            .lines()
            .filter(|l| l.starts_with("cpu") && l.as_bytes().get(3).is_some_and(u8::is_ascii_digit))
            .count();
        Some((total - idle, total, cores))
    }

    /// `VmRSS` in the text of `/proc/<pid>/status` [KiB] (absent for a zombie).
    pub fn vm_rss_kib(status: &str) -> Option<u64> {
        let line = status.lines().find(|l| l.starts_with("VmRSS:"))?;
        line.split_whitespace().nth(1)?.parse().ok()
    }

    /// Every pid that descends from `root` (not `root` itself), given `(pid, parent)` pairs.
    pub fn descendants(root: u32, parents: &[(u32, u32)]) -> Vec<u32> {
        let mut children: BTreeMap<u32, Vec<u32>> = BTreeMap::new();
        for &(pid, parent) in parents {
            children.entry(parent).or_default().push(pid);
        }
        let mut found = Vec::new();
        let mut todo = vec![root];
        while let Some(p) = todo.pop() {
            for &c in children.get(&p).map_or(&[][..], Vec::as_slice) {
                found.push(c);
                todo.push(c);
            }
        }
        found
    }

    /// What a role a process of a run plays, from its command line (`/proc/<pid>/cmdline`, the
    /// arguments NUL-separated): the subcommand after the program, `hub`, `agent` or `router`,
    /// as `agents`, `hub`, `routers`; anything else is `other`.
    pub fn role_of(cmdline: &[u8]) -> &'static str {
        match cmdline.split(|&b| b == 0).nth(1) {
            Some(b"hub") => "hub",
            Some(b"agent") => "agents",
            Some(b"router") => "routers",
            _ => "other",
        }
    }

    /// One process under a run, as sampled.
    #[derive(Debug, Clone, PartialEq, Eq)]
    pub struct Proc {
        /// Its pid.
        pub pid: u32,
        /// Its role ([`role_of`]).
        pub role: &'static str,
        /// Resident memory [KiB] (0 for a zombie).
        pub rss_kib: u64,
        /// User + system time so far [clock ticks].
        pub ticks: u64,
    }

    /// Every process descending from `root` now.
    pub fn descendants_now(root: u32) -> Vec<Proc> {
        let Ok(dir) = std::fs::read_dir("/proc") else { return Vec::new() };
        let stats: BTreeMap<u32, String> = dir
            .filter_map(|e| {
                let pid: u32 = e.ok()?.file_name().to_str()?.parse().ok()?;
                Some((pid, std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?))
            })
            .collect();
        let parents: Vec<(u32, u32)> = stats.iter().filter_map(|(&pid, st)| Some((pid, parent_of(st)?))).collect();
        descendants(root, &parents)
            .into_iter()
            .filter_map(|pid| {
                let ticks = process_ticks(stats.get(&pid)?)?;
                let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap_or_default();
                let cmdline = std::fs::read(format!("/proc/{pid}/cmdline")).unwrap_or_default();
                Some(Proc { pid, role: role_of(&cmdline), rss_kib: vm_rss_kib(&status).unwrap_or(0), ticks })
            })
            .collect()
    }

    /// This process's user + system time so far [clock ticks] (0 off Linux).
    pub fn own_ticks() -> u64 {
        std::fs::read_to_string("/proc/self/stat").ok().as_deref().and_then(process_ticks).unwrap_or(0)
    }
}

/// A row with every field set, for the table's and the chart's tests.
#[cfg(test)]
pub(crate) fn test_row(uavs: usize, mode: &str) -> ScaleRow {
    ScaleRow {
        scenario: format!("s{uavs}"),
        uavs,
        localization: mode.into(),
        time_mode: "lockstep".into(),
        processes: 3,
        x_real_time: 12.5,
        hub_tick_p50_ms: 0.25,
        hub_tick_p99_ms: 1.5,
        agent_step_p50_ms: 0.5,
        agent_step_p99_ms: f64::NAN,
        rss_total_mib: 200.0,
        rss_per_uav_mib: 200.0 / uavs as f64,
        collisions: 0,
        goal_s: (uavs == 5).then_some(41.25),
        sim_time_s: 60.0,
        late_share: 0.0,
        shares_arrived_per_tick: 3.0,
        shares_counted_per_tick: 2.5,
        kb_received_per_tick: 3.25,
        cpu_s_per_sim_s: [("hub".to_string(), 0.125), ("agents".to_string(), 0.5), ("launcher".to_string(), 0.25)]
            .into(),
        wall_ms_per_tick: 8.0,
        floor_ms_per_tick: (uavs == 5).then_some(2.0),
        peer: None,
    }
}

#[cfg(test)]
mod tests {
    use super::proc_fs::*;
    use super::*;

    use super::test_row as row;

    #[test]
    fn the_table_has_a_line_per_row_with_its_numbers() {
        let t = table(&[row(5, "broadcast"), row(40, "icp")]);
        let main = t.split("\n\n").nth(1).expect("the main table");
        let lines: Vec<&str> = main.lines().filter(|l| l.starts_with("| s") && !l.starts_with("| scenario")).collect();
        assert_eq!(lines.len(), 2, "{t}");
        assert_eq!(lines[0], "| s5 | 5 | broadcast | lockstep | 3 | 12.50 | 0.250 / 1.50 | 0.500 / - | 200 | 40.0 | 3.0 / 2.5 | 3.25 | 0 | 41.2 |");
        assert!(lines[1].ends_with("| 0 | no (60 s flown) |"), "{}", lines[1]);
        let header_cells = t.lines().find(|l| l.starts_with("| scenario")).map(|l| l.matches('|').count());
        assert_eq!(header_cells, Some(lines[0].matches('|').count()), "header and rows have as many cells");
        assert!(t.contains("| s5 | 5 | 0.125 / 0.500 / 0.250 | 0.875 | 8.00 | 2.00 | 4.00 |"), "{t}");
        assert!(t.contains("| s40 | 40 | 0.125 / 0.500 / 0.250 | 0.875 | 8.00 | - | - |"), "{t}");
    }

    #[test]
    fn peer_rows_get_a_side_by_side_table_with_the_ratio() {
        assert!(!table(&[row(5, "icp")]).contains("Side by side"), "no peer, no table");
        let mut a = row(40, "icp");
        a.peer = Some(peer::PeerRow {
            peer: "vmas 1.5.2".into(),
            x_real_time: Some(0.5),
            steps: 100,
            obstacles: 51,
            rays: 750,
            note: None,
        });
        let mut b = row(1000, "icp");
        b.peer = Some(peer::PeerRow {
            peer: "vmas 1.5.2".into(),
            x_real_time: None,
            steps: 0,
            obstacles: 700,
            rays: 750,
            note: Some("slow".into()),
        });
        let t = table(&[a, b]);
        assert!(t.contains("| s40 | 40 | 51 | 750 | 12.50 | vmas 1.5.2 | 0.5000 | 25x | 100 |"), "{t}");
        assert!(t.contains("| s1000 | 1000 | 700 | 750 | 12.50 | vmas 1.5.2 | out of reach (slow) | - | 0 |"), "{t}");
    }

    #[test]
    fn a_row_takes_the_summary_and_divides_memory_by_the_uavs() {
        let sc = swarm_config::builtin("forest-5").expect("builtin");
        let mut s = swarm_record::recorder::metrics::Metrics::default().summary("r", &sc);
        (s.sim_speed, s.time_to_goal_s) = (10.0, Some(40.0));
        (s.timing.agent_step_p99_ms, s.timing.late_share) = (0.4, 0.1);
        (s.sim_time_s, s.wall_time_s, s.ticks) = (40.0, 4.0, 400);
        let mut w =
            Watched { mem: MemoryPeak { rss_kib: 10 * 1024, processes: 6 }, launcher_ticks: 200, ..Default::default() };
        let ps = |pid, role, ticks| proc_fs::Proc { pid, role, rss_kib: 1, ticks };
        w.take(&[ps(10, "hub", 100), ps(11, "agents", 300), ps(12, "agents", 500)]);
        w.take(&[ps(10, "other", 400), ps(11, "agents", 900)]);
        let r = ScaleRow::new(&s, "broadcast", &w);
        assert_eq!((r.uavs, r.processes, r.collisions, r.goal_s), (5, 6, 0, Some(40.0)));
        assert_eq!((r.rss_total_mib, r.rss_per_uav_mib), (10.0, 2.0));
        assert_eq!((r.x_real_time, r.agent_step_p99_ms, r.late_share), (10.0, 0.4, 0.1));
        let cpu: Vec<(&str, f64)> = r.cpu_s_per_sim_s.iter().map(|(k, v)| (k.as_str(), *v)).collect();
        // Each process at its last sample (agent 12 ended after 5 s; the hub was last seen as a
        // zombie, with no command line), over 40 sim s.
        assert_eq!(cpu, vec![("agents", 0.35), ("hub", 0.1), ("launcher", 0.05)]);
        assert_eq!(r.wall_ms_per_tick, 10.0);
    }

    #[test]
    fn a_resized_scenario_keeps_its_density() {
        let sc = swarm_config::builtin("open-1000").expect("builtin");
        let small = resized(&sc, 250).expect("resized");
        let (a, b) = (sc.swarm.start_area.as_ref().expect("disc"), small.swarm.start_area.as_ref().expect("disc"));
        assert_eq!((small.swarm.count, small.name.as_str()), (250, "open-1000-n250"));
        assert!((b.radius_m - a.radius_m / 2.0).abs() < 1e-9, "a quarter of the UAVs on a quarter of the area");
        assert_eq!(b.min_spacing_m, a.min_spacing_m);
        let listed = swarm_config::builtin("forest-5").expect("builtin");
        let err = resized(&listed, 10).expect_err("listed starts").to_string();
        assert!(err.contains("start disc"), "{err}");
    }

    #[test]
    fn proc_text_is_parsed_for_parent_and_resident_memory() {
        assert_eq!(parent_of("4242 (swarm agent) S 17 4242 17 0 -1 4194560 0"), Some(17));
        assert_eq!(parent_of("7 (a) b) (c) R 3 7 7"), Some(3), "the last `)` ends the name");
        assert_eq!(parent_of("garbage"), None);
        let stat = "4242 (swarm (agent)) S 1 4242 1 0 -1 4194560 120 0 0 0 250 37 0 0 20 0 9 0 100 0 0";
        assert_eq!(process_ticks(stat), Some(287), "utime 250 + stime 37, the name's `)` skipped");
        assert_eq!(process_ticks("1 (x) S 1"), None);
        let stat =
            "cpu  100 5 45 800 50 0 0 0 0 0\ncpu0 50 2 20 400 25 0 0 0 0 0\ncpu1 50 3 25 400 25 0 0 0 0 0\nintr 9\n";
        assert_eq!(machine_ticks(stat), Some((150, 1000, 2)), "busy but for idle and iowait, two cores");
        assert_eq!(machine_ticks("intr 1 2\n"), None);
        assert_eq!(vm_rss_kib("Name:\tswarm\nVmPeak:\t  9000 kB\nVmRSS:\t   15123 kB\n"), Some(15123));
        assert_eq!(vm_rss_kib("Name:\tzombie\n"), None);
        assert_eq!(role_of(b"/usr/bin/swarm\0hub\0scenario.toml\0"), "hub");
        assert_eq!(role_of(b"swarm-e2e\0agent\0--run\0r\0"), "agents");
        assert_eq!(role_of(b"swarm\0router\0"), "routers");
        assert_eq!(role_of(b"sleep\0x\0"), "other");
        assert_eq!(role_of(b""), "other");
    }

    #[test]
    fn descendants_are_children_and_their_children_only() {
        let parents = [(2, 1), (3, 2), (4, 2), (5, 1), (6, 9), (7, 3)];
        let mut d = descendants(2, &parents);
        d.sort_unstable();
        assert_eq!(d, vec![3, 4, 7]);
        assert!(descendants(6, &parents).is_empty());
        assert_eq!(MemoryPeak::default().fold(5, 2).fold(3, 4), MemoryPeak { rss_kib: 5, processes: 4 });
    }

    #[test]
    fn a_live_child_is_found_with_memory_in_proc() {
        if !Path::new("/proc/self/stat").exists() {
            return;
        }
        let mut child = std::process::Command::new("sleep").arg("5").spawn().expect("sleep starts");
        let now = descendants_now(std::process::id());
        let _ = child.kill();
        let _ = child.wait();
        let found = now.iter().find(|p| p.pid == child.id()).expect("the child is a descendant");
        assert!(found.rss_kib > 0, "and holds memory");
        assert_eq!(found.role, "other");
    }
}

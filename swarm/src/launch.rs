//! `swarm run`: the launcher. It starts the hub (`swarm hub`, a Zenoh router on a free loopback
//! port), reads the locator the hub prints, starts the recorder ([`Recording`]), then the
//! agents: one `swarm agent` process per UAV for small swarms, agent hosts (`swarm agent --ids`,
//! many agents in one process) for large ones ([`agents_per_process`]), and watches them: kills, restarts and link faults of the
//! scenario's `[[failures]]` are applied as sim time passes, and the children are stopped at the
//! end. Children are this same executable; each gets a piped stdin and `--exit-with-stdin`, so
//! they die with the launcher even if it is killed outright, and `kill_on_drop` covers the
//! ordinary paths. Child logs go to `<run folder>/logs/`. Every run makes fresh credentials in
//! `<run folder>/credentials/` ([`swarm_node::auth`]): the hub gets the dictionary, each child its own
//! user (`uav{id}`, `uavs{ids}` for a host), the recording logs in as `observer`; `--insecure`
//! skips all that.

use crate::proxy::{LinkProxy, LinkState};
use anyhow::{bail, Context, Result};
use clap::Args;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{ExitCode, Stdio};
use std::time::Duration;
use swarm_args::{default_run_id, scenario_value, RosArgs};
use swarm_config::{FailureKind, Scenario};
use swarm_node::auth::{bridge_user, ext_user, host_user, ids_text, uav_user, Credentials};
use swarm_node::pieces::LISTENING_PREFIX;
use swarm_record::recorder::{progress_bar, Recording};
use swarm_record::summary::Summary;
use swarm_types::UavId;
use swarm_wire::Keys;
use tokio::io::{AsyncBufReadExt, BufReader};
use tokio::process::{Child, ChildStdin, Command};
use tracing::{info, warn};
use uav_agent::Controllers;

/// How long the launcher waits for the hub to print its locator.
const HUB_START_TIMEOUT: Duration = Duration::from_secs(30);

/// The lease every piece announces when the scenario has link faults [ms].
const LINK_FAULT_LEASE_MS: u64 = 1000;

/// `swarm run`.
#[derive(Args, Debug, Clone)]
pub struct RunArgs {
    /// Scenario file or built-in name (default: forest-5).
    pub scenario: Option<String>,
    /// Run folder (default: runs/<run id>).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Run id: every key is under swarm/<run id> (default: <scenario>-<time>-<pid>).
    #[arg(long)]
    pub run: Option<String>,
    /// Override the scenario's time mode (`lockstep` or `realtime`).
    #[arg(long)]
    pub time_mode: Option<String>,
    /// Override the scenario's master seed (forest, start area, sensor noise).
    #[arg(long)]
    pub seed: Option<u64>,
    /// An experiment file (`[[netem]]` and `[[failures]]` tables, sim times) added to the
    /// scenario's own timeline.
    #[arg(long)]
    pub experiment: Option<PathBuf>,
    /// Fly these UAVs (`3`, `1-4,7`) with an external controller (docs/own-controller.md),
    /// added to the scenario's `[controller] external`.
    #[arg(long, value_parser = swarm_args::parse_ids)]
    pub external: Option<swarm_args::UavIds>,
    /// Set a scenario field for this run, `SECTION.FIELD=VALUE` in the scenario file's TOML
    /// (`time.tick_timeout_ms=60000`, `end.time_limit_s=30`, `localization.mode="icp"`;
    /// repeatable); the result is validated as a whole, like a file.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Zenoh config override `KEY:JSON5` for every piece of the run (repeatable).
    #[arg(long)]
    pub cfg: Vec<String>,
    /// Do not draw a progress bar.
    #[arg(long)]
    pub quiet: bool,
    /// No credentials: the hub lets anyone in (`swarm hub --insecure`; it says so loudly).
    #[arg(long)]
    pub insecure: bool,
    /// What `run.mcap` keeps.
    #[command(flatten)]
    pub mcap: swarm_record::recorder::McapArgs,
    /// Watch the run live: serve `swarm view`'s page on this port of 127.0.0.1 (default 8765;
    /// 0 = any free port) and the Foxglove WebSocket beside it; prints the addresses, and keeps
    /// serving after the run until Ctrl-C.
    #[arg(long, num_args = 0..=1, default_missing_value = "8765", value_name = "PORT")]
    pub view: Option<u16>,
    /// Agents per process: 1 is one process per UAV; more starts agent hosts. Default: 1 up to
    /// 10 UAVs, else one host per core. UAVs with kills, restarts or link faults in
    /// `[[failures]]` always get a process of their own.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub agents_per_process: Option<u32>,
    /// Exit with status 2 when a check of the scenario's `[expect]` fails (`checks[]` of the
    /// summary), after a run that otherwise ended well.
    #[arg(long)]
    pub check: bool,
    /// Also show the run to ROS 2 (`swarm ros2` in the run: /clock, /tf, each UAV's scan,
    /// odometry, goal and neighbours, cmd_vel of external UAVs; docs/ros2.md), in this ROS
    /// domain (0 when given without a value), over rmw_zenoh on the hub's router (a ROS machine
    /// logs in as `ros`) unless `--dds`.
    #[arg(long, num_args = 0..=1, default_missing_value = "0", value_name = "DOMAIN")]
    pub ros2: Option<u32>,
    /// ROS 2 over DDS, what a stock ROS 2 install speaks (implies `--ros2`).
    #[arg(long)]
    pub dds: bool,
    /// DDS on the loopback interface only (as ROS's `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`,
    /// which also sets it).
    #[arg(long)]
    pub ros2_localhost: bool,
    /// Publish the truth topics (`/tf_static`, `/world/markers`) on DDS too, where anyone on
    /// the network may read them.
    #[arg(long)]
    pub ros2_truth: bool,
    /// Run these UAVs' agents (`3`, `1-4,7`) on ROS 2 topics, as on a vehicle: each reads its
    /// scan, odometry and goal from ROS and sends its command there, and the bridge drives its
    /// body (implies `--ros2`; `swarm agent --sensors ros2`).
    #[arg(long, value_parser = swarm_args::parse_ids)]
    pub ros2_agents: Option<swarm_args::UavIds>,
    /// The run as a step function on this process's standard input and output: one JSON line of
    /// every external UAV's view (and the hub's truth) out per tick, one line of their commands
    /// in (docs/python.md; the Python package `uavswarm` speaks it). Needs `--external`; the
    /// summary goes to standard error.
    #[arg(long)]
    pub gym: bool,
}

impl RunArgs {
    /// The ROS 2 side these arguments ask for, if any.
    fn ros2_side(&self, sc: &Scenario) -> Option<Ros2Side> {
        let agents = self.ros2_agents.as_ref().map(|a| a.0.clone()).unwrap_or_default();
        if self.ros2.is_none() && !self.dds && agents.is_empty() {
            return None;
        }
        let ros = RosArgs { domain: self.ros2.unwrap_or(0), dds: self.dds, localhost: self.ros2_localhost };
        let reliable_sensors = sc.time.mode == swarm_config::TimeMode::Lockstep;
        Some(Ros2Side { localhost_only: ros.localhost_only(), ros, truth: self.ros2_truth, agents, reliable_sensors })
    }
}

/// A run's ROS 2 side: the bridge's graph, whether truth goes out on DDS, the agents on ROS
/// topics.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Ros2Side {
    /// Domain and middleware.
    pub ros: RosArgs,
    /// DDS on loopback only (the flag or ROS's environment).
    pub localhost_only: bool,
    /// Truth on DDS too.
    pub truth: bool,
    /// The UAVs whose agents read their sensors from ROS topics.
    pub agents: Vec<UavId>,
    /// Those agents ask for their scan and odometry reliably (`swarm agent --reliable-sensors`):
    /// in a lockstep run, whose bridge publishes them reliably (`swarm_ros2::Qos::sensor`).
    pub reliable_sensors: bool,
}

/// Up to this many UAVs, `swarm run` starts one process per UAV by default.
const SOLO_UP_TO_UAVS: u32 = 10;

/// How many agents `swarm run` puts in one process: `asked`, else 1 for swarms of up to
/// [`SOLO_UP_TO_UAVS`], else the swarm spread evenly over one host per core.
pub fn agents_per_process(uavs: usize, asked: Option<u32>) -> u32 {
    per_process(uavs, cores(), asked)
}

/// This machine's cores (1 when it cannot tell).
fn cores() -> u32 {
    std::thread::available_parallelism().map_or(1, |n| u32::try_from(n.get()).unwrap_or(1))
}

/// [`agents_per_process`] on a machine of `cores` cores.
fn per_process(uavs: usize, cores: u32, asked: Option<u32>) -> u32 {
    let uavs = u32::try_from(uavs).unwrap_or(u32::MAX);
    match asked {
        Some(n) => n,
        None if uavs <= SOLO_UP_TO_UAVS => 1,
        None => uavs.div_ceil(cores),
    }
}

/// The runtime workers of each of a run's `processes` agent processes (`swarm agent
/// --workers`): the machine's cores shared among them, at least one each.
///
/// Why: one host per core, each on the default two workers, put two busy threads on every core.
/// A host's agents then moved between cores, and each share's reference count crossed between
/// them. With one worker per host, and the hub completing every host's frames together
/// (`Batches::order`), forest-1000-icp ran 3 % faster on 5 % less CPU over sim s 20–120, and its
/// whole flight at the same speed on 2.4 % less (docs/performance.md, "One worker per agent
/// host").
fn workers_per_agent_process(processes: usize, cores: u32) -> u16 {
    let processes = u32::try_from(processes.max(1)).unwrap_or(u32::MAX);
    u16::try_from((cores / processes).max(1)).unwrap_or(u16::MAX)
}

/// Runs a scenario end to end and writes the run folder.
pub async fn run(a: RunArgs, controllers: &Controllers) -> Result<ExitCode> {
    let (sc, text) = resolve(&a)?;
    crate::scenarios::admit(&sc, a.scenario.as_deref().unwrap_or(swarm_config::DEFAULT_SCENARIO), controllers)?;
    let run_id = a.run.clone().unwrap_or_else(|| default_run_id(&sc.name));
    let out = a.out.clone().unwrap_or_else(|| PathBuf::from("runs").join(&run_id));
    refuse_cut_short(&out)?;
    let per_process = agents_per_process(sc.count(), a.agents_per_process);
    let show = Show {
        quiet: a.quiet,
        mcap: a.mcap.detail(sc.count()),
        journal: !a.mcap.no_journal,
        view: a.view,
        ros2: a.ros2_side(&sc),
        gym: a.gym,
    };
    let how = How { zenoh_cfg: &a.cfg, show, per_process, insecure: a.insecure };
    let (summary, hub_ok) = execute(&sc, &text, &run_id, &out, &how).await?;
    // With --gym, standard output is the step protocol's.
    let say = |line: String| if a.gym { eprintln!("{line}") } else { swarm_node::process::out(&line) };
    say(summary.human());
    say(format!("run folder: {}", out.display()));
    if a.view.is_some() {
        eprintln!("the run is over; the view stays up until Ctrl-C");
        let _ = tokio::signal::ctrl_c().await;
    }
    if a.check && hub_ok && summary.failed_checks().next().is_some() {
        return Ok(ExitCode::from(2));
    }
    Ok(summary.exit_code(hub_ok))
}

/// A run folder still holding a killed run's journal is not flown over (that would lose it);
/// the other cut-short runs beside it are named, with the command that recovers them.
fn refuse_cut_short(out: &Path) -> Result<()> {
    let recover = |d: &Path| format!("swarm recover {}", d.display());
    if swarm_record::recorder::cut_short(out) {
        anyhow::bail!(
            "{} holds a run that was cut short and not recovered: run `{}`, or choose another --out",
            out.display(),
            recover(out)
        );
    }
    let siblings = out.parent().and_then(|p| std::fs::read_dir(p).ok()).into_iter().flatten().flatten();
    for d in siblings.map(|e| e.path()).filter(|d| swarm_record::recorder::cut_short(d)) {
        eprintln!("note: {} was cut short; `{}` rebuilds its summary and run.mcap", d.display(), recover(&d));
    }
    Ok(())
}

/// The scenario `swarm run` flies, with the command line's overrides, and the text the hub
/// serves the agents.
fn resolve(a: &RunArgs) -> Result<(Scenario, String)> {
    let name = a.scenario.as_deref().unwrap_or(swarm_config::DEFAULT_SCENARIO);
    let (mut sc, mut text) = Scenario::from_arg(name)?;
    if let Some(mode) = &a.time_mode {
        sc.time.mode = scenario_value("--time-mode", mode)?;
    }
    if let Some(seed) = a.seed {
        sc.seed = seed;
        if let Some(f) = sc.world.forest.as_mut() {
            f.seed = None;
        }
    }
    if let Some(path) = &a.experiment {
        let t = sc.timeline_from_file(path)?;
        sc.netem.extend(t.netem);
        sc.failures.extend(t.failures);
    }
    if let Some(ids) = &a.external {
        let external = &mut sc.controller.external;
        for &id in &ids.0 {
            if !external.contains(&id) {
                external.push(id);
            }
        }
    }
    if a.time_mode.is_some() || a.seed.is_some() || a.experiment.is_some() || a.external.is_some() || !a.set.is_empty()
    {
        // The hub serves this text to the agents, so overrides must be in it; and the whole must
        // still be valid (link faults need realtime mode, say).
        (sc, text) = with_sets(&sc, &a.set, name)?;
    }
    Ok((sc, text))
}

/// `sc` with each `--set SECTION.FIELD=VALUE` of `sets` applied, validated as a whole like a
/// file, and its TOML text (`name`: where `sc` came from, for the errors).
pub(crate) fn with_sets(sc: &Scenario, sets: &[String], name: &str) -> Result<(Scenario, String)> {
    let mut value = toml::Value::try_from(sc).context("cannot re-serialize the scenario")?;
    for kv in sets {
        set_field(&mut value, kv)?;
    }
    let text = toml::to_string(&value).context("cannot re-serialize the scenario")?;
    let sc = Scenario::from_toml_str(&text, &format!("{name} (with the command line's overrides)"))?;
    Ok((sc, text))
}

/// Applies one `--set SECTION.FIELD=VALUE` to a scenario's TOML: the value is TOML (a number,
/// `true`, a quoted string, an array), or else taken as a string.
fn set_field(scenario: &mut toml::Value, kv: &str) -> Result<()> {
    let (path, raw) = kv.split_once('=').with_context(|| format!("--set {kv:?}: expected SECTION.FIELD=VALUE"))?;
    let value = match toml::from_str::<toml::Table>(&format!("v = {raw}")) {
        Ok(mut t) => t.remove("v").context("a value")?,
        Err(_) => toml::Value::String(raw.to_string()),
    };
    let keys: Vec<&str> = path.trim().split('.').collect();
    anyhow::ensure!(keys.iter().all(|k| !k.is_empty()), "--set {kv:?}: an empty key in {path:?}");
    let (last, parents) = keys.split_last().context("a key")?;
    let mut at = scenario;
    for k in parents {
        let table = at.as_table_mut().with_context(|| format!("--set {kv:?}: {k:?} is not a table"))?;
        at = table.entry(k.to_string()).or_insert_with(|| toml::Value::Table(toml::Table::new()));
    }
    let table = at.as_table_mut().with_context(|| format!("--set {kv:?}: {path:?} is not inside a table"))?;
    table.insert(last.to_string(), value);
    Ok(())
}

/// How [`execute`] starts the pieces.
#[derive(Debug, Clone)]
pub struct How<'a> {
    /// `--cfg` overrides for every piece.
    pub zenoh_cfg: &'a [String],
    /// What the run shows besides its run folder's CSV, summary and figures.
    pub show: Show,
    /// Agents per process (see [`agents_per_process`]).
    pub per_process: u32,
    /// Start the hub with `--insecure` instead of fresh credentials.
    pub insecure: bool,
}

/// What a run shows besides its run folder's CSV, summary and figures.
#[derive(Debug, Clone)]
pub struct Show {
    /// No progress bar.
    pub quiet: bool,
    /// Write `run.mcap`, with this much of each UAV.
    pub mcap: Option<swarm_record::scene::Detail>,
    /// Keep the recorder's journal while the run goes (for `swarm recover`).
    pub journal: bool,
    /// Serve the live view on this page port (see `RunArgs::view`).
    pub view: Option<u16>,
    /// Bridge the run to ROS 2 (see `RunArgs::ros2`).
    pub ros2: Option<Ros2Side>,
    /// The run as a step function on standard input and output (see `RunArgs::gym`).
    pub gym: bool,
}

/// Runs a resolved scenario (`text` is what the hub serves the agents) under run id `run_id`,
/// writes the run folder `out`, and returns the summary and whether the hub exited cleanly.
/// Unless `insecure`, every piece logs in with credentials made for this run in
/// `<out>/credentials/` (readable by the owner only).
pub async fn execute(sc: &Scenario, text: &str, run_id: &str, out: &Path, how: &How<'_>) -> Result<(Summary, bool)> {
    let How { zenoh_cfg, show, per_process, insecure } = how.clone();
    Keys::new(run_id)?;
    let logs = out.join("logs");
    std::fs::create_dir_all(&logs).with_context(|| format!("cannot create {}", logs.display()))?;
    let scenario_path = out.join("scenario.toml");
    std::fs::write(&scenario_path, text).with_context(|| format!("cannot write {}", scenario_path.display()))?;
    eprintln!("run {run_id}: scenario {} ({} UAVs), folder {}", sc.name, sc.count(), out.display());

    let ros_agents = ros_agents(sc, show.ros2.as_ref())?;
    let groups = spread(sc.agent_ids(), per_process, |id| has_own_failures(sc, id) || ros_agents.contains(&id));
    let creds = if insecure { None } else { Some(run_credentials(sc, out, &groups.hosts, show.ros2.as_ref())?) };
    let launcher = Launcher {
        agent_workers: workers_per_agent_process(groups.hosts.len() + groups.solo.len(), cores()),
        exe: std::env::current_exe().context("cannot find my own executable")?,
        logs,
        run_id: run_id.to_string(),
        cfg: children_cfg(sc, zenoh_cfg),
        creds,
        ros2: show.ros2.clone(),
    };
    let mut hub = launcher.hub(&scenario_path)?;
    let locators = read_locators(&mut hub.child, &launcher.logs).await?;
    info!(?locators, "hub up");
    // Where pieces started by hand (an external controller) connect: one locator a line.
    std::fs::write(out.join(HUB_FILE), locators.join("\n") + "\n")
        .with_context(|| format!("cannot write {}", out.join(HUB_FILE).display()))?;
    let proxies = start_proxies(sc, &locators).await?;

    let mut rec_cfg = match &launcher.creds {
        Some(c) => c.client_cfg(OBSERVER)?,
        None => Vec::new(),
    };
    rec_cfg.extend(zenoh_cfg.iter().cloned());
    let mut rec = Recording::start(run_id, &locators, &rec_cfg, show.mcap.is_some()).await?;
    rec.write_mcap(sc, out, show.mcap)?;
    if !show.journal {
        rec.without_journal();
    }
    if let Some(port) = show.view {
        let live = swarm_view::Live::start(run_id, &locators, &rec_cfg, port).await?;
        // Stdout, flushed at once (`out` flushes): scripts (and tests) read the address while the
        // run goes.
        swarm_node::process::out(&live.addresses());
        tokio::spawn(live.run());
    }
    if let Some(side) = &show.ros2 {
        start_bridge(&launcher, run_id, &locators, zenoh_cfg, side).await?;
    }
    if show.gym {
        start_gym(&launcher, sc, run_id, &locators, zenoh_cfg).await?;
    }
    let mut agents = Agents::start(&launcher, sc, locators, proxies, groups)?;
    let _interrupt = stop_hub_on_interrupt(&mut hub);
    let progress = progress_bar(sc, show.quiet);
    let summary = rec.record(out, sc, &progress, Some(&mut hub.child), &mut |t| agents.on_tick(t)).await?;
    progress.finish_and_clear();
    let hub_ok = agents.stop(hub).await;
    Ok((summary, hub_ok))
}

/// The UAVs whose agents run on ROS topics, each checked to have an agent of ours.
fn ros_agents(sc: &Scenario, side: Option<&Ros2Side>) -> Result<Vec<UavId>> {
    let ids = side.map(|r| r.agents.clone()).unwrap_or_default();
    for &id in &ids {
        anyhow::ensure!(
            sc.agent_ids().any(|a| a == id),
            "--ros2-agents: UAV {id} has no agent of ours in this scenario"
        );
    }
    Ok(ids)
}

/// On Ctrl-C (or a SIGINT to this process alone), closes the hub's standard input, its order to
/// end the run: it ends it as `stopped` with a last truth step, so the recording finishes whole
/// at once, as when the whole process group is interrupted (the hub then gets the signal itself).
/// Dropping the returned guard (the run is over) ends the watch.
fn stop_hub_on_interrupt(hub: &mut Piece) -> tokio::sync::oneshot::Sender<()> {
    let stdin = hub._stdin.take();
    let (guard, over) = tokio::sync::oneshot::channel::<()>();
    tokio::spawn(async move {
        tokio::select! {
            r = tokio::signal::ctrl_c() => if r.is_ok() {
                info!("interrupted: telling the hub to end the run");
            },
            _ = over => {}
        }
        drop(stdin);
    });
    guard
}

/// The file of the run folder that holds the hub's locators while the run flies.
pub const HUB_FILE: &str = "hub.txt";

/// Starts the ROS 2 bridge of the run in this process, logged in as `bridge`.
async fn start_bridge(
    launcher: &Launcher,
    run_id: &str,
    locators: &[String],
    zenoh_cfg: &[String],
    side: &Ros2Side,
) -> Result<()> {
    let mut cfg = match &launcher.creds {
        Some(c) => c.client_cfg(&bridge_user(&side.agents))?,
        None => Vec::new(),
    };
    cfg.extend(zenoh_cfg.iter().cloned());
    let opts = crate::ros2::BridgeOptions {
        run: run_id.to_string(),
        connect: locators.to_vec(),
        cfg,
        domain: side.ros.domain,
        dds: side.ros.dds,
        localhost_only: side.localhost_only,
        truth: side.truth,
        vehicles: side.agents.clone(),
    };
    let bridge = crate::ros2::Bridge::start(&opts).await?;
    tokio::spawn(async move {
        if let Err(e) = bridge.run().await {
            warn!("the ROS 2 bridge failed: {e:#}");
        }
    });
    Ok(())
}

/// The user a program that is the external controller of every external UAV logs in as.
pub const CONTROLLER: &str = "controller";

/// Starts the gym gateway of the run in this process, logged in as `controller`.
async fn start_gym(
    launcher: &Launcher,
    sc: &Scenario,
    run_id: &str,
    locators: &[String],
    zenoh_cfg: &[String],
) -> Result<()> {
    anyhow::ensure!(
        !sc.controller.external.is_empty(),
        "--gym needs external UAVs (--external 1-5) to hand to the learning loop"
    );
    let mut cfg = match &launcher.creds {
        Some(c) => c.client_cfg(CONTROLLER)?,
        None => Vec::new(),
    };
    cfg.extend(zenoh_cfg.iter().cloned());
    let gym = crate::gym::Gym::start(run_id, locators, &cfg, sc).await?;
    tokio::spawn(async move {
        if let Err(e) = gym.run().await {
            warn!("the gym gateway failed: {e:#}");
        }
    });
    Ok(())
}

/// The user the launcher's own recording logs in as.
const OBSERVER: &str = "observer";

/// Fresh credentials for one run in `<out>/credentials/`: a user per UAV (restarts reuse it),
/// one per agent host of `hosts` (as [`spread`] grouped them), one per external controller
/// (`ext{id}`) and `controller` for all of them at once, with `--ros2` the bridge's (`bridge`, or `bridge-uavs{ids}` when it drives the
/// bodies of agents on ROS topics) and a `ros` for ROS machines, the recorder's
/// `observer`, and an `operator` for `swarm netem` on the running swarm.
fn run_credentials(sc: &Scenario, out: &Path, hosts: &[Vec<UavId>], ros2: Option<&Ros2Side>) -> Result<Credentials> {
    let mut users: Vec<String> = sc.agent_ids().map(uav_user).collect();
    users.extend(hosts.iter().map(|g| host_user(g)));
    users.extend(sc.controller.external.iter().map(|&id| ext_user(id)));
    if !sc.controller.external.is_empty() {
        // One login for a program that controls every external UAV (a learning environment).
        users.push(CONTROLLER.to_string());
    }
    if let Some(side) = ros2 {
        users.extend([bridge_user(&side.agents), "ros".to_string()]);
    }
    users.extend([OBSERVER.to_string(), "operator".to_string()]);
    Credentials::create(&out.join("credentials"), &users)
}

/// Whether `[[failures]]` kills, restarts or cuts off UAV `id` (it then runs alone).
fn has_own_failures(sc: &Scenario, id: UavId) -> bool {
    sc.failures.iter().any(|f| f.kind != FailureKind::Freeze && f.uav == id)
}

/// The `--cfg` overrides every child gets: the run's, after a short lease when the scenario has
/// link faults.
fn children_cfg(sc: &Scenario, zenoh_cfg: &[String]) -> Vec<String> {
    let mut cfg = zenoh_cfg.to_vec();
    if sc.failures.iter().any(|f| f.kind.is_link()) {
        // A stalled link is noticed when the lease expires; the default 10 s would outlast most
        // faults. Each side is expired by the lease it announces, so every piece gets it.
        cfg.insert(0, format!("transport/link/tx/lease:{LINK_FAULT_LEASE_MS}"));
    }
    cfg
}

/// One TCP proxy per UAV with link faults, in front of the hub's first TCP locator.
async fn start_proxies(sc: &Scenario, locators: &[String]) -> Result<BTreeMap<UavId, LinkProxy>> {
    let mut proxies = BTreeMap::new();
    for f in sc.failures.iter().filter(|f| f.kind.is_link()) {
        if proxies.contains_key(&f.uav) {
            continue;
        }
        let upstream = locators
            .iter()
            .find_map(|l| l.strip_prefix("tcp/").and_then(|a| a.parse::<std::net::SocketAddr>().ok()))
            .with_context(|| format!("link faults need a TCP locator of the hub, got {locators:?}"))?;
        let p = LinkProxy::start(upstream).await.context("cannot start the link proxy")?;
        info!(uav_id = %f.uav, proxy = %p.addr(), "link proxy up");
        proxies.insert(f.uav, p);
    }
    Ok(proxies)
}

/// How long UAV `id`'s agent waits for a lost hub [wall s]: its longest link outage in the
/// scenario (sim time divided by the realtime factor), plus 10 s for the lease and the
/// reconnection backoff.
fn link_grace_s(sc: &Scenario, id: UavId) -> f64 {
    let mut events: Vec<(f64, FailureKind)> =
        sc.failures.iter().filter(|f| f.uav == id && f.kind.is_link()).map(|f| (f.at_s, f.kind)).collect();
    events.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut longest: f64 = 0.0;
    let mut down_since = None;
    for (t, k) in events {
        match (k, down_since) {
            (FailureKind::LinkRestore, Some(s)) => {
                longest = longest.max(t - s);
                down_since = None;
            }
            (FailureKind::LinkRestore, None) => {}
            (_, None) => down_since = Some(t),
            (_, Some(_)) => {}
        }
    }
    if let Some(s) = down_since {
        longest = longest.max(sc.end.time_limit_s - s);
    }
    longest / sc.time.realtime_factor + 10.0
}

/// A child process and the write end of its stdin. The handle is kept apart from the [`Child`]
/// because `Child::wait` closes stdin, which the child takes as the order to exit.
struct Piece {
    child: Child,
    _stdin: Option<ChildStdin>,
}

/// How the launcher starts its children: this executable, under the run id, with the run's
/// `--cfg` overrides, each logging to its own file in `logs`.
struct Launcher {
    exe: PathBuf,
    logs: PathBuf,
    run_id: String,
    cfg: Vec<String>,
    /// `None`: the hub runs `--insecure`.
    creds: Option<Credentials>,
    /// The run's ROS 2 side, whose agents get `--sensors ros2`.
    ros2: Option<Ros2Side>,
    /// Every agent process's `--workers` ([`workers_per_agent_process`]).
    agent_workers: u16,
}

impl Launcher {
    /// Starts `swarm hub` on a free loopback port, its stdout piped for the locator line.
    fn hub(&self, scenario_path: &Path) -> Result<Piece> {
        self.spawn("hub.log", true, |c| {
            c.arg("hub").arg(scenario_path).args([
                "--run",
                &self.run_id,
                "--listen",
                "tcp/127.0.0.1:0",
                "--exit-with-stdin",
            ]);
            match &self.creds {
                Some(creds) => c.arg("--users").arg(creds.dictionary()),
                None => c.arg("--insecure"),
            };
        })
    }

    /// Starts `swarm agent` for UAV `id`, connected through its link proxy (with a hub grace
    /// long enough for the scenario's outages) or straight to the hub's `locators`.
    fn agent(&self, id: UavId, log: &str, proxy: Option<(&LinkProxy, f64)>, locators: &[String]) -> Result<Piece> {
        self.agents(AgentProcess::Uav(id), log, proxy, locators)
    }

    /// Starts `swarm agent --ids ids` (an agent host) straight on the hub's `locators`.
    fn host(&self, ids: &[UavId], locators: &[String]) -> Result<Piece> {
        let log = format!("agents-{}-{}.log", ids[0], ids[ids.len() - 1]);
        self.agents(AgentProcess::Host(ids), &log, None, locators)
    }

    fn agents(
        &self,
        who: AgentProcess<'_>,
        log: &str,
        proxy: Option<(&LinkProxy, f64)>,
        locators: &[String],
    ) -> Result<Piece> {
        self.spawn(log, false, |c| {
            c.arg("agent").args(["--run", &self.run_id]).args(who.args()).arg("--exit-with-stdin");
            c.args(["--workers", &self.agent_workers.to_string()]);
            if let (AgentProcess::Uav(id), Some(side)) = (who, &self.ros2) {
                if side.agents.contains(&id) {
                    c.args(["--sensors", "ros2", "--ros-domain", &side.ros.domain.to_string()]);
                    c.args(side.ros.dds.then_some("--dds")).args(side.localhost_only.then_some("--localhost"));
                    c.args(side.reliable_sensors.then_some("--reliable-sensors"));
                }
            }
            if let Some(creds) = &self.creds {
                c.args(creds.client_args(&who.user()));
            }
            match proxy {
                Some((p, grace_s)) => {
                    c.args(["--connect", &p.locator(), "--hub-grace-s", &grace_s.to_string()]);
                }
                None => {
                    for l in locators {
                        c.args(["--connect", l]);
                    }
                }
            }
        })
    }

    fn spawn(&self, log: &str, pipe_stdout: bool, args: impl FnOnce(&mut Command)) -> Result<Piece> {
        let log = self.logs.join(log);
        let log_file = std::fs::File::create(&log).with_context(|| format!("cannot create {}", log.display()))?;
        let mut c = Command::new(&self.exe);
        args(&mut c);
        for kv in &self.cfg {
            c.args(["--cfg", kv]);
        }
        let stdout = if pipe_stdout { Stdio::piped() } else { Stdio::null() };
        c.stdin(Stdio::piped()).stdout(stdout).stderr(Stdio::from(log_file)).kill_on_drop(true);
        let mut child = c.spawn().with_context(|| format!("cannot start {}", self.exe.display()))?;
        let stdin = child.stdin.take();
        Ok(Piece { child, _stdin: stdin })
    }
}

/// One agent process to start: a UAV's own, or an agent host's.
#[derive(Debug, Clone, Copy)]
enum AgentProcess<'a> {
    Uav(UavId),
    /// The UAVs it serves, ascending.
    Host(&'a [UavId]),
}

impl AgentProcess<'_> {
    /// `--id ID` or `--ids IDS`.
    fn args(self) -> [String; 2] {
        match self {
            AgentProcess::Uav(id) => ["--id".into(), id.to_string()],
            AgentProcess::Host(ids) => ["--ids".into(), ids_text(ids)],
        }
    }

    /// The user it logs in as.
    fn user(self) -> String {
        match self {
            AgentProcess::Uav(id) => uav_user(id),
            AgentProcess::Host(ids) => host_user(ids),
        }
    }
}

/// The agent processes of a run, their link proxies, and the kills, restarts and link faults of
/// `[[failures]]` still to come, in time order. A UAV that `[[failures]]` kills, restarts or
/// cuts off has a process of its own (in `running`), so those act on it alone; the others may
/// share agent hosts (`hosts`), which run to the end.
struct Agents<'a> {
    launcher: &'a Launcher,
    sc: &'a Scenario,
    locators: Vec<String>,
    proxies: BTreeMap<UavId, LinkProxy>,
    running: BTreeMap<UavId, Piece>,
    hosts: Vec<Piece>,
    schedule: Vec<(f64, UavId, FailureKind)>,
    restarts: u32,
}

impl<'a> Agents<'a> {
    /// Starts the agents of every UAV of the scenario, as `spread` grouped them.
    fn start(
        launcher: &'a Launcher,
        sc: &'a Scenario,
        locators: Vec<String>,
        proxies: BTreeMap<UavId, LinkProxy>,
        spread: Spread,
    ) -> Result<Agents<'a>> {
        let mut schedule: Vec<(f64, UavId, FailureKind)> =
            sc.failures.iter().filter(|f| f.kind != FailureKind::Freeze).map(|f| (f.at_s, f.uav, f.kind)).collect();
        schedule.sort_by(|x, y| x.0.total_cmp(&y.0));
        let mut agents = Agents {
            launcher,
            sc,
            locators,
            proxies,
            running: BTreeMap::new(),
            hosts: Vec::new(),
            schedule,
            restarts: 0,
        };
        for group in &spread.hosts {
            agents.hosts.push(launcher.host(group, &agents.locators)?);
        }
        for id in spread.solo {
            agents.start_solo(id)?;
        }
        Ok(agents)
    }

    /// Starts UAV `id`'s agent in a process of its own.
    fn start_solo(&mut self, id: UavId) -> Result<()> {
        let piece = self.spawn(id, &format!("agent-{id}.log"))?;
        self.running.insert(id, piece);
        Ok(())
    }

    fn spawn(&self, id: UavId, log: &str) -> Result<Piece> {
        let proxy = self.proxies.get(&id).map(|p| (p, link_grace_s(self.sc, id)));
        self.launcher.agent(id, log, proxy, &self.locators)
    }

    /// Applies every scheduled failure due at sim time `t`.
    fn on_tick(&mut self, t: f64) -> Result<()> {
        while let Some(&(at, id, kind)) = self.schedule.first() {
            if at > t + 1e-9 {
                break;
            }
            self.schedule.remove(0);
            if kind.is_link() {
                self.link_fault(id, kind, t);
                continue;
            }
            if let Some(mut old) = self.running.remove(&id) {
                info!(uav_id = %id, t, "killing agent");
                let _ = old.child.start_kill();
            }
            if kind == FailureKind::Restart {
                self.restarts += 1;
                info!(uav_id = %id, t, "restarting agent");
                let piece = self.spawn(id, &format!("agent-{id}-restart-{}.log", self.restarts))?;
                self.running.insert(id, piece);
            }
        }
        Ok(())
    }

    /// Sets UAV `id`'s link proxy to the state a link fault asks for.
    fn link_fault(&self, id: UavId, kind: FailureKind, t: f64) {
        if let Some(p) = self.proxies.get(&id) {
            info!(uav_id = %id, t, ?kind, "link fault");
            p.set(match kind {
                FailureKind::LinkStall => LinkState::Stalled,
                FailureKind::LinkClose => LinkState::Closed,
                _ => LinkState::Up,
            });
        }
    }

    /// Waits for the hub and then the agents to exit (killing stragglers), with the link proxies
    /// still up; returns whether the hub exited cleanly.
    async fn stop(self, mut hub: Piece) -> bool {
        let grace = Duration::from_secs(5);
        let hub_ok = match tokio::time::timeout(grace, hub.child.wait()).await {
            Ok(Ok(status)) => status.success(),
            _ => {
                warn!("hub did not exit; killing it");
                let _ = hub.child.kill().await;
                false
            }
        };
        for mut a in self.running.into_values().chain(self.hosts) {
            // Closing its stdin tells an agent to stop (else it would wait out its hub grace).
            drop(a._stdin.take());
            if tokio::time::timeout(grace, a.child.wait()).await.is_err() {
                warn!("an agent did not exit; killing it");
                let _ = a.child.kill().await;
            }
        }
        hub_ok
    }
}

/// How a run's UAVs are spread over agent processes.
#[derive(Debug, Clone, PartialEq)]
struct Spread {
    /// The UAVs with a process of their own, ascending.
    solo: Vec<UavId>,
    /// The agent hosts, each its UAVs ascending.
    hosts: Vec<Vec<UavId>>,
}

/// Spreads UAVs `ids` over processes, `per_process` to a host in id order: the UAVs that get a
/// process of their own (those `alone` picks, and a last group of one) and the hosts. Computed
/// once per run: the credentials and the launch must agree on it.
fn spread(ids: impl Iterator<Item = UavId>, per_process: u32, alone: impl Fn(UavId) -> bool) -> Spread {
    let (mut solo, shared): (Vec<UavId>, Vec<UavId>) = ids.partition(|&id| per_process <= 1 || alone(id));
    let mut hosts = Vec::new();
    for group in shared.chunks(per_process.max(1) as usize) {
        match group {
            [id] => solo.push(*id),
            _ => hosts.push(group.to_vec()),
        }
    }
    solo.sort_unstable();
    Spread { solo, hosts }
}

async fn read_locators(hub: &mut Child, logs: &Path) -> Result<Vec<String>> {
    let stdout = hub.stdout.take().context("hub stdout not piped")?;
    let mut lines = BufReader::new(stdout).lines();
    let line = tokio::time::timeout(HUB_START_TIMEOUT, async {
        while let Ok(Some(line)) = lines.next_line().await {
            if let Some(rest) = line.strip_prefix(LISTENING_PREFIX) {
                return Some(rest.split_whitespace().map(String::from).collect::<Vec<_>>());
            }
        }
        None
    })
    .await;
    // Keep draining the hub's stdout so it never blocks on a full pipe.
    tokio::spawn(async move { while let Ok(Some(_)) = lines.next_line().await {} });
    match line {
        Ok(Some(l)) if !l.is_empty() => Ok(l),
        _ => bail!("the hub did not start; see {}", logs.join("hub.log").display()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn set_puts_a_toml_value_at_a_dotted_path() {
        let mut v = toml::Value::try_from(toml::toml! { [time] mode = "lockstep" }).expect("toml");
        set_field(&mut v, "time.tick_timeout_ms=60000").expect("number");
        set_field(&mut v, "localization.mode=icp").expect("a bare word is a string");
        set_field(&mut v, "end.goal_rule=\"any\"").expect("quoted");
        assert_eq!(v["time"]["tick_timeout_ms"].as_integer(), Some(60000));
        assert_eq!(v["localization"]["mode"].as_str(), Some("icp"));
        assert_eq!(v["end"]["goal_rule"].as_str(), Some("any"));
        assert!(set_field(&mut v, "time").is_err(), "no value");
        assert!(set_field(&mut v, "time.mode.x=1").is_err(), "a string is not a table");
    }

    #[test]
    fn small_swarms_get_a_process_per_uav_and_large_ones_hosts() {
        assert_eq!(per_process(5, 2, None), 1);
        assert_eq!(per_process(10, 2, None), 1);
        assert_eq!(per_process(40, 2, None), 20);
        assert_eq!(per_process(40, 8, None), 5);
        assert_eq!(per_process(41, 2, None), 21, "the last host takes the remainder");
        assert_eq!(per_process(11, 16, None), 1);
        assert_eq!(per_process(5, 2, Some(5)), 5);
    }

    #[test]
    fn agent_processes_share_the_cores_with_one_worker_at_least() {
        assert_eq!(workers_per_agent_process(2, 2), 1, "one host per core");
        assert_eq!(workers_per_agent_process(5, 2), 1, "more processes than cores");
        assert_eq!(workers_per_agent_process(1, 2), 2, "one host of the whole swarm");
        assert_eq!(workers_per_agent_process(2, 8), 4);
        assert_eq!(workers_per_agent_process(3, 8), 2, "rounded down");
        assert_eq!(workers_per_agent_process(0, 4), 4, "no process asks for none");
    }

    /// The ids `v`, typed.
    fn ids(v: &[u32]) -> Vec<UavId> {
        v.iter().copied().map(UavId::new).collect()
    }

    #[test]
    fn uavs_with_failures_keep_a_process_of_their_own() {
        let Spread { solo, hosts } = spread(UavId::all(7), 3, |id| id == UavId::new(2));
        assert_eq!(hosts, vec![ids(&[1, 3, 4]), ids(&[5, 6, 7])]);
        assert_eq!(solo, ids(&[2]));
        let Spread { solo, hosts } = spread(UavId::all(5), 2, |_| false);
        assert_eq!(hosts, vec![ids(&[1, 2]), ids(&[3, 4])]);
        assert_eq!(solo, ids(&[5]), "a group of one is a plain agent");
        let Spread { solo, hosts } = spread(UavId::all(3), 1, |_| false);
        assert!(hosts.is_empty());
        assert_eq!(solo, ids(&[1, 2, 3]));
    }

    #[test]
    fn an_agent_process_logs_in_as_the_user_of_what_it_serves() {
        let host = AgentProcess::Host(&ids(&[1, 2, 3, 7]));
        assert_eq!(host.args(), ["--ids".to_string(), "1-3,7".to_string()]);
        assert_eq!(host.user(), "uavs1-3,7");
        assert_eq!(
            swarm_node::auth::Role::of(&host.user()).expect("a role"),
            swarm_node::auth::Role::Agents(ids(&[1, 2, 3, 7]))
        );
        let uav = AgentProcess::Uav(UavId::new(4));
        assert_eq!(uav.args(), ["--id".to_string(), "4".to_string()]);
        assert_eq!(uav.user(), "uav4");
    }
}

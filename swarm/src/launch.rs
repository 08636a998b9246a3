//! `swarm run`: the launcher. It starts the hub (`swarm hub`, a Zenoh router on a free loopback
//! port), reads the locator the hub prints, opens the recorder's session, then starts one
//! `swarm agent` process per UAV. Children are this same executable; each gets a piped stdin and
//! `--exit-with-stdin`, so they die with the launcher even if it is killed outright, and
//! `kill_on_drop` covers the ordinary paths. Child logs go to `<run folder>/logs/`.

use crate::cli::{RecordArgs, RunArgs, LISTENING_PREFIX};
use crate::proxy::{LinkProxy, LinkState};
use crate::recorder::{decode, Files, Metrics};
use crate::summary::Summary;
use anyhow::{bail, Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::process::{ExitCode, Stdio};
use std::time::Duration;
use std::collections::BTreeMap;
use swarm_config::{FailureKind, Scenario};
use swarm_wire::session::{self, Role};
use swarm_wire::{Keys, Msg};
use tokio::io::{AsyncBufReadExt, BufReader};
use tokio::process::{Child, ChildStdin, Command};
use tokio::sync::{mpsc, watch};
use tracing::{info, warn};

/// How long the launcher waits for the hub to print its locator.
const HUB_START_TIMEOUT: Duration = Duration::from_secs(30);

/// Seconds since the Unix epoch (run ids and study folders).
pub(crate) fn unix_secs() -> u64 {
    std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs())
}

/// `<name>-<unix seconds>-<pid>`: unique per run on a machine.
pub(crate) fn default_run_id(name: &str) -> String {
    format!("{name}-{}-{}", unix_secs(), std::process::id())
}

/// A command-line value for a scenario enum, spelled as in the scenario file (`"realtime"`,
/// `"a21"`, …); the error lists the accepted spellings.
pub fn scenario_value<T: serde::de::DeserializeOwned>(flag: &str, value: &str) -> Result<T> {
    use serde::de::IntoDeserializer;
    T::deserialize(value.trim().into_deserializer()).map_err(|e: serde::de::value::Error| anyhow::anyhow!("{flag}: {e}"))
}

/// Runs a scenario end to end and writes the run folder.
pub async fn run(a: RunArgs) -> Result<ExitCode> {
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
    if a.time_mode.is_some() || a.seed.is_some() || a.experiment.is_some() {
        // The hub serves this text to the agents, so overrides must be in it; and the whole must
        // still be valid (link faults need realtime mode, say).
        text = toml::to_string(&sc).context("cannot re-serialize the scenario")?;
        sc = Scenario::from_toml_str(&text, &format!("{name} (with the command line's overrides)"))?;
    }
    let run_id = a.run.clone().unwrap_or_else(|| default_run_id(&sc.name));
    let out = a.out.clone().unwrap_or_else(|| PathBuf::from("runs").join(&run_id));
    let (summary, hub_ok) = execute(&sc, &text, &run_id, &out, &a.cfg, a.quiet).await?;
    println!("{}", summary.human());
    println!("run folder: {}", out.display());
    Ok(exit_code(&summary, hub_ok))
}

/// Runs a resolved scenario (`text` is what the hub serves the agents) under run id `run_id`,
/// writes the run folder `out`, and returns the summary and whether the hub exited cleanly.
pub async fn execute(sc: &Scenario, text: &str, run_id: &str, out: &Path, zenoh_cfg: &[String], quiet: bool) -> Result<(Summary, bool)> {
    let (sc, run_id) = (sc.clone(), run_id.to_string());
    Keys::new(&run_id)?;
    let logs = out.join("logs");
    std::fs::create_dir_all(&logs).with_context(|| format!("cannot create {}", logs.display()))?;
    let scenario_path = out.join("scenario.toml");
    std::fs::write(&scenario_path, text).with_context(|| format!("cannot write {}", scenario_path.display()))?;
    eprintln!("run {run_id}: scenario {} ({} UAVs), folder {}", sc.name, sc.count(), out.display());

    let exe = std::env::current_exe().context("cannot find my own executable")?;
    let link_faults = sc.failures.iter().any(|f| f.kind.is_link());
    let mut cfg = zenoh_cfg.to_vec();
    if link_faults {
        // A stalled link is noticed when the lease expires; the default 10 s would outlast most
        // faults. Each side is expired by the lease it announces, so every piece gets it.
        cfg.insert(0, format!("transport/link/tx/lease:{LINK_FAULT_LEASE_MS}"));
    }
    let mut hub = spawn(&exe, &logs.join("hub.log"), true, |c| {
        c.arg("hub").arg(&scenario_path).args(["--run", &run_id, "--listen", "tcp/127.0.0.1:0", "--exit-with-stdin"]);
        for kv in &cfg {
            c.args(["--cfg", kv]);
        }
    })?;
    let locators = read_locators(&mut hub.child, &logs).await?;
    info!(?locators, "hub up");
    let proxies = start_proxies(&sc, &locators).await?;

    let rec = Recording::start(&run_id, &locators, zenoh_cfg).await?;
    let start_agent = |id: u32, log: &str| {
        spawn(&exe, &logs.join(log), false, |c| {
            c.arg("agent").args(["--run", &run_id, "--id", &id.to_string(), "--exit-with-stdin"]);
            match proxies.get(&id) {
                Some(p) => {
                    c.args(["--connect", &p.locator(), "--hub-grace-s", &link_grace_s(&sc, id).to_string()]);
                }
                None => {
                    for l in &locators {
                        c.args(["--connect", l]);
                    }
                }
            }
            for kv in &cfg {
                c.args(["--cfg", kv]);
            }
        })
    };
    let mut agents: BTreeMap<u32, Piece> = BTreeMap::new();
    for id in sc.agent_ids() {
        agents.insert(id, start_agent(id, &format!("agent-{id}.log"))?);
    }
    // Kills, restarts and link faults of `[[failures]]`, in time order, applied as sim time passes.
    let mut schedule: Vec<(f64, u32, FailureKind)> = sc
        .failures
        .iter()
        .filter(|f| f.kind != FailureKind::Freeze)
        .map(|f| (f.at_s, f.uav, f.kind))
        .collect();
    schedule.sort_by(|x, y| x.0.total_cmp(&y.0));
    let mut restarts = 0u32;
    let mut on_tick = |t: f64| -> Result<()> {
        while let Some(&(at, id, kind)) = schedule.first() {
            if at > t + 1e-9 {
                break;
            }
            schedule.remove(0);
            if kind.is_link() {
                if let Some(p) = proxies.get(&id) {
                    info!(uav_id = id, t, ?kind, "link fault");
                    p.set(match kind {
                        FailureKind::LinkStall => LinkState::Stalled,
                        FailureKind::LinkClose => LinkState::Closed,
                        _ => LinkState::Up,
                    });
                }
                continue;
            }
            if let Some(mut old) = agents.remove(&id) {
                info!(uav_id = id, t, "killing agent");
                let _ = old.child.start_kill();
            }
            if kind == FailureKind::Restart {
                restarts += 1;
                info!(uav_id = id, t, "restarting agent");
                agents.insert(id, start_agent(id, &format!("agent-{id}-restart-{restarts}.log"))?);
            }
        }
        Ok(())
    };
    let progress = progress_bar(&sc, quiet);
    let summary = rec.record(out, &sc, &progress, Some(&mut hub.child), &mut on_tick).await?;
    progress.finish_and_clear();
    let hub_ok = stop_children(hub, agents.into_values().collect()).await;
    Ok((summary, hub_ok))
}

/// The lease every piece announces when the scenario has link faults [ms].
const LINK_FAULT_LEASE_MS: u64 = 1000;

/// One TCP proxy per UAV with link faults, in front of the hub's first TCP locator.
async fn start_proxies(sc: &Scenario, locators: &[String]) -> Result<BTreeMap<u32, LinkProxy>> {
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
        info!(uav_id = f.uav, proxy = %p.addr(), "link proxy up");
        proxies.insert(f.uav, p);
    }
    Ok(proxies)
}

/// How long UAV `id`'s agent waits for a lost hub [wall s]: its longest link outage in the
/// scenario (sim time divided by the realtime factor), plus 10 s for the lease and the
/// reconnection backoff.
fn link_grace_s(sc: &Scenario, id: u32) -> f64 {
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

/// `swarm record`: the recorder alone, for a run whose pieces were started by hand.
pub async fn record_only(a: RecordArgs) -> Result<ExitCode> {
    anyhow::ensure!(!a.zenoh.connect.is_empty(), "the recorder needs --connect <hub endpoint>");
    std::fs::create_dir_all(&a.out).with_context(|| format!("cannot create {}", a.out.display()))?;
    let rec = Recording::start(&a.run, &a.zenoh.connect, &a.zenoh.cfg).await?;
    let sc = rec.fetch_scenario().await?;
    let progress = progress_bar(&sc, false);
    let summary = rec.record(&a.out, &sc, &progress, None, &mut |_| Ok(())).await?;
    progress.finish_and_clear();
    println!("{}", summary.human());
    Ok(exit_code(&summary, true))
}

/// A child process and the write end of its stdin. The handle is kept apart from the [`Child`]
/// because `Child::wait` closes stdin, which the child takes as the order to exit.
struct Piece {
    child: Child,
    _stdin: Option<ChildStdin>,
}

/// The exit status of `swarm run` / `swarm record`: 0 for a run that ended by its own rule (goal
/// or time limit), 130 for one stopped by Ctrl-C, 1 otherwise (hub failed, vanished, no agents).
fn exit_code(summary: &Summary, hub_ok: bool) -> ExitCode {
    match summary.end_reason.as_str() {
        "goal" | "time_limit" if hub_ok => ExitCode::SUCCESS,
        "stopped" => ExitCode::from(130),
        _ => ExitCode::FAILURE,
    }
}

fn spawn(exe: &Path, log: &Path, pipe_stdout: bool, args: impl FnOnce(&mut Command)) -> Result<Piece> {
    let log_file = std::fs::File::create(log).with_context(|| format!("cannot create {}", log.display()))?;
    let mut c = Command::new(exe);
    args(&mut c);
    let stdout = if pipe_stdout { Stdio::piped() } else { Stdio::null() };
    c.stdin(Stdio::piped()).stdout(stdout).stderr(Stdio::from(log_file)).kill_on_drop(true);
    let mut child = c.spawn().with_context(|| format!("cannot start {}", exe.display()))?;
    let stdin = child.stdin.take();
    Ok(Piece { child, _stdin: stdin })
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

/// Waits for the children to exit (killing stragglers); returns whether the hub exited cleanly.
async fn stop_children(mut hub: Piece, agents: Vec<Piece>) -> bool {
    let grace = Duration::from_secs(5);
    let hub_ok = match tokio::time::timeout(grace, hub.child.wait()).await {
        Ok(Ok(status)) => status.success(),
        _ => {
            warn!("hub did not exit; killing it");
            let _ = hub.child.kill().await;
            false
        }
    };
    for mut a in agents {
        // Closing its stdin tells an agent to stop (else it would wait out its hub grace).
        drop(a._stdin.take());
        if tokio::time::timeout(grace, a.child.wait()).await.is_err() {
            warn!("an agent did not exit; killing it");
            let _ = a.child.kill().await;
        }
    }
    hub_ok
}

fn progress_bar(sc: &Scenario, quiet: bool) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let ticks = (sc.end.time_limit_s * sc.time.control_hz).ceil() as u64;
    let pb = ProgressBar::new(ticks);
    pb.set_style(
        ProgressStyle::with_template("{elapsed:>4} [{bar:32}] {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    pb
}

/// The recorder's session and subscriptions.
struct Recording {
    session: zenoh::Session,
    keys: Keys,
    run_id: String,
    truth: mpsc::UnboundedReceiver<Vec<u8>>,
    states: mpsc::UnboundedReceiver<Vec<u8>>,
    hub_alive: watch::Receiver<bool>,
    _subs: [zenoh::pubsub::Subscriber<()>; 3],
    _token: zenoh::liveliness::LivelinessToken,
}

/// How long a stopping run may take to deliver the hub's last step.
const STOP_GRACE: Duration = Duration::from_secs(5);

fn zerr(e: zenoh::Error) -> anyhow::Error {
    anyhow::anyhow!("zenoh: {e}")
}

/// What the recorder writes as it goes.
struct Sink<'a> {
    files: Files,
    m: Metrics,
    malformed: u64,
    sc: &'a Scenario,
    pb: &'a ProgressBar,
}

impl Sink<'_> {
    /// Takes one truth payload; returns true on the run's last step.
    fn truth(&mut self, b: &[u8]) -> Result<bool> {
        match decode(b, &mut self.malformed) {
            Some(Msg::TruthStep(s)) => {
                self.files.write_step(&s)?;
                self.m.on_step(&s);
                let g = self.sc.swarm.goal;
                let d = s.bodies.iter().map(|b| (b.x - g[0]).hypot(b.y - g[1])).fold(0.0, f64::max);
                self.pb.set_position(s.tick);
                self.pb.set_message(format!(
                    "t={:.1}s  farthest UAV {d:.1} m from goal  collisions {}",
                    s.t_secs,
                    self.m.collision_count()
                ));
                Ok(self.m.ended().is_some())
            }
            Some(Msg::TruthWorld(w)) => {
                self.m.on_world(w);
                Ok(false)
            }
            _ => Ok(false),
        }
    }

    /// Takes one agent state payload (states of ids outside the scenario are dropped).
    fn state(&mut self, b: &[u8]) -> Result<()> {
        if let Some(Msg::State(st)) = decode(b, &mut self.malformed) {
            if (1..=self.sc.swarm.count).contains(&st.id) {
                self.files.write_state(&st)?;
                self.m.on_state(*st);
            }
        }
        Ok(())
    }
}

impl Recording {
    async fn start(run_id: &str, connect: &[String], cfg: &[String]) -> Result<Recording> {
        let keys = Keys::new(run_id)?;
        let session = session::open(Role::Client, &[], connect, cfg).await?;
        let (ttx, truth) = mpsc::unbounded_channel();
        let (stx, states) = mpsc::unbounded_channel();
        let t_sub = session
            .declare_subscriber(keys.truth_all())
            .callback(move |s| {
                let _ = ttx.send(s.payload().to_bytes().into_owned());
            })
            .await
            .map_err(zerr)?;
        let s_sub = session
            .declare_subscriber(keys.state_any())
            .callback(move |s| {
                let _ = stx.send(s.payload().to_bytes().into_owned());
            })
            .await
            .map_err(zerr)?;
        let (htx, hub_alive) = watch::channel(false);
        let h_sub = session
            .liveliness()
            .declare_subscriber(keys.alive_hub())
            .history(true)
            .callback(move |s| {
                let _ = htx.send(s.kind() == zenoh::sample::SampleKind::Put);
            })
            .await
            .map_err(zerr)?;
        // Subscribed: say so, for whoever starts agents by hand and wants the whole run recorded.
        let token = session.liveliness().declare_token(keys.alive_recorder()).await.map_err(zerr)?;
        Ok(Recording {
            session,
            keys,
            run_id: run_id.to_string(),
            truth,
            states,
            hub_alive,
            _subs: [t_sub, s_sub, h_sub],
            _token: token,
        })
    }

    /// Asks the hub for a reply on `key` (a queryable of the run).
    async fn ask(&self, key: String) -> Result<Vec<u8>> {
        let replies = self.session.get(&key).timeout(Duration::from_secs(5)).await.map_err(zerr)?;
        while let Ok(r) = replies.recv_async().await {
            if let Ok(s) = r.result() {
                return Ok(s.payload().to_bytes().into_owned());
            }
        }
        bail!("no hub answered {key}")
    }

    async fn fetch_scenario(&self) -> Result<Scenario> {
        let text = String::from_utf8_lossy(&self.ask(self.keys.scenario()).await?).into_owned();
        Ok(Scenario::from_toml_str(&text, "hub")?)
    }

    /// Records until the hub marks the last step, the hub goes away, or a Ctrl-C (after which it
    /// waits up to [`STOP_GRACE`] for the hub's `stopped` step).
    /// `on_tick` is called with the sim time of every truth step (the launcher applies kills
    /// and restarts there).
    async fn record(
        mut self,
        out: &Path,
        sc: &Scenario,
        pb: &ProgressBar,
        mut hub: Option<&mut Child>,
        on_tick: &mut dyn FnMut(f64) -> Result<()>,
    ) -> Result<Summary> {
        let mut sink = Sink { files: Files::create(out)?, m: Metrics::default(), malformed: 0, sc, pb };
        // The world is published once; ask for it too, in case that was before we subscribed.
        match self.ask(self.keys.truth_world()).await {
            Ok(b) => {
                sink.truth(&b)?;
            }
            Err(e) => warn!("no world from the hub yet: {e}"),
        }
        let mut hub_seen = *self.hub_alive.borrow();
        let mut stop_at: Option<tokio::time::Instant> = None;
        loop {
            let hub_exit = async {
                match hub.as_mut() {
                    Some(h) => h.wait().await.ok(),
                    None => std::future::pending().await,
                }
            };
            let stop = async {
                match stop_at {
                    Some(t) => tokio::time::sleep_until(t).await,
                    None => std::future::pending().await,
                }
            };
            // Biased: every queued truth step is taken before the hub's exit is noticed.
            tokio::select! {
                biased;
                Some(b) = self.truth.recv() => {
                    if sink.truth(&b)? { break }
                    if let Some(t) = sink.m.last_step().map(|s| s.t_secs) { on_tick(t)?; }
                },
                Some(b) = self.states.recv() => sink.state(&b)?,
                changed = self.hub_alive.changed() => {
                    let up = changed.is_ok() && *self.hub_alive.borrow();
                    if up { hub_seen = true; } else if hub_seen || changed.is_err() { warn!("hub gone before the end of the run"); break; }
                },
                status = hub_exit => { warn!(?status, "hub exited before the end of the run"); break; }
                _ = tokio::signal::ctrl_c(), if stop_at.is_none() => {
                    warn!("interrupted: waiting for the hub's last step");
                    stop_at = Some(tokio::time::Instant::now() + STOP_GRACE);
                }
                _ = stop => { warn!("the hub's last step did not come"); break; }
            }
        }
        while let Ok(b) = self.truth.try_recv() {
            sink.truth(&b)?;
        }
        // States of the last tick may still be in flight.
        let drain_until = tokio::time::Instant::now() + Duration::from_millis(200);
        while let Ok(Some(b)) = tokio::time::timeout_at(drain_until, self.states.recv()).await {
            sink.state(&b)?;
        }
        let Sink { mut files, m, malformed, .. } = sink;
        files.flush()?;
        let summary = m.summary(&self.run_id, sc);
        let path = out.join("summary.json");
        std::fs::write(&path, serde_json::to_string_pretty(&summary)?).with_context(|| format!("cannot write {}", path.display()))?;
        let title = format!(
            "{} ({}): {}, {} collisions",
            sc.name,
            self.run_id,
            summary.time_to_goal_s.map_or_else(|| format!("goal not reached ({})", summary.end_reason), |t| format!("goal in {t:.1} s")),
            summary.collisions
        );
        if let Some(svg) = m.svg(&title, sc.end.goal_radius_m) {
            let path = out.join("run.svg");
            std::fs::write(&path, svg).with_context(|| format!("cannot write {}", path.display()))?;
        }
        if malformed > 0 {
            warn!(malformed, "recorder dropped malformed messages");
        }
        let _ = self.session.close().await;
        Ok(summary)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scenario_values_are_spelled_as_in_the_file() {
        let m: swarm_config::TimeMode = scenario_value("--time-mode", "realtime").expect("ok");
        assert_eq!(m, swarm_config::TimeMode::Realtime);
        let k: swarm_config::ControllerKind = scenario_value("--controllers", " a21").expect("ok");
        assert_eq!(k, swarm_config::ControllerKind::A21);
        let e = scenario_value::<swarm_config::TimeMode>("--time-mode", "fast").expect_err("no such mode").to_string();
        assert!(e.starts_with("--time-mode") && e.contains("lockstep"), "{e}");
    }
}

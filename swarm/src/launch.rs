//! `swarm run`: the launcher. It starts the hub (`swarm hub`, a Zenoh router on a free loopback
//! port), reads the locator the hub prints, opens the recorder's session, then starts one
//! `swarm agent` process per UAV. Children are this same executable; each gets a piped stdin and
//! `--exit-with-stdin`, so they die with the launcher even if it is killed outright, and
//! `kill_on_drop` covers the ordinary paths. Child logs go to `<run folder>/logs/`.

use crate::cli::{RecordArgs, RunArgs, LISTENING_PREFIX};
use crate::recorder::{decode, Files, Metrics};
use crate::summary::Summary;
use anyhow::{bail, Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::process::{ExitCode, Stdio};
use std::time::Duration;
use swarm_config::{Scenario, TimeMode};
use swarm_wire::session::{self, Role};
use swarm_wire::{Keys, Msg};
use tokio::io::{AsyncBufReadExt, BufReader};
use tokio::process::{Child, ChildStdin, Command};
use tokio::sync::mpsc;
use tracing::{info, warn};

/// How long the launcher waits for the hub to print its locator.
const HUB_START_TIMEOUT: Duration = Duration::from_secs(30);

fn default_run_id(name: &str) -> String {
    let secs = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs());
    format!("{name}-{secs}-{}", std::process::id())
}

/// Runs a scenario end to end and writes the run folder.
pub async fn run(a: RunArgs) -> Result<ExitCode> {
    let name = a.scenario.as_deref().unwrap_or(swarm_config::DEFAULT_SCENARIO);
    let (mut sc, mut text) = Scenario::from_arg(name)?;
    if let Some(mode) = &a.time_mode {
        sc.time.mode = match mode.as_str() {
            "lockstep" => TimeMode::Lockstep,
            "realtime" => TimeMode::Realtime,
            other => bail!("--time-mode: expected `lockstep` or `realtime`, got `{other}`"),
        };
    }
    if let Some(seed) = a.seed {
        sc.seed = seed;
        if let Some(f) = sc.world.forest.as_mut() {
            f.seed = None;
        }
    }
    if a.time_mode.is_some() || a.seed.is_some() {
        // The hub serves this text to the agents, so overrides must be in it.
        text = toml::to_string(&sc).context("cannot re-serialize the scenario")?;
    }
    let run_id = a.run.unwrap_or_else(|| default_run_id(&sc.name));
    Keys::new(&run_id)?;
    let out = a.out.unwrap_or_else(|| PathBuf::from("runs").join(&run_id));
    let logs = out.join("logs");
    std::fs::create_dir_all(&logs).with_context(|| format!("cannot create {}", logs.display()))?;
    let scenario_path = out.join("scenario.toml");
    std::fs::write(&scenario_path, &text).with_context(|| format!("cannot write {}", scenario_path.display()))?;
    eprintln!("run {run_id}: scenario {} ({} UAVs), folder {}", sc.name, sc.count(), out.display());

    let exe = std::env::current_exe().context("cannot find my own executable")?;
    let mut hub = spawn(&exe, &logs.join("hub.log"), |c| {
        c.arg("hub").arg(&scenario_path).args(["--run", &run_id, "--listen", "tcp/127.0.0.1:0", "--exit-with-stdin"]);
    })?;
    let locators = read_locators(&mut hub.child, &logs).await?;
    info!(?locators, "hub up");

    let rec = Recording::start(&run_id, &locators).await?;
    let mut agents = Vec::new();
    for id in sc.uav_ids() {
        agents.push(spawn(&exe, &logs.join(format!("agent-{id}.log")), |c| {
            c.arg("agent").args(["--run", &run_id, "--id", &id.to_string(), "--exit-with-stdin"]);
            for l in &locators {
                c.args(["--connect", l]);
            }
        })?);
    }
    let progress = progress_bar(&sc, a.quiet);
    let summary = rec.record(&out, &sc, &progress, Some(&mut hub.child)).await?;
    progress.finish_and_clear();
    stop_children(hub, agents).await;
    println!("{}", summary.human());
    println!("run folder: {}", out.display());
    Ok(ExitCode::SUCCESS)
}

/// `swarm record`: the recorder alone, for a run whose pieces were started by hand.
pub async fn record_only(a: RecordArgs) -> Result<ExitCode> {
    anyhow::ensure!(!a.zenoh.connect.is_empty(), "the recorder needs --connect <hub endpoint>");
    std::fs::create_dir_all(&a.out).with_context(|| format!("cannot create {}", a.out.display()))?;
    let rec = Recording::start(&a.run, &a.zenoh.connect).await?;
    let sc = rec.fetch_scenario().await?;
    let progress = progress_bar(&sc, false);
    let summary = rec.record(&a.out, &sc, &progress, None).await?;
    progress.finish_and_clear();
    println!("{}", summary.human());
    Ok(ExitCode::SUCCESS)
}

/// A child process and the write end of its stdin. The handle is kept apart from the [`Child`]
/// because `Child::wait` closes stdin, which the child takes as the order to exit.
struct Piece {
    child: Child,
    _stdin: Option<ChildStdin>,
}

fn spawn(exe: &Path, log: &Path, args: impl FnOnce(&mut Command)) -> Result<Piece> {
    let log_file = std::fs::File::create(log).with_context(|| format!("cannot create {}", log.display()))?;
    let mut c = Command::new(exe);
    args(&mut c);
    c.stdin(Stdio::piped()).stdout(Stdio::piped()).stderr(Stdio::from(log_file)).kill_on_drop(true);
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

async fn stop_children(mut hub: Piece, agents: Vec<Piece>) {
    let grace = Duration::from_secs(5);
    if tokio::time::timeout(grace, hub.child.wait()).await.is_err() {
        warn!("hub did not exit; killing it");
        let _ = hub.child.kill().await;
    }
    for mut a in agents {
        // Agents exit on their own once the hub's token is gone.
        if tokio::time::timeout(grace, a.child.wait()).await.is_err() {
            warn!("an agent did not exit; killing it");
            let _ = a.child.kill().await;
        }
    }
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
    _subs: [zenoh::pubsub::Subscriber<()>; 2],
    _token: zenoh::liveliness::LivelinessToken,
}

impl Recording {
    async fn start(run_id: &str, connect: &[String]) -> Result<Recording> {
        let keys = Keys::new(run_id)?;
        let session = session::open(Role::Client, &[], connect, &[]).await?;
        let (ttx, truth) = mpsc::unbounded_channel();
        let (stx, states) = mpsc::unbounded_channel();
        let z = |e: zenoh::Error| anyhow::anyhow!("zenoh: {e}");
        let t_sub = session
            .declare_subscriber(keys.truth_all())
            .callback(move |s| {
                let _ = ttx.send(s.payload().to_bytes().into_owned());
            })
            .await
            .map_err(z)?;
        let s_sub = session
            .declare_subscriber(keys.state_any())
            .callback(move |s| {
                let _ = stx.send(s.payload().to_bytes().into_owned());
            })
            .await
            .map_err(z)?;
        // Subscribed: say so, for whoever starts agents by hand and wants the whole run recorded.
        let token = session.liveliness().declare_token(keys.alive_recorder()).await.map_err(z)?;
        Ok(Recording { session, keys, run_id: run_id.to_string(), truth, states, _subs: [t_sub, s_sub], _token: token })
    }

    async fn fetch_scenario(&self) -> Result<Scenario> {
        let replies = self
            .session
            .get(self.keys.scenario())
            .timeout(Duration::from_secs(5))
            .await
            .map_err(|e| anyhow::anyhow!("zenoh: {e}"))?;
        while let Ok(r) = replies.recv_async().await {
            if let Ok(s) = r.result() {
                let text = String::from_utf8_lossy(&s.payload().to_bytes()).into_owned();
                return Ok(Scenario::from_toml_str(&text, "hub")?);
            }
        }
        bail!("no hub answered {}", self.keys.scenario())
    }

    /// Records until the hub marks the last step (or the hub process exits, or Ctrl-C).
    async fn record(mut self, out: &Path, sc: &Scenario, pb: &ProgressBar, mut hub: Option<&mut Child>) -> Result<Summary> {
        let mut files = Files::create(out)?;
        let mut m = Metrics::default();
        let mut malformed = 0u64;
        let goal = sc.swarm.goal;
        loop {
            let hub_exit = async {
                match hub.as_mut() {
                    Some(h) => h.wait().await.ok(),
                    None => std::future::pending().await,
                }
            };
            tokio::select! {
                Some(b) = self.truth.recv() => match decode(&b, &mut malformed) {
                    Some(Msg::TruthStep(s)) => {
                        files.write_step(&s)?;
                        m.on_step(&s);
                        let d = s.bodies.iter().map(|b| (b.x - goal[0]).hypot(b.y - goal[1])).fold(0.0, f64::max);
                        pb.set_position(s.tick);
                        pb.set_message(format!("t={:.1}s  farthest UAV {d:.1} m from goal  collisions {}", s.t_secs, m.collision_count()));
                        if m.ended().is_some() { break; }
                    }
                    Some(Msg::TruthWorld(w)) => m.on_world(w),
                    _ => {}
                },
                Some(b) = self.states.recv() => if let Some(Msg::State(st)) = decode(&b, &mut malformed) {
                    files.write_state(&st)?;
                    m.on_state(st);
                },
                status = hub_exit => {
                    warn!(?status, "hub exited before the end of the run");
                    break;
                }
                _ = tokio::signal::ctrl_c() => { warn!("interrupted"); break; }
            }
        }
        // States of the last tick may still be in flight.
        let drain_until = tokio::time::Instant::now() + Duration::from_millis(200);
        while let Ok(Some(b)) = tokio::time::timeout_at(drain_until, self.states.recv()).await {
            if let Some(Msg::State(st)) = decode(&b, &mut malformed) {
                files.write_state(&st)?;
                m.on_state(st);
            }
        }
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

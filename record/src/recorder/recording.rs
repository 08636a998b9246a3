//! The recorder's Zenoh side: a client session subscribed to `truth/**`, every agent's `state`
//! and the hub's liveliness token, feeding [`Metrics`] and [`Files`] until the run ends, then
//! writing `summary.json` and the figures of [`swarm_plot`].

use super::files::{decode, write_connectivity, write_world, Files};
use super::journal::{self, Journal, Kind};
use super::metrics::Metrics;
use crate::checks::Checker;
use crate::scene::{Feed, Scene};
use crate::summary::Summary;
use anyhow::{Context, Result};
use indicatif::ProgressBar;
use std::path::Path;
use std::time::Duration;
use swarm_config::Scenario;
use swarm_wire::plumbing::{self, Speaker, Subscription};
use swarm_wire::session::{self, Role};
use swarm_wire::{AgentState, Keys, Msg};
use tokio::process::Child;
use tokio::sync::{mpsc, watch};
use tracing::warn;

/// How long a stopping run may take to deliver the hub's last step.
const STOP_GRACE: Duration = Duration::from_secs(5);
/// How long the recorder waits, once the run has ended, for the states of its last tick.
const LAST_STATES_WAIT: Duration = Duration::from_secs(10);
/// How long the recorder asks the hub for the scenario and the world.
const ASK_WAIT: Duration = Duration::from_secs(5);

/// The recorder's session and subscriptions.
pub struct Recording {
    session: zenoh::Session,
    keys: Keys,
    run_id: String,
    truth: mpsc::UnboundedReceiver<Vec<u8>>,
    states: mpsc::UnboundedReceiver<(Origin, Vec<u8>)>,
    hub_alive: watch::Receiver<bool>,
    _subs: [Subscription; 4],
    feed: Option<Feed>,
    scene: Option<Scene>,
    journal: bool,
    _token: zenoh::liveliness::LivelinessToken,
}

/// How often the recorder hands what it has to the file system [sim s]: the CSVs, `run.mcap`
/// (whose chunks therefore span at most this) and the journal. A killed run loses at most the
/// data of the last such span (see `swarm recover`).
pub const CHECKPOINT_S: f64 = 1.0;

/// Where an agent state payload comes from.
enum Origin {
    /// The recorder's own journal, or a flight in its own process: states already taken.
    Taken,
    /// A sample on the wire, and whom its key lets it speak for (`None`: a key that names no
    /// UAV of the run, such as a host's list not written the way hosts write it).
    Wire(Option<Speaker>),
}

/// What the recorder writes as it goes.
struct Sink<'a> {
    files: Files,
    m: Metrics,
    checks: Checker,
    malformed: u64,
    /// States dropped because their key does not name their UAV.
    unnamed: u64,
    sc: &'a Scenario,
    pb: &'a ProgressBar,
    scene: Option<Scene>,
    journal: Option<Journal>,
    next_checkpoint_t: f64,
}

impl<'a> Sink<'a> {
    /// A sink writing the run folder `out` (its CSVs are created afresh).
    fn new(
        out: &Path,
        sc: &'a Scenario,
        pb: &'a ProgressBar,
        scene: Option<Scene>,
        journal: Option<Journal>,
    ) -> Result<Sink<'a>> {
        let files = Files::create(out)?;
        Ok(Sink {
            files,
            m: Metrics::settling(sc),
            checks: Checker::new(sc),
            malformed: 0,
            unnamed: 0,
            sc,
            pb,
            scene,
            journal,
            next_checkpoint_t: 0.0,
        })
    }

    /// Journals one payload (stamped with the latest truth step's time).
    fn journal(&mut self, kind: Kind, b: &[u8]) -> Result<()> {
        if let Some(j) = self.journal.as_mut() {
            j.append(kind, b, self.m.last_step().map_or(0.0, |s| s.t_s))?;
        }
        Ok(())
    }

    /// Hands the CSVs, the scene's file and the journal to the file system, once every
    /// [`CHECKPOINT_S`] of sim time.
    fn checkpoint(&mut self, t_s: f64) -> Result<()> {
        if t_s < self.next_checkpoint_t {
            return Ok(());
        }
        // A hair early, so a sum of tick lengths that rounds below a whole second still counts.
        self.next_checkpoint_t = t_s + CHECKPOINT_S - 1e-6;
        self.files.flush()?;
        if let Some(scene) = &self.scene {
            scene.flush()?;
        }
        if let Some(j) = self.journal.as_mut() {
            j.flush()?;
        }
        Ok(())
    }

    /// Closes the files and writes the summary, `world.json`, `connectivity.csv` and the
    /// figures into `out`. `recovered`: folded again from a killed run's journal (see
    /// [`replay`]).
    fn finish(self, run_id: &str, out: &Path, recovered: bool) -> Result<Summary> {
        let Sink { mut files, m, checks, malformed, unnamed, scene, sc, .. } = self;
        files.flush()?;
        if let Some(mut scene) = scene {
            scene.finish()?;
        }
        let mut summary = m.summary(run_id, sc);
        if recovered && m.ended().is_none() {
            summary.end_reason = CUT_SHORT.into();
        }
        summary.checks = checks.finish(sc, &summary);
        write_outputs(out, &summary, &m)?;
        if malformed > 0 {
            warn!(malformed, "recorder dropped malformed messages");
        }
        if unnamed > 0 {
            warn!(unnamed, "recorder dropped states whose key does not name their UAV");
        }
        Ok(summary)
    }

    /// Takes one truth payload; returns true on the run's last step.
    fn truth(&mut self, b: &[u8]) -> Result<bool> {
        self.journal(Kind::Truth, b)?;
        match decode(b, &mut self.malformed) {
            Some(Msg::TruthStep(s)) => {
                if let Some(scene) = self.scene.as_mut() {
                    scene.on_step(&s);
                }
                self.files.write_step(&s)?;
                self.m.on_step(&s);
                self.files.write_scored(&self.m.take_scored())?;
                self.checks.on_step(&s);
                let g = self.sc.swarm.goal;
                let d = s.bodies.iter().map(|b| (b.x - g[0]).hypot(b.y - g[1])).fold(0.0, f64::max);
                self.pb.set_position(s.tick);
                self.pb.set_message(format!(
                    "t={:.1}s  farthest UAV {d:.1} m from goal  collisions {}",
                    s.t_s,
                    self.m.collision_count()
                ));
                self.checkpoint(s.t_s)?;
                Ok(self.m.ended().is_some())
            }
            Some(Msg::TruthWorld(w)) => {
                if let Some(scene) = self.scene.as_mut() {
                    scene.on_world(&w);
                }
                self.m.on_world(w);
                Ok(false)
            }
            _ => Ok(false),
        }
    }

    /// Takes one agent state payload: one UAV's, or an agent host's states of a tick. From the
    /// wire it keeps only the states of the UAVs their key names ([`Speaker::names`]), as the
    /// access rules hold each login to its own UAVs' keys: a state whose id is not its key's is
    /// counted and dropped, and the journal keeps only what was taken. States of ids outside
    /// the scenario are dropped too.
    fn state(&mut self, b: &[u8], origin: Origin) -> Result<()> {
        let speaker = match origin {
            Origin::Taken => None,
            Origin::Wire(None) => {
                self.unnamed += 1;
                return Ok(());
            }
            Origin::Wire(Some(s)) => Some(s),
        };
        let (states, alone) = match decode(b, &mut self.malformed) {
            Some(Msg::State(st)) => (vec![*st], true),
            Some(Msg::States(states)) => (states, false),
            // Journaled as it came, so that folding the journal again counts it again.
            _ => return self.journal(Kind::State, b),
        };
        let all = states.len();
        let named =
            |st: &AgentState| speaker.as_ref().is_none_or(|s| s.names((!alone).then_some(st.id)) == Some(st.id));
        let states: Vec<AgentState> = states.into_iter().filter(named).collect();
        self.unnamed += (all - states.len()) as u64;
        if states.len() == all {
            self.journal(Kind::State, b)?;
        } else if !states.is_empty() {
            self.journal(Kind::State, &Msg::States(states.clone()).encode()?)?;
        }
        states.into_iter().try_for_each(|st| self.fold_state(st))
    }

    /// Folds one agent's state into the files, the scene, the checks and the metrics.
    fn fold_state(&mut self, st: AgentState) -> Result<()> {
        if st.id.within(self.sc.count()) {
            self.files.write_state(&st)?;
            if let Some(scene) = self.scene.as_mut() {
                scene.on_state(&st);
            }
            self.checks.on_state(&st);
            self.m.on_state(st);
            self.files.write_scored(&self.m.take_scored())?;
        }
        Ok(())
    }
}

impl Recording {
    /// Opens the recorder's session to `connect`, subscribes (to what `run.mcap` needs too when
    /// `mcap`), then announces `alive/recorder`.
    pub async fn start(run_id: &str, connect: &[String], cfg: &[String], mcap: bool) -> Result<Recording> {
        let keys = Keys::new(run_id)?;
        let session = session::open(Role::Client, &[], connect, cfg).await?;
        let (ttx, truth) = mpsc::unbounded_channel();
        let (stx, states) = mpsc::unbounded_channel();
        let t_sub = plumbing::subscribe_payloads(&session, keys.truth_all(), ttx).await?;
        let s_sub = subscribe_states(&session, &keys, keys.state_any(), stx.clone()).await?;
        let hs_sub = subscribe_states(&session, &keys, keys.host_state_any(), stx).await?;
        let (hub_alive, h_sub) = plumbing::watch_token(&session, keys.alive_hub()).await?;
        let feed = if mcap { Some(Feed::subscribe(&session, &keys).await?) } else { None };
        // Subscribed: say so, for whoever starts agents by hand and wants the whole run recorded.
        let token =
            session.liveliness().declare_token(keys.alive_recorder()).await.map_err(swarm_wire::WireError::zenoh)?;
        Ok(Recording {
            session,
            keys,
            run_id: run_id.to_string(),
            truth,
            states,
            hub_alive,
            _subs: [t_sub, s_sub, hs_sub, h_sub],
            feed,
            scene: None,
            journal: true,
            _token: token,
        })
    }

    /// Starts `run.mcap` in `out` with `detail`, for a recording started with `mcap` (with no
    /// detail, or no feed, does nothing).
    pub fn write_mcap(&mut self, sc: &Scenario, out: &Path, detail: Option<crate::scene::Detail>) -> Result<()> {
        if let (Some(detail), Some(_)) = (detail, &self.feed) {
            let mut scene = Scene::new(sc)?;
            scene.set_detail(detail);
            scene.write_mcap(&out.join("run.mcap"))?;
            self.scene = Some(scene);
        }
        Ok(())
    }

    /// Keeps no journal: a killed run's summary then cannot be rebuilt (`--no-journal`).
    pub fn without_journal(&mut self) {
        self.journal = false;
    }

    /// The scenario the hub serves, and its text.
    pub async fn fetch_scenario(&self) -> Result<(Scenario, String)> {
        let text = plumbing::fetch_scenario_text(&self.session, &self.keys, ASK_WAIT).await?;
        Ok((Scenario::from_toml_str(&text, "hub")?, text))
    }

    /// Records until the hub marks the last step, the hub goes away, or a Ctrl-C (after which it
    /// waits up to [`STOP_GRACE`] for the hub's `stopped` step), then writes the run folder's
    /// summary and map. `on_tick` is called with the sim time of every truth step (the launcher
    /// applies kills and restarts there).
    pub async fn record(
        mut self,
        out: &Path,
        sc: &Scenario,
        pb: &ProgressBar,
        hub: Option<&mut Child>,
        on_tick: &mut dyn FnMut(f64) -> Result<()>,
    ) -> Result<Summary> {
        let (scene, mut feed) = (self.scene.take(), self.feed.take());
        let journal = if self.journal { Some(Journal::create(out, &self.run_id)?) } else { None };
        let mut sink = Sink::new(out, sc, pb, scene, journal)?;
        // The world is published once; ask for it too, in case that was before we subscribed.
        match plumbing::fetch(&self.session, &self.keys.truth_world(), ASK_WAIT).await {
            Ok(b) => {
                sink.truth(&b)?;
            }
            Err(e) => warn!("no world from the hub yet: {e}"),
        }
        self.follow(&mut sink, feed.as_mut(), hub, on_tick).await?;
        self.drain(&mut sink, feed.as_mut()).await?;
        let journal = sink.journal.take();
        let summary = sink.finish(&self.run_id, out, false)?;
        if let Some(j) = journal {
            j.discard(out)?;
        }
        let _ = self.session.close().await;
        Ok(summary)
    }

    /// Takes truth steps and states as they come until the run ends (see [`Recording::record`]).
    async fn follow(
        &mut self,
        sink: &mut Sink<'_>,
        mut feed: Option<&mut Feed>,
        mut hub: Option<&mut Child>,
        on_tick: &mut dyn FnMut(f64) -> Result<()>,
    ) -> Result<()> {
        let mut hub_seen = *self.hub_alive.borrow();
        let mut stop_at: Option<tokio::time::Instant> = None;
        loop {
            let hub_exit = async {
                match hub.as_mut() {
                    Some(h) => h.wait().await.ok(),
                    None => std::future::pending().await,
                }
            };
            let extra = async {
                match feed.as_mut() {
                    Some(f) => f.rx.recv().await,
                    None => std::future::pending().await,
                }
            };
            let stop = async {
                match stop_at {
                    Some(t) => tokio::time::sleep_until(t).await,
                    None => std::future::pending().await,
                }
            };
            // Biased: queued states before truth steps, and both before the hub's exit. States
            // first keeps scoring repeatable: a state of tick k is in its queue before the truth
            // step of tick k + 2 (the agent sends it before its next command), so it is folded
            // while its tick's truth is still kept, however far the recorder lags behind a fast
            // run (truth first let a lagging recorder drop the truth of states still queued, and
            // forest-100's summary scored a different number of estimates on every run).
            tokio::select! {
                biased;
                Some((from, b)) = self.states.recv() => sink.state(&b, from)?,
                Some(b) = self.truth.recv() => {
                    if sink.truth(&b)? { break }
                    if let Some(t) = sink.m.last_step().map(|s| s.t_s) { on_tick(t)?; }
                },
                Some(e) = extra => if let Some(scene) = sink.scene.as_mut() { scene.on_extra(e) },
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
        Ok(())
    }

    /// Takes the truth steps already queued, and the states of the last tick still in flight.
    /// (A truth step after the last is never expected: the hub ends with it.)
    async fn drain(&mut self, sink: &mut Sink<'_>, feed: Option<&mut Feed>) -> Result<()> {
        while let Ok(b) = self.truth.try_recv() {
            sink.truth(&b)?;
        }
        if let (Some(f), Some(scene)) = (feed, sink.scene.as_mut()) {
            while let Ok(e) = f.rx.try_recv() {
                scene.on_extra(e);
            }
        }
        // The states of the last tick are on their way: wait for every one the last step
        // promises (bounded, for an agent that dies between its command and its state), then
        // take whatever else is already queued.
        let drain_until = tokio::time::Instant::now() + LAST_STATES_WAIT;
        while sink.m.awaiting_last_states() {
            match tokio::time::timeout_at(drain_until, self.states.recv()).await {
                Ok(Some((from, b))) => sink.state(&b, from)?,
                Ok(None) => break,
                Err(_) => {
                    warn!("some agents' last states did not come within {LAST_STATES_WAIT:?}");
                    break;
                }
            }
        }
        while let Ok((from, b)) = self.states.try_recv() {
            sink.state(&b, from)?;
        }
        Ok(())
    }
}

/// Subscribes to the agent states on `key` (a wildcard of UAVs' or agent hosts' state keys) and
/// sends each payload into `tx` with whom its key speaks for.
async fn subscribe_states(
    session: &zenoh::Session,
    keys: &Keys,
    key: String,
    tx: mpsc::UnboundedSender<(Origin, Vec<u8>)>,
) -> Result<Subscription> {
    let k = keys.clone();
    let map = move |sample: &zenoh::sample::Sample| {
        Some((Origin::Wire(Speaker::of(&k, sample.key_expr().as_str())), plumbing::payload(sample)))
    };
    Ok(plumbing::subscribe(session, key, tx, map).await?)
}

/// A recording fed by hand instead of by a session: what `swarm floor`, which flies the whole
/// swarm in its own process, hands it is what a run's recorder would have received (the world,
/// then each tick's agent states before the truth step that follows them), and it writes the
/// same run folder (no `run.mcap`, no journal).
pub struct Offline<'a> {
    sink: Sink<'a>,
    run_id: String,
    out: std::path::PathBuf,
}

impl<'a> Offline<'a> {
    /// A recording of run `run_id` of `sc` into the run folder `out` (made if missing), its
    /// progress on `pb`.
    pub fn new(out: &Path, sc: &'a Scenario, pb: &'a ProgressBar, run_id: &str) -> Result<Offline<'a>> {
        std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
        let sink = Sink::new(out, sc, pb, None, None)?;
        Ok(Offline { sink, run_id: run_id.to_string(), out: out.to_path_buf() })
    }

    /// The hub's world.
    pub fn world(&mut self, w: swarm_wire::TruthWorld) -> Result<()> {
        self.sink.truth(&Msg::TruthWorld(w).encode()?).map(|_| ())
    }

    /// An agent's state.
    pub fn state(&mut self, st: swarm_wire::AgentState) -> Result<()> {
        self.sink.state(&Msg::State(Box::new(st)).encode()?, Origin::Taken)
    }

    /// A truth step; true on the run's last.
    pub fn step(&mut self, s: swarm_wire::TruthStep) -> Result<bool> {
        self.sink.truth(&Msg::TruthStep(s).encode()?)
    }

    /// Writes the summary, `world.json`, `connectivity.csv` and the figures.
    pub fn finish(self) -> Result<Summary> {
        self.sink.finish(&self.run_id, &self.out, false)
    }
}

/// The `end_reason` of a run recovered from its journal that did not reach its last step.
pub const CUT_SHORT: &str = "cut_short";

/// Folds the journal of the run folder `out` (a run whose recorder was killed) into the CSVs,
/// summary and figures a clean end at its last journaled tick would have written; the summary's
/// end reason is [`CUT_SHORT`] unless the journal holds the hub's last step.
pub fn replay(out: &Path, sc: &Scenario) -> Result<(Summary, journal::salvage::Cut)> {
    let pb = ProgressBar::hidden();
    let mut sink = Sink::new(out, sc, &pb, None, None)?;
    let mut folded = Ok(());
    let (run_id, cut) = journal::each(out, |kind, b| {
        if folded.is_ok() {
            folded = match kind {
                Kind::Truth => sink.truth(b).map(|_| ()),
                Kind::State => sink.state(b, Origin::Taken),
            };
        }
    })?;
    folded?;
    let summary = sink.finish(&run_id, out, true)?;
    Ok((summary, cut))
}

/// Writes `summary.json`, `world.json` and `connectivity.csv` into the run folder `out`, then
/// the figures (a figure that cannot be drawn is a warning: the run itself is recorded).
fn write_outputs(out: &Path, summary: &Summary, m: &Metrics) -> Result<()> {
    let path = out.join("summary.json");
    std::fs::write(&path, serde_json::to_string_pretty(summary)?)
        .with_context(|| format!("cannot write {}", path.display()))?;
    if let Some(w) = m.world() {
        write_world(out, w)?;
    }
    write_connectivity(out, &m.components_series())?;
    if let Err(e) = swarm_plot::write_all(out, None) {
        warn!("the run's figures were not drawn: {e:#}");
    }
    Ok(())
}

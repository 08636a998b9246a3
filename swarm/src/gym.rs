//! `swarm run --gym`: the run as a step function for a learning loop, over the launcher's own
//! standard input and output, one JSON line each way per tick (the Python package `uavswarm`
//! speaks it; docs/python.md).
//!
//! Why in the launcher and over pipes: a learning process then needs no Zenoh client and no key
//! of ours, only the one child it starts (which takes every other process of the run down with
//! it), and it gets the whole swarm's tick in one message however many UAVs fly. Behind it, the
//! run is what it always is: each external UAV's agent publishes its view on its own key and
//! waits for its command, over the hub's router, in lockstep.
//!
//! Out (stdout), once the view of tick k of every external UAV whose agent is alive has come:
//! `{"tick": k, "t_s": …, "views": {"3": ExtView, …}, "truth": the TruthStep that reached tick k
//! (null at tick 0)}`;
//! once the hub's last step came: `{"tick": k, "end": "goal" | "time_limit" | …, "truth": …}`.
//! The truth is the hub's ground truth (bodies, contacts), for rewards: a learning loop keeps it
//! out of its observations. In (stdin): `{"tick": k, "cmds": {"3": {"x": …, "y": …,
//! "yaw_rate": …, "kind": "velocity"}, …}}`, each put as that UAV's `ext/cmd`. A line that is not
//! that is said on stderr and ignored (its UAVs hover at the tick timeout).

use anyhow::{Context, Result};
use serde_json::{json, Value};
use std::collections::{BTreeMap, BTreeSet};
use swarm_config::Scenario;
use swarm_types::UavId;
use swarm_wire::external::ExtCmd;
use swarm_wire::plumbing::{self, Subscription};
use swarm_wire::session::{self, Role};
use swarm_wire::{Keys, Msg, TruthStep, WireError};
use tokio::io::{AsyncBufReadExt, AsyncWriteExt, BufReader};
use tokio::sync::mpsc;
use tracing::{info, warn};
use zenoh::liveliness::LivelinessToken;
use zenoh::qos::CongestionControl;

/// What reaches the gateway.
enum Event {
    /// An external UAV's view (JSON).
    View(UavId, Value),
    /// The hub's step.
    Truth(Box<TruthStep>),
    /// An agent's liveliness token came or went.
    Alive(UavId, bool),
}

/// The gateway of one run.
pub struct Gym {
    session: zenoh::Session,
    keys: Keys,
    external: BTreeSet<UavId>,
    rx: mpsc::UnboundedReceiver<Event>,
    _subs: Vec<Subscription>,
    _tokens: Vec<LivelinessToken>,
}

/// The truth a learning loop gets: the step without its wall-clock fields (which differ from run
/// to run even in lockstep).
fn truth_json(t: &TruthStep) -> Value {
    json!({
        "tick": t.tick,
        "t_s": t.t_s,
        "bodies": t.bodies,
        "collisions": t.collisions,
        "goal_reached_at": t.goal_reached_at,
        "ended": t.ended,
    })
}

impl Gym {
    /// Connects (as `controller`), declares the external controller's token of every external
    /// UAV and subscribes to their views, the hub's steps and the agents' tokens.
    pub async fn start(run: &str, connect: &[String], cfg: &[String], sc: &Scenario) -> Result<Gym> {
        let keys = Keys::new(run)?;
        let s =
            session::open(Role::Client, &[], connect, cfg).await.context("the gym gateway cannot open its session")?;
        let (tx, rx) = mpsc::unbounded_channel();
        let mut subs = Vec::new();
        let mut tokens = Vec::new();
        let external: BTreeSet<UavId> = sc.controller.external.iter().copied().collect();
        for &id in &external {
            subs.push(
                plumbing::subscribe(&s, keys.ext_view(id), tx.clone(), move |x| {
                    serde_json::from_slice(&plumbing::payload(x)).ok().map(|v| Event::View(id, v))
                })
                .await?,
            );
        }
        subs.push(
            plumbing::subscribe(&s, keys.truth_step(), tx.clone(), |x| match plumbing::decode(x) {
                Ok(Msg::TruthStep(t)) => Some(Event::Truth(Box::new(t))),
                _ => None,
            })
            .await?,
        );
        let k = keys.clone();
        let alive = tx.clone();
        subs.push(
            plumbing::on_tokens(&s, keys.alive_uav_any(), move |key, up| {
                if let Some(id) = k.uav_id_of(key) {
                    let _ = alive.send(Event::Alive(id, up));
                }
            })
            .await?,
        );
        for &id in &external {
            tokens.push(s.liveliness().declare_token(keys.alive_ext(id)).await.map_err(WireError::zenoh)?);
        }
        info!(external = ?external, "gym gateway up");
        Ok(Gym { session: s, keys, external, rx, _subs: subs, _tokens: tokens })
    }

    /// Runs until the hub's last step has been handed on (or stdout closes).
    pub async fn run(mut self) -> Result<()> {
        let mut out = tokio::io::stdout();
        let mut lines = BufReader::new(tokio::io::stdin()).lines();
        let mut alive: BTreeSet<UavId> = BTreeSet::new();
        let mut views: BTreeMap<u64, BTreeMap<UavId, Value>> = BTreeMap::new();
        let mut truth: Option<Box<TruthStep>> = None;
        let mut stdin_open = true;
        loop {
            tokio::select! {
                ev = self.rx.recv() => {
                    let Some(ev) = ev else { break };
                    match ev {
                        Event::Alive(id, up) => {
                            if up { alive.insert(id); } else { alive.remove(&id); }
                        }
                        Event::View(id, v) => {
                            let tick = v.get("tick").and_then(Value::as_u64).unwrap_or(0);
                            views.entry(tick).or_default().insert(id, v);
                        }
                        Event::Truth(t) => {
                            let ended = t.ended;
                            truth = Some(t);
                            if let Some(end) = ended {
                                let t = truth.as_deref().expect("just set");
                                let line = json!({"tick": t.tick, "end": end, "truth": truth_json(t)});
                                write_line(&mut out, &line).await?;
                                info!(?end, "gym gateway: the run ended");
                                return Ok(());
                            }
                        }
                    }
                    self.hand_on(&mut out, &mut views, &alive, truth.as_deref()).await?;
                }
                line = lines.next_line(), if stdin_open => match line {
                    Ok(Some(l)) => self.on_commands(&l).await,
                    _ => stdin_open = false,
                },
            }
        }
        Ok(())
    }

    /// Hands on the oldest tick whose views have all come.
    async fn hand_on(
        &self,
        out: &mut tokio::io::Stdout,
        views: &mut BTreeMap<u64, BTreeMap<UavId, Value>>,
        alive: &BTreeSet<UavId>,
        truth: Option<&TruthStep>,
    ) -> Result<()> {
        let Some((&tick, got)) = views.iter().next() else { return Ok(()) };
        let expected: Vec<UavId> = self.external.iter().copied().filter(|id| alive.contains(id)).collect();
        if expected.is_empty() || !expected.iter().all(|id| got.contains_key(id)) {
            return Ok(());
        }
        let got = views.remove(&tick).expect("the oldest tick");
        let t_s = got.values().next().and_then(|v| v.get("t_s")).cloned().unwrap_or(Value::Null);
        let views_json: serde_json::Map<String, Value> = got.into_iter().map(|(id, v)| (id.to_string(), v)).collect();
        // The truth the step before this tick led to (a truth step's tick is the one it reached).
        let truth = truth.filter(|t| t.tick == tick).map(truth_json).unwrap_or(Value::Null);
        write_line(out, &json!({"tick": tick, "t_s": t_s, "views": views_json, "truth": truth})).await
    }

    /// One line of commands: each UAV's put on its `ext/cmd`.
    async fn on_commands(&self, line: &str) {
        let parsed: Result<(u64, serde_json::Map<String, Value>), String> =
            serde_json::from_str::<Value>(line).map_err(|e| e.to_string()).and_then(|v| {
                let tick = v.get("tick").and_then(Value::as_u64).ok_or("no \"tick\"")?;
                let cmds = v.get("cmds").and_then(Value::as_object).cloned().ok_or("no \"cmds\" object")?;
                Ok((tick, cmds))
            });
        let (tick, cmds) = match parsed {
            Ok(p) => p,
            Err(e) => {
                warn!("gym gateway: a line that is not a tick's commands ignored ({e}): {line:.200}");
                return;
            }
        };
        for (id, c) in cmds {
            let Some(id) = id.parse::<UavId>().ok().filter(|id| self.external.contains(id)) else {
                warn!("gym gateway: a command for {id:?}, which is not an external UAV, ignored");
                continue;
            };
            let mut c = c;
            c["tick"] = json!(tick);
            let bytes = c.to_string().into_bytes();
            if ExtCmd::parse(&bytes).is_none() {
                warn!(uav_id = %id, "gym gateway: not a command, ignored: {c}");
                continue;
            }
            // Blocking, not dropped under congestion: the tick waits for every command.
            let put = self.session.put(self.keys.ext_cmd(id), bytes).congestion_control(CongestionControl::Block);
            if let Err(e) = put.await {
                warn!(uav_id = %id, "gym gateway: {e}");
            }
        }
    }
}

async fn write_line(out: &mut tokio::io::Stdout, v: &Value) -> Result<()> {
    let mut text = v.to_string();
    text.push('\n');
    out.write_all(text.as_bytes()).await?;
    out.flush().await?;
    Ok(())
}

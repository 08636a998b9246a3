//! Watching a swarm, live or recorded, in a crate of its own so the processes that fly
//! (`swarm-node`) link no web or Foxglove server.
//!
//! `swarm view`: watch a running swarm. An observer that joins the run's key space, drains
//! every subscription into a ring buffer (like `swarm tap`: a slow viewer drops its oldest
//! samples, it never holds a lockstep run back), and serves two things on loopback:
//!
//! - a web page (`http`; the page itself is `page.html`, embedded) drawing the map, the UAVs
//!   with heading and trail, radio links by netem state, estimates, collisions and failures,
//!   the clock and x real time, and a panel per UAV, from the frames of a `board`;
//! - the Foxglove WebSocket protocol (the SDK's server on the [`Scene`]'s context, the same
//!   topics as `run.mcap`), for Foxglove or Lichtblick, behind `front`, which lets clients that
//!   offer only the protocol's old name (`foxglove.websocket.v1`) in.
//!
//! The page asks for the selected UAV's scan only while its toggle is on (`scans`), and is
//! handed the last seconds of every path as it connects (`trails`), so a page opened late draws
//! the trails at once.
//!
//! `swarm run --view` starts the same [`Live`] view inside the run ([`Live::start`]);
//! `replay` is `swarm replay`: the same page and WebSocket over a recorded `run.mcap`.

mod board;
mod front;
mod http;
mod replay;
mod scans;
mod trails;

pub use replay::{replay, ReplayArgs};

use anyhow::{Context as _, Result};
use board::Board;
use clap::Args;
use front::Front;
use scans::LiveScans;
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Duration;
use swarm_args::ZenohArgs;
use swarm_config::Scenario;
use swarm_record::scene::Scene;
use swarm_wire::session::{self, Role};
use swarm_wire::{plumbing, Keys, Msg, WireError};
use tokio::sync::watch;
use trails::LiveTrails;
use zenoh::handlers::{RingChannel, RingChannelHandler};
use zenoh::pubsub::Subscriber;
use zenoh::sample::Sample;

/// How long the view asks the hub for the scenario and the world.
const ASK_WAIT: Duration = Duration::from_secs(10);
/// How often the page gets a new frame at most [wall].
const FRAME_EVERY: Duration = Duration::from_millis(50);
/// How often the world is logged again for Foxglove clients that joined late [wall].
const WORLD_EVERY: Duration = Duration::from_secs(2);
/// Samples each subscription keeps when the view falls behind.
const RING: usize = 4096;

/// `swarm view`.
#[derive(Args, Debug, Clone)]
pub struct ViewArgs {
    /// Run id.
    #[arg(long)]
    pub run: String,
    /// Endpoints (the hub's).
    #[command(flatten)]
    pub zenoh: ZenohArgs,
    /// The page's HTTP port on 127.0.0.1 (0: any free port); the Foxglove WebSocket is on the
    /// next port (or any free port when this is 0).
    #[arg(long, default_value_t = 8765)]
    pub port: u16,
}

/// Runs `swarm view` until Ctrl-C.
pub async fn view(a: ViewArgs) -> Result<ExitCode> {
    anyhow::ensure!(!a.zenoh.connect.is_empty(), "the view needs --connect <hub endpoint>");
    // A tool's session: a short wait for the hub, and a refused login said as such.
    let session = a.zenoh.open_tool_session().await?;
    let live = Live::start_on(session, &a.run, a.port).await?;
    println!("{}", live.addresses());
    tokio::select! {
        r = live.run() => r?,
        _ = tokio::signal::ctrl_c() => {}
    }
    Ok(ExitCode::SUCCESS)
}

/// The page's port and the Foxglove WebSocket's for a requested page port.
fn ports(page: u16) -> (u16, u16) {
    (page, if page == 0 { 0 } else { page.saturating_add(1) })
}

type Ring = Subscriber<RingChannelHandler<Sample>>;

async fn ring(s: &zenoh::Session, key: String) -> Result<Ring> {
    Ok(s.declare_subscriber(key).with(RingChannel::new(RING)).await.map_err(WireError::zenoh)?)
}

/// The Foxglove WebSocket of `ctx`: the SDK's server on a free loopback port, behind the front
/// door on 127.0.0.1:`port` (0: any free port), which clients connect to.
async fn foxglove_server(
    ctx: &Arc<foxglove::Context>,
    name: String,
    port: u16,
) -> Result<(foxglove::WebSocketServerHandle, Front)> {
    let sdk = ctx
        .websocket_server()
        .name(name)
        .bind("127.0.0.1", 0)
        .start()
        .await
        .context("cannot start the Foxglove WebSocket server")?;
    let front = Front::start(port, ([127, 0, 0, 1], sdk.port()).into())
        .await
        .with_context(|| format!("cannot listen on port {port}"))?;
    Ok((sdk, front))
}

/// A live view: the session, its ring-buffered subscriptions, and what they feed.
pub struct Live {
    /// Held: the subscriptions live as long as their session.
    _session: zenoh::Session,
    subs: [Ring; 6],
    shown: Shown,
    page_port: u16,
    _foxglove: foxglove::WebSocketServerHandle,
    front: Front,
}

/// What the samples feed: the Foxglove scene and the page's board.
struct Shown {
    keys: Keys,
    run_id: String,
    scene: Scene,
    board: Board,
    scans: Arc<LiveScans>,
    trails: Arc<LiveTrails>,
    snap: watch::Sender<http::Snapshot>,
}

impl Live {
    /// Joins run `run_id` at `connect`, fetches the scenario and the world, and starts serving
    /// the page on 127.0.0.1:`page_port` and the Foxglove WebSocket beside it.
    pub async fn start(run_id: &str, connect: &[String], cfg: &[String], page_port: u16) -> Result<Live> {
        Live::start_on(session::open(Role::Client, &[], connect, cfg).await?, run_id, page_port).await
    }

    /// [`Live::start`] on a session already open.
    pub async fn start_on(session: zenoh::Session, run_id: &str, page_port: u16) -> Result<Live> {
        let keys = Keys::new(run_id)?;
        let subs = [
            ring(&session, keys.truth_all()).await?,
            ring(&session, keys.state_any()).await?,
            ring(&session, keys.host_state_any()).await?,
            ring(&session, keys.sense_any()).await?,
            ring(&session, keys.host_sense_any()).await?,
            ring(&session, keys.netem_rules()).await?,
        ];
        let text = plumbing::fetch_scenario_text(&session, &keys, ASK_WAIT).await?;
        let sc = Scenario::from_toml_str(&text, "hub")?;
        let (page, fox) = ports(page_port);
        let scene = Scene::new(&sc)?;
        let (foxglove, front) = foxglove_server(scene.context(), format!("swarm view {run_id}"), fox).await?;
        let listener = tokio::net::TcpListener::bind(("127.0.0.1", page))
            .await
            .with_context(|| format!("cannot listen on port {page}"))?;
        let page_port = listener.local_addr()?.port();
        let (snap, rx) = watch::channel(http::Snapshot::default());
        let scans = Arc::new(LiveScans::default());
        let trails = Arc::new(LiveTrails::default());
        tokio::spawn(http::serve(
            listener,
            http::Sources { snap: rx, control: None, scans: scans.clone(), trails: trails.clone() },
        ));
        let mut shown = Shown { keys, run_id: run_id.to_string(), scene, board: Board::new(&sc), scans, trails, snap };
        match plumbing::fetch(&session, &shown.keys.truth_world(), ASK_WAIT).await {
            Ok(b) => shown.truth(&b),
            Err(e) => tracing::warn!("no world from the hub yet: {e}"),
        }
        Ok(Live { _session: session, subs, shown, page_port, _foxglove: foxglove, front })
    }

    /// The page's and the Foxglove WebSocket's addresses, as printed.
    pub fn addresses(&self) -> String {
        format!("view: http://127.0.0.1:{}/  foxglove: ws://127.0.0.1:{}", self.page_port, self.front.port())
    }

    /// Takes samples as they come, forever (the view outlives the run: Ctrl-C ends it).
    pub async fn run(mut self) -> Result<()> {
        let mut frames = tokio::time::interval(FRAME_EVERY);
        let mut world = tokio::time::interval(WORLD_EVERY);
        let mut shown = None;
        loop {
            let [truth, states, host_states, alone, hosts, rules] = &self.subs;
            tokio::select! {
                Ok(s) = truth.recv_async() => self.shown.truth(&plumbing::payload(&s)),
                Ok(s) = states.recv_async() => self.shown.stated(&s),
                Ok(s) = host_states.recv_async() => self.shown.stated(&s),
                Ok(s) = alone.recv_async() => self.shown.sensed(&s),
                Ok(s) = hosts.recv_async() => self.shown.sensed(&s),
                Ok(s) = rules.recv_async() => {
                    if let Ok(Msg::NetemRules(json)) = plumbing::decode(&s) {
                        if let Ok(t) = serde_json::from_str::<swarm_config::Timeline>(&json) {
                            self.shown.board.on_timeline(t.clone());
                            self.shown.scene.on_timeline(t);
                        }
                    }
                }
                _ = frames.tick() => {
                    if self.shown.board.tick() != shown {
                        shown = self.shown.board.tick();
                        self.shown.publish();
                    }
                }
                _ = world.tick() => self.shown.scene.relog_world(),
            }
        }
    }
}

impl Shown {
    /// The agent states of a sample, one UAV's or an agent host's.
    fn stated(&mut self, s: &zenoh::sample::Sample) {
        for (_, st) in plumbing::agent_states(&self.keys, s) {
            self.scene.on_state(&st);
            self.board.on_state(*st);
        }
    }

    /// The sensor frames of a sample, one UAV's or an agent host's.
    fn sensed(&mut self, s: &zenoh::sample::Sample) {
        for (id, f) in plumbing::sense_frames(&self.keys, s) {
            self.board.on_radio(&f.radio);
            self.scene.on_radio(&f.radio);
            self.scene.on_scan(id, &f.scan);
            self.scans.on_scan(id, f.scan);
        }
    }

    fn truth(&mut self, b: &[u8]) {
        match Msg::decode(b) {
            Ok(Msg::TruthStep(s)) => {
                let s = Arc::new(s);
                self.scene.on_step(&s);
                self.trails.on_step(&s);
                self.scans.on_step(s.clone());
                self.board.on_step(s);
            }
            Ok(Msg::TruthWorld(w)) => {
                self.scene.on_world(&w);
                self.board.on_world(&self.run_id, &w);
                self.publish();
            }
            _ => {}
        }
    }

    /// Hands the page the world and the latest frame.
    fn publish(&self) {
        let world = self.board.world().map(|w| Arc::<str>::from(w.to_string()));
        let frame = self.board.frame().map(|f| Arc::<str>::from(f.to_string()));
        self.snap.send_modify(|s| {
            if s.world.is_none() {
                s.world = world;
            }
            if frame.is_some() {
                s.frame = frame;
            }
        });
    }
}

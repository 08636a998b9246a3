//! `swarm ros2` (and `swarm run --ros2`): a run's UAVs as ROS 2 nodes on rmw_zenoh's wire, so a
//! ROS 2 machine connected to the hub's router sees `/uav{id}/scan` (`sensor_msgs/msg/LaserScan`,
//! body frame) and `/uav{id}/odom` (`nav_msgs/msg/Odometry`) of every UAV, and drives each
//! external UAV through `/uav{id}/cmd_vel` (`geometry_msgs/msg/Twist`).
//!
//! Why a bridge and not the agents themselves: the run's own keys stay compact (postcard, one
//! key family per concern) and ROS's cost is paid only when someone asks for it; the bridge is
//! one more client of the router, logged in as `bridge`. For each external UAV it is the external
//! controller (docs/own-controller.md): it answers every view with the newest Twist
//! from ROS (linear x, y in the body frame, angular z as the yaw rate), zero before the first
//! and once the newest is older than half a second.
//! Formats: `swarm_wire::ros2`.

use anyhow::{Context, Result};
use clap::Args;
use std::collections::BTreeMap;
use std::process::ExitCode;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};
use swarm_config::Scenario;
use swarm_node::args::ZenohArgs;
use swarm_wire::external::{ExtCmd, ExtCmdKind};
use swarm_wire::plumbing::{self, Subscription};
use swarm_wire::ros2::msgs::{laser_scan, odometry, Twist};
use swarm_wire::ros2::{
    attachment, data_key, Entity, Kind, RosType, LASER_SCAN, ODOMETRY, QOS_DEFAULT, QOS_SENSOR, TWIST,
};
use swarm_wire::session::{self, Role};
use swarm_wire::{Keys, Msg, SenseFrame, WireError};
use tokio::sync::{mpsc, watch};
use tracing::{info, warn};
use zenoh::liveliness::LivelinessToken;
use zenoh::qos::CongestionControl;

/// `swarm ros2`.
#[derive(Args, Debug, Clone)]
pub struct Ros2Args {
    /// Run id of the running swarm.
    #[arg(long)]
    pub run: String,
    /// ROS 2 domain id of the topics (`ROS_DOMAIN_ID` on the ROS side).
    #[arg(long, default_value_t = 0)]
    pub ros_domain: u32,
    /// Where and how to connect (log in as `bridge`).
    #[command(flatten)]
    pub zenoh: ZenohArgs,
}

/// Runs `swarm ros2` until the run's hub goes away or Ctrl-C.
pub async fn ros2(a: Ros2Args) -> Result<ExitCode> {
    anyhow::ensure!(!a.zenoh.connect.is_empty(), "swarm ros2 needs --connect <hub endpoint>");
    let bridge = Bridge::start(&a.run, &a.zenoh.connect, &a.zenoh.session_cfg()?, a.ros_domain).await?;
    tokio::select! {
        r = bridge.run() => r?,
        _ = tokio::signal::ctrl_c() => {}
    }
    Ok(ExitCode::SUCCESS)
}

/// What reaches the bridge, in one channel.
enum Event {
    /// A UAV's sensor frame (the bridge takes its odometry and scan).
    Sense(u32, Box<SenseFrame>),
    /// An external UAV's view (JSON).
    View(u32, Vec<u8>),
    /// A Twist from ROS for an external UAV (CDR).
    CmdVel(u32, Vec<u8>),
}

/// The bridge of one run.
pub struct Bridge {
    session: zenoh::Session,
    keys: Keys,
    domain: u32,
    /// The scan period [s] (one tick).
    scan_period_s: f32,
    rx: mpsc::UnboundedReceiver<Event>,
    hub_alive: watch::Receiver<bool>,
    _subs: Vec<Subscription>,
    _tokens: Vec<LivelinessToken>,
    /// Last sequence number per (UAV, topic).
    seq: BTreeMap<(u32, &'static str), i64>,
    /// The newest Twist of each external UAV, and when it came.
    twists: BTreeMap<u32, (Twist, Instant)>,
    /// Payloads on a cmd_vel or view key that were not a Twist or view.
    malformed: u64,
}

impl Bridge {
    /// Connects, fetches the run's scenario, declares the ROS graph (a node per UAV with its
    /// publishers, and a subscription per external UAV) and subscribes to what it bridges.
    pub async fn start(run: &str, connect: &[String], cfg: &[String], domain: u32) -> Result<Bridge> {
        let keys = Keys::new(run)?;
        let s = session::open(Role::Client, &[], connect, cfg).await.context("the bridge cannot open its session")?;
        let text = plumbing::fetch_scenario_text(&s, &keys, Duration::from_secs(30)).await?;
        let sc = Scenario::from_toml_str(&text, &format!("hub:{}", keys.scenario()))?;
        let (tx, rx) = mpsc::unbounded_channel();
        let mut subs = Vec::new();
        let keys2 = keys.clone();
        subs.push(plumbing::subscribe(&s, keys.sense_any(), tx.clone(), move |x| sense_event(&keys2, x)).await?);
        let mut tokens = graph(&s, &sc, domain).await?;
        for &id in &sc.controller.external {
            subs.push(
                plumbing::subscribe(&s, keys.ext_view(id), tx.clone(), move |x| {
                    Some(Event::View(id, plumbing::payload(x)))
                })
                .await?,
            );
            let cmd_vel = data_key(domain, &format!("/uav{id}/cmd_vel"), &TWIST);
            subs.push(
                plumbing::subscribe(&s, cmd_vel, tx.clone(), move |x| Some(Event::CmdVel(id, plumbing::payload(x))))
                    .await?,
            );
            tokens.push(s.liveliness().declare_token(keys.alive_ext(id)).await.map_err(WireError::zenoh)?);
        }
        let (hub_alive, hub_sub) = plumbing::watch_token(&s, keys.alive_hub()).await?;
        subs.push(hub_sub);
        info!(uavs = sc.count(), external = ?sc.controller.external, domain, "ROS 2 bridge up");
        let scan_period_s = sc.dt_secs() as f32;
        let (seq, twists) = (BTreeMap::new(), BTreeMap::new());
        Ok(Bridge {
            session: s,
            keys,
            domain,
            scan_period_s,
            rx,
            hub_alive,
            _subs: subs,
            _tokens: tokens,
            seq,
            twists,
            malformed: 0,
        })
    }

    /// Bridges until the hub's token goes away (after it was seen).
    pub async fn run(mut self) -> Result<()> {
        loop {
            tokio::select! {
                ev = self.rx.recv() => match ev {
                    // One failed put must not take every external UAV's controller with it.
                    Some(ev) => if let Err(e) = self.on_event(ev).await {
                        warn!("ROS 2 bridge: {e:#}");
                    },
                    None => break,
                },
                // The token only ever goes down after it was up: a change to down is the end.
                changed = self.hub_alive.changed() => {
                    if changed.is_err() || !*self.hub_alive.borrow() {
                        break;
                    }
                }
            }
        }
        info!(malformed = self.malformed, "ROS 2 bridge done: the hub is gone");
        let _ = self.session.close().await;
        Ok(())
    }

    async fn on_event(&mut self, ev: Event) -> Result<()> {
        match ev {
            Event::Sense(id, f) => {
                let base = format!("uav{id}/base_link");
                self.publish(id, "odom", ODOMETRY, odometry(&f.odom, &format!("uav{id}/odom"), &base)).await?;
                self.publish(id, "scan", LASER_SCAN, laser_scan(&f.scan, &base, self.scan_period_s)).await
            }
            Event::CmdVel(id, bytes) => {
                match Twist::decode(&bytes) {
                    Ok(t) if t.linear.iter().chain(&t.angular).all(|v| v.is_finite()) => {
                        self.twists.insert(id, (t, Instant::now()));
                    }
                    _ => self.dropped(id, "cmd_vel"),
                }
                Ok(())
            }
            Event::View(id, bytes) => match serde_json::from_slice::<ViewTick>(&bytes) {
                Ok(v) => self.answer(id, v.tick).await,
                Err(_) => {
                    self.dropped(id, "ext/view");
                    Ok(())
                }
            },
        }
    }

    fn dropped(&mut self, id: u32, what: &str) {
        self.malformed += 1;
        warn!(uav_id = id, "malformed {what} payload dropped");
    }

    /// Publishes `payload` on UAV `id`'s `topic` with rmw_zenoh's attachment.
    async fn publish(&mut self, id: u32, topic: &'static str, t: RosType, payload: Vec<u8>) -> Result<()> {
        let seq = self.seq.entry((id, topic)).or_insert(0);
        *seq += 1;
        let stamp_ns = SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.as_nanos() as i64);
        let att = attachment(*seq, stamp_ns, &gid(id, topic));
        let key = data_key(self.domain, &format!("/uav{id}/{topic}"), &t);
        let put = self.session.put(key, payload).attachment(att.to_vec()).congestion_control(CongestionControl::Drop);
        Ok(put.await.map_err(WireError::zenoh)?)
    }

    /// Answers the view of `tick` of external UAV `id` with its newest Twist, or zero when none
    /// came in the last [`CMD_VEL_TIMEOUT`] (a ROS driver's usual guard: a teleop that stops or
    /// dies must not leave the UAV flying).
    async fn answer(&self, id: u32, tick: u64) -> Result<()> {
        let fresh = self.twists.get(&id).filter(|(_, at)| at.elapsed() <= CMD_VEL_TIMEOUT);
        let t = fresh.map(|(t, _)| *t).unwrap_or_default();
        let cmd = ExtCmd { tick, kind: ExtCmdKind::Velocity, x: t.linear[0], y: t.linear[1], yaw_rate: t.angular[2] };
        let json = serde_json::to_vec(&cmd)?;
        Ok(self.session.put(self.keys.ext_cmd(id), json).await.map_err(WireError::zenoh)?)
    }
}

/// How long a cmd_vel Twist holds (wall clock).
const CMD_VEL_TIMEOUT: Duration = Duration::from_millis(500);

/// The one field of a view the bridge needs.
#[derive(serde::Deserialize)]
struct ViewTick {
    tick: u64,
}

/// A UAV's sensor frame from its key.
fn sense_event(keys: &Keys, sample: &zenoh::sample::Sample) -> Option<Event> {
    let id = keys.uav_id_of(sample.key_expr().as_str())?;
    match plumbing::decode(sample) {
        Ok(Msg::Sense(f)) => Some(Event::Sense(id, f)),
        _ => None,
    }
}

/// A publisher's GID: any 16 bytes unique to it (rmw_zenoh only reports them).
fn gid(id: u32, topic: &str) -> [u8; 16] {
    let mut g = [0u8; 16];
    g[..4].copy_from_slice(&id.to_le_bytes());
    for (i, b) in topic.bytes().take(12).enumerate() {
        g[4 + i] = b;
    }
    g
}

/// The liveliness tokens of the ROS graph: node `swarm` in namespace `/uav{id}` for each UAV,
/// with its `scan` and `odom` publishers, and a `cmd_vel` subscription for an external UAV.
async fn graph(s: &zenoh::Session, sc: &Scenario, domain: u32) -> Result<Vec<LivelinessToken>> {
    let zid = s.zid().to_string();
    let mut tokens = Vec::new();
    for id in sc.uav_ids() {
        let ns = format!("/uav{id}");
        let node = Entity {
            domain,
            zid: &zid,
            node_id: id,
            entity_id: id,
            kind: Kind::Node,
            namespace: &ns,
            node: "swarm",
            topic: None,
        };
        let (scan, odom, cmd_vel) = (format!("{ns}/scan"), format!("{ns}/odom"), format!("{ns}/cmd_vel"));
        let mut entities = vec![
            node,
            Entity {
                entity_id: 1_000_000 + 3 * id,
                kind: Kind::Publisher,
                topic: Some((&scan, LASER_SCAN, QOS_SENSOR)),
                ..node
            },
            Entity {
                entity_id: 1_000_001 + 3 * id,
                kind: Kind::Publisher,
                topic: Some((&odom, ODOMETRY, QOS_SENSOR)),
                ..node
            },
        ];
        if sc.controller.external.contains(&id) {
            entities.push(Entity {
                entity_id: 1_000_002 + 3 * id,
                kind: Kind::Subscription,
                topic: Some((&cmd_vel, TWIST, QOS_DEFAULT)),
                ..node
            });
        }
        for e in entities {
            tokens.push(s.liveliness().declare_token(e.token_key()).await.map_err(WireError::zenoh)?);
        }
    }
    Ok(tokens)
}

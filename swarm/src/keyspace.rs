//! `swarm keys --run R`: the live key space of a run, the way `ros2 topic list -v`, `hz` and
//! `bw` show a ROS graph: each key family (`uav/{id}/share/pose` stands for every UAV's), who
//! publishes it and who subscribes to it, per Zenoh session, and its message rate and bandwidth.
//!
//! Who publishes and who subscribes is what the routers themselves hold: their admin space
//! (`@/<zid>/router/{subscriber,publisher,querier,token}/swarm/R/**`, enabled read-only on every
//! router we start; the hub's access control lets only observers query it). Our pieces write
//! without declaring Zenoh publishers, but each of their writers declares a querier on its key
//! (`swarm_wire::session::Writer` says why): a session is a key's publisher when it declared a
//! publisher or a querier on it. Every router of a mesh
//! answers for the sessions attached to it, so the union is the whole run. A session is named
//! by the liveliness tokens it holds: `uav3` (an agent), `uavs1-20` (an agent host), `hub`,
//! `recorder`; one holding none goes by its Zenoh id. Rates come from a subscription to
//! `swarm/R/**` held for `--window` seconds (wall time, as `ros2 topic hz` measures).
//!
//! The gathering talks to Zenoh; everything after it ([`KeySpace`], families, the table) is pure
//! and tested on admin-space replies written by hand.

use anyhow::{Context, Result};
use clap::Args;
use serde::Serialize;
use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::process::ExitCode;
use std::time::Duration;
use swarm_types::UavId;
use swarm_wire::{Keys, WireError};
use zenoh::key_expr::KeyExpr;

/// `swarm keys`.
#[derive(Args, Debug, Clone)]
pub struct KeysArgs {
    /// Run id.
    #[arg(long)]
    pub run: String,
    /// Endpoints and login (an observer's: `--user observer --password-file
    /// <run>/credentials/observer.password`).
    #[command(flatten)]
    pub zenoh: swarm_args::ZenohArgs,
    /// Seconds to listen for message rates and bandwidth (0: no rates, the graph only).
    #[arg(long, default_value_t = 2.0)]
    pub window: f64,
    /// Print JSON for scripts instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Also list each session with the keys it subscribes to and publishes.
    #[arg(long, short = 'v')]
    pub verbose: bool,
}

/// One router's admin-space entry for a key: the sessions that hold it.
#[derive(Debug, Clone, Default, PartialEq, Eq, serde::Deserialize)]
struct Sources {
    #[serde(default)]
    routers: Vec<String>,
    #[serde(default)]
    clients: Vec<String>,
    #[serde(default)]
    peers: Vec<String>,
}

/// What a run's routers hold, keyed by Zenoh session id: subscriptions, publishers and tokens
/// (keys relative to `swarm/R/`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct KeySpace {
    /// The routers that answered.
    pub routers: BTreeSet<String>,
    /// Per session, the keys it subscribes to.
    pub subscribes: BTreeMap<String, BTreeSet<String>>,
    /// Per session, the keys it declared publishers (or our writers' queriers) on.
    pub publishes: BTreeMap<String, BTreeSet<String>>,
    /// Per session, the liveliness tokens it holds.
    pub tokens: BTreeMap<String, BTreeSet<String>>,
    /// Per key family, messages and payload bytes seen in the window.
    pub traffic: BTreeMap<String, (u64, u64)>,
    /// The window's length [s] (0: no rates).
    pub window_s: f64,
}

/// What one admin-space reply says: which kind of entry, for which key, held by whom.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Entry {
    Subscriber,
    Publisher,
    Token,
}

impl KeySpace {
    /// Folds one admin-space reply: `admin_key` (`@/<router>/router/<kind>/swarm/R/<key>`) and its
    /// JSON `payload`. Replies of other kinds or runs are ignored.
    fn add_reply(&mut self, run_prefix: &str, admin_key: &str, payload: &[u8]) {
        let mut parts = admin_key.splitn(5, '/');
        let (Some("@"), Some(router), Some("router"), Some(kind), Some(rest)) =
            (parts.next(), parts.next(), parts.next(), parts.next(), parts.next())
        else {
            return;
        };
        let entry = match kind {
            "subscriber" => Entry::Subscriber,
            "publisher" | "querier" => Entry::Publisher,
            "token" => Entry::Token,
            _ => return,
        };
        let Some(key) = rest.strip_prefix(run_prefix).and_then(|k| k.strip_prefix('/')) else { return };
        let Ok(sources) = serde_json::from_slice::<Sources>(payload) else {
            tracing::debug!(admin_key, "admin reply is not a list of sources");
            return;
        };
        self.routers.insert(router.to_string());
        let map = match entry {
            Entry::Subscriber => &mut self.subscribes,
            Entry::Publisher => &mut self.publishes,
            Entry::Token => &mut self.tokens,
        };
        // Routers' own entries stand for sessions behind them, which their own router lists.
        for session in sources.clients.iter().chain(&sources.peers) {
            map.entry(session.clone()).or_default().insert(key.to_string());
        }
    }

    /// Every session that holds anything.
    fn sessions(&self) -> BTreeSet<&String> {
        self.subscribes.keys().chain(self.publishes.keys()).chain(self.tokens.keys()).collect()
    }

    /// The name of session `zid`, from the tokens it holds.
    pub fn label(&self, zid: &str) -> String {
        let tokens = self.tokens.get(zid);
        let held = |t: &str| tokens.is_some_and(|s| s.contains(t));
        let uavs: Vec<UavId> =
            tokens.into_iter().flatten().filter_map(|t| t.strip_prefix("alive/uav/")?.parse().ok()).collect();
        if held("alive/hub") {
            "hub".into()
        } else if held("alive/recorder") {
            "recorder".into()
        } else if uavs.len() == 1 {
            format!("uav{}", uavs[0])
        } else if !uavs.is_empty() {
            let mut ids = uavs;
            ids.sort_unstable();
            swarm_node::auth::host_user(&ids)
        } else {
            zid.chars().take(8).collect()
        }
    }

    /// The key families of the run: of every key published, subscribed (wildcards included) or
    /// seen in the window.
    fn families(&self) -> BTreeSet<String> {
        let keys = self.subscribes.values().chain(self.publishes.values()).flatten();
        keys.map(|k| family(k)).chain(self.traffic.keys().cloned()).filter(|f| !f.contains("**")).collect()
    }

    /// The rows of the table, one per key family.
    pub fn rows(&self) -> Vec<FamilyRow> {
        self.families().into_iter().map(|f| self.row(&f)).collect()
    }

    fn row(&self, fam: &str) -> FamilyRow {
        let pattern = family_pattern(fam);
        let holders = |map: &BTreeMap<String, BTreeSet<String>>| -> (Vec<String>, usize) {
            let mut sessions = Vec::new();
            let mut keys = 0;
            for (zid, held) in map {
                let n = held.iter().filter(|k| intersects(&pattern, k)).count();
                if n > 0 {
                    sessions.push(self.label(zid));
                    keys += n;
                }
            }
            (sessions, keys)
        };
        let (mut publishers, _) = holders(&self.publishes);
        publishers.sort_by_key(|n| natural(n));
        let (mut subscribers, subscribed_keys) = holders(&self.subscribes);
        subscribers.sort_by_key(|n| natural(n));
        let (msgs, bytes) = self.traffic.get(fam).copied().unwrap_or_default();
        let rate = |v: u64| if self.window_s > 0.0 { Some(v as f64 / self.window_s) } else { None };
        FamilyRow {
            family: fam.to_string(),
            publishers,
            subscribers,
            subscribed_keys,
            msgs_per_s: rate(msgs),
            bytes_per_s: rate(bytes),
        }
    }

    /// Each session: its name, Zenoh id, and what it subscribes to and publishes.
    pub fn session_rows(&self) -> Vec<SessionRow> {
        let mut rows: Vec<SessionRow> = self
            .sessions()
            .into_iter()
            .map(|zid| {
                let list = |m: &BTreeMap<String, BTreeSet<String>>| {
                    m.get(zid).map(|s| s.iter().cloned().collect()).unwrap_or_default()
                };
                SessionRow {
                    session: zid.clone(),
                    name: self.label(zid),
                    subscribes: list(&self.subscribes),
                    publishes: list(&self.publishes),
                }
            })
            .collect();
        rows.sort_by_key(|r| natural(&r.name));
        rows
    }
}

/// One key family's row.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FamilyRow {
    /// `uav/{id}/sense`: numeric ids written `{id}`, an agent host's id lists `{ids}`.
    pub family: String,
    /// Sessions that declared a publisher, or a writer's querier, on a key of it.
    pub publishers: Vec<String>,
    /// Sessions that subscribe to a key of it (wildcards included).
    pub subscribers: Vec<String>,
    /// Subscriptions to it over all sessions (an agent subscribes to each neighbour's share key).
    pub subscribed_keys: usize,
    /// Messages per wall second in the window (`None`: no window).
    pub msgs_per_s: Option<f64>,
    /// Payload bytes per wall second in the window.
    pub bytes_per_s: Option<f64>,
}

/// One session's row.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SessionRow {
    /// Its Zenoh id.
    pub session: String,
    /// Its name from the tokens it holds.
    pub name: String,
    /// Keys it subscribes to.
    pub subscribes: Vec<String>,
    /// Keys it publishes.
    pub publishes: Vec<String>,
}

/// The family of `key` (relative to `swarm/R/`): every chunk that is a UAV id, or a `*` in its
/// place, becomes `{id}`; an agent host's list of UAVs (`1-4,7`, or one id, or a `*`, after
/// `host`) becomes `{ids}`.
pub fn family(key: &str) -> String {
    let digits = |c: &str| !c.is_empty() && c.bytes().all(|b| b.is_ascii_digit());
    let id_list = |c: &str| {
        c.bytes().any(|b| b.is_ascii_digit()) && c.bytes().all(|b| b.is_ascii_digit() || b == b'-' || b == b',')
    };
    let chunks: Vec<&str> = key.split('/').collect();
    chunks
        .iter()
        .enumerate()
        .map(|(i, &c)| {
            // The chunk after `host` names an agent host's UAVs, one or many, or any host's (`*`).
            let host = i > 0 && chunks[i - 1] == "host";
            match c {
                _ if host && (c == "*" || id_list(c)) => "{ids}",
                "*" => "{id}",
                c if digits(c) => "{id}",
                c if id_list(c) => "{ids}",
                c => c,
            }
        })
        .collect::<Vec<_>>()
        .join("/")
}

/// A name's sort key with its digits read as a number: `uav2` before `uav10`.
fn natural(name: &str) -> (String, u64, String) {
    let head: String = name.chars().take_while(|c| !c.is_ascii_digit()).collect();
    let digits: String = name[head.len()..].chars().take_while(char::is_ascii_digit).collect();
    let tail = name[head.len() + digits.len()..].to_string();
    (head, digits.parse().unwrap_or(0), tail)
}

/// A family as a key expression (`{id}` and `{ids}` → `*`).
fn family_pattern(fam: &str) -> String {
    fam.replace("{ids}", "*").replace("{id}", "*")
}

/// Whether key expressions `a` and `b` (relative keys, any wildcards) intersect.
fn intersects(a: &str, b: &str) -> bool {
    match (KeyExpr::try_from(a), KeyExpr::try_from(b)) {
        (Ok(a), Ok(b)) => a.intersects(&b),
        _ => false,
    }
}

/// Runs `swarm keys`.
pub async fn keys(a: KeysArgs) -> Result<ExitCode> {
    anyhow::ensure!(!a.zenoh.connect.is_empty(), "keys needs --connect <hub endpoint>");
    anyhow::ensure!((0.0..=3600.0).contains(&a.window), "--window {}: seconds from 0 (no rates) to 3600", a.window);
    let keys = Keys::new(&a.run)?;
    let s = a.zenoh.open_tool_session().await?;
    let gathered = gather(&s, &keys, a.window).await;
    let _ = s.close().await;
    let space = gathered?;
    anyhow::ensure!(
        !space.routers.is_empty(),
        "no router answered for run `{}`: is the run live, and is this login an observer's (`--user observer --password-file <run>/credentials/observer.password`)?",
        a.run
    );
    if a.json {
        let out = serde_json::json!({
            "run": a.run,
            "routers": space.routers,
            "window_s": space.window_s,
            "families": space.rows(),
            "sessions": space.session_rows(),
        });
        swarm_node::process::out(&serde_json::to_string_pretty(&out)?);
    } else {
        print!("{}", table(&a.run, &space, a.verbose));
    }
    Ok(ExitCode::SUCCESS)
}

/// Reads the routers' admin space, then listens to the run for `window` seconds.
async fn gather(s: &zenoh::Session, keys: &Keys, window: f64) -> Result<KeySpace> {
    let prefix = keys.prefix().to_string();
    let mut space = KeySpace::default();
    for kind in ["subscriber", "publisher", "querier", "token"] {
        let selector = format!("@/*/router/{kind}/{prefix}/**");
        let replies = s
            .get(&selector)
            .timeout(Duration::from_secs(3))
            .await
            .map_err(WireError::zenoh)
            .with_context(|| format!("query {selector}"))?;
        while let Ok(r) = replies.recv_async().await {
            match r.result() {
                Ok(sample) => space.add_reply(&prefix, sample.key_expr().as_str(), &sample.payload().to_bytes()),
                Err(e) => tracing::warn!("{selector}: {}", String::from_utf8_lossy(&e.payload().to_bytes())),
            }
        }
    }
    if window > 0.0 {
        space.window_s = window;
        space.traffic = listen(s, &prefix, window).await?;
    }
    Ok(space)
}

/// Messages and payload bytes per key family on `prefix/**` for `window` seconds.
async fn listen(s: &zenoh::Session, prefix: &str, window: f64) -> Result<BTreeMap<String, (u64, u64)>> {
    let counts = std::sync::Arc::new(std::sync::Mutex::new(BTreeMap::<String, (u64, u64)>::new()));
    let (c, cut) = (counts.clone(), prefix.len() + 1);
    let sub = s
        .declare_subscriber(format!("{prefix}/**"))
        .callback(move |sample| {
            let key = sample.key_expr().as_str();
            let fam = family(key.get(cut..).unwrap_or(key));
            let mut m = c.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
            let e = m.entry(fam).or_default();
            e.0 += 1;
            e.1 += sample.payload().len() as u64;
        })
        .await
        .map_err(WireError::zenoh)?;
    tokio::time::sleep(Duration::from_secs_f64(window)).await;
    drop(sub);
    let m = counts.lock().unwrap_or_else(std::sync::PoisonError::into_inner).clone();
    Ok(m)
}

/// At most `n` names, then how many more.
fn some(names: &[String], n: usize) -> String {
    if names.is_empty() {
        return "-".into();
    }
    let mut s = names.iter().take(n).cloned().collect::<Vec<_>>().join(", ");
    if names.len() > n {
        let _ = write!(s, " +{} more", names.len() - n);
    }
    s
}

/// The table of `space` for run `run`, with each session's keys when `verbose`.
pub fn table(run: &str, space: &KeySpace, verbose: bool) -> String {
    let mut t = String::new();
    let sessions = space.sessions();
    let _ = writeln!(t, "run {run}: {} router(s), {} sessions", space.routers.len(), sessions.len());
    let _ = writeln!(
        t,
        "{:<28} {:>5} {:>5} {:>6} {:>9} {:>10}  publishers / subscribers",
        "key family", "pubs", "subs", "keys", "msg/s", "kB/s"
    );
    for r in space.rows() {
        let rate = |v: Option<f64>, scale: f64| v.map_or_else(|| "-".into(), |v| format!("{:.1}", v / scale));
        let _ = writeln!(
            t,
            "{:<28} {:>5} {:>5} {:>6} {:>9} {:>10}  {} / {}",
            r.family,
            r.publishers.len(),
            r.subscribers.len(),
            r.subscribed_keys,
            rate(r.msgs_per_s, 1.0),
            rate(r.bytes_per_s, 1000.0),
            some(&r.publishers, 3),
            some(&r.subscribers, 3)
        );
    }
    if verbose {
        let _ = writeln!(t, "\nsessions:");
        for s in space.session_rows() {
            let _ = writeln!(
                t,
                "{} ({})\n  subscribes: {}\n  publishes:  {}",
                s.name,
                s.session,
                s.subscribes.join(" "),
                s.publishes.join(" ")
            );
        }
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    const P: &str = "swarm/r";

    /// A run as two routers' admin spaces say it: the hub (`h`), agents 1 and 2 on their own
    /// sessions (`a1`, `a2`) and a host of 3 and 4 (`hh`) behind a second router, a recorder.
    fn space() -> KeySpace {
        let mut s = KeySpace::default();
        let mut add = |admin: &str, json: &str| s.add_reply(P, admin, json.as_bytes());
        add("@/h/router/token/swarm/r/alive/hub", r#"{"routers":[],"peers":[],"clients":["h"]}"#);
        add("@/h/router/token/swarm/r/alive/uav/1", r#"{"clients":["a1"]}"#);
        add("@/h/router/token/swarm/r/alive/uav/2", r#"{"clients":["a2"]}"#);
        add("@/x/router/token/swarm/r/alive/uav/3", r#"{"clients":["hh"]}"#);
        add("@/x/router/token/swarm/r/alive/uav/4", r#"{"clients":["hh"]}"#);
        add("@/h/router/token/swarm/r/alive/recorder", r#"{"clients":["rec"]}"#);
        add("@/h/router/publisher/swarm/r/uav/1/sense", r#"{"clients":["h"]}"#);
        add("@/h/router/publisher/swarm/r/uav/2/sense", r#"{"clients":["h"]}"#);
        add("@/h/router/subscriber/swarm/r/uav/1/sense", r#"{"clients":["a1"]}"#);
        add("@/h/router/subscriber/swarm/r/uav/2/sense", r#"{"clients":["a2"]}"#);
        add("@/h/router/subscriber/swarm/r/uav/*/sense", r#"{"clients":["rec"]}"#);
        add("@/h/router/querier/swarm/r/uav/1/share/pose", r#"{"clients":["a1"]}"#);
        add("@/h/router/subscriber/swarm/r/uav/1/share/pose", r#"{"routers":["x"],"clients":["a2"]}"#);
        add("@/x/router/subscriber/swarm/r/uav/1/share/pose", r#"{"clients":["hh"]}"#);
        add("@/x/router/subscriber/swarm/r/uav/2/share/pose", r#"{"clients":["hh"]}"#);
        add("@/h/router/subscriber/swarm/other/uav/2/share/pose", r#"{"clients":["zz"]}"#);
        add("@/h/router/queryable/swarm/r/scenario", r#"{"clients":["h"]}"#);
        add("@/h/router/subscriber/swarm/r/truth/**", "not json");
        s
    }

    #[test]
    fn families_write_ids_and_their_wildcards_alike() {
        assert_eq!(family("uav/12/sense"), "uav/{id}/sense");
        assert_eq!(family("uav/*/share/pose"), "uav/{id}/share/pose");
        assert_eq!(family("alive/uav/3"), "alive/uav/{id}");
        assert_eq!(family("host/1-4,7/sense"), "host/{ids}/sense", "an agent host's UAVs");
        assert_eq!(family("alive/host/12"), "alive/host/{ids}", "a host of one UAV");
        assert_eq!(family("host/*/cmd"), "host/{ids}/cmd", "the hub's subscription to every host's");
        assert_eq!(family("uav/*/cmd"), "uav/{id}/cmd");
        assert_eq!(family("truth/step"), "truth/step");
        assert_eq!(family("truth/**"), "truth/**");
    }

    #[test]
    fn sessions_are_named_by_their_tokens() {
        let s = space();
        assert_eq!(s.label("h"), "hub");
        assert_eq!(s.label("a1"), "uav1");
        assert_eq!(s.label("hh"), "uavs3-4");
        assert_eq!(s.label("rec"), "recorder");
        assert_eq!(s.label("0123456789abcdef"), "01234567");
        assert_eq!(
            s.routers,
            ["h", "x"].map(String::from).into(),
            "both routers answered; other runs, queryables and bad JSON ignored"
        );
        assert!(!s.subscribes.contains_key("zz"));
    }

    #[test]
    fn a_row_has_the_family_s_publishers_subscribers_and_rate() {
        let mut s = space();
        s.window_s = 2.0;
        s.traffic.insert("uav/{id}/share/pose".into(), (40, 4000));
        let rows = s.rows();
        let names: Vec<&str> = rows.iter().map(|r| r.family.as_str()).collect();
        assert_eq!(names, ["uav/{id}/sense", "uav/{id}/share/pose"]);
        let sense = &rows[0];
        assert_eq!(sense.publishers, ["hub"]);
        assert_eq!(sense.subscribers, ["recorder", "uav1", "uav2"]);
        assert_eq!((sense.subscribed_keys, sense.msgs_per_s), (3, Some(0.0)));
        let pose = &rows[1];
        assert_eq!(pose.publishers, ["uav1"]);
        assert_eq!(pose.subscribers, ["uav2", "uavs3-4"], "the host once, with its two senders");
        let names: Vec<String> = s.session_rows().into_iter().map(|r| r.name).collect();
        assert_eq!(names, ["hub", "recorder", "uav1", "uav2", "uavs3-4"]);
        let mut by_number = vec!["uav10".to_string(), "uav9".into(), "hub".into()];
        by_number.sort_by_key(|n| natural(n));
        assert_eq!(by_number, ["hub", "uav9", "uav10"]);
        assert_eq!((pose.subscribed_keys, pose.msgs_per_s, pose.bytes_per_s), (3, Some(20.0), Some(2000.0)));
        let t = table("r", &s, true);
        assert!(t.contains("uav/{id}/share/pose") && t.contains("uavs3-4 (hh)"), "{t}");
    }
}

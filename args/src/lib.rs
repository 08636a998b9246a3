//! What every command shares, below all of them: the Zenoh endpoints and login flattened into
//! each command that opens a session, the ROS 2 graph a piece joins, run ids, UAV id lists
//! (`1-4,7`), and command-line values spelled as in the scenario file. A crate of its own, below
//! the pieces (`swarm-node`), the recorder and the viewer, so a tool that only watches a run
//! links none of the hub or the agent for its arguments.

use anyhow::Result;
use clap::Args;
use swarm_types::UavId;

/// Endpoints and overrides shared by every piece that opens a Zenoh session.
#[derive(Args, Debug, Clone, Default)]
pub struct ZenohArgs {
    /// Endpoint to connect to, e.g. `tcp/10.0.0.5:7447` (repeatable).
    #[arg(long = "connect", short = 'e')]
    pub connect: Vec<String>,
    /// Endpoint to listen on, e.g. `tcp/0.0.0.0:7447` (repeatable; the hub only).
    #[arg(long = "listen", short = 'l')]
    pub listen: Vec<String>,
    /// Zenoh config override `KEY:JSON5`, e.g. `transport/link/tx/lease:3000` (repeatable).
    #[arg(long = "cfg")]
    pub cfg: Vec<String>,
    /// User to log in to the hub as (`uav3`, `uavs1-20`, `observer`, `operator`; see
    /// docs/security.md), with `--password-file`.
    #[arg(long, requires = "password_file")]
    pub user: Option<String>,
    /// File whose first line is the password of `--user` (`swarm run` writes one per user in
    /// `<run folder>/credentials/`).
    #[arg(long, requires = "user")]
    pub password_file: Option<std::path::PathBuf>,
}

impl ZenohArgs {
    /// The Zenoh config overrides of this piece's session: the login of `--user`, if any, then
    /// the `--cfg` overrides.
    pub fn session_cfg(&self) -> Result<Vec<String>> {
        let mut cfg = match (&self.user, &self.password_file) {
            (Some(user), Some(file)) => usrpwd_cfg(user, &read_password(file)?),
            _ => Vec::new(),
        };
        cfg.extend(self.cfg.iter().cloned());
        Ok(cfg)
    }

    /// A tool's client session (`tap`, `put`, `keys`, `netem`, `view`): it waits
    /// [`TOOL_CONNECT_S`] for the hub (not a piece's 30 s: a person is waiting), and when it
    /// cannot connect the error says why in our words. Zenoh reports a refused login only as
    /// refused handshakes, so the endpoints are probed: one that accepts a TCP connection is a hub
    /// that refused this session (the login is wrong, or missing: a `swarm run` hub wants one);
    /// none is no hub there.
    pub async fn open_tool_session(&self) -> Result<zenoh::Session> {
        let mut cfg = vec![format!("connect/timeout_ms:{}", TOOL_CONNECT_S * 1000)];
        cfg.extend(self.session_cfg()?);
        let opened = swarm_wire::session::open(swarm_wire::session::Role::Client, &[], &self.connect, &cfg).await;
        opened.map_err(|e| anyhow::anyhow!("{}", self.why_not_connected(&e.to_string())))
    }

    /// Why a tool could not connect, from probing its endpoints.
    fn why_not_connected(&self, zenoh: &str) -> String {
        let listening: Vec<&String> = self.connect.iter().filter(|e| tcp_accepts(e)).collect();
        let endpoints = self.connect.join(", ");
        match (listening.is_empty(), &self.user) {
            (true, _) => format!(
                "cannot connect to {endpoints}: nothing accepts a connection there; is the hub up, and is this its endpoint (the run folder's hub.txt)? ({zenoh})"
            ),
            (false, None) => format!(
                "the hub at {endpoints} refused this session: it wants a login (a `swarm run` hub does): \
                 --user observer --password-file <run folder>/credentials/observer.password"
            ),
            (false, Some(user)) => format!(
                "the hub at {endpoints} refused to let {user:?} in: the user or its password is not this run's \
                 (`swarm run` makes fresh ones each run, in <run folder>/credentials/)"
            ),
        }
    }
}

/// How long a tool waits for the hub [s].
pub const TOOL_CONNECT_S: u64 = 10;

/// Whether a `tcp/HOST:PORT` endpoint accepts a TCP connection within a second.
fn tcp_accepts(endpoint: &str) -> bool {
    use std::net::ToSocketAddrs;
    let Some(addr) = endpoint.strip_prefix("tcp/") else { return false };
    let addr = addr.split('#').next().unwrap_or(addr);
    addr.to_socket_addrs()
        .ok()
        .into_iter()
        .flatten()
        .any(|a| std::net::TcpStream::connect_timeout(&a, std::time::Duration::from_secs(1)).is_ok())
}

/// Which ROS 2 graph a piece joins: its middleware and domain (`swarm ros2`, `swarm run --ros2`,
/// `swarm agent --sensors ros2`).
#[derive(Args, Debug, Clone, Default, PartialEq, Eq)]
pub struct RosArgs {
    /// ROS 2 domain id (ROS's `ROS_DOMAIN_ID`).
    #[arg(long = "ros-domain", visible_alias = "domain", env = "ROS_DOMAIN_ID", default_value_t = 0)]
    pub domain: u32,
    /// Speak DDS, what a stock ROS 2 install (Fast DDS) speaks, instead of rmw_zenoh's keys on
    /// the hub's router.
    #[arg(long)]
    pub dds: bool,
    /// DDS on the loopback interface only; also set by ROS's own
    /// `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST` (or Humble's `ROS_LOCALHOST_ONLY=1`).
    #[arg(long)]
    pub localhost: bool,
}

impl RosArgs {
    /// Whether DDS keeps to 127.0.0.1: `--localhost`, or ROS's environment says so.
    pub fn localhost_only(&self) -> bool {
        let env = |k: &str| std::env::var(k).unwrap_or_default();
        self.localhost
            || env("ROS_AUTOMATIC_DISCOVERY_RANGE").eq_ignore_ascii_case("localhost")
            || env("ROS_LOCALHOST_ONLY") == "1"
    }
}

/// The first line of a password file, trimmed; an empty one is an error.
pub fn read_password(file: &std::path::Path) -> Result<String> {
    let text = std::fs::read_to_string(file)
        .map_err(|e| anyhow::anyhow!("cannot read password file {}: {e}", file.display()))?;
    let password = text.lines().next().unwrap_or_default().trim().to_string();
    anyhow::ensure!(!password.is_empty(), "password file {} is empty", file.display());
    Ok(password)
}

/// The `--cfg` overrides that log a client session in as `user` (Zenoh's usrpwd).
pub fn usrpwd_cfg(user: &str, password: &str) -> Vec<String> {
    let quote = |s: &str| serde_json::Value::String(s.to_string()).to_string();
    vec![
        format!("transport/auth/usrpwd/user:{}", quote(user)),
        format!("transport/auth/usrpwd/password:{}", quote(password)),
    ]
}

/// Seconds since the Unix epoch (run ids and study folders).
pub fn unix_secs() -> u64 {
    std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs())
}

/// `<name>-<unix seconds>-<pid>`: unique per run on a machine.
pub fn default_run_id(name: &str) -> String {
    format!("{name}-{}-{}", unix_secs(), std::process::id())
}

/// A command-line value for a scenario enum, spelled as in the scenario file (`"realtime"`,
/// `"a21"`, …); the error lists the accepted spellings.
pub fn scenario_value<T: serde::de::DeserializeOwned>(flag: &str, value: &str) -> Result<T> {
    use serde::de::IntoDeserializer;
    T::deserialize(value.trim().into_deserializer())
        .map_err(|e: serde::de::value::Error| anyhow::anyhow!("{flag}: {e}"))
}

/// UAV ids given as ranges and lists: `1-4,7`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UavIds(pub Vec<UavId>);

/// Parses `1-4,7` into `[1, 2, 3, 4, 7]`: ascending ranges, no repeats, ids from 1
/// ([`swarm_types::parse_ids`], as a clap value).
pub fn parse_ids(text: &str) -> Result<UavIds, String> {
    swarm_types::parse_ids(text).map(UavIds)
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

    #[test]
    fn ids_take_ranges_and_lists() {
        assert_eq!(parse_ids("1-4,7"), Ok(UavIds([1, 2, 3, 4, 7].map(UavId::new).to_vec())));
        assert_eq!(parse_ids("5"), Ok(UavIds(vec![UavId::new(5)])));
        assert!(parse_ids("0-3").is_err());
        assert!(parse_ids("4-2").is_err());
        assert!(parse_ids("1-3,2").expect_err("twice").contains("twice"));
        assert!(parse_ids("1,x").expect_err("not a number").contains("`x`"));
    }
}

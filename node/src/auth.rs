//! Who may touch what: Zenoh user/password authentication and access control, enforced by the
//! hub's router (the one place all traffic passes: agents and tools are its clients, and
//! multicast scouting and gossip are off everywhere, so nothing routes around it).
//!
//! A user's role is read from its name, so the hub needs nothing but the dictionary file of
//! `user:password` lines to build its rules ([`router_cfg`]):
//! - `uav{id}`: one agent. It may subscribe to its own `uav/{id}/sense` (its sensor frames),
//!   `clock`, `netem/rules` and every UAV's `share/**`, ask for `scenario`, watch `alive/hub`;
//!   publish only its own `cmd`, `share/**` and `state`; hold only `alive/uav/{id}`. Nothing
//!   else, `truth/**` least of all (the default is deny). In a run with a ROS side (a `bridge`
//!   user) it may also read its own ROS topics `*/uav{id}/{scan,odom,goal}` and put its own
//!   `*/uav{id}/{cmd_vel,cmd_accel}`, as an agent on ROS topics over rmw_zenoh does.
//! - `uavs{ids}` (`uavs1-20`, `uavs1-4,7`, the `--ids` syntax): an agent host, one session for
//!   several UAVs, allowed exactly what each of those UAVs is, and the host's own keys of
//!   exactly those UAVs: its sensor frames in one message, `host/{ids}/sense`, its commands and
//!   states in one message each, `host/{ids}/cmd` and `host/{ids}/state`, and its token
//!   `alive/host/{ids}`. The same user serves a second
//!   router that relays a group of agents to the hub.
//! - `ext{id}`: UAV `id`'s external controller (docs/own-controller.md). It may
//!   subscribe to `uav/{id}/ext/view`, put only `uav/{id}/ext/cmd`, hold only `alive/ext/{id}`,
//!   watch `alive/hub` (to know the run is over); nothing else of the run (not even the scenario).
//! - `bridge`: the ROS 2 bridge (`swarm ros2`): an observer that also puts the ROS 2 topics
//!   (each UAV's `scan`, `odom`, `goal`, `neighbours`; `clock`, `tf`, and the truth topics
//!   `tf_static` and `world/**`), reads `cmd_vel` and `cmd_accel`, holds `@ros2_lv/**` tokens,
//!   is the external controller of every UAV (`uav/*/ext/view` in, `uav/*/ext/cmd` out,
//!   `alive/ext/*`). As `bridge-uavs{ids}` it also drives the bodies of those UAVs, whose agents
//!   run on ROS topics: it may put their `uav/{id}/cmd`, and no other UAV's.
//! - `ros` (or `ros-NAME`): a ROS 2 machine on rmw_zenoh: it may read every ROS topic but the
//!   truth ones, put `cmd_vel` only of the scenario's external UAVs, and hold and read the
//!   `@ros2_lv/**` tokens of the ROS graph; nothing of the run's own keys.
//! - `controller` (or `controller-NAME`): the external controller of every external UAV that
//!   also observes the run (a learning environment reads its rewards from the truth): what an
//!   observer may, and `uav/*/ext/cmd` out, `uav/*/ext/view` in, the `alive/ext/*` tokens.
//! - `observer` (or `observer-NAME`): reads every key of the run, every ROS 2 topic (truth
//!   among them) and the routers' admin space
//!   (`@/**`, read-only: who subscribes to what, for `swarm keys`), publishes nothing; it may hold
//!   `alive/recorder` (the recorder is an observer).
//! - `operator` (or `operator-NAME`): an observer that may also put on `netem/add`.
//!
//! Every rule is written for both directions: what a client may send or declare (ingress) and
//! what the router forwards to it (egress). Declarations of subscribers and queryables flow to
//! everyone (clients need them to know a publication has a reader; they carry no data).
//!
//! One exception keeps the router cheap at 1000 UAVs: the egress rule for sensor data is one
//! wildcard for every agent (`uav/*/sense`), not a list of each user's own keys. Zenoh admits a
//! subscriber only if its key is *included* in a key its user may subscribe to (a broader
//! subscription, such as `uav/*/sense` or `**`, is refused whole, and another UAV's
//! `uav/{id}/sense` too: tested in `tests/tests/security.rs`), and data reaches a client only
//! through its subscribers, so a user's ingress list already bounds what it receives. The
//! per-user egress list cost the router a walk of two keys per UAV of a host for every share it
//! forwarded to that host (those decisions are not cached): 18–35 % of the hub's CPU on
//! open-1000 (docs/performance.md).
//!
//! [`Credentials`] makes fresh users and passwords: `swarm run` for each run (in the run folder,
//! readable by its owner only), `swarm credentials` for pieces started by hand.

use anyhow::{bail, Context, Result};
use clap::Args;
use serde_json::{json, Value};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use swarm_args::parse_ids;
pub use swarm_types::ids_text;
use swarm_types::UavId;
use swarm_wire::Keys;

/// The dictionary file's name in a credentials folder.
pub const DICTIONARY: &str = "users.txt";

/// What a user may do, read from its name.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Role {
    /// Agents of these UAVs (one, or an agent host's).
    Agents(Vec<UavId>),
    /// UAV `id`'s external controller.
    External(UavId),
    /// The ROS 2 bridge, driving the bodies of these UAVs (whose agents run on ROS topics).
    Bridge(Vec<UavId>),
    /// A ROS 2 machine.
    Ros,
    /// The external controller of every external UAV, which observes the run too (a learning
    /// environment: `uavswarm`'s Python environments).
    Controller,
    /// Reads everything, publishes nothing.
    Observer,
    /// An observer that may also add netem timelines.
    Operator,
}

impl Role {
    /// The role of user `name`, or an error saying which names are understood.
    pub fn of(name: &str) -> Result<Role> {
        let named = |role: &str| name == role || name.strip_prefix(role).is_some_and(|r| r.starts_with('-'));
        if named("observer") {
            return Ok(Role::Observer);
        }
        if named("operator") {
            return Ok(Role::Operator);
        }
        if name == "bridge" {
            return Ok(Role::Bridge(Vec::new()));
        }
        if let Some(spec) = name.strip_prefix("bridge-uavs") {
            return parse_ids(spec).map(|ids| Role::Bridge(ids.0)).map_err(|e| anyhow::anyhow!("user {name:?}: {e}"));
        }
        if named("ros") {
            return Ok(Role::Ros);
        }
        if named("controller") {
            return Ok(Role::Controller);
        }
        if let Some(spec) = name.strip_prefix("uavs") {
            return parse_ids(spec).map(|ids| Role::Agents(ids.0)).map_err(|e| anyhow::anyhow!("user {name:?}: {e}"));
        }
        if let Some(id) = name.strip_prefix("uav").and_then(|n| n.parse::<UavId>().ok()) {
            return Ok(Role::Agents(vec![id]));
        }
        if let Some(id) = name.strip_prefix("ext").and_then(|n| n.parse::<UavId>().ok()) {
            return Ok(Role::External(id));
        }
        bail!("user {name:?} has no role: names are uav<id>, uavs<ids> (e.g. uavs1-4,7), ext<id>, bridge, bridge-uavs<ids>, ros[-name], controller[-name], observer[-name], operator[-name]")
    }
}

/// The user name of UAV `id`'s own agent: `uav7`.
pub fn uav_user(id: UavId) -> String {
    format!("uav{id}")
}

/// The user name of UAV `id`'s external controller: `ext7`.
pub fn ext_user(id: UavId) -> String {
    format!("ext{id}")
}

/// The user name of the ROS 2 bridge, which drives the bodies of `ids` (ascending; agents on ROS
/// topics): `bridge`, or `bridge-uavs3`.
pub fn bridge_user(ids: &[UavId]) -> String {
    match ids {
        [] => "bridge".to_string(),
        _ => format!("bridge-uavs{}", ids_text(ids)),
    }
}

/// The user name of an agent host serving `ids` (ascending): `uavs1-4,7`.
pub fn host_user(ids: &[UavId]) -> String {
    format!("uavs{}", ids_text(ids))
}

/// A folder of fresh credentials: the hub's dictionary and one password file per user, all
/// readable by the owner only.
#[derive(Debug, Clone)]
pub struct Credentials {
    dir: PathBuf,
}

impl Credentials {
    /// Writes a random password for each of `users` into `dir` (made if missing, mode 0700):
    /// `users.txt` (`user:password` lines, the hub's `--users`) and `<user>.password`.
    pub fn create(dir: &Path, users: &[String]) -> Result<Credentials> {
        use std::os::unix::fs::{DirBuilderExt, PermissionsExt};
        std::fs::DirBuilder::new()
            .recursive(true)
            .mode(0o700)
            .create(dir)
            .with_context(|| format!("cannot create {}", dir.display()))?;
        std::fs::set_permissions(dir, std::fs::Permissions::from_mode(0o700))?;
        let creds = Credentials { dir: dir.to_path_buf() };
        let mut dictionary = String::new();
        for user in users {
            Role::of(user)?;
            let password = random_password()?;
            dictionary.push_str(&format!("{user}:{password}\n"));
            write_private(&creds.password_file(user), &format!("{password}\n"))?;
        }
        write_private(&creds.dictionary(), &dictionary)?;
        Ok(creds)
    }

    /// The password file of `user` (`<dir>/<user>.password`): the one place in this crate its
    /// name is made (the end-to-end tests, outside it, write theirs themselves).
    pub fn password_file(&self, user: &str) -> PathBuf {
        self.dir.join(format!("{user}.password"))
    }

    /// The dictionary file (`user:password` lines) the hub reads.
    pub fn dictionary(&self) -> PathBuf {
        self.dir.join(DICTIONARY)
    }

    /// A dictionary of `user`'s line alone (`users-<user>.txt`, 0600), for a relay router whose
    /// agents log in as that user.
    pub fn dictionary_of(&self, user: &str) -> Result<PathBuf> {
        let all = std::fs::read_to_string(self.dictionary())?;
        let line = all
            .lines()
            .find(|l| l.split_once(':').is_some_and(|(u, _)| u == user))
            .with_context(|| format!("no user {user:?} in {}", self.dictionary().display()))?;
        let path = self.dir.join(format!("users-{user}.txt"));
        write_private(&path, &format!("{line}\n"))?;
        Ok(path)
    }

    /// `--user USER --password-file FILE`, for a child of the launcher.
    pub fn client_args(&self, user: &str) -> [String; 4] {
        let file = self.password_file(user);
        ["--user".into(), user.into(), "--password-file".into(), file.to_string_lossy().into_owned()]
    }

    /// The `--cfg` overrides of a client session logged in as `user`.
    pub fn client_cfg(&self, user: &str) -> Result<Vec<String>> {
        let password = swarm_args::read_password(&self.password_file(user))?;
        Ok(swarm_args::usrpwd_cfg(user, &password))
    }
}

/// 128 random bits from the kernel, as hex.
fn random_password() -> Result<String> {
    use std::io::Read;
    let mut bytes = [0u8; 16];
    std::fs::File::open("/dev/urandom")
        .and_then(|mut f| f.read_exact(&mut bytes))
        .context("cannot read /dev/urandom")?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}

/// Writes `text` to a new file only its owner can read (0600).
fn write_private(path: &Path, text: &str) -> Result<()> {
    use std::os::unix::fs::OpenOptionsExt;
    let _ = std::fs::remove_file(path);
    let mut f = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .mode(0o600)
        .open(path)
        .with_context(|| format!("cannot create {}", path.display()))?;
    f.write_all(text.as_bytes()).with_context(|| format!("cannot write {}", path.display()))
}

/// The user names of a dictionary file (`user:password` lines; blank lines skipped).
pub(crate) fn users_of(dictionary: &Path) -> Result<Vec<String>> {
    let text = std::fs::read_to_string(dictionary).with_context(|| format!("cannot read {}", dictionary.display()))?;
    text.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .map(|l| {
            l.split_once(':')
                .map(|(u, _)| u.trim().to_string())
                .with_context(|| format!("{}: a line is not user:password", dictionary.display()))
        })
        .collect()
}

/// The hub router's `--cfg` overrides for run `run`: the dictionary, and access control with a
/// rule set per user of it (see the module doc), default deny.
pub fn router_cfg(run: &str, dictionary: &Path, external: &[UavId]) -> Result<Vec<String>> {
    let users = users_of(dictionary)?;
    let acl = access_control(run, &users, external)?;
    let path = serde_json::to_string(&dictionary.to_string_lossy())?;
    Ok(vec![format!("transport/auth/usrpwd/dictionary_file:{path}"), format!("access_control:{acl}")])
}

/// One ACL rule: `permission: allow` for `messages` in `flow` on `keys`.
fn rule(id: &str, flow: &str, messages: &[&str], keys: Vec<String>) -> Value {
    json!({ "id": id, "permission": "allow", "flows": [flow], "messages": messages, "key_exprs": keys })
}

/// The `access_control` section for `users` of run `run`.
fn access_control(run: &str, users: &[String], external: &[UavId]) -> Result<Value> {
    let k = Keys::new(run)?;
    let read = ["declare_subscriber", "query", "liveliness_query", "declare_liveliness_subscriber"];
    let mut rules = vec![
        // Everyone: declarations flow out (a client's publisher needs to see its readers).
        rule("decl-out", "egress", &["declare_subscriber", "declare_queryable"], vec![k.all()]),
        // Observers and operators.
        rule("observe-in", "ingress", &read, vec![k.all()]),
        rule("observe-out", "egress", &["put", "delete", "reply", "liveliness_token"], vec![k.all()]),
        // Observers and operators may read the routers' admin space (`swarm keys`).
        rule("observe-admin-in", "ingress", &["query"], vec!["@/**".into()]),
        rule("observe-admin-out", "egress", &["reply"], vec!["@/**".into()]),
        rule("recorder-token", "ingress", &["liveliness_token"], vec![k.alive_recorder()]),
        rule("operate", "ingress", &["put"], vec![k.netem_add()]),
        // Every agent: the run-wide keys, and its neighbours' shares.
        rule("agent-sub", "ingress", &["declare_subscriber"], agent_common_keys(&k)),
        rule("agent-data", "egress", &["put"], agent_common_keys(&k)),
        // Bounded by each agent's own ingress list, as the sensors (see the module doc).
        rule("agent-sensors-out", "egress", &["put"], vec![k.sense_any(), k.host_sense_any(), k.ext_cmd_any()]),
        rule("agent-ext-token", "egress", &["liveliness_token"], vec![k.alive_ext_any()]),
        rule("agent-ask", "ingress", &["query"], vec![k.scenario()]),
        rule("agent-answer", "egress", &["reply"], vec![k.scenario()]),
        rule("agent-hub-watch", "ingress", &["declare_liveliness_subscriber", "liveliness_query"], vec![k.alive_hub()]),
        rule("agent-hub-token", "egress", &["liveliness_token"], vec![k.alive_hub()]),
        // External controllers: their view, bounded by each one's own ingress list.
        rule("ext-view-out", "egress", &["put"], vec![k.ext_view_any()]),
    ];
    rules.extend(ros_rules(&k, external));
    // Agents get ROS rules only in a run with a ROS side (a bridge): the router's rules grow with
    // the agents, and a run of 1000 without ROS keeps its lists short.
    let ros_side = users.iter().any(|u| matches!(Role::of(u), Ok(Role::Bridge(_))));
    let mut subjects = Vec::new();
    let mut policies = Vec::new();
    let mut seen = BTreeMap::new();
    for (n, user) in users.iter().enumerate() {
        if seen.insert(user.clone(), ()).is_some() {
            bail!("user {user:?} appears twice in the dictionary");
        }
        let subject = format!("user{n}");
        subjects.push(json!({ "id": subject, "usernames": [user] }));
        let granted: Vec<String> = match Role::of(user)? {
            Role::Bridge(ids) => {
                if !ids.is_empty() {
                    let cmds = ids.iter().map(|i| k.cmd(*i)).collect();
                    rules.push(rule(&format!("{subject}-bridge-cmd"), "ingress", &["put"], cmds));
                }
                bridge_rules(&subject, !ids.is_empty())
            }
            Role::Controller => {
                ["decl-out", "observe-in", "observe-out", "ext-view-out", "bridge-ext-in", "bridge-ext-token"]
                    .map(String::from)
                    .to_vec()
            }
            Role::Ros => ["ros-in", "ros-out", "ros-graph-in", "ros-graph-out", "ros-decl-out"]
                .into_iter()
                .chain((!external.is_empty()).then_some("ros-cmd"))
                .map(String::from)
                .collect(),
            Role::Observer => {
                ["decl-out", "observe-in", "observe-out", "observe-admin-in", "observe-admin-out", "recorder-token"]
                    .into_iter()
                    .chain(ROS_READER)
                    .map(String::from)
                    .collect()
            }
            Role::Operator => [
                "decl-out",
                "observe-in",
                "observe-out",
                "observe-admin-in",
                "observe-admin-out",
                "recorder-token",
                "operate",
            ]
            .into_iter()
            .chain(ROS_READER)
            .map(String::from)
            .collect(),
            Role::External(id) => {
                rules.extend(external_rules(&k, &subject, id));
                ["decl-out", "ext-view-out", "agent-hub-watch", "agent-hub-token"]
                    .iter()
                    .map(|s| s.to_string())
                    .chain(["sub", "pub", "token"].map(|k| format!("{subject}-ext-{k}")))
                    .collect()
            }
            Role::Agents(ids) => {
                rules.extend(own_rules(&k, &subject, &ids));
                let mut own: Vec<String> = ["own-sub", "own-pub", "own-token", "own-ext-watch"]
                    .iter()
                    .map(|k| format!("{subject}-{k}"))
                    .collect();
                if ros_side {
                    rules.extend(ros_agent_rules(&subject, &ids));
                    own.extend(["ros-sub", "ros-pub"].map(|k| format!("{subject}-{k}")));
                    own.extend(["ros-out", "ros-graph-in", "ros-graph-out", "ros-decl-out"].map(String::from));
                }
                [
                    "decl-out",
                    "agent-sub",
                    "agent-data",
                    "agent-sensors-out",
                    "agent-ext-token",
                    "agent-ask",
                    "agent-answer",
                    "agent-hub-watch",
                    "agent-hub-token",
                ]
                .iter()
                .map(|s| s.to_string())
                .chain(own)
                .collect()
            }
        };
        policies.push(json!({ "id": format!("{subject}-policy"), "rules": granted, "subjects": [subject] }));
    }
    Ok(
        json!({ "enabled": true, "default_permission": "deny", "rules": rules, "subjects": subjects, "policies": policies }),
    )
}

/// The ROS 2 topics a `ros` login may read (docs/ros2.md): each UAV's sensors, goal and
/// neighbour estimates, and the clock and transforms every node needs. A ROS key starts with
/// its domain, so every rule holds for any domain (`*`).
const ROS_TOPICS: [&str; 6] =
    ["*/*/scan/**", "*/*/odom/**", "*/*/goal/**", "*/*/neighbours/**", "*/clock/**", "*/tf/**"];

/// The ROS 2 topics that are ground truth (where each UAV started in the world, the world
/// itself): observers and operators only, as `truth/**`.
const ROS_TRUTH: [&str; 2] = ["*/tf_static/**", "*/world/**"];

/// The ROS 2 commands: velocities and accelerations of UAVs.
const ROS_COMMANDS: [&str; 2] = ["*/*/cmd_vel/**", "*/*/cmd_accel/**"];

fn strings(keys: &[&str]) -> Vec<String> {
    keys.iter().map(|k| k.to_string()).collect()
}

/// The ROS 2 side: the bridge (`swarm ros2`), ROS machines (`ros`), agents on ROS topics and
/// observers; cmd_vel from a ROS machine only for the `external` UAVs.
fn ros_rules(k: &Keys, external: &[UavId]) -> Vec<Value> {
    let (topics, truth, commands) = (strings(&ROS_TOPICS), strings(&ROS_TRUTH), strings(&ROS_COMMANDS));
    let cmd_vel: Vec<String> = external.iter().map(|id| format!("*/uav{id}/cmd_vel/**")).collect();
    let graph = vec!["@ros2_lv/**".to_string()];
    let token_read = ["declare_liveliness_subscriber", "liveliness_query", "liveliness_token"];
    let everything: Vec<String> = topics.iter().chain(&truth).chain(&commands).cloned().collect();
    let mut rules = vec![
        rule("bridge-ext-in", "ingress", &["put"], vec![k.ext_cmd_any()]),
        rule("bridge-ext-token", "ingress", &["liveliness_token"], vec![k.alive_ext_any()]),
        rule("bridge-ros-pub", "ingress", &["put"], topics.iter().chain(&truth).cloned().collect()),
        rule("bridge-ros-sub", "ingress", &["declare_subscriber"], commands.clone()),
        rule("bridge-ros-out", "egress", &["put"], commands),
        rule("ros-in", "ingress", &["declare_subscriber"], topics.clone()),
        rule("ros-out", "egress", &["put"], topics),
        rule("ros-truth-in", "ingress", &["declare_subscriber"], truth.clone()),
        rule("ros-truth-out", "egress", &["put"], truth),
        rule("ros-graph-in", "ingress", &token_read, graph.clone()),
        rule("ros-graph-out", "egress", &["liveliness_token", "reply"], graph),
        rule("ros-decl-out", "egress", &["declare_subscriber"], everything),
    ];
    if !cmd_vel.is_empty() {
        rules.push(rule("ros-cmd", "ingress", &["put"], cmd_vel));
    }
    rules
}

/// The rules the bridge (under subject id `subject`) is granted: an observer's, its ROS topics,
/// and, when it `drives` bodies, its subject's own command rule.
fn bridge_rules(subject: &str, drives: bool) -> Vec<String> {
    let common = [
        "decl-out",
        "observe-in",
        "observe-out",
        "bridge-ext-in",
        "bridge-ext-token",
        "bridge-ros-pub",
        "bridge-ros-sub",
        "bridge-ros-out",
        "ros-graph-in",
        "ros-graph-out",
        "ros-decl-out",
    ];
    let own = drives.then(|| format!("{subject}-bridge-cmd"));
    common.into_iter().map(String::from).chain(own).collect()
}

/// The ROS rules of the agents of `ids` (under subject id `subject`), in a run with a ROS side:
/// each may read its own sensor and goal topics and put its own commands, as an agent on ROS
/// topics does (`swarm agent --sensors ros2`, over rmw_zenoh).
fn ros_agent_rules(subject: &str, ids: &[UavId]) -> Vec<Value> {
    let per = |topics: &[&str]| -> Vec<String> {
        ids.iter().flat_map(|i| topics.iter().map(move |t| format!("*/uav{i}/{t}/**"))).collect()
    };
    vec![
        rule(&format!("{subject}-ros-sub"), "ingress", &["declare_subscriber"], per(&["scan", "odom", "goal"])),
        rule(&format!("{subject}-ros-pub"), "ingress", &["put"], per(&["cmd_vel", "cmd_accel"])),
    ]
}

/// What observers and operators may read of the ROS 2 side: every topic, truth among them.
const ROS_READER: [&str; 7] =
    ["ros-in", "ros-out", "ros-truth-in", "ros-truth-out", "ros-graph-in", "ros-graph-out", "ros-decl-out"];

/// Keys every agent may read: `clock`, `netem/rules`, and every UAV's shares.
fn agent_common_keys(k: &Keys) -> Vec<String> {
    vec![k.clock(), k.netem_rules(), k.shares_any()]
}

/// The rules of the agents of `ids` (under subject id `subject`): subscribing to their own
/// sensor frames (each UAV's, and the host's of exactly `ids`), their own commands, shares and
/// states out (each UAV's, and the host's), their own liveliness tokens (and the host's).
fn own_rules(k: &Keys, subject: &str, ids: &[UavId]) -> Vec<Value> {
    let keys = |f: &dyn Fn(UavId) -> Vec<String>| ids.iter().flat_map(|&i| f(i)).collect::<Vec<String>>();
    let mut ascending = ids.to_vec();
    ascending.sort_unstable();
    // An agent host's frames come in one message on the key of exactly its UAVs.
    let mut sensors = keys(&|i| vec![k.sense(i), k.ext_cmd(i)]);
    sensors.push(k.host_sense(&ascending));
    // And its commands and states in one message each, on the keys of exactly its UAVs.
    let mut out = keys(&|i| vec![k.cmd(i), k.shares_of(i), k.state(i), k.ext_view(i)]);
    out.extend([k.host_cmd(&ascending), k.host_state(&ascending)]);
    let mut tokens = keys(&|i| vec![k.alive_uav(i)]);
    tokens.push(k.alive_host(&ascending));
    let ext_tokens = keys(&|i| vec![k.alive_ext(i)]);
    vec![
        rule(&format!("{subject}-own-sub"), "ingress", &["declare_subscriber"], sensors),
        rule(&format!("{subject}-own-pub"), "ingress", &["put"], out),
        rule(&format!("{subject}-own-token"), "ingress", &["liveliness_token"], tokens),
        rule(
            &format!("{subject}-own-ext-watch"),
            "ingress",
            &["declare_liveliness_subscriber", "liveliness_query"],
            ext_tokens,
        ),
    ]
}

/// The rules of UAV `id`'s external controller (under subject id `subject`): its view in, its
/// command out, its token.
fn external_rules(k: &Keys, subject: &str, id: UavId) -> Vec<Value> {
    vec![
        rule(&format!("{subject}-ext-sub"), "ingress", &["declare_subscriber"], vec![k.ext_view(id)]),
        rule(&format!("{subject}-ext-pub"), "ingress", &["put"], vec![k.ext_cmd(id)]),
        rule(&format!("{subject}-ext-token"), "ingress", &["liveliness_token"], vec![k.alive_ext(id)]),
    ]
}

/// `swarm credentials`.
#[derive(Args, Debug, Clone)]
pub struct CredentialsArgs {
    /// Folder to write `users.txt` (the hub's `--users`) and one `<user>.password` per user.
    #[arg(long)]
    pub out: PathBuf,
    /// Make `uav1` .. `uavN`.
    #[arg(long, default_value_t = 0)]
    pub uavs: u32,
    /// Also an agent-host user for these UAVs, e.g. `1-20` makes `uavs1-20` (repeatable).
    #[arg(long = "host", value_parser = parse_ids)]
    pub hosts: Vec<swarm_args::UavIds>,
    /// More users by name (`observer-alice`, `operator-bob`, `uav7`...); `observer` and
    /// `operator` are always made.
    #[arg(long = "user")]
    pub users: Vec<String>,
}

/// Runs `swarm credentials`: prints each user and its password file.
pub fn credentials(a: CredentialsArgs) -> Result<ExitCode> {
    let mut users: Vec<String> = UavId::all(a.uavs as usize).map(uav_user).collect();
    users.extend(a.hosts.iter().map(|h| host_user(&h.0)));
    users.extend(["observer".to_string(), "operator".to_string()]);
    users.extend(a.users);
    let creds = Credentials::create(&a.out, &users)?;
    println!("dictionary (swarm hub --users): {}", creds.dictionary().display());
    for u in &users {
        println!("{u}: --user {u} --password-file {}", creds.password_file(u).display());
    }
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn roles_are_read_from_names() {
        assert_eq!(Role::of("uav3").expect("agent"), Role::Agents(vec![UavId::new(3)]));
        assert_eq!(
            Role::of("uavs1-3,7").expect("host"),
            Role::Agents(vec![UavId::new(1), UavId::new(2), UavId::new(3), UavId::new(7)])
        );
        assert_eq!(Role::of("observer").expect("o"), Role::Observer);
        assert_eq!(Role::of("operator-bob").expect("op"), Role::Operator);
        assert_eq!(Role::of("bridge").expect("bridge"), Role::Bridge(vec![]));
        assert_eq!(Role::of("controller").expect("controller"), Role::Controller);
        assert_eq!(
            Role::of(&bridge_user(&[UavId::new(3), UavId::new(4)])).expect("bridge"),
            Role::Bridge(vec![UavId::new(3), UavId::new(4)])
        );
        for bad in ["uav0", "uav", "uavx", "observers", "root", "uavs3-1"] {
            assert!(Role::of(bad).is_err(), "{bad} has no role");
        }
    }

    #[test]
    fn host_users_round_trip() {
        assert_eq!(
            host_user(&[UavId::new(1), UavId::new(2), UavId::new(3), UavId::new(4), UavId::new(7)]),
            "uavs1-4,7"
        );
        assert_eq!(host_user(&[UavId::new(5)]), "uavs5");
        assert_eq!(
            Role::of(&host_user(&[UavId::new(2), UavId::new(3), UavId::new(9), UavId::new(10)])).expect("host"),
            Role::Agents(vec![UavId::new(2), UavId::new(3), UavId::new(9), UavId::new(10)])
        );
    }

    #[test]
    fn credentials_are_private_and_rules_cover_each_user() {
        use std::os::unix::fs::PermissionsExt;
        let dir = std::env::temp_dir().join(format!("swarm-auth-test-{}", std::process::id()));
        let users: Vec<String> = ["uav1", "uavs2-3", "observer", "operator"].map(String::from).to_vec();
        let c = Credentials::create(&dir, &users).expect("made");
        let mode = std::fs::metadata(c.dictionary()).expect("dict").permissions().mode() & 0o777;
        assert_eq!(mode, 0o600);
        assert_eq!(users_of(&c.dictionary()).expect("read"), users);
        let acl = access_control("r", &users, &[]).expect("acl");
        assert_eq!(acl["default_permission"], "deny");
        assert_eq!(acl["policies"].as_array().expect("p").len(), 4);
        let text = acl.to_string();
        assert!(text.contains("swarm/r/uav/3/cmd") && text.contains("swarm/r/alive/uav/2"), "{text}");
        for agent in ["uav1", "uavs2-3"] {
            let keys: Vec<&str> = granted(&acl, agent).iter().flat_map(|r| keys_of(&acl, r)).collect();
            assert!(
                !keys.iter().any(|k| k.contains("truth") || k.contains("world")),
                "{agent} may touch truth: {keys:?}"
            );
            assert!(!keys.iter().any(|k| k.contains("scan")), "no ROS side, no ROS rules for {agent}: {keys:?}");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// The rule ids granted to `user` in `acl`.
    fn granted<'a>(acl: &'a Value, user: &str) -> Vec<&'a str> {
        let subject =
            acl["subjects"].as_array().expect("subjects").iter().find(|s| s["usernames"][0] == user).expect("subject");
        let policy = acl["policies"].as_array().expect("policies").iter().find(|p| p["subjects"][0] == subject["id"]);
        policy.expect("policy")["rules"].as_array().expect("rules").iter().filter_map(Value::as_str).collect()
    }

    /// The keys of rule `id` in `acl`.
    fn keys_of<'a>(acl: &'a Value, id: &str) -> Vec<&'a str> {
        let rule = acl["rules"].as_array().expect("rules").iter().find(|r| r["id"] == id).expect("rule");
        rule["key_exprs"].as_array().expect("keys").iter().filter_map(Value::as_str).collect()
    }

    #[test]
    fn only_a_bridge_that_drives_bodies_may_command_them_and_only_those() {
        let users: Vec<String> = ["uav3", "ros", "bridge-uavs3"].map(String::from).to_vec();
        let acl = access_control("r", &users, &[]).expect("acl");
        let bridge = granted(&acl, "bridge-uavs3");
        let own: Vec<&str> = bridge.iter().copied().filter(|r| r.ends_with("-bridge-cmd")).collect();
        assert_eq!(own.len(), 1, "{bridge:?}");
        assert_eq!(keys_of(&acl, own[0]), vec!["swarm/r/uav/3/cmd"]);
        let plain = access_control("r", &["bridge".to_string()], &[]).expect("acl");
        assert!(
            !granted(&plain, "bridge").iter().any(|r| r.contains("cmd")),
            "a bridge driving nothing commands nothing"
        );
        // With a ROS side, UAV 3's agent may read its own ROS sensors and put its own commands.
        let agent = granted(&acl, "uav3");
        let sub = agent.iter().find(|r| r.ends_with("-ros-sub")).expect("ROS rules");
        assert!(keys_of(&acl, sub).iter().all(|k| k.starts_with("*/uav3/")), "{:?}", keys_of(&acl, sub));
        // A `ros` login reads no truth topic.
        let ros = granted(&acl, "ros");
        assert!(!ros.iter().any(|r| r.starts_with("ros-truth")), "{ros:?}");
        assert!(keys_of(&acl, "ros-truth-in").contains(&"*/world/**"));
    }
}

//! End to end across hosts: a small network the test builds with Linux network namespaces, one
//! per machine, joined by veth pairs to a bridge in a namespace of its own. The hub runs in one,
//! UAVs 1 and 2 in another (clients of the hub), a second Zenoh router (`swarm router`) in a third,
//! connected to the hub, and UAVs 3, 4, 5 in a fourth as its clients: a swarm spread over several
//! machines. forest-5 flies over it in lockstep; mid-flight the kernel cuts the fourth machine's
//! link (`ip link set eth0 down`) and brings it back. The agents behind it drop out at the hub
//! and their UAVs hover; their sessions come back by themselves; the swarm reaches the goal with
//! no collision. The times from link-down to hover and from link-up to the swarm whole again are
//! printed.
//!
//! Every address lives only inside the namespaces the test creates (names unique per test
//! process), and [`Net`]'s drop removes them, also when the test fails. A kernel (or a user) that
//! refuses network namespaces fails the test with a message saying so.

mod common;

use common::{run_id, Proc, RUN_LIMIT, SWARM, TOOL_LIMIT};
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// The machines of the network, each a namespace with `eth0` at `10.77.0.{index + 1}/24`.
const HOSTS: [&str; 4] = ["hub", "near", "router", "far"];

/// A lease short enough that a cut link is noticed within about a second (every piece gets it:
/// each side expires the other by the lease it announces) [ms].
const LEASE: &str = "transport/link/tx/lease:1000";

/// The network namespaces of one test; removed (with their links) on drop.
struct Net {
    prefix: String,
    created: Vec<String>,
}

/// Runs `ip ARGS`; the error is what it printed.
fn ip(args: &[&str]) -> Result<(), String> {
    let out = Command::new("ip").args(args).output().map_err(|e| format!("cannot run `ip`: {e}"))?;
    if out.status.success() {
        Ok(())
    } else {
        Err(format!("`ip {}`: {}", args.join(" "), String::from_utf8_lossy(&out.stderr).trim()))
    }
}

impl Net {
    /// Builds the bridge namespace and one namespace per host, each linked to the bridge.
    fn build() -> Net {
        let mut net = Net { prefix: run_id("net"), created: Vec::new() };
        let br = net.add_ns("br");
        let must = |args: &[&str]| ip(args).unwrap_or_else(|e| panic!("building the test network: {e}"));
        must(&["-n", &br, "link", "add", "br0", "type", "bridge"]);
        must(&["-n", &br, "link", "set", "br0", "up"]);
        for (i, host) in HOSTS.iter().enumerate() {
            let ns = net.add_ns(host);
            let port = format!("p{i}");
            must(&["-n", &ns, "link", "set", "lo", "up"]);
            must(&["-n", &ns, "link", "add", "eth0", "type", "veth", "peer", "name", &port, "netns", &br]);
            must(&["-n", &br, "link", "set", &port, "master", "br0"]);
            must(&["-n", &br, "link", "set", &port, "up"]);
            must(&["-n", &ns, "addr", "add", &format!("{}/24", addr(host)), "dev", "eth0"]);
            must(&["-n", &ns, "link", "set", "eth0", "up"]);
        }
        net
    }

    /// Creates namespace `<prefix>-<name>`; the kernel refusing it fails the test saying so.
    fn add_ns(&mut self, name: &str) -> String {
        let ns = format!("{}-{name}", self.prefix);
        if let Err(e) = ip(&["netns", "add", &ns]) {
            panic!(
                "the kernel refused a network namespace, which this test needs (it runs as root in CI, \
                 `.ci/run`; network namespaces and veth must be available): {e}"
            );
        }
        self.created.push(ns.clone());
        ns
    }

    fn ns(&self, host: &str) -> String {
        format!("{}-{host}", self.prefix)
    }

    /// Takes `host`'s link up or down, as the kernel does when a cable or radio goes.
    fn set_link(&self, host: &str, up: bool) {
        let state = if up { "up" } else { "down" };
        ip(&["-n", &self.ns(host), "link", "set", "eth0", state]).unwrap_or_else(|e| panic!("{e}"));
    }

    /// Starts `swarm ARGS` inside `host`'s namespace, stderr to `log`.
    fn start(&self, host: &str, args: &[&str], log: &Path) -> Proc {
        let err = std::fs::File::create(log).expect("log file");
        let mut child = Command::new("ip")
            .args(["netns", "exec", &self.ns(host), SWARM])
            .args(args)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::from(err))
            .spawn()
            .expect("spawn ip netns exec");
        let stdin = child.stdin.take();
        Proc { child, stdin }
    }
}

impl Drop for Net {
    fn drop(&mut self) {
        for ns in self.created.iter().rev() {
            if let Err(e) = ip(&["netns", "del", ns]) {
                eprintln!("cleanup: {e}");
            }
        }
    }
}

/// The address of `host` (inside its namespace only).
fn addr(host: &str) -> String {
    let i = HOSTS.iter().position(|h| *h == host).expect("a host");
    format!("10.77.0.{}", i + 1)
}

fn endpoint(host: &str) -> String {
    format!("tcp/{}:7447", addr(host))
}

/// Each stdout line of `p`, with the instant it arrived, on a channel.
fn lines_of(p: &mut Proc) -> mpsc::Receiver<(Instant, String)> {
    let out = p.child.stdout.take().expect("piped stdout");
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(out).lines().map_while(Result::ok) {
            if tx.send((Instant::now(), line)).is_err() {
                break;
            }
        }
    });
    rx
}

/// Waits (at most `limit`) for a line that `pick` accepts; fails the test saying `what`.
fn wait_line(
    rx: &mpsc::Receiver<(Instant, String)>,
    limit: Duration,
    what: &str,
    pick: impl Fn(&str) -> bool,
) -> Instant {
    let end = Instant::now() + limit;
    loop {
        let left = end.saturating_duration_since(Instant::now());
        match rx.recv_timeout(left) {
            Ok((at, line)) if pick(&line) => return at,
            Ok(_) => {}
            Err(_) => panic!("{what}: not seen within {limit:?}"),
        }
    }
}

/// The instant the last UAV of `ids` was reported `alive` (true or false) by the liveliness tap.
fn wait_alive(rx: &mpsc::Receiver<(Instant, String)>, run: &str, ids: &[u32], alive: bool, what: &str) -> Instant {
    let mut left: std::collections::BTreeSet<u32> = ids.iter().copied().collect();
    let limit = Duration::from_secs(90);
    let end = Instant::now() + limit;
    let prefix = format!("swarm/{run}/alive/uav/");
    let mut last = Instant::now();
    while !left.is_empty() {
        let Ok((at, line)) = rx.recv_timeout(end.saturating_duration_since(Instant::now())) else {
            panic!("{what}: still waiting for {left:?} after {limit:?}");
        };
        let v: serde_json::Value = serde_json::from_str(&line).unwrap_or_default();
        let id = v["key"].as_str().and_then(|k| k.strip_prefix(prefix.as_str())).and_then(|s| s.parse::<u32>().ok());
        if id.is_some_and(|id| v["alive"] == alive && left.remove(&id)) {
            last = at;
        }
    }
    last
}

/// forest-5 with a time limit long enough to wait for the machine that was cut off: the goal
/// counts every UAV, so the run can end only when the swarm is whole again.
fn scenario_file(dir: &Path) -> String {
    let text = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/forest-5.toml"))
        .expect("forest-5");
    let text = text.replace("time_limit_s = 300.0", "time_limit_s = 3000.0");
    assert!(text.contains("3000.0"), "forest-5's time limit moved: update this test");
    let path = dir.join("forest-5-hosts.toml");
    std::fs::write(&path, text).expect("write scenario");
    path.to_str().expect("utf8").to_string()
}

/// Speeds of `id` in `trajectories.csv` at the ticks its agent was not alive, from 1 s after
/// each drop-out (the body needs well under a second to stop from 1 m/s at 2 m/s²).
fn speeds_while_out(csv: &str, id: &str) -> Vec<f64> {
    // Columns: tick,t_s,id,x_m,y_m,yaw_rad,vx_mps,vy_mps,...,colliding,alive,cmd_on_time
    let mut out_since: Option<f64> = None;
    let mut speeds = Vec::new();
    for c in csv.lines().skip(1).map(|l| l.split(',').collect::<Vec<_>>()).filter(|c| c[2] == id) {
        let t: f64 = c[1].parse().expect("t");
        if c[11] == "1" {
            out_since = None;
            continue;
        }
        let since = *out_since.get_or_insert(t);
        if t - since >= 1.0 {
            speeds.push(c[6].parse::<f64>().expect("vx").hypot(c[7].parse::<f64>().expect("vy")));
        }
    }
    speeds
}

#[test]
fn a_swarm_over_four_machines_lives_through_a_cut_link() {
    let net = Net::build();
    let dir = tempfile::tempdir().expect("tempdir");
    let d = dir.path();
    let run = run_id("hosts");
    let sc = scenario_file(d);
    let hub_ep = endpoint("hub");

    // `--insecure`: this test is about hosts and a cut link; tests/tests/security.rs tests logins.
    let hub_args = ["hub", &sc, "--run", &run, "--listen", &hub_ep, "--exit-with-stdin", "--insecure", "--cfg", LEASE];
    let mut hub = net.start("hub", &hub_args, &d.join("hub.log"));
    wait_line(&lines_of(&mut hub), TOOL_LIMIT, "the hub's locator", |l| l.starts_with("swarm-hub listening:"));
    let router_ep = endpoint("router");
    let router_args = ["router", "--listen", &router_ep, "--connect", &hub_ep, "--exit-with-stdin", "--cfg", LEASE];
    let mut router = net.start("router", &router_args, &d.join("router.log"));
    wait_line(&lines_of(&mut router), TOOL_LIMIT, "the router's locator", |l| l.starts_with("swarm-router listening:"));

    let out = d.join("rec");
    let mut rec = net.start(
        "hub",
        &["record", "--run", &run, "--out", out.to_str().expect("utf8"), "--connect", &hub_ep, "--cfg", LEASE],
        &d.join("rec.log"),
    );
    let tap = |key: String, extra: &[&str], log: &str| {
        let mut args =
            vec!["tap".to_string(), key, "--connect".into(), hub_ep.clone(), "--duration".into(), "900".into()];
        args.extend(extra.iter().map(|s| s.to_string()));
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        net.start("hub", &args, &d.join(log))
    };
    let mut rec_up = tap(format!("swarm/{run}/alive/recorder"), &["--alive", "--count", "1"], "tap-rec.log");
    wait_line(&lines_of(&mut rec_up), TOOL_LIMIT, "the recorder's token", |l| l.contains("\"alive\":true"));
    let mut alive_tap = tap(format!("swarm/{run}/alive/uav/**"), &["--alive"], "tap-alive.log");
    let alive = lines_of(&mut alive_tap);
    let mut clock_tap = tap(format!("swarm/{run}/clock"), &[], "tap-clock.log");
    let clock = lines_of(&mut clock_tap);
    std::thread::sleep(Duration::from_millis(500));

    let agent = |host: &str, id: u32, ep: &str| {
        let id = id.to_string();
        let args = ["agent", "--run", &run, "--id", &id, "--connect", ep, "--hub-grace-s", "300", "--cfg", LEASE];
        net.start(host, &args, &d.join(format!("agent-{id}.log")))
    };
    let _near: Vec<Proc> = (1..=2).map(|id| agent("near", id, &hub_ep)).collect();
    let mut far: Vec<Proc> = (3..=5).map(|id| agent("far", id, &router_ep)).collect();
    wait_alive(&alive, &run, &[1, 2, 3, 4, 5], true, "every agent alive at the hub");

    // Mid-flight (sim 15 s, among the trees), the far machine's link goes down.
    let tick_at_least = |n: u64| {
        move |l: &str| {
            serde_json::from_str::<serde_json::Value>(l)
                .ok()
                .and_then(|v| v["msg"]["Clock"]["tick"].as_u64())
                .is_some_and(|t| t >= n)
        }
    };
    wait_line(&clock, TOOL_LIMIT, "tick 150", tick_at_least(150));
    let down_at = Instant::now();
    net.set_link("far", false);
    let gone_at = wait_alive(&alive, &run, &[3, 4, 5], false, "the far agents dropping out at the hub");
    // Let the near UAVs fly on while the far ones hover, then restore the link.
    std::thread::sleep(Duration::from_secs(3));
    let up_at = Instant::now();
    net.set_link("far", true);
    let whole_at = wait_alive(&alive, &run, &[3, 4, 5], true, "the far agents back at the hub");
    let (to_hover_s, to_whole_s) =
        (gone_at.duration_since(down_at).as_secs_f64(), whole_at.duration_since(up_at).as_secs_f64());
    println!("netns: link down -> far agents out at the hub, hovering: {to_hover_s:.2} s; link up -> swarm whole again: {to_whole_s:.2} s");

    let status = rec.wait_for(RUN_LIMIT).expect("the recorder finishes with the run");
    assert!(status.success(), "recorder: {status:?}");
    let s = common::summary(&out);
    assert_eq!(s["reached_goal"], true, "the swarm reaches the goal: {s:#}");
    assert_eq!(s["collisions"], 0, "no collision: {s:#}");
    let csv = std::fs::read_to_string(out.join("trajectories.csv")).expect("trajectories.csv");
    for id in ["1", "2"] {
        assert_eq!(common::alive_changes(&out, id).len(), 1, "UAV {id} (near machine) alive throughout");
    }
    for id in ["3", "4", "5"] {
        let changes = common::alive_changes(&out, id);
        assert!(changes.len() >= 3 && changes.last().is_some_and(|c| c.1), "UAV {id}: alive, out, back: {changes:?}");
        let speeds = speeds_while_out(&csv, id);
        assert!(!speeds.is_empty(), "UAV {id} was out for more than 1 s of sim time: {changes:?}");
        let max = speeds.iter().copied().fold(0.0, f64::max);
        assert!(max < 0.05, "UAV {id} hovers while its machine is cut off: up to {max} m/s");
    }
    assert!(hub.wait_for(Duration::from_secs(30)).expect("hub exits after the run").success(), "hub");
    for (i, a) in far.iter_mut().enumerate() {
        // Still running (waiting out its long grace for the hub that ended the run): the same
        // process lived through the cut.
        assert!(
            a.child.try_wait().expect("try_wait").is_none(),
            "agent {}: the same process lived through the cut",
            i + 3
        );
        let log = std::fs::read_to_string(d.join(format!("agent-{}.log", i + 3))).expect("log");
        assert!(log.contains("hub back"), "agent {}: its session came back: {log}", i + 3);
    }
    println!(
        "netns: goal at {} s sim, min UAV distance {} m, min obstacle distance {} m",
        s["time_to_goal_s"], s["min_agent_distance_m"], s["min_obstacle_distance_m"]
    );
    drop(router);
}

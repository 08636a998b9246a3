//! End to end: watching a run. `swarm run --view` serves the live page and the Foxglove
//! WebSocket: two Foxglove clients (Python `websockets`, speaking the Foxglove WebSocket
//! protocol) receive UAV poses during the run, one offering the protocol's current name
//! `foxglove.sdk.v1`, one offering only the old name `foxglove.websocket.v1` as Lichtblick does;
//! headless Chromium (Debian's, driven by playwright) sees the drawn UAVs move and sit where the
//! run's truth puts them, and, with the scan toggle on, UAV 1's scan drawn at UAV 1's true pose
//! of the scan's tick with its returns on the trees. `swarm replay` of a run folder seeks to a
//! tick and draws that tick's positions and scan. Screenshots are kept under the tests' target
//! temporary folder (`target/tmp/view/`).

mod common;

use common::{python, run_id, Proc, RUN_LIMIT, SWARM, TOOL_LIMIT};
use serde_json::Value;
use std::collections::BTreeMap;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Where a test keeps its screenshots (kept after the test).
fn output_dir(test: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("view").join(test);
    std::fs::create_dir_all(&d).expect("output dir");
    d
}

/// Starts `swarm <args>` and reads its stdout until a line starting with `prefix`: returns
/// the process and the (page URL, Foxglove URL) of that line.
fn start_serving(args: &[&str], prefix: &str, log: &Path) -> (Proc, String, String) {
    let err = std::fs::File::create(log).expect("log");
    let mut child = Command::new(SWARM).args(args).stdin(Stdio::piped()).stdout(Stdio::piped()).stderr(Stdio::from(err)).spawn().expect("spawn");
    let stdout = child.stdout.take().expect("stdout");
    let stdin = child.stdin.take();
    let (tx, rx) = std::sync::mpsc::channel();
    let wanted = prefix.to_string();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            if line.starts_with(&wanted) {
                let _ = tx.send(line);
            }
        }
    });
    let proc = Proc { child, stdin };
    let line = rx.recv_timeout(TOOL_LIMIT).unwrap_or_else(|_| panic!("no '{prefix}' line: see {}", log.display()));
    let words: Vec<&str> = line.split_whitespace().collect();
    let page = words.iter().find(|w| w.starts_with("http://")).expect("page URL").to_string();
    let ws = words.iter().find(|w| w.starts_with("ws://")).expect("foxglove URL").to_string();
    (proc, page, ws)
}

/// Runs one of the Python scripts in tests/py and parses the JSON it prints.
fn py(script: &str, args: &[&str]) -> Value {
    let out = common::output_within(Command::new(python()).arg(format!("{}/py/{script}", env!("CARGO_MANIFEST_DIR"))).args(args), TOOL_LIMIT);
    assert!(out.status.success(), "{script}: {}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{script} printed no JSON ({e}): {}", String::from_utf8_lossy(&out.stdout)))
}

/// `trajectories.csv` as (tick, id) -> (x, y).
fn truth(run: &Path) -> BTreeMap<(u64, u64), (f64, f64)> {
    let text = std::fs::read_to_string(run.join("trajectories.csv")).expect("trajectories.csv");
    text.lines()
        .skip(1)
        .map(|l| {
            let c: Vec<&str> = l.split(',').collect();
            let num = |i: usize| c[i].parse::<f64>().expect("number");
            ((num(0) as u64, num(2) as u64), (num(3), num(4)))
        })
        .collect()
}

/// Every UAV drawn in `state` (a `window.viewState`) sits at the truth of its tick, within 1 cm
/// (the CSV keeps 4 decimals), and on the canvas.
fn assert_drawn_at_truth(state: &Value, truth: &BTreeMap<(u64, u64), (f64, f64)>) {
    let tick = state["tick"].as_u64().expect("tick");
    let uavs = state["uavs"].as_array().expect("uavs");
    assert_eq!(uavs.len(), 5, "five UAVs drawn: {state}");
    for u in uavs {
        let id = u["id"].as_u64().expect("id");
        let (x, y) = truth.get(&(tick, id)).unwrap_or_else(|| panic!("no truth for tick {tick} UAV {id}"));
        let (dx, dy) = (u["x"].as_f64().expect("x") - x, u["y"].as_f64().expect("y") - y);
        assert!(dx.hypot(dy) < 0.01, "UAV {id} at tick {tick}: drawn {u}, truth ({x}, {y})");
        let (px, py) = (u["px"].as_f64().expect("px"), u["py"].as_f64().expect("py"));
        assert!((0.0..=1200.0).contains(&px) && (0.0..=800.0).contains(&py), "UAV {id} drawn off the canvas: {u}");
    }
}

/// A Foxglove client's JSON (`foxglove_ws.py`): it negotiated `subprotocol` and received at
/// least 20 `/uav/1/pose` messages in the world frame, in sim-time order.
fn assert_poses(fox: &Value, subprotocol: &str) {
    assert_eq!(fox["subprotocol"], subprotocol, "{fox}");
    assert_eq!(fox["channel"]["schemaName"], "foxglove.PoseInFrame", "{fox}");
    let poses = fox["poses"].as_array().expect("poses");
    assert!(poses.len() >= 20, "20 poses during the run: {fox}");
    assert!(poses.iter().all(|p| p["frame_id"] == "world"));
    let times: Vec<u64> = poses.iter().map(|p| p["log_time_ns"].as_u64().expect("time")).collect();
    assert!(times.windows(2).all(|w| w[0] < w[1]), "poses in sim-time order: {times:?}");
}

/// The scan drawn in `state` (a `window.viewState` with the toggle on) is UAV `id`'s, drawn at
/// its truth pose of the scan's tick (within 1 cm), and most of its returns lie on a tree's
/// surface or another UAV's body (within 0.1 m: the LIDAR's noise is 0.02 m).
fn assert_scan_drawn(state: &Value, id: u64, run: &Path, truth: &BTreeMap<(u64, u64), (f64, f64)>) {
    let scan = &state["scan"];
    assert_eq!(scan["id"], id, "{scan}");
    assert_eq!(scan["beams"], 750, "{scan}");
    let tick = scan["tick"].as_u64().expect("scan tick");
    let pose = scan["pose"].as_array().expect("pose");
    let (x, y) = truth[&(tick, id)];
    let at = |i: usize| pose[i].as_f64().expect("pose number");
    assert!((at(0) - x).hypot(at(1) - y) < 0.01, "scan of tick {tick} drawn at {pose:?}, truth ({x}, {y})");
    let world: Value = serde_json::from_str(&std::fs::read_to_string(run.join("world.json")).expect("world.json")).expect("world json");
    let r_uav = world["body_radius_m"].as_f64().expect("body radius");
    let mut surfaces: Vec<(f64, f64, f64)> = world["trees"].as_array().expect("trees").iter().map(|t| (t[0].as_f64().unwrap_or(0.0), t[1].as_f64().unwrap_or(0.0), t[2].as_f64().unwrap_or(0.0))).collect();
    surfaces.extend(truth.iter().filter(|((t, u), _)| *t == tick && *u != id).map(|(_, &(ux, uy))| (ux, uy, r_uav)));
    let hits = scan["hits"].as_array().expect("hits");
    assert!(hits.len() >= 10, "the scan sees something: {} returns", hits.len());
    let on_surface = hits
        .iter()
        .filter(|h| {
            let (hx, hy) = (h[0].as_f64().unwrap_or(f64::NAN), h[1].as_f64().unwrap_or(f64::NAN));
            surfaces.iter().any(|&(cx, cy, r)| ((hx - cx).hypot(hy - cy) - r).abs() < 0.1)
        })
        .count();
    assert!(on_surface * 10 >= hits.len() * 9, "{on_surface} of {} returns on a surface", hits.len());
}

/// Waits (bounded) for a file to appear.
fn wait_for_file(p: &Path, limit: Duration) {
    let t0 = Instant::now();
    while !p.exists() {
        assert!(t0.elapsed() < limit, "{} never appeared", p.display());
        std::thread::sleep(Duration::from_millis(200));
    }
}

#[test]
fn live_view_draws_the_run_and_serves_foxglove_poses() {
    let dir = tempfile::tempdir().expect("tempdir");
    let sc = common::forest5_cut(dir.path(), 40.0);
    let out = dir.path().join("run");
    let run = run_id("view");
    let args = ["run", &sc, "--out", out.to_str().expect("utf8"), "--run", &run, "--quiet", "--time-mode", "realtime", "--view", "0"];
    let (_run, page, ws) = start_serving(&args, "view: ", &dir.path().join("run.log"));

    // Offered both names, the SDK's server chooses the current one.
    assert_poses(&py("foxglove_ws.py", &[&ws, "/uav/1/pose", "20", "60"]), "foxglove.sdk.v1");
    // Lichtblick offers only the old name: the front door answers with it.
    assert_poses(&py("foxglove_ws.py", &[&ws, "/uav/1/pose", "20", "60", "foxglove.websocket.v1"]), "foxglove.websocket.v1");

    let shot = output_dir("live").join("live.png");
    let seen = py("page.py", &[&page, shot.to_str().expect("utf8"), "live", "3"]);
    assert!(shot.exists(), "screenshot kept");
    assert_eq!(seen["panels"], 5, "a panel per UAV: {seen}");
    let (first, second) = (&seen["first"], &seen["second"]);
    let tick = |v: &Value| v["tick"].as_u64().unwrap_or_else(|| panic!("a tick: {seen}"));
    assert!(tick(second) > tick(first), "the clock moves: {seen}");
    let moved = |a: &Value, b: &Value| (a["x"].as_f64().unwrap_or(0.0) - b["x"].as_f64().unwrap_or(0.0)).hypot(a["y"].as_f64().unwrap_or(0.0) - b["y"].as_f64().unwrap_or(0.0)) > 0.05;
    assert!(first["uavs"].as_array().expect("uavs").iter().zip(second["uavs"].as_array().expect("uavs")).any(|(a, b)| moved(a, b)), "drawn UAVs move: {seen}");
    let scan_shot = output_dir("live").join("live-scan.png");
    let scanned = py("page.py", &[&page, scan_shot.to_str().expect("utf8"), "scan", "1"]);
    assert!(scan_shot.exists(), "screenshot kept");

    // The run ends by its time limit; its truth is in the run folder.
    wait_for_file(&out.join("summary.json"), RUN_LIMIT);
    std::thread::sleep(Duration::from_millis(500));
    let truth = truth(&out);
    assert_drawn_at_truth(first, &truth);
    assert_drawn_at_truth(second, &truth);
    assert_scan_drawn(&scanned["scan"], 1, &out, &truth);
}

#[test]
fn replay_seeks_to_a_tick_and_draws_its_positions() {
    let dir = tempfile::tempdir().expect("tempdir");
    let sc = common::forest5_cut(dir.path(), 8.0);
    let out = dir.path().join("run");
    let o = common::swarm_run(&[&sc, "--out", out.to_str().expect("utf8"), "--run", &run_id("replay")]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (_replay, page, _ws) = start_serving(&["replay", out.to_str().expect("utf8"), "--port", "0", "--paused"], "replay: ", &dir.path().join("replay.log"));
    let shot = output_dir("replay").join("replay.png");
    let seen = py("page.py", &[&page, shot.to_str().expect("utf8"), "seek", "42", "2"]);
    assert!(shot.exists(), "screenshot kept");
    let state = &seen["seek"];
    assert_eq!(state["tick"], 42, "{seen}");
    let truth = truth(&out);
    assert_drawn_at_truth(state, &truth);
    assert_eq!(seen["scan"]["scan"]["tick"], 42, "the scan of the sought tick: {}", seen["scan"]["scan"]);
    assert_scan_drawn(&seen["scan"], 2, &out, &truth);
}

//! End to end: watching a run. `swarm run --view` serves the live page and the Foxglove
//! WebSocket: two Foxglove clients (Python `websockets`, speaking the Foxglove WebSocket
//! protocol) receive UAV poses during the run, one offering the protocol's current name
//! `foxglove.sdk.v1`, one offering only the old name `foxglove.websocket.v1` as Lichtblick does;
//! headless Chromium (Debian's, driven by playwright) opens the page 5 sim seconds into the run
//! and finds every UAV's trail back to the run's start on the truth at its first frame, sees the
//! drawn UAVs move and sit where the run's truth puts them, the legend, a scale bar as long as
//! its metres, units in the panels, UAV 1 selected by a click where the map draws it (its
//! estimates drawn as rings above the arrows, near the other UAVs), and, with the scan toggle on,
//! UAV 1's scan drawn at UAV 1's true pose of the scan's tick with its returns on the trees.
//! `swarm replay` of a run folder seeks to a tick and draws that tick's positions, the trails up
//! to it, the seek bar's times (current / total, and under the cursor), the legend with the
//! scenario's goal radius, and the scan of a UAV clicked on the map. Screenshots are kept under the tests' target temporary folder
//! (`target/tmp/view/`).

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
    let mut child = Command::new(SWARM)
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::from(err))
        .spawn()
        .expect("spawn");
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
    let out = common::output_within(
        Command::new(python()).arg(format!("{}/py/{script}", env!("CARGO_MANIFEST_DIR"))).args(args),
        TOOL_LIMIT,
    );
    assert!(out.status.success(), "{script}: {}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout)
        .unwrap_or_else(|e| panic!("{script} printed no JSON ({e}): {}", String::from_utf8_lossy(&out.stdout)))
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

/// The tick length of a run [s], from `trajectories.csv` (a row past tick 0: t_s / tick).
fn tick_length(run: &Path) -> f64 {
    let text = std::fs::read_to_string(run.join("trajectories.csv")).expect("trajectories.csv");
    let row = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
        .find(|c| c[0] != "0")
        .expect("a row past tick 0");
    row[1].parse::<f64>().expect("t_s") / row[0].parse::<f64>().expect("tick")
}

/// The trails a page holds (`{id: [[x, y, t], ...]}`): one per UAV, each reaching from at most
/// `from_s` to at least `to_s` (its points before the page's last within 1 s of it) with no gap
/// over 0.5 s, and every point on the run's truth at its
/// time (within 1 cm).
fn assert_trails_on_truth(trails: &Value, from_s: f64, to_s: f64, truth: &BTreeMap<(u64, u64), (f64, f64)>, dt: f64) {
    let trails = trails.as_object().unwrap_or_else(|| panic!("trails: {trails}"));
    assert_eq!(trails.len(), 5, "a trail per UAV: {trails:?}");
    for (id, points) in trails {
        let id: u64 = id.parse().expect("UAV id");
        let points: Vec<[f64; 3]> = points
            .as_array()
            .expect("points")
            .iter()
            .map(|p| [0, 1, 2].map(|i| p[i].as_f64().expect("number")))
            .collect();
        let (first, last) = (points.first().expect("a point")[2], points.last().expect("a point")[2]);
        assert!(
            first <= from_s && last >= to_s,
            "UAV {id}'s trail spans {first} to {last} s, not {from_s} to {to_s} s"
        );
        // The last point may be the page's own, from the frame it drew; the one before it came
        // with the trails the server handed over, which must reach up to that frame too.
        let handed = points[points.len().saturating_sub(2)][2];
        assert!(handed >= to_s - 1.0, "UAV {id}'s trail from the server ends at {handed} s, long before {to_s} s");
        assert!(
            points.windows(2).all(|w| w[1][2] > w[0][2] && w[1][2] - w[0][2] <= 0.5 + 1e-9),
            "UAV {id}'s trail has a gap: {points:?}"
        );
        for [x, y, t] in points {
            let tick = (t / dt).round() as u64;
            let (tx, ty) = truth.get(&(tick, id)).unwrap_or_else(|| panic!("no truth for tick {tick} UAV {id}"));
            assert!((x - tx).hypot(y - ty) < 0.01, "UAV {id}'s trail at {t} s: ({x}, {y}), truth ({tx}, {ty})");
        }
    }
}

/// The number after `label` in `text` that carries `unit` (glued to it, like `12°`, or as the
/// next word, like `0.39 m/s`), if any.
fn value_with_unit(text: &str, label: &str, unit: &str) -> Option<f64> {
    let words: Vec<&str> = text.split_whitespace().collect();
    words.windows(3).filter(|w| w[0] == label).find_map(|w| match w[1].strip_suffix(unit).filter(|n| !n.is_empty()) {
        Some(n) => n.parse().ok(),
        None => (w[2] == unit).then(|| w[1].parse().ok()).flatten(),
    })
}

/// A UAV's panel gives each number its unit: speed and command in m/s, position in m, heading
/// in degrees, step time in ms.
fn assert_units(panel: &str) {
    for (label, unit) in
        [("speed", "m/s"), ("x", "m"), ("y", "m"), ("heading", "°"), ("step", "ms"), ("command", "m/s")]
    {
        assert!(
            value_with_unit(panel, label, unit).is_some_and(f64::is_finite),
            "'{label} <number> {unit}' in the panel: {panel}"
        );
    }
}

/// The legend names every mark the map draws.
fn assert_legend(legend: &str) {
    for key in [
        "UAV, its heading",
        "selected UAV",
        "tree",
        "goal (4 m radius)",
        "trail: last 20 s",
        "neighbour estimate",
        "radio link",
        "collision",
        "lost UAV",
    ] {
        assert!(legend.contains(key), "'{key}' in the legend: {legend}");
    }
}

/// The scale bar says a round length (1, 2 or 5 times a power of ten metres) and is that long on
/// the map: its width is its metres times the pixels per metre between two drawn UAVs (within
/// 2 %).
fn assert_scale(seen: &Value) {
    let state = &seen["selected"];
    let m = state["scale"]["m"].as_f64().expect("scale metres");
    let mantissa = m / 10f64.powf(m.log10().floor());
    assert!([1.0, 2.0, 5.0].iter().any(|k| (mantissa - k).abs() < 1e-9), "a round length: {m} m");
    assert_eq!(seen["scale_text"], format!("{m} m"), "{seen}");
    let uavs = state["uavs"].as_array().expect("uavs");
    let num = |u: &Value, k: &str| u[k].as_f64().expect("number");
    let (a, b) = uavs
        .iter()
        .flat_map(|a| uavs.iter().map(move |b| (a, b)))
        .find(|(a, b)| (num(a, "x") - num(b, "x")).hypot(num(a, "y") - num(b, "y")) > 1.0)
        .expect("two UAVs a metre apart");
    let px_per_m = (num(a, "px") - num(b, "px")).hypot(num(a, "py") - num(b, "py"))
        / (num(a, "x") - num(b, "x")).hypot(num(a, "y") - num(b, "y"));
    let css = seen["scale_css_px"].as_f64().expect("bar width") * seen["dpr"].as_f64().expect("dpr");
    assert!((css / (m * px_per_m) - 1.0).abs() < 0.02, "a {m} m bar {css} px long at {px_per_m} px/m");
}

/// UAV 1, clicked where the map drew it, is selected (its panel too), and its estimates are drawn
/// as rings of at least 5 px above the arrows, most within 1 m of another UAV.
fn assert_selected_on_map(seen: &Value) {
    let state = &seen["selected"];
    assert_eq!(state["selected"], 1, "{state}");
    assert_eq!(seen["panel_selected"], "1", "{seen}");
    let layers: Vec<&str> = state["layers"].as_array().expect("layers").iter().filter_map(Value::as_str).collect();
    let at =
        |name: &str| layers.iter().position(|l| *l == name).unwrap_or_else(|| panic!("no {name} layer: {layers:?}"));
    assert!(at("estimates") > at("uavs"), "estimates above the arrows: {layers:?}");
    let marks = state["estimates"].as_array().expect("estimates");
    assert!(!marks.is_empty(), "UAV 1's estimates drawn: {state}");
    assert!(
        marks.iter().all(|e| e["of"] == 1 && e["r"].as_f64().unwrap_or(0.0) >= 5.0),
        "rings of UAV 1's, 5 px or more: {marks:?}"
    );
    let others: Vec<(f64, f64)> = state["uavs"]
        .as_array()
        .expect("uavs")
        .iter()
        .filter(|u| u["id"] != 1)
        .map(|u| (u["x"].as_f64().unwrap_or(f64::NAN), u["y"].as_f64().unwrap_or(f64::NAN)))
        .collect();
    let near = marks
        .iter()
        .filter(|e| {
            others.iter().any(|&(x, y)| {
                (e["x"].as_f64().unwrap_or(f64::NAN) - x).hypot(e["y"].as_f64().unwrap_or(f64::NAN) - y) < 1.0
            })
        })
        .count();
    assert!(near * 4 >= marks.len() * 3, "{near} of {} estimates near a UAV: {marks:?}", marks.len());
}

/// Seconds in a text like `4.2 s`.
fn seconds(text: &str) -> f64 {
    text.trim()
        .strip_suffix(" s")
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("not a time in seconds: {text:?}"))
}

/// The replay's seek bar shows the sought time and the total, its ends' times, and with the
/// cursor over its middle the time there (within 8 % of the run).
fn assert_seek_times(seen: &Value, tick: u64, dt: f64, truth: &BTreeMap<(u64, u64), (f64, f64)>) {
    let last_t = truth.keys().map(|(t, _)| *t).max().expect("ticks") as f64 * dt;
    let first_t = truth.keys().map(|(t, _)| *t).min().expect("ticks") as f64 * dt;
    let text = |k: &str| seen[k].as_str().unwrap_or_else(|| panic!("{k}: {seen}")).to_string();
    assert_eq!(text("seek_time"), format!("{:.1} s / {:.1} s", tick as f64 * dt, last_t), "{seen}");
    assert_eq!(text("seek_end"), format!("{last_t:.1} s"), "{seen}");
    assert!((seconds(&text("seek_start")) - first_t).abs() < 0.051, "{seen}");
    let mid = (first_t + last_t) / 2.0;
    assert!(
        (seconds(&text("seek_hover")) - mid).abs() <= 0.08 * (last_t - first_t),
        "the bar's middle is about {mid} s: {seen}"
    );
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
    let world: Value = serde_json::from_str(&std::fs::read_to_string(run.join("world.json")).expect("world.json"))
        .expect("world json");
    let r_uav = world["body_radius_m"].as_f64().expect("body radius");
    let mut surfaces: Vec<(f64, f64, f64)> = world["trees"]
        .as_array()
        .expect("trees")
        .iter()
        .map(|t| (t[0].as_f64().unwrap_or(0.0), t[1].as_f64().unwrap_or(0.0), t[2].as_f64().unwrap_or(0.0)))
        .collect();
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
    let args = [
        "run",
        &sc,
        "--out",
        out.to_str().expect("utf8"),
        "--run",
        &run,
        "--quiet",
        "--time-mode",
        "realtime",
        "--view",
        "0",
    ];
    let (_run, page, ws) = start_serving(&args, "view: ", &dir.path().join("run.log"));

    // Offered both names, the SDK's server chooses the current one.
    assert_poses(&py("foxglove_ws.py", &[&ws, "/uav/1/pose", "20", "60"]), "foxglove.sdk.v1");
    // Lichtblick offers only the old name: the front door answers with it.
    assert_poses(
        &py("foxglove_ws.py", &[&ws, "/uav/1/pose", "20", "60", "foxglove.websocket.v1"]),
        "foxglove.websocket.v1",
    );

    let shot = output_dir("live").join("live.png");
    let seen = py("page.py", &[&page, shot.to_str().expect("utf8"), "live", "3"]);
    assert!(shot.exists(), "screenshot kept");
    assert_eq!(seen["panels"], 5, "a panel per UAV: {seen}");
    let (first, second) = (&seen["first"], &seen["second"]);
    let tick = |v: &Value| v["tick"].as_u64().unwrap_or_else(|| panic!("a tick: {seen}"));
    assert!(tick(second) > tick(first), "the clock moves: {seen}");
    let moved = |a: &Value, b: &Value| {
        (a["x"].as_f64().unwrap_or(0.0) - b["x"].as_f64().unwrap_or(0.0))
            .hypot(a["y"].as_f64().unwrap_or(0.0) - b["y"].as_f64().unwrap_or(0.0))
            > 0.05
    };
    assert!(
        first["uavs"]
            .as_array()
            .expect("uavs")
            .iter()
            .zip(second["uavs"].as_array().expect("uavs"))
            .any(|(a, b)| moved(a, b)),
        "drawn UAVs move: {seen}"
    );
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
    // Opened 5 s or more into the run, the page has at its first frame every trail back to the
    // start (or the 20 s a trail keeps) and up to that frame.
    let first_t = seen["first_trails"]["t"].as_f64().expect("first frame's t");
    assert!(first_t >= 5.0, "the page was opened late: {}", seen["first_trails"]);
    assert_trails_on_truth(
        &seen["first_trails"]["trails"],
        (first_t - 19.5).max(0.5),
        first_t - 1e-6,
        &truth,
        tick_length(&out),
    );
    assert_legend(seen["legend"].as_str().expect("legend"));
    assert_scale(&seen);
    assert_selected_on_map(&seen);
    assert_units(seen["panel"].as_str().expect("panel"));
}

#[test]
fn replay_seeks_to_a_tick_and_draws_its_positions() {
    let dir = tempfile::tempdir().expect("tempdir");
    let sc = common::forest5_cut(dir.path(), 8.0);
    let out = dir.path().join("run");
    let o = common::swarm_run(&[&sc, "--out", out.to_str().expect("utf8"), "--run", &run_id("replay")]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (_replay, page, _ws) = start_serving(
        &["replay", out.to_str().expect("utf8"), "--port", "0", "--paused"],
        "replay: ",
        &dir.path().join("replay.log"),
    );
    let shot = output_dir("replay").join("replay.png");
    let seen = py("page.py", &[&page, shot.to_str().expect("utf8"), "seek", "42", "2"]);
    assert!(shot.exists(), "screenshot kept");
    let state = &seen["seek"];
    assert_eq!(state["tick"], 42, "{seen}");
    let truth = truth(&out);
    assert_drawn_at_truth(state, &truth);
    assert_eq!(seen["scan"]["scan"]["tick"], 42, "the scan of the sought tick: {}", seen["scan"]["scan"]);
    assert_scan_drawn(&seen["scan"], 2, &out, &truth);
    assert_eq!(seen["panel_selected"], "2", "UAV 2 clicked on the map: {seen}");
    let dt = tick_length(&out);
    assert_trails_on_truth(&seen["trails"], 0.5, 42.0 * dt - 1e-6, &truth, dt);
    assert_seek_times(&seen, 42, dt, &truth);
    assert_legend(seen["legend"].as_str().expect("legend"));
}

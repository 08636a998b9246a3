//! End to end: a run killed at a random moment (SIGKILL of `swarm run`: no cleanup code runs)
//! is made whole by `swarm recover`. Before recovery, `swarm run` refuses to fly over the folder
//! and says how to recover it; after, Foxglove's Python `mcap` reader opens `run.mcap` by its
//! summary section, with a pose per UAV for every tick the CSVs hold, and the summary counts the
//! ticks the CSVs hold, losing at most the last sim second the killed run had written.

mod common;

use common::{output_within, python, run_id, summary, SWARM, TOOL_LIMIT};
use serde_json::Value;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Forest-40: 40 UAVs, far from its goal for the first minute of wall time on any machine here.
const SCENARIO: &str = "forest-40";
const UAVS: u64 = 40;
/// Control ticks per sim second (forest-40's 10 Hz), and so the most ticks a kill may lose.
const TICKS_PER_S: u64 = 10;

/// The ticks of `trajectories.csv`, in order, one per complete row (a row cut by the kill is
/// not counted; none before the file exists).
fn csv_ticks(dir: &Path) -> Vec<u64> {
    let text = std::fs::read_to_string(dir.join("trajectories.csv")).unwrap_or_default();
    text.split_inclusive('\n')
        .skip(1)
        .filter(|l| l.ends_with('\n'))
        .filter_map(|l| l.split(',').next()?.parse().ok())
        .collect()
}

/// A kill delay in [2, 6) s after the first rows: random per test run, printed for a rerun.
fn kill_delay() -> Duration {
    let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).expect("clock").subsec_nanos();
    let d = Duration::from_millis(2000 + u64::from(nanos) % 4000);
    eprintln!("killing swarm run {d:?} after its first rows");
    d
}

#[test]
fn a_killed_run_is_recovered_and_read_by_the_python_mcap_reader() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("run");
    let out_s = out.to_str().expect("utf-8 path");
    let run = run_id("recover");
    let mut launcher = Command::new(SWARM)
        .args(["run", SCENARIO, "--quiet", "--run", &run, "--out", out_s])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("swarm run");
    let deadline = Instant::now() + Duration::from_secs(120);
    while csv_ticks(&out).is_empty() {
        assert!(Instant::now() < deadline, "the run never wrote a row");
        std::thread::sleep(Duration::from_millis(50));
    }
    std::thread::sleep(kill_delay());
    launcher.kill().expect("SIGKILL");
    launcher.wait().expect("reaped");
    assert!(!out.join("summary.json").exists(), "killed before its end: no summary");
    let written = *csv_ticks(&out).last().expect("rows");

    let again = output_within(Command::new(SWARM).args(["run", "forest-5", "--quiet", "--out", out_s]), TOOL_LIMIT);
    let said = String::from_utf8_lossy(&again.stderr);
    assert!(!again.status.success(), "swarm run does not fly over a cut-short run");
    assert!(said.contains("cut short") && said.contains(&format!("swarm recover {out_s}")), "{said}");

    let rec = output_within(Command::new(SWARM).args(["recover", out_s]), TOOL_LIMIT);
    let said = String::from_utf8_lossy(&rec.stdout);
    assert!(rec.status.success(), "swarm recover: {said}\n{}", String::from_utf8_lossy(&rec.stderr));
    assert!(said.contains("cut_short") && said.contains("run.mcap rewritten"), "{said}");
    assert!(!out.join("journal.mcap").exists(), "the journal is gone once recovered");

    let ticks = csv_ticks(&out);
    let last = *ticks.last().expect("recovered rows");
    assert!(
        written.saturating_sub(last) <= TICKS_PER_S,
        "at most one sim second lost: the killed run had tick {written}, recovered {last}"
    );
    assert_eq!(ticks.len() as u64, last * UAVS, "a row per UAV for every tick from 1 to {last}");
    let s = summary(&out);
    assert_eq!(s["end_reason"], "cut_short");
    assert_eq!(s["ticks"].as_u64(), Some(last), "the summary counts the ticks the CSVs hold");
    assert!(out.join("run.png").exists() && out.join("world.json").exists(), "figures and world drawn");

    let py = output_within(
        Command::new(python())
            .arg(concat!(env!("CARGO_MANIFEST_DIR"), "/py/read_mcap.py"))
            .arg(out.join("run.mcap"))
            .args(["1", "0.0"]),
        TOOL_LIMIT,
    );
    assert!(
        py.status.success(),
        "the Python reader opens the recovered run.mcap: {}",
        String::from_utf8_lossy(&py.stderr)
    );
    let read: Value = serde_json::from_slice(&py.stdout).expect("reader json");
    let count = |t: &str| read["topics"][t]["count"].as_u64().unwrap_or(0);
    assert!(count("/tf") >= last, "a transform set for each of the {last} ticks: {}", count("/tf"));
    for id in 1..=UAVS {
        assert!(count(&format!("/uav/{id}/pose")) >= last, "UAV {id}: a pose for each of the {last} ticks");
    }
    assert_eq!(read["chunk_compressions"], serde_json::json!(["zstd"]));

    let twice = output_within(Command::new(SWARM).args(["recover", out_s]), TOOL_LIMIT);
    assert!(twice.status.success() && String::from_utf8_lossy(&twice.stdout).contains("nothing to recover"));
}

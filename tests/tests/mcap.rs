//! End to end: `run.mcap` read by a reader no one here wrote. Forest-5 is flown piece by piece
//! (hub, `swarm record`, UAV 1 alone and 2-5 in an agent host, so the recorder takes both kinds of
//! sensor message) so a `swarm tap` can listen to UAV 1's scans before the first
//! tick; Foxglove's Python `mcap` and `mcap-protobuf-support` then read the recording: every
//! topic there with its schema, one message per tick (and per UAV) where that is the rule, every
//! chunk zstd-compressed (decompressed by the reader's own `zstandard`), and the LaserScan of one
//! tick equal, range for range, to the scan the hub sent on the wire.

mod common;

use common::{python, run_id, start_hub, summary, Proc, RUN_LIMIT, TOOL_LIMIT};
use serde_json::Value;
use std::process::Command;

/// Forest-5 cut to this many sim seconds (50 ticks at 10 Hz).
const FLY_S: f64 = 5.0;
/// The tick whose scan is compared.
const TICK: u64 = 20;

#[test]
fn run_mcap_is_read_by_foxglove_readers_and_holds_the_wire_scans() {
    let dir = tempfile::tempdir().expect("tempdir");
    let sc = common::forest5_cut(dir.path(), FLY_S);
    let run = run_id("mcap");
    let (mut hub, loc) = start_hub(&sc, &run, dir.path());
    let out = dir.path().join("rec");
    let mut rec = common::start_recorder(&run, &loc, &out, dir.path());
    let scans = common::tap_listening(&[
        &format!("swarm/{run}/uav/1/sense"),
        "--connect",
        &loc,
        "--count",
        &(TICK + 1).to_string(),
        "--duration",
        "300",
    ]);
    // UAV 1 alone, 2-5 in a host: the scene records both kinds of sensor message.
    let _agents: Vec<Proc> = [("--id", "1"), ("--ids", "2-5")]
        .iter()
        .map(|(flag, ids)| {
            Proc::start(
                &["agent", "--run", &run, flag, ids, "--connect", &loc],
                &dir.path().join(format!("a{ids}.log")),
            )
        })
        .collect();
    assert!(rec.wait_for(RUN_LIMIT).expect("the run ends").success(), "recorder failed: see rec.log");
    let _ = hub.wait_for(std::time::Duration::from_secs(20));

    let wire: Value = scans
        .output()
        .lines()
        .map(|l| serde_json::from_str::<Value>(l).expect("tap json"))
        .find(|v| v["msg"]["Sense"]["scan"]["tick"] == TICK)
        .unwrap_or_else(|| panic!("tap saw no scan of tick {TICK}"));
    let wire = &wire["msg"]["Sense"]["scan"];
    let t_s = wire["t_s"].as_f64().expect("t_s");

    let py = common::output_within(
        Command::new(python())
            .arg(concat!(env!("CARGO_MANIFEST_DIR"), "/py/read_mcap.py"))
            .arg(out.join("run.mcap"))
            .arg("1")
            .arg(format!("{t_s:?}")),
        TOOL_LIMIT,
    );
    assert!(py.status.success(), "read_mcap.py: {}", String::from_utf8_lossy(&py.stderr));
    let read: Value = serde_json::from_slice(&py.stdout).expect("reader json");
    let topics = &read["topics"];
    assert_eq!(read["chunk_compressions"], serde_json::json!(["zstd"]), "every chunk compressed");

    let ticks = summary(&out)["ticks"].as_u64().expect("ticks");
    assert_eq!(ticks, (FLY_S * 10.0) as u64, "the run flew to its time limit");
    let count = |t: &str| topics[t]["count"].as_u64().unwrap_or_else(|| panic!("topic {t} missing: {topics:#}"));
    let schema = |t: &str| topics[t]["schema"].as_str().unwrap_or_default().to_string();
    // Published by the hub, and fetched once more by the recorder in case that came first.
    assert!((1..=2).contains(&count("/world")), "{topics:#}");
    assert_eq!(schema("/world"), "foxglove.SceneUpdate");
    assert_eq!(count("/tf"), ticks, "one transform set per tick");
    assert_eq!(count("/radio"), ticks, "one radio graph per tick");
    assert!(count("/trails") >= FLY_S as u64, "a trail per sim second");
    if !topics["/events"].is_null() {
        assert_eq!(schema("/events"), "foxglove.Log", "events: a Log channel");
    }
    for id in 1..=5 {
        assert_eq!(count(&format!("/uav/{id}/pose")), ticks, "UAV {id}: a pose per tick");
        assert_eq!(schema(&format!("/uav/{id}/pose")), "foxglove.PoseInFrame");
        assert_eq!(count(&format!("/uav/{id}/scan")), ticks, "UAV {id}: a scan per tick");
        assert_eq!(schema(&format!("/uav/{id}/scan")), "foxglove.LaserScan");
        assert_eq!(
            count(&format!("/uav/{id}/numbers")),
            count(&format!("/uav/{id}/estimates")),
            "UAV {id}: numbers and estimates per state"
        );
        assert!(count(&format!("/uav/{id}/numbers")) >= ticks - 1, "UAV {id}: numbers every tick");
        assert_eq!(topics[format!("/uav/{id}/numbers")]["encoding"], "json");
    }

    let scan = &read["scan"];
    assert_eq!(scan["frame_id"], "uav1", "the scan is in UAV 1's body frame");
    let mcap_ranges = scan["ranges"].as_array().expect("ranges");
    let wire_ranges = wire["ranges_m"].as_array().expect("wire ranges");
    assert_eq!(mcap_ranges.len(), wire_ranges.len());
    assert!(wire_ranges.iter().any(Value::is_number), "the compared scan sees something");
    for (i, (m, w)) in mcap_ranges.iter().zip(wire_ranges).enumerate() {
        // Both sides are the wire's f32: widened to f64 in the MCAP, printed shortest by the tap.
        let f = |v: &Value| v.as_f64().map(|x| x as f32);
        assert_eq!(f(m), f(w), "beam {i} of tick {TICK}");
    }
    let start = scan["start_angle"].as_f64().expect("start") as f32;
    assert_eq!(start, wire["angle_min"].as_f64().expect("angle_min") as f32);
}

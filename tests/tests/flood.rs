//! End to end: a flood of malformed payloads on keys an outsider can reach, while forest-5 flies
//! in lockstep. Every bad payload is counted and dropped (the hub's `malformed_cmds`, the agents'
//! `malformed_messages` in the summary), and the swarm flies exactly as it does without the flood:
//! same trajectories byte for byte, goal reached, no collision. The x real time of both flights is
//! printed with their ratio (measured, not asserted: the machine's load decides it).

mod common;

use common::{run_id, start_hub, start_recorder, Proc, RUN_LIMIT};
use std::time::Duration;

/// Garbage for a command key: a `Cmd` tag with a body cut short (a structured message, truncated).
const BAD_CMD_HEX: &str = "05 02 00";
/// Garbage for a share key: no variant has tag 255.
const BAD_SHARE_HEX: &str = "ff 00 13 37 de ad be ef";

/// What one flight left behind.
struct Flight {
    summary: serde_json::Value,
    trajectories: String,
    hub_log: String,
    flood_logs: Vec<String>,
}

/// Flies forest-5 by hand (hub, recorder, five agents on loopback); with `flood`, two publishers
/// send malformed payloads every millisecond on UAV 3's command key and on its obstacle-share key
/// from before the agents start until the run is over.
fn fly(flood: bool) -> Flight {
    let dir = tempfile::tempdir().expect("tempdir");
    let run = run_id(if flood { "flood" } else { "calm" });
    let (mut hub, loc) = start_hub("forest-5", &run, dir.path());
    let out = dir.path().join("rec");
    let mut rec = start_recorder(&run, &loc, &out, dir.path());
    let flooders: Vec<Proc> = if flood {
        [("uav/3/cmd", BAD_CMD_HEX), ("uav/3/share/obstacles", BAD_SHARE_HEX)]
            .iter()
            .enumerate()
            .map(|(i, (key, hex))| {
                let key = format!("swarm/{run}/{key}");
                let args = ["put", &key, "--hex", hex, "--repeat", "0", "--every-ms", "1", "--connect", &loc];
                Proc::start(&args, &dir.path().join(format!("flood-{i}.log")))
            })
            .collect()
    } else {
        Vec::new()
    };
    // Let the floods get going before the first tick.
    std::thread::sleep(Duration::from_millis(if flood { 1500 } else { 0 }));
    let _agents: Vec<Proc> = (1..=5)
        .map(|id| {
            let args = ["agent", "--run", &run, "--id", &id.to_string(), "--connect", &loc];
            Proc::start(&args, &dir.path().join(format!("agent-{id}.log")))
        })
        .collect();
    let status = rec.wait_for(RUN_LIMIT).expect("the recorder finishes with the run");
    assert!(status.success(), "recorder: {status:?}");
    assert!(hub.wait_for(Duration::from_secs(30)).expect("hub exits after the run").success(), "hub did not fail");
    drop(flooders);
    let read = |name: &str| std::fs::read_to_string(dir.path().join(name)).unwrap_or_default();
    Flight {
        summary: common::summary(&out),
        trajectories: std::fs::read_to_string(out.join("trajectories.csv")).expect("trajectories.csv"),
        hub_log: read("hub.log"),
        flood_logs: if flood { vec![read("flood-0.log"), read("flood-1.log")] } else { Vec::new() },
    }
}

/// The `malformed_cmds=N` the hub logs when it ends.
fn hub_malformed(log: &str) -> u64 {
    log.split("malformed_cmds=")
        .nth(1)
        .and_then(|r| r.split(|c: char| !c.is_ascii_digit()).next())
        .and_then(|n| n.parse().ok())
        .unwrap_or(0)
}

/// The highest `sent=N` a flooder logged (it logs every 1000 payloads).
fn flood_sent(log: &str) -> u64 {
    log.split("sent=")
        .skip(1)
        .filter_map(|r| r.split(|c: char| !c.is_ascii_digit()).next()?.parse().ok())
        .max()
        .unwrap_or(0)
}

#[test]
fn a_flood_of_malformed_payloads_changes_nothing_the_swarm_does() {
    let calm = fly(false);
    let flooded = fly(true);
    for (name, f) in [("calm", &calm), ("flooded", &flooded)] {
        let s = &f.summary;
        assert_eq!(s["reached_goal"], true, "{name}: the swarm reaches the goal: {s:#}");
        assert_eq!(s["collisions"], 0, "{name}: no collision: {s:#}");
    }
    let agents_malformed: u64 = flooded.summary["agents"]
        .as_array()
        .expect("agents")
        .iter()
        .map(|a| a["malformed_messages"].as_u64().unwrap_or(0))
        .sum();
    let hub_bad = hub_malformed(&flooded.hub_log);
    assert!(hub_bad > 0, "the hub counted the malformed commands: {}", flooded.hub_log);
    assert!(
        agents_malformed > 0,
        "the agents in UAV 3's range counted the malformed shares: {:#}",
        flooded.summary["agents"]
    );
    assert_eq!(hub_malformed(&calm.hub_log), 0, "no malformed command without the flood");
    assert!(calm.trajectories == flooded.trajectories, "lockstep: the flood changed the trajectories");
    let speed = |f: &Flight| f.summary["sim_speed"].as_f64().expect("sim_speed");
    let sent: Vec<u64> = flooded.flood_logs.iter().map(|l| flood_sent(l)).collect();
    println!(
        "flood: x real time {:.1} calm, {:.1} flooded (ratio {:.2}); flooders sent at least {:?} payloads; \
         counted: hub {hub_bad} malformed commands, agents {agents_malformed} malformed shares",
        speed(&calm),
        speed(&flooded),
        speed(&flooded) / speed(&calm),
        sent
    );
}

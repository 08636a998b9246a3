//! End to end: `swarm scale` flies a short series with real processes and reports a sane row
//! (its speeds are measurements, never asserted).

mod common;

use common::{output_within, RUN_LIMIT, SWARM};
use std::process::Command;

/// One short forest-5 run (a name that does not exist is skipped, not fatal): one row, 5 UAVs,
/// a positive speed and memory, no collision; the table, rows and both pictures are written.
#[test]
fn scale_flies_a_series_and_reports_a_sane_row() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out_dir = dir.path().join("study");
    let out = output_within(
        Command::new(SWARM)
            .args(["scale", "--scenarios", "forest-5,no-such-scenario", "--time-limit", "4", "--json", "--out"])
            .arg(&out_dir),
        RUN_LIMIT,
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("no-such-scenario: no such file or built-in scenario, skipped"), "{stderr}");
    let rows: serde_json::Value = serde_json::from_slice(&out.stdout).expect("--json prints the rows");
    let rows = rows.as_array().expect("an array of rows");
    assert_eq!(rows.len(), 1, "{rows:#?}");
    let r = &rows[0];
    assert_eq!(
        (r["scenario"].as_str(), r["uavs"].as_u64(), r["collisions"].as_u64()),
        (Some("forest-5"), Some(5), Some(0)),
        "{r:#}"
    );
    let positive = |k: &str| r[k].as_f64().is_some_and(|v| v > 0.0);
    for k in ["x_real_time", "rss_total_mib", "rss_per_uav_mib", "hub_tick_p99_ms", "agent_step_p99_ms"] {
        assert!(positive(k), "{k} in {r:#}");
    }
    assert!(r["processes"].as_u64().is_some_and(|n| n >= 2), "a hub and agents: {r:#}");
    assert!((r["sim_time_s"].as_f64().expect("sim time") - 4.0).abs() < 0.2, "--time-limit caps the run: {r:#}");
    let table = std::fs::read_to_string(out_dir.join("scale.md")).expect("scale.md");
    assert!(table.contains("| forest-5 | 5 | icp | lockstep |"), "{table}");
    for f in ["scale.json", "scale.svg", "scale.png"] {
        assert!(std::fs::metadata(out_dir.join(f)).is_ok_and(|m| m.len() > 100), "{f} written");
    }
}

//! End to end: `swarm icp-eval --cases` on a small committed file (`tests/data/icp-eval-cases.json`)
//! with one case whose answer is known and one that is ambiguous by construction.

mod common;

use common::{output_within, SWARM, TOOL_LIMIT};
use std::process::Command;

/// Case 1 (an irregular set of trunks, 8 of 10 shared) must be placed right; case 2 (a square
/// lattice, which looks the same a quarter turn round) must be refused as ambiguous: nothing is
/// wrong but accepted. The table names the quoted Open3D peer.
#[test]
fn icp_eval_places_the_known_case_and_refuses_the_ambiguous_one() {
    let file = concat!(env!("CARGO_MANIFEST_DIR"), "/data/icp-eval-cases.json");
    let out = output_within(Command::new(SWARM).args(["icp-eval", "--json", "--cases", file]), TOOL_LIMIT);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(stdout.lines().count(), 1, "--json prints one line: {stdout}");
    let r: serde_json::Value = serde_json::from_str(&stdout).expect("one JSON line");
    let all = &r["all"];
    let count = |k: &str| all[k].as_u64();
    assert_eq!(
        (count("cases"), count("right"), count("ambiguous"), count("no_fit"), count("wrong_accepted")),
        (Some(2), Some(1), Some(1), Some(0), Some(0)),
        "{r:#}"
    );
    assert_eq!(r["shared_5_plus"]["cases"].as_u64(), Some(2), "both cases share at least 5 trees: {r:#}");
    assert!(all["ms_per_case"].as_f64().is_some_and(|v| v > 0.0), "{r:#}");

    let out = output_within(Command::new(SWARM).args(["icp-eval", "--cases", file]), TOOL_LIMIT);
    let table = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success() && table.contains("| all | 2 | 50.0 % | 50.0 % (1 + 0) | 0.0 % |"), "{table}");
    assert!(table.contains("Open3D") && table.contains("82.5 %"), "{table}");
}

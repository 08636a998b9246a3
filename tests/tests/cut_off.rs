//! End to end over real Zenoh and real processes: issue 24's half-swarm cut off from whoever knew
//! the goal comes back.
//!
//! `forest-9-cut-off`: nine UAVs, two informed, through 10 trees/100 m² over burst loss; a halves
//! partition from 15 s to 45 s cuts UAVs 5-9 off both informed UAVs, and informed UAV 1 freezes
//! among the trees at 30 s. With the group behaviour (hop counts in every share; the cut-off half
//! flies back to where it last had a path, then follows the UAVs closer to an informed one) and
//! K21's barrier, nobody touches anything, the flying UAVs end together and the goal rule is met.
//! With the group behaviour and arrival (issue 25, which also leads the half back once it hears
//! the swarm) both off, the half flies on with nobody steering it and ends farther from the goal
//! than the swarm started.
//!
//! `forest-9-cut-off-long` (issue 46): the partition lasts to 75 s, the informed half is at the
//! goal beyond radio range by then, and the half holding where it last had a path waits for
//! nobody. With the search (`[lost_contact] search_after_s`) it flies on the way it was going and
//! comes in; without it, it holds for good.
//!
//! `forest-9-cut-off-icp` and `forest-9-cut-off-dense` (issue 46): over ICP, and with 15 trees
//! per 100 m². In both a UAV stops for good at the mouth of the gap between the frozen UAV and a
//! trunk unless K21's detour takes it round; over ICP the half also flies off led by nobody it
//! localizes unless a path leads only through a neighbour in sight (`lead_in_sight`).
//! Lockstep, so every outcome repeats exactly. The flights with what each case needs go over real
//! Zenoh and real processes; the controls without it, which show that it is what makes the
//! difference, fly in one process (`swarm floor`, the same flight byte for byte: `floor.rs`), at a
//! fraction of the cost.

mod common;

use common::{output_within, run_id, summary, swarm_run, RUN_LIMIT, SWARM};
use std::path::Path;
use std::process::Command;

/// The scenario shipped in `scenarios/`.
const CUT_OFF: &str = include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenarios/forest-9-cut-off.toml"));

/// Issue 46's variant, the partition healed at 75 s.
const CUT_OFF_LONG: &str =
    include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenarios/forest-9-cut-off-long.toml"));

/// Issue 46's variant over ICP.
const CUT_OFF_ICP: &str = include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenarios/forest-9-cut-off-icp.toml"));

/// Issue 46's variant with 15 trees per 100 m².
const CUT_OFF_DENSE: &str =
    include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenarios/forest-9-cut-off-dense.toml"));

/// The UAV that freezes (the hub's goal rule leaves it out; it cannot move).
const FROZEN: u32 = 1;

/// Flies a scenario (text) to its end; returns the summary, per flying UAV its distance to the
/// nearest other flying UAV at the last tick [m], and the farthest flying UAV's distance from
/// the goal then [m].
fn fly(toml: &str, tag: &str) -> (serde_json::Value, Vec<(u32, f64)>, f64) {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("scenario.toml");
    std::fs::write(&path, toml).expect("write scenario");
    let out_dir = dir.path().join("run");
    let out = swarm_run(&[
        path.to_str().expect("utf8"),
        "--out",
        out_dir.to_str().expect("utf8"),
        "--run",
        &run_id(tag),
        "--no-mcap",
    ]);
    assert!(out.status.success(), "{tag}: {}", String::from_utf8_lossy(&out.stderr));
    (summary(&out_dir), nearest_at_end(&out_dir), farthest_from_goal(&out_dir))
}

/// As [`fly`], in one process: `swarm floor` records the lockstep flight into a run folder
/// without a message (for the controls; see the module doc).
fn fly_in_process(toml: &str, tag: &str) -> (serde_json::Value, Vec<(u32, f64)>, f64) {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("scenario.toml");
    std::fs::write(&path, toml).expect("write scenario");
    let floor = dir.path().join("floor");
    let mut cmd = Command::new(SWARM);
    cmd.args(["floor", "--scenarios", path.to_str().expect("utf8"), "--out", floor.to_str().expect("utf8")]);
    let out = output_within(&mut cmd, RUN_LIMIT);
    assert!(out.status.success(), "{tag}: {}", String::from_utf8_lossy(&out.stderr));
    let mut folders = std::fs::read_dir(&floor).expect("the floor's folder").map(|e| e.expect("entry").path());
    let out_dir = folders.next().expect("one run folder");
    (summary(&out_dir), nearest_at_end(&out_dir), farthest_from_goal(&out_dir))
}

/// The goal of the scenario, and how far from it the swarm starts (its start positions are
/// within 4 m of the origin) [m].
const GOAL: (f64, f64) = (30.0, 0.0);

/// The largest distance from the goal of a flying UAV at the last tick [m].
fn farthest_from_goal(dir: &Path) -> f64 {
    let text = std::fs::read_to_string(dir.join("trajectories.csv")).expect("trajectories.csv");
    let rows: Vec<Vec<&str>> = text.lines().skip(1).map(|l| l.split(',').collect()).collect();
    let last = rows.iter().map(|f| f[0].parse::<u64>().expect("tick")).max().expect("rows");
    rows.iter()
        .filter(|f| f[0].parse::<u64>().expect("tick") == last && f[2].parse::<u32>().expect("id") != FROZEN)
        .map(|f| (f[3].parse::<f64>().expect("x") - GOAL.0).hypot(f[4].parse::<f64>().expect("y") - GOAL.1))
        .fold(0.0, f64::max)
}

/// Each flying UAV's distance to its nearest other flying UAV at the last tick of the run.
fn nearest_at_end(dir: &Path) -> Vec<(u32, f64)> {
    let text = std::fs::read_to_string(dir.join("trajectories.csv")).expect("trajectories.csv");
    let rows: Vec<(u64, u32, f64, f64)> = text
        .lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (f[0].parse().expect("tick"), f[2].parse().expect("id"), f[3].parse().expect("x"), f[4].parse().expect("y"))
        })
        .collect();
    let last = rows.iter().map(|r| r.0).max().expect("rows");
    let end: Vec<_> = rows.iter().filter(|r| r.0 == last && r.1 != FROZEN).collect();
    end.iter()
        .map(|a| {
            (a.1, end.iter().filter(|b| b.1 != a.1).map(|b| (a.2 - b.2).hypot(a.3 - b.3)).fold(f64::INFINITY, f64::min))
        })
        .collect()
}

#[test]
fn a_half_cut_off_from_the_informed_comes_back_and_the_swarm_meets_its_goal() {
    let (s, nearest, _) = fly(CUT_OFF, "cutoff");
    assert_eq!(s["collisions"], 0, "no contact: {:#}", s["collision_events"]);
    assert_eq!(s["reached_goal"], true, "the goal rule is met: {}", s["end_reason"]);
    let apart: Vec<_> = nearest.iter().filter(|(_, d)| *d > 10.0).collect();
    assert!(apart.is_empty(), "every flying UAV ends within 10 m of another: {apart:?}");

    // The group behaviour alone (arrival off) brings the half back too: every flying UAV ends
    // with the others, nearer the goal than the swarm started (30 m). Without arrival nothing
    // makes the swarm settle at the goal, so whether all eight are inside the 6 m disc at one
    // tick as it flies about it is chance (the hard barrier's flight was, at 140 s; the graded
    // barrier's ends orbiting, all within 18.7 m).
    let group_only = CUT_OFF.replace("[localization]", "[controller.k21]\narrival_radius_m = 0.0\n\n[localization]");
    assert_ne!(group_only, CUT_OFF, "arrival is turned off");
    let (s, nearest, far) = fly_in_process(&group_only, "cutoff-group");
    let apart: Vec<_> = nearest.iter().filter(|(_, d)| *d > 10.0).collect();
    assert!(apart.is_empty() && far < GOAL.0, "the group behaviour alone: {nearest:?}, {far:.1} m from the goal");
    assert_eq!(s["collisions"], 0, "{:#}", s["collision_events"]);

    // Both ways back off: the group behaviour, and arrival (issue 25), whose second hop count
    // also leads a half that hears the swarm again to the informed UAV at the goal.
    let off = CUT_OFF
        .replace(
            "[[netem]]                        # burst loss",
            "[lost_contact]\nregroup_after_s = 0.0\n\n[[netem]]                        # burst loss",
        )
        .replace("[localization]", "[controller.k21]\narrival_radius_m = 0.0\n\n[localization]");
    assert_eq!(
        off.matches("regroup_after_s = 0.0").count() + off.matches("arrival_radius_m = 0.0").count(),
        2,
        "both are turned off"
    );
    // The half flies off with nobody steering it, farther from the goal than the swarm started;
    // whether it leaves the rest behind (the hard barrier's flight: UAV 7 17.5 m from the
    // others) or takes informed UAV 2 with it (the graded barrier's: all together, 91.8 m away).
    let (s, nearest, far) = fly_in_process(&off, "cutoff-off");
    assert!(
        s["reached_goal"] == false && far > GOAL.0,
        "without it the half flies off: goal {}, {nearest:?}, {far:.1} m from the goal",
        s["reached_goal"]
    );
}

#[test]
fn a_half_cut_off_until_the_others_are_out_of_range_searches_the_way_it_went_and_comes_in() {
    let (s, nearest, far) = fly(CUT_OFF_LONG, "cutoff-long");
    meets_everything("long", &s, &nearest, far);

    // Without the search the half holds where it last had a path, 30 m short of the goal.
    let off = CUT_OFF_LONG.replace("search_after_s = 30.0", "search_after_s = 0.0");
    assert_ne!(off, CUT_OFF_LONG, "the search is turned off");
    let (s, _, far) = fly_in_process(&off, "cutoff-long-off");
    assert!(s["reached_goal"] == false && far > 20.0, "without it the half holds: {far:.1} m from the goal");
}

/// Asserts the whole of issue 46's rule for a variant of forest-9-cut-off: no contact, the goal met, every flying UAV
/// within 10 m of another at the end, and every check passed.
#[track_caller]
fn meets_everything(tag: &str, s: &serde_json::Value, nearest: &[(u32, f64)], far: f64) {
    assert_eq!(s["collisions"], 0, "{tag}: no contact: {:#}", s["collision_events"]);
    assert_eq!(s["reached_goal"], true, "{tag}: the goal rule is met: {} ({far:.1} m)", s["end_reason"]);
    let apart: Vec<_> = nearest.iter().filter(|(_, d)| *d > 10.0).collect();
    assert!(apart.is_empty(), "{tag}: every flying UAV ends within 10 m of another: {apart:?}");
    let failed: Vec<_> = s["checks"].as_array().expect("checks").iter().filter(|c| c["passed"] != true).collect();
    assert!(failed.is_empty(), "{tag}: {failed:#?}");
}

#[test]
fn over_icp_the_detour_and_a_lead_in_sight_bring_every_uav_to_the_goal() {
    let (s, nearest, far) = fly(CUT_OFF_ICP, "cutoff-icp");
    meets_everything("icp", &s, &nearest, far);
    assert_eq!(s["localization"]["mode"], "icp");

    // Without the lead in sight the half flies off led by nobody it localizes, out of the trees
    // where ICP has nothing to match, and holds there (UAVs 6-9 west of the forest, 16.6 m and
    // more from the informed at the goal).
    let off = CUT_OFF_ICP.replace("lead_in_sight = true", "lead_in_sight = false");
    assert_ne!(off, CUT_OFF_ICP, "the lead in sight is turned off");
    let (s, _, far) = fly_in_process(&off, "cutoff-icp-nolead");
    assert!(s["reached_goal"] == false && far > 20.0, "without it the half is lost: {far:.1} m from the goal");
}

#[test]
fn with_fifteen_trees_per_100_m2_the_detour_frees_the_informed_uav_and_it_leads_the_swarm_in() {
    let (s, nearest, far) = fly(CUT_OFF_DENSE, "cutoff-dense");
    meets_everything("dense", &s, &nearest, far);

    // Without the detour informed UAV 2 waits for good beside the frozen UAV 1 and a trunk, and
    // the others, led by nobody, circle trunks near the start (31.2 m from the goal).
    let off = CUT_OFF_DENSE.replace("detour_after_s = 5.0", "detour_after_s = 0.0");
    assert_ne!(off, CUT_OFF_DENSE, "the detour is turned off");
    let (s, _, far) = fly_in_process(&off, "cutoff-dense-nodetour");
    assert!(
        s["reached_goal"] == false && far > 20.0,
        "without it the swarm stays near the start: {far:.1} m from the goal"
    );
}

//! End to end over real Zenoh and real processes: issue 14's lost UAV finds its swarm again.
//!
//! `forest-9-stranded`: nine UAVs, two informed, through 10 trees/100 m² over burst loss; the
//! informed turn north at 50 s and uninformed UAV 9 is deaf and mute from 60 s to 90 s, while
//! the swarm turns. With the lost-contact layer (the default) UAV 9 flies back to where it last
//! estimated the swarm, finds it again as soon as the link is back, and the swarm meets its goal
//! rule; with the layer off (the controller alone, as before issue 14) it flies off for good.
//! Lockstep, so both outcomes repeat exactly; the bounds below leave room for small changes of
//! the controllers.

mod common;

use common::{run_id, summary, swarm_run};

/// The scenario shipped in `scenarios/`.
const STRANDED: &str = include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenarios/forest-9-stranded.toml"));

/// When UAV 9's link comes back [s] (the scenario's heal).
const HEAL_S: f64 = 90.0;

/// Radio range of the scenario (the default) [m].
const RADIO_RANGE_M: f64 = 10.0;

/// Flies a scenario file (text) to completion and returns its summary.
fn fly_text(toml: &str, tag: &str) -> serde_json::Value {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("scenario.toml");
    std::fs::write(&path, toml).expect("write scenario");
    let out_dir = dir.path().join("run");
    let run = run_id(tag);
    let out = swarm_run(&[path.to_str().expect("utf8"), "--out", out_dir.to_str().expect("utf8"), "--run", &run]);
    assert!(out.status.success(), "{tag}: {}", String::from_utf8_lossy(&out.stderr));
    summary(&out_dir)
}

fn agent(s: &serde_json::Value, id: u64) -> &serde_json::Value {
    s["agents"].as_array().expect("agents").iter().find(|a| a["id"] == id).expect("agent")
}

fn number(v: &serde_json::Value) -> f64 {
    v.as_f64().unwrap_or(f64::INFINITY)
}

/// The changes of the number of groups (components of the estimated neighbour graph), as
/// `(t_s, groups)`.
fn group_changes(s: &serde_json::Value) -> Vec<(f64, u64)> {
    let changes = s["connectivity"]["components_changes"].as_array().expect("components changes");
    changes.iter().map(|c| (number(&c["t_s"]), c["components"].as_u64().expect("components"))).collect()
}

/// The bound stated in docs/results.md: the isolated UAV never strays out of radio range of the swarm
/// (its nearest other UAV is always within 10 m), has a neighbour estimate again within 10 s of
/// the heal, and every UAV of the swarm is within the 10 m goal disc within 300 s, with no
/// collision; any UAV that was out of radio range of all others came back.
#[test]
fn an_isolated_uav_rejoins_and_the_swarm_meets_its_goal() {
    let s = fly_text(STRANDED, "rejoin");
    assert_eq!(s["reached_goal"], true, "{s:#}");
    assert!(number(&s["time_to_goal_s"]) <= 300.0, "{}", s["time_to_goal_s"]);
    assert_eq!(s["collisions"], 0, "{:#}", s["collision_events"]);
    let nine = agent(&s, 9);
    assert!(number(&nine["max_nearest_uav_m"]) <= RADIO_RANGE_M, "{nine:#}");
    let events = nine["contact_events"].as_array().expect("contact events");
    let lost = events.iter().find(|e| e["regained"] == false).expect("UAV 9 lost its neighbours while isolated");
    assert!((60.0..HEAL_S).contains(&number(&lost["t_s"])), "{events:?}");
    let regained = events.iter().find(|e| e["regained"] == true).expect("UAV 9 found its neighbours again");
    let t = number(&regained["t_s"]);
    assert!((HEAL_S..=HEAL_S + 10.0).contains(&t), "regained at {t} s: {events:?}");
    for a in s["agents"].as_array().expect("agents") {
        assert_ne!(a["rejoined"], false, "a UAV ended out of radio range of every other: {a:#}");
        assert!(a["time_alone_s"].as_f64().is_some(), "solitude reported: {a:#}");
    }
    let (last_t, last_groups) = *group_changes(&s).last().expect("a group change");
    assert_eq!(last_groups, 1, "the swarm ended split: {:?}", group_changes(&s));
    assert!((HEAL_S..=HEAL_S + 10.0).contains(&last_t), "one group from the heal on: {:?}", group_changes(&s));
}

/// Without the layer (`[lost_contact] enabled = false`: the controllers alone, and K21's arrival
/// of issue 25 off too, whose count also leads a straggler that hears the swarm to the goal)
/// the same run loses the swarm's unity: UAV 9 flies on east alone while isolated, the swarm that
/// finds it again after the heal splits later, it ends in more than one group and the goal rule
/// is not met. (Which UAVs follow UAV 9 is a detail of the trajectories; that the swarm splits
/// is not.)
#[test]
fn without_the_lost_contact_layer_the_isolated_uav_flies_off() {
    let s = fly_text(
        &format!("{STRANDED}\n[lost_contact]\nenabled = false\n\n[controller.k21]\narrival_radius_m = 0.0\n"),
        "norejoin",
    );
    assert_eq!(s["reached_goal"], false, "{s:#}");
    let changes = group_changes(&s);
    let (_, last_groups) = *changes.last().expect("a group change");
    assert!(last_groups >= 2, "the swarm ended as one group: {changes:?}");
    let split_after_heal = changes.iter().any(|&(t, groups)| t > HEAL_S + 10.0 && groups >= 2);
    assert!(split_after_heal, "no split after the heal: {changes:?}");
}

//! A crashed piece (issue 46 item 5): `kill -9` of one agent process, or of an agent host with
//! two agents, in the middle of a `swarm run`, in lockstep and in real time, the way a companion
//! computer dies. The hub goes on with the others at once (liveliness, not a tick timeout per
//! tick), the lost UAVs hover and are marked `lost` in the summary, their neighbours drop them
//! within the stale-estimate grace (the check says so), the others reach the goal and the goal
//! check judges them without the lost ones (the hub's rule still waits for a lost UAV, which
//! looks like one whose link will come back, so the run flies to its time limit), and the run
//! folder is whole. And the dead end a crash showed in
//! K21's hard barrier, replayed from a scenario, with the graded barrier that passes it.

mod common;

use common::{run_id, summary, Proc};
use std::path::Path;
use std::process::Command;
use std::time::Duration;

/// Waits until `count` ground-truth steps of `run` were seen (the swarm flies), logged in as
/// observer.
fn wait_steps(run: &str, loc: &str, folder: &Path, count: u32) {
    // The run's own credentials folder, read as the tests' `Creds`.
    let login = common::Creds(folder.join("credentials")).login("observer");
    let (key, count_s) = (format!("swarm/{run}/truth/step"), count.to_string());
    let mut args = vec![key.as_str(), "--connect", loc, "--count", &count_s, "--duration", "120"];
    args.extend(login.iter().map(String::as_str));
    let got = common::tap(&args);
    assert_eq!(got.lines().count(), count as usize, "the swarm flies: {got}");
}

/// The PID of the agent process of `run` whose id arguments are `ids_arg` (`--id 3`, `--ids 3-4`).
fn agent_pid(run: &str, ids_arg: &str) -> String {
    let pattern = format!("swarm-e2e agent --run {run} {ids_arg} ");
    let o = Command::new("pgrep").args(["-f", "--", &pattern]).output().expect("pgrep");
    let pids = String::from_utf8_lossy(&o.stdout).trim().to_string();
    assert!(!pids.is_empty() && !pids.contains('\n'), "one process for `{pattern}`: {pids:?}");
    pids
}

/// `swarm run forest-5 <extra>`; once it flies, `kill -9` of the agent process `ids_arg`, whose
/// UAVs are `victims`. Returns the run folder's summary and its terminal output.
fn crash(tag: &str, extra: &[&str], ids_arg: &str, victims: &[u64]) -> (tempfile::TempDir, serde_json::Value) {
    let dir = tempfile::tempdir().expect("tempdir");
    let folder = dir.path().join("run");
    let run = run_id(tag);
    let mut args = vec!["run", "forest-5", "--run", &run, "--out", folder.to_str().expect("utf8")];
    args.extend_from_slice(extra);
    let mut swarm = Proc::start(&args, &dir.path().join("run.log"));
    let loc = common::hub_locator(&folder);
    wait_steps(&run, &loc, &folder, 150);
    let pid = agent_pid(&run, ids_arg);
    let st = Command::new("kill").args(["-9", &pid]).status().expect("kill");
    assert!(st.success(), "kill -9 {pid}");
    let status = swarm.wait_for(Duration::from_secs(600)).expect("the run ends");
    let mut out = String::new();
    std::io::Read::read_to_string(swarm.child.stdout.as_mut().expect("stdout"), &mut out).expect("stdout");
    let log = std::fs::read_to_string(dir.path().join("run.log")).unwrap_or_default();
    assert!(status.success(), "{status:?}: {out}\n{log}");
    let s = summary(&folder);
    assert_eq!(s["end_reason"], "time_limit", "the hub's rule waits for the lost: {out}");
    let lost = s["lost"].as_array().expect("lost");
    let ids: Vec<u64> = lost.iter().map(|l| l["id"].as_u64().expect("id")).collect();
    assert_eq!(ids, victims, "the killed process's UAVs are lost: {lost:?}");
    let end_s = s["sim_time_s"].as_f64().expect("sim time");
    for l in lost {
        let at = l["at_s"].as_f64().expect("at_s");
        assert!(at > 10.0 && at < end_s, "lost mid-run, after 150 steps: {l}");
    }
    let said = format!("{out}\n{log}");
    assert!(said.contains("lost: the agents of UAVs"), "the run table says so: {said}");
    // Every check holds over the rest: no contact, no two closer than the bound, the neighbours
    // dropped the lost UAVs within the grace (stale_estimate), the rest together and at the goal
    // at the end (judged without the lost).
    let checks = s["checks"].as_array().expect("checks");
    assert!(checks.iter().all(|c| c["passed"] == true), "{checks:#?}");
    let goal = checks.iter().find(|c| c["name"] == "goal").expect("goal check");
    assert!(goal["detail"].as_str().unwrap_or("").contains("judged without the lost UAVs"), "{goal:#}");
    for f in ["summary.json", "trajectories.csv", "agent_states.csv", "run.mcap", "run.png"] {
        assert!(folder.join(f).exists(), "{f} in the run folder");
    }
    assert!(!folder.join("journal.mcap").exists(), "a clean end removes the journal");
    // From the crash on, the lost UAVs hover with no agent: alive false in the trajectories.
    let traj = std::fs::read_to_string(folder.join("trajectories.csv")).expect("csv");
    for &v in victims {
        let at = lost.iter().find(|l| l["id"] == v).and_then(|l| l["at_s"].as_f64()).expect("at");
        let after: Vec<Vec<String>> = traj
            .lines()
            .skip(1)
            .map(|l| l.split(',').map(str::to_string).collect::<Vec<_>>())
            .filter(|f| f[2] == v.to_string() && f[1].parse::<f64>().expect("t") >= at)
            .collect();
        assert!(!after.is_empty() && after.iter().all(|f| f[11] == "0" || f[11] == "false"), "UAV {v} dead after");
    }
    (dir, s)
}

/// In lockstep the hub waits for no one it knows is gone: the lost UAVs' late ticks (alive, no
/// command) are at most the tick of the crash, and the living ones have none.
fn assert_no_stall(s: &serde_json::Value, victims: &[u64]) {
    for a in s["agents"].as_array().expect("agents") {
        let late = a["late_ticks"].as_u64().expect("late_ticks");
        let bound = if victims.contains(&a["id"].as_u64().expect("id")) { 2 } else { 0 };
        assert!(late <= bound, "UAV {}: {late} late ticks", a["id"]);
    }
}

#[test]
fn a_killed_agent_process_in_lockstep_is_lost_and_the_rest_fly_on() {
    let victims = [3];
    let (_dir, s) = crash("crashsolo", &[], "--id 3", &victims);
    assert_no_stall(&s, &victims);
    println!("kill -9 of UAV 3's agent, lockstep: lost {:?}", s["lost"]);
}

#[test]
fn a_killed_agent_host_in_lockstep_loses_both_its_uavs_and_the_rest_fly_on() {
    let victims = [3, 4];
    let (_dir, s) = crash("crashhost", &["--agents-per-process", "2"], "--ids 3-4", &victims);
    assert_no_stall(&s, &victims);
    println!("kill -9 of the host of UAVs 3-4, lockstep: lost {:?}", s["lost"]);
}

/// Real time at four times the wall clock, to a time limit of 140 s (the rest arrive in about
/// 100 s), so the flight lasts 35 s.
const REALTIME: [&str; 6] =
    ["--time-mode", "realtime", "--set", "time.realtime_factor=4.0", "--set", "end.time_limit_s=140"];

#[test]
fn a_killed_agent_process_in_real_time_is_lost_and_the_rest_fly_on() {
    let (_dir, s) = crash("crashrt", &REALTIME, "--id 2", &[2]);
    println!("kill -9 of UAV 2's agent, real time x4: lost {:?}", s["lost"]);
}

#[test]
fn a_killed_agent_host_in_real_time_loses_both_its_uavs_and_the_rest_fly_on() {
    let extra: Vec<&str> = REALTIME.iter().copied().chain(["--agents-per-process", "2"]).collect();
    let (_dir, s) = crash("crashrthost", &extra, "--ids 3-4", &[3, 4]);
    println!("kill -9 of the host of UAVs 3-4, real time x4: lost {:?}", s["lost"]);
}

/// The goal check of a summary.
fn goal_check(s: &serde_json::Value) -> serde_json::Value {
    let checks = s["checks"].as_array().expect("checks");
    checks.iter().find(|c| c["name"] == "goal").cloned().expect("goal check")
}

/// The crash that found the hard barrier's dead end, replayed from the scenario: forest-5 with
/// UAV 3's agent killed at 19.2 s. UAV 5 is then 1.0 m from a trunk and from UAV 3's hovering
/// body, 129° apart: with the hard barrier (`barrier_ramp_m = 0`) no direction is left and it
/// waits there to the time limit (the goal check names it); the graded barrier lets it through
/// and the rest reach the goal (the goal check, judged without UAV 3, passes).
#[test]
fn the_graded_barrier_lets_a_uav_past_a_dead_uavs_body_beside_a_trunk() {
    let dir = tempfile::tempdir().expect("tempdir");
    let exp = dir.path().join("kill.toml");
    std::fs::write(&exp, "[[failures]]\nat_s = 19.2\nuav = 3\nkind = \"kill\"\n").expect("write");
    let fly = |tag: &str, extra: &[&str]| {
        let out = dir.path().join(tag);
        let mut args = vec!["forest-5", "--experiment", exp.to_str().expect("utf8"), "--no-mcap"];
        args.extend_from_slice(extra);
        args.extend(["--out", out.to_str().expect("utf8"), "--run"]);
        let run = run_id(tag);
        args.push(&run);
        let o = common::swarm_run(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        summary(&out)
    };
    let graded = fly("graded", &[]);
    assert_eq!(goal_check(&graded)["passed"], true, "{graded:#}");
    assert_eq!(graded["collisions"], 0);
    assert_eq!(graded["lost"][0]["id"], 3);
    let hard = fly("hard", &["--set", "controller.k21.barrier_ramp_m=0.0"]);
    let failed = goal_check(&hard);
    let out: Vec<u64> = failed["first_failure"]["uavs"]
        .as_array()
        .map_or(vec![], |u| u.iter().filter_map(|u| u["id"].as_u64()).collect());
    assert!(failed["passed"] == false && out == [5], "the hard barrier's dead end: {failed:#}");
    let five = &hard["agents"][4];
    assert!(five["path_length_m"].as_f64().expect("path") < 15.0, "UAV 5 stayed behind: {five:#}");
    println!("UAV 3 killed at 19.2 s: the rest at the goal; hard barrier: UAV 5 flew {:.1} m", five["path_length_m"]);
}

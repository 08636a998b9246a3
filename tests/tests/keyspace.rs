//! Issue 22, item 2: the wire the design draws, seen from outside. Eight UAVs in a line 21 m
//! long with a 10 m radio fly in realtime, each agent its own process logged in as itself; the
//! routers' admin space, read mid-flight with the observer's login, must show each agent's
//! session subscribed to the share keys of exactly the UAVs in its radio set, and to no
//! wildcard. Read twice: by a client no one here wrote (Python `eclipse-zenoh`, `keyspace/admin.py`,
//! which also decodes the hub's radio sets by hand), and by `swarm keys --json`.
//!
//! The margin: the admin space is read at one instant of a realtime run, while radio sets change
//! at 10 Hz and an agent of a loaded machine may lag, so an agent's subscriptions must lie
//! between the intersection and the union of its radio sets from 1 s before the query to 0.5 s
//! after (a UAV entering or leaving range then may be in either state); and the line makes the
//! sets strict subsets of the swarm, so a session subscribed to everyone fails.

mod common;

use common::{output_within, run_id, start_secure_hub, Creds, Proc, SWARM, TOOL_LIMIT};
use std::collections::{BTreeMap, BTreeSet};
use std::process::Command;
use std::time::Duration;

/// Eight UAVs 3 m apart in a line across the way to a goal 200 m ahead, broadcast localization,
/// realtime: UAV 1 hears 2 to 4, UAV 4 hears 1 to 7.
const LINE: &str = "name = \"line-8\"\n[swarm]\ncount = 8\nstart_positions = [[0.0, 0.0], [0.0, 3.0], [0.0, 6.0], [0.0, 9.0], [0.0, 12.0], [0.0, 15.0], [0.0, 18.0], [0.0, 21.0]]\ngoal = [200.0, 10.5]\n[localization]\nmode = \"broadcast\"\n[time]\nmode = \"realtime\"\n[end]\ntime_limit_s = 20.0\n";

const UAVS: u32 = 8;

/// A secured hub flying [`LINE`], its recorder (as `observer`) and one agent process per UAV.
struct Flight {
    dir: tempfile::TempDir,
    run: String,
    loc: String,
    creds: Creds,
    hub: Proc,
    rec: Proc,
    _agents: Vec<Proc>,
}

impl Flight {
    fn start() -> Flight {
        let dir = tempfile::tempdir().expect("tempdir");
        let run = run_id("keys");
        let sc = dir.path().join("line.toml");
        std::fs::write(&sc, LINE).expect("scenario");
        let creds = Creds::make(dir.path(), UAVS);
        let (hub, loc) = start_secure_hub(sc.to_str().expect("utf8"), &run, dir.path(), &creds);
        let out = dir.path().join("rec");
        let mut args = vec![
            "record".to_string(),
            "--run".into(),
            run.clone(),
            "--out".into(),
            out.to_str().expect("utf8").into(),
            "--connect".into(),
            loc.clone(),
        ];
        args.extend(creds.login("observer"));
        let rec = Proc::start(&args.iter().map(String::as_str).collect::<Vec<_>>(), &dir.path().join("rec.log"));
        let agents = (1..=UAVS)
            .map(|id| {
                let mut a = vec![
                    "agent".to_string(),
                    "--run".into(),
                    run.clone(),
                    "--id".into(),
                    id.to_string(),
                    "--connect".into(),
                    loc.clone(),
                ];
                a.extend(creds.login(&format!("uav{id}")));
                Proc::start(&a.iter().map(String::as_str).collect::<Vec<_>>(), &dir.path().join(format!("a{id}.log")))
            })
            .collect();
        Flight { dir, run, loc, creds, hub, rec, _agents: agents }
    }

    fn finish(mut self) -> serde_json::Value {
        assert!(self.rec.wait_for(Duration::from_secs(120)).expect("the run ends").success(), "recorder");
        assert!(self.hub.wait_for(Duration::from_secs(30)).expect("hub exits").success(), "hub");
        common::summary(&self.dir.path().join("rec"))
    }
}

/// The ids of a JSON array of numbers.
fn ids(v: &serde_json::Value) -> BTreeSet<u64> {
    v.as_array().map(|a| a.iter().filter_map(serde_json::Value::as_u64).collect()).unwrap_or_default()
}

#[test]
fn each_agent_session_subscribes_to_the_share_keys_of_its_radio_set_only() {
    let f = Flight::start();
    let script = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/keyspace/admin.py");
    let o = output_within(
        Command::new(common::python()).arg(script).args([
            &f.loc,
            &f.run,
            &f.creds.password("observer"),
            &UAVS.to_string(),
        ]),
        TOOL_LIMIT,
    );
    assert!(o.status.success(), "admin.py: {}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("one JSON line");
    assert_eq!(v["sessions"], UAVS, "each agent session holds its token: {v}");
    assert_eq!(v["share_wildcards"], serde_json::json!([]), "no session subscribes to every UAV's shares: {v}");
    let mut strict = 0;
    for id in 1..=u64::from(UAVS) {
        let me = id.to_string();
        let subscribed = ids(&v["subscribed"][&me]);
        let sets: Vec<BTreeSet<u64>> = v["radio"][&me]
            .as_array()
            .expect("radio sets of the ticks around the query")
            .iter()
            .map(|tick_set| ids(&tick_set[1]).into_iter().filter(|&j| j != id).collect())
            .collect();
        assert!(sets.len() >= 3, "UAV {id}: radio sets around the query: {v}");
        let union: BTreeSet<u64> = sets.iter().flatten().copied().collect();
        let both: BTreeSet<u64> =
            sets.iter().skip(1).fold(sets[0].clone(), |a, b| a.intersection(b).copied().collect());
        assert!(subscribed.is_subset(&union), "UAV {id} subscribes to {subscribed:?}, beyond its radio sets {sets:?}");
        assert!(
            both.is_subset(&subscribed),
            "UAV {id} subscribes to {subscribed:?}, missing some of its radio sets {sets:?}"
        );
        if subscribed.len() < UAVS as usize - 1 {
            strict += 1;
        }
    }
    assert!(strict >= 4, "the line makes most radio sets strict subsets of the swarm: {v}");

    // The same graph through our own tool, with rates.
    let mut login = f.creds.login("observer");
    login.extend(["--connect".into(), f.loc.clone()]);
    let o = output_within(
        Command::new(SWARM).args(["keys", "--run", &f.run, "--json", "--window", "1"]).args(&login),
        TOOL_LIMIT,
    );
    assert!(o.status.success(), "swarm keys: {}", String::from_utf8_lossy(&o.stderr));
    let k: serde_json::Value = serde_json::from_slice(&o.stdout).expect("JSON");
    let families: BTreeMap<String, &serde_json::Value> = k["families"]
        .as_array()
        .expect("families")
        .iter()
        .map(|r| (r["family"].as_str().expect("name").to_string(), r))
        .collect();
    let pose = families.get("uav/{id}/share/pose").expect("the share family");
    let names: Vec<&str> =
        pose["subscribers"].as_array().expect("subscribers").iter().filter_map(|n| n.as_str()).collect();
    assert_eq!(
        names,
        (1..=UAVS).map(|i| format!("uav{i}")).collect::<Vec<_>>(),
        "every agent, named by its token: {pose}"
    );
    let keys = pose["subscribed_keys"].as_u64().expect("count");
    assert!(
        keys < u64::from(UAVS * (UAVS - 1)) && keys >= u64::from(UAVS),
        "one subscription per neighbour, not per UAV: {pose}"
    );
    assert!(pose["msgs_per_s"].as_f64().expect("a rate") > 40.0, "eight UAVs share at 10 Hz: {pose}");
    let sense = families.get("uav/{id}/sense").expect("sensor frames");
    assert_eq!(
        sense["publishers"],
        serde_json::json!(["hub"]),
        "the hub's writers are seen by their queriers: {sense}"
    );
    let pose_writers: Vec<&str> =
        pose["publishers"].as_array().expect("publishers").iter().filter_map(|n| n.as_str()).collect();
    assert_eq!(pose_writers, names, "every agent writes its own share: {pose}");

    let summary = f.finish();
    let traffic = &summary["traffic"];
    assert_eq!(traffic["sessions"], UAVS, "{traffic}");
    let (arrived, counted) = (
        traffic["shares_arrived_per_agent_tick"].as_f64().expect("n"),
        traffic["shares_counted_per_agent_tick"].as_f64().expect("n"),
    );
    assert!(
        arrived < f64::from(UAVS - 1) - 1.0,
        "a session receives its neighbours' shares, not every UAV's: {traffic}"
    );
    assert!(counted > 0.0 && arrived >= counted, "{traffic}");
}

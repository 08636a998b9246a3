//! Unit tests of the schema: parsing, defaults, validation errors with their dotted paths, the
//! built-in scenarios and the commented example file.

use super::*;

const MINIMAL: &str = r#"
name = "t"
[swarm]
count = 2
start_positions = [[0.0, 0.0], [1.0, 0.0]]
goal = [10.0, 0.0]
"#;

fn err(text: &str) -> ScenarioError {
    Scenario::from_toml_str(text, "x.toml").expect_err("scenario should be rejected")
}

#[test]
fn every_builtin_parses() {
    for (name, _) in BUILTIN {
        let sc = builtin(name).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(&sc.name, name, "built-in name matches its file's name field");
    }
}

#[test]
fn example_file_sets_every_section_away_from_nothing() {
    let sc = builtin("example").expect("example parses");
    assert_eq!(sc.world.trees.len(), 1);
    assert_eq!(sc.world.walls.len(), 1);
    assert!(sc.world.forest.is_some());
    assert_eq!(sc.swarm.count, 3);
    assert_eq!(sc.lidar.beams, 750);
    assert_eq!(sc.controller.k21.kf, 0.4);
    assert!(sc.radio.distance_loss.is_some());
    assert_eq!(sc.controller.p17.values().d, 8.0);
    assert_eq!(sc.controller.a21.damping_per_s, 0.5);
    assert!(sc.localization.broadcast_error.is_some());
    assert!(sc.netem.iter().any(|r| r.partition.is_some() && r.rule.hold));
}

#[test]
fn minimal_scenario_gets_documented_defaults() {
    let sc = Scenario::from_toml_str(MINIMAL, "m.toml").expect("minimal parses");
    assert_eq!(sc.body.radius_m, 0.3);
    assert_eq!(sc.lidar.max_range_m, 12.0);
    assert_eq!(sc.time.mode, TimeMode::Lockstep);
    assert!(sc.is_informed(UavId::new(2)));
    assert_eq!(sc.uav_ids().map(UavId::get).collect::<Vec<_>>(), vec![1, 2]);
    assert!((sc.dt_s() - 0.1).abs() < 1e-12);
}

#[test]
fn unknown_field_names_file_and_field() {
    let e = err(&MINIMAL.replace("[swarm]", "[swarm]\ncuont = 3"));
    let text = e.to_string();
    assert_eq!(e.source_name, "x.toml");
    assert!(text.contains("x.toml"), "{text}");
    assert!(e.message.contains("cuont"), "{text}");
    assert!(e.field.starts_with("swarm"), "{text}");
}

#[test]
fn unknown_nested_field_has_dotted_path() {
    let e = err(&format!("{MINIMAL}\n[controller.k21]\nkz = 1.0\n"));
    assert!(e.field.starts_with("controller.k21"), "{e}");
    assert!(e.message.contains("kz"), "{e}");
}

#[test]
fn wrong_type_names_field() {
    let e = err(&format!("{MINIMAL}\n[lidar]\nbeams = \"many\"\n"));
    assert_eq!(e.field, "lidar.beams", "{e}");
}

#[test]
fn a_controller_name_a_program_could_register_is_accepted_and_round_trips() {
    let sc = Scenario::from_toml_str(&format!("{MINIMAL}\n[controller]\nkind = \"potential-field\"\n"), "t.toml")
        .expect("valid");
    assert_eq!(sc.controller.kind, ControllerKind::Own("potential-field".into()));
    assert_eq!(sc.controller.kind.name(), "potential-field");
    let back = toml::to_string(&sc).expect("serializes");
    assert!(back.contains("kind = \"potential-field\""), "{back}");
    let k21 = Scenario::from_toml_str(&format!("{MINIMAL}\n[controller]\nkind = \"k21\"\n"), "t.toml").expect("valid");
    assert_eq!(k21.controller.kind, ControllerKind::K21);
}

#[test]
fn a_controller_name_no_program_could_register_names_field() {
    let e = err(&format!("{MINIMAL}\n[controller]\nkind = \"Potential Field\"\n"));
    assert_eq!(e.field, "controller.kind", "{e}");
    assert!(e.message.contains("Potential Field") && e.message.contains("lower-case"), "{e}");
}

#[test]
fn an_external_uav_listed_twice_is_refused() {
    let e = err(&format!("{MINIMAL}\n[controller]\nexternal = [2, 2]\n"));
    assert_eq!(e.field, "controller.external", "{e}");
    assert_eq!(e.message, "UAV 2 is listed twice");
}

#[test]
fn a_syntax_error_says_where() {
    let e = err("name = \"x\"\n[swarm\ncount = 2\n");
    assert!(e.message.contains("(line 2, column"), "{e}");
    let e = err(&format!("{MINIMAL}\n[lidar]\nbeams = \"many\"\n"));
    let line = MINIMAL.lines().count() + 3;
    assert!(e.message.contains(&format!("(line {line}, column 9)")), "{e}");
}

#[test]
fn listed_starts_closer_than_two_body_radii_are_refused_naming_the_uavs() {
    let e = err(&MINIMAL.replace("[[0.0, 0.0], [1.0, 0.0]]", "[[0.0, 0.0], [0.1, 0.0]]"));
    assert_eq!(e.field, "swarm.start_positions", "{e}");
    assert!(e.message.starts_with("UAVs 1 and 2 start 0.10 m apart, closer than two body radii"), "{e}");
}

#[test]
fn bad_enum_value_names_field() {
    let e = err(&format!("{MINIMAL}\n[time]\nmode = \"fast\"\n"));
    assert_eq!(e.field, "time.mode", "{e}");
    assert!(e.message.contains("fast"), "{e}");
}

#[test]
fn semantic_errors_name_field() {
    let cases = [
        (format!("{MINIMAL}\n[lidar]\nmax_range_m = -1.0\n"), "lidar.max_range_m"),
        (format!("{MINIMAL}\n[time]\ncontrol_hz = 0.0\n"), "time.control_hz"),
        (format!("{MINIMAL}\n[time]\ncontrol_hz = 1e-9\n"), "time.control_hz"),
        (format!("{MINIMAL}\n[time]\nstartup_timeout_s = -1.0\n"), "time.startup_timeout_s"),
        (format!("{MINIMAL}\n[time]\nrealtime_factor = 1e9\n"), "time.realtime_factor"),
        (MINIMAL.replace("count = 2", "count = 3"), "swarm.start_positions"),
        (MINIMAL.replace("goal = [10.0, 0.0]", "goal = [10.0, 0.0]\ninformed = [5]"), "swarm.informed"),
        (format!("{MINIMAL}\n[perception]\nmin_points = 2\n"), "perception.min_points"),
        (MINIMAL.replace("goal = [10.0, 0.0]", "goal = [10.0, 0.0]\nfailed = [3]"), "swarm.failed"),
        (MINIMAL.replace("goal = [10.0, 0.0]", "goal = [10.0, 0.0]\nfailed = [1, 2]"), "swarm.failed"),
        (format!("{MINIMAL}\n[localization.icp]\nlambda = 0.0\n"), "localization.icp.lambda"),
        (format!("{MINIMAL}\n[[netem]]\nrule = {{ loss = {{ model = \"random\", p = 1.5 }} }}\n"), "netem[0].rule.loss.p"),
        (format!("{MINIMAL}\n[[netem]]\nto = [7]\n"), "netem[0].to"),
        (format!("{MINIMAL}\n[[failures]]\nat_s = 1.0\nuav = 9\nkind = \"freeze\"\n"), "failures[0].uav"),
        (format!("{MINIMAL}\n[localization.icp]\ngrid_headings = 0\n"), "localization.icp.grid_headings"),
        (format!("{MINIMAL}\n[localization.icp]\ntight_long_every_s = 4.0\n"), "localization.icp.tight_long_every_s"),
        (format!("{MINIMAL}\n[localization.icp]\ncrowd_full_grids_per_s = -1.0\n"), "localization.icp.crowd_full_grids_per_s"),
        (
            format!("{MINIMAL}\n[world.forest]\nregion = {{ x_min = 5.0, x_max = 1.0, y_min = 0.0, y_max = 1.0 }}\ndensity_per_100m2 = 1.0\n"),
            "world.forest.region",
        ),
        (format!("{MINIMAL}\n[[world.walls]]\nx1 = 0.0\ny1 = 0.0\nx2 = 0.0\ny2 = 0.0\n"), "world.walls[0]"),
        (MINIMAL.replace("name = \"t\"", "name = \"a b\""), "name"),
    ];
    for (text, field) in cases {
        let e = err(&text);
        assert_eq!(e.field, field, "{e}");
    }
}

#[test]
fn missing_required_field_is_reported() {
    let e = err(&MINIMAL.replace("goal = [10.0, 0.0]", ""));
    assert!(e.message.contains("goal"), "{e}");
}

#[test]
fn from_arg_resolves_builtin_and_reports_unknown() {
    let (sc, text) = Scenario::from_arg("forest-5").expect("builtin by name");
    assert_eq!(sc.name, "forest-5");
    assert!(text.contains("forest-5"));
    let e = Scenario::from_arg("no-such-thing").expect_err("unknown");
    assert!(e.message.contains("built-ins"), "{e}");
}

#[test]
fn goals_change_by_mission_time_and_uav() {
    let sc = Scenario::from_toml_str(
        &format!("{MINIMAL}\n[[mission]]\nat_s = 5.0\nuavs = [1]\ngoal = [0.0, 9.0]\n\n[[mission]]\nat_s = 8.0\ngoal = [20.0, 0.0]\n"),
        "m.toml",
    )
    .expect("valid");
    assert_eq!(sc.goal_of(UavId::new(1), 1.0), [10.0, 0.0], "swarm.goal before any change");
    assert_eq!(sc.goal_of(UavId::new(1), 5.0), [0.0, 9.0]);
    assert_eq!(sc.goal_of(UavId::new(2), 6.0), [10.0, 0.0], "the change was for UAV 1 only");
    assert_eq!(sc.goal_of(UavId::new(2), 8.0), [20.0, 0.0], "a change for all");
}

#[test]
fn partition_events_and_distance_loss_are_validated() {
    let base = r#"
name = "p"
[swarm]
count = 3
start_positions = [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]
goal = [10.0, 0.0]
"#;
    let e = err(&format!("{base}[[netem]]\npartition = {{ scheme = \"isolate\", node = 9 }}\n"));
    assert_eq!(e.field, "netem[0].partition", "{e}");
    let e = err(&format!("{base}[[netem]]\nfrom = [1]\npartition = {{ scheme = \"isolate\", node = 1 }}\n"));
    assert_eq!(e.field, "netem[0].partition", "{e}");
    let e = err(&format!(
        "{base}[[netem]]\nrule = {{ delay_s = 1.0 }}\npartition = {{ scheme = \"isolate\", node = 1 }}\n"
    ));
    assert_eq!(e.field, "netem[0].rule", "{e}");
    let e = err(&format!("{base}[radio]\ndistance_loss = {{ from_m = 12.0, at_range = 0.5 }}\n"));
    assert_eq!(e.field, "radio.distance_loss.from_m", "{e}");
    let e = err(&format!("{base}[radio]\ndistance_loss = {{ from_m = 2.0, at_range = 1.5 }}\n"));
    assert_eq!(e.field, "radio.distance_loss.at_range", "{e}");
}

#[test]
fn experiment_files_are_read_and_checked_against_the_scenario() {
    let sc = Scenario::from_toml_str(MINIMAL, "m.toml").expect("minimal parses");
    let dir = std::env::temp_dir().join(format!("swarm-config-timeline-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let ok = dir.join("ok.toml");
    std::fs::write(&ok, "[[netem]]\nat_s = 5.0\npartition = { scheme = \"isolate\", node = 2 }\n[[failures]]\nat_s = 6.0\nuav = 1\nkind = \"kill\"\n").expect("write");
    let t = sc.timeline_from_file(&ok).expect("ok");
    assert_eq!((t.netem.len(), t.failures.len()), (1, 1));
    assert!(sc.check_timeline(&t, true).is_err(), "a kill cannot be added to a running swarm");
    let bad = dir.join("bad.toml");
    std::fs::write(&bad, "[[failures]]\nat_s = 6.0\nuav = 7\nkind = \"freeze\"\n").expect("write");
    let e = sc.timeline_from_file(&bad).expect_err("UAV 7 of 2");
    assert!(e.to_string().contains("bad.toml") && e.to_string().contains("failures[0].uav"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_moving_mission_goal_moves_from_its_start_time() {
    let sc = Scenario::from_toml_str(
        &format!("{MINIMAL}\n[[mission]]\nat_s = 10.0\ngoal = [1.0, 2.0]\nvelocity_mps = [0.5, -1.0]\n"),
        "m.toml",
    )
    .expect("parses");
    assert_eq!(sc.goal_motion_of(UavId::new(1), 5.0), ([10.0, 0.0], [0.0, 0.0]), "swarm goal before the mission");
    assert_eq!(sc.goal_motion_of(UavId::new(1), 14.0), ([3.0, -2.0], [0.5, -1.0]));
    assert_eq!(sc.goal_of(UavId::new(2), 14.0), [3.0, -2.0]);
}

#[test]
fn a_hold_as_long_as_the_run_is_refused_with_its_field() {
    let ok = Scenario::from_toml_str(&format!("{MINIMAL}\n[end]\ntime_limit_s = 100.0\nhold_s = 60.0\n"), "h.toml")
        .expect("valid");
    assert_eq!(ok.end.hold_s, 60.0);
    let e = Scenario::from_toml_str(&format!("{MINIMAL}\n[end]\ntime_limit_s = 100.0\nhold_s = 100.0\n"), "h.toml")
        .expect_err("hold too long");
    assert!(e.to_string().contains("end.hold_s") && e.message.contains("time_limit_s"), "{e}");
}

#[test]
fn a_failure_kinds_name_is_how_a_scenario_file_writes_it() {
    use crate::FailureKind::*;
    for k in [Freeze, Kill, Restart, LinkStall, LinkClose, LinkRestore] {
        assert_eq!(serde_json::to_value(k).expect("json"), serde_json::json!(k.name()), "{k:?}");
    }
}

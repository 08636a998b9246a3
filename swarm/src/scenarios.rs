//! `swarm scenarios` and `swarm check`: the built-in scenarios, and what a scenario file
//! resolves to (every default filled in), for a person writing one.

use anyhow::{Context, Result};
use std::process::ExitCode;
use swarm_config::Scenario;
use swarm_types::UavId;
use uav_agent::Controllers;

/// Runs `swarm scenarios`: one line per built-in scenario, its name and description.
pub fn list() -> Result<ExitCode> {
    let width = swarm_config::BUILTIN.iter().map(|(n, _)| n.len()).max().unwrap_or(0);
    let mut list = String::new();
    for (name, text) in swarm_config::BUILTIN {
        let desc = Scenario::from_toml_str(text, name).map(|s| s.description).unwrap_or_default();
        list.push_str(&format!("{name:width$}  {desc}\n"));
    }
    swarm_node::process::out(list.trim_end());
    Ok(ExitCode::SUCCESS)
}

/// What a parsed scenario must still pass before a run starts, beyond its own validation: every
/// controller it names is known, and no UAV starts inside a tree or wall (the forest is drawn
/// here, so a generated forest over the start area is caught too).
pub fn admit(sc: &Scenario, name: &str, controllers: &Controllers) -> Result<()> {
    controllers.check(sc).with_context(|| format!("scenario `{name}`"))?;
    if let Some((uav, what)) = physics_hub::start_in_obstacle(sc) {
        let field = if sc.swarm.start_positions.is_some() { "swarm.start_positions" } else { "swarm.start_area" };
        anyhow::bail!(
            "scenario `{name}`: {field}: UAV {uav} {what} (move it, or list the spot in world.forest.keep_clear)"
        );
    }
    Ok(())
}

/// Runs `swarm check`: validates `scenario` and prints a short summary of what it flies (or,
/// with `json`, the whole scenario resolved, every default filled in).
pub fn check(scenario: &str, json: bool, controllers: &Controllers) -> Result<ExitCode> {
    let (sc, _) = Scenario::from_arg(scenario)?;
    admit(&sc, scenario, controllers)?;
    match json {
        true => swarm_node::process::out(&serde_json::to_string_pretty(&sc)?),
        false => swarm_node::process::out(&summary(&sc)),
    }
    Ok(ExitCode::SUCCESS)
}

/// What a scenario flies, in a few lines a person reads: the swarm, the controller and
/// localization, the world as the hub will draw it, and every fault by sim time.
pub fn summary(sc: &Scenario) -> String {
    let mut lines = vec![format!("{}: {}", sc.name, sc.description)];
    let informed = match &sc.swarm.informed {
        swarm_config::Informed::All(_) => "all informed".to_string(),
        swarm_config::Informed::Ids(ids) => format!("informed: {ids:?}"),
    };
    lines.push(format!(
        "swarm: {} UAVs ({informed}), goal ({}, {}), end: goal rule {} within {} m, time limit {} s",
        sc.count(),
        sc.swarm.goal[0],
        sc.swarm.goal[1],
        name(&sc.end.goal_rule),
        sc.end.goal_radius_m,
        sc.end.time_limit_s
    ));
    let external = match sc.controller.external.as_slice() {
        [] => String::new(),
        ids => format!(", external UAVs {ids:?}"),
    };
    lines.push(format!(
        "controller: {}{external}; localization: {}; time: {} at {} Hz; radio range {} m",
        name(&sc.controller.kind),
        name(&sc.localization.mode),
        name(&sc.time.mode),
        sc.time.control_hz,
        sc.radio.range_m
    ));
    let trees = physics_hub::scenario_trees(sc).len();
    lines.push(format!("world: {trees} trees drawn, {} walls (master seed {})", sc.world.walls.len(), sc.seed));
    let mut faults: Vec<(f64, String)> = sc.netem.iter().map(|r| (r.at_s, netem_line(r, sc))).collect();
    faults.extend(sc.failures.iter().map(|f| (f.at_s, format!("UAV {} {}", f.uav, f.kind.name()))));
    faults.sort_by(|a, b| a.0.total_cmp(&b.0));
    match faults.is_empty() {
        true => lines.push("faults: none".to_string()),
        false => {
            lines.push("faults (sim time):".to_string());
            lines.extend(faults.into_iter().map(|(t, what)| format!("  {t:>7.1} s  {what}")));
        }
    }
    lines.push("(every field resolved: swarm check SCENARIO --json)".to_string());
    lines.join("\n")
}

/// `sc` as scenario-file TOML with only what it sets: every field equal to its default left out
/// (sections that are then empty too), so a generated file (`swarm fuzz`'s found cases) shows
/// what matters. The name, description, seed and `[swarm]` always stay; the text parses back to
/// the same scenario (tested).
pub fn minimal_toml(sc: &Scenario) -> Result<String> {
    let full = toml::Value::try_from(sc).context("cannot serialize the scenario")?;
    let swarm = full.get("swarm").cloned().context("a scenario has a [swarm] table")?;
    let mut base = toml::Table::new();
    base.insert("name".into(), toml::Value::String(sc.name.clone()));
    base.insert("swarm".into(), swarm);
    let defaults = Scenario::from_toml_str(&toml::to_string(&base)?, "the defaults")?;
    let defaults = toml::Value::try_from(&defaults)?;
    let mut kept = toml::Table::new();
    for (k, v) in full.as_table().context("a table")? {
        let keep = matches!(k.as_str(), "name" | "description" | "seed" | "swarm");
        match (keep, prune(v, defaults.get(k))) {
            (true, _) => {
                kept.insert(k.clone(), v.clone());
            }
            (false, Some(p)) => {
                kept.insert(k.clone(), p);
            }
            (false, None) => {}
        }
    }
    Ok(toml::to_string(&kept)?)
}

/// `v` without what equals `default` (tables field by field); `None` when nothing is left.
fn prune(v: &toml::Value, default: Option<&toml::Value>) -> Option<toml::Value> {
    if Some(v) == default {
        return None;
    }
    match (v, default) {
        (toml::Value::Table(t), Some(toml::Value::Table(d))) => {
            let kept: toml::Table = t.iter().filter_map(|(k, x)| prune(x, d.get(k)).map(|p| (k.clone(), p))).collect();
            (!kept.is_empty()).then_some(toml::Value::Table(kept))
        }
        _ => Some(v.clone()),
    }
}

/// A scenario value's name as the scenario file spells it (`"icp"`, `"lockstep"`, `"freeze"`).
fn name<T: serde::Serialize>(v: &T) -> String {
    match serde_json::to_value(v) {
        Ok(serde_json::Value::String(s)) => s,
        Ok(other) => other.to_string(),
        Err(_) => String::new(),
    }
}

/// One `[[netem]]` rule in words, with what an explicit partition's groups mean.
fn netem_line(r: &swarm_config::NetemRule, sc: &Scenario) -> String {
    let compact = |v: &dyn erased::Json| v.json();
    match &r.partition {
        Some(p) => {
            let mut line = format!("partition {}", compact(p));
            if let swarm_config::Partition::Groups { groups } = p {
                line.push_str(&groups_note(groups, sc.count() as u32));
            }
            line
        }
        None => format!("from {} to {}: {}", compact(&r.from), compact(&r.to), changed(&r.rule)),
    }
}

/// An impairment as compact JSON of the fields it sets (an empty rule heals: `{}`).
fn changed(rule: &swarm_config::Impairment) -> String {
    let (Ok(serde_json::Value::Object(set)), Ok(serde_json::Value::Object(none))) =
        (serde_json::to_value(rule), serde_json::to_value(swarm_config::Impairment::IDENTITY))
    else {
        return String::new();
    };
    let kept: serde_json::Map<String, serde_json::Value> =
        set.into_iter().filter(|(k, v)| none.get(k) != Some(v)).collect();
    serde_json::Value::Object(kept).to_string()
}

/// What explicit partition groups do beyond the obvious: a UAV in two groups bridges them
/// (Jepsen's complete-grudge: two UAVs hear each other iff some group holds both), and a UAV in
/// none is untouched by the partition.
pub fn groups_note(groups: &[Vec<UavId>], count: u32) -> String {
    let mut seen: std::collections::BTreeMap<UavId, usize> = std::collections::BTreeMap::new();
    for g in groups {
        for &id in g {
            *seen.entry(id).or_default() += 1;
        }
    }
    let bridges: Vec<UavId> = seen.iter().filter(|(_, &n)| n > 1).map(|(&id, _)| id).collect();
    let untouched: Vec<UavId> = UavId::all(count as usize).filter(|id| !seen.contains_key(id)).collect();
    let mut notes = Vec::new();
    if !bridges.is_empty() {
        notes.push(format!("UAVs {bridges:?} in more than one group hear both, bridging them"));
    }
    if !untouched.is_empty() {
        notes.push(format!("UAVs {untouched:?} in no group are untouched by it"));
    }
    match notes.is_empty() {
        true => String::new(),
        false => format!(" ({})", notes.join("; ")),
    }
}

/// Compact JSON of a scenario value, for a line of the summary.
mod erased {
    /// A value printed as compact JSON.
    pub trait Json {
        /// The JSON text.
        fn json(&self) -> String;
    }
    impl<T: serde::Serialize> Json for T {
        fn json(&self) -> String {
            serde_json::to_string(self).unwrap_or_default()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_minimal_file_keeps_what_differs_and_reads_back_the_same() {
        for name in ["forest-9-cut-off", "m23-indoor-lf", "a21-forest-uvdar"] {
            let (sc, _) = Scenario::from_arg(name).expect("built-in");
            let text = minimal_toml(&sc).expect("minimal");
            let full = toml::to_string(&sc).expect("full");
            assert!(
                text.lines().count() * 2 < full.lines().count(),
                "{name}: {} of {} lines",
                text.lines().count(),
                full.lines().count()
            );
            let back = Scenario::from_toml_str(&text, name).expect("parses");
            let json = |s: &Scenario| serde_json::to_value(s).expect("json");
            assert_eq!(json(&back), json(&sc), "{name}: the same scenario:\n{text}");
        }
    }

    #[test]
    fn overlapping_and_missing_partition_groups_are_said() {
        assert_eq!(
            groups_note(
                &[vec![UavId::new(1), UavId::new(2), UavId::new(3)], vec![UavId::new(3), UavId::new(4), UavId::new(5)]],
                7
            ),
            " (UAVs [3] in more than one group hear both, bridging them; UAVs [6, 7] in no group are untouched by it)"
        );
        assert_eq!(groups_note(&[vec![UavId::new(1), UavId::new(2)], vec![UavId::new(3)]], 3), "");
    }

    #[test]
    fn a_summary_names_the_trees_drawn_and_every_fault_by_time() {
        let (sc, _) = Scenario::from_arg("forest-9-cut-off").expect("built-in");
        let s = summary(&sc);
        assert!(s.contains("9 UAVs") && s.contains("trees drawn"), "{s}");
        assert!(s.contains("faults (sim time):") && s.contains("UAV 1 freeze"), "{s}");
        assert!(s.lines().count() < 20, "short: {s}");
    }
}

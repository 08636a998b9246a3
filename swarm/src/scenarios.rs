//! `swarm scenarios` and `swarm check`: the built-in scenarios, and what a scenario file
//! resolves to (every default filled in), for a person writing one.

use anyhow::{Context, Result};
use std::process::ExitCode;
use swarm_config::Scenario;
use uav_agent::Controllers;

/// Writes `text` to standard output; a reader that went away (`swarm scenarios | head`) ends the
/// output quietly instead of a panic.
fn print_out(text: &str) -> Result<()> {
    use std::io::Write;
    match std::io::stdout().lock().write_all(text.as_bytes()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(e.into()),
        _ => Ok(()),
    }
}

/// Runs `swarm scenarios`: one line per built-in scenario, its name and description.
pub fn list() -> Result<ExitCode> {
    let width = swarm_config::BUILTIN.iter().map(|(n, _)| n.len()).max().unwrap_or(0);
    let mut list = String::new();
    for (name, text) in swarm_config::BUILTIN {
        let desc = Scenario::from_toml_str(text, name).map(|s| s.description).unwrap_or_default();
        list.push_str(&format!("{name:width$}  {desc}\n"));
    }
    print_out(&list)?;
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

/// Runs `swarm check`: validates `scenario` and prints it resolved, as JSON.
pub fn check(scenario: &str, controllers: &Controllers) -> Result<ExitCode> {
    let (sc, _) = Scenario::from_arg(scenario)?;
    admit(&sc, scenario, controllers)?;
    print_out(&format!("{}\n", serde_json::to_string_pretty(&sc)?))?;
    Ok(ExitCode::SUCCESS)
}

//! The scenarios of `scenarios/`, compiled in: `swarm run` works with no argument and with no
//! files beside the binary, and a test parses every one of them.

use crate::{Scenario, ScenarioError};

/// Built-in scenarios, `(name, toml text)`: the files of `scenarios/`, compiled in.
pub const BUILTIN: &[(&str, &str)] = &[
    ("a21-forest-uvdar", include_str!("../../scenarios/a21-forest-uvdar.toml")),
    ("compare-4", include_str!("../../scenarios/compare-4.toml")),
    ("forest-5", include_str!("../../scenarios/forest-5.toml")),
    ("forest-5-burst-frozen", include_str!("../../scenarios/forest-5-burst-frozen.toml")),
    ("forest-5-linkloss", include_str!("../../scenarios/forest-5-linkloss.toml")),
    ("forest-5-lossy", include_str!("../../scenarios/forest-5-lossy.toml")),
    ("forest-7-failed", include_str!("../../scenarios/forest-7-failed.toml")),
    ("forest-9-dense", include_str!("../../scenarios/forest-9-dense.toml")),
    ("forest-9-stranded", include_str!("../../scenarios/forest-9-stranded.toml")),
    ("forest-9-cut-off", include_str!("../../scenarios/forest-9-cut-off.toml")),
    ("forest-9-cut-off-long", include_str!("../../scenarios/forest-9-cut-off-long.toml")),
    ("forest-9-cut-off-dense", include_str!("../../scenarios/forest-9-cut-off-dense.toml")),
    ("forest-9-cut-off-uav2", include_str!("../../scenarios/forest-9-cut-off-uav2.toml")),
    ("forest-9-cut-off-icp", include_str!("../../scenarios/forest-9-cut-off-icp.toml")),
    ("forest-40", include_str!("../../scenarios/forest-40.toml")),
    ("forest-100", include_str!("../../scenarios/forest-100.toml")),
    ("forest-40-arrive", include_str!("../../scenarios/forest-40-arrive.toml")),
    ("forest-100-arrive", include_str!("../../scenarios/forest-100-arrive.toml")),
    ("forest-40-icp", include_str!("../../scenarios/forest-40-icp.toml")),
    ("forest-100-icp", include_str!("../../scenarios/forest-100-icp.toml")),
    ("forest-1000-icp", include_str!("../../scenarios/forest-1000-icp.toml")),
    ("m23-indoor-lf", include_str!("../../scenarios/m23-indoor-lf.toml")),
    ("m23-indoor-none", include_str!("../../scenarios/m23-indoor-none.toml")),
    ("m23-indoor-pf", include_str!("../../scenarios/m23-indoor-pf.toml")),
    ("m23-indoor-tnpf", include_str!("../../scenarios/m23-indoor-tnpf.toml")),
    ("open-1000", include_str!("../../scenarios/open-1000.toml")),
    ("open-field-5", include_str!("../../scenarios/open-field-5.toml")),
    ("open-field-5-linkfault", include_str!("../../scenarios/open-field-5-linkfault.toml")),
    ("open-field-5-restart", include_str!("../../scenarios/open-field-5-restart.toml")),
    ("open-field-7-partition", include_str!("../../scenarios/open-field-7-partition.toml")),
    ("p17-error-forest", include_str!("../../scenarios/p17-error-forest.toml")),
    ("p17-error-free", include_str!("../../scenarios/p17-error-free.toml")),
    ("p17-free-4", include_str!("../../scenarios/p17-free-4.toml")),
    ("p17-gap", include_str!("../../scenarios/p17-gap.toml")),
    ("p17-moving-goal", include_str!("../../scenarios/p17-moving-goal.toml")),
    ("p17-wall", include_str!("../../scenarios/p17-wall.toml")),
    ("example", include_str!("../../scenarios/example.toml")),
];

/// The scenario `swarm run` uses when given none.
pub const DEFAULT_SCENARIO: &str = "forest-5";

/// Looks up a built-in scenario by name and parses it.
pub fn builtin(name: &str) -> Result<Scenario, ScenarioError> {
    let (_, text) = BUILTIN
        .iter()
        .find(|(n, _)| *n == name)
        .ok_or_else(|| ScenarioError::new(name, "(file)", format!("no built-in scenario named `{name}`")))?;
    Scenario::from_toml_str(text, &format!("builtin:{name}"))
}

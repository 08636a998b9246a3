//! The swarm the hub benches fly: open-1000's crowd scaled to `n` UAVs, so the area per UAV stays
//! about 18 m² (a start disc holding the UAVs at least 3 m apart, so a UAV hears about 18 others
//! within the 10 m radio range), broadcast localization, every UAV informed of the goal.

use swarm_config::Scenario;

/// open-1000's crowd scaled to `n` UAVs, named `name`.
pub fn scenario(n: usize, name: &str) -> Scenario {
    let radius_m = 75.0 * (n as f64 / 1000.0).sqrt();
    let text = format!(
        r#"
name = "{name}"
seed = 1000
[swarm]
count = {n}
start_area = {{ center = [0.0, 0.0], radius_m = {radius_m}, min_spacing_m = 3.0 }}
goal = [60.0, 0.0]
informed = "all"
[localization]
mode = "broadcast"
[end]
time_limit_s = 1000000.0
"#
    );
    Scenario::from_toml_str(&text, name).expect("valid bench scenario")
}

//! What every command shares, below all of them: the Zenoh endpoints flattened into each
//! command that opens a session, run ids, and command-line values spelled as in the scenario
//! file. A leaf: it imports nothing of this crate, so any command can use it without a circle.

use anyhow::Result;
use clap::Args;

/// Endpoints and overrides shared by every piece that opens a Zenoh session.
#[derive(Args, Debug, Clone, Default)]
pub struct ZenohArgs {
    /// Endpoint to connect to, e.g. `tcp/10.0.0.5:7447` (repeatable).
    #[arg(long = "connect", short = 'e')]
    pub connect: Vec<String>,
    /// Endpoint to listen on, e.g. `tcp/0.0.0.0:7447` (repeatable; the hub only).
    #[arg(long = "listen", short = 'l')]
    pub listen: Vec<String>,
    /// Zenoh config override `KEY:JSON5`, e.g. `transport/link/tx/lease:3000` (repeatable).
    #[arg(long = "cfg")]
    pub cfg: Vec<String>,
}

/// Seconds since the Unix epoch (run ids and study folders).
pub(crate) fn unix_secs() -> u64 {
    std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs())
}

/// `<name>-<unix seconds>-<pid>`: unique per run on a machine.
pub(crate) fn default_run_id(name: &str) -> String {
    format!("{name}-{}-{}", unix_secs(), std::process::id())
}

/// A command-line value for a scenario enum, spelled as in the scenario file (`"realtime"`,
/// `"a21"`, …); the error lists the accepted spellings.
pub fn scenario_value<T: serde::de::DeserializeOwned>(flag: &str, value: &str) -> Result<T> {
    use serde::de::IntoDeserializer;
    T::deserialize(value.trim().into_deserializer()).map_err(|e: serde::de::value::Error| anyhow::anyhow!("{flag}: {e}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scenario_values_are_spelled_as_in_the_file() {
        let m: swarm_config::TimeMode = scenario_value("--time-mode", "realtime").expect("ok");
        assert_eq!(m, swarm_config::TimeMode::Realtime);
        let k: swarm_config::ControllerKind = scenario_value("--controllers", " a21").expect("ok");
        assert_eq!(k, swarm_config::ControllerKind::A21);
        let e = scenario_value::<swarm_config::TimeMode>("--time-mode", "fast").expect_err("no such mode").to_string();
        assert!(e.starts_with("--time-mode") && e.contains("lockstep"), "{e}");
    }
}

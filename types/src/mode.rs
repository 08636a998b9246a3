//! The modes a scenario chooses, with their names as the scenario spells them, so a table, a
//! summary or a log line never derives a name from `Debug`.

use serde::{Deserialize, Serialize};

/// Relative localization mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LocalizationMode {
    /// Each agent broadcasts its pose in a shared global frame (GNSS-like, seed 001 3.4).
    Broadcast,
    /// Agents share their obstacle centres and align them by ICP (seed 000 chapters 3 and 5).
    Icp,
    /// No communication at all: onboard relative sensing (UVDAR, seed 003) from the hub.
    Uvdar,
}

impl LocalizationMode {
    /// Every mode.
    pub const ALL: [LocalizationMode; 3] =
        [LocalizationMode::Broadcast, LocalizationMode::Icp, LocalizationMode::Uvdar];

    /// The name as a scenario writes it (`broadcast`, `icp`, `uvdar`).
    pub const fn name(self) -> &'static str {
        match self {
            LocalizationMode::Broadcast => "broadcast",
            LocalizationMode::Icp => "icp",
            LocalizationMode::Uvdar => "uvdar",
        }
    }

    /// What an agent shares in this mode, if anything.
    pub const fn share(self) -> Option<ShareKind> {
        match self {
            LocalizationMode::Broadcast => Some(ShareKind::Pose),
            LocalizationMode::Icp => Some(ShareKind::Obstacles),
            LocalizationMode::Uvdar => None,
        }
    }
}

/// What an agent shares with the UAVs in its radio range.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ShareKind {
    /// Its pose in the shared frame (`broadcast`).
    Pose,
    /// Its obstacle centres in its body frame (`icp`).
    Obstacles,
}

impl ShareKind {
    /// The last part of its key, `share/{name}`.
    pub const fn name(self) -> &'static str {
        match self {
            ShareKind::Pose => "pose",
            ShareKind::Obstacles => "obstacles",
        }
    }
}

/// Time mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TimeMode {
    /// The hub advances when every live agent has answered the tick (or after a timeout).
    Lockstep,
    /// The hub advances at wall-clock rate (times `realtime_factor`).
    Realtime,
}

impl TimeMode {
    /// The name as a scenario writes it (`lockstep`, `realtime`).
    pub const fn name(self) -> &'static str {
        match self {
            TimeMode::Lockstep => "lockstep",
            TimeMode::Realtime => "realtime",
        }
    }

    /// Whether a message that cannot leave at once waits (lockstep: every message counts) rather
    /// than being dropped (real time: a late message is worth less than the next).
    pub const fn blocks(self) -> bool {
        matches!(self, TimeMode::Lockstep)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_the_scenarios_spelling() {
        for m in [LocalizationMode::Broadcast, LocalizationMode::Icp, LocalizationMode::Uvdar] {
            assert_eq!(serde_json::to_string(&m).expect("encodes"), format!("\"{}\"", m.name()));
        }
        for m in [TimeMode::Lockstep, TimeMode::Realtime] {
            assert_eq!(serde_json::to_string(&m).expect("encodes"), format!("\"{}\"", m.name()));
        }
        assert_eq!(LocalizationMode::Icp.share().map(ShareKind::name), Some("obstacles"));
        assert_eq!(LocalizationMode::Uvdar.share(), None);
    }
}

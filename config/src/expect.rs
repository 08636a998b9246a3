//! `[expect]`: what a scenario promises about its own run, the invariants `swarm run --check` and
//! `swarm fuzz` evaluate after every run (issue 15, after Jepsen's checkers). Every check applies
//! unless `skip` names it; every bound has a default derived from the rest of the scenario, so
//! most scenarios need no `[expect]` table at all (the defaults are listed in docs/faults-and-experiments.md, "Invariants and `swarm fuzz`").

use serde::{Deserialize, Serialize};

/// The invariants a run is checked against.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CheckName {
    /// No collision (UAV–obstacle or UAV–UAV contact).
    Collision,
    /// No two UAVs closer than `min_separation_m`, centre to centre.
    MinSeparation,
    /// No neighbour estimate held across a link cut (blocked, held, or a frozen sender) for
    /// longer than `stale_grace_s`.
    StaleEstimate,
    /// No neighbour reported after `stale_grace_s` with no other UAV within `alone_m`.
    NeighbourWhileAlone,
    /// After every heal of the `[[netem]]` timeline, one connected component of the estimate
    /// graph again within `reconnect_within_s`.
    Reconnect,
    /// At the end, every live UAV within `end_range_m` of another live UAV.
    ConnectedAtEnd,
    /// The goal rule met by the end.
    Goal,
}

impl CheckName {
    /// Every check, in report order.
    pub const ALL: [CheckName; 7] = [
        CheckName::Collision,
        CheckName::MinSeparation,
        CheckName::StaleEstimate,
        CheckName::NeighbourWhileAlone,
        CheckName::Reconnect,
        CheckName::ConnectedAtEnd,
        CheckName::Goal,
    ];

    /// The name as written in `[expect]` and in `summary.json`.
    pub fn as_str(self) -> &'static str {
        match self {
            CheckName::Collision => "collision",
            CheckName::MinSeparation => "min_separation",
            CheckName::StaleEstimate => "stale_estimate",
            CheckName::NeighbourWhileAlone => "neighbour_while_alone",
            CheckName::Reconnect => "reconnect",
            CheckName::ConnectedAtEnd => "connected_at_end",
            CheckName::Goal => "goal",
        }
    }
}

/// The `[expect]` table: which checks apply and with what bounds (`None`: the default).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Expect {
    /// Checks that do not apply to this scenario.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub skip: Vec<CheckName>,
    /// Smallest allowed centre-to-centre distance between two UAVs [m] (default: 2 body radii
    /// plus 0.2 m, i.e. 0.8 m with the default body).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_separation_m: Option<f64>,
    /// How long an estimate may outlive a link cut, or a UAV report neighbours once alone [s]
    /// (default: `localization.stale_after_s` plus one control tick, plus one more tick for the
    /// share's own delivery).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stale_grace_s: Option<f64>,
    /// A UAV with no other UAV within this distance is truly alone [m] (default: radio range
    /// plus hysteresis, or the UVDAR range if larger in `uvdar` mode).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub alone_m: Option<f64>,
    /// Time from each heal to one connected component again [s] (default 20).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reconnect_within_s: Option<f64>,
    /// At the end, every live UAV must have another within this distance [m] (default: the
    /// radio range).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub end_range_m: Option<f64>,
}

/// Default of [`Expect::reconnect_within_s`] [s].
pub const DEFAULT_RECONNECT_WITHIN_S: f64 = 20.0;

/// Margin of the default [`Expect::min_separation_m`] over two body radii [m].
pub const DEFAULT_SEPARATION_MARGIN_M: f64 = 0.2;

/// The bounds of [`Expect`] with every default filled in from the scenario.
#[derive(Debug, Clone, PartialEq)]
pub struct Bounds {
    /// See [`Expect::min_separation_m`].
    pub min_separation_m: f64,
    /// See [`Expect::stale_grace_s`].
    pub stale_grace_s: f64,
    /// See [`Expect::alone_m`].
    pub alone_m: f64,
    /// See [`Expect::reconnect_within_s`].
    pub reconnect_within_s: f64,
    /// See [`Expect::end_range_m`].
    pub end_range_m: f64,
}

impl crate::Scenario {
    /// Whether check `c` applies to this scenario.
    pub fn expects(&self, c: CheckName) -> bool {
        !self.expect.skip.contains(&c)
    }

    /// The bounds of the checks, defaults filled in.
    pub fn bounds(&self) -> Bounds {
        let e = &self.expect;
        let tick = self.dt_s();
        let mut alone = self.radio.range_m + self.radio.hysteresis_m;
        if self.localization.mode == crate::LocalizationMode::Uvdar {
            alone = alone.max(self.localization.uvdar.max_range_m);
        }
        Bounds {
            min_separation_m: e.min_separation_m.unwrap_or(2.0 * self.body.radius_m + DEFAULT_SEPARATION_MARGIN_M),
            stale_grace_s: e.stale_grace_s.unwrap_or(self.localization.stale_after_s + 2.0 * tick),
            alone_m: e.alone_m.unwrap_or(alone),
            reconnect_within_s: e.reconnect_within_s.unwrap_or(DEFAULT_RECONNECT_WITHIN_S),
            end_range_m: e.end_range_m.unwrap_or(self.radio.range_m),
        }
    }

    /// Validates `[expect]`: every bound given is a finite number > 0.
    pub(crate) fn validate_expect(&self) -> crate::validate::Check {
        let e = &self.expect;
        for (name, v) in [
            ("min_separation_m", e.min_separation_m),
            ("stale_grace_s", e.stale_grace_s),
            ("alone_m", e.alone_m),
            ("reconnect_within_s", e.reconnect_within_s),
            ("end_range_m", e.end_range_m),
        ] {
            if let Some(v) = v {
                crate::validate::positive(&format!("expect.{name}"), v)?;
            }
        }
        Ok(())
    }
}

//! A21Params: parameters of the A21 controller (seed 003 section III, Table I).
//!
//! Why this module exists: the A21 flocking law f = p + n + c is fully shaped by the nine numbers
//! of seed 003 Table I; they are the defaults here, so a scenario that names `controller = "a21"`
//! flies the paper's controller unless it overrides a value.
//!
//! Choices where seed 003 is silent (each is documented at its field):
//! - maximum speed and acceleration: the seed gives none (its MPC tracker enforces the platform's
//!   limits, section IV-B); the scenario's `body.max_speed_mps` / `body.max_accel_mps2` apply
//!   unless `max_speed_mps` caps A21 lower (to fly it at K21's top speed beside it, seed 000 6.5);
//! - `phi_alone` (φ when no agent is observed): 0, continuous with φ = 0 beyond d_max;
//! - occupancy grid resolution 0.1 m, inflation 0.7 m, replanning period 1 s and path lookahead
//!   1 m for the A* path of the navigation vector (section IV-C gives no numbers).
//!
//! `validate` checks each range and the orderings the formulas need: d_c < d_0 (λβ of eq. 6
//! divides by √d_0 − √d_c), d_0 < d_f (eq. 3 and λα of eq. 4), d_0 < d_max (else the informed
//! agent gets no navigation at the rest distance d_0 of its flock, eq. 8).

use serde::{Deserialize, Serialize};

/// A21 parameters (seed 003 section III). Where Table I gives a number it is the default.
///
/// All control vectors are read as accelerations [m/s²] (seed 003 section III: f "is used to
/// generate the desired acceleration" of a double integrator), so the gains kα, kβ, kn, ko carry
/// the units that make α, β, n, c accelerations; Table I lists them as dimensionless.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct A21Params {
    /// d_0 [m]: distance with neither attraction nor repulsion (seed 003 eq. 3 and 5;
    /// Table I: 4.00).
    #[serde(default = "d_d0")]
    pub d0_m: f64,
    /// d_f [m]: beyond it the attraction saturates towards λα·π/2 (seed 003 eq. 3; Table I: 5.85).
    #[serde(default = "d_df")]
    pub df_m: f64,
    /// kα [m⁻¹s⁻²]: attraction gain, α = kα(d − d_0)² on (d_0, d_f] (seed 003 eq. 3;
    /// Table I "k_a": 0.16).
    #[serde(default = "d_k_alpha")]
    pub k_alpha: f64,
    /// d_c [m]: "critically close"; below it the repulsion grows as 1/√d (seed 003 eq. 5;
    /// Table I: 1.93).
    #[serde(default = "d_dc")]
    pub dc_m: f64,
    /// kβ [m⁻¹s⁻²]: repulsion gain, β = −kβ(d − d_0)² on (d_c, d_0] (seed 003 eq. 5;
    /// Table I "k_r": 0.07).
    #[serde(default = "d_k_beta")]
    pub k_beta: f64,
    /// d_max [m]: mean agent distance at which navigation fades to zero (seed 003 eq. 8;
    /// Table I: 8.00).
    #[serde(default = "d_dmax")]
    pub dmax_m: f64,
    /// kn [m/s²]: navigation gain, n = kn φ(μ_d) x̂ⁿ (seed 003 eq. 7; Table I: 1.20).
    #[serde(default = "d_kn")]
    pub kn: f64,
    /// d_r [m]: obstacle points farther than this are ignored by the collision vector (seed 000
    /// eq. 2.5; seed 003 Table I: 2.00).
    #[serde(default = "d_dr")]
    pub dr_m: f64,
    /// ko [m^½/s²]: collision gain, Φ = ko(1/√d − 1/√d_r) (seed 000 eq. 2.5;
    /// seed 003 Table I: 2.00).
    #[serde(default = "d_ko")]
    pub ko: f64,
    /// φ used when the informed agent observes no agent at all, in [0, 1] (seed 003 eq. 8 leaves
    /// μ_d undefined then). Default 0: an agent that sees nobody behaves as one whose agents are
    /// beyond d_max (seed 003: d_max is chosen so agents within it are still detectable), i.e. it
    /// waits for the flock instead of leaving it. 1 lets a lone informed UAV fly its path. A
    /// scenario of a single UAV has no flock to wait for and flies with 1 whatever this says
    /// (issue 25: `scenarios/found/found-2026-31.toml` waited for ever).
    #[serde(default)]
    pub phi_alone: f64,
    /// Cell size of the occupancy grid A* plans on [m] (seed 003 IV-C uses the Hector SLAM map,
    /// size not given). 0.1 m: a thinnest trunk (radius 0.1 m) still covers two cells, LIDAR
    /// noise (σ = 0.02 m) stays within one, and a 40 m × 40 m map is only 160 000 cells for A*.
    #[serde(default = "d_grid_resolution")]
    pub grid_resolution_m: f64,
    /// Obstacles in the grid are inflated by this distance before A* [m] (seed 003 IV-C:
    /// "inflated w.r.t the UAV size", no number). 0.7 m: the A21 frame's 22.5 cm arms plus
    /// propellers (≈ 0.35 m, the 0.3 m default body radius) plus the overshoot of a double
    /// integrator tracking a path (with 0.5 m, a21-forest-uvdar passed trunks at 0.51 m from the
    /// centre; with 0.7 m at 0.75 m).
    #[serde(default = "d_inflation")]
    pub inflation_m: f64,
    /// The A* path is planned again every this many seconds of sim time [s] (seed 003 is silent).
    /// 1 s: at the default 1 m/s speed limit the UAV moves at most the path lookahead between two
    /// plans, and newly scanned trees enter the plan within a second.
    #[serde(default = "d_replan")]
    pub replan_period_s: f64,
    /// x̂ⁿ points at the path point this far along the path beyond the path point nearest to the
    /// UAV [m] (seed 003 eq. 7 reads "the nearest point on path P", which is the UAV itself once it
    /// is on the path; 0 is that literal reading). 1 m: several grid cells, so the direction does
    /// not follow the grid's staircase, yet well below the 2.5 m tree spacing so the chord to the
    /// target stays near the (inflated, obstacle-free) path.
    #[serde(default = "d_lookahead")]
    pub path_lookahead_m: f64,
    /// Velocity damping k_v [1/s]: the agent commands f − k_v·v. Seed 003 feeds f to the MRS
    /// trajectory generator and MPC tracker, which damp the motion; our bodies track the
    /// acceleration directly, so without this the double integrator overshoots (0 = the bare
    /// eq. 1).
    #[serde(default = "d_damping")]
    pub damping_per_s: f64,
    /// The fastest A21 commands [m/s], below the body's limit (default: none, the body's
    /// `max_speed_mps` alone). Seed 003 gives no speed; seed 000 section 6.5 compares K21, whose
    /// final vector is capped at 0.4 m/s (`kf`), with this controller on one world, and a
    /// comparison of controllers wants one top speed (`compare-4` sets 0.4).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_speed_mps: Option<f64>,
    /// The safety layer, our extension (seed 003 has none): the velocity each command reaches
    /// within one control period loses its approach to every neighbour and scan point it could
    /// not stop short of at `safety_brake_mps2` (`uav-agent/src/control/barrier.rs`), as K21's
    /// barrier holds K21's. Off by default, so the seed's tables fly the bare eq. 1; `swarm
    /// fuzz` turns it on in its A21 cases. Without it an informed agent's navigation (kn·φ ≈
    /// 1 m/s²) outweighs the repulsion of a neighbour in its way, which eq. 2 averages over every
    /// agent within d_0, and from starts closer than d_c it pushes through its own flock
    /// (`scenarios/found/found-2026-44.toml`). It sees the scan points the collision vector
    /// takes (within `dr_m`), enough while a stop at the top speed needs less than that
    /// (`safety_surface_m` + v²/2b = 1 m at 1 m/s).
    #[serde(default)]
    pub safety: bool,
    /// The safety layer stops the approach to a neighbour's centre here [m], centre to centre:
    /// 0.9 m, above the separation invariant's 0.8 m.
    #[serde(default = "d_safety_neighbour")]
    pub safety_neighbour_m: f64,
    /// The safety layer stops the approach to a scan point (an obstacle's surface) here [m]:
    /// 0.5 m, a 0.3 m body and 0.2 m to spare.
    #[serde(default = "d_safety_surface")]
    pub safety_surface_m: f64,
    /// The deceleration the safety layer plans its stops with [m/s²]: 1.0, half the default
    /// body's 2 m/s², so the stop leaves the body room for the rest of the command.
    #[serde(default = "d_safety_brake")]
    pub safety_brake_mps2: f64,
}
fn d_safety_neighbour() -> f64 {
    0.9
}
fn d_safety_surface() -> f64 {
    0.5
}
fn d_safety_brake() -> f64 {
    1.0
}
fn d_damping() -> f64 {
    0.5
}
fn d_d0() -> f64 {
    4.00
}
fn d_df() -> f64 {
    5.85
}
fn d_k_alpha() -> f64 {
    0.16
}
fn d_dc() -> f64 {
    1.93
}
fn d_k_beta() -> f64 {
    0.07
}
fn d_dmax() -> f64 {
    8.00
}
fn d_kn() -> f64 {
    1.20
}
fn d_dr() -> f64 {
    2.00
}
fn d_ko() -> f64 {
    2.00
}
fn d_grid_resolution() -> f64 {
    0.1
}
fn d_inflation() -> f64 {
    0.7
}
fn d_replan() -> f64 {
    1.0
}
fn d_lookahead() -> f64 {
    1.0
}

impl Default for A21Params {
    fn default() -> Self {
        A21Params {
            d0_m: d_d0(),
            df_m: d_df(),
            k_alpha: d_k_alpha(),
            dc_m: d_dc(),
            k_beta: d_k_beta(),
            dmax_m: d_dmax(),
            kn: d_kn(),
            dr_m: d_dr(),
            ko: d_ko(),
            phi_alone: 0.0,
            grid_resolution_m: d_grid_resolution(),
            inflation_m: d_inflation(),
            replan_period_s: d_replan(),
            path_lookahead_m: d_lookahead(),
            damping_per_s: d_damping(),
            max_speed_mps: None,
            safety: false,
            safety_neighbour_m: d_safety_neighbour(),
            safety_surface_m: d_safety_surface(),
            safety_brake_mps2: d_safety_brake(),
        }
    }
}

impl A21Params {
    /// Checks every range and the orderings d_c < d_0 < d_f and d_0 < d_max; the error names the
    /// field as `{at}.name`.
    pub fn validate(&self, at: &str) -> Result<(), (String, String)> {
        for (name, v) in [
            ("d0_m", self.d0_m),
            ("df_m", self.df_m),
            ("dc_m", self.dc_m),
            ("dmax_m", self.dmax_m),
            ("dr_m", self.dr_m),
            ("grid_resolution_m", self.grid_resolution_m),
            ("replan_period_s", self.replan_period_s),
        ] {
            crate::validate::positive(&format!("{at}.{name}"), v)?;
        }
        for (name, v) in [
            ("k_alpha", self.k_alpha),
            ("k_beta", self.k_beta),
            ("kn", self.kn),
            ("ko", self.ko),
            ("inflation_m", self.inflation_m),
            ("path_lookahead_m", self.path_lookahead_m),
            ("damping_per_s", self.damping_per_s),
            ("safety_neighbour_m", self.safety_neighbour_m),
            ("safety_surface_m", self.safety_surface_m),
        ] {
            crate::validate::non_negative(&format!("{at}.{name}"), v)?;
        }
        crate::validate::within(&format!("{at}.phi_alone"), self.phi_alone, 0.0, 1.0)?;
        crate::validate::positive(&format!("{at}.safety_brake_mps2"), self.safety_brake_mps2)?;
        if let Some(v) = self.max_speed_mps {
            crate::validate::positive(&format!("{at}.max_speed_mps"), v)?;
        }
        // seed 003 eq. 6: λβ divides by √d_0 − √d_c, and eq. 5 orders its branches d_c < d_0.
        if self.dc_m >= self.d0_m {
            return Err((
                format!("{at}.dc_m"),
                format!("must be < d0_m = {} (seed 003 eq. 5-6), got {}", self.d0_m, self.dc_m),
            ));
        }
        // seed 003 eq. 3-4: the branches are ordered d_0 < d_f.
        if self.df_m <= self.d0_m {
            return Err((
                format!("{at}.df_m"),
                format!("must be > d0_m = {} (seed 003 eq. 3-4), got {}", self.d0_m, self.df_m),
            ));
        }
        // seed 003 eq. 8: φ(d_0) = 0 when d_max <= d_0, and an informed agent resting at d_0 from
        // its flock would never navigate.
        if self.dmax_m <= self.d0_m {
            return Err((
                format!("{at}.dmax_m"),
                format!("must be > d0_m = {} (seed 003 eq. 8), got {}", self.d0_m, self.dmax_m),
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_table_one() {
        let p = A21Params::default();
        // seed 003 Table I, in column order.
        assert_eq!(
            [p.d0_m, p.df_m, p.k_alpha, p.dc_m, p.k_beta, p.dmax_m, p.kn, p.dr_m, p.ko],
            [4.00, 5.85, 0.16, 1.93, 0.07, 8.00, 1.20, 2.00, 2.00]
        );
        assert_eq!(p.phi_alone, 0.0);
        assert_eq!(p.validate("controller.a21"), Ok(()));
    }

    #[test]
    fn empty_toml_gives_the_defaults_and_unknown_fields_are_rejected() {
        let p: A21Params = toml::from_str("").unwrap();
        let d = A21Params::default();
        assert_eq!(format!("{p:?}"), format!("{d:?}"));
        let p: A21Params = toml::from_str("d0_m = 4.5\nphi_alone = 1.0").unwrap();
        assert_eq!((p.d0_m, p.phi_alone, p.df_m), (4.5, 1.0, 5.85));
        assert!(toml::from_str::<A21Params>("d_0 = 4.0").is_err());
    }

    fn err_field(p: &A21Params) -> String {
        p.validate("c.a21").unwrap_err().0
    }

    #[test]
    fn validate_rejects_bad_ranges() {
        let d = A21Params::default();
        assert_eq!(err_field(&A21Params { d0_m: f64::NAN, ..d.clone() }), "c.a21.d0_m");
        assert_eq!(err_field(&A21Params { dr_m: 0.0, ..d.clone() }), "c.a21.dr_m");
        assert_eq!(err_field(&A21Params { dc_m: -1.0, ..d.clone() }), "c.a21.dc_m");
        assert_eq!(err_field(&A21Params { k_alpha: -0.1, ..d.clone() }), "c.a21.k_alpha");
        assert_eq!(err_field(&A21Params { ko: f64::INFINITY, ..d.clone() }), "c.a21.ko");
        assert_eq!(err_field(&A21Params { phi_alone: 1.5, ..d.clone() }), "c.a21.phi_alone");
        assert_eq!(err_field(&A21Params { grid_resolution_m: 0.0, ..d.clone() }), "c.a21.grid_resolution_m");
        assert_eq!(err_field(&A21Params { path_lookahead_m: -1.0, ..d.clone() }), "c.a21.path_lookahead_m");
        // Zero gains switch a term off and are allowed.
        let off = A21Params { k_alpha: 0.0, k_beta: 0.0, kn: 0.0, ko: 0.0, ..d };
        assert_eq!(off.validate("c.a21"), Ok(()));
    }

    #[test]
    fn validate_checks_the_orderings() {
        let d = A21Params::default();
        // d_c = d_0: λβ of eq. 6 would divide by zero.
        assert_eq!(err_field(&A21Params { dc_m: 4.0, ..d.clone() }), "c.a21.dc_m");
        assert_eq!(err_field(&A21Params { dc_m: 4.5, ..d.clone() }), "c.a21.dc_m");
        // d_f = d_0 or below.
        assert_eq!(err_field(&A21Params { df_m: 4.0, ..d.clone() }), "c.a21.df_m");
        assert_eq!(err_field(&A21Params { d0_m: 6.0, ..d.clone() }), "c.a21.df_m");
        // d_max <= d_0.
        assert_eq!(err_field(&A21Params { dmax_m: 3.9, ..d.clone() }), "c.a21.dmax_m");
        // Just inside every ordering is fine.
        let tight = A21Params { dc_m: 3.99, df_m: 4.01, dmax_m: 4.01, ..d };
        assert_eq!(tight.validate("c.a21"), Ok(()));
    }
}

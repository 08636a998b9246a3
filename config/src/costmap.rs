//! CostmapParams: parameters of the costmap of seed 004 chapter 3 (its map, its inflation and
//! social layers, and the A* global planner that runs on it).
//!
//! Every default is the value seed 004 ran with: Fig. 27 (Hector mapping), Fig. 30a
//! (`costmap_common_params.yaml`), Fig. 30c (local costmap resolution) and Fig. 33
//! (`global_planner_params.yaml`). Where the seed gives no number the default is that of the ROS
//! package the seed configured (named at the field), or the project's own choice (said so).

use serde::{Deserialize, Serialize};

use crate::validate::{non_negative, positive, within, Check};

/// Parameters of the seed 004 costmap and of the A* planner on it.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CostmapParams {
    /// Cell size [m]; seed 004 Fig. 27 (Hector `map_resolution` 0.050) and Fig. 30c
    /// (`resolution: 0.05`).
    #[serde(default = "d_resolution")]
    pub resolution_m: f64,
    /// Hector `update_factor_occupied`, the probability a hit gives a cell (seed 004 Fig. 27: 0.8).
    #[serde(default = "d_occupied")]
    pub update_factor_occupied: f64,
    /// Hector `update_factor_free`, the probability a pass-through gives a cell (seed 004
    /// Fig. 27: 0.45).
    #[serde(default = "d_free")]
    pub update_factor_free: f64,
    /// Scan points farther than this mark nothing, and beams clear only this far
    /// (`obstacle_range` and `raytrace_range`, seed 004 Fig. 30a: 9.0) [m].
    #[serde(default = "d_obstacle_range")]
    pub obstacle_range_m: f64,
    /// `robot_radius`, the inscribed radius: cells this close to an obstacle cost 253
    /// (seed 004 Fig. 30a: 0.6) [m].
    #[serde(default = "d_robot_radius")]
    pub robot_radius_m: f64,
    /// `inflation_radius`: cells farther than this from every obstacle get no inflation cost,
    /// measured from the obstacle as costmap_2d does (seed 004 Fig. 30a: 1.0) [m].
    #[serde(default = "d_inflation_radius")]
    pub inflation_radius_m: f64,
    /// `cost_scaling_factor` of the exponential fall-off `252·exp(−k·(d − robot_radius))`
    /// (seed 004 Fig. 30a: 5.0) [1/m].
    #[serde(default = "d_cost_scaling")]
    pub cost_scaling_factor: f64,
    /// Social layer amplitude A of seed 004 eq. 11, the cost at a neighbour's position
    /// (Fig. 30a: 150.0) [cost units, 0..=254].
    #[serde(default = "d_amplitude")]
    pub social_amplitude: f64,
    /// Social layer "covariance" σ of eq. 11 (Fig. 30a: 0.3). σ·f·|v| is a standard deviation
    /// in metres, and never less than σ itself (the project's floor for a slow neighbour) [m].
    #[serde(default = "d_covariance")]
    pub social_covariance: f64,
    /// Social layer velocity factor f of eq. 11 (Fig. 30a: 7.0) [s].
    #[serde(default = "d_factor")]
    pub social_factor: f64,
    /// Social costs below this are not written (seed 004 3.4 names the cut-off without a value;
    /// 10.0 is the default of the ProxemicLayer the seed ran) [cost units].
    #[serde(default = "d_cutoff")]
    pub social_cutoff: f64,
    /// global_planner `lethal_cost`: cells whose cost is at least `lethal_cost − 1` cannot be
    /// entered (seed 004 Fig. 33: 253).
    #[serde(default = "d_lethal")]
    pub lethal_cost: u8,
    /// global_planner `neutral_cost`, the cost of a step through a free or unknown cell
    /// (seed 004 Fig. 33: 50).
    #[serde(default = "d_neutral")]
    pub neutral_cost: u8,
    /// global_planner `cost_factor`: a step costs `neutral_cost + cost_factor · cell cost`
    /// (seed 004 Fig. 33: 3.0).
    #[serde(default = "d_cost_factor")]
    pub cost_factor: f64,
    /// A* stops after expanding this many cells and returns the best partial path, so a far goal
    /// cannot stall a control step (seed silent; project choice).
    #[serde(default = "d_max_expanded")]
    pub max_expanded_cells: u32,
    /// A* searches the known map plus start and goal, widened by this margin (seed silent;
    /// project choice) [m].
    #[serde(default = "d_margin")]
    pub search_margin_m: f64,
}
fn d_resolution() -> f64 {
    0.05
}
fn d_occupied() -> f64 {
    0.8
}
fn d_free() -> f64 {
    0.45
}
fn d_obstacle_range() -> f64 {
    9.0
}
fn d_robot_radius() -> f64 {
    0.6
}
fn d_inflation_radius() -> f64 {
    1.0
}
fn d_cost_scaling() -> f64 {
    5.0
}
fn d_amplitude() -> f64 {
    150.0
}
fn d_covariance() -> f64 {
    0.3
}
fn d_factor() -> f64 {
    7.0
}
fn d_cutoff() -> f64 {
    10.0
}
fn d_lethal() -> u8 {
    253
}
fn d_neutral() -> u8 {
    50
}
fn d_cost_factor() -> f64 {
    3.0
}
fn d_max_expanded() -> u32 {
    50_000
}
fn d_margin() -> f64 {
    2.0
}

impl Default for CostmapParams {
    fn default() -> Self {
        CostmapParams {
            resolution_m: d_resolution(),
            update_factor_occupied: d_occupied(),
            update_factor_free: d_free(),
            obstacle_range_m: d_obstacle_range(),
            robot_radius_m: d_robot_radius(),
            inflation_radius_m: d_inflation_radius(),
            cost_scaling_factor: d_cost_scaling(),
            social_amplitude: d_amplitude(),
            social_covariance: d_covariance(),
            social_factor: d_factor(),
            social_cutoff: d_cutoff(),
            lethal_cost: d_lethal(),
            neutral_cost: d_neutral(),
            cost_factor: d_cost_factor(),
            max_expanded_cells: d_max_expanded(),
            search_margin_m: d_margin(),
        }
    }
}

/// The inflation stamp is (2·radius/resolution)² cells; beyond this many cells per radius the
/// costmap would spend a control step stamping one obstacle.
const MAX_INFLATION_CELLS: f64 = 100.0;

impl CostmapParams {
    /// Checks every field; the error names the field as `{at}.field`.
    pub fn validate(&self, at: &str) -> Check {
        within(&format!("{at}.resolution_m"), self.resolution_m, 1e-3, 10.0)?;
        self.validate_map(at)?;
        self.validate_inflation(at)?;
        self.validate_social(at)?;
        self.validate_planner(at)
    }

    fn validate_map(&self, at: &str) -> Check {
        let occ = self.update_factor_occupied;
        if !(occ.is_finite() && occ > 0.5 && occ < 1.0) {
            return Err((format!("{at}.update_factor_occupied"), format!("must be in (0.5, 1), got {occ}")));
        }
        let free = self.update_factor_free;
        if !(free.is_finite() && free > 0.0 && free < 0.5) {
            return Err((format!("{at}.update_factor_free"), format!("must be in (0, 0.5), got {free}")));
        }
        positive(&format!("{at}.obstacle_range_m"), self.obstacle_range_m)
    }

    fn validate_inflation(&self, at: &str) -> Check {
        non_negative(&format!("{at}.robot_radius_m"), self.robot_radius_m)?;
        non_negative(&format!("{at}.inflation_radius_m"), self.inflation_radius_m)?;
        if self.inflation_radius_m < self.robot_radius_m {
            return Err((
                format!("{at}.inflation_radius_m"),
                format!(
                    "must be >= robot_radius_m ({}): it is measured from the obstacle, as in costmap_2d",
                    self.robot_radius_m
                ),
            ));
        }
        if self.inflation_radius_m / self.resolution_m > MAX_INFLATION_CELLS {
            return Err((
                format!("{at}.inflation_radius_m"),
                format!("spans more than {MAX_INFLATION_CELLS} cells of resolution_m; use coarser cells"),
            ));
        }
        non_negative(&format!("{at}.cost_scaling_factor"), self.cost_scaling_factor)
    }

    fn validate_social(&self, at: &str) -> Check {
        within(&format!("{at}.social_amplitude"), self.social_amplitude, 0.0, 254.0)?;
        positive(&format!("{at}.social_covariance"), self.social_covariance)?;
        non_negative(&format!("{at}.social_factor"), self.social_factor)?;
        within(&format!("{at}.social_cutoff"), self.social_cutoff, 1.0, 254.0)
    }

    fn validate_planner(&self, at: &str) -> Check {
        if self.lethal_cost < 2 {
            return Err((format!("{at}.lethal_cost"), format!("must be between 2 and 255, got {}", self.lethal_cost)));
        }
        if self.neutral_cost == 0 || self.neutral_cost >= self.lethal_cost {
            return Err((
                format!("{at}.neutral_cost"),
                format!("must be between 1 and lethal_cost − 1 ({}), got {}", self.lethal_cost - 1, self.neutral_cost),
            ));
        }
        non_negative(&format!("{at}.cost_factor"), self.cost_factor)?;
        if self.max_expanded_cells == 0 {
            return Err((format!("{at}.max_expanded_cells"), "must be > 0".into()));
        }
        non_negative(&format!("{at}.search_margin_m"), self.search_margin_m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_seed_values_and_valid() {
        let p = CostmapParams::default();
        // seed 004 Fig. 27, 30a, 30c and 33.
        assert_eq!(p.resolution_m, 0.05);
        assert_eq!((p.update_factor_occupied, p.update_factor_free), (0.8, 0.45));
        assert_eq!(p.obstacle_range_m, 9.0);
        assert_eq!((p.robot_radius_m, p.inflation_radius_m, p.cost_scaling_factor), (0.6, 1.0, 5.0));
        assert_eq!((p.social_amplitude, p.social_covariance, p.social_factor), (150.0, 0.3, 7.0));
        assert_eq!((p.lethal_cost, p.neutral_cost, p.cost_factor), (253, 50, 3.0));
        assert_eq!(p.validate("m23.costmap"), Ok(()));
    }

    #[test]
    fn empty_toml_gives_the_defaults_and_unknown_fields_are_rejected() {
        let p: CostmapParams = toml::from_str("").expect("empty table");
        assert_eq!(format!("{p:?}"), format!("{:?}", CostmapParams::default()));
        let p: CostmapParams = toml::from_str("inflation_radius_m = 1.5\nneutral_cost = 66").expect("two fields");
        assert_eq!((p.inflation_radius_m, p.neutral_cost), (1.5, 66));
        assert!(toml::from_str::<CostmapParams>("inflation_radius = 1.0").is_err());
    }

    #[test]
    fn out_of_range_values_name_their_field() {
        let field = |p: CostmapParams| p.validate("c").expect_err("must be rejected").0;
        let d = CostmapParams::default;
        assert_eq!(field(CostmapParams { resolution_m: 0.0, ..d() }), "c.resolution_m");
        assert_eq!(field(CostmapParams { update_factor_occupied: 0.4, ..d() }), "c.update_factor_occupied");
        assert_eq!(field(CostmapParams { update_factor_free: 0.5, ..d() }), "c.update_factor_free");
        assert_eq!(field(CostmapParams { inflation_radius_m: 0.5, ..d() }), "c.inflation_radius_m");
        assert_eq!(field(CostmapParams { resolution_m: 0.001, ..d() }), "c.inflation_radius_m");
        assert_eq!(field(CostmapParams { cost_scaling_factor: f64::NAN, ..d() }), "c.cost_scaling_factor");
        assert_eq!(field(CostmapParams { social_amplitude: 300.0, ..d() }), "c.social_amplitude");
        assert_eq!(field(CostmapParams { social_covariance: 0.0, ..d() }), "c.social_covariance");
        assert_eq!(field(CostmapParams { social_cutoff: 0.5, ..d() }), "c.social_cutoff");
        assert_eq!(field(CostmapParams { lethal_cost: 1, ..d() }), "c.lethal_cost");
        assert_eq!(field(CostmapParams { neutral_cost: 253, ..d() }), "c.neutral_cost");
        assert_eq!(field(CostmapParams { neutral_cost: 0, ..d() }), "c.neutral_cost");
        assert_eq!(field(CostmapParams { max_expanded_cells: 0, ..d() }), "c.max_expanded_cells");
        assert_eq!(field(CostmapParams { search_margin_m: -1.0, ..d() }), "c.search_margin_m");
    }
}

//! UvdarParams: parameters of the onboard relative sensing of seed 003 (UVDAR).
//!
//! Seed 003 (A21) localizes neighbours with UVDAR — blinking ultraviolet markers seen by onboard
//! cameras — and no communication at all (abstract, section V-A, V-B). The seed gives no camera
//! figures (range, field of view, accuracy, rate); what it does say, and the choices made where
//! it is silent:
//!
//! - **Range**: section III-B chooses d_max = 8 m (Table I) "such that the informed agent can
//!   still detect other agents using its relative localization system", so UVDAR sees at least
//!   8 m. That lower bound is the default: the only range the seed ties to UVDAR.
//! - **Field of view**: silent. Default 360°: the proximal vector (eq. 2) sums over neighbours
//!   in every direction and self-aggregation (V-A) starts from arbitrary placements, which only
//!   makes sense with all-around coverage.
//! - **Range noise**: silent. Modelled as **relative** — σ_r = `range_noise_rel` · d — because
//!   a camera gets distance from the apparent size of the marker constellation (markers a known
//!   span apart), which shrinks as 1/d, so a fixed pixel error gives a distance error that grows
//!   with d; a bearing, read off one image point, does not. One dimensionless number covers all
//!   distances. Default 0.1 (10 %): a choice.
//! - **Bearing noise**: silent. Default 1°: a choice (a few fisheye pixels).
//! - **Detection probability**: silent. Default 1.0: the only cause of lost detections the seed
//!   names is occlusion (V-B), which is modelled geometrically by the next two switches.
//! - **Occlusion**: V-B: "the UAVs would also get occluded by nearby trees and other agents" —
//!   both default to true.
//! - **Rate**: silent; no field: the hub is meant to observe once per tick, like the LIDAR.

use serde::{Deserialize, Serialize};

/// Onboard relative sensing (seed 003 UVDAR): what a UAV's cameras see of its neighbours.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UvdarParams {
    /// Neighbours farther than this are not seen [m] (seed 003 III-B, Table I: d_max = 8 m is
    /// "selected such that the informed agent can still detect other agents").
    #[serde(default = "d_max_range")]
    pub max_range_m: f64,
    /// Horizontal field of view, centred on the heading [deg]; 360 = all around (seed silent;
    /// 360 because eq. 2 sums over neighbours in every direction).
    #[serde(default = "d_fov")]
    pub fov_deg: f64,
    /// Range noise relative to the true distance: σ_r = range_noise_rel · d [-] (seed silent;
    /// relative because distance comes from the apparent marker spacing; 0.1 is a choice).
    #[serde(default = "d_range_noise")]
    pub range_noise_rel: f64,
    /// Bearing noise σ [deg] (seed silent; 1° is a choice).
    #[serde(default = "d_bearing_noise")]
    pub bearing_noise_deg: f64,
    /// Probability that a visible neighbour is detected in one observation [-] (seed silent;
    /// 1 because occlusion, modelled below, is the loss the seed names in V-B).
    #[serde(default = "d_detect")]
    pub detection_probability: f64,
    /// Trees and walls block the line of sight (seed 003 V-B: "occluded by nearby trees").
    #[serde(default = "yes")]
    pub occluded_by_obstacles: bool,
    /// Other UAVs block the line of sight (seed 003 V-B: "occluded by ... other agents").
    #[serde(default = "yes")]
    pub occluded_by_uavs: bool,
    /// Radius of the disc with which another UAV blocks the line of sight [m]. Default 0.3, the
    /// default body radius (SPEC §2; the seed 003 V-B frame has 22.5 cm arms); keep it equal to
    /// `body.radius_m` when that is changed.
    #[serde(default = "d_uav_radius")]
    pub uav_radius_m: f64,
}
fn d_max_range() -> f64 {
    8.0
}
fn d_fov() -> f64 {
    360.0
}
fn d_range_noise() -> f64 {
    0.1
}
fn d_bearing_noise() -> f64 {
    1.0
}
fn d_detect() -> f64 {
    1.0
}
fn yes() -> bool {
    true
}
fn d_uav_radius() -> f64 {
    0.3
}

impl Default for UvdarParams {
    fn default() -> Self {
        UvdarParams {
            max_range_m: d_max_range(),
            fov_deg: d_fov(),
            range_noise_rel: d_range_noise(),
            bearing_noise_deg: d_bearing_noise(),
            detection_probability: d_detect(),
            occluded_by_obstacles: yes(),
            occluded_by_uavs: yes(),
            uav_radius_m: d_uav_radius(),
        }
    }
}

impl UvdarParams {
    /// Checks every field; the error names `{at}.{field}` and what is wrong.
    pub fn validate(&self, at: &str) -> Result<(), (String, String)> {
        crate::validate::positive(&format!("{at}.max_range_m"), self.max_range_m)?;
        if !(self.fov_deg.is_finite() && self.fov_deg > 0.0 && self.fov_deg <= 360.0) {
            return Err((format!("{at}.fov_deg"), format!("must be in (0, 360], got {}", self.fov_deg)));
        }
        // A relative σ above 1 would put most draws of a near neighbour at range 0.
        crate::validate::within(&format!("{at}.range_noise_rel"), self.range_noise_rel, 0.0, 1.0)?;
        crate::validate::within(&format!("{at}.bearing_noise_deg"), self.bearing_noise_deg, 0.0, 180.0)?;
        crate::validate::within(&format!("{at}.detection_probability"), self.detection_probability, 0.0, 1.0)?;
        crate::validate::non_negative(&format!("{at}.uav_radius_m"), self.uav_radius_m)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_documented_values() {
        let p = UvdarParams::default();
        assert_eq!(p.max_range_m, 8.0); // seed 003 Table I d_max
        assert_eq!(p.fov_deg, 360.0);
        assert_eq!(p.range_noise_rel, 0.1);
        assert_eq!(p.bearing_noise_deg, 1.0);
        assert_eq!(p.detection_probability, 1.0);
        assert!(p.occluded_by_obstacles && p.occluded_by_uavs); // seed 003 V-B
        assert_eq!(p.uav_radius_m, 0.3);
        assert_eq!(p.validate("u"), Ok(()));
    }

    #[test]
    fn empty_toml_gives_the_defaults_and_unknown_fields_are_rejected() {
        let p: UvdarParams = toml::from_str("").expect("empty table parses");
        assert_eq!(format!("{p:?}"), format!("{:?}", UvdarParams::default()));
        let p: UvdarParams = toml::from_str("fov_deg = 120.0\noccluded_by_uavs = false").expect("two fields parse");
        assert_eq!(p.fov_deg, 120.0);
        assert!(!p.occluded_by_uavs);
        assert_eq!(p.max_range_m, 8.0);
        assert!(toml::from_str::<UvdarParams>("range_m = 5.0").is_err());
    }

    #[test]
    fn validate_names_the_bad_field() {
        let field = |p: UvdarParams| p.validate("localization.uvdar").err().map(|e| e.0);
        let bad = |f: fn(&mut UvdarParams)| {
            let mut p = UvdarParams::default();
            f(&mut p);
            field(p)
        };
        let at = |s: &str| Some(format!("localization.uvdar.{s}"));
        assert_eq!(bad(|p| p.max_range_m = 0.0), at("max_range_m"));
        assert_eq!(bad(|p| p.max_range_m = f64::INFINITY), at("max_range_m"));
        assert_eq!(bad(|p| p.fov_deg = 0.0), at("fov_deg"));
        assert_eq!(bad(|p| p.fov_deg = 360.5), at("fov_deg"));
        assert_eq!(bad(|p| p.fov_deg = f64::NAN), at("fov_deg"));
        assert_eq!(bad(|p| p.range_noise_rel = -0.01), at("range_noise_rel"));
        assert_eq!(bad(|p| p.range_noise_rel = 1.5), at("range_noise_rel"));
        assert_eq!(bad(|p| p.bearing_noise_deg = f64::NAN), at("bearing_noise_deg"));
        assert_eq!(bad(|p| p.detection_probability = 1.01), at("detection_probability"));
        assert_eq!(bad(|p| p.uav_radius_m = -0.1), at("uav_radius_m"));
        // Edges that are allowed: a 360° view, no noise, never detected, point-sized UAVs.
        assert_eq!(bad(|p| p.fov_deg = 360.0), None);
        assert_eq!(bad(|p| p.range_noise_rel = 0.0), None);
        assert_eq!(bad(|p| p.detection_probability = 0.0), None);
        assert_eq!(bad(|p| p.uav_radius_m = 0.0), None);
    }
}

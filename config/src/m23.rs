//! M23Params: parameters of the M23 formation layer (seed 004 chapter 3, section 3.4).
//!
//! Why this module exists: the scenario schema of the leader-follower topologies of seed 004
//! (None / LF / PF / TNPF), the leader's wait rule (Fig. 38), the follower's goal validation
//! against the costmap (Fig. 40–42) and the limits of the local tracker (Fig. 34, section 3.6).
//! Every number the seed gives is the default; where the seed names a parameter but prints no
//! value, the default is a choice, said so at its field:
//! - the LF offsets are the start layout of Table 7 relative to the leader UAV 1, a 2 × 2
//!   rectangle with 2 m spacing (section 3.4: "LF topology will always give rectangle
//!   formation"); followers beyond the list continue that rectangle two columns wide;
//! - the PF / TNPF pull-back `distance` of Fig. 42e is not printed: 2 m, the spacing of Table 7;
//! - MAX_DISTANCE, MAX_TIME, SEARCHING_RADIUS and the follower's update period are not printed;
//! - COSTMAP_THRES is not printed: 50, the seed's "area with the cost less than 50 is considered
//!   as safe area" (text under Fig. 33).

use crate::validate::Check;
use serde::{Deserialize, Serialize};
use swarm_types::UavId;

/// Which formation rule generates the followers' goals (seed 004 section 3.4, Fig. 37 and 41).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Topology {
    /// No formation: every UAV flies to its own static goal (section 3.5, "None").
    None,
    /// Leader Following: every follower keeps a fixed offset to the leader (Fig. 41a).
    Lf,
    /// Predecessor Following: each follower follows the UAV before it (Fig. 41b).
    Pf,
    /// Two-Nearest Predecessor Following: the centre of the two nearest predecessors (Fig. 41c).
    Tnpf,
}

/// The frame the LF offsets are given in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LfFrame {
    /// World axes, not rotated: seed 004 Fig. 42d line 353 adds the offset to the leader's
    /// position in the fixed map frame, so the rectangle keeps its orientation.
    World,
    /// The leader's body frame (x forward, y left): the offset is rotated by the leader's heading.
    /// Not in the seed; for scenarios whose goal is not along +x.
    LeaderHeading,
}

/// M23 parameters (seed 004 chapter 3). Where the seed gives a number it is the default.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct M23Params {
    /// Formation topology, TOPO of Fig. 40. Default `lf`, the topology section 3.6 builds on.
    #[serde(default = "d_topology")]
    pub topology: Topology,
    /// Id of the leader UAV; the others follow in ascending id order (Fig. 39: `uav1` leads,
    /// Fig. 42a line 623: the predecessor of `uavN` is `uav(N-1)`).
    #[serde(default = "d_leader")]
    pub leader_id: UavId,
    /// Frame of `lf_offsets_m` (seed: `world`, Fig. 42d line 353).
    #[serde(default = "d_lf_frame")]
    pub lf_frame: LfFrame,
    /// LF offset of each follower from the leader [m], in follower order (ascending id, leader
    /// skipped). Default: the Table 7 start positions of UAV 2, 3, 4 minus that of UAV 1:
    /// (0, −15) − (2, −15) = (−2, 0), (2, −17) − (2, −15) = (0, −2),
    /// (0, −17) − (2, −15) = (−2, −2).
    #[serde(default = "d_lf_offsets")]
    pub lf_offsets_m: Vec<[f64; 2]>,
    /// Spacing of the generated LF rectangle for followers beyond `lf_offsets_m` [m]: slot s
    /// (leader s = 0) sits at (−spacing·(s mod 2), −spacing·⌊s/2⌋), which reproduces Table 7.
    #[serde(default = "d_spacing")]
    pub lf_spacing_m: f64,
    /// PF: the predecessor's position pulled back towards the follower by this distance [m]
    /// (`distance` of Fig. 42e lines 454–456; value not printed, chosen = Table 7 spacing).
    #[serde(default = "d_spacing")]
    pub pf_distance_m: f64,
    /// TNPF: the centre of the two nearest predecessors pulled back towards the follower by this
    /// distance [m] (Fig. 42e lines 446–450; value not printed, chosen = Table 7 spacing).
    #[serde(default = "d_spacing")]
    pub tnpf_distance_m: f64,
    /// MAX_DISTANCE (Fig. 38) [m]: the leader waits while a follower is farther than this. Not
    /// printed; chosen 6 m, the length of the seed's four-UAV PF chain (3 × 2 m), so a formation
    /// that holds its shape never makes the leader wait.
    #[serde(default = "d_max_distance")]
    pub max_distance_m: f64,
    /// MAX_TIME (Fig. 38) [s]: the leader waits at most this long per episode. Not printed;
    /// chosen 10 s.
    #[serde(default = "d_max_time")]
    pub max_time_s: f64,
    /// COSTMAP_THRES (Fig. 40): a goal is accepted when its cost is below this (0–255 ROS costmap
    /// scale). Default 50: "area with the cost less than 50 is considered as safe area" (seed 004,
    /// text under Fig. 33).
    #[serde(default = "d_costmap_thres")]
    pub costmap_thres: u8,
    /// SEARCHING_RADIUS (Fig. 40, 42b) [m]: how far around an occupied formation goal to look
    /// for a cheap cell. Not printed; chosen 2 m, one formation spacing.
    #[serde(default = "d_spacing")]
    pub searching_radius_m: f64,
    /// A follower recomputes its formation goal (and plans to it) this often [s]. Fig. 42a
    /// recomputes and republishes the goal on every pass of its loop; 0.1 s is every control step
    /// at 10 Hz. (Until issue 25: 1 s, the global costmap's update_frequency of Fig. 30b, which
    /// left a follower chasing a goal up to 1 m old and doubled PF's deviation.)
    #[serde(default = "d_goal_period")]
    pub goal_period_s: f64,
    /// Once the leader is this close to its goal the followers fly to their own final goals
    /// (Fig. 42a line 601: `distance2d(leader_pos, leader_goal) < 2.0`) [m].
    #[serde(default = "d_spacing")]
    pub leader_arrived_m: f64,
    /// Per-UAV static goals [m], world frame, indexed by id − 1; used by topology `none` and by
    /// followers once the leader has arrived. Optional: absent, every UAV flies to `swarm.goal`.
    /// Table 7 of seed 004: [[42, −2], [42, 2], [40, −1], [40, 1]].
    #[serde(default)]
    pub goals: Option<Vec<[f64; 2]>>,
    /// Tracker speed limit [m/s]: DWA max_vel_x 1.5 (Fig. 34), the "Slow" setting of section 3.6.
    #[serde(default = "d_max_speed")]
    pub max_speed_mps: f64,
    /// Tracker acceleration limit [m/s²]: DWA acc_lim_x = acc_lim_y = 1.0 (Fig. 34, section 3.6).
    #[serde(default = "d_max_accel")]
    pub max_accel_mps2: f64,
    /// Tracker lookahead along the path [m]: max_vel_x 1.5 m/s × DWA sim_time 1.0 s (Fig. 34),
    /// the distance DWA simulates ahead.
    #[serde(default = "d_lookahead")]
    pub lookahead_m: f64,
    /// The tracker stops within this distance of the path's end [m]: DWA xy_goal_tolerance 0.5
    /// (Fig. 34).
    #[serde(default = "d_goal_tolerance")]
    pub goal_tolerance_m: f64,
    /// Costmap parameters (inflation, social layer).
    #[serde(default)]
    pub costmap: crate::CostmapParams,
}

fn d_topology() -> Topology {
    Topology::Lf
}
fn d_leader() -> UavId {
    UavId::new(1)
}
fn d_lf_frame() -> LfFrame {
    LfFrame::World
}
fn d_lf_offsets() -> Vec<[f64; 2]> {
    vec![[-2.0, 0.0], [0.0, -2.0], [-2.0, -2.0]]
}
fn d_spacing() -> f64 {
    2.0
}
fn d_max_distance() -> f64 {
    6.0
}
fn d_max_time() -> f64 {
    10.0
}
fn d_costmap_thres() -> u8 {
    50
}
fn d_goal_period() -> f64 {
    0.1
}
fn d_max_speed() -> f64 {
    1.5
}
fn d_max_accel() -> f64 {
    1.0
}
fn d_lookahead() -> f64 {
    1.5
}
fn d_goal_tolerance() -> f64 {
    0.5
}

impl Default for M23Params {
    fn default() -> Self {
        M23Params {
            topology: d_topology(),
            leader_id: d_leader(),
            lf_frame: d_lf_frame(),
            lf_offsets_m: d_lf_offsets(),
            lf_spacing_m: d_spacing(),
            pf_distance_m: d_spacing(),
            tnpf_distance_m: d_spacing(),
            max_distance_m: d_max_distance(),
            max_time_s: d_max_time(),
            costmap_thres: d_costmap_thres(),
            searching_radius_m: d_spacing(),
            goal_period_s: d_goal_period(),
            leader_arrived_m: d_spacing(),
            goals: None,
            max_speed_mps: d_max_speed(),
            max_accel_mps2: d_max_accel(),
            lookahead_m: d_lookahead(),
            goal_tolerance_m: d_goal_tolerance(),
            costmap: crate::CostmapParams::default(),
        }
    }
}

fn all_finite(field: String, points: &[[f64; 2]]) -> Check {
    match points.iter().position(|p| !(p[0].is_finite() && p[1].is_finite())) {
        Some(i) => Err((format!("{field}[{i}]"), format!("must be finite, got {:?}", points[i]))),
        None => Ok(()),
    }
}

impl M23Params {
    /// Checks ranges; the error names the dotted field under `at` (e.g. `controller.m23`).
    /// The number of `goals` against `swarm.count` is checked by the scenario, which knows it.
    pub fn validate(&self, at: &str) -> Check {
        if self.leader_id.try_index().is_none() {
            return Err((format!("{at}.leader_id"), "must be a UAV id (>= 1)".into()));
        }
        for (name, v) in [
            ("lf_spacing_m", self.lf_spacing_m),
            ("pf_distance_m", self.pf_distance_m),
            ("tnpf_distance_m", self.tnpf_distance_m),
            ("max_distance_m", self.max_distance_m),
            ("max_time_s", self.max_time_s),
            ("searching_radius_m", self.searching_radius_m),
            ("goal_period_s", self.goal_period_s),
            ("leader_arrived_m", self.leader_arrived_m),
            ("max_speed_mps", self.max_speed_mps),
            ("max_accel_mps2", self.max_accel_mps2),
            ("lookahead_m", self.lookahead_m),
            ("goal_tolerance_m", self.goal_tolerance_m),
        ] {
            crate::validate::positive(&format!("{at}.{name}"), v)?;
        }
        if !(1..=254).contains(&self.costmap_thres) {
            return Err((
                format!("{at}.costmap_thres"),
                format!("must be between 1 and 254 (goals need a cost below it), got {}", self.costmap_thres),
            ));
        }
        all_finite(format!("{at}.lf_offsets_m"), &self.lf_offsets_m)?;
        if let Some(goals) = &self.goals {
            all_finite(format!("{at}.goals"), goals)?;
        }
        Ok(())
    }

    /// LF offset [m] of the follower with 0-based index `follower_index` (ascending id, leader
    /// skipped): `lf_offsets_m[i]` if given, else slot s = i + 1 of the generated rectangle,
    /// (−spacing·(s mod 2), −spacing·⌊s/2⌋) — the Table 7 layout continued two columns wide.
    pub fn lf_offset_m(&self, follower_index: usize) -> [f64; 2] {
        if let Some(o) = self.lf_offsets_m.get(follower_index) {
            return *o;
        }
        let slot = follower_index + 1;
        let column = (slot % 2) as f64;
        let row = (slot / 2) as f64;
        [-self.lf_spacing_m * column, -self.lf_spacing_m * row]
    }

    /// The static goal of UAV `id`: `goals[id − 1]` when given, else `swarm_goal`.
    pub fn goal_of(&self, id: UavId, swarm_goal: [f64; 2]) -> [f64; 2] {
        let index = id.try_index();
        self.goals.as_ref().and_then(|g| index.and_then(|i| g.get(i))).copied().unwrap_or(swarm_goal)
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_seed_numbers() {
        let p = M23Params::default();
        // Fig. 34 / section 3.6 "Slow": 1.5 m/s, 1 m/s²; Fig. 34 xy_goal_tolerance 0.5;
        // Fig. 42a line 601: 2.0 m; text under Fig. 33: cost < 50 is safe.
        assert_eq!((p.max_speed_mps, p.max_accel_mps2, p.goal_tolerance_m), (1.5, 1.0, 0.5));
        assert_eq!((p.leader_arrived_m, p.costmap_thres, p.leader_id), (2.0, 50, UavId::new(1)));
        assert_eq!(p.lf_frame, LfFrame::World);
        assert!(p.validate("m").is_ok());
    }

    #[test]
    fn generated_rectangle_reproduces_table_7() {
        // Table 7 starts: UAV1 (2,−15), UAV2 (0,−15), UAV3 (2,−17), UAV4 (0,−17).
        let p = M23Params { lf_offsets_m: vec![], ..M23Params::default() };
        let given = M23Params::default();
        for i in 0..3 {
            assert_eq!(p.lf_offset_m(i), given.lf_offset_m(i));
        }
        // Slot 4 = (−2·0, −2·2) = (0, −4); slot 5 = (−2, −4).
        assert_eq!(given.lf_offset_m(3), [0.0, -4.0]);
        assert_eq!(given.lf_offset_m(4), [-2.0, -4.0]);
    }

    #[test]
    fn goal_of_uses_the_per_uav_goals_when_given() {
        let shared = [30.0, 0.0];
        let p = M23Params::default();
        assert_eq!(p.goal_of(UavId::new(3), shared), shared);
        let table7 = vec![[42.0, -2.0], [42.0, 2.0], [40.0, -1.0], [40.0, 1.0]];
        let p = M23Params { goals: Some(table7), ..M23Params::default() };
        assert_eq!(p.goal_of(UavId::new(3), shared), [40.0, -1.0]);
        assert_eq!(p.goal_of(UavId::new(5), shared), shared);
        assert_eq!(p.goal_of(UavId::new(0), shared), shared);
    }

    #[test]
    fn validate_names_the_field() {
        let p = M23Params { max_time_s: 0.0, ..M23Params::default() };
        assert_eq!(p.validate("controller.m23").unwrap_err().0, "controller.m23.max_time_s");
        let p = M23Params { costmap_thres: 255, ..M23Params::default() };
        assert_eq!(p.validate("c").unwrap_err().0, "c.costmap_thres");
        let p = M23Params { goals: Some(vec![[0.0, 0.0], [f64::NAN, 1.0]]), ..M23Params::default() };
        assert_eq!(p.validate("c").unwrap_err().0, "c.goals[1]");
        let p = M23Params { leader_id: UavId::new(0), ..M23Params::default() };
        assert_eq!(p.validate("c").unwrap_err().0, "c.leader_id");
    }

    #[test]
    fn toml_round_trip_and_unknown_fields() {
        let p: M23Params = toml::from_str("topology = \"tnpf\"\nlf_frame = \"leader_heading\"\n").unwrap();
        assert_eq!((p.topology, p.lf_frame), (Topology::Tnpf, LfFrame::LeaderHeading));
        assert_eq!(p.pf_distance_m, 2.0);
        assert!(toml::from_str::<M23Params>("max_speed = 3.0\n").is_err());
    }
}

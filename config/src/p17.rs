//! P17Params: parameters of the P17 controller (seed 001 chapter 3, Tables 1 and 2).
//!
//! Why this module exists: seed 001 does not have one parameter set but one per experiment
//! (Table 1: one row per simulation figure; Table 2: the real deployment; section 6.1: the
//! localization-error study). A scenario names the experiment it follows with
//! `preset = "<name>"` in `[controller.p17]` and may override any single value; [`P17Params::values`]
//! resolves preset + overrides into the plain numbers the controller uses ([`P17Values`]).
//!
//! Choices where seed 001 is silent or contradicts itself:
//! - Table 1 marks values an experiment did not use with "X" (no obstacle: k2, w; no goal: c1,
//!   c2; Table 2 has no wall: b2). A preset fills an X with the value of the default preset
//!   (`forest_9`), so every preset is a complete, flyable set.
//! - Loop rate 5 Hz and loop distance 0.75 m: section 4.4 says so for all Table 1 simulations;
//!   Table 2 does not say, and the same values are taken. Section 6.1 sets 30 Hz and 2 m.
//! - The default preset is `forest_9` (Table 1, Fig. 52 and 54: 9 UAVs through a forest-like
//!   environment, the planar forest flight this project reproduces; the row has no X).
//! - Ranges: the seed asks d, w ∈ (0, r) (eq. 7, 29), but its own Table 1 row of Fig. 52/54 has
//!   d = 8 m > r = 7.5 m, so only d, w > 0 is enforced. It asks c1, c2 > 0 (eq. 38–39), but
//!   Table 2 has c2 = 0, so c1, c2 ≥ 0; b1, b2 ≥ 0 as well (0 switches the tangential β-agent
//!   velocity off, useful for comparison). k1, k2, r, loop rate and loop distance must be > 0.
//! - `obstacle_barrier` (default `true`, every preset) is not a table value but a reading of
//!   eq. 28–29: σ_j is the magnitude of the push away from a β-agent (Fig. 22 plots it rising
//!   without bound at contact), so the push is σ_j times the unit vector from the β-agent. `false`
//!   keeps eq. 28 as typeset, σ_j (p0 − p_qj), whose magnitude k2(√x − x/√w) falls to zero at
//!   contact (issue 14: that is how P17 flew into trees and stalled far from single trees; see the
//!   controller's module doc).
//! - `obstacle_margin_m` (default 0.8 m, every preset) is ours, a safety layer the seed does not
//!   have: a velocity that would bring the UAV's centre nearer than this to an obstacle's border
//!   loses its component towards it (0 turns it off; see the controller's module doc). 0.8 m is
//!   the bodies' 0.3 m radius plus the 0.25 m a body at 1 m/s needs to stop at 2 m/s², plus slack.

use serde::{Deserialize, Serialize};

/// The named parameter sets of seed 001, each named after what the seed uses it for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum P17Preset {
    /// `boids`: Table 1, Fig. 28, 29 and 35: pure Boids, a 4-UAV swarm forming in free space
    /// (the lattice of section 4.1, ξ = 2.80 ± 0.15 m with d = 4 m).
    Boids,
    /// `boids_7`: Table 1, Fig. 33: pure Boids with 7 UAVs.
    Boids7,
    /// `navigation`: Table 1, Fig. 36 and 38: free space with a common static goal.
    Navigation,
    /// `cylinder`: Table 1, Fig. 40, 41, 44 and 45: one cylinder, and gaps between two.
    Cylinder,
    /// `wall`: Table 1, Fig. 42: one wall, planar.
    Wall,
    /// `wall_3d`: Table 1, Fig. 43: one wall, 3D flight.
    Wall3d,
    /// `gap_formation`: Table 1, Fig. 46: forming a formation before a narrow gap.
    GapFormation,
    /// `forest`: Table 1, Fig. 48–51: swarming started inside a forest-like environment, without
    /// and with a common static goal.
    Forest,
    /// `forest_9`: Table 1, Fig. 52 and 54: 9 UAVs navigating through a forest-like environment.
    /// The default.
    Forest9,
    /// `deployment`: Table 2: the real 3-UAV flight through a modelled forest (chapter 5).
    Deployment,
    /// `localization_error`: section 6.1: the localization-error study (d = w = 8 m, 30 Hz, 2 m;
    /// run in the Fig. 54/56 world, so the other values are those of `forest_9`).
    LocalizationError,
}

impl P17Preset {
    /// Every preset, in the order of the seed.
    pub const ALL: [P17Preset; 11] = [
        P17Preset::Boids,
        P17Preset::Boids7,
        P17Preset::Navigation,
        P17Preset::Cylinder,
        P17Preset::Wall,
        P17Preset::Wall3d,
        P17Preset::GapFormation,
        P17Preset::Forest,
        P17Preset::Forest9,
        P17Preset::Deployment,
        P17Preset::LocalizationError,
    ];

    /// The default preset (see the module doc).
    pub const DEFAULT: P17Preset = P17Preset::Forest9;

    /// The name a scenario uses.
    pub fn name(self) -> &'static str {
        match self {
            P17Preset::Boids => "boids",
            P17Preset::Boids7 => "boids_7",
            P17Preset::Navigation => "navigation",
            P17Preset::Cylinder => "cylinder",
            P17Preset::Wall => "wall",
            P17Preset::Wall3d => "wall_3d",
            P17Preset::GapFormation => "gap_formation",
            P17Preset::Forest => "forest",
            P17Preset::Forest9 => "forest_9",
            P17Preset::Deployment => "deployment",
            P17Preset::LocalizationError => "localization_error",
        }
    }

    /// The preset of that name, if any.
    pub fn from_name(name: &str) -> Option<P17Preset> {
        P17Preset::ALL.into_iter().find(|p| p.name() == name)
    }

    /// The values of this preset (Table 1 row, Table 2 or section 6.1; an "X" is filled from
    /// `forest_9`).
    pub fn values(self) -> P17Values {
        // seed 001 Table 1, Fig. 52 and 54 (no X in this row); section 4.4: 5 Hz, 0.75 m.
        let forest_9 = P17Values {
            r: 7.5,
            k1: 14.0,
            k2: 25.0,
            c1: 0.15,
            c2: 0.9,
            d: 8.0,
            w: 4.0,
            b1: 10.0,
            b2: 4.0,
            loop_rate_hz: 5.0,
            loop_distance_m: 0.75,
            obstacle_barrier: true,
            obstacle_margin_m: 0.8,
        };
        let x = forest_9;
        match self {
            // seed 001 Table 1, Fig. 28/29/35: r 10, k1 10, d 4, b1 10, b2 4 (k2, c1, c2, w: X).
            P17Preset::Boids => P17Values { r: 10.0, k1: 10.0, d: 4.0, ..x },
            // seed 001 Table 1, Fig. 33: r 15, k1 10, d 8, b1 10, b2 4 (k2, c1, c2, w: X).
            P17Preset::Boids7 => P17Values { r: 15.0, k1: 10.0, d: 8.0, ..x },
            // seed 001 Table 1, Fig. 36/38: r 15, k1 10, c1 0.25, c2 1.15, d 8 (k2, w: X).
            P17Preset::Navigation => P17Values { r: 15.0, k1: 10.0, c1: 0.25, c2: 1.15, d: 8.0, ..x },
            // seed 001 Table 1, Fig. 40/41/44/45: r 10, k1 12.5, k2 15, c1 0.25, c2 1.15, d 8, w 6.
            P17Preset::Cylinder => P17Values { r: 10.0, k1: 12.5, k2: 15.0, c1: 0.25, c2: 1.15, d: 8.0, w: 6.0, ..x },
            // seed 001 Table 1, Fig. 42: r 10, k1 15, k2 12.5, c1 0.15, c2 1.05, d 8, w 6.
            P17Preset::Wall => P17Values { r: 10.0, k1: 15.0, k2: 12.5, c1: 0.15, c2: 1.05, d: 8.0, w: 6.0, ..x },
            // seed 001 Table 1, Fig. 43: r 15, k1 10, k2 17.5, c1 0.15, c2 1.05, d 8, w 8.
            P17Preset::Wall3d => P17Values { r: 15.0, k1: 10.0, k2: 17.5, c1: 0.15, c2: 1.05, d: 8.0, w: 8.0, ..x },
            // seed 001 Table 1, Fig. 46: r 10, k1 10, k2 17.5, c1 0.25, c2 1.15, d 8, w 6.
            P17Preset::GapFormation => {
                P17Values { r: 10.0, k1: 10.0, k2: 17.5, c1: 0.25, c2: 1.15, d: 8.0, w: 6.0, ..x }
            }
            // seed 001 Table 1, Fig. 48–51: r 10, k1 10, k2 12.5, c1 0.15, c2 1.05, d 8, w 6.
            P17Preset::Forest => P17Values { r: 10.0, k1: 10.0, k2: 12.5, c1: 0.15, c2: 1.05, d: 8.0, w: 6.0, ..x },
            P17Preset::Forest9 => forest_9,
            // seed 001 Table 2: r 15, k1 13.5, k2 16, c1 0.2, c2 0, d 8, w 8, b1 10 (b2: X).
            P17Preset::Deployment => {
                P17Values { r: 15.0, k1: 13.5, k2: 16.0, c1: 0.2, c2: 0.0, d: 8.0, w: 8.0, b1: 10.0, ..x }
            }
            // seed 001 section 6.1: d = w = 8 m, loop rate 30 Hz, loop distance 2 m.
            P17Preset::LocalizationError => P17Values { d: 8.0, w: 8.0, loop_rate_hz: 30.0, loop_distance_m: 2.0, ..x },
        }
    }
}

/// The resolved P17 numbers (preset + overrides), as the controller uses them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct P17Values {
    /// Localization radius r [m]: neighbours and obstacles farther away are not seen (seed 001
    /// section 1.2, 6.2).
    pub r: f64,
    /// Separation steepness k1 [-] (eq. 7).
    pub k1: f64,
    /// Obstacle-separation steepness k2 [-] (eq. 29).
    pub k2: f64,
    /// Navigation position gain c1 [-] (eq. 38–39).
    pub c1: f64,
    /// Navigation velocity gain c2 [-] (eq. 38–39).
    pub c2: f64,
    /// Separation range d [m] (eq. 7).
    pub d: f64,
    /// Obstacle-separation range w [m] (eq. 29).
    pub w: f64,
    /// Cylinder β-agent velocity weight b1 [-] (eq. 19).
    pub b1: f64,
    /// Wall β-agent velocity weight b2 [-] (eq. 25).
    pub b2: f64,
    /// Loop rate [Hz] (section 3.5, 4.4).
    pub loop_rate_hz: f64,
    /// Loop distance: the longest move of one loop [m] (section 3.5, Algorithm 1).
    pub loop_distance_m: f64,
    /// Obstacle separation as a barrier: σ_j along the unit vector from the β-agent (Fig. 22);
    /// `false`: eq. 28 as typeset, σ_j (p0 − p_qj). See the module doc.
    pub obstacle_barrier: bool,
    /// Within this distance of an obstacle's border [m], the velocity loses its component towards
    /// it (ours, not the seed's; 0: off). See the module doc.
    pub obstacle_margin_m: f64,
}

/// P17 parameters as a scenario writes them: a preset and optional overrides of single values.
/// Every value left out is the preset's.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct P17Params {
    /// Parameter set of seed 001 (see [`P17Preset`] for the names); default `forest_9`.
    #[serde(default = "d_preset")]
    pub preset: String,
    /// Override of the localization radius r [m] (seed 001 Tables 1–2).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub r: Option<f64>,
    /// Override of the separation steepness k1 [-] (seed 001 eq. 7, Tables 1–2).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub k1: Option<f64>,
    /// Override of the obstacle-separation steepness k2 [-] (seed 001 eq. 29, Tables 1–2).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub k2: Option<f64>,
    /// Override of the navigation position gain c1 [-] (seed 001 eq. 38–39, Tables 1–2).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub c1: Option<f64>,
    /// Override of the navigation velocity gain c2 [-] (seed 001 eq. 38–39, Tables 1–2).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub c2: Option<f64>,
    /// Override of the separation range d [m] (seed 001 eq. 7, Tables 1–2).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub d: Option<f64>,
    /// Override of the obstacle-separation range w [m] (seed 001 eq. 29, Tables 1–2).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub w: Option<f64>,
    /// Override of the cylinder β-agent velocity weight b1 [-] (seed 001 eq. 19, Tables 1–2).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub b1: Option<f64>,
    /// Override of the wall β-agent velocity weight b2 [-] (seed 001 eq. 25, Tables 1–2).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub b2: Option<f64>,
    /// Override of the loop rate [Hz] (seed 001 section 3.5; 5 Hz in section 4.4).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub loop_rate_hz: Option<f64>,
    /// Override of the loop distance [m] (seed 001 section 3.5; 0.75 m in section 4.4).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub loop_distance_m: Option<f64>,
    /// Obstacle separation as a barrier (default `true`; `false`: eq. 28 as typeset). See the
    /// module doc.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub obstacle_barrier: Option<bool>,
    /// Override of the obstacle margin [m] (default 0.8; 0: off). See the module doc.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub obstacle_margin_m: Option<f64>,
}

fn d_preset() -> String {
    P17Preset::DEFAULT.name().to_string()
}

impl Default for P17Params {
    fn default() -> Self {
        P17Params {
            preset: d_preset(),
            r: None,
            k1: None,
            k2: None,
            c1: None,
            c2: None,
            d: None,
            w: None,
            b1: None,
            b2: None,
            loop_rate_hz: None,
            loop_distance_m: None,
            obstacle_barrier: None,
            obstacle_margin_m: None,
        }
    }
}

impl P17Params {
    /// The preset named by `preset`; `None` for an unknown name (which `validate` rejects).
    pub fn preset(&self) -> Option<P17Preset> {
        P17Preset::from_name(&self.preset)
    }

    /// The preset's values with every given override applied. An unknown preset name (rejected
    /// by `validate`) resolves as the default preset.
    pub fn values(&self) -> P17Values {
        let p = self.preset().unwrap_or(P17Preset::DEFAULT).values();
        P17Values {
            r: self.r.unwrap_or(p.r),
            k1: self.k1.unwrap_or(p.k1),
            k2: self.k2.unwrap_or(p.k2),
            c1: self.c1.unwrap_or(p.c1),
            c2: self.c2.unwrap_or(p.c2),
            d: self.d.unwrap_or(p.d),
            w: self.w.unwrap_or(p.w),
            b1: self.b1.unwrap_or(p.b1),
            b2: self.b2.unwrap_or(p.b2),
            loop_rate_hz: self.loop_rate_hz.unwrap_or(p.loop_rate_hz),
            loop_distance_m: self.loop_distance_m.unwrap_or(p.loop_distance_m),
            obstacle_barrier: self.obstacle_barrier.unwrap_or(p.obstacle_barrier),
            obstacle_margin_m: self.obstacle_margin_m.unwrap_or(p.obstacle_margin_m),
        }
    }

    /// Checks the preset name and the ranges of the resolved values (see the module doc).
    pub fn validate(&self, at: &str) -> Result<(), (String, String)> {
        if self.preset().is_none() {
            let known: Vec<&str> = P17Preset::ALL.iter().map(|p| p.name()).collect();
            return Err((
                format!("{at}.preset"),
                format!("unknown preset {:?}; known: {}", self.preset, known.join(", ")),
            ));
        }
        let v = self.values();
        for (name, x) in [
            ("r", v.r),
            ("k1", v.k1),
            ("k2", v.k2),
            ("d", v.d),
            ("w", v.w),
            ("loop_rate_hz", v.loop_rate_hz),
            ("loop_distance_m", v.loop_distance_m),
        ] {
            crate::validate::positive(&format!("{at}.{name}"), x)?;
        }
        for (name, x) in
            [("c1", v.c1), ("c2", v.c2), ("b1", v.b1), ("b2", v.b2), ("obstacle_margin_m", v.obstacle_margin_m)]
        {
            crate::validate::non_negative(&format!("{at}.{name}"), x)?;
        }
        Ok(())
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    fn parse(text: &str) -> P17Params {
        toml::from_str(text).unwrap()
    }

    #[test]
    fn default_is_forest_9_of_table_1() {
        // seed 001 Table 1, Fig. 52/54: r 7.5, k1 14, k2 25, c1 0.15, c2 0.9, d 8, w 4, b1 10,
        // b2 4; section 4.4: 5 Hz, 0.75 m.
        let want = P17Values {
            r: 7.5,
            k1: 14.0,
            k2: 25.0,
            c1: 0.15,
            c2: 0.9,
            d: 8.0,
            w: 4.0,
            b1: 10.0,
            b2: 4.0,
            loop_rate_hz: 5.0,
            loop_distance_m: 0.75,
            obstacle_barrier: true,
            obstacle_margin_m: 0.8,
        };
        assert_eq!(P17Params::default().values(), want);
        assert_eq!(parse("").values(), want);
        assert_eq!(parse("").preset, "forest_9");
        assert!(P17Params::default().validate("controller.p17").is_ok());
    }

    #[test]
    fn presets_are_the_table_rows() {
        // (r, k1, k2, c1, c2, d, w, b1, b2, Hz, m), typed from seed 001 Tables 1 and 2 and
        // section 6.1; an X of the table is the forest_9 value (k2 25, c1 0.15, c2 0.9, w 4, b2 4).
        let rows: [(&str, [f64; 11]); 11] = [
            ("boids", [10.0, 10.0, 25.0, 0.15, 0.9, 4.0, 4.0, 10.0, 4.0, 5.0, 0.75]),
            ("boids_7", [15.0, 10.0, 25.0, 0.15, 0.9, 8.0, 4.0, 10.0, 4.0, 5.0, 0.75]),
            ("navigation", [15.0, 10.0, 25.0, 0.25, 1.15, 8.0, 4.0, 10.0, 4.0, 5.0, 0.75]),
            ("cylinder", [10.0, 12.5, 15.0, 0.25, 1.15, 8.0, 6.0, 10.0, 4.0, 5.0, 0.75]),
            ("wall", [10.0, 15.0, 12.5, 0.15, 1.05, 8.0, 6.0, 10.0, 4.0, 5.0, 0.75]),
            ("wall_3d", [15.0, 10.0, 17.5, 0.15, 1.05, 8.0, 8.0, 10.0, 4.0, 5.0, 0.75]),
            ("gap_formation", [10.0, 10.0, 17.5, 0.25, 1.15, 8.0, 6.0, 10.0, 4.0, 5.0, 0.75]),
            ("forest", [10.0, 10.0, 12.5, 0.15, 1.05, 8.0, 6.0, 10.0, 4.0, 5.0, 0.75]),
            ("forest_9", [7.5, 14.0, 25.0, 0.15, 0.9, 8.0, 4.0, 10.0, 4.0, 5.0, 0.75]),
            ("deployment", [15.0, 13.5, 16.0, 0.2, 0.0, 8.0, 8.0, 10.0, 4.0, 5.0, 0.75]),
            ("localization_error", [7.5, 14.0, 25.0, 0.15, 0.9, 8.0, 8.0, 10.0, 4.0, 30.0, 2.0]),
        ];
        for (name, r) in rows {
            let v = parse(&format!("preset = {name:?}")).values();
            let got = [v.r, v.k1, v.k2, v.c1, v.c2, v.d, v.w, v.b1, v.b2, v.loop_rate_hz, v.loop_distance_m];
            assert_eq!(got, r, "{name}");
            assert_eq!(P17Preset::from_name(name).map(P17Preset::name), Some(name));
        }
        assert_eq!(rows.len(), P17Preset::ALL.len());
    }

    #[test]
    fn preset_plus_override_resolves() {
        // Table 2 with k1 overridden: k1 12 instead of 13.5, everything else Table 2.
        let p = parse("preset = \"deployment\"\nk1 = 12.0\n");
        let v = p.values();
        assert_eq!(v.k1, 12.0);
        assert_eq!((v.r, v.k2, v.c1, v.c2, v.d, v.w), (15.0, 16.0, 0.2, 0.0, 8.0, 8.0));
        assert!(p.validate("controller.p17").is_ok());
        // The lattice set with a faster loop: boids (d 4) at 20 Hz, 0.25 m.
        let v = parse("preset = \"boids\"\nloop_rate_hz = 20.0\nloop_distance_m = 0.25\n").values();
        assert_eq!((v.d, v.k1, v.r, v.loop_rate_hz, v.loop_distance_m), (4.0, 10.0, 10.0, 20.0, 0.25));
        // An override without a preset applies to the default.
        let v = parse("w = 5.5").values();
        assert_eq!((v.w, v.k2, v.r), (5.5, 25.0, 7.5));
        // The barrier reading is on in every preset and can be turned off.
        assert!(P17Preset::ALL.iter().all(|p| p.values().obstacle_barrier));
        assert!(!parse("preset = \"forest\"\nobstacle_barrier = false\n").values().obstacle_barrier);
    }

    #[test]
    fn params_survive_a_toml_round_trip() {
        let p = parse("preset = \"wall\"\nb2 = 2.0\n");
        let text = toml::to_string(&p).unwrap();
        // Only the given fields are written back.
        assert_eq!(text, "preset = \"wall\"\nb2 = 2.0\n");
        assert_eq!(parse(&text).values(), p.values());
    }

    #[test]
    fn unknown_preset_is_rejected_at_its_field() {
        let p = parse("preset = \"jungle\"");
        let (field, msg) = p.validate("controller.p17").unwrap_err();
        assert_eq!(field, "controller.p17.preset");
        assert!(msg.contains("jungle") && msg.contains("forest_9"), "{msg}");
        // values() still gives something defined: the default preset.
        assert_eq!(p.values(), P17Preset::DEFAULT.values());
    }

    #[test]
    fn unknown_field_is_rejected() {
        assert!(toml::from_str::<P17Params>("k3 = 1.0").is_err());
    }

    #[test]
    fn ranges_are_checked() {
        let bad = [
            ("r = 0.0", "r"),
            ("k1 = -1.0", "k1"),
            ("k2 = 0.0", "k2"),
            ("d = -4.0", "d"),
            ("w = nan", "w"),
            ("c1 = -0.1", "c1"),
            ("c2 = -1.0", "c2"),
            ("b1 = -10.0", "b1"),
            ("b2 = inf", "b2"),
            ("loop_rate_hz = 0.0", "loop_rate_hz"),
            ("loop_distance_m = -0.75", "loop_distance_m"),
        ];
        for (text, field) in bad {
            let (f, _) = parse(text).validate("x").unwrap_err();
            assert_eq!(f, format!("x.{field}"), "{text}");
        }
        // Zero is allowed where the seed itself uses it (Table 2: c2 = 0) or it switches a term off.
        for text in ["c1 = 0.0", "c2 = 0.0", "b1 = 0.0", "b2 = 0.0", "d = 9.0"] {
            assert!(parse(text).validate("x").is_ok(), "{text}");
        }
    }
}

//! The checks a parsed scenario passes before anyone sees it, each error naming the dotted
//! field it is about. Serde has checked names and types; these check values and how fields
//! agree (ids in range, starts apart, a hold shorter than the run), and the small checkers
//! (`positive`, `within`, ...) are shared with the parameter modules.

use crate::{
    Failure, FailureKind, IcpParams, Impairment, Informed, K21Params, NetemRule, PerceptionParams, Scenario, TimeMode,
    Timeline, UavId, UavSet,
};

/// What a check finds: nothing, or the dotted path of the bad field and what is wrong with it.
pub(crate) type Check = Result<(), (String, String)>;

pub(crate) fn positive(field: &str, v: f64) -> Check {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err((field.into(), format!("must be a finite number > 0, got {v}")))
    }
}

pub(crate) fn within(field: &str, v: f64, lo: f64, hi: f64) -> Check {
    if v.is_finite() && (lo..=hi).contains(&v) {
        Ok(())
    } else {
        Err((field.into(), format!("must be between {lo} and {hi}, got {v}")))
    }
}

pub(crate) fn non_negative(field: &str, v: f64) -> Check {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err((field.into(), format!("must be a finite number >= 0, got {v}")))
    }
}

pub(crate) fn finite(field: &str, v: &[f64]) -> Check {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err((field.into(), format!("must be finite numbers, got {v:?}")))
    }
}

/// Listed start positions closer than `min_m` put two bodies into one another: refused, naming
/// the UAVs (in list order, the first is UAV 1).
fn apart(field: &str, p: &[[f64; 2]], min_m: f64) -> Check {
    for (i, a) in p.iter().enumerate() {
        for (j, b) in p.iter().enumerate().skip(i + 1) {
            let d = (a[0] - b[0]).hypot(a[1] - b[1]);
            if d < min_m {
                return Err((
                    field.into(),
                    format!(
                        "UAVs {} and {} start {d:.2} m apart, closer than two body radii ({min_m:.2} m)",
                        UavId::from_index(i),
                        UavId::from_index(j)
                    ),
                ));
            }
        }
    }
    Ok(())
}

impl Scenario {
    pub(crate) fn validate(&self) -> Check {
        if self.name.is_empty() || !self.name.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_') {
            return Err(("name".into(), format!("must be non-empty and use only [A-Za-z0-9_-], got {:?}", self.name)));
        }
        self.validate_world()?;
        self.validate_swarm()?;
        self.validate_sensors()?;
        within("time.control_hz", self.time.control_hz, 0.1, 1000.0)?;
        within("time.realtime_factor", self.time.realtime_factor, 1e-3, 1e4)?;
        within("time.startup_timeout_s", self.time.startup_timeout_s, 1e-3, 1e6)?;
        if self.time.tick_timeout_ms == 0 {
            return Err(("time.tick_timeout_ms".into(), "must be > 0".into()));
        }
        if let Some(bad) = self.controller.external.iter().find(|&&i| !i.within(self.count())) {
            return Err(("controller.external".into(), format!("UAV id {bad} is not in 1..={}", self.swarm.count)));
        }
        let ext = &self.controller.external;
        if let Some(twice) = ext.iter().enumerate().find(|(i, id)| ext[..*i].contains(id)).map(|(_, id)| id) {
            return Err(("controller.external".into(), format!("UAV {twice} is listed twice")));
        }
        self.controller.k21.validate("controller.k21")?;
        self.controller.p17.validate("controller.p17")?;
        self.controller.a21.validate("controller.a21")?;
        self.controller.m23.validate("controller.m23")?;
        self.controller.m23.costmap.validate("controller.m23.costmap")?;
        self.localization.uvdar.validate("localization.uvdar")?;
        self.perception.validate()?;
        positive("lost_contact.after_s", self.lost_contact.after_s)?;
        positive("lost_contact.speed_mps", self.lost_contact.speed_mps)?;
        positive("lost_contact.hold_radius_m", self.lost_contact.hold_radius_m)?;
        non_negative("lost_contact.regroup_after_s", self.lost_contact.regroup_after_s)?;
        non_negative("lost_contact.search_after_s", self.lost_contact.search_after_s)?;
        positive("lost_contact.search_distance_m", self.lost_contact.search_distance_m)?;
        if self.lost_contact.max_hops < 2 {
            return Err(("lost_contact.max_hops".into(), "must be at least 2".into()));
        }
        if let Some(r) = self.lost_contact.contact_radius_m {
            positive("lost_contact.contact_radius_m", r)?;
        }
        positive("localization.stale_after_s", self.localization.stale_after_s)?;
        self.localization.icp.validate()?;
        if let Some(e) = &self.localization.broadcast_error {
            non_negative("localization.broadcast_error.delta_a_m", e.delta_a_m)?;
            non_negative("localization.broadcast_error.from_s", e.from_s)?;
            if e.until_s.is_some_and(|u| !(u.is_finite() && u > e.from_s)) {
                return Err(("localization.broadcast_error.until_s".into(), "must be after from_s".into()));
            }
            self.check_uav_set("localization.broadcast_error.uavs", &e.uavs)?;
        }
        if let Some(l) = &self.radio.distance_loss {
            if !(l.from_m.is_finite() && l.from_m >= 0.0 && l.from_m < self.radio.range_m) {
                return Err(("radio.distance_loss.from_m".into(), "must be in [0, radio.range_m)".into()));
            }
            if !(0.0..=1.0).contains(&l.at_range) {
                return Err(("radio.distance_loss.at_range".into(), "must be a probability in [0, 1]".into()));
            }
        }
        self.validate_netem()?;
        self.validate_failures()?;
        self.validate_mission()?;
        self.validate_expect()?;
        positive("end.goal_radius_m", self.end.goal_radius_m)?;
        positive("end.time_limit_s", self.end.time_limit_s)?;
        non_negative("end.hold_s", self.end.hold_s)?;
        if self.end.hold_s >= self.end.time_limit_s {
            return Err((
                "end.hold_s".into(),
                format!(
                    "{} s: must be shorter than end.time_limit_s ({} s), or no run could end with the goal",
                    self.end.hold_s, self.end.time_limit_s
                ),
            ));
        }
        Ok(())
    }

    fn check_uav_set(&self, field: &str, set: &UavSet) -> Check {
        match set {
            UavSet::Ids(ids) => match ids.iter().find(|&&id| !id.within(self.count())) {
                Some(bad) => Err((field.into(), format!("UAV id {bad} is not in 1..={}", self.swarm.count))),
                None => Ok(()),
            },
            UavSet::All(_) => Ok(()),
        }
    }

    fn validate_mission(&self) -> Check {
        for (i, m) in self.mission.iter().enumerate() {
            non_negative(&format!("mission[{i}].at_s"), m.at_s)?;
            finite(&format!("mission[{i}].goal"), &m.goal)?;
            finite(&format!("mission[{i}].velocity_mps"), &m.velocity_mps)?;
            self.check_uav_set(&format!("mission[{i}].uavs"), &m.uavs)?;
        }
        Ok(())
    }

    fn validate_failures(&self) -> Check {
        self.failures.iter().enumerate().try_for_each(|(i, f)| self.check_failure(i, f))
    }

    /// Checks failure number `i` (of the scenario or of a timeline) against this scenario.
    fn check_failure(&self, i: usize, f: &Failure) -> Check {
        non_negative(&format!("failures[{i}].at_s"), f.at_s)?;
        if !f.uav.within(self.count()) {
            return Err((format!("failures[{i}].uav"), format!("UAV id {} is not in 1..={}", f.uav, self.swarm.count)));
        }
        if f.kind.is_link() && self.time.mode != TimeMode::Realtime {
            // Zenoh leases are wall-clock: a stall of sim seconds in lockstep would last a
            // few milliseconds of wall time, or stop the run for a tick timeout per tick.
            return Err((
                format!("failures[{i}].kind"),
                "link faults need time.mode = \"realtime\" (Zenoh leases run on wall time)".into(),
            ));
        }
        Ok(())
    }

    fn validate_netem(&self) -> Check {
        for (i, r) in self.netem.iter().enumerate() {
            self.check_rule(&format!("netem[{i}]."), r)?;
        }
        Ok(())
    }

    /// Checks one netem rule; `at` prefixes the field names (`netem[3].`).
    fn check_rule(&self, at: &str, r: &NetemRule) -> Check {
        non_negative(&format!("{at}at_s"), r.at_s)?;
        self.check_uav_set(&format!("{at}from"), &r.from)?;
        self.check_uav_set(&format!("{at}to"), &r.to)?;
        r.rule.validate().map_err(|e| (format!("{at}rule.{}", e.field), e.reason))?;
        if let Some(p) = &r.partition {
            if r.from != UavSet::default() || r.to != UavSet::default() {
                return Err((
                    format!("{at}partition"),
                    "a partition names its nodes itself: leave `from` and `to` out".into(),
                ));
            }
            let only_hold = Impairment { hold: r.rule.hold, ..Impairment::IDENTITY };
            if r.rule != only_hold {
                return Err((format!("{at}rule"), "with a partition, `rule` may only set `hold`".into()));
            }
            for id in p.nodes() {
                if !id.within(self.count()) {
                    return Err((format!("{at}partition"), format!("UAV id {id} is not in 1..={}", self.swarm.count)));
                }
            }
        }
        Ok(())
    }

    /// Checks a timeline to be added to a running swarm (`swarm netem`) or merged into this
    /// scenario (`--experiment`): ids in range, valid impairments, only freezes among the failures
    /// when `running` (kill and restart are the launcher's). The error names the field.
    pub fn check_timeline(&self, t: &Timeline, running: bool) -> Result<(), String> {
        let check = || -> Check {
            for (i, r) in t.netem.iter().enumerate() {
                self.check_rule(&format!("netem[{i}]."), r)?;
            }
            for (i, f) in t.failures.iter().enumerate() {
                self.check_failure(i, f)?;
                if running && f.kind != FailureKind::Freeze {
                    return Err((
                        format!("failures[{i}].kind"),
                        "only `freeze` can be added to a running swarm".into(),
                    ));
                }
            }
            Ok(())
        };
        check().map_err(|(field, msg)| format!("field `{field}`: {msg}"))
    }

    fn validate_world(&self) -> Check {
        for (i, t) in self.world.trees.iter().enumerate() {
            finite(&format!("world.trees[{i}]"), &[t.x, t.y])?;
            positive(&format!("world.trees[{i}].r"), t.r)?;
        }
        for (i, w) in self.world.walls.iter().enumerate() {
            finite(&format!("world.walls[{i}]"), &[w.x1, w.y1, w.x2, w.y2])?;
            positive(&format!("world.walls[{i}].thickness"), w.thickness)?;
            if (w.x1 - w.x2).hypot(w.y1 - w.y2) < 1e-6 {
                return Err((format!("world.walls[{i}]"), "wall has zero length".into()));
            }
        }
        if let Some(f) = &self.world.forest {
            let r = &f.region;
            finite("world.forest.region", &[r.x_min, r.x_max, r.y_min, r.y_max])?;
            if r.x_min >= r.x_max || r.y_min >= r.y_max {
                return Err(("world.forest.region".into(), "needs x_min < x_max and y_min < y_max".into()));
            }
            positive("world.forest.density_per_100m2", f.density_per_100m2)?;
            non_negative("world.forest.min_spacing_m", f.min_spacing_m)?;
            let [lo, hi] = f.trunk_radius_m;
            if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && lo <= hi) {
                return Err(("world.forest.trunk_radius_m".into(), format!("needs 0 < min <= max, got [{lo}, {hi}]")));
            }
            for (i, c) in f.keep_clear.iter().enumerate() {
                finite(&format!("world.forest.keep_clear[{i}]"), &[c.x, c.y])?;
                positive(&format!("world.forest.keep_clear[{i}].r"), c.r)?;
            }
        }
        Ok(())
    }

    fn validate_swarm(&self) -> Check {
        let s = &self.swarm;
        if s.count == 0 || s.count > 1000 {
            return Err(("swarm.count".into(), format!("must be between 1 and 1000, got {}", s.count)));
        }
        match (&s.start_positions, &s.start_area) {
            (Some(_), Some(_)) => {
                return Err(("swarm.start_positions".into(), "give start_positions or start_area, not both".into()))
            }
            (None, None) => {
                return Err(("swarm".into(), "needs start_positions or start_area".into()));
            }
            (Some(p), None) => {
                if p.len() != s.count as usize {
                    return Err((
                        "swarm.start_positions".into(),
                        format!("has {} entries but swarm.count is {}", p.len(), s.count),
                    ));
                }
                for (i, xy) in p.iter().enumerate() {
                    finite(&format!("swarm.start_positions[{i}]"), xy)?;
                }
                apart("swarm.start_positions", p, 2.0 * self.body.radius_m)?;
            }
            (None, Some(a)) => {
                finite("swarm.start_area.center", &a.center)?;
                positive("swarm.start_area.radius_m", a.radius_m)?;
                positive("swarm.start_area.min_spacing_m", a.min_spacing_m)?;
            }
        }
        finite("swarm.goal", &s.goal)?;
        if let Some(bad) = s.failed.iter().find(|&&i| !i.within(s.count as usize)) {
            return Err(("swarm.failed".into(), format!("UAV id {bad} is not in 1..={}", s.count)));
        }
        if s.failed.len() >= s.count as usize {
            return Err(("swarm.failed".into(), "at least one UAV must have an agent".into()));
        }
        finite("swarm.start_heading_deg", &[s.start_heading_deg])?;
        if let Informed::Ids(ids) = &s.informed {
            if let Some(bad) = ids.iter().find(|&&i| !i.within(s.count as usize)) {
                return Err(("swarm.informed".into(), format!("UAV id {bad} is not in 1..={}", s.count)));
            }
        }
        let b = &self.body;
        positive("body.radius_m", b.radius_m)?;
        positive("body.max_speed_mps", b.max_speed_mps)?;
        positive("body.max_accel_mps2", b.max_accel_mps2)?;
        positive("body.max_yaw_rate_dps", b.max_yaw_rate_dps)?;
        Ok(())
    }

    fn validate_sensors(&self) -> Check {
        let l = &self.lidar;
        if l.beams < 3 || l.beams > 100_000 {
            return Err(("lidar.beams".into(), format!("must be between 3 and 100000, got {}", l.beams)));
        }
        positive("lidar.max_range_m", l.max_range_m)?;
        non_negative("lidar.noise_std_m", l.noise_std_m)?;
        if !(0.0..1.0).contains(&l.dropout) {
            return Err(("lidar.dropout".into(), format!("must be in [0, 1), got {}", l.dropout)));
        }
        positive("radio.range_m", self.radio.range_m)?;
        non_negative("radio.hysteresis_m", self.radio.hysteresis_m)?;
        Ok(())
    }
}

impl K21Params {
    fn validate(&self, at: &str) -> Check {
        for (name, v) in [("kc", self.kc), ("ks", self.ks), ("ko", self.ko), ("kn", self.kn)] {
            non_negative(&format!("{at}.{name}"), v)?;
        }
        non_negative(&format!("{at}.separation_all_around_m"), self.separation_all_around_m)?;
        non_negative(&format!("{at}.barrier_m"), self.barrier_m)?;
        non_negative(&format!("{at}.barrier_surface_m"), self.barrier_surface_m)?;
        non_negative(&format!("{at}.barrier_ramp_m"), self.barrier_ramp_m)?;
        non_negative(&format!("{at}.detour_after_s"), self.detour_after_s)?;
        positive(&format!("{at}.detour_s"), self.detour_s)?;
        if let Some(r) = self.arrival_radius_m {
            non_negative(&format!("{at}.arrival_radius_m"), r)?;
        }
        for (name, v) in [
            ("kf", self.kf),
            ("cohesion_radius_m", self.cohesion_radius_m),
            ("separation_radius_m", self.separation_radius_m),
            ("separation_scale_m", self.separation_scale_m),
            ("avoidance_radius_m", self.avoidance_radius_m),
            ("avoidance_gain_m", self.avoidance_gain_m),
            ("obstacle_near_m", self.obstacle_near_m),
            ("heading_gain", self.heading_gain),
            ("neighbour_radius_m", self.neighbour_radius_m),
        ] {
            positive(&format!("{at}.{name}"), v)?;
        }
        if !(0.0..=180.0).contains(&self.avoidance_ignore_deg) {
            return Err((format!("{at}.avoidance_ignore_deg"), "must be in [0, 180]".into()));
        }
        Ok(())
    }
}

impl IcpParams {
    fn validate(&self) -> Check {
        let at = "localization.icp";
        for (name, v) in [
            ("lambda", self.lambda),
            ("tolerance_m", self.tolerance_m),
            ("grid_spacing_m", self.grid_spacing_m),
            ("match_frmsd", self.match_frmsd),
            ("match_shift_m", self.match_shift_m),
            ("match_turn_deg", self.match_turn_deg),
            ("suspend_s", self.suspend_s),
            ("long_every_s", self.long_every_s),
            ("tight_long_every_s", self.tight_long_every_s),
            ("step_budget_ms", self.step_budget_ms),
        ] {
            positive(&format!("{at}.{name}"), v)?;
        }
        non_negative(&format!("{at}.crowd_full_grids_per_s"), self.crowd_full_grids_per_s)?;
        if self.tight_long_every_s < self.long_every_s {
            return Err((
                format!("{at}.tight_long_every_s"),
                format!(
                    "must be at least long_every_s ({}), got {}: a tight fit is re-checked less often, not more",
                    self.long_every_s, self.tight_long_every_s
                ),
            ));
        }
        if self.max_iterations == 0 || self.max_iterations > 1000 {
            return Err((
                format!("{at}.max_iterations"),
                format!("must be between 1 and 1000, got {}", self.max_iterations),
            ));
        }
        if self.grid_half_cells > 50 {
            return Err((format!("{at}.grid_half_cells"), format!("must be at most 50, got {}", self.grid_half_cells)));
        }
        if self.grid_headings == 0 || self.grid_headings > 360 {
            return Err((
                format!("{at}.grid_headings"),
                format!("must be between 1 and 360, got {}", self.grid_headings),
            ));
        }
        if self.min_points < 3 {
            return Err((
                format!("{at}.min_points"),
                "must be at least 3 (a rigid 2D transform needs 3 points)".into(),
            ));
        }
        Ok(())
    }
}

impl PerceptionParams {
    fn validate(&self) -> Check {
        positive("perception.group_gap_m", self.group_gap_m)?;
        if self.min_points < 3 {
            return Err(("perception.min_points".into(), "must be at least 3 (a circle has 3 unknowns)".into()));
        }
        let [lo, hi] = self.radius_range_m;
        if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && lo <= hi) {
            return Err(("perception.radius_range_m".into(), format!("needs 0 < min <= max, got [{lo}, {hi}]")));
        }
        non_negative("perception.neighbour_match_m", self.neighbour_match_m)?;
        Ok(())
    }
}

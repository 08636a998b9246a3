//! One generated scenario: a [`Case`] holds what the fuzzer draws and the shrinker cuts (the
//! controller and localization, the start positions, the trees, the goal distance, the flight
//! time, the nemesis schedule) and renders into an ordinary [`Scenario`] on the controller's
//! built-in forest scenario, whose tuned parameters it keeps.

use super::envelope::Envelope;
use netem::nemesis::{schedule, Fault, NemesisKind, ScheduleSpec};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use swarm_config::{ControllerKind, LocalizationMode, Scenario, Tree};
use swarm_types::UavId;

/// What `--weaken` turns off, to show the fuzzer finds a broken swarm.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Weaken {
    /// K21's separation off (`ks = 0`, no all-around separation) and cohesion's dead radius,
    /// which alone keeps a K21 swarm about 2.5 m apart, cut to 0.2 m: cohesion pulls neighbours
    /// into each other.
    Separation,
}

/// What the generator may draw.
#[derive(Debug, Clone)]
pub struct Space {
    /// Controllers, each with a built-in forest scenario as its base.
    pub controllers: Vec<ControllerKind>,
    /// Swarm sizes `2..=max_uavs`.
    pub max_uavs: u32,
    /// Nemesis kinds of the schedule.
    pub nemesis: Vec<NemesisKind>,
    /// At most this many faults per case.
    pub max_faults: usize,
    /// The weakening applied to every case.
    pub weaken: Option<Weaken>,
}

/// A generated scenario before rendering.
#[derive(Debug, Clone)]
pub struct Case {
    /// Its index in the fuzz (names its folder and file).
    pub index: usize,
    /// Master seed of the rendered scenario (sensor noise, link streams).
    pub seed: u64,
    /// The controller.
    pub controller: ControllerKind,
    /// The localization mode.
    pub localization: LocalizationMode,
    /// Start positions, one per UAV (id = index + 1).
    pub starts: Vec<[f64; 2]>,
    /// The trees.
    pub trees: Vec<Tree>,
    /// The goal is `(goal_x_m, 0)`.
    pub goal_x_m: f64,
    /// Sim-time limit [s].
    pub time_limit_s: f64,
    /// The nemesis schedule.
    pub faults: Vec<Fault>,
    /// The weakening.
    pub weaken: Option<Weaken>,
}

/// The built-in forest scenario a controller's cases start from (a registered controller's:
/// forest-5, as K21's).
pub fn base_name(kind: &ControllerKind) -> &'static str {
    match kind {
        ControllerKind::P17 => "p17-error-forest",
        ControllerKind::A21 => "a21-forest-uvdar",
        ControllerKind::M23 => "m23-indoor-none",
        ControllerKind::K21 | ControllerKind::Own(_) => "forest-5",
    }
}

/// Localization modes a controller flies with in its built-in scenarios.
fn modes(kind: &ControllerKind) -> &'static [LocalizationMode] {
    match kind {
        ControllerKind::P17 | ControllerKind::M23 => &[LocalizationMode::Broadcast],
        ControllerKind::A21 => &[LocalizationMode::Uvdar, LocalizationMode::Broadcast],
        ControllerKind::K21 | ControllerKind::Own(_) => &[LocalizationMode::Broadcast, LocalizationMode::Icp],
    }
}

/// Start positions in a disc around the origin, at least `spacing_m` apart (rejection sampling).
fn starts(rng: &mut ChaCha8Rng, n: u32, spacing_m: f64) -> Vec<[f64; 2]> {
    let radius = spacing_m * f64::from(n).sqrt() + 1.0;
    let mut out: Vec<[f64; 2]> = Vec::new();
    while out.len() < n as usize {
        let (r, a) = (radius * rng.gen::<f64>().sqrt(), rng.gen_range(0.0..std::f64::consts::TAU));
        let p = [-r * a.cos(), r * a.sin()];
        if out.iter().all(|q| (q[0] - p[0]).hypot(q[1] - p[1]) >= spacing_m) {
            out.push([(p[0] * 100.0).round() / 100.0, (p[1] * 100.0).round() / 100.0]);
        }
    }
    out
}

/// A forest between the start disc and the goal: density (up to `max_density_per_100m2`) and
/// band width drawn, trees at least 2.5 m apart and clear of the start disc and the goal.
fn forest(rng: &mut ChaCha8Rng, goal_x_m: f64, start_r_m: f64, max_density_per_100m2: f64) -> Vec<Tree> {
    let density = rng.gen_range(0.0..max_density_per_100m2) / 100.0;
    let half_width = rng.gen_range(6.0..14.0);
    let (x0, x1) = (start_r_m + 2.0, goal_x_m - 2.0);
    let target = (density * (x1 - x0) * 2.0 * half_width).round() as usize;
    let mut trees: Vec<Tree> = Vec::new();
    for _ in 0..target * 30 {
        if trees.len() >= target {
            break;
        }
        let (x, y, r) = (rng.gen_range(x0..x1), rng.gen_range(-half_width..half_width), rng.gen_range(0.15..0.35));
        let clear = (x.hypot(y) > start_r_m + 2.0) && (x - goal_x_m).hypot(y) > 3.0;
        if clear && trees.iter().all(|t| (t.x - x).hypot(t.y - y) >= 2.5) {
            let c = |v: f64| (v * 100.0).round() / 100.0;
            trees.push(Tree { x: c(x), y: c(y), r: c(r) });
        }
    }
    trees
}

impl Case {
    /// Case `index` of the fuzz, all of it drawn from `seed`.
    pub fn generate(space: &Space, index: usize, seed: u64) -> anyhow::Result<Case> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let controller = space.controllers[rng.gen_range(0..space.controllers.len())].clone();
        let m = modes(&controller);
        let localization = m[rng.gen_range(0..m.len())];
        let n = rng.gen_range(2..=space.max_uavs.max(2));
        let envelope = Envelope::of(&controller);
        let starts = starts(&mut rng, n, envelope.min_start_spacing_m);
        let start_r = starts.iter().map(|p| p[0].hypot(p[1])).fold(0.0, f64::max);
        let goal_x_m = rng.gen_range(20.0..35.0_f64).round();
        let trees = forest(&mut rng, goal_x_m, start_r, envelope.max_density_per_100m2);
        let base = swarm_config::builtin(base_name(&controller))?;
        let base_goal_m = base.swarm.goal[0].hypot(base.swarm.goal[1]).max(1.0);
        let time_limit_s = (base.end.time_limit_s * goal_x_m / base_goal_m).round();
        let spec = ScheduleSpec {
            uavs: n,
            horizon_s: 0.6 * time_limit_s,
            max_faults: space.max_faults,
            duration_s: (2.0, 30.0),
            kinds: space.nemesis.clone(),
        };
        let faults = schedule(rng.gen(), &spec);
        Ok(Case {
            index,
            seed: rng.gen_range(0..1_000_000),
            controller,
            localization,
            starts,
            trees,
            goal_x_m,
            time_limit_s,
            faults,
            weaken: space.weaken,
        })
    }

    /// The number of UAVs.
    pub fn uavs(&self) -> u32 {
        self.starts.len() as u32
    }

    /// `controller/localization`, the row of the summary by controller.
    pub fn row(&self) -> String {
        format!("{}/{}", self.controller.name(), self.localization.name())
    }

    /// A short description for tables.
    pub fn label(&self) -> String {
        format!(
            "{:?}/{:?} {} UAVs {} trees {} faults {:.0} s",
            self.controller,
            self.localization,
            self.uavs(),
            self.trees.len(),
            self.faults.len(),
            self.time_limit_s
        )
        .to_lowercase()
    }

    /// The case as a scenario: its controller's base scenario with the world, the swarm, the
    /// flight time and the nemesis schedule of the case.
    pub fn render(&self) -> anyhow::Result<Scenario> {
        let mut sc = swarm_config::builtin(base_name(&self.controller))?;
        sc.name = format!("fuzz-{}", self.index);
        sc.description = format!("swarm fuzz case {}: {}", self.index, self.label());
        sc.seed = self.seed;
        sc.world.forest = None;
        sc.world.trees = self.trees.clone();
        sc.swarm.count = self.uavs();
        sc.swarm.start_positions = Some(self.starts.clone());
        sc.swarm.start_area = None;
        sc.swarm.goal = [self.goal_x_m, 0.0];
        sc.swarm.failed.clear();
        if let swarm_config::Informed::Ids(ids) = &mut sc.swarm.informed {
            ids.retain(|&id| id.get() <= self.uavs());
            if ids.is_empty() {
                ids.push(UavId::new(1));
            }
        }
        sc.controller.kind = self.controller.clone();
        sc.controller.a21.safety = Envelope::of(&self.controller).a21_safety;
        sc.localization.mode = self.localization;
        sc.end.time_limit_s = self.time_limit_s;
        sc.netem.clear();
        sc.failures.clear();
        sc.mission.clear();
        for f in &self.faults {
            let (rules, failures) = f.render();
            sc.netem.extend(rules);
            sc.failures.extend(failures);
        }
        if self.weaken == Some(Weaken::Separation) {
            sc.controller.k21.ks = 0.0;
            sc.controller.k21.separation_all_around_m = 0.0;
            sc.controller.k21.cohesion_radius_m = 0.2;
        }
        // Through TOML, so the scenario is exactly what a file of it reads as, validated.
        let text = toml::to_string(&sc)?;
        Ok(Scenario::from_toml_str(&text, &sc.name)?)
    }
}

//! Seeded generation of what a scenario leaves to chance: the forest and the start positions.
//!
//! Both use rejection sampling from a ChaCha stream seeded by the scenario, so the same file
//! always gives the same world on every machine.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use swarm_config::{Forest, Scenario, StartArea, Tree};
use swarm_types::UavId;

/// Stream ids mixed into the scenario seed, one per purpose, so adding a draw in one place never
/// shifts the numbers drawn in another.
pub(crate) mod stream {
    /// Forest generation.
    pub const FOREST: u64 = 0x466f_7265_7374;
    /// Start positions.
    pub const START: u64 = 0x0053_7461_7274;
    /// LIDAR noise of UAV `id` is `LIDAR + id`.
    pub const LIDAR: u64 = 0x4c69_6461_7200;
    /// The broadcast-position error of UAV `id` (seed 001 section 6) is `GNSS_ERROR + id`.
    pub const GNSS_ERROR: u64 = 0x476e_7373_4500;
    /// UVDAR noise of UAV `id` is `UVDAR + id`.
    pub const UVDAR: u64 = 0x5556_4441_5200;
}

/// A ChaCha8 stream for `purpose` derived from `seed`.
pub(crate) fn rng(seed: u64, purpose: u64) -> ChaCha8Rng {
    let mut r = ChaCha8Rng::seed_from_u64(seed);
    r.set_stream(purpose);
    r
}

/// The trees of a generated forest. `existing` (explicit trees) are respected by the spacing rule.
pub fn generate_forest(f: &Forest, scenario_seed: u64, existing: &[Tree]) -> Vec<Tree> {
    let mut rng = rng(f.seed.unwrap_or(scenario_seed), stream::FOREST);
    let r = &f.region;
    let area = (r.x_max - r.x_min) * (r.y_max - r.y_min);
    let target = (f.density_per_100m2 * area / 100.0).round() as usize;
    let mut trees: Vec<Tree> = Vec::with_capacity(target);
    let max_attempts = target * 50 + 100;
    for _ in 0..max_attempts {
        if trees.len() >= target {
            break;
        }
        let x = rng.gen_range(r.x_min..=r.x_max);
        let y = rng.gen_range(r.y_min..=r.y_max);
        let radius = rng.gen_range(f.trunk_radius_m[0]..=f.trunk_radius_m[1]);
        let spaced = |t: &Tree| (t.x - x).hypot(t.y - y) >= f.min_spacing_m;
        let clear = f.keep_clear.iter().all(|c| (c.x - x).hypot(c.y - y) >= c.r + radius);
        if clear && trees.iter().all(spaced) && existing.iter().all(spaced) {
            trees.push(Tree { x, y, r: radius });
        }
    }
    trees
}

/// Every tree of the scenario: the explicit ones, then the generated forest.
pub fn scenario_trees(sc: &Scenario) -> Vec<Tree> {
    let mut trees = sc.world.trees.clone();
    if let Some(f) = &sc.world.forest {
        let generated = generate_forest(f, sc.seed, &trees);
        trees.extend(generated);
    }
    trees
}

/// The first UAV whose body would start inside a tree or a wall: `(id, what)`, e.g.
/// `(3, "0.12 m from the tree at (4.00, 5.00), r 0.30 m")`. Checks the listed or drawn starts
/// against every tree, explicit or generated, so a forest drawn over a start area is caught
/// before any process starts. A start touching an obstacle would fly as a collision at tick 0.
pub fn start_in_obstacle(sc: &Scenario) -> Option<(UavId, String)> {
    let world = crate::world::World::new(scenario_trees(sc), sc.world.walls.clone());
    let body = sc.body.radius_m;
    for (i, p) in start_positions(sc).iter().enumerate() {
        let clear = world.clearance(*p);
        if clear >= body {
            continue;
        }
        // The trunk that gives this clearance (none: a wall does).
        let surface = |t: &&Tree| (t.x - p[0]).hypot(t.y - p[1]) - t.r;
        let tree = world
            .trees()
            .iter()
            .filter(|t| surface(t) <= clear + 1e-9)
            .min_by(|a, b| surface(a).total_cmp(&surface(b)));
        let what = match tree {
            Some(t) => format!("{clear:.2} m from the tree at ({:.2}, {:.2}), r {:.2} m", t.x, t.y, t.r),
            None => format!("{clear:.2} m from a wall"),
        };
        return Some((
            UavId::from_index(i),
            format!("starts at ({:.2}, {:.2}), {what}; its body needs {body:.2} m", p[0], p[1]),
        ));
    }
    None
}

/// Start positions of every UAV, index = id − 1.
pub fn start_positions(sc: &Scenario) -> Vec<[f64; 2]> {
    match (&sc.swarm.start_positions, &sc.swarm.start_area) {
        (Some(p), _) => p.clone(),
        (None, Some(a)) => sample_start_area(a, sc.count(), sc.seed),
        (None, None) => vec![[0.0, 0.0]; sc.count()],
    }
}

fn sample_start_area(a: &StartArea, n: usize, seed: u64) -> Vec<[f64; 2]> {
    let mut rng = rng(seed, stream::START);
    let mut out: Vec<[f64; 2]> = Vec::with_capacity(n);
    let mut spacing = a.min_spacing_m;
    while out.len() < n {
        // If the disc is too small for the spacing, relax it rather than loop forever.
        for _ in 0..1000 {
            if out.len() >= n {
                break;
            }
            let rho = a.radius_m * rng.gen::<f64>().sqrt();
            let phi = rng.gen_range(0.0..std::f64::consts::TAU);
            let p = [a.center[0] + rho * phi.cos(), a.center[1] + rho * phi.sin()];
            if out.iter().all(|q| (q[0] - p[0]).hypot(q[1] - p[1]) >= spacing) {
                out.push(p);
            }
        }
        spacing *= 0.9;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use swarm_config::Region;

    fn forest() -> Forest {
        Forest {
            region: Region { x_min: 0.0, x_max: 50.0, y_min: 0.0, y_max: 50.0 },
            density_per_100m2: 4.0,
            min_spacing_m: 2.5,
            trunk_radius_m: [0.1, 0.4],
            seed: None,
            keep_clear: vec![Tree { x: 10.0, y: 10.0, r: 5.0 }],
        }
    }

    #[test]
    fn forest_is_deterministic_and_respects_its_rules() {
        let f = forest();
        let a = generate_forest(&f, 3, &[]);
        let b = generate_forest(&f, 3, &[]);
        assert_eq!(a, b, "same seed, same forest");
        assert_ne!(a, generate_forest(&f, 4, &[]), "another seed, another forest");
        assert_eq!(a.len(), 100, "4 per 100 m² on 2500 m² is reachable at 2.5 m spacing");
        for (i, t) in a.iter().enumerate() {
            assert!((0.1..=0.4).contains(&t.r));
            assert!((t.x - 10.0).hypot(t.y - 10.0) >= 5.0 + t.r, "keep-clear disc respected");
            for u in &a[i + 1..] {
                assert!((t.x - u.x).hypot(t.y - u.y) >= 2.5, "spacing respected");
            }
        }
    }

    #[test]
    fn start_area_is_deterministic_spaced_and_inside() {
        let a = StartArea { center: [1.0, 2.0], radius_m: 3.0, min_spacing_m: 1.5 };
        let p = sample_start_area(&a, 5, 9);
        assert_eq!(p, sample_start_area(&a, 5, 9));
        assert_eq!(p.len(), 5);
        for (i, q) in p.iter().enumerate() {
            assert!((q[0] - 1.0).hypot(q[1] - 2.0) <= 3.0 + 1e-9);
            for r in &p[i + 1..] {
                assert!((q[0] - r[0]).hypot(q[1] - r[1]) >= 1.5);
            }
        }
    }
}

//! The cases of `swarm icp-eval`: pairs of obstacle sets as two UAVs in a forest see them, with
//! the truth of where the second one is. Read from a JSON file, or generated from a seed.
//!
//! Generation (one case, all draws from one ChaCha8 stream seeded by `--seed`, in this order):
//! the source UAV's position, uniform in distance (`distance_m`) and bearing, and its heading,
//! uniform in (−π, π] (the reference UAV sits at the origin, heading 0, so its body frame is the
//! world frame); then a forest of `density_per_100m2` trees on the square of half-side
//! [`HALF_SIDE_M`] around the origin, by rejection sampling with [`MIN_SPACING_M`] between trunks
//! and [`CLEAR_M`] around both UAVs; then, for each UAV in turn and each tree within `range_m`
//! of it, a miss with probability `miss`, else the centre with Gaussian noise σ = `sigma_m` on
//! each coordinate, in that UAV's body frame. Trees only: the neighbour's body and occlusion by
//! trunks are left out (the conditions of issue 14's measurement).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

/// The truth of a case: the source UAV's pose in the reference UAV's body frame [m, rad].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Truth {
    /// Position, x [m].
    pub x: f64,
    /// Position, y [m].
    pub y: f64,
    /// Heading [rad].
    pub heading: f64,
}

/// One pair of views: what the reference UAV sees, what the source UAV sees (each in its own body
/// frame) [m], and the truth.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Case {
    /// Obstacle centres seen by the reference UAV [m].
    pub reference: Vec<[f64; 2]>,
    /// Obstacle centres seen by the source UAV [m].
    pub source: Vec<[f64; 2]>,
    /// The source UAV's pose in the reference UAV's frame.
    pub truth: Truth,
}

/// Two views share a tree when a source point, put into the reference frame by the truth, lies
/// this close to a reference point [m] (noise is centimetres, trunks metres apart).
pub const SHARED_TOL_M: f64 = 0.25;

impl Case {
    /// Trees both UAVs saw: source points within [`SHARED_TOL_M`] of a reference point once
    /// placed by the truth, `p_R = Rot(heading) p_S + (x, y)`.
    pub fn shared(&self) -> usize {
        let (s, c) = self.truth.heading.sin_cos();
        self.source
            .iter()
            .map(|p| [c * p[0] - s * p[1] + self.truth.x, s * p[0] + c * p[1] + self.truth.y])
            .filter(|q| self.reference.iter().any(|r| (r[0] - q[0]).hypot(r[1] - q[1]) <= SHARED_TOL_M))
            .count()
    }
}

/// How cases are generated (defaults: issue 14's measurement).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Views {
    /// Tree density [trees per 100 m²].
    pub density_per_100m2: f64,
    /// A UAV sees a tree centre within this distance [m].
    pub range_m: f64,
    /// Probability that a UAV misses a tree in range.
    pub miss: f64,
    /// Noise on each coordinate of a seen centre [m].
    pub sigma_m: f64,
    /// Distance between the UAVs, drawn uniformly in [lo, hi] [m].
    pub distance_m: (f64, f64),
}

impl Default for Views {
    fn default() -> Self {
        Views { density_per_100m2: 5.0, range_m: 8.0, miss: 0.1, sigma_m: 0.03, distance_m: (1.0, 5.0) }
    }
}

/// Half-side of the square forest around the reference UAV [m]: both UAVs' ranges inside it.
pub const HALF_SIDE_M: f64 = 15.0;

/// Least distance between two trunk centres [m].
pub const MIN_SPACING_M: f64 = 2.0;

/// No trunk centre this close to a UAV [m].
pub const CLEAR_M: f64 = 1.0;

/// `n` cases from `seed`.
pub fn generate(seed: u64, n: usize, v: &Views) -> Vec<Case> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n).map(|_| one(&mut rng, v)).collect()
}

fn one(rng: &mut ChaCha8Rng, v: &Views) -> Case {
    let d = rng.gen_range(v.distance_m.0..=v.distance_m.1);
    let bearing = rng.gen_range(-std::f64::consts::PI..std::f64::consts::PI);
    let heading = rng.gen_range(-std::f64::consts::PI..std::f64::consts::PI);
    let truth = Truth { x: d * bearing.cos(), y: d * bearing.sin(), heading };
    let trees = forest(rng, v.density_per_100m2, &[[0.0, 0.0], [truth.x, truth.y]]);
    let reference = view(rng, v, &trees, &Truth { x: 0.0, y: 0.0, heading: 0.0 });
    let source = view(rng, v, &trees, &truth);
    Case { reference, source, truth }
}

/// Tree centres on the square, at least [`MIN_SPACING_M`] apart and [`CLEAR_M`] from `uavs`; as
/// many as the density asks, or as rejection sampling finds in a bounded number of tries.
fn forest(rng: &mut ChaCha8Rng, density_per_100m2: f64, uavs: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let side = 2.0 * HALF_SIDE_M;
    let want = (density_per_100m2 * side * side / 100.0).round() as usize;
    let mut trees: Vec<[f64; 2]> = Vec::with_capacity(want);
    let far = |p: &[f64; 2], q: &[f64; 2], r: f64| (p[0] - q[0]).hypot(p[1] - q[1]) >= r;
    for _ in 0..want * 200 {
        if trees.len() == want {
            break;
        }
        let p = [rng.gen_range(-HALF_SIDE_M..HALF_SIDE_M), rng.gen_range(-HALF_SIDE_M..HALF_SIDE_M)];
        if trees.iter().all(|t| far(t, &p, MIN_SPACING_M)) && uavs.iter().all(|u| far(u, &p, CLEAR_M)) {
            trees.push(p);
        }
    }
    trees
}

/// What a UAV at `pose` sees: each tree within range, unless missed, with noise, in its body
/// frame `p_B = Rot(−heading) (p_W − position)`.
fn view(rng: &mut ChaCha8Rng, v: &Views, trees: &[[f64; 2]], pose: &Truth) -> Vec<[f64; 2]> {
    let noise = Normal::new(0.0, v.sigma_m.max(0.0)).unwrap_or_else(|_| Normal::new(0.0, 0.0).expect("σ = 0 is valid"));
    let (s, c) = pose.heading.sin_cos();
    let mut seen = Vec::new();
    for t in trees {
        let (dx, dy) = (t[0] - pose.x, t[1] - pose.y);
        if dx.hypot(dy) > v.range_m || rng.gen::<f64>() < v.miss {
            continue;
        }
        let (nx, ny) = (noise.sample(rng), noise.sample(rng));
        seen.push([c * dx + s * dy + nx, -s * dx + c * dy + ny]);
    }
    seen
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn generated_views_agree_with_their_truth() {
        let v = Views { sigma_m: 0.0, miss: 0.0, ..Views::default() };
        let cases = generate(7, 20, &v);
        assert_eq!(cases, generate(7, 20, &v), "a seed gives the same cases");
        for c in &cases {
            let d = c.truth.x.hypot(c.truth.y);
            assert!((1.0..=5.0).contains(&d), "{d}");
            assert!(c.reference.iter().chain(&c.source).all(|p| p[0].hypot(p[1]) <= 8.0 + 1e-9));
            // Noise-free and nothing missed: every source tree within range of the reference
            // UAV is shared.
            let (s, k) = c.truth.heading.sin_cos();
            let in_ref_range = c
                .source
                .iter()
                .filter(|p| (k * p[0] - s * p[1] + c.truth.x).hypot(s * p[0] + k * p[1] + c.truth.y) <= 8.0)
                .count();
            assert_eq!(c.shared(), in_ref_range);
        }
        let mean_seen = cases.iter().map(|c| c.reference.len()).sum::<usize>() as f64 / cases.len() as f64;
        // 5 trees / 100 m² over π·8² ≈ 201 m²: about 10 trees in range.
        assert!((6.0..=13.0).contains(&mean_seen), "{mean_seen}");
    }
}

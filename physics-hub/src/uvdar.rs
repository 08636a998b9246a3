//! Onboard relative sensing (seed 003 UVDAR, SPEC §3): what one UAV's ultraviolet cameras see
//! of its neighbours — the id of each visible neighbour (UVDAR's markers blink an id) with a
//! noisy range and bearing in the observer's body frame.
//!
//! This module exists because the `uvdar` localization mode needs no communication at all
//! (seed 003 abstract, V-A, V-B): only the hub, the holder of ground truth, can say which
//! neighbours a camera sees. It is pure: the world, the poses, the parameters and the RNG come
//! in as parameters, and the same RNG state always gives the same observations.
//!
//! Seed 003 gives no sensor model beyond "the UAVs would also get occluded by nearby trees and
//! other agents" (V-B). Choices made where it is silent (the parameter defaults and their
//! reasons are in `swarm_config::UvdarParams`):
//! - a neighbour is seen when its centre is within `max_range_m` (inclusive) and within
//!   ±`fov_deg`/2 of the heading, and the segment from the observer's centre to the target's
//!   centre crosses no tree or wall (if `occluded_by_obstacles`) and no other UAV's disc of
//!   radius `uav_radius_m` (if `occluded_by_uavs`) — one line of sight to the centre, no
//!   partial visibility;
//! - like the LIDAR, obstacles are solid: an observer inside a tree, wall or other UAV sees
//!   nothing through it; a neighbour at exactly the observer's position (bearing undefined) is
//!   not reported;
//! - range noise is relative, σ_r = `range_noise_rel` · d, the measured range clamped to ≥ 0;
//!   bearing noise is absolute, σ_b = `bearing_noise_deg`, the result wrapped to (−π, π];
//! - each visible neighbour is detected with probability `detection_probability`,
//!   independently per observation;
//! - a UAV never observes itself (its index, or any entry carrying its id).
//!
//! RNG draw order: for every entry of `poses` in order whose id is not the observer's, whatever
//! the geometry: one uniform `f64` if `detection_probability < 1`, then one standard normal for
//! the range if `range_noise_rel > 0`, then one for the bearing if `bearing_noise_deg > 0`. So
//! the stream an observation consumes depends only on the number of neighbours and the
//! parameters: a neighbour disappearing behind a tree does not change the noise drawn for the
//! others.

use crate::body::wrap_angle;
use crate::world::{ray_circle, World};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use swarm_config::UvdarParams;
use swarm_types::UavId;

/// One neighbour as the observer's cameras see it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Observation {
    /// The neighbour's id, decoded from its blinking markers.
    pub id: UavId,
    /// Measured distance between the centres [m], ≥ 0.
    pub range_m: f64,
    /// Measured bearing in the observer's body frame: counter-clockwise from its heading [rad],
    /// in (−π, π].
    pub bearing_rad: f64,
}

/// What the UAV at `poses[observer]` sees of the others: every UAV within range and field of
/// view whose line of sight is not blocked, detected with the configured probability, with
/// range and bearing noise.
///
/// `poses` holds `(id, position in the world [m], yaw [rad])` of every UAV, the observer
/// included. Returns the observations in `poses` order; empty when `observer` is out of bounds
/// or its pose is not finite. Entries with a non-finite pose are never seen, never occlude, and
/// still consume their draws (see the module docs for the draw order).
pub fn observe(
    world: &World,
    observer: usize,
    poses: &[(UavId, [f64; 2], f64)],
    params: &UvdarParams,
    rng: &mut ChaCha8Rng,
) -> Vec<Observation> {
    let Some(&(self_id, origin, yaw)) = poses.get(observer) else {
        return Vec::new();
    };
    let eye = Eye { index: observer, origin, yaw };
    let eye_ok = origin.iter().all(|v| v.is_finite()) && yaw.is_finite();
    let mut out = Vec::new();
    for (j, &(id, _, _)) in poses.iter().enumerate() {
        if j == observer || id == self_id {
            continue; // a UAV never observes itself, and draws nothing for itself
        }
        let draws = draw(params, rng);
        if !eye_ok || !draws.detected {
            continue;
        }
        if let Some(truth) = sight(world, poses, &eye, j, params) {
            out.push(measure(id, truth, &draws, params));
        }
    }
    out
}

/// The observer: its index in `poses` and its (finite) pose.
struct Eye {
    /// Index of the observer in `poses`.
    index: usize,
    /// Position in the world [m].
    origin: [f64; 2],
    /// Heading [rad].
    yaw: f64,
}

/// The random part of one observation, drawn whatever the geometry.
struct Draws {
    /// The uniform draw fell below the detection probability.
    detected: bool,
    /// Standard normal for the range (0 when range noise is off).
    n_range: f64,
    /// Standard normal for the bearing (0 when bearing noise is off).
    n_bearing: f64,
}

/// Draws in the documented order: uniform, range normal, bearing normal, each only when used.
fn draw(params: &UvdarParams, rng: &mut ChaCha8Rng) -> Draws {
    let p = params.detection_probability;
    // NaN or ≥ 1: always detected, no draw.
    let detected = if p < 1.0 { rng.gen::<f64>() < p } else { true };
    let n_range = if params.range_noise_rel > 0.0 { rng.sample::<f64, _>(StandardNormal) } else { 0.0 };
    let n_bearing = if params.bearing_noise_deg > 0.0 { rng.sample::<f64, _>(StandardNormal) } else { 0.0 };
    Draws { detected, n_range, n_bearing }
}

/// The true geometry of one observation.
#[derive(Debug, Clone, Copy)]
struct Truth {
    /// Distance between the centres [m], > 0.
    range_m: f64,
    /// Bearing in the observer's body frame [rad], in (−π, π].
    bearing_rad: f64,
}

/// True range and bearing of `poses[target]` if the observer can see it: in range, in the field
/// of view and not occluded (choices, seed 003 silent except V-B on occlusion; see module docs).
fn sight(
    world: &World,
    poses: &[(UavId, [f64; 2], f64)],
    eye: &Eye,
    target: usize,
    params: &UvdarParams,
) -> Option<Truth> {
    let (_, t, _) = *poses.get(target)?;
    let (dx, dy) = (t[0] - eye.origin[0], t[1] - eye.origin[1]);
    // Euclidean distance and body-frame bearing: plain plane geometry (SPEC §2, yaw CCW from x).
    let range_m = dx.hypot(dy);
    if !range_m.is_finite() || range_m <= 0.0 || range_m > params.max_range_m {
        return None;
    }
    let bearing_rad = wrap_angle(dy.atan2(dx) - eye.yaw);
    let half_fov = 0.5 * params.fov_deg.to_radians();
    if bearing_rad.abs() > half_fov {
        return None;
    }
    let dir = [dx / range_m, dy / range_m];
    // Seed 003 V-B: "occluded by nearby trees and other agents".
    if params.occluded_by_obstacles && world.cast_ray(eye.origin, dir, range_m).is_some() {
        return None;
    }
    if params.occluded_by_uavs && blocked_by_uav(poses, eye, target, dir, range_m, params) {
        return None;
    }
    Some(Truth { range_m, bearing_rad })
}

/// Whether another UAV's disc (neither the observer's nor the target's) meets the line of sight
/// `eye.origin + t·dir` before the target's centre, at t < `range_m`.
fn blocked_by_uav(
    poses: &[(UavId, [f64; 2], f64)],
    eye: &Eye,
    target: usize,
    dir: [f64; 2],
    range_m: f64,
    params: &UvdarParams,
) -> bool {
    let r = params.uav_radius_m.max(0.0);
    poses.iter().enumerate().any(|(k, &(_, c, _))| {
        k != eye.index
            && k != target
            && c.iter().all(|v| v.is_finite())
            && ray_circle(eye.origin, dir, c, r).is_some_and(|t| t < range_m)
    })
}

/// Applies the noise to the true geometry (choice, seed 003 silent; see module docs):
/// range = d + range_noise_rel · d · n_r, clamped to ≥ 0; bearing = wrap(b + σ_b · n_b).
fn measure(id: UavId, truth: Truth, draws: &Draws, params: &UvdarParams) -> Observation {
    let sigma_range_m = params.range_noise_rel * truth.range_m;
    let sigma_bearing_rad = params.bearing_noise_deg.to_radians();
    Observation {
        id,
        range_m: (truth.range_m + sigma_range_m * draws.n_range).max(0.0),
        bearing_rad: wrap_angle(truth.bearing_rad + sigma_bearing_rad * draws.n_bearing),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::tests::{tree, wall};
    use proptest::prelude::*;
    use rand::{Rng, SeedableRng};
    use std::f64::consts::{FRAC_PI_2, PI};

    /// Noise-free, always-detecting parameters (occlusion on, as by default).
    fn exact() -> UvdarParams {
        UvdarParams {
            range_noise_rel: 0.0,
            bearing_noise_deg: 0.0,
            detection_probability: 1.0,
            ..UvdarParams::default()
        }
    }

    fn rng(seed: u64) -> ChaCha8Rng {
        ChaCha8Rng::seed_from_u64(seed)
    }

    fn open() -> World {
        World::new(vec![], vec![])
    }

    /// `poses` with their ids typed.
    fn typed(poses: &[(u32, [f64; 2], f64)]) -> Vec<(UavId, [f64; 2], f64)> {
        poses.iter().map(|&(id, p, yaw)| (UavId::new(id), p, yaw)).collect()
    }

    /// The ids seen by UAV 0 in `poses`.
    fn ids_seen(world: &World, poses: &[(u32, [f64; 2], f64)], p: &UvdarParams) -> Vec<u32> {
        observe(world, 0, &typed(poses), p, &mut rng(1)).iter().map(|o| o.id.get()).collect()
    }

    #[test]
    fn target_in_the_open_is_seen_at_the_true_range_and_bearing() {
        // Observer at (1, 2) heading +y (yaw π/2); target at (4, 6): offset (3, 4), d = 5.
        // World angle atan2(4, 3) = 0.927295; body bearing 0.927295 − π/2 = −0.643501
        // (= −atan2(3, 4): the target is 36.87° to the right of the heading).
        let poses = [(7, [1.0, 2.0], FRAC_PI_2), (9, [4.0, 6.0], 0.3)];
        let obs = observe(&open(), 0, &typed(&poses), &exact(), &mut rng(1));
        assert_eq!(obs.len(), 1);
        assert_eq!(obs[0].id, UavId::new(9));
        assert!((obs[0].range_m - 5.0).abs() < 1e-12, "{obs:?}");
        assert!((obs[0].bearing_rad + 3.0f64.atan2(4.0)).abs() < 1e-12, "{obs:?}");
        assert!((obs[0].bearing_rad + 0.643_501_108_793_284_4).abs() < 1e-12);
        // And the other way: from (4, 6) at yaw 0.3, the observer is at world angle
        // atan2(−4, −3) = −(π − 0.927295) = −2.214297, body bearing −2.214297 − 0.3 = −2.514297.
        let back = observe(&open(), 1, &typed(&poses), &exact(), &mut rng(1));
        assert_eq!(back.len(), 1);
        assert_eq!(back[0].id, UavId::new(7));
        assert!((back[0].range_m - 5.0).abs() < 1e-12);
        assert!((back[0].bearing_rad - ((-4.0f64).atan2(-3.0) - 0.3)).abs() < 1e-12);
        assert!((back[0].bearing_rad + 2.514_297_435_588_181).abs() < 1e-9);
    }

    #[test]
    fn target_behind_a_tree_or_wall_is_not_seen() {
        // Observer (0, 0), target (6, 0). A trunk at (3, 0) r 0.3 straddles the line of sight.
        let poses = [(0, [0.0, 0.0], 0.0), (1, [6.0, 0.0], 0.0)];
        let behind = World::new(vec![tree(3.0, 0.0, 0.3)], vec![]);
        assert_eq!(ids_seen(&behind, &poses, &exact()), Vec::<u32>::new());
        // The same trunk 0.5 m off the line (clearance 0.5 − 0.3 = 0.2 m) hides nothing.
        let beside = World::new(vec![tree(3.0, 0.5, 0.3)], vec![]);
        assert_eq!(ids_seen(&beside, &poses, &exact()), vec![1]);
        // A tree beyond the target (centre 7 > 6 + 0.3) hides nothing either.
        let beyond = World::new(vec![tree(7.0, 0.0, 0.3)], vec![]);
        assert_eq!(ids_seen(&beyond, &poses, &exact()), vec![1]);
        // A wall across the line, from (2, −1) to (2, 1), blocks.
        let walled = World::new(vec![], vec![wall(2.0, -1.0, 2.0, 1.0, 0.1)]);
        assert_eq!(ids_seen(&walled, &poses, &exact()), Vec::<u32>::new());
        // With obstacle occlusion switched off, both are seen through.
        let through = UvdarParams { occluded_by_obstacles: false, ..exact() };
        assert_eq!(ids_seen(&behind, &poses, &through), vec![1]);
        assert_eq!(ids_seen(&walled, &poses, &through), vec![1]);
    }

    #[test]
    fn a_uav_in_the_line_of_sight_hides_the_one_behind_it() {
        // Observer (0, 0); UAV 1 at (3, 0) in front of UAV 2 at (6, 0); radius 0.3.
        let poses = [(0, [0.0, 0.0], 0.0), (1, [3.0, 0.0], 0.0), (2, [6.0, 0.0], 0.0)];
        assert_eq!(ids_seen(&open(), &poses, &exact()), vec![1]);
        let through = UvdarParams { occluded_by_uavs: false, ..exact() };
        assert_eq!(ids_seen(&open(), &poses, &through), vec![1, 2]);
        // UAV 1 moved 0.4 m off the line: 0.4 > r = 0.3, both seen.
        let off = [(0, [0.0, 0.0], 0.0), (1, [3.0, 0.4], 0.0), (2, [6.0, 0.0], 0.0)];
        assert_eq!(ids_seen(&open(), &off, &exact()), vec![1, 2]);
        // ... but 0.2 m off the line (< 0.3) it still hides UAV 2.
        let near = [(0, [0.0, 0.0], 0.0), (1, [3.0, 0.2], 0.0), (2, [6.0, 0.0], 0.0)];
        assert_eq!(ids_seen(&open(), &near, &exact()), vec![1]);
    }

    #[test]
    fn out_of_range_is_not_seen_and_the_range_limit_is_inclusive() {
        // Default max range 8 m (seed 003 Table I d_max): 7.99 and 8.0 seen, 8.01 not.
        let at = |x: f64| [(0, [0.0, 0.0], 0.0), (1, [x, 0.0], 0.0)];
        assert_eq!(ids_seen(&open(), &at(7.99), &exact()), vec![1]);
        assert_eq!(ids_seen(&open(), &at(8.0), &exact()), vec![1]);
        assert_eq!(ids_seen(&open(), &at(8.01), &exact()), Vec::<u32>::new());
        // Diagonal: (5.6, 5.6) is 7.92 m away, (5.7, 5.7) is 8.06 m.
        let diag = |v: f64| [(0, [0.0, 0.0], 0.0), (1, [v, v], 0.0)];
        assert_eq!(ids_seen(&open(), &diag(5.6), &exact()), vec![1]);
        assert_eq!(ids_seen(&open(), &diag(5.7), &exact()), Vec::<u32>::new());
    }

    #[test]
    fn out_of_the_field_of_view_is_not_seen() {
        // A 90° view centred on yaw = π (heading −x): bearings within ±45° are seen.
        let p = UvdarParams { fov_deg: 90.0, ..exact() };
        let at_bearing = |deg: f64| {
            let a = PI + deg.to_radians(); // world angle of a target at body bearing `deg`
            [(0, [0.0, 0.0], PI), (1, [5.0 * a.cos(), 5.0 * a.sin()], 0.0)]
        };
        assert_eq!(ids_seen(&open(), &at_bearing(0.0), &p), vec![1]);
        assert_eq!(ids_seen(&open(), &at_bearing(44.0), &p), vec![1]);
        assert_eq!(ids_seen(&open(), &at_bearing(-44.0), &p), vec![1]);
        assert_eq!(ids_seen(&open(), &at_bearing(46.0), &p), Vec::<u32>::new());
        assert_eq!(ids_seen(&open(), &at_bearing(-46.0), &p), Vec::<u32>::new());
        assert_eq!(ids_seen(&open(), &at_bearing(180.0), &p), Vec::<u32>::new());
        // The default 360° view sees straight behind too.
        assert_eq!(ids_seen(&open(), &at_bearing(180.0), &exact()), vec![1]);
    }

    #[test]
    fn a_uav_never_observes_itself() {
        // Entry 2 carries the observer's id (a stale duplicate): neither it nor entry 0 is seen.
        let poses = [(4, [0.0, 0.0], 0.0), (5, [2.0, 0.0], 0.0), (4, [0.0, 2.0], 0.0)];
        let p = UvdarParams { occluded_by_uavs: false, ..UvdarParams::default() };
        let obs = observe(&open(), 0, &typed(&poses), &p, &mut rng(3));
        assert_eq!(obs.iter().map(|o| o.id.get()).collect::<Vec<_>>(), vec![5]);
        // Alone, a UAV sees nothing.
        assert!(observe(&open(), 0, &typed(&poses[..1]), &p, &mut rng(3)).is_empty());
    }

    #[test]
    fn non_finite_or_missing_inputs_give_no_observations_and_no_panic() {
        let p = UvdarParams::default();
        let poses = [(0, [0.0, 0.0], f64::NAN), (1, [2.0, 0.0], 0.0)];
        assert!(observe(&open(), 0, &typed(&poses), &p, &mut rng(1)).is_empty());
        assert!(observe(&open(), 5, &typed(&poses), &p, &mut rng(1)).is_empty());
        // A neighbour with a NaN position is not seen and does not hide the others.
        let poses = [(0, [0.0, 0.0], 0.0), (1, [f64::NAN, 0.0], 0.0), (2, [3.0, 0.0], 0.0)];
        assert_eq!(ids_seen(&open(), &poses, &exact()), vec![2]);
        // A neighbour exactly on the observer has no bearing and is not reported.
        let poses = [(0, [1.0, 1.0], 0.0), (1, [1.0, 1.0], 0.0)];
        assert!(observe(&open(), 0, &typed(&poses), &exact(), &mut rng(1)).is_empty());
    }

    /// Mean and (population) standard deviation.
    fn mean_std(v: &[f64]) -> (f64, f64) {
        let n = v.len() as f64;
        let m = v.iter().sum::<f64>() / n;
        let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / n;
        (m, var.sqrt())
    }

    #[test]
    fn noise_has_zero_mean_and_the_configured_sigma() {
        // Targets at d = 5 (ahead) and d = 2 (to the left); σ_rel = 0.1 → σ_r = 0.5 m and
        // 0.2 m; σ_b = 2° = 0.034907 rad. N = 20000: the standard error of a mean is
        // σ/√N = σ/141.4, so |mean| < 4σ/141.4 ≈ 0.028σ.
        let p = UvdarParams { range_noise_rel: 0.1, bearing_noise_deg: 2.0, occluded_by_uavs: false, ..exact() };
        let poses = [(0, [0.0, 0.0], 0.0), (1, [5.0, 0.0], 0.0), (2, [0.0, 2.0], 0.0)];
        let mut r = rng(42);
        let (mut e5, mut e2, mut eb) = (vec![], vec![], vec![]);
        for _ in 0..20_000 {
            let obs = observe(&open(), 0, &typed(&poses), &p, &mut r);
            assert_eq!(obs.len(), 2);
            e5.push(obs[0].range_m - 5.0);
            e2.push(obs[1].range_m - 2.0);
            eb.push(obs[0].bearing_rad); // true bearing 0
        }
        let sigma_b = 2.0f64.to_radians();
        for (errors, sigma) in [(&e5, 0.5), (&e2, 0.2), (&eb, sigma_b)] {
            let (m, s) = mean_std(errors);
            assert!(m.abs() < 4.0 * sigma / 141.4, "mean {m} for σ {sigma}");
            assert!((s / sigma - 1.0).abs() < 0.10, "std {s} for σ {sigma}");
        }
    }

    #[test]
    fn detections_happen_at_the_configured_rate() {
        // p = 0.7, N = 10000: the fraction's standard error is √(0.7·0.3/10000) = 0.0046.
        let p = UvdarParams { detection_probability: 0.7, ..exact() };
        let poses = [(0, [0.0, 0.0], 0.0), (1, [3.0, 0.0], 0.0)];
        let mut r = rng(5);
        let seen = (0..10_000).filter(|_| !observe(&open(), 0, &typed(&poses), &p, &mut r).is_empty()).count();
        let rate = seen as f64 / 10_000.0;
        assert!((rate - 0.7).abs() < 4.0 * 0.0046, "{rate}");
        // p = 0 never detects.
        let never = UvdarParams { detection_probability: 0.0, ..exact() };
        assert!((0..100).all(|_| observe(&open(), 0, &typed(&poses), &never, &mut r).is_empty()));
    }

    #[test]
    fn same_seed_same_observations_other_seed_other_noise() {
        let p = UvdarParams { detection_probability: 0.9, ..UvdarParams::default() };
        let w = World::new(vec![tree(2.0, 2.0, 0.3)], vec![]);
        let poses = [
            (0, [0.0, 0.0], 0.4),
            (1, [3.0, 1.0], 0.0),
            (2, [-2.0, 4.0], 1.0),
            (3, [4.0, 4.0], 2.0), // behind the tree
            (4, [0.0, -5.0], 3.0),
        ];
        let run = |seed: u64| {
            let mut r = rng(seed);
            (0..50).map(|_| observe(&w, 0, &typed(&poses), &p, &mut r)).collect::<Vec<_>>()
        };
        assert_eq!(run(11), run(11));
        assert_ne!(run(11), run(12));
    }

    #[test]
    fn an_occluded_neighbour_does_not_shift_the_noise_of_the_others() {
        // Same seed, UAV 1 in the open or behind a tree: UAV 2's noisy observation is the same,
        // because the draws do not depend on the geometry.
        let p = UvdarParams { detection_probability: 0.8, ..UvdarParams::default() };
        let poses = [(0, [0.0, 0.0], 0.0), (1, [6.0, 0.0], 0.0), (2, [0.0, 4.0], 0.0)];
        let open_obs = observe(&open(), 0, &typed(&poses), &p, &mut rng(9));
        let hidden = World::new(vec![tree(3.0, 0.0, 0.3)], vec![]);
        let hidden_obs = observe(&hidden, 0, &typed(&poses), &p, &mut rng(9));
        let uav2 = |v: &[Observation]| v.iter().find(|o| o.id == UavId::new(2)).copied();
        assert!(hidden_obs.iter().all(|o| o.id != UavId::new(1)));
        assert_eq!(uav2(&open_obs), uav2(&hidden_obs));
        // And the stream consumed is the same length: the next draw agrees.
        let (mut a, mut b) = (rng(9), rng(9));
        let _ = observe(&open(), 0, &typed(&poses), &p, &mut a);
        let _ = observe(&hidden, 0, &typed(&poses), &p, &mut b);
        assert_eq!(a.gen::<u64>(), b.gen::<u64>());
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]
        /// Noise-free and with occlusion off, the observations are exactly the other UAVs in
        /// range and view, and each one puts the target back where it is:
        /// origin + range·(cos(yaw + bearing), sin(yaw + bearing)) = target.
        #[test]
        fn noise_free_observations_reconstruct_the_targets(
            others in prop::collection::vec((-12.0..12.0f64, -12.0..12.0f64), 0..8),
            pose in (-3.0..3.0f64, -3.0..3.0f64, -10.0..10.0f64),
            fov_deg in 10.0..=360.0f64,
        ) {
            let p = UvdarParams {
                fov_deg,
                occluded_by_obstacles: false,
                occluded_by_uavs: false,
                ..exact()
            };
            let mut poses = vec![(100, [pose.0, pose.1], pose.2)];
            poses.extend(others.iter().enumerate().map(|(i, &(x, y))| (i as u32, [x, y], 0.0)));
            let obs = observe(&open(), 0, &typed(&poses), &p, &mut rng(0));
            let mut expected = vec![];
            for &(id, t, _) in &poses[1..] {
                let (dx, dy) = (t[0] - pose.0, t[1] - pose.1);
                let d = dx.hypot(dy);
                let b = wrap_angle(dy.atan2(dx) - pose.2);
                if d > 0.0 && d <= p.max_range_m && b.abs() <= 0.5 * fov_deg.to_radians() {
                    expected.push(id);
                }
            }
            prop_assert_eq!(obs.iter().map(|o| o.id.get()).collect::<Vec<_>>(), expected);
            for o in &obs {
                prop_assert!(o.id != UavId::new(100));
                let t = poses[o.id.get() as usize + 1].1;
                let a = pose.2 + o.bearing_rad;
                prop_assert!((pose.0 + o.range_m * a.cos() - t[0]).abs() < 1e-9);
                prop_assert!((pose.1 + o.range_m * a.sin() - t[1]).abs() < 1e-9);
            }
        }
    }
}

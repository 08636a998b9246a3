//! The A21 flocking controller (seed 003, section III): f = p + n + c, a desired acceleration.
//!
//! Why this module exists: it is the decision of one UAV per control step under the A21 law,
//! kept free of I/O so every term can be checked against hand-computed values of the paper's
//! equations. Given the relative positions of the observed agents (UVDAR in the seed), the
//! relative positions of nearby obstacle points and, for an informed agent, the direction x̂ⁿ
//! along its planned path — all in the body frame — [`step`] returns the desired acceleration
//! f = p + n + c (seed 003 eq. 1) and each of its terms:
//! - the proximal vector p (eq. 2) from the attraction α (eq. 3–4) and the repulsion β (eq. 5–6);
//! - the navigation vector n = kn φ(μ_d) x̂ⁿ (eq. 7–8), for informed agents only;
//! - the collision vector c from obstacle points within d_r (seed 003 III-C defers to the
//!   former controller, written out as seed 000 eq. 2.4–2.5).
//!
//! [`navigation_direction`] turns a path (from the A* planner in `grid`) into x̂ⁿ. It works in
//! the frame the path is in (the agent's odometry frame); the caller rotates the result into the
//! body frame before [`step`].
//!
//! A21 does not steer the heading: seed 003 IV-B feeds its tracker a constant desired heading ψ_d,
//! so the caller commands no yaw rate (UVDAR sees all round).
//!
//! Choices where the seeds are silent or inconsistent (each is documented at its function):
//! - collision sign and direction: seed 000 eq. 2.4 writes c = (1/N_c) Σ Φ(|x_o|) x_o with
//!   Φ ≥ 0 and x_o the obstacle's position relative to the UAV, which points *towards* the
//!   obstacle; seed 000 4.6 says the former controller's avoidance vectors point "directly away
//!   from the obstacle". We use c = −(1/N_c) Σ Φ(|x_o|) x̂_o: away from the obstacle, and along
//!   the unit vector as in seed 003 eq. 2 (seed 000's transcription also drops the hat of eq. 2,
//!   its eq. 2.6). With the raw x_o the magnitude ko(√d − d/√d_r) would peak at d = d_r/4 and
//!   vanish at contact, too weak to hold off the navigation vector (kn = 1.2 > 0.71 m/s²);
//! - the obstacle points x_o are surface points, not trunk centres: the caller passes the LIDAR
//!   scan points (body frame). Seed 003 computes c from its SLAM occupancy map (section V-B: "the
//!   collision control vector uses this map"), whose occupied cells are LIDAR hits on surfaces,
//!   so d_r = 2 m is a clearance to the bark; centres would shrink it by the trunk radius
//!   (0.1–0.4 m) and walls have no centre. A neighbour UAV also shows in the scan; seed 003 had
//!   the same effect in its map (V-B) and only repels a little more — the caller may drop scan
//!   points near localized neighbours;
//! - N_α, N_β, N_c count the terms that are non-zero (as the seeds define them); a sum with no
//!   non-zero term is zero, not 0/0;
//! - φ when no agent is observed: `A21Params::phi_alone` (default 0: the informed agent waits, as
//!   if its agents were beyond d_max, where they become undetectable);
//! - x̂ⁿ: seed 003 eq. 7 takes "the relative position of the nearest point on path P", which is
//!   zero once the agent is on its path. We read it as the point `lookahead_m` further along the
//!   path than the nearest point (`lookahead_m` = 0 is the literal reading);
//! - an agent or obstacle point at the UAV's own position (closer than 1e-9 m) has no direction
//!   and is ignored, as are non-finite inputs; a non-finite term (possible only with
//!   non-finite or invalid parameters) becomes zero.

use nalgebra::{Point2, Vector2};
use swarm_config::A21Params;

/// Everything one control step needs, in the body frame.
#[derive(Debug, Clone, Copy)]
pub struct Input<'a> {
    /// Relative positions of the observed agents x_i^a [m], body frame.
    pub neighbours: &'a [Vector2<f64>],
    /// Obstacle surface points x_o [m], body frame (the LIDAR scan points; see the module doc).
    pub obstacle_points: &'a [Vector2<f64>],
    /// x̂ⁿ, the direction along the planned path, body frame; `None` for an uninformed agent or
    /// when there is no path. Normalised here, so any non-zero length will do.
    pub path_direction: Option<Vector2<f64>>,
}

/// The result of one control step, with the terms of eq. 1 for logging and tests.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Output {
    /// Desired acceleration f = p + n + c [m/s²], body frame (seed 003 eq. 1).
    pub acceleration: Vector2<f64>,
    /// Proximal vector p (eq. 2).
    pub proximal: Vector2<f64>,
    /// Navigation vector n (eq. 7); zero for an uninformed agent.
    pub navigation: Vector2<f64>,
    /// Collision vector c (seed 000 eq. 2.4–2.5, pointing away from the obstacles).
    pub collision: Vector2<f64>,
    /// φ(μ_d) of eq. 8 (or `phi_alone` when no agent is observed).
    pub phi: f64,
}

use super::barrier::{barrier, braking};
use crate::geometry::{finite_or_zero, is_finite, EPS};

/// Length and unit vector of a finite vector longer than 1e-9 m, else `None`.
fn length_and_direction(v: &Vector2<f64>) -> Option<(f64, Vector2<f64>)> {
    let d = v.norm();
    (is_finite(v) && d.is_finite() && d > EPS).then(|| (d, v / d))
}

/// λα, the scale that makes α continuous at d_f (seed 003 eq. 4).
pub fn lambda_alpha(p: &A21Params) -> f64 {
    // seed 003 eq. 4: λα = kα (d_f − d_0)² / atan(0.1 d_f).
    p.k_alpha * (p.df_m - p.d0_m).powi(2) / (0.1 * p.df_m).atan()
}

/// λβ, the scale that makes β continuous at d_c (seed 003 eq. 6).
pub fn lambda_beta(p: &A21Params) -> f64 {
    // seed 003 eq. 6: λβ = kβ (d_c − d_0)² √(d_c d_0) / (√d_0 − √d_c).
    p.k_beta * (p.dc_m - p.d0_m).powi(2) * (p.dc_m * p.d0_m).sqrt() / (p.d0_m.sqrt() - p.dc_m.sqrt())
}

/// Attraction α(d) ≥ 0 towards an agent at distance `d_m` (seed 003 eq. 3).
///
/// 0 up to d_0, kα(d − d_0)² up to d_f, λα atan(d − 0.9 d_f) beyond (tending to λα π/2).
/// NaN gives 0.
pub fn alpha(p: &A21Params, d_m: f64) -> f64 {
    if d_m.is_nan() || d_m <= p.d0_m {
        // seed 003 eq. 3, first branch: 0 for 0 ≤ d ≤ d_0.
        0.0
    } else if d_m <= p.df_m {
        // seed 003 eq. 3, second branch: kα (d − d_0)².
        p.k_alpha * (d_m - p.d0_m).powi(2)
    } else {
        // seed 003 eq. 3, third branch: λα atan(d − 0.9 d_f).
        lambda_alpha(p) * (d_m - 0.9 * p.df_m).atan()
    }
}

/// Repulsion β(d) ≤ 0 from an agent at distance `d_m` (seed 003 eq. 5).
///
/// −λβ(1/√d − 1/√d_0) on (0, d_c], −kβ(d − d_0)² on (d_c, d_0], 0 beyond. Eq. 5 is undefined at
/// d = 0 (it tends to −∞); there the agent has no direction either, so 0 is returned and
/// [`proximal`] ignores it. NaN and negative distances give 0.
pub fn beta(p: &A21Params, d_m: f64) -> f64 {
    if d_m.is_nan() || d_m <= 0.0 || d_m > p.d0_m {
        // seed 003 eq. 5, third branch (d > d_0), and outside the domain.
        0.0
    } else if d_m <= p.dc_m {
        // seed 003 eq. 5, first branch: −λβ (1/√d − 1/√d_0).
        -lambda_beta(p) * (1.0 / d_m.sqrt() - 1.0 / p.d0_m.sqrt())
    } else {
        // seed 003 eq. 5, second branch: −kβ (d − d_0)².
        -p.k_beta * (d_m - p.d0_m).powi(2)
    }
}

/// Proximal vector p (seed 003 eq. 2).
///
/// p = (1/N_α) Σ α(|x_i|) x̂_i + (1/N_β) Σ β(|x_i|) x̂_i, where N_α (N_β) is the number of agents
/// with a non-zero α (β); each mean is zero when its count is. Agents with a non-finite position
/// or closer than 1e-9 m are ignored.
pub fn proximal(p: &A21Params, neighbours: &[Vector2<f64>]) -> Vector2<f64> {
    let (mut sum_a, mut n_a) = (Vector2::zeros(), 0usize);
    let (mut sum_b, mut n_b) = (Vector2::zeros(), 0usize);
    for (d, x_hat) in neighbours.iter().filter_map(length_and_direction) {
        let a = alpha(p, d);
        if a != 0.0 {
            sum_a += a * x_hat;
            n_a += 1;
        }
        let b = beta(p, d);
        if b != 0.0 {
            sum_b += b * x_hat;
            n_b += 1;
        }
    }
    let mean = |sum: Vector2<f64>, n: usize| if n == 0 { sum } else { sum / n as f64 };
    // seed 003 eq. 2: p = (1/N_α) Σ α x̂ + (1/N_β) Σ β x̂.
    finite_or_zero(mean(sum_a, n_a) + mean(sum_b, n_b))
}

/// μ_d, the mean distance to the observed agents [m] (seed 003 eq. 8); `None` when no agent with
/// a finite position is observed.
pub fn mean_distance(neighbours: &[Vector2<f64>]) -> Option<f64> {
    let (sum, n) = neighbours
        .iter()
        .filter(|x| is_finite(x))
        .map(|x| x.norm())
        .filter(|d| d.is_finite())
        .fold((0.0, 0usize), |(s, n), d| (s + d, n + 1));
    (n > 0).then(|| sum / n as f64)
}

/// φ(μ_d) (seed 003 eq. 8): 1 − (μ_d/d_max)² on [0, d_max], 0 beyond. A negative or NaN μ_d is
/// outside the domain and gives 0.
pub fn phi(p: &A21Params, mu_d_m: f64) -> f64 {
    if (0.0..=p.dmax_m).contains(&mu_d_m) {
        // seed 003 eq. 8, first branch.
        1.0 - (mu_d_m / p.dmax_m).powi(2)
    } else {
        // seed 003 eq. 8, second branch (and outside the domain).
        0.0
    }
}

/// φ for this set of observed agents: φ(μ_d) of eq. 8, or `p.phi_alone` when none is observed
/// (μ_d undefined; see the module doc).
pub fn phi_of_neighbours(p: &A21Params, neighbours: &[Vector2<f64>]) -> f64 {
    match mean_distance(neighbours) {
        Some(mu_d) => phi(p, mu_d),
        None => p.phi_alone,
    }
}

/// Navigation vector n = kn φ x̂ⁿ (seed 003 eq. 7), `phi` from [`phi_of_neighbours`].
///
/// `direction` is x̂ⁿ (normalised here); `None`, zero or non-finite gives n = 0, as for an
/// uninformed agent.
pub fn navigation(p: &A21Params, phi: f64, direction: Option<Vector2<f64>>) -> Vector2<f64> {
    match direction.as_ref().and_then(length_and_direction) {
        // seed 003 eq. 7: n = kn φ(μ_d) x̂ⁿ.
        Some((_, x_hat)) => finite_or_zero(p.kn * phi * x_hat),
        None => Vector2::zeros(),
    }
}

/// Collision gain Φ(d) ≥ 0 for an obstacle point at distance `d_m` (seed 000 eq. 2.5).
///
/// ko(1/√d − 1/√d_r) on (0, d_r], 0 beyond. Like β, it tends to ∞ at d = 0, where the point has
/// no direction: 0 is returned and [`collision`] ignores the point. NaN and negative give 0.
pub fn collision_gain(p: &A21Params, d_m: f64) -> f64 {
    if d_m.is_nan() || d_m <= 0.0 || d_m > p.dr_m {
        // seed 000 eq. 2.5, second branch (d > d_r), and outside the domain.
        0.0
    } else {
        // seed 000 eq. 2.5, first branch: ko (1/√d − 1/√d_r).
        p.ko * (1.0 / d_m.sqrt() - 1.0 / p.dr_m.sqrt())
    }
}

/// Collision vector c (seed 000 eq. 2.4 with the sign of seed 000 4.6), away from the obstacles.
///
/// c = −(1/N_c) Σ Φ(|x_o|) x̂_o over the obstacle points x_o (body frame), N_c the number of
/// points with a non-zero Φ, i.e. within d_r; no such point gives zero. See the module doc for
/// the minus sign, the unit vector and why the points are surface points. Non-finite points and
/// points closer than 1e-9 m are ignored.
pub fn collision(p: &A21Params, obstacle_points: &[Vector2<f64>]) -> Vector2<f64> {
    let (mut sum, mut n_c) = (Vector2::zeros(), 0usize);
    for (d, x_hat) in obstacle_points.iter().filter_map(length_and_direction) {
        let g = collision_gain(p, d);
        if g != 0.0 {
            sum += g * x_hat;
            n_c += 1;
        }
    }
    if n_c == 0 {
        return Vector2::zeros();
    }
    // seed 000 eq. 2.4: c = (1/N_c) Σ Φ(|x_o|) x_o, turned to point away from the obstacle
    // (seed 000 4.6) and taken along x̂_o as in seed 003 eq. 2.
    finite_or_zero(-sum / n_c as f64)
}

fn finite_points(path: &[Point2<f64>]) -> impl Iterator<Item = Point2<f64>> + Clone + '_ {
    path.iter().copied().filter(|q| q.x.is_finite() && q.y.is_finite())
}

/// Consecutive pairs of the path's finite points.
fn segments(path: &[Point2<f64>]) -> impl Iterator<Item = (Point2<f64>, Point2<f64>)> + '_ {
    finite_points(path).zip(finite_points(path).skip(1))
}

/// Arc length along the path of its point nearest to `pos`; the earliest one on a tie.
fn nearest_arc_length(path: &[Point2<f64>], pos: Point2<f64>) -> Option<f64> {
    let first = finite_points(path).next()?;
    let (mut best_dist, mut best_s) = ((first - pos).norm(), 0.0);
    let mut s0 = 0.0;
    for (a, b) in segments(path) {
        let ab = b - a;
        let len2 = ab.norm_squared();
        let t = if len2 > 0.0 { ((pos - a).dot(&ab) / len2).clamp(0.0, 1.0) } else { 0.0 };
        let dist = (a + ab * t - pos).norm();
        let len = len2.sqrt();
        if dist < best_dist {
            (best_dist, best_s) = (dist, s0 + t * len);
        }
        s0 += len;
    }
    Some(best_s)
}

/// The path point at arc length `s` from its start; the last point when `s` is beyond the end.
fn point_at_arc_length(path: &[Point2<f64>], s: f64) -> Option<Point2<f64>> {
    let mut last = finite_points(path).next()?;
    let mut s0 = 0.0;
    for (a, b) in segments(path) {
        let len = (b - a).norm();
        if len > 0.0 && s <= s0 + len {
            return Some(a + (b - a) * ((s - s0) / len).clamp(0.0, 1.0));
        }
        s0 += len;
        last = b;
    }
    Some(last)
}

/// x̂ⁿ of seed 003 eq. 7: the unit vector from `pos` towards the path point `lookahead_m`
/// further along `path` than the path point nearest to `pos`.
///
/// Seed 003 III-B: xⁿ "is the relative position of the nearest point on path P" (the path to the
/// goal); seed 000 2.3: "the closest point in the path". Read literally (`lookahead_m` = 0) xⁿ
/// vanishes once the agent is on its path, so the target is advanced along the path by
/// `lookahead_m` (clamped at the path's end, the goal). The nearest point is the orthogonal
/// projection onto the polyline; on a tie the earliest along the path wins. `path` and `pos` are in the same frame and so is the
/// result. `None` when there is no finite path point, `pos` is not finite, or the target is
/// within 1e-9 m of `pos` (at the goal). Non-finite path points are skipped; a NaN or negative
/// lookahead counts as 0, an infinite one aims at the goal.
pub fn navigation_direction(path: &[Point2<f64>], pos: Point2<f64>, lookahead_m: f64) -> Option<Vector2<f64>> {
    if !(pos.x.is_finite() && pos.y.is_finite()) {
        return None;
    }
    let lookahead = if lookahead_m > 0.0 { lookahead_m } else { 0.0 };
    let s = nearest_arc_length(path, pos)?;
    let target = point_at_arc_length(path, s + lookahead)?;
    length_and_direction(&(target - pos)).map(|(_, x_hat)| x_hat)
}

/// One A21 control step: f = p + n + c (seed 003 eq. 1), all in the body frame.
///
/// p from [`proximal`], n from [`navigation`] with φ from [`phi_of_neighbours`], c from
/// [`collision`]. The seed applies no limit of its own; the body's speed and acceleration limits
/// apply downstream. Note for the caller: eq. 1 has no velocity damping — in seed 003 (IV-B) f
/// goes through a trajectory generator and an MPC tracker, which supply it — so a body that
/// integrates f directly oscillates about the rest distance d_0 unless the speed limit or the
/// caller damps it.
pub fn step(p: &A21Params, input: &Input) -> Output {
    let proximal = proximal(p, input.neighbours);
    let phi = phi_of_neighbours(p, input.neighbours);
    let navigation = navigation(p, phi, input.path_direction);
    let collision = collision(p, input.obstacle_points);
    // seed 003 eq. 1: f = p + n + c.
    let acceleration = finite_or_zero(proximal + navigation + collision);
    Output { acceleration, proximal, navigation, collision, phi }
}

/// The safety layer (our extension; seed 003 has none, see `A21Params::safety`): `reached`, the
/// velocity the command reaches within one control period [m/s] (body frame), with its approach
/// to each neighbour of `input` and each of its obstacle points held to the speed the UAV can
/// still shed at `safety_brake_mps2` before that one's stop distance ([`braking`]:
/// `safety_neighbour_m` centre to centre, `safety_surface_m` to a scan point), and none from
/// there in. `speed_mps` is the fastest the UAV flies: points it can stop short of at that speed
/// are not held at all. A velocity hemmed in on every side comes back zero: the UAV brakes.
pub fn safe_velocity(p: &A21Params, reached: Vector2<f64>, input: &Input, speed_mps: f64) -> Vector2<f64> {
    let brake = p.safety_brake_mps2;
    let neighbours = braking(input.neighbours, p.safety_neighbour_m, brake, speed_mps);
    let surfaces = braking(input.obstacle_points, p.safety_surface_m, brake, speed_mps);
    finite_or_zero(barrier(reached, neighbours.chain(surfaces)))
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use proptest::test_runner::RngSeed;

    fn params() -> A21Params {
        A21Params::default()
    }

    fn v(x: f64, y: f64) -> Vector2<f64> {
        Vector2::new(x, y)
    }

    fn pt(x: f64, y: f64) -> Point2<f64> {
        Point2::new(x, y)
    }

    #[track_caller]
    fn close(a: Vector2<f64>, b: Vector2<f64>, tol: f64) {
        assert!((a - b).norm() < tol, "{a:?} != {b:?}");
    }

    #[track_caller]
    fn near(a: f64, b: f64, tol: f64) {
        assert!((a - b).abs() < tol, "{a} != {b}");
    }

    // Table I: d_0 = 4, d_f = 5.85, kα = 0.16, d_c = 1.93, kβ = 0.07.
    // λα = 0.16·1.85² / atan(0.585) = 0.5476 / 0.5293171 = 1.0345406.
    const LAMBDA_ALPHA: f64 = 1.034_540_602_083_072_3;
    // λβ = 0.07·2.07²·√(1.93·4) / (2 − √1.93) = 0.299943·2.7784888 / (2 − 1.3892444)
    //    = 0.8333883 / 0.6107556 = 1.3645201.
    const LAMBDA_BETA: f64 = 1.364_520_053_628_511_6;

    /// The safety layer: an informed agent flying at 1 m/s straight at a neighbour 1.2 m ahead
    /// keeps only the approach it can still shed before 0.9 m (√(2·1·0.3) m/s), keeps its
    /// sideways speed, and keeps nothing towards a trunk's surface 0.45 m off; nothing near,
    /// nothing held.
    #[test]
    fn the_safety_layer_holds_the_approach_it_could_not_stop() {
        let p = A21Params { safety: true, ..params() };
        let ns = [v(1.2, 0.0)];
        let input = Input { neighbours: &ns, obstacle_points: &[], path_direction: Some(v(1.0, 0.0)) };
        close(safe_velocity(&p, v(1.0, 0.2), &input, 1.0), v(0.6_f64.sqrt(), 0.2), 1e-12);
        let bark = [v(0.0, -0.45)];
        let input = Input { neighbours: &[], obstacle_points: &bark, path_direction: None };
        close(safe_velocity(&p, v(0.5, -0.4), &input, 1.0), v(0.5, 0.0), 1e-12);
        let far = [v(3.0, 0.0)];
        let input = Input { neighbours: &far, obstacle_points: &far, path_direction: None };
        close(safe_velocity(&p, v(1.0, 0.0), &input, 1.0), v(1.0, 0.0), 1e-12);
    }

    #[test]
    fn lambdas_hand_computed() {
        near(lambda_alpha(&params()), LAMBDA_ALPHA, 1e-9);
        near(lambda_beta(&params()), LAMBDA_BETA, 1e-9);
    }

    #[test]
    fn alpha_hand_computed() {
        let p = params();
        // First branch: 0 up to and at d_0.
        assert_eq!(alpha(&p, 0.0), 0.0);
        assert_eq!(alpha(&p, 3.0), 0.0);
        assert_eq!(alpha(&p, 4.0), 0.0);
        // Second branch: 0.16·0.5² = 0.04; 0.16·1² = 0.16; at d_f 0.16·1.85² = 0.5476.
        near(alpha(&p, 4.5), 0.04, 1e-12);
        near(alpha(&p, 5.0), 0.16, 1e-12);
        near(alpha(&p, 5.85), 0.5476, 1e-12);
        // Third branch: λα·atan(10 − 5.265) = 1.0345406·atan(4.735) = 1.0345406·1.3626616
        // = 1.4097287; at infinity λα·π/2 = 1.6250526.
        near(alpha(&p, 10.0), 1.409_728_715_705_906_6, 1e-9);
        near(alpha(&p, f64::INFINITY), 1.625_052_577_672_270_6, 1e-9);
        // NaN → 0.
        assert_eq!(alpha(&p, f64::NAN), 0.0);
    }

    #[test]
    fn beta_hand_computed() {
        let p = params();
        // Third branch: 0 beyond d_0; second branch gives 0 at d_0 itself.
        assert_eq!(beta(&p, 5.0), 0.0);
        assert_eq!(beta(&p, 4.0), 0.0);
        // Second branch: −0.07·1² = −0.07; −0.07·2² = −0.28; at d_c −0.07·2.07² = −0.299943.
        near(beta(&p, 3.0), -0.07, 1e-12);
        near(beta(&p, 2.0), -0.28, 1e-12);
        near(beta(&p, 1.93), -0.299_943, 1e-9);
        // First branch: −λβ(1/√1 − 1/2) = −0.5·1.3645201 = −0.6822600;
        // −λβ(1/√1.5 − 0.5) = −1.3645201·(0.8164966 − 0.5) = −0.4318659.
        near(beta(&p, 1.0), -0.682_260_026_814_255_8, 1e-9);
        near(beta(&p, 1.5), -0.431_865_931_580_741_4, 1e-9);
        // Outside the domain: 0.
        assert_eq!(beta(&p, 0.0), 0.0);
        assert_eq!(beta(&p, -1.0), 0.0);
        assert_eq!(beta(&p, f64::NAN), 0.0);
        assert_eq!(beta(&p, f64::INFINITY), 0.0);
    }

    /// Left and right limits at `x`: f(x − h) and f(x + h) with h = 1e-10; the slopes of α and β
    /// are below 2 near their joints, so a continuous function moves by < 1e-9.
    #[track_caller]
    fn continuous_at(f: impl Fn(f64) -> f64, x: f64) {
        let h = 1e-10;
        let (left, right) = (f(x - h), f(x + h));
        assert!((left - right).abs() < 1e-9, "jump at {x}: {left} vs {right}");
    }

    #[test]
    fn alpha_and_beta_are_continuous_at_their_joints() {
        let p = params();
        continuous_at(|d| alpha(&p, d), p.d0_m);
        continuous_at(|d| alpha(&p, d), p.df_m);
        continuous_at(|d| beta(&p, d), p.dc_m);
        continuous_at(|d| beta(&p, d), p.d0_m);
        // Both branches at the joint itself: α(d_f) = kα(d_f − d_0)² = λα atan(0.1 d_f);
        // β(d_c) = −kβ(d_c − d_0)² = −λβ(1/√d_c − 1/√d_0).
        near(LAMBDA_ALPHA * (0.1f64 * 5.85).atan(), 0.5476, 1e-12);
        near(-LAMBDA_BETA * (1.0 / 1.93f64.sqrt() - 0.5), -0.299_943, 1e-9);
    }

    #[test]
    fn attraction_beyond_d0_repulsion_below() {
        let p = params();
        for i in 1..=400 {
            let d = 0.05 * i as f64; // 0.05 … 20 m
            let px = proximal(&p, &[v(d, 0.0)]).x;
            if d < p.d0_m - 1e-9 {
                assert!(beta(&p, d) < 0.0 && alpha(&p, d) == 0.0, "d = {d}");
                assert!(px < 0.0, "d = {d}: p.x = {px}");
            } else if d > p.d0_m + 1e-9 {
                assert!(alpha(&p, d) > 0.0 && beta(&p, d) == 0.0, "d = {d}");
                assert!(px > 0.0, "d = {d}: p.x = {px}");
            } else {
                assert_eq!(px, 0.0, "d = {d}");
            }
        }
    }

    #[test]
    fn proximal_hand_computed() {
        let p = params();
        // (5,0): α = 0.16 → (0.16,0), N_α = 1. (0,3): β = −0.07 → (0,−0.07), N_β = 1.
        close(proximal(&p, &[v(5.0, 0.0), v(0.0, 3.0)]), v(0.16, -0.07), 1e-12);
        // Two attracting: (5,0) → (0.16,0); (0,−4.5) → 0.04·(0,−1); N_α = 2 → (0.08,−0.02).
        // An agent exactly at d_0 has α = β = 0 and does not dilute the mean.
        let ns = [v(5.0, 0.0), v(0.0, -4.5), v(4.0, 0.0)];
        close(proximal(&p, &ns), v(0.08, -0.02), 1e-12);
        // Two repelling: (1,0) → −0.6822600·(1,0); (0,−3) → −0.07·(0,−1) = (0,0.07);
        // N_β = 2 → (−0.3411300, 0.035).
        close(proximal(&p, &[v(1.0, 0.0), v(0.0, -3.0)]), v(-0.341_130_013_407_127_9, 0.035), 1e-9);
        // Direction only matters through x̂: (3,4) is at 5 m → 0.16·(0.6,0.8) = (0.096,0.128).
        close(proximal(&p, &[v(3.0, 4.0)]), v(0.096, 0.128), 1e-12);
        // Nobody → zero.
        close(proximal(&p, &[]), v(0.0, 0.0), 1e-15);
    }

    #[test]
    fn phi_hand_computed() {
        let p = params();
        // 1 − (μ/8)²: μ = 0 → 1; μ = 4 → 0.75; μ = 8 → 0; beyond → 0.
        assert_eq!(phi(&p, 0.0), 1.0);
        near(phi(&p, 4.0), 0.75, 1e-15);
        assert_eq!(phi(&p, 8.0), 0.0);
        assert_eq!(phi(&p, 8.5), 0.0);
        assert_eq!(phi(&p, 100.0), 0.0);
        assert_eq!(phi(&p, f64::NAN), 0.0);
        assert_eq!(phi(&p, -1.0), 0.0);
    }

    #[test]
    fn phi_of_neighbours_uses_the_mean_distance() {
        let p = params();
        // |(3,4)| = 5, |(0,−3)| = 3 → μ_d = 4 → φ = 0.75. The NaN agent is not observed.
        let ns = [v(3.0, 4.0), v(0.0, -3.0), v(f64::NAN, 1.0)];
        assert_eq!(mean_distance(&ns), Some(4.0));
        near(phi_of_neighbours(&p, &ns), 0.75, 1e-15);
        // Nobody observed: φ = phi_alone.
        assert_eq!(mean_distance(&[]), None);
        assert_eq!(phi_of_neighbours(&p, &[]), 0.0);
        let alone = A21Params { phi_alone: 1.0, ..params() };
        assert_eq!(phi_of_neighbours(&alone, &[v(f64::NAN, 0.0)]), 1.0);
    }

    #[test]
    fn navigation_hand_computed() {
        let p = params();
        // n = 1.2·0.75·(0,1) = (0,0.9); the direction is normalised first.
        close(navigation(&p, 0.75, Some(v(0.0, 1.0))), v(0.0, 0.9), 1e-12);
        close(navigation(&p, 0.75, Some(v(0.0, 2.0))), v(0.0, 0.9), 1e-12);
        // (3,4)/5 with φ = 1 → 1.2·(0.6,0.8) = (0.72,0.96).
        close(navigation(&p, 1.0, Some(v(3.0, 4.0))), v(0.72, 0.96), 1e-12);
        // Uninformed, zero or NaN direction → 0.
        close(navigation(&p, 1.0, None), v(0.0, 0.0), 1e-15);
        close(navigation(&p, 1.0, Some(v(0.0, 0.0))), v(0.0, 0.0), 1e-15);
        close(navigation(&p, 1.0, Some(v(f64::NAN, 1.0))), v(0.0, 0.0), 1e-15);
    }

    #[test]
    fn collision_gain_hand_computed() {
        let p = params();
        // Φ = 2(1/√d − 1/√2): d = 1 → 2(1 − 0.7071068) = 0.5857864;
        // d = 0.5 → 2(1.4142136 − 0.7071068) = 1.4142136; d = 1.5 → 2(0.8164966 − 0.7071068)
        // = 0.2187796; d = d_r → 0; beyond → 0.
        near(collision_gain(&p, 1.0), 0.585_786_437_626_905_1, 1e-12);
        near(collision_gain(&p, 0.5), std::f64::consts::SQRT_2, 1e-12);
        near(collision_gain(&p, 1.5), 0.218_779_599_482_357_4, 1e-12);
        near(collision_gain(&p, 2.0), 0.0, 1e-15);
        assert_eq!(collision_gain(&p, 2.5), 0.0);
        assert_eq!(collision_gain(&p, 0.0), 0.0);
        assert_eq!(collision_gain(&p, f64::NAN), 0.0);
        continuous_at(|d| collision_gain(&p, d), p.dr_m);
    }

    #[test]
    fn collision_hand_computed() {
        let p = params();
        // One point ahead at 1 m: c = −0.5857864·(1,0), away from it.
        close(collision(&p, &[v(1.0, 0.0)]), v(-0.585_786_437_626_905_1, 0.0), 1e-12);
        // (1,0) → 0.5857864·(1,0); (0,0.5) → 1.4142136·(0,1); (3,0) beyond d_r does not count:
        // N_c = 2 → c = −(0.5857864, 1.4142136)/2 = (−0.2928932, −0.7071068).
        let pts = [v(1.0, 0.0), v(0.0, 0.5), v(3.0, 0.0)];
        close(collision(&p, &pts), v(-0.292_893_218_813_452_5, -0.707_106_781_186_547_5), 1e-12);
        // A wall-like row at x = 1: (1,−1), (1,0), (1,1) at 1.4142, 1, 1.4142 m.
        // Φ(√2) = 2(0.8408964 − 0.7071068) = 0.2675793, x̂ = (0.7071068, ∓0.7071068):
        // Σ = (2·0.2675793·0.7071068 + 0.5857864, 0) = (0.9642007, 0); N_c = 3 → (−0.3214002, 0).
        let wall = [v(1.0, -1.0), v(1.0, 0.0), v(1.0, 1.0)];
        close(collision(&p, &wall), v(-0.321_400_222_544_115_9, 0.0), 1e-9);
        // Nothing within d_r, points at the origin and non-finite points → zero.
        let ignored = [v(0.0, 0.0), v(f64::NAN, 0.5), v(f64::INFINITY, 0.0), v(2.5, 0.0)];
        close(collision(&p, &ignored), v(0.0, 0.0), 1e-15);
    }

    /// The L-shaped path (0,0) → (4,0) → (4,4), 8 m long.
    fn l_path() -> Vec<Point2<f64>> {
        vec![pt(0.0, 0.0), pt(4.0, 0.0), pt(4.0, 4.0)]
    }

    #[track_caller]
    fn dir(path: &[Point2<f64>], pos: Point2<f64>, lookahead: f64) -> Vector2<f64> {
        navigation_direction(path, pos, lookahead).unwrap()
    }

    #[test]
    fn navigation_direction_on_an_l_shaped_path() {
        let path = l_path();
        // (1,0.5): nearest (1,0) at s = 1; target s = 2 → (2,0); (1,−0.5)/√1.25
        // = (0.8944272, −0.4472136).
        close(dir(&path, pt(1.0, 0.5), 1.0), v(2.0, -1.0) / 5f64.sqrt(), 1e-12);
        // Literal reading, lookahead 0: towards the nearest point (1,0) → (0,−1).
        close(dir(&path, pt(1.0, 0.5), 0.0), v(0.0, -1.0), 1e-12);
        // (3.5,0.2): nearest (3.5,0), s = 3.5; target s = 4.5 → (4,0.5) round the corner;
        // (0.5,0.3)/√0.34.
        close(dir(&path, pt(3.5, 0.2), 1.0), v(0.5, 0.3) / 0.34f64.sqrt(), 1e-12);
        // (4.5,2) on the second leg: nearest (4,2), s = 6; target (4,3); (−0.5,1)/√1.25.
        close(dir(&path, pt(4.5, 2.0), 1.0), v(-1.0, 2.0) / 5f64.sqrt(), 1e-12);
        // (3,1) is 1 m from both legs: the earliest, (3,0) at s = 3, wins; target (4,0) →
        // (1,−1)/√2.
        close(dir(&path, pt(3.0, 1.0), 1.0), v(1.0, -1.0) / 2f64.sqrt(), 1e-12);
        // Past the goal (4,5): nearest is the end (4,4) → (0,−1); lookahead clamps at the end.
        close(dir(&path, pt(4.0, 5.0), 1.0), v(0.0, -1.0), 1e-12);
        // On the path at (2,0): target (3,0) → (1,0); at the goal → None.
        close(dir(&path, pt(2.0, 0.0), 1.0), v(1.0, 0.0), 1e-12);
        assert_eq!(navigation_direction(&path, pt(4.0, 4.0), 1.0), None);
        // Infinite lookahead aims at the goal: from (0,0) → (1,1)/√2.
        close(dir(&path, pt(0.0, 0.0), f64::INFINITY), v(1.0, 1.0) / 2f64.sqrt(), 1e-12);
    }

    #[test]
    fn navigation_direction_degenerate_inputs() {
        let path = l_path();
        // No path, NaN position → None.
        assert_eq!(navigation_direction(&[], pt(0.0, 0.0), 1.0), None);
        assert_eq!(navigation_direction(&path, pt(f64::NAN, 0.0), 1.0), None);
        // A one-point path is the goal itself: from (0,3) to (0,0) → (0,−1).
        close(dir(&[pt(0.0, 0.0)], pt(0.0, 3.0), 1.0), v(0.0, -1.0), 1e-12);
        // NaN points are skipped: same as the L path. NaN or negative lookahead counts as 0.
        let with_nan = [pt(0.0, 0.0), pt(f64::NAN, 1.0), pt(4.0, 0.0), pt(4.0, 4.0)];
        close(dir(&with_nan, pt(1.0, 0.5), 1.0), v(2.0, -1.0) / 5f64.sqrt(), 1e-12);
        close(dir(&path, pt(1.0, 0.5), f64::NAN), v(0.0, -1.0), 1e-12);
        close(dir(&path, pt(1.0, 0.5), -2.0), v(0.0, -1.0), 1e-12);
        // Repeated points (zero-length segments) change nothing.
        let repeated = [pt(0.0, 0.0), pt(0.0, 0.0), pt(4.0, 0.0), pt(4.0, 0.0), pt(4.0, 4.0)];
        close(dir(&repeated, pt(3.5, 0.2), 1.0), v(0.5, 0.3) / 0.34f64.sqrt(), 1e-12);
    }

    #[test]
    fn step_with_nobody_and_nothing() {
        let free = |dir| Input { neighbours: &[], obstacle_points: &[], path_direction: dir };
        // Uninformed and alone: hover (f = 0).
        let out = step(&params(), &free(None));
        close(out.acceleration, v(0.0, 0.0), 1e-15);
        // Informed but alone: φ = phi_alone = 0 by default → still f = 0.
        let out = step(&params(), &free(Some(v(1.0, 0.0))));
        close(out.acceleration, v(0.0, 0.0), 1e-15);
        assert_eq!(out.phi, 0.0);
        // phi_alone = 1: f = n = 1.2·(1,0).
        let alone = A21Params { phi_alone: 1.0, ..params() };
        let out = step(&alone, &free(Some(v(1.0, 0.0))));
        close(out.acceleration, v(1.2, 0.0), 1e-12);
        close(out.navigation, v(1.2, 0.0), 1e-12);
        close(out.proximal + out.collision, v(0.0, 0.0), 1e-15);
    }

    #[test]
    fn step_hand_computed() {
        // Agents (5,0) and (0,3): p = (0.16,−0.07) (see proximal_hand_computed);
        // μ_d = (5 + 3)/2 = 4 → φ = 0.75; x̂ⁿ = (1,0) → n = 1.2·0.75·(1,0) = (0.9,0);
        // obstacle point (0,−1) → c = −Φ(1)·(0,−1) = (0,0.5857864).
        // f = (0.16 + 0.9, −0.07 + 0.5857864) = (1.06, 0.5157864).
        let input = Input {
            neighbours: &[v(5.0, 0.0), v(0.0, 3.0)],
            obstacle_points: &[v(0.0, -1.0)],
            path_direction: Some(v(1.0, 0.0)),
        };
        let out = step(&params(), &input);
        close(out.proximal, v(0.16, -0.07), 1e-12);
        close(out.navigation, v(0.9, 0.0), 1e-12);
        close(out.collision, v(0.0, 0.585_786_437_626_905_1), 1e-12);
        close(out.acceleration, v(1.06, 0.515_786_437_626_905_1), 1e-12);
        near(out.phi, 0.75, 1e-15);
    }

    #[test]
    fn step_ignores_non_finite_inputs() {
        let clean = Input {
            neighbours: &[v(5.0, 0.0), v(0.0, 3.0)],
            obstacle_points: &[v(0.0, -1.0)],
            path_direction: Some(v(1.0, 0.0)),
        };
        let dirty = Input {
            neighbours: &[v(5.0, 0.0), v(f64::NAN, 1.0), v(0.0, 3.0), v(f64::INFINITY, 0.0)],
            obstacle_points: &[v(f64::NAN, f64::NAN), v(0.0, -1.0), v(0.0, f64::NEG_INFINITY)],
            path_direction: Some(v(1.0, 0.0)),
        };
        assert_eq!(step(&params(), &dirty), step(&params(), &clean));
        // A NaN path direction is no direction: n = 0, the rest unchanged.
        let out = step(&params(), &Input { path_direction: Some(v(f64::NAN, 0.0)), ..clean });
        close(out.navigation, v(0.0, 0.0), 1e-15);
        close(out.acceleration, v(0.16, -0.07 + 0.585_786_437_626_905_1), 1e-12);
    }

    fn config(cases: u32) -> ProptestConfig {
        ProptestConfig {
            cases,
            rng_seed: RngSeed::Fixed(0x0A21),
            failure_persistence: None,
            ..ProptestConfig::default()
        }
    }

    /// Valid parameter sets: 0 < d_c < d_0 < d_f, positive gains.
    fn valid_params() -> impl Strategy<Value = A21Params> {
        (0.2..5.0f64, 0.05..0.95f64, 0.1..5.0f64, 0.01..2.0f64, 0.01..2.0f64).prop_map(
            |(d0, dc_frac, df_extra, k_alpha, k_beta)| A21Params {
                d0_m: d0,
                dc_m: d0 * dc_frac,
                df_m: d0 + df_extra,
                k_alpha,
                k_beta,
                ..A21Params::default()
            },
        )
    }

    fn vec2() -> impl Strategy<Value = Vector2<f64>> {
        (-20.0..20.0f64, -20.0..20.0f64).prop_map(|(x, y)| Vector2::new(x, y))
    }

    proptest! {
        #![proptest_config(config(256))]

        /// λα and λβ make α and β continuous for every valid parameter set (seed 003 eq. 4, 6).
        #[test]
        fn prop_continuity_for_any_valid_params(p in valid_params()) {
            let h = 1e-10;
            for (f, x) in [
                (alpha as fn(&A21Params, f64) -> f64, p.d0_m),
                (alpha, p.df_m),
                (beta, p.dc_m),
                (beta, p.d0_m),
            ] {
                let (left, right) = (f(&p, x - h), f(&p, x + h));
                // A continuous f moves by at most h·(left slope + right slope) across the joint;
                // the slopes are 2kα(d_f − d_0) and λα/(1 + (0.1 d_f)²) at d_f, λβ/(2 d_c^1.5)
                // and 2kβ(d_0 − d_c) at d_c, 0 at d_0. A jump would exceed this bound.
                let slopes = 2.0 * p.k_alpha * (p.df_m - p.d0_m)
                    + lambda_alpha(&p) / (1.0 + (0.1 * p.df_m).powi(2))
                    + lambda_beta(&p) / (2.0 * (p.dc_m - h).powf(1.5))
                    + 2.0 * p.k_beta * (p.d0_m - p.dc_m);
                let bound = 1e-9 + 2.0 * h * slopes;
                prop_assert!((left - right).abs() < bound, "{x}: {left} vs {right}");
            }
        }

        /// α is non-decreasing and ≥ 0, β is non-decreasing and ≤ 0 (attraction grows with
        /// distance, repulsion grows as agents close in).
        #[test]
        fn prop_alpha_beta_monotone(p in valid_params(), a in 0.001..30.0f64, b in 0.001..30.0f64) {
            let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
            prop_assert!(alpha(&p, lo) >= 0.0 && alpha(&p, lo) <= alpha(&p, hi) + 1e-12);
            prop_assert!(beta(&p, hi) <= 0.0 && beta(&p, lo) <= beta(&p, hi) + 1e-12);
        }

        /// The step is finite for any finite input, and the collision vector never points
        /// towards the obstacle points (c · Σ x̂_o ≤ 0).
        #[test]
        fn prop_step_is_finite_and_collision_repels(
            ns in prop::collection::vec(vec2(), 0..8),
            obs in prop::collection::vec(vec2().prop_map(|x| x / 8.0), 0..12),
            dir in prop::option::of(vec2()),
        ) {
            let input = Input { neighbours: &ns, obstacle_points: &obs, path_direction: dir };
            let out = step(&params(), &input);
            prop_assert!(is_finite(&out.acceleration));
            prop_assert!((0.0..=1.0).contains(&out.phi));
            prop_assert!(out.navigation.norm() <= params().kn + 1e-12);
            if obs.len() == 1 {
                prop_assert!(out.collision.dot(&obs[0]) <= 0.0);
            }
        }
    }
}

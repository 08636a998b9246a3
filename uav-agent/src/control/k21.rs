//! The K21 flocking controller (seed 000, chapter 4): Boids with tangential obstacle avoidance.
//!
//! Why this module exists: it is the decision of one UAV per control step, kept free of I/O so it
//! can be tested against hand-computed values of the thesis' equations. Given the neighbours'
//! relative positions and headings, the obstacle centres (both in the body frame) and, for an
//! informed UAV, the direction of the goal, it returns a desired velocity in the body frame (the
//! final control vector v_f of eq. 4.2, a reference for the speed tracker) and a yaw rate for
//! heading alignment (eq. 4.14–4.15).
//!
//! The order of computation is section 4.1 / Algorithm 4: cohesion v_c and separation v_s; a
//! first navigation vector v_n1 from v_c, v_s; the desired direction p = v_c + v_s + v_n1 (the
//! text of section 4.1; Algorithm 4 writes the not-yet-computed avoidance vector there); the
//! avoidance vector v_o from p; the navigation vector again from v_c, v_s, v_o; and the weighted
//! sum of eq. 4.1, normalised if longer than 1 and scaled by kf (eq. 4.2).
//!
//! Choices where seed 000 is silent (each is documented at its function):
//! - separation's "desired direction of movement" is the body x axis, the direction the
//!   navigation vector propels (section 4.5); N of eq. 4.9 counts the neighbours that pass the
//!   180° sector test and are inside the separation radius;
//! - avoidance first discards obstacles beyond the avoidance radius or more than
//!   `avoidance_ignore_deg` from the desired direction, then takes the closest remaining one, so
//!   a passed obstacle behind cannot mask one ahead;
//! - degenerate geometry (a neighbour or obstacle exactly at the UAV, a desired direction
//!   pointing straight at the obstacle, headings that cancel) has a defined, finite answer;
//! - non-finite inputs (a NaN position, an infinite obstacle) are ignored, and a non-finite
//!   output (possible only with non-finite parameters) becomes zero, i.e. hover;
//! - the final velocity may approach an obstacle or neighbour centre closer than `barrier_m`,
//!   or a body the caller found inside a scan group that joins several (`Input::bodies`), only
//!   slowly and not at all deeper than `barrier_ramp_m` inside that reach ([`barrier`],
//!   [`within`]), since eq. 4.10–4.13 avoid the closest obstacle only.

use nalgebra::{Matrix2, Vector2};
use swarm_config::{K21Params, SeparationCombine};

/// A neighbouring UAV as this UAV's relative localization sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Neighbour {
    /// Relative position [m], body frame.
    pub pos: Vector2<f64>,
    /// Relative heading [rad]: the neighbour's heading minus ours.
    pub heading: f64,
}

/// Everything one control step needs.
#[derive(Debug, Clone, Copy)]
pub struct Input<'a> {
    /// The neighbours currently localized.
    pub neighbours: &'a [Neighbour],
    /// Obstacle centres [m], body frame.
    pub obstacles: &'a [Vector2<f64>],
    /// Angle of the goal in the body frame [rad] (eq. 4.15 minus own heading); `None` for an
    /// uninformed UAV.
    pub goal_heading: Option<f64>,
    /// The bodies inside scan groups that join several, and the circles of neighbours within
    /// `barrier_m` (body frame): barriers too, by the
    /// centre when it is closer than `barrier_m`, else by the nearest point when that is closer
    /// than `barrier_surface_m` (none of them when either is 0).
    pub bodies: &'a [Body],
}

/// The result of one control step, with the four component vectors for logging and tests.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Output {
    /// Desired velocity [m/s], body frame: v_f of eq. 4.2; its length never exceeds kf.
    pub velocity: Vector2<f64>,
    /// Desired yaw rate [rad/s]: heading_gain · α (eq. 4.14).
    pub yaw_rate: f64,
    /// Cohesion vector v_c (eq. 4.6), unweighted.
    pub cohesion: Vector2<f64>,
    /// Separation vector v_s (eq. 4.9), unweighted.
    pub separation: Vector2<f64>,
    /// Obstacle-avoidance vector v_o (eq. 4.13), unweighted.
    pub avoidance: Vector2<f64>,
    /// Navigation vector v_n (eq. 4.17, second evaluation), unweighted.
    pub navigation: Vector2<f64>,
    /// The velocity before the barrier [m/s], body frame: eq. 4.2's v_f as the seed has it.
    pub wanted: Vector2<f64>,
}

use super::barrier::{barrier, within};
use crate::geometry::{is_finite, EPS};
use crate::world_model::Body;

/// Clip to unit length: v/|v| if |v| > 1, else v (seed 000, eq. 4.6, 4.13 and 4.2 share it).
fn clip_unit(v: Vector2<f64>) -> Vector2<f64> {
    let n = v.norm();
    if n > 1.0 {
        v / n
    } else {
        v
    }
}

/// The vector of least length (the first of equals), if any.
fn nearest(vs: impl Iterator<Item = Vector2<f64>>) -> Option<Vector2<f64>> {
    vs.min_by(|a, b| a.norm_squared().total_cmp(&b.norm_squared()))
}

/// Unit vector along `v`, or the body x axis when `v` is zero or not finite.
pub(super) fn direction_or_x(v: Vector2<f64>) -> Vector2<f64> {
    let n = v.norm();
    if is_finite(&v) && n > EPS {
        v / n
    } else {
        Vector2::x()
    }
}

/// Cohesion vector v_c (seed 000, section 4.2, eq. 4.3–4.6).
///
/// c = Σx_i/(N+1) over the neighbours; when `obstacle_near` only the closest neighbour is used,
/// so c = x_closest/2. k = max(0, 1 − cohesion_radius_m/|c|), v_c = k·c clipped to unit length.
/// No neighbours (or c = 0) gives zero. Neighbours with a non-finite position are ignored.
pub fn cohesion(p: &K21Params, neighbours: &[Neighbour], obstacle_near: bool) -> Vector2<f64> {
    let valid = neighbours.iter().map(|n| n.pos).filter(is_finite);
    let c = if obstacle_near {
        // seed 000 section 4.2: with an obstacle nearby only the closest neighbour counts;
        // eq. 4.3 with N = 1: c = x_closest / 2.
        match nearest(valid) {
            Some(x) => x / 2.0,
            None => return Vector2::zeros(),
        }
    } else {
        let (sum, count) = valid.fold((Vector2::zeros(), 0usize), |(s, k), x| (s + x, k + 1));
        if count == 0 {
            return Vector2::zeros();
        }
        // seed 000, eq. 4.3: c = 1/(N+1) · Σ x_i.
        sum / (count + 1) as f64
    };
    let dist = c.norm();
    if dist <= 0.0 {
        return Vector2::zeros();
    }
    // seed 000, eq. 4.4: k = max(0, 1 − 2.5/|c|), 2.5 = cohesion_radius_m.
    let k = (1.0 - p.cohesion_radius_m / dist).max(0.0);
    // seed 000, eq. 4.5 and 4.6: v_c = k·c, clipped to unit length.
    clip_unit(k * c)
}

/// Separation vector v_s (seed 000, section 4.3, eq. 4.7–4.9).
///
/// Only neighbours in the 180° sector around `desired_dir` count (x_i·d ≥ 0; a neighbour exactly
/// abeam counts), and those closer than `separation_all_around_m` from any direction. For each, k_i = max(−1, 1 − separation_scale_m/|x_i|) and
/// v_i = k_i·x_i/|x_i| if |x_i| ≤ separation_radius_m, else 0. v_s is the mean of the v_i over the
/// neighbours in the sector and inside the radius — N of eq. 4.9 ("the number of all agents used
/// to calculate v_s") is read as the agents that contribute — with `SeparationCombine::Mean`;
/// with `SeparationCombine::ClippedSum` (the default, see the module doc) v_s is their sum clipped
/// to unit length. Counting those beyond the radius would let far neighbours dilute the push of a
/// close one. No such neighbour gives zero.
///
/// `step` passes the body x axis as `desired_dir`: it is the direction the navigation vector
/// propels the UAV (section 4.5), and the heading is aligned with the group and the goal.
/// A zero or non-finite `desired_dir` is replaced by the body x axis. A neighbour at the UAV's
/// own position (|x_i| < 1e-9) has no direction; it is taken as straight along `desired_dir`
/// (k_i = −1, v_i = −d). Neighbours with a non-finite position are ignored.
pub fn separation(p: &K21Params, neighbours: &[Neighbour], desired_dir: Vector2<f64>) -> Vector2<f64> {
    let d = direction_or_x(desired_dir);
    let mut sum = Vector2::zeros();
    let mut count = 0usize;
    for x in neighbours.iter().map(|n| n.pos).filter(is_finite) {
        let dist = x.norm();
        // seed 000 section 4.3: neighbours outside the 180° sector around the desired direction
        // of movement are ignored — except those closer than separation_all_around_m (our
        // choice, module doc: side by side, each UAV may see the other just behind its beam).
        if x.dot(&d) < 0.0 && dist >= p.separation_all_around_m {
            continue;
        }
        // seed 000, eq. 4.8: v_i = 0 if |x_i| > 2 (2 = separation_radius_m).
        if dist > p.separation_radius_m {
            continue;
        }
        // N of eq. 4.9 counts the agents used to calculate v_s: those inside the radius. Counting
        // the far ones too would dilute the push of a close neighbour (one at 0.6 m among three
        // beyond 2 m gave |v_s| = 1/4, left navigation at 3/4 and flew into it).
        count += 1;
        let v_i = if dist > EPS {
            // seed 000, eq. 4.7: k_i = max(−1, 1 − 3/|x_i|), 3 = separation_scale_m.
            let k_i = (1.0 - p.separation_scale_m / dist).max(-1.0);
            // seed 000, eq. 4.8: v_i = k_i · x_i/|x_i|.
            k_i * (x / dist)
        } else {
            // seed 000, eq. 4.7 limit |x_i| → 0: k_i = −1, direction taken as d.
            -d
        };
        sum += v_i;
    }
    if count == 0 {
        return Vector2::zeros();
    }
    match p.separation_combine {
        // seed 000, eq. 4.9: v_s = 1/N · Σ v_i.
        SeparationCombine::Mean => sum / count as f64,
        // Our reading for crowds (see the module doc): Σ v_i clipped to unit length like eq. 4.6.
        SeparationCombine::ClippedSum => clip_unit(sum),
    }
}

/// Obstacle-avoidance vector v_o (seed 000, section 4.4, eq. 4.10–4.13).
///
/// Candidates are the obstacle centres y with |y| ≤ avoidance_radius_m and at most
/// avoidance_ignore_deg from the desired direction; of those only the closest (by centre
/// distance) is used — filtering before choosing means a passed obstacle behind the UAV never
/// masks one ahead. P = I − ŷŷᵀ, v = P·desired, v_o = v/|v| · avoidance_gain_m/|y|, clipped to
/// unit length. No candidate gives zero.
///
/// A zero or non-finite `desired` is replaced by the body x axis. When `desired` points straight
/// at (or away from) the obstacle, v = P·desired vanishes and the tangent is undefined; then v/|v|
/// is taken as ŷ rotated by +90° (pass the obstacle on the right-hand side, i.e. turn left).
/// Obstacle centres closer than 1e-9 m or non-finite are ignored.
pub fn avoidance(p: &K21Params, obstacles: &[Vector2<f64>], desired: Vector2<f64>) -> Vector2<f64> {
    let d = direction_or_x(desired);
    let ignore = p.avoidance_ignore_deg.to_radians();
    let candidates = obstacles.iter().copied().filter(is_finite).filter(|y| {
        let dist = y.norm();
        // seed 000 section 4.4: angle between y and the desired direction, in [0, π];
        // obstacles more than 135° (avoidance_ignore_deg) from it are ignored.
        let angle = (d.x * y.y - d.y * y.x).abs().atan2(d.dot(y));
        dist > EPS && dist <= p.avoidance_radius_m && angle <= ignore
    });
    let Some(y) = nearest(candidates) else {
        return Vector2::zeros();
    };
    let dist = y.norm();
    let y_hat = y / dist;
    // seed 000, eq. 4.10: P = I − (y/|y|)(y/|y|)ᵀ.
    let proj = Matrix2::identity() - y_hat * y_hat.transpose();
    // seed 000, eq. 4.11: v = P·p.
    let v = proj * d;
    let v_norm = v.norm();
    let v_dir = if v_norm > EPS {
        v / v_norm
    } else {
        // Desired direction along ŷ: take ŷ rotated by +90°, (−ŷ_y, ŷ_x).
        Vector2::new(-y_hat.y, y_hat.x)
    };
    // seed 000, eq. 4.12: v_o = v/|v| · 2/|y|, 2 = avoidance_gain_m; eq. 4.13: clip to unit length.
    clip_unit(v_dir * (p.avoidance_gain_m / dist))
}

/// Navigation vector v_n (seed 000, section 4.5, eq. 4.16–4.17).
///
/// k_n = |v_c| + |v_s| + |v_o|; v_n = (1 − k_n)·(1, 0) if k_n ≤ 1, else 0. The parameters are not
/// used by eq. 4.17; `_p` keeps the signature uniform with the other vectors.
pub fn navigation(_p: &K21Params, vc: Vector2<f64>, vs: Vector2<f64>, vo: Vector2<f64>) -> Vector2<f64> {
    // seed 000, eq. 4.16: k_n = |v_c| + |v_s| + |v_o|.
    let k_n = vc.norm() + vs.norm() + vo.norm();
    // seed 000, eq. 4.17: v_n = (1 − k_n)·x̂ if k_n ≤ 1, else 0 (a NaN k_n gives 0).
    if k_n <= 1.0 {
        Vector2::new(1.0 - k_n, 0.0)
    } else {
        Vector2::zeros()
    }
}

/// Heading-alignment angle α [rad] (seed 000, section 4.5, eq. 4.14–4.15).
///
/// α = atan2(Σ sin Θ_i, Σ cos Θ_i) over the neighbours' relative headings plus a virtual agent
/// whose relative heading is `goal_heading` (eq. 4.15, already in the body frame) when `Some`.
/// The UAV itself is not one of the agents. No agents gives 0. When the headings cancel (their
/// resultant is shorter than 1e-9 times their count, e.g. 0 and π) the mean is undefined and 0 is
/// returned (keep the heading). Non-finite headings are ignored.
pub fn alignment(neighbours: &[Neighbour], goal_heading: Option<f64>) -> f64 {
    let headings = neighbours.iter().map(|n| n.heading).chain(goal_heading).filter(|h| h.is_finite());
    let (mut sum_sin, mut sum_cos, mut count) = (0.0, 0.0, 0usize);
    for h in headings {
        sum_sin += h.sin();
        sum_cos += h.cos();
        count += 1;
    }
    if count == 0 || sum_sin.hypot(sum_cos) <= EPS * count as f64 {
        return 0.0;
    }
    // seed 000, eq. 4.14: α = atan2(Σ sin Θ_i, Σ cos Θ_i).
    sum_sin.atan2(sum_cos)
}

/// The closest finite obstacle centre [m], body frame.
fn nearest_obstacle(obstacles: &[Vector2<f64>]) -> Option<Vector2<f64>> {
    nearest(obstacles.iter().copied().filter(is_finite))
}

/// The neighbours closer than `neighbour_radius_m`, in their original order (so that with every
/// neighbour in reach the sums below add in the same order as without the filter).
pub fn within_reach(p: &K21Params, neighbours: &[Neighbour]) -> Vec<Neighbour> {
    neighbours.iter().copied().filter(|n| n.pos.norm() <= p.neighbour_radius_m).collect()
}

/// `v` without its component towards the obstacle centre `y` (body frame); a component away
/// from it is kept. Our reading of seed 000 section 4.6 ("prioritize the obstacle avoidance
/// vector"): near a tree, the crowd's cohesion and separation may slide a UAV along the tree or
/// away from it, never into it, so the tangential avoidance vector (eq. 4.12) keeps its room.
pub fn not_towards(v: Vector2<f64>, y: Vector2<f64>) -> Vector2<f64> {
    let y_hat = direction_or_x(y);
    let towards = v.dot(&y_hat);
    if towards > 0.0 {
        v - towards * y_hat
    } else {
        v
    }
}

/// One K21 control step (seed 000, section 4.1, Algorithm 4; eq. 4.1–4.2).
///
/// Only the neighbours within `p.neighbour_radius_m` are used ([`within_reach`]). "An obstacle
/// nearby" for cohesion: the nearest obstacle centre is closer than `p.obstacle_near_m`, whatever
/// its direction; with `p.obstacle_priority` v_c and v_s then lose their component towards it
/// ([`not_towards`]). Separation uses the body x axis as the desired direction. Then p = v_c + v_s + v_n1 with v_n1 = navigation(v_c, v_s, 0), v_o = avoidance(p),
/// v_n = navigation(v_c, v_s, v_o), v = kc·v_c + ks·v_s + ko·v_o + kn·v_n, normalised if |v| > 1,
/// times kf, then with its component towards an obstacle or a neighbour closer than
/// `p.barrier_m`, or towards a body of `input.bodies`, limited by the graded barrier
/// ([`barrier`], [`within`]); `p.barrier_m = 0` turns the whole barrier off,
/// `p.barrier_surface_m = 0` the bodies'.
/// yaw_rate = heading_gain·α. A non-finite velocity or yaw rate (only possible with
/// non-finite parameters) is replaced by zero.
pub fn step(p: &K21Params, input: &Input) -> Output {
    let nearest = nearest_obstacle(input.obstacles);
    // seed 000 section 4.2: "an obstacle nearby" switches cohesion to the closest neighbour.
    let near_obstacle = nearest.filter(|y| y.norm() < p.obstacle_near_m);
    let neighbours = within_reach(p, input.neighbours);

    let mut vc = cohesion(p, &neighbours, near_obstacle.is_some());
    let mut vs = separation(p, &neighbours, Vector2::x());
    if let (true, Some(y)) = (p.obstacle_priority, near_obstacle) {
        vc = not_towards(vc, y);
        vs = not_towards(vs, y);
    }
    let vn1 = navigation(p, vc, vs, Vector2::zeros());
    // seed 000 section 4.1: p = v_c + v_s + v_n, the desired direction for avoidance.
    let desired = vc + vs + vn1;
    let vo = avoidance(p, input.obstacles, desired);
    let vn = navigation(p, vc, vs, vo);

    // seed 000, eq. 4.1: v = kc·v_c + ks·v_s + ko·v_o + kn·v_n.
    let v = p.kc * vc + p.ks * vs + p.ko * vo + p.kn * vn;
    // seed 000, eq. 4.2: v_f = v/|v|·kf if |v| > 1, else v·kf.
    let wanted = clip_unit(v) * p.kf;
    let mut velocity = barrier(wanted, barrier_points(p, input));
    if !is_finite(&velocity) {
        velocity = Vector2::zeros();
    }

    // seed 000, eq. 4.14: turn towards the mean relative heading α.
    let mut yaw_rate = p.heading_gain * alignment(&neighbours, input.goal_heading);
    if !yaw_rate.is_finite() {
        yaw_rate = 0.0;
    }

    Output { velocity, yaw_rate, cohesion: vc, separation: vs, avoidance: vo, navigation: vn, wanted }
}

/// The points the barrier holds the final velocity off, each with its allowance [m/s] (our
/// extension, [`step`]): every obstacle, neighbour and body centre closer than barrier_m, and
/// the nearest point closer than barrier_surface_m of a body whose centre is not (none fits,
/// or one fits so far behind its points that it would miss them).
pub fn barrier_points(p: &K21Params, input: &Input) -> Vec<(Vector2<f64>, f64)> {
    let bodies = if p.barrier_on_bodies() { input.bodies } else { &[] };
    let centred = |b: &&Body| b.centre.is_some_and(|c| c.norm() < p.barrier_m);
    let body_centres = bodies.iter().filter(centred).filter_map(|b| b.centre.as_ref());
    let centres = input.obstacles.iter().chain(input.neighbours.iter().map(|n| &n.pos)).chain(body_centres);
    let nearest = bodies.iter().filter(|b| !centred(b)).map(|b| &b.nearest);
    let ramp = p.barrier_ramp_m;
    within(centres, p.barrier_m, ramp, p.kf).chain(within(nearest, p.barrier_surface_m, ramp, p.kf)).collect()
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI};

    fn params() -> K21Params {
        K21Params::default()
    }

    fn nb(x: f64, y: f64) -> Neighbour {
        Neighbour { pos: Vector2::new(x, y), heading: 0.0 }
    }

    fn v(x: f64, y: f64) -> Vector2<f64> {
        Vector2::new(x, y)
    }

    #[track_caller]
    fn close(a: Vector2<f64>, b: Vector2<f64>, tol: f64) {
        assert!((a - b).norm() < tol, "{a:?} != {b:?}");
    }

    #[test]
    fn defaults_are_the_seed_numbers() {
        let p = params();
        assert_eq!(
            (
                p.cohesion_radius_m,
                p.separation_scale_m,
                p.separation_radius_m,
                p.avoidance_gain_m,
                p.avoidance_ignore_deg,
                p.kf
            ),
            (2.5, 3.0, 2.0, 2.0, 135.0, 0.4)
        );
        // Our choices where the seed is silent (module doc): 5 m reach, 1.2 m all around,
        // clipped sum, priority.
        assert_eq!(
            (p.neighbour_radius_m, p.separation_all_around_m, p.separation_combine, p.obstacle_priority),
            (5.0, 1.2, SeparationCombine::ClippedSum, true)
        );
    }

    #[test]
    fn cohesion_inside_dead_radius_is_zero() {
        // (4,0),(0,4): c = (4,4)/3 = (1.3333,1.3333), |c| = 1.8856 < 2.5 → k = max(0, −0.3258) = 0.
        close(cohesion(&params(), &[nb(4.0, 0.0), nb(0.0, 4.0)], false), v(0.0, 0.0), 1e-15);
    }

    #[test]
    fn cohesion_far_pair_is_clipped() {
        // (6,0),(6,0): c = (12,0)/3 = (4,0), k = 1 − 2.5/4 = 0.375, v_c = (1.5,0) → clipped (1,0).
        close(cohesion(&params(), &[nb(6.0, 0.0), nb(6.0, 0.0)], false), v(1.0, 0.0), 1e-12);
    }

    #[test]
    fn cohesion_unclipped() {
        // (0,6): c = (0,6)/2 = (0,3), k = 1 − 2.5/3 = 1/6, v_c = (0,0.5).
        close(cohesion(&params(), &[nb(0.0, 6.0)], false), v(0.0, 0.5), 1e-12);
        // (3,4),(3,4),(3,4): c = (9,12)/4 = (2.25,3), |c| = 3.75, k = 1 − 2.5/3.75 = 1/3,
        // v_c = (0.75,1.0), |v_c| = 1.25 → clipped (0.6,0.8).
        close(cohesion(&params(), &[nb(3.0, 4.0); 3], false), v(0.6, 0.8), 1e-12);
    }

    #[test]
    fn cohesion_obstacle_near_uses_closest_only() {
        let ns = [nb(0.0, 20.0), nb(6.0, 0.0)];
        // All: c = (6,20)/3 = (2,6.6667), |c| = 6.9602, k = 1 − 2.5/6.9602 = 0.64082,
        // v_c = (1.2816,4.2721), |v_c| = 4.4602 → clipped c/|c| = (0.28735,0.95783).
        close(cohesion(&params(), &ns, false), v(2.0, 20.0 / 3.0) / (4.0f64 + 400.0 / 9.0).sqrt(), 1e-12);
        // Obstacle near: closest (6,0), c = (3,0), k = 1 − 2.5/3 = 1/6, v_c = (0.5,0).
        close(cohesion(&params(), &ns, true), v(0.5, 0.0), 1e-12);
    }

    #[test]
    fn cohesion_no_neighbours_is_zero() {
        close(cohesion(&params(), &[], false), v(0.0, 0.0), 1e-15);
        close(cohesion(&params(), &[], true), v(0.0, 0.0), 1e-15);
        // A NaN neighbour is ignored: as if absent.
        let nan = Neighbour { pos: v(f64::NAN, 1.0), heading: 0.0 };
        close(cohesion(&params(), &[nan], false), v(0.0, 0.0), 1e-15);
        // A neighbour at the origin: c = 0 → zero.
        close(cohesion(&params(), &[nb(0.0, 0.0)], false), v(0.0, 0.0), 1e-15);
    }

    #[test]
    fn separation_single_neighbour_ahead() {
        let p = params();
        let x = v(1.0, 0.0);
        // (1,0): k = 1 − 3/1 = −2 → −1, v = −1·(1,0) = (−1,0).
        close(separation(&p, &[nb(1.0, 0.0)], x), v(-1.0, 0.0), 1e-12);
        // (1.5,0): k = 1 − 3/1.5 = −1, v = (−1,0).
        close(separation(&p, &[nb(1.5, 0.0)], x), v(-1.0, 0.0), 1e-12);
        // (2,0): k = 1 − 3/2 = −0.5, v = (−0.5,0).
        close(separation(&p, &[nb(2.0, 0.0)], x), v(-0.5, 0.0), 1e-12);
        // (1.2,1.6): |x| = 2, k = −0.5, v = −0.5·(0.6,0.8) = (−0.3,−0.4).
        close(separation(&p, &[nb(1.2, 1.6)], x), v(-0.3, -0.4), 1e-12);
        // (1,1): |x| = √2, k = 1 − 3/√2 = −1.1213 → −1, v = −(1,1)/√2 = (−0.70711,−0.70711).
        close(separation(&p, &[nb(1.0, 1.0)], x), -v(1.0, 1.0) / 2f64.sqrt(), 1e-12);
        // (2.5,0): beyond the 2 m radius → v_i = 0.
        close(separation(&p, &[nb(2.5, 0.0)], x), v(0.0, 0.0), 1e-15);
    }

    #[test]
    fn separation_ignores_neighbours_behind() {
        let p = params();
        let x = v(1.0, 0.0);
        // (−1.5,0): x·d = −1.5 < 0 and 1.5 m ≥ 1.2 m → ignored, N = 0 → zero.
        close(separation(&p, &[nb(-1.5, 0.0)], x), v(0.0, 0.0), 1e-15);
        // (1,0) and (−1.5,0): only (1,0) counts, N = 1 → (−1,0).
        close(separation(&p, &[nb(1.0, 0.0), nb(-1.5, 0.0)], x), v(-1.0, 0.0), 1e-12);
        // (0,1.5) exactly abeam: x·d = 0 ≥ 0 → counts; k = −1 → (0,−1).
        close(separation(&p, &[nb(0.0, 1.5)], x), v(0.0, -1.0), 1e-12);
        // Desired direction (0,1): (1,0) abeam counts → (−1,0); (0,−1.5) behind is ignored.
        close(separation(&p, &[nb(1.0, 0.0), nb(0.0, -1.5)], v(0.0, 3.0)), v(-1.0, 0.0), 1e-12);
    }

    #[test]
    fn separation_counts_a_very_close_neighbour_behind() {
        let p = params();
        let x = v(1.0, 0.0);
        // Side by side, just behind the beam: (−0.03,0.8), |x| = 0.80056 < 1.2 m → counts,
        // k = −1 → v = −(−0.03,0.8)/0.80056 = (0.03747,−0.99930).
        let s = separation(&p, &[nb(-0.03, 0.8)], x);
        close(s, -v(-0.03, 0.8) / v(-0.03, 0.8).norm(), 1e-12);
        // The same neighbour at 1.3 m behind the beam is ignored (section 4.3's sector).
        close(separation(&p, &[nb(-0.05, 1.3)], x), v(0.0, 0.0), 1e-15);
        // With the all-around distance at 0 the sector rule alone applies.
        let sector_only = K21Params { separation_all_around_m: 0.0, ..params() };
        close(separation(&sector_only, &[nb(-0.03, 0.8)], x), v(0.0, 0.0), 1e-15);
    }

    #[test]
    fn separation_mean_over_sector_neighbours() {
        let p = params();
        let x = v(1.0, 0.0);
        // (2,0) → (−0.5,0); (2.5,0) in the sector but beyond 2 m is not used: N = 1 → (−0.5,0).
        close(separation(&p, &[nb(2.0, 0.0), nb(2.5, 0.0)], x), v(-0.5, 0.0), 1e-12);
        // One neighbour at 0.6 m among three beyond 2 m: full push, k = max(−1, 1 − 3/0.6) = −1.
        let crowd = [nb(0.6, 0.0), nb(3.0, 1.0), nb(4.0, -1.0), nb(2.5, 0.5)];
        close(separation(&p, &crowd, x), v(-1.0, 0.0), 1e-12);
        // (1,0) → (−1,0); (0,−2) → k = −0.5, (0,0.5); (−1.5,0) behind, ignored; N = 2 → (−0.5,0.25).
        let mean = K21Params { separation_combine: SeparationCombine::Mean, ..params() };
        let three = [nb(1.0, 0.0), nb(0.0, -2.0), nb(-1.5, 0.0)];
        close(separation(&mean, &three, x), v(-0.5, 0.25), 1e-12);
        // Clipped sum: (−1,0.5), |·| = 1.11803 > 1 → (−0.89443,0.44721).
        close(separation(&p, &three, x), v(-1.0, 0.5) / 1.25f64.sqrt(), 1e-12);
    }

    #[test]
    fn separation_in_a_crowd_pushes_away_from_the_nearest() {
        // One neighbour 0.7 m ahead and two symmetric pairs within 2 m: (0.7,0) → k = −1, (−1,0);
        // (1.5,±1.2): |x| = 1.92094, k = −0.56173, v = (−0.43862,∓0.35089);
        // (0.3,±1.9): |x| = 1.92354, k = −0.55963, v = (−0.08728,∓0.55277).
        let crowd = [nb(0.7, 0.0), nb(1.5, 1.2), nb(1.5, -1.2), nb(0.3, 1.9), nb(0.3, -1.9)];
        let x = v(1.0, 0.0);
        // Clipped sum: Σ = (−2.05185,0) → (−1,0), the full push away from the nearest.
        close(separation(&params(), &crowd, x), v(-1.0, 0.0), 1e-12);
        // Eq. 4.9's mean: (−0.41037,0), which would leave navigation 0.59 of its thrust towards
        // the neighbour at 0.7 m.
        let mean = K21Params { separation_combine: SeparationCombine::Mean, ..params() };
        close(separation(&mean, &crowd, x), v(-0.410_369_6, 0.0), 1e-6);
    }

    #[test]
    fn within_reach_keeps_near_neighbours_in_order() {
        let p = params();
        let ns = [nb(0.0, 4.9), nb(5.1, 0.0), nb(-3.0, -4.0), nb(1.0, 0.0)];
        // |x| = 4.9, 5.1, 5.0 (on the boundary: kept), 1.0.
        assert_eq!(within_reach(&p, &ns), vec![ns[0], ns[2], ns[3]]);
        let nan = Neighbour { pos: v(f64::NAN, 0.0), heading: 0.0 };
        assert_eq!(within_reach(&p, &[nan]), vec![]);
    }

    #[test]
    fn not_towards_removes_only_the_approach() {
        // Obstacle at (2,0): (1,1) loses its x part → (0,1); (−1,1) moves away → kept.
        close(not_towards(v(1.0, 1.0), v(2.0, 0.0)), v(0.0, 1.0), 1e-15);
        close(not_towards(v(-1.0, 1.0), v(2.0, 0.0)), v(-1.0, 1.0), 1e-15);
        // Obstacle at (1,1): (1,0)·ŷ = 0.70711 → (1,0) − 0.5·(1,1) = (0.5,−0.5).
        close(not_towards(v(1.0, 0.0), v(1.0, 1.0)), v(0.5, -0.5), 1e-12);
    }

    #[test]
    fn step_front_of_a_crowd_flies_on() {
        // The UAV leads a 5 × 7 lattice of 2.1 m spacing (34 neighbours, 8.4 m deep), no obstacle.
        let ns: Vec<Neighbour> = (0..5)
            .flat_map(|i| (-3..=3).map(move |j| nb(-2.1 * f64::from(i), 2.1 * f64::from(j))))
            .filter(|n| n.pos.norm() > 0.0)
            .collect();
        let input = Input { neighbours: &ns, obstacles: &[], goal_heading: Some(0.0), bodies: &[] };
        // Within 5 m: 12 neighbours, c = (−21.32,0)/13 = (−1.77692,0), inside 2.5 m → v_c = 0;
        // none within 2 m → v_s = 0; v_n = (1,0) → (0.4,0).
        let out = step(&params(), &input);
        close(out.cohesion, v(0.0, 0.0), 1e-15);
        close(out.velocity, v(0.4, 0.0), 1e-12);
        // Seeing all 34: c = (−142.8,0)/35 = (−4.2,0), k = 1 − 2.5/4.2 → v_c = (−1.7,0) clipped to
        // (−1,0), v_n = 0: the front flies backwards into the crowd (the drift).
        let all = K21Params { neighbour_radius_m: 100.0, ..params() };
        let out = step(&all, &input);
        close(out.cohesion, v(-1.0, 0.0), 1e-12);
        close(out.velocity, v(-0.4, 0.0), 1e-12);
    }

    #[test]
    fn step_crowd_does_not_push_into_a_tree() {
        // Neighbour abeam at (0,−1.2) → v_s = (0,1) (k = −1); tree centre at (0,2) is nearby
        // (2 m < 2.5 m) and 90° off the desired direction, so v_o is tangential, (1,0)·(2/2) = (1,0).
        let ns = [nb(0.0, -1.2)];
        let input = Input { neighbours: &ns, obstacles: &[v(0.0, 2.0)], goal_heading: Some(0.0), bodies: &[] };
        // With priority v_s loses its part towards the tree → 0; p = (1,0), v_o = (1,0), v_n = 0:
        // v_f = (0.4,0), along the tree.
        let out = step(&params(), &input);
        close(out.separation, v(0.0, 0.0), 1e-15);
        close(out.velocity, v(0.4, 0.0), 1e-12);
        // Without: v_s = (0,1), v_n1 = 0, p = (0,1) points at the tree → v_o = ŷ rotated +90° ·
        // 2/2 = (−1,0); v = (−1,1) → v_f = 0.4·(−1,1)/√2: towards the tree.
        let off = K21Params { obstacle_priority: false, ..params() };
        let out = step(&off, &input);
        close(out.separation, v(0.0, 1.0), 1e-12);
        close(out.velocity, 0.4 * v(-1.0, 1.0) / 2f64.sqrt(), 1e-12);
    }

    #[test]
    fn separation_degenerate_cases() {
        let p = params();
        // A neighbour at our own position is taken as straight ahead: v = −d = (−1,0).
        close(separation(&p, &[nb(0.0, 0.0)], v(1.0, 0.0)), v(-1.0, 0.0), 1e-12);
        // Zero desired direction → body x: (−1.5,0) is behind it.
        close(separation(&p, &[nb(1.0, 0.0), nb(-1.5, 0.0)], v(0.0, 0.0)), v(-1.0, 0.0), 1e-12);
        // Non-finite neighbour ignored.
        let nan = Neighbour { pos: v(f64::NAN, 0.5), heading: 0.0 };
        close(separation(&p, &[nan], v(1.0, 0.0)), v(0.0, 0.0), 1e-15);
    }

    #[test]
    fn avoidance_tangential_hand_computed() {
        let p = params();
        // y = (2,1), p = (1,0): ŷ = (2,1)/√5, P(1,0) = (1 − 4/5, −2/5) = (0.2,−0.4),
        // /|·| = (0.4472,−0.8944), × 2/√5 = 0.8944 → (0.4,−0.8).
        close(avoidance(&p, &[v(2.0, 1.0)], v(1.0, 0.0)), v(0.4, -0.8), 1e-12);
        // Only the direction of p matters: p = (3,0) gives the same.
        close(avoidance(&p, &[v(2.0, 1.0)], v(3.0, 0.0)), v(0.4, -0.8), 1e-12);
        // y = (1,2), p = (0,1): ŷ = (1,2)/√5, P(0,1) = (0,1) − (2/5)(1,2) = (−0.4,0.2),
        // /|·| = (−0.8944,0.4472), × 2/√5 = 0.8944 → (−0.8,0.4).
        close(avoidance(&p, &[v(1.0, 2.0)], v(0.0, 1.0)), v(-0.8, 0.4), 1e-12);
    }

    #[test]
    fn avoidance_close_obstacle_is_clipped() {
        // y = (1,1), p = (1,0): P(1,0) = (1,0) − (1/2)(1,1) = (0.5,−0.5) → (0.70711,−0.70711),
        // × 2/√2 = 1.4142 → |v_o| > 1 → clipped (0.70711,−0.70711).
        close(avoidance(&params(), &[v(1.0, 1.0)], v(1.0, 0.0)), v(1.0, -1.0) / 2f64.sqrt(), 1e-12);
    }

    #[test]
    fn avoidance_ignores_obstacles_behind_and_far() {
        let p = params();
        let x = v(1.0, 0.0);
        // y = (−2,0.5): angle = 180° − atan(0.5/2) = 165.96° > 135° → ignored.
        close(avoidance(&p, &[v(-2.0, 0.5)], x), v(0.0, 0.0), 1e-15);
        // y = (−1,1.2): angle = 180° − atan(1.2) = 129.81° ≤ 135° → active. |y| = √2.44 = 1.5620,
        // tangent ⟂ y with positive x: (1.2,1)/√2.44 = (0.76822,0.64018); × 2/1.5620 = 1.2804 > 1
        // → clipped (0.76822,0.64018).
        close(avoidance(&p, &[v(-1.0, 1.2)], x), v(1.2, 1.0) / 2.44f64.sqrt(), 1e-12);
        // y = (5,0.1): |y| = 5.001 > 4 m → ignored.
        close(avoidance(&p, &[v(5.0, 0.1)], x), v(0.0, 0.0), 1e-15);
        // No obstacles → zero.
        close(avoidance(&p, &[], x), v(0.0, 0.0), 1e-15);
    }

    #[test]
    fn avoidance_uses_closest_eligible_obstacle() {
        let p = params();
        let x = v(1.0, 0.0);
        // (2,1): |y| = 2.236; (3,−1): |y| = 3.162 → (2,1) wins → (0.4,−0.8).
        close(avoidance(&p, &[v(3.0, -1.0), v(2.0, 1.0)], x), v(0.4, -0.8), 1e-12);
        // (−1,0) is closer but 180° behind: ignored first, so (2,1) is still avoided.
        close(avoidance(&p, &[v(-1.0, 0.0), v(2.0, 1.0)], x), v(0.4, -0.8), 1e-12);
    }

    #[test]
    fn the_barrier_keeps_off_the_bodies_of_a_joined_group() {
        // A crowd's group fitted as one circle 1.13 m ahead and right, a neighbour to cohere with
        // ahead and left, and inside the group a UAV 0.78 m ahead and left (0.48 m to its surface).
        let p = params();
        let uav = v(0.72, 0.3);
        let surface = uav * (1.0 - 0.3 / uav.norm());
        let ns = [nb(2.2, 0.9)];
        let obstacles = [v(1.1, -0.25)];
        let towards = |p: &K21Params, bodies: &[Body]| {
            let out = step(p, &Input { neighbours: &ns, obstacles: &obstacles, goal_heading: None, bodies });
            out.velocity.dot(&uav.normalize())
        };
        assert!(towards(&p, &[]) > 0.05, "without the body it flies into the UAV");
        let both = Body { nearest: surface, centre: Some(uav) };
        assert!(towards(&p, &[both]) <= 1e-9);
        // Known only by its nearest point; or with a centre fitted too far behind its points to
        // count (a centre within reach stands for the body instead of its nearest point).
        assert!(towards(&p, &[Body { nearest: surface, centre: None }]) <= 1e-9);
        assert!(towards(&p, &[Body { nearest: surface, centre: Some(uav * 2.0) }]) <= 1e-9);
        // Beyond reach: a centre at 1 m or more with its nearest point at 0.7 m or more.
        assert!(towards(&p, &[Body { nearest: uav.normalize() * 0.75, centre: Some(uav * 1.3) }]) > 0.05);
        // Either switch at 0 turns the bodies off.
        for off in [K21Params { barrier_surface_m: 0.0, ..params() }, K21Params { barrier_m: 0.0, ..params() }] {
            assert!(towards(&off, &[both]) > 0.05);
        }
    }

    #[test]
    fn avoidance_degenerate_cases() {
        let p = params();
        // Head-on: y = (3,0), p = (1,0): P p = 0 → ŷ rotated +90° = (0,1), × 2/3 → (0,0.66667).
        close(avoidance(&p, &[v(3.0, 0.0)], v(1.0, 0.0)), v(0.0, 2.0 / 3.0), 1e-12);
        // Zero desired direction → body x: same as p = (1,0) → (0.4,−0.8).
        close(avoidance(&p, &[v(2.0, 1.0)], v(0.0, 0.0)), v(0.4, -0.8), 1e-12);
        // Obstacle at the origin or non-finite: ignored.
        close(avoidance(&p, &[v(0.0, 0.0), v(f64::NAN, 1.0), v(f64::INFINITY, 0.0)], v(1.0, 0.0)), v(0.0, 0.0), 1e-15);
    }

    #[test]
    fn navigation_hand_computed() {
        let p = params();
        // k_n = |(0.1,0)| + |(0,−0.1)| + |(0.06,0.08)| = 0.1 + 0.1 + 0.1 = 0.3 → (0.7,0).
        close(navigation(&p, v(0.1, 0.0), v(0.0, -0.1), v(0.06, 0.08)), v(0.7, 0.0), 1e-12);
        // k_n = 0.6 + 0.6 + 0 = 1.2 > 1 → 0.
        close(navigation(&p, v(0.6, 0.0), v(0.0, 0.6), v(0.0, 0.0)), v(0.0, 0.0), 1e-15);
        // k_n = 0 → (1,0); k_n = 1 → (0,0) from the first branch.
        close(navigation(&p, v(0.0, 0.0), v(0.0, 0.0), v(0.0, 0.0)), v(1.0, 0.0), 1e-15);
        close(navigation(&p, v(0.5, 0.0), v(0.0, 0.5), v(0.0, 0.0)), v(0.0, 0.0), 1e-15);
    }

    #[test]
    fn alignment_hand_computed() {
        let ns = [Neighbour { pos: v(1.0, 0.0), heading: 0.1 }, Neighbour { pos: v(0.0, 1.0), heading: -0.3 }];
        // Σ sin = sin 0.1 + sin(−0.3) + sin 0.5 = 0.099833 − 0.295520 + 0.479426 = 0.283739,
        // Σ cos = 0.995004 + 0.955336 + 0.877583 = 2.827923; α = atan2(0.283739, 2.827923) = 0.1
        // (the headings 0.1 ± 0.4 and 0.1 are symmetric about 0.1).
        let a = alignment(&ns, Some(0.5));
        assert!((a - 0.1).abs() < 1e-12, "{a}");
        assert!((a - 0.283_738_748_589_691_6f64.atan2(2.827_923_216_294_004_7)).abs() < 1e-12);
        // Headings 0, π/2 and goal π/2: Σ sin = 2, Σ cos = 1 → α = atan2(2,1) = 1.1071487.
        let ns = [Neighbour { pos: v(1.0, 0.0), heading: 0.0 }, Neighbour { pos: v(0.0, 1.0), heading: FRAC_PI_2 }];
        assert!((alignment(&ns, Some(FRAC_PI_2)) - 2f64.atan2(1.0)).abs() < 1e-12);
        // Without the goal: Σ sin = 1, Σ cos = 1 → π/4.
        assert!((alignment(&ns, None) - PI / 4.0).abs() < 1e-12);
    }

    #[test]
    fn alignment_edge_cases() {
        // Nothing → 0.
        assert_eq!(alignment(&[], None), 0.0);
        // Goal only: α = the goal heading, wrapped to (−π, π]: 3.5 → 3.5 − 2π = −2.78319.
        assert!((alignment(&[], Some(2.0)) - 2.0).abs() < 1e-12);
        assert!((alignment(&[], Some(3.5)) - (3.5 - 2.0 * PI)).abs() < 1e-12);
        // Headings 0 and π cancel: mean undefined → 0.
        let ns = [Neighbour { pos: v(1.0, 0.0), heading: 0.0 }, Neighbour { pos: v(0.0, 1.0), heading: PI }];
        assert_eq!(alignment(&ns, None), 0.0);
        // A NaN heading and a NaN goal are ignored.
        let ns = [Neighbour { pos: v(1.0, 0.0), heading: f64::NAN }, Neighbour { pos: v(0.0, 1.0), heading: 0.3 }];
        assert!((alignment(&ns, Some(f64::NAN)) - 0.3).abs() < 1e-12);
    }

    #[test]
    fn step_free_flight_goal_ahead() {
        // No neighbours, no obstacles: v_c = v_s = v_o = 0, v_n = (1,0), v = (1,0), v_f = 0.4·(1,0).
        let out = step(&params(), &Input { neighbours: &[], obstacles: &[], goal_heading: Some(0.0), bodies: &[] });
        close(out.velocity, v(0.4, 0.0), 1e-15);
        assert_eq!(out.yaw_rate, 0.0);
        close(out.navigation, v(1.0, 0.0), 1e-15);
        // Goal to the left: same velocity, yaw rate = 1·0.7.
        let out = step(&params(), &Input { neighbours: &[], obstacles: &[], goal_heading: Some(0.7), bodies: &[] });
        close(out.velocity, v(0.4, 0.0), 1e-15);
        assert!((out.yaw_rate - 0.7).abs() < 1e-12);
        // kf and heading_gain scale the outputs.
        let p = K21Params { kf: 1.5, heading_gain: 2.0, ..params() };
        let out = step(&p, &Input { neighbours: &[], obstacles: &[], goal_heading: Some(0.7), bodies: &[] });
        close(out.velocity, v(1.5, 0.0), 1e-15);
        assert!((out.yaw_rate - 1.4).abs() < 1e-12);
    }

    #[test]
    fn step_equilibrium_behind_a_neighbour() {
        // Neighbour at (2,0), heading 0.2; no obstacle; uninformed.
        // v_c: c = (1,0), |c| < 2.5 → 0. v_s: k = −0.5 → (−0.5,0), N = 1.
        // v_n1 = (1 − 0.5)·x̂ = (0.5,0); p = (0,0) → no obstacle anyway, v_o = 0.
        // v_n = (0.5,0); v = 0 + (−0.5,0) + 0 + (0.5,0) = 0 → hover. α = 0.2 → yaw 0.2.
        let ns = [Neighbour { pos: v(2.0, 0.0), heading: 0.2 }];
        let out = step(&params(), &Input { neighbours: &ns, obstacles: &[], goal_heading: None, bodies: &[] });
        close(out.separation, v(-0.5, 0.0), 1e-12);
        close(out.navigation, v(0.5, 0.0), 1e-12);
        close(out.velocity, v(0.0, 0.0), 1e-12);
        assert!((out.yaw_rate - 0.2).abs() < 1e-12);
    }

    #[test]
    fn step_obstacle_hand_computed() {
        // Obstacle at (2,1), nothing else: v_c = v_s = 0, v_n1 = (1,0), p = (1,0),
        // v_o = (0.4,−0.8) (see avoidance_tangential_hand_computed), |v_o| = 0.89443,
        // v_n = (1 − 0.89443, 0) = (0.10557,0), v = (0.50557,−0.8), |v| = 0.94636 ≤ 1,
        // v_f = 0.4·v = (0.20223,−0.32).
        let out = step(
            &params(),
            &Input { neighbours: &[], obstacles: &[v(2.0, 1.0)], goal_heading: Some(0.0), bodies: &[] },
        );
        close(out.avoidance, v(0.4, -0.8), 1e-12);
        let kn = 1.0 - 0.8f64.sqrt();
        close(out.navigation, v(kn, 0.0), 1e-12);
        close(out.velocity, 0.4 * v(0.4 + kn, -0.8), 1e-12);
        // Weights: ko = 2 → v = (0.8 + 0.10557, −1.6), |v| > 1 → normalised, × 0.4.
        let p = K21Params { ko: 2.0, ..params() };
        let out = step(&p, &Input { neighbours: &[], obstacles: &[v(2.0, 1.0)], goal_heading: Some(0.0), bodies: &[] });
        close(out.velocity, 0.4 * v(0.8 + kn, -1.6).normalize(), 1e-12);
    }

    #[test]
    fn step_obstacle_near_switches_cohesion() {
        // Obstacle (−2,0) is behind (no avoidance) but 2 m < 2.5 m away → cohesion uses only the
        // closest neighbour (6,0): v_c = (0.5,0) (see cohesion_obstacle_near_uses_closest_only).
        let ns = [nb(0.0, 20.0), nb(6.0, 0.0)];
        // Both neighbours beyond the default 5 m reach: widen it so that they count.
        let wide = K21Params { neighbour_radius_m: 100.0, ..params() };
        let out = step(&wide, &Input { neighbours: &ns, obstacles: &[v(-2.0, 0.0)], goal_heading: None, bodies: &[] });
        close(out.cohesion, v(0.5, 0.0), 1e-12);
        close(out.avoidance, v(0.0, 0.0), 1e-15);
        // v_s = 0 ((6,0) beyond 2 m, (0,20) beyond 2 m; N = 2); v_n = (0.5,0); v = (1,0) → (0.4,0).
        close(out.velocity, v(0.4, 0.0), 1e-12);
        // Without the obstacle all neighbours count and v_c = c/|c| (clipped).
        let out = step(&wide, &Input { neighbours: &ns, obstacles: &[], goal_heading: None, bodies: &[] });
        close(out.cohesion, v(2.0, 20.0 / 3.0).normalize(), 1e-12);
    }

    #[test]
    fn step_ignores_non_finite_inputs() {
        let ns = [Neighbour { pos: v(f64::NAN, 1.0), heading: f64::NAN }];
        let obs = [v(f64::INFINITY, 0.0), v(f64::NAN, f64::NAN)];
        let out =
            step(&params(), &Input { neighbours: &ns, obstacles: &obs, goal_heading: Some(f64::NAN), bodies: &[] });
        close(out.velocity, v(0.4, 0.0), 1e-15);
        assert_eq!(out.yaw_rate, 0.0);
    }

    #[test]
    fn step_velocity_is_capped_and_finite() {
        let p = params();
        let coords = [-5.0, -2.5, -1.0, -0.3, 0.0, 0.3, 1.0, 2.0, 4.0];
        let mut cases = 0usize;
        for &ax in &coords {
            for &ay in &coords {
                for &ox in &coords {
                    for &oy in &coords {
                        for goal in [None, Some(0.0), Some(2.5), Some(-3.0)] {
                            let ns = [
                                Neighbour { pos: v(ax, ay), heading: ax - ay },
                                Neighbour { pos: v(ay + 1.0, -ax), heading: 0.5 },
                                Neighbour { pos: v(6.0, ay), heading: -1.0 },
                            ];
                            let obs = [v(ox, oy), v(oy + 0.5, ox - 0.5)];
                            for k in 0..=3 {
                                let input =
                                    Input { neighbours: &ns[..k], obstacles: &obs, goal_heading: goal, bodies: &[] };
                                let out = step(&p, &input);
                                assert!(out.velocity.x.is_finite() && out.velocity.y.is_finite(), "{input:?}");
                                assert!(out.velocity.norm() <= p.kf + 1e-12, "{input:?} → {out:?}");
                                assert!(out.yaw_rate.is_finite());
                                assert!(out.yaw_rate.abs() <= PI + 1e-12);
                                for w in [out.cohesion, out.avoidance] {
                                    assert!(w.norm() <= 1.0 + 1e-12, "{input:?} → {out:?}");
                                }
                                assert!(out.separation.norm() <= 1.0 + 1e-12);
                                assert!(out.navigation.norm() <= 1.0 + 1e-12);
                                cases += 1;
                            }
                        }
                    }
                }
            }
        }
        assert_eq!(cases, 9 * 9 * 9 * 9 * 4 * 4);
    }
}

//! The velocity barrier: a velocity with its approach to each close point held to that point's
//! allowance.
//!
//! Why this module exists: the seeds' controllers steer by fields (seed 000's closest-obstacle
//! avoidance, seed 003's averaged repulsion), and a field can push a UAV into a second body while
//! it avoids the first, or let an informed agent's navigation outweigh a neighbour in its way.
//! The barrier is our extension over both, a constraint on the command rather than one more
//! term in the sum: K21 applies it to its final velocity (`k21::step`), A21's opt-in safety
//! layer to the velocity its acceleration reaches in one control period (`a21::safe_velocity`).
//! [`within`] grades the allowance linearly (K21's velocity commands), [`braking`] by the
//! distance a double integrator needs to stop (A21's acceleration commands).

use nalgebra::Vector2;

use crate::geometry::{is_finite, EPS};

/// `v` with its component towards each of `close` (body frame) at most that point's allowance
/// [m/s]: our extension of seed 000 section 4.4, whose avoidance (eq. 4.10–4.13) looks at the
/// closest obstacle only and so may push a UAV squeezing between two obstacles into the farther
/// one. Each close point is a half-plane constraint v·ŷ ≤ allowance; the constraints are applied
/// in turn until none is violated (a few rounds: in 2D at most two are active at once). Where
/// they leave no direction at all (hemmed in on every side with no allowance), the UAV stops.
/// The caller picks what is close and its allowance ([`within`]).
pub fn barrier(v: Vector2<f64>, close: impl IntoIterator<Item = (Vector2<f64>, f64)>) -> Vector2<f64> {
    // Usually empty: no allocation unless something is this close.
    let close: Vec<(Vector2<f64>, f64)> = close
        .into_iter()
        .filter(|(y, a)| is_finite(y) && a.is_finite())
        .filter_map(|(y, a)| {
            let d = y.norm();
            (d > EPS).then(|| (y / d, a.max(0.0)))
        })
        .collect();
    let mut v = v;
    for _ in 0..8 {
        let mut changed = false;
        for (y, allowed) in &close {
            let over = v.dot(y) - allowed;
            if over > EPS {
                v -= over * y;
                changed = true;
            }
        }
        if !changed {
            return v;
        }
    }
    if close.iter().any(|(y, allowed)| v.dot(y) - allowed > 1e-6) {
        Vector2::zeros()
    } else {
        v
    }
}

/// The points of `points` closer than `radius_m` (none when it is 0: that barrier is off), each
/// with the speed [m/s] at which the UAV may still approach it: `speed` at `radius_m`, falling
/// linearly to 0 at `radius_m − ramp_m` and 0 deeper in (a hard barrier with `ramp_m` = 0).
pub fn within<'a>(
    points: impl IntoIterator<Item = &'a Vector2<f64>>,
    radius_m: f64,
    ramp_m: f64,
    speed: f64,
) -> impl Iterator<Item = (Vector2<f64>, f64)> {
    let stop = (radius_m - ramp_m).max(0.0);
    let band = radius_m - stop;
    points.into_iter().copied().filter_map(move |y| {
        let d = y.norm();
        let allowed = if band > 0.0 { speed * ((d - stop) / band).clamp(0.0, 1.0) } else { 0.0 };
        (d < radius_m).then_some((y, allowed))
    })
}

/// The points of `points` from which a UAV braking at `brake_mps2` could not stop before
/// `stop_m` at `speed_mps`, each with the speed [m/s] at which it may still approach it:
/// √(2·b·(d − stop)) (the speed a double integrator can shed at deceleration b over the distance
/// left), at most `speed_mps`, 0 from `stop_m` in. None when `stop_m` or `brake_mps2` is not
/// above 0.
pub fn braking<'a>(
    points: impl IntoIterator<Item = &'a Vector2<f64>>,
    stop_m: f64,
    brake_mps2: f64,
    speed_mps: f64,
) -> impl Iterator<Item = (Vector2<f64>, f64)> {
    let on = stop_m > 0.0 && brake_mps2 > 0.0;
    let reach = if on { stop_m + speed_mps * speed_mps / (2.0 * brake_mps2) } else { 0.0 };
    points.into_iter().copied().filter_map(move |y| {
        let d = y.norm();
        let allowed = (2.0 * brake_mps2 * (d - stop_m).max(0.0)).sqrt().min(speed_mps);
        (on && d < reach).then_some((y, allowed))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f64, y: f64) -> Vector2<f64> {
        Vector2::new(x, y)
    }

    fn close(a: Vector2<f64>, b: Vector2<f64>, tol: f64) {
        assert!((a - b).norm() <= tol, "{a} vs {b}");
    }

    /// The hard barrier (no ramp): nothing towards a point within reach.
    fn hard<'a>(points: &'a [Vector2<f64>], reach: f64) -> impl Iterator<Item = (Vector2<f64>, f64)> + 'a {
        within(points, reach, 0.0, 0.4)
    }

    #[test]
    fn barrier_keeps_a_uav_off_both_obstacles_it_squeezes_between() {
        // A frozen UAV 0.8 m to the left, a trunk 0.85 m to the right: it slides on between them.
        let beside = [v(0.0, 0.8), v(0.0, -0.85)];
        close(barrier(v(0.2, -0.3), hard(&beside, 1.0)), v(0.2, 0.0), 1e-12);
        // The trunk a little ahead on the right: no component towards either is left.
        let ahead = [v(0.0, 0.8), v(0.3, -0.85)];
        let out = barrier(v(0.2, -0.3), hard(&ahead, 1.0));
        for y in &ahead {
            assert!(out.dot(&(y / y.norm())) <= 1e-9, "{out} moves towards {y}");
        }
        close(barrier(v(0.2, -0.3), hard(&ahead, 0.0)), v(0.2, -0.3), 1e-12);
        close(barrier(v(0.4, 0.0), hard(&[v(3.0, 0.0)], 1.0)), v(0.4, 0.0), 1e-12);
        // Hemmed in on three sides with the velocity into the corner: it stops.
        let corner = [v(0.5, 0.0), v(-0.25, 0.45), v(-0.25, -0.45)];
        close(barrier(v(0.3, 0.1), hard(&corner, 1.0)), Vector2::zeros(), 1e-9);
        close(barrier(v(0.3, 0.1), within(&corner, 1.0, 0.15, 0.4)), Vector2::zeros(), 1e-9);
    }

    /// The graded barrier: within the ramp a point may be approached at the allowance (kf at the
    /// reach, 0 at reach − ramp), deeper in not at all. In a gap between a trunk and a still UAV,
    /// both centres 1.0 m away and 129° apart (issue 46's crash: every direction through the gap
    /// approaches both), the hard barrier stops the UAV for good; the graded one lets it through.
    #[test]
    fn the_graded_barrier_lets_a_uav_through_a_gap_the_hard_one_closes() {
        let (reach, ramp, kf) = (1.0, 0.15, 0.4);
        let at = |deg: f64, d: f64| v(d * deg.to_radians().cos(), d * deg.to_radians().sin());
        let (a, b) = (at(58.0, 0.97), at(-71.0, 0.98));
        let gap = [a, b];
        let through = v(0.4, 0.0);
        close(barrier(through, hard(&gap, reach)), Vector2::zeros(), 1e-9);
        let out = barrier(through, within(&gap, reach, ramp, kf));
        assert!(out.x > 0.1, "on through the gap: {out}");
        for (y, allowed) in within(&gap, reach, ramp, kf) {
            let d = y.norm();
            close(v(allowed, 0.0), v(kf * (d - 0.85) / 0.15, 0.0), 1e-12);
            assert!(out.dot(&y.normalize()) <= allowed + 1e-9, "{out} faster than {allowed} towards {y}");
        }
        // Deeper than reach − ramp: hard again.
        let deep = [at(58.0, 0.8), at(-71.0, 0.84)];
        close(barrier(through, within(&deep, reach, ramp, kf)), Vector2::zeros(), 1e-9);
        // At the reach itself, nothing is held back (beyond it the point is not close).
        assert_eq!(within(&[v(1.0, 0.0)], reach, ramp, kf).count(), 0);
    }

    /// Braking: the allowance is the speed that can still be shed before the stop distance, and
    /// points from which the top speed can be shed are not close at all.
    #[test]
    fn the_braking_allowance_is_the_speed_that_stops_in_time() {
        let (stop, b, top) = (0.9, 1.0, 1.0);
        // Reach: 0.9 + 1²/(2·1) = 1.4 m.
        assert_eq!(braking(&[v(1.41, 0.0)], stop, b, top).count(), 0);
        let got: Vec<_> = braking(&[v(1.3, 0.0), v(0.0, 0.9), v(0.0, -0.5)], stop, b, top).collect();
        assert_eq!(got.len(), 3);
        assert!((got[0].1 - (2.0_f64 * 0.4).sqrt()).abs() < 1e-12, "{got:?}");
        assert_eq!((got[1].1, got[2].1), (0.0, 0.0));
        // A UAV at 1 m/s towards a neighbour 1.3 m ahead keeps √0.8 m/s of it, and none deeper in.
        close(barrier(v(1.0, 0.0), braking(&[v(1.3, 0.0)], stop, b, top)), v(0.8_f64.sqrt(), 0.0), 1e-12);
        close(barrier(v(1.0, 0.3), braking(&[v(0.8, 0.0)], stop, b, top)), v(0.0, 0.3), 1e-12);
        // Off: no stop distance or no deceleration.
        assert_eq!(braking(&[v(0.5, 0.0)], 0.0, b, top).count(), 0);
        assert_eq!(braking(&[v(0.5, 0.0)], stop, 0.0, top).count(), 0);
    }

    /// Flown as a double integrator at the braking deceleration, a UAV heading straight at a
    /// point from the reach at the top speed stops short of the stop distance.
    #[test]
    fn a_double_integrator_under_the_braking_barrier_stops_before_the_stop_distance() {
        let (stop, b, top, dt) = (0.9, 1.0, 1.0, 0.05);
        let (mut x, mut speed) = (0.0, top);
        let target = 0.9 + 0.5 + 0.1;
        for _ in 0..400 {
            let ahead = [v(target - x, 0.0)];
            let want = barrier(v(top, 0.0), braking(&ahead, stop, b, top)).x;
            // The deceleration the body can give; the barrier asks at most what it allows.
            speed = (speed + ((want - speed) / dt).clamp(-b * 1.2, b * 1.2) * dt).max(0.0);
            x += speed * dt;
        }
        assert!(target - x > stop - 0.05, "{:.3} m left, stop {stop}", target - x);
        assert!(target - x < stop + 0.05, "it gets there: {:.3} m left", target - x);
    }
}

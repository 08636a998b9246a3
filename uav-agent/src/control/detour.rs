//! The detour: how a K21 UAV gets out of the mouth of a gap the barrier shuts.
//!
//! Why a module of its own: K21 (seed 000 chapter 4) is stateless, and at the mouth of a gap
//! narrower than the barrier lets through (a frozen UAV on one side, a trunk on the other, each
//! about 0.9 m from the UAV) every direction its avoidance and navigation want points into the
//! gap. The barrier ([`super::barrier`]) takes the whole of it away, the UAV stops, and the next
//! step wants the same: it waited there for good (issue 46's forest-9-cut-off with UAV 2
//! frozen, and with 15 trees per 100 m², where the informed UAV stopped so and the rest circled
//! with nobody leading). Getting out needs memory: noticing that it has been held, and then
//! keeping to one way round for long enough to leave the mouth.
//!
//! So, once the barrier has held the velocity under a tenth of kf for `detour_after_s` while
//! K21 wanted at least half of kf, the UAV flies for `detour_s` the direction nearest K21's that
//! the barrier lets through at three quarters of kf or more, looking always to the same side
//! (the side where a free direction came first, chosen once). Each later step goes on the way
//! it flew the step before while that stays free, else turns from it to that side by as little
//! as frees one: the barrier bends each step along what holds the UAV, so the detour slides
//! round the blockage, and repeated detours keep going the same way. The barrier still holds
//! every step of it. Opt-in
//! (`[controller.k21] detour_after_s`, off by default), like the rest of our extensions that
//! change a flight.

use super::barrier::barrier;
use super::k21::{direction_or_x, Output};
use nalgebra::{Rotation2, Vector2};
use swarm_config::K21Params;

/// The barrier holds the velocity under this share of kf: held.
const HELD: f64 = 0.1;
/// K21 wants at least this share of kf: it means to move.
const MEANT: f64 = 0.5;
/// A direction is free when the barrier lets this share of kf through along it.
const FREE: f64 = 0.75;
/// The step of the search round from K21's direction [rad] (10°), up to half a turn.
const TURN_STEP: f64 = std::f64::consts::PI / 18.0;

/// The detour's memory between steps.
#[derive(Debug, Default)]
pub struct Detour {
    /// Since when the barrier has held the UAV [s].
    held_since_s: Option<f64>,
    /// Until when the current detour lasts [s].
    until_s: Option<f64>,
    /// The side it turns to, +1 left or −1 right, chosen at its first detour.
    side: Option<f64>,
    /// The direction the detour flies, odometry frame (unit): at its start what K21 wanted,
    /// then each step the direction of the velocity it flew, which the barrier bent along what
    /// holds it (so the detour slides round the blockage), or when that is no longer free the
    /// first free one from it round to the side. Kept so, neither K21's swerves at the mouth (its
    /// avoidance flips from one side of the closest obstacle to the other) nor a direction freed
    /// behind it turn the UAV back and forth (both did: it shook in place).
    going: Vector2<f64>,
    /// Detours begun.
    count: u32,
}

impl Detour {
    /// A detour that has seen nothing yet.
    pub fn new() -> Detour {
        Detour::default()
    }

    /// Detours begun so far.
    #[cfg(test)]
    pub fn count(&self) -> u32 {
        self.count
    }

    /// The velocity of this step [m/s], body frame: `out.velocity` unless the UAV is on a
    /// detour (or starts one now), then the free direction nearest K21's `out.wanted` on the
    /// detour's side, held by the barrier's points that `close` gives
    /// ([`super::k21::barrier_points`]; asked for only on a detour or once held, so the step does
    /// not compute them twice). `t_s`: sim time [s]; `yaw`: own heading in the odometry frame
    /// [rad]. Off (`out.velocity` always) when `p.detour_after_s` is 0.
    pub fn steer(
        &mut self,
        p: &K21Params,
        t_s: f64,
        yaw: f64,
        out: &Output,
        close: impl FnOnce() -> Vec<(Vector2<f64>, f64)>,
    ) -> Vector2<f64> {
        if p.detour_after_s <= 0.0 {
            return out.velocity;
        }
        let on = self.until_s.is_some_and(|u| t_s < u - 1e-9);
        if !on {
            self.until_s = None;
            if !self.held(p, t_s, out) {
                return out.velocity;
            }
            self.going = Rotation2::new(yaw) * direction_or_x(out.wanted);
        }
        let going = Rotation2::new(-yaw) * self.going;
        let Some(Free { velocity, side }) = free_direction(p, going, &close(), self.side) else {
            return out.velocity;
        };
        self.going = Rotation2::new(yaw) * direction_or_x(velocity);
        if !on {
            (self.until_s, self.held_since_s) = (Some(t_s + p.detour_s), None);
            self.count += 1;
            tracing::debug!(t_s, detour = self.count, side, "held at a shut gap: a detour");
        }
        self.side = side.or(self.side);
        velocity
    }

    /// Notes whether the barrier holds K21's velocity this step; true once it has for
    /// `detour_after_s`.
    fn held(&mut self, p: &K21Params, t_s: f64, out: &Output) -> bool {
        let held = out.wanted.norm() >= MEANT * p.kf && out.velocity.norm() < HELD * p.kf;
        if !held {
            self.held_since_s = None;
            return false;
        }
        let since = *self.held_since_s.get_or_insert(t_s);
        t_s - since >= p.detour_after_s - 1e-9
    }
}

/// A free direction found by [`free_direction`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Free {
    /// The velocity the barrier leaves along it [m/s], body frame.
    pub velocity: Vector2<f64>,
    /// The side it turned to (+1 left, −1 right), or the side asked for when it did not turn.
    pub side: Option<f64>,
}

/// The direction nearest `wanted` (body x when it is zero; `wanted` itself first) that the
/// barrier of `close` lets through at [`FREE`]·kf or more, turning to `side` (+1 left, −1
/// right), or to whichever side frees one first (left on a tie) when `side` is `None`. `None`
/// when no direction within half a turn is free.
pub fn free_direction(
    p: &K21Params,
    wanted: Vector2<f64>,
    close: &[(Vector2<f64>, f64)],
    side: Option<f64>,
) -> Option<Free> {
    let w = direction_or_x(wanted);
    let sides: &[f64] = match side {
        Some(s) if s < 0.0 => &[-1.0],
        Some(_) => &[1.0],
        None => &[1.0, -1.0],
    };
    let free = |direction: Vector2<f64>, side: Option<f64>| {
        let velocity = barrier(direction * p.kf, close.iter().copied());
        (velocity.dot(&direction) >= FREE * p.kf).then_some(Free { velocity, side })
    };
    free(w, side).or_else(|| {
        (1..=18).find_map(|k| sides.iter().find_map(|&s| free(Rotation2::new(s * k as f64 * TURN_STEP) * w, Some(s))))
    })
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::control::barrier::within;

    fn params() -> K21Params {
        K21Params { detour_after_s: 2.0, detour_s: 5.0, ..K21Params::default() }
    }

    fn output(wanted: Vector2<f64>, velocity: Vector2<f64>) -> Output {
        let z = Vector2::zeros();
        Output { velocity, yaw_rate: 0.0, cohesion: z, separation: z, avoidance: z, navigation: z, wanted }
    }

    /// A gap 1.6 m wide straight ahead: a body 0.9 m ahead-left and one 0.9 m ahead-right,
    /// both inside the barrier's reach (1 m, graded over 0.15 m).
    fn gap() -> Vec<(Vector2<f64>, f64)> {
        let p = K21Params::default();
        let pts = [Vector2::new(0.42, 0.8), Vector2::new(0.42, -0.8)];
        within(pts.iter(), p.barrier_m, p.barrier_ramp_m, p.kf).collect()
    }

    #[test]
    fn the_barrier_shuts_the_gap_and_the_free_direction_turns_out_of_it() {
        let p = params();
        let close = gap();
        let ahead = Vector2::new(p.kf, 0.0);
        // Straight on the barrier leaves (almost) nothing: both points are 0.9 m away, where
        // the allowance is kf·(0.9 − 0.85)/0.15 = 0.133 m/s along each, at 62° from ahead.
        assert!(barrier(ahead, close.iter().copied()).norm() < HELD * p.kf * 2.0);
        let Free { velocity: v, side, .. } = free_direction(&p, ahead, &close, None).unwrap();
        assert_eq!(side, Some(1.0), "a tie goes left");
        assert!(v.norm() >= FREE * p.kf, "{v:?}");
        // Free means away from both: the velocity approaches neither faster than its allowance.
        for (y, allowed) in &close {
            assert!(v.dot(&y.normalize()) <= allowed + 1e-9, "{v:?} towards {y:?}");
        }
        // A side once chosen is kept: to the right it finds the mirror image.
        let Free { velocity: r, side: s, .. } = free_direction(&p, ahead, &close, Some(-1.0)).unwrap();
        assert_eq!(s, Some(-1.0));
        assert!((r.y + v.y).abs() < 1e-9 && (r.x - v.x).abs() < 1e-9, "{r:?} vs {v:?}");
    }

    #[test]
    fn held_for_the_delay_it_detours_for_detour_s_then_flies_k21_again() {
        let p = params();
        let close = gap();
        let mut d = Detour::new();
        let held = output(Vector2::new(p.kf, 0.0), Vector2::zeros());
        // Held, but not for 2 s yet: K21's velocity (zero) stands.
        for i in 0..20 {
            assert_eq!(d.steer(&p, i as f64 * 0.1, 0.0, &held, || close.clone()), Vector2::zeros());
        }
        // At 2 s held: the detour begins.
        let v = d.steer(&p, 2.0, 0.0, &held, || close.clone());
        assert!(v.norm() >= FREE * p.kf && d.count() == 1, "{v:?}");
        // It lasts 5 s, whatever K21 says meanwhile (here: free to fly on).
        let free = output(Vector2::new(p.kf, 0.0), Vector2::new(p.kf, 0.0));
        assert_ne!(d.steer(&p, 6.9, 0.0, &free, || close.clone()), free.velocity);
        // Then K21 flies again.
        assert_eq!(d.steer(&p, 7.0, 0.0, &free, Vec::new), free.velocity);
        assert_eq!(d.count(), 1);
    }

    #[test]
    fn on_a_detour_it_keeps_its_direction_while_it_stays_free_whatever_k21_swerves_to() {
        let p = params();
        let close = gap();
        let mut d = Detour::new();
        let held = output(Vector2::new(p.kf, 0.0), Vector2::zeros());
        for i in 0..=20 {
            d.steer(&p, i as f64 * 0.1, 0.0, &held, || close.clone());
        }
        let first = d.steer(&p, 2.1, 0.0, &held, || close.clone());
        // K21 swerves the other way (its avoidance flipped sides); the detour keeps going.
        let swerved = output(Vector2::new(0.0, -p.kf), Vector2::zeros());
        let v = d.steer(&p, 2.2, 0.0, &swerved, || close.clone());
        assert!(v.dot(&first) > 0.9 * first.norm_squared(), "{v:?} vs {first:?}");
        // What it keeps is the direction it flew (the barrier's bend included).
        assert!((d.going - v.normalize()).norm() < 1e-9);
        // Out of the mouth (nothing close): on along that direction, at kf.
        let out = d.steer(&p, 2.3, 0.0, &swerved, Vec::new);
        assert!((out - v.normalize() * p.kf).norm() < 1e-9, "{out:?} vs {v:?}");
        // The direction is kept in the odometry frame: the UAV turned left by 90°, so in the body
        // frame the same direction is turned right by 90°.
        let v = d.steer(&p, 2.4, std::f64::consts::FRAC_PI_2, &swerved, Vec::new);
        let expected = Rotation2::new(-std::f64::consts::FRAC_PI_2) * out;
        assert!((v - expected).norm() < 1e-9, "{v:?} vs {expected:?}");
    }

    #[test]
    fn not_held_when_k21_wants_little_or_the_barrier_lets_it_move() {
        let p = params();
        let mut d = Detour::new();
        // K21 itself wants under half of kf (a hover among the flock): never a detour.
        let quiet = output(Vector2::new(0.1, 0.0), Vector2::zeros());
        // The barrier slows but does not hold it (over a tenth of kf gets through).
        let slowed = output(Vector2::new(p.kf, 0.0), Vector2::new(0.05, 0.0));
        for i in 0..100 {
            let o = if i % 2 == 0 { quiet } else { slowed };
            assert_eq!(d.steer(&p, i as f64 * 0.1, 0.0, &o, gap), o.velocity);
        }
        assert_eq!(d.count(), 0);
    }

    #[test]
    fn off_by_default() {
        let p = K21Params::default();
        let mut d = Detour::new();
        let held = output(Vector2::new(p.kf, 0.0), Vector2::zeros());
        for i in 0..1000 {
            assert_eq!(d.steer(&p, i as f64 * 0.1, 0.0, &held, gap), Vector2::zeros());
        }
    }

    #[test]
    fn hemmed_in_all_round_it_stays_held() {
        let p = params();
        let ring: Vec<Vector2<f64>> =
            (0..8).map(|k| Rotation2::new(k as f64 * std::f64::consts::FRAC_PI_4) * Vector2::new(0.8, 0.0)).collect();
        let close: Vec<_> = within(ring.iter(), p.barrier_m, p.barrier_ramp_m, p.kf).collect();
        assert!(free_direction(&p, Vector2::new(p.kf, 0.0), &close, None).is_none());
        let mut d = Detour::new();
        let held = output(Vector2::new(p.kf, 0.0), Vector2::zeros());
        for i in 0..50 {
            assert_eq!(d.steer(&p, i as f64 * 0.1, 0.0, &held, || close.clone()), Vector2::zeros());
        }
    }
}

//! Each neighbour's velocity from its successive positions (seed 001 eq. 9), for the
//! controllers that steer by their neighbours' velocities: P17's alignment force and M23's
//! social costs. It lives here, beside both, rather than in either one.

use crate::geometry::is_finite;
use nalgebra::Vector2;
use std::collections::BTreeMap;
use swarm_types::UavId;

/// A neighbour's last position sample and velocity estimate.
#[derive(Debug, Clone, Copy)]
struct Track {
    pos: Vector2<f64>,
    t_s: f64,
    vel_mps: Option<Vector2<f64>>,
}

/// Estimates each neighbour's velocity from its successive positions (seed 001 eq. 9:
/// v_j[t−1] = p_j[t] − p_j[t−1], here divided by the time between the samples, so in m/s).
///
/// Keyed by a neighbour id; `t_s` is the sample's own time stamp (the sender's, not the
/// arrival time, so network delay does not distort the estimate). A sample older than or as old
/// as the last one (reordered or repeated) is ignored. The first sample of a neighbour gives no
/// estimate (`None`: the caller uses zero). Entries not updated for `forget_after_secs` are dropped
/// by [`VelocityTracker::forget_stale`]; a neighbour seen again afterwards starts afresh.
#[derive(Debug, Clone)]
pub struct VelocityTracker {
    forget_after_secs: f64,
    tracks: BTreeMap<UavId, Track>,
}

impl VelocityTracker {
    /// A tracker forgetting neighbours not seen for `forget_after_secs`.
    pub fn new(forget_after_secs: f64) -> Self {
        VelocityTracker { forget_after_secs, tracks: BTreeMap::new() }
    }

    /// Records neighbour `id` at `pos` [m] stamped `t_s`; returns its velocity estimate [m/s].
    /// Non-finite samples are ignored.
    pub fn update(&mut self, id: UavId, pos: Vector2<f64>, t_s: f64) -> Option<Vector2<f64>> {
        if !is_finite(&pos) || !t_s.is_finite() {
            return self.velocity(id);
        }
        match self.tracks.get_mut(&id) {
            None => {
                self.tracks.insert(id, Track { pos, t_s, vel_mps: None });
                None
            }
            Some(track) if t_s > track.t_s => {
                // seed 001 eq. 9: v_j = (p_j[t] − p_j[t−1]), per second of the sample interval.
                let vel = (pos - track.pos) / (t_s - track.t_s);
                track.vel_mps = is_finite(&vel).then_some(vel);
                track.pos = pos;
                track.t_s = t_s;
                track.vel_mps
            }
            Some(track) => track.vel_mps,
        }
    }

    /// The velocity estimate of neighbour `id` [m/s], if it has one.
    pub fn velocity(&self, id: UavId) -> Option<Vector2<f64>> {
        self.tracks.get(&id).and_then(|t| t.vel_mps)
    }

    /// Drops the neighbours whose last sample is more than `forget_after_secs` older than
    /// `now_secs`. A non-finite `now_secs` drops nothing.
    pub fn forget_stale(&mut self, now_secs: f64) {
        if now_secs.is_finite() {
            let keep = self.forget_after_secs;
            self.tracks.retain(|_, t| now_secs - t.t_s <= keep);
        }
    }

    /// Number of neighbours tracked (the tests count what `forget_stale` keeps).
    #[cfg(test)]
    pub fn len(&self) -> usize {
        self.tracks.len()
    }

    /// Whether no neighbour is tracked.
    #[cfg(test)]
    pub fn is_empty(&self) -> bool {
        self.tracks.is_empty()
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    fn v(x: f64, y: f64) -> Vector2<f64> {
        Vector2::new(x, y)
    }

    fn close(a: Vector2<f64>, b: Vector2<f64>, tol: f64) {
        assert!((a - b).norm() < tol, "{a:?} != {b:?}");
    }

    #[test]
    fn velocity_tracker_estimates_from_position_differences() {
        let mut t = VelocityTracker::new(1.0);
        // First sample: no estimate.
        assert_eq!(t.update(UavId::new(7), v(0.0, 0.0), 1.0), None);
        // (1,2) 0.5 s later: ((1,2) − (0,0))/0.5 = (2,4) m/s (seed 001 eq. 9, per second).
        close(t.update(UavId::new(7), v(1.0, 2.0), 1.5).unwrap(), v(2.0, 4.0), 1e-12);
        // The same stamp again, and an older (reordered) sample: ignored.
        close(t.update(UavId::new(7), v(9.0, 9.0), 1.5).unwrap(), v(2.0, 4.0), 1e-12);
        close(t.update(UavId::new(7), v(5.0, 5.0), 1.2).unwrap(), v(2.0, 4.0), 1e-12);
        // NaN sample ignored.
        close(t.update(UavId::new(7), v(f64::NAN, 5.0), 1.8).unwrap(), v(2.0, 4.0), 1e-12);
        // (2,2) at 2.0: ((2,2) − (1,2))/0.5 = (2,0).
        close(t.update(UavId::new(7), v(2.0, 2.0), 2.0).unwrap(), v(2.0, 0.0), 1e-12);
        close(t.velocity(UavId::new(7)).unwrap(), v(2.0, 0.0), 1e-12);
        assert_eq!(t.velocity(UavId::new(8)), None);
        // Another neighbour last seen at 0.5; at now = 2.0 it is 1.5 s old > 1 s → forgotten,
        // neighbour 7 (0 s old) is kept.
        t.update(UavId::new(8), v(0.0, 0.0), 0.2);
        t.update(UavId::new(8), v(0.3, 0.0), 0.5);
        close(t.velocity(UavId::new(8)).unwrap(), v(1.0, 0.0), 1e-12);
        assert_eq!(t.len(), 2);
        t.forget_stale(2.0);
        assert_eq!(t.len(), 1);
        assert_eq!(t.velocity(UavId::new(8)), None);
        // Seen again: starts afresh.
        assert_eq!(t.update(UavId::new(8), v(5.0, 0.0), 2.1), None);
        assert_eq!(t.len(), 2);
        // At 3.0 neighbour 7 (last 2.0) is exactly 1 s old: kept. At 3.05 it goes, 8 (last 2.1,
        // 0.95 s old) stays. A NaN time drops nothing; at 3.2 both are gone.
        t.forget_stale(3.0);
        assert_eq!(t.len(), 2);
        t.forget_stale(3.05);
        assert_eq!((t.len(), t.velocity(UavId::new(7))), (1, None));
        t.forget_stale(f64::NAN);
        assert_eq!(t.len(), 1);
        t.forget_stale(3.2);
        assert!(t.is_empty());
    }
}

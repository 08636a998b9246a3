//! Trails for a page opened late. The page draws each UAV's path from the frames it receives, so
//! a page opened after the run started (or a replay just sought) would begin with no trails and
//! grow them frame by frame. The server keeps the last [`TRAIL_S`] of every path instead, a
//! point every [`EVERY_S`] (bounded: at most `TRAIL_S / EVERY_S + 1` points a UAV, whatever the
//! run's length), and hands them to a page as it connects and after each seek (`http`'s
//! `trails` event), so the trails are there at once and the frames extend them.
//!
//! [`Trails`] is the pure ring, tested alone; a [`TrailSource`] answers the page's server:
//! [`LiveTrails`] fed by the live view's truth steps, `replay`'s from the recording's frames.

use serde_json::{json, Value};
use std::collections::{BTreeMap, VecDeque};
use std::sync::Mutex;
use swarm_record::scene::TRAIL_S;
use swarm_types::UavId;
use swarm_wire::msg::TruthStep;

/// The sim time between two kept points of a path [s].
pub const EVERY_S: f64 = 0.2;

/// Slack for sim times that are sums of tick lengths [s].
const TIME_EPS: f64 = 1e-6;

/// Each UAV's recent path: `[x, y, t]` points [m, m, sim s], oldest first, at least
/// [`EVERY_S`] apart and none older than [`TRAIL_S`] before the UAV's newest.
#[derive(Debug, Default, Clone, PartialEq)]
pub struct Trails {
    by_uav: BTreeMap<UavId, VecDeque<[f64; 3]>>,
}

impl Trails {
    /// UAV `id` at (`x`, `y`) at sim time `t`: kept if at least [`EVERY_S`] after its last kept
    /// point; a time before that point (a replay sought back) starts its path again.
    pub fn push(&mut self, id: UavId, t: f64, x: f64, y: f64) {
        let path = self.by_uav.entry(id).or_default();
        match path.back() {
            Some(last) if t < last[2] - TIME_EPS => path.clear(),
            Some(last) if t < last[2] + EVERY_S - TIME_EPS => return,
            _ => {}
        }
        path.push_back([x, y, t]);
        while path.front().is_some_and(|p| p[2] < t - TRAIL_S - TIME_EPS) {
            path.pop_front();
        }
    }

    /// Every body of a truth step.
    pub fn push_step(&mut self, s: &TruthStep) {
        for b in &s.bodies {
            self.push(b.id, s.t_s, b.x, b.y);
        }
    }

    /// UAV `id`'s kept points.
    #[cfg(test)]
    fn path(&self, id: UavId) -> Vec<[f64; 3]> {
        self.by_uav.get(&id).map(|p| p.iter().copied().collect()).unwrap_or_default()
    }

    /// What the page receives: `{"keep_s", "every_s", "uavs": {"id": [[x, y, t], ...]}}`,
    /// positions to the millimetre and times to the microsecond.
    pub fn to_json(&self) -> Value {
        let round = |v: f64, k: f64| (v * k).round() / k;
        let uavs: serde_json::Map<String, Value> = self
            .by_uav
            .iter()
            .map(|(id, path)| {
                (
                    id.to_string(),
                    path.iter().map(|p| json!([round(p[0], 1e3), round(p[1], 1e3), round(p[2], 1e6)])).collect(),
                )
            })
            .collect();
        json!({"keep_s": TRAIL_S, "every_s": EVERY_S, "uavs": uavs})
    }
}

/// Where the page's server gets the trails it hands a page.
pub trait TrailSource: Send + Sync {
    /// Every UAV's recent path up to the shown time, as [`Trails::to_json`] writes it.
    fn trails(&self) -> Value;
}

/// A live view's trails, shared between the view's loop (writer, one truth step at a time) and
/// the page's server (reader, once per page).
#[derive(Default)]
pub struct LiveTrails {
    trails: Mutex<Trails>,
}

impl LiveTrails {
    fn lock(&self) -> std::sync::MutexGuard<'_, Trails> {
        self.trails.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// One truth step.
    pub fn on_step(&self, s: &TruthStep) {
        self.lock().push_step(s);
    }
}

impl TrailSource for LiveTrails {
    fn trails(&self) -> Value {
        self.lock().to_json()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_path_keeps_a_point_every_so_often_and_the_last_seconds_only() {
        let mut tr = Trails::default();
        // 60 s of ticks of 0.1 s along x at 1 m/s.
        for tick in 0..=600u32 {
            let t = f64::from(tick) * 0.1;
            tr.push(UavId::new(3), t, t, 0.0);
        }
        let path = tr.path(UavId::new(3));
        assert_eq!(path.len(), (TRAIL_S / EVERY_S) as usize + 1, "{path:?}");
        assert!((path[0][2] - 40.0).abs() < 1e-9 && (path[path.len() - 1][2] - 60.0).abs() < 1e-9, "{path:?}");
        assert!(path.windows(2).all(|w| (w[1][2] - w[0][2] - EVERY_S).abs() < 1e-9), "a point every {EVERY_S} s");
        assert!(path.iter().all(|p| (p[0] - p[2]).abs() < 1e-9), "each point where the UAV was then");
    }

    #[test]
    fn a_time_going_back_starts_the_path_again() {
        let mut tr = Trails::default();
        for t in [1.0, 1.2, 1.4] {
            tr.push(UavId::new(1), t, t, 1.0);
        }
        tr.push(UavId::new(1), 0.5, 9.0, 9.0);
        assert_eq!(tr.path(UavId::new(1)), vec![[9.0, 9.0, 0.5]]);
    }

    #[test]
    fn the_json_names_each_uav_and_the_bounds() {
        let mut tr = Trails::default();
        tr.push(UavId::new(2), 0.1, 1.23456, -2.0);
        tr.push(UavId::new(4), 0.1, 0.0, 0.0);
        let j = tr.to_json();
        assert_eq!(j["uavs"]["2"], json!([[1.235, -2.0, 0.1]]));
        assert_eq!(j["uavs"].as_object().map(|o| o.len()), Some(2));
        assert_eq!(j["keep_s"], TRAIL_S);
        assert_eq!(j["every_s"], EVERY_S);
    }
}

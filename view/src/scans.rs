//! Scans on demand: the page asks `/scan?id=N` for UAV N's latest scan only while its "scan"
//! toggle is on and N is selected, so the frames stay small (a scan is 750 ranges per UAV per
//! tick) and nothing is converted that nobody looks at. A [`ScanSource`] answers: [`LiveScans`]
//! from the sensor frames of a live run, paired with the truth pose of the scan's own tick;
//! `replay` from the recording's `/uav/{id}/scan` and `/tf` at the playback time.

use serde_json::json;
use std::collections::{BTreeMap, VecDeque};
use std::sync::{Arc, Mutex};
use swarm_types::UavId;
use swarm_wire::msg::{Scan, TruthStep};

/// How many ticks of truth steps a live view keeps to pair scans with.
const POSE_TICKS: usize = 32;

/// One UAV's scan placed in the world.
#[derive(Debug, Clone, PartialEq)]
pub struct ScanPicture {
    /// The UAV.
    pub id: UavId,
    /// The scan's tick.
    pub tick: u64,
    /// Its sim time [s].
    pub t_s: f64,
    /// The UAV's true pose at that tick: x, y [m], yaw [rad] in the world frame.
    pub pose: [f64; 3],
    /// Beam 0's angle in the body frame [rad].
    pub angle_min: f64,
    /// The angle between beams [rad].
    pub angle_increment: f64,
    /// Ranges [m]; +inf: no return.
    pub ranges: Vec<f64>,
}

impl ScanPicture {
    /// UAV `id`'s wire scan at `pose`.
    pub fn of_wire(id: UavId, s: &Scan, pose: [f64; 3]) -> ScanPicture {
        ScanPicture {
            id,
            tick: s.tick,
            t_s: s.t_s,
            pose,
            angle_min: f64::from(s.angle_min),
            angle_increment: f64::from(s.angle_increment),
            ranges: s.ranges_m.iter().map(|&r| f64::from(r)).collect(),
        }
    }

    /// The returns in the world frame [m]: beam i at body angle a_i = angle_min + i * increment
    /// hits p = (x + r cos(yaw + a_i), y + r sin(yaw + a_i)).
    pub fn hits(&self) -> Vec<[f64; 2]> {
        let [x, y, yaw] = self.pose;
        self.ranges
            .iter()
            .enumerate()
            .filter(|(_, r)| r.is_finite())
            .map(|(i, &r)| {
                let a = yaw + self.angle_min + self.angle_increment * i as f64;
                [x + r * a.cos(), y + r * a.sin()]
            })
            .collect()
    }

    /// What `/scan` answers: the pose and the returns in the world, to the millimetre.
    pub fn to_json(&self) -> String {
        let mm = |v: f64| (v * 1000.0).round() / 1000.0;
        let hits: Vec<[f64; 2]> = self.hits().into_iter().map(|[x, y]| [mm(x), mm(y)]).collect();
        json!({"id": self.id, "tick": self.tick, "t": self.t_s, "pose": self.pose, "beams": self.ranges.len(), "hits": hits}).to_string()
    }
}

/// Where `/scan?id=N` gets UAV N's latest scan.
pub trait ScanSource: Send + Sync {
    /// UAV `id`'s latest scan whose pose is known, if any.
    fn scan(&self, id: UavId) -> Option<ScanPicture>;
}

/// A live view's latest scan per UAV and the truth steps of the last ticks, shared between the
/// view's loop (writer) and the page's server (reader). The steps are kept as they came (shared,
/// not copied): a pose is looked up only when the page asks for a scan.
#[derive(Default)]
pub struct LiveScans {
    book: Mutex<Book>,
}

#[derive(Default)]
struct Book {
    steps: VecDeque<Arc<TruthStep>>,
    scans: BTreeMap<UavId, Scan>,
}

impl LiveScans {
    fn book(&self) -> std::sync::MutexGuard<'_, Book> {
        self.book.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// One truth step: its poses, for the scans of its tick.
    pub fn on_step(&self, s: Arc<TruthStep>) {
        let mut book = self.book();
        book.steps.push_back(s);
        while book.steps.len() > POSE_TICKS {
            book.steps.pop_front();
        }
    }

    /// A scan the hub sent UAV `id`.
    pub fn on_scan(&self, id: UavId, s: Scan) {
        self.book().scans.insert(id, s);
    }
}

impl ScanSource for LiveScans {
    fn scan(&self, id: UavId) -> Option<ScanPicture> {
        let book = self.book();
        let s = book.scans.get(&id)?;
        let step = book.steps.iter().rev().find(|step| step.tick == s.tick)?;
        let b = step.bodies.iter().find(|b| b.id == id)?;
        Some(ScanPicture::of_wire(id, s, [b.x, b.y, b.yaw]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use swarm_wire::msg::TruthBody;

    #[test]
    fn a_live_scan_is_placed_at_the_pose_of_its_own_tick() {
        let scans = LiveScans::default();
        let body = |tick: u64| TruthBody {
            id: UavId::new(2),
            x: tick as f64,
            y: 1.0,
            yaw: std::f64::consts::FRAC_PI_2,
            vx: 0.0,
            vy: 0.0,
            alive: true,
            cmd_on_time: true,
            obstacle_distance_m: 1.0,
            agent_distance_m: 1.0,
            colliding: false,
        };
        let step = |tick| TruthStep { tick, t_s: tick as f64 * 0.1, bodies: vec![body(tick)], ..Default::default() };
        let scan = Scan {
            tick: 5,
            t_s: 0.5,
            angle_min: 0.0,
            angle_increment: std::f32::consts::FRAC_PI_2,
            max_range_m: 9.0,
            ranges_m: vec![2.0, f32::INFINITY, 3.0],
        };
        scans.on_scan(UavId::new(2), scan.clone());
        assert!(scans.scan(UavId::new(2)).is_none(), "no pose of tick 5 yet");
        scans.on_step(Arc::new(step(5)));
        scans.on_step(Arc::new(step(6)));
        let p = scans.scan(UavId::new(2)).expect("scan of tick 5");
        assert_eq!(p.pose, [5.0, 1.0, std::f64::consts::FRAC_PI_2]);
        // Beam 0 points along the heading (+y), beam 2 at +pi from it (-y); beam 1 has no return.
        let hits = p.hits();
        assert_eq!(hits.len(), 2);
        assert!((hits[0][0] - 5.0).abs() < 1e-6 && (hits[0][1] - 3.0).abs() < 1e-6, "{hits:?}");
        assert!((hits[1][0] - 5.0).abs() < 1e-6 && (hits[1][1] + 2.0).abs() < 1e-6, "{hits:?}");
        let json: serde_json::Value = serde_json::from_str(&p.to_json()).expect("json");
        assert_eq!(json["tick"], 5);
        assert_eq!(json["beams"], 3);
        assert_eq!(json["hits"][0], json!([5.0, 3.0]));
        assert!(scans.scan(UavId::new(1)).is_none(), "no scan of UAV 1");
    }
}

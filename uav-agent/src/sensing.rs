//! The sensor frame of one tick, and the pure collector that assembles it from messages arriving
//! one at a time. Why a type of its own: the node receives scan, odometry, GNSS and UVDAR as
//! separate messages in wire order; a step may run only once every sensor its localizer needs has
//! reported the scan's tick. Keeping that matching here, free of Zenoh, makes it testable and
//! gives the agent one value per tick instead of loose arguments.

use swarm_wire::{Gnss, Msg, Odom, Scan, Uvdar};

/// Everything one step senses, all of the same tick.
#[derive(Debug, Clone, PartialEq)]
pub struct SensorFrame {
    /// The LIDAR scan; its tick and time are the frame's.
    pub scan: Scan,
    /// Own odometry (odometry frame), of the scan's tick.
    pub odom: Odom,
    /// Own GNSS fix (world frame), when one of the scan's tick came in.
    pub gnss: Option<Gnss>,
    /// Onboard relative sensing, when one of the scan's tick came in.
    pub uvdar: Option<Uvdar>,
}

impl SensorFrame {
    /// Tick of the frame.
    pub fn tick(&self) -> u64 {
        self.scan.tick
    }
}

/// Which sensors a step waits for besides scan and odometry (the localizer decides).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Needs {
    /// Wait for the tick's GNSS fix (`broadcast`).
    pub gnss: bool,
    /// Wait for the tick's UVDAR sensing (`uvdar`).
    pub uvdar: bool,
}

/// Holds the newest message of each sensor until a frame is complete.
///
/// A frame is ready when the newest scan's tick has odometry and every needed sensor of the same
/// tick. Taking it consumes the scan and the UVDAR sensing; odometry and GNSS stay (a later scan
/// of their tick never comes, but they are overwritten by the next tick's anyway).
#[derive(Debug, Clone, Default)]
pub struct FrameCollector {
    needs: Needs,
    scan: Option<Scan>,
    odom: Option<Odom>,
    gnss: Option<Gnss>,
    uvdar: Option<Uvdar>,
}

impl FrameCollector {
    /// A collector waiting for scan, odometry and `needs`.
    pub fn new(needs: Needs) -> FrameCollector {
        FrameCollector { needs, ..FrameCollector::default() }
    }

    /// Keeps a sensor message; gives it back when it is not one (radio, rules, ...).
    pub fn offer(&mut self, msg: Msg) -> Option<Msg> {
        match msg {
            Msg::Scan(s) => self.scan = Some(s),
            Msg::Odom(o) => self.odom = Some(o),
            Msg::Gnss(g) => self.gnss = Some(g),
            Msg::Uvdar(u) => self.uvdar = Some(u),
            other => return Some(other),
        }
        None
    }

    /// The frame of the newest scan, once everything it needs of its tick is in.
    pub fn take_ready(&mut self) -> Option<SensorFrame> {
        let tick = self.scan.as_ref()?.tick;
        let odom_ready = self.odom.as_ref().is_some_and(|o| o.tick == tick);
        let gnss_ready = !self.needs.gnss || self.gnss.as_ref().is_some_and(|g| g.tick == tick);
        let uvdar_ready = !self.needs.uvdar || self.uvdar.as_ref().is_some_and(|u| u.tick == tick);
        if !(odom_ready && gnss_ready && uvdar_ready) {
            return None;
        }
        let scan = self.scan.take()?;
        let odom = self.odom?;
        let gnss = self.gnss.filter(|g| g.tick == tick);
        let uvdar = self.uvdar.take().filter(|u| u.tick == tick);
        Some(SensorFrame { scan, odom, gnss, uvdar })
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    fn scan(tick: u64) -> Scan {
        Scan {
            tick,
            t_secs: tick as f64 * 0.1,
            angle_min: 0.0,
            angle_increment: 0.1,
            max_range_m: 12.0,
            ranges_m: vec![],
        }
    }

    fn odom(tick: u64) -> Odom {
        Odom { tick, t_secs: tick as f64 * 0.1, x: 0.0, y: 0.0, yaw: 0.0, vx: 0.0, vy: 0.0, goal: None, goal_vel: None }
    }

    fn gnss(tick: u64) -> Gnss {
        Gnss { tick, t_secs: tick as f64 * 0.1, x: 1.0, y: 2.0, yaw: 0.0, vx: 0.0, vy: 0.0 }
    }

    fn uvdar(tick: u64) -> Uvdar {
        Uvdar { tick, t_secs: tick as f64 * 0.1, seen: Vec::new() }
    }

    /// A frame of `tick` with an empty scan, still odometry and nothing else.
    pub(crate) fn frame_at(tick: u64) -> SensorFrame {
        SensorFrame { scan: scan(tick), odom: odom(tick), gnss: None, uvdar: None }
    }

    #[test]
    fn a_frame_waits_for_scan_and_odometry_of_one_tick() {
        let mut c = FrameCollector::new(Needs::default());
        assert!(c.offer(Msg::Scan(scan(2))).is_none());
        assert_eq!(c.take_ready(), None, "no odometry yet");
        c.offer(Msg::Odom(odom(1)));
        assert_eq!(c.take_ready(), None, "odometry of another tick");
        c.offer(Msg::Odom(odom(2)));
        assert_eq!(c.take_ready(), Some(frame_at(2)));
        assert_eq!(c.take_ready(), None, "the scan is consumed");
    }

    #[test]
    fn gnss_is_waited_for_only_when_needed_and_kept_only_for_its_tick() {
        let mut c = FrameCollector::new(Needs { gnss: true, uvdar: false });
        c.offer(Msg::Gnss(gnss(1)));
        c.offer(Msg::Scan(scan(2)));
        c.offer(Msg::Odom(odom(2)));
        assert_eq!(c.take_ready(), None);
        c.offer(Msg::Gnss(gnss(2)));
        assert_eq!(c.take_ready().and_then(|f| f.gnss), Some(gnss(2)));
        let mut free = FrameCollector::new(Needs::default());
        free.offer(Msg::Gnss(gnss(1)));
        free.offer(Msg::Scan(scan(2)));
        free.offer(Msg::Odom(odom(2)));
        assert_eq!(free.take_ready().map(|f| f.gnss), Some(None), "a stale fix is left out");
    }

    #[test]
    fn uvdar_is_waited_for_when_needed_and_used_once() {
        let mut c = FrameCollector::new(Needs { gnss: false, uvdar: true });
        c.offer(Msg::Scan(scan(3)));
        c.offer(Msg::Odom(odom(3)));
        assert_eq!(c.take_ready(), None);
        c.offer(Msg::Uvdar(uvdar(3)));
        assert_eq!(c.take_ready().and_then(|f| f.uvdar), Some(uvdar(3)));
        c.offer(Msg::Scan(scan(4)));
        c.offer(Msg::Odom(odom(4)));
        assert_eq!(c.take_ready(), None, "the tick-3 sensing was used up");
    }

    #[test]
    fn other_messages_are_handed_back() {
        let mut c = FrameCollector::new(Needs::default());
        let rules = Msg::NetemRules(String::new());
        assert_eq!(c.offer(rules.clone()), Some(rules));
    }
}

//! The sensor frame of one tick as a step takes it, and the check that makes it from the hub's
//! wire frame (`uav/{id}/sense`, one message per UAV and tick). Why a module of its own: the wire
//! frame also carries the radio set, which goes to the admission rather than the step, and a
//! frame whose parts disagree on the tick, or that lacks a sensor the localizer needs, is
//! malformed (counted and dropped, never stepped on). Free of Zenoh, so testable.

use swarm_wire::{Gnss, Odom, RadioSet, Scan, SenseFrame, Uvdar};

/// Everything one step senses, all of the same tick.
#[derive(Debug, Clone, PartialEq)]
pub struct SensorFrame {
    /// The LIDAR scan; its tick and time are the frame's.
    pub scan: Scan,
    /// Own odometry (odometry frame), of the scan's tick.
    pub odom: Odom,
    /// Own GNSS fix (world frame), in broadcast mode.
    pub gnss: Option<Gnss>,
    /// Onboard relative sensing, in uvdar mode.
    pub uvdar: Option<Uvdar>,
}

impl SensorFrame {
    /// Tick of the frame.
    pub fn tick(&self) -> u64 {
        self.scan.tick
    }

    /// Splits the hub's frame into its radio set and the frame a step takes, or says why it is
    /// malformed: parts of different ticks, or a sensor `needs` asks for missing.
    pub fn from_wire(wire: SenseFrame, needs: Needs) -> Result<(RadioSet, SensorFrame), MalformedFrame> {
        let tick = wire.tick();
        let SenseFrame { radio, odom, gnss, uvdar, scan } = wire;
        let other_tick = radio.tick != tick
            || odom.tick != tick
            || gnss.as_ref().is_some_and(|g| g.tick != tick)
            || uvdar.as_ref().is_some_and(|u| u.tick != tick);
        if other_tick {
            return Err(MalformedFrame::MixedTicks);
        }
        if needs.gnss && gnss.is_none() {
            return Err(MalformedFrame::NoGnss);
        }
        if needs.uvdar && uvdar.is_none() {
            return Err(MalformedFrame::NoUvdar);
        }
        Ok((radio, SensorFrame { scan, odom, gnss, uvdar }))
    }
}

/// Why a sensor frame is not stepped on. Never propagated: the node counts the frame as
/// malformed, logs this and drops it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum MalformedFrame {
    /// Its parts are of different ticks.
    #[error("its parts are of different ticks")]
    MixedTicks,
    /// Broadcast localization needs a GNSS fix, and it has none.
    #[error("it has no GNSS fix, which broadcast localization needs")]
    NoGnss,
    /// UVDAR localization needs the onboard sensing, and it has none.
    #[error("it has no UVDAR sensing, which uvdar localization needs")]
    NoUvdar,
}

/// Which sensors a step needs besides scan and odometry (the localizer decides).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Needs {
    /// The tick's GNSS fix (`broadcast`).
    pub gnss: bool,
    /// The tick's UVDAR sensing (`uvdar`).
    pub uvdar: bool,
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use swarm_types::UavId;

    fn scan(tick: u64) -> Scan {
        Scan { tick, t_s: tick as f64 * 0.1, angle_min: 0.0, angle_increment: 0.1, max_range_m: 12.0, ranges_m: vec![] }
    }

    fn odom(tick: u64) -> Odom {
        Odom { tick, t_s: tick as f64 * 0.1, x: 0.0, y: 0.0, yaw: 0.0, vx: 0.0, vy: 0.0, goal: None, goal_vel: None }
    }

    fn gnss(tick: u64) -> Gnss {
        Gnss { tick, t_s: tick as f64 * 0.1, x: 1.0, y: 2.0, yaw: 0.0, vx: 0.0, vy: 0.0 }
    }

    fn uvdar(tick: u64) -> Uvdar {
        Uvdar { tick, t_s: tick as f64 * 0.1, seen: Vec::new() }
    }

    fn radio(tick: u64) -> RadioSet {
        RadioSet { tick, id: UavId::new(1), in_range: vec![UavId::new(2), UavId::new(3)], loss: vec![] }
    }

    /// A frame of `tick` with an empty scan, still odometry and nothing else.
    pub(crate) fn frame_at(tick: u64) -> SensorFrame {
        SensorFrame { scan: scan(tick), odom: odom(tick), gnss: None, uvdar: None }
    }

    fn wire(tick: u64) -> SenseFrame {
        SenseFrame { radio: radio(tick), odom: odom(tick), gnss: None, uvdar: None, scan: scan(tick) }
    }

    /// UAV 1's sensor message of `tick`, with UAVs 2 and 3 in radio range and a GNSS fix at
    /// (1, 2): what a broadcast agent steps on.
    pub(crate) fn broadcast_wire(tick: u64) -> SenseFrame {
        SenseFrame { gnss: Some(gnss(tick)), ..wire(tick) }
    }

    #[test]
    fn a_frame_splits_into_its_radio_set_and_the_step_frame() {
        assert_eq!(SensorFrame::from_wire(wire(2), Needs::default()), Ok((radio(2), frame_at(2))));
        let full = SenseFrame { gnss: Some(gnss(2)), uvdar: Some(uvdar(2)), ..wire(2) };
        let (_, f) = SensorFrame::from_wire(full, Needs { gnss: true, uvdar: true }).expect("complete");
        assert_eq!((f.gnss, f.uvdar), (Some(gnss(2)), Some(uvdar(2))));
    }

    #[test]
    fn parts_of_another_tick_make_a_frame_malformed() {
        let needs = Needs::default();
        for bad in [
            SenseFrame { odom: odom(1), ..wire(2) },
            SenseFrame { radio: radio(3), ..wire(2) },
            SenseFrame { gnss: Some(gnss(1)), ..wire(2) },
            SenseFrame { uvdar: Some(uvdar(1)), ..wire(2) },
        ] {
            assert_eq!(SensorFrame::from_wire(bad, needs), Err(MalformedFrame::MixedTicks));
        }
    }

    #[test]
    fn a_sensor_the_localizer_needs_must_be_there() {
        let gnss_needed = Needs { gnss: true, uvdar: false };
        assert_eq!(SensorFrame::from_wire(wire(2), gnss_needed), Err(MalformedFrame::NoGnss));
        let uvdar_needed = Needs { gnss: false, uvdar: true };
        assert_eq!(SensorFrame::from_wire(wire(2), uvdar_needed), Err(MalformedFrame::NoUvdar));
        let extra = SenseFrame { gnss: Some(gnss(2)), ..wire(2) };
        assert!(SensorFrame::from_wire(extra, Needs::default()).is_ok(), "a sensor not needed may come along");
    }
}

//! Solitude: how long each UAV was out of radio reach of every other UAV, whether and when it
//! came back, and how far it strayed. Ground truth, computed by the recorder from the track of
//! the distance to the nearest other UAV; the agents never see it.
//!
//! Why its own module: it judges the lost-contact behaviour (`uav_agent`'s `lost_contact`), the
//! one metric that needs the whole track of a UAV rather than a fold over ticks. A UAV is alone
//! from the tick its nearest other UAV is beyond `radio.range_m + radio.hysteresis_m` (every link
//! of it has dropped) until the tick one is within `radio.range_m` again (a link forms): the
//! radio model's own hysteresis, so a UAV on the edge of range is not counted as leaving and
//! coming back at every tick. The rule is the radio's own ([`Hysteresis`], which the hub's radio
//! decides links by), so a UAV counts as back at exactly the distance its link comes up.

use super::metrics::TrackSample;
use swarm_types::Hysteresis;

/// One UAV's solitude over a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Solitude {
    /// Sim time spent alone [s].
    pub time_alone_s: f64,
    /// Times it became alone.
    pub spells: u32,
    /// `None` if never alone; whether its last spell ended before the run did.
    pub rejoined: Option<bool>,
    /// When its last spell ended [s] (`None` if never alone or still alone at the end).
    pub rejoined_at_s: Option<f64>,
    /// Its largest distance to the nearest other UAV [m] (`inf` when it had no other UAV).
    pub max_nearest_uav_m: f64,
}

/// The solitude of one track (its samples' times and nearest-UAV distances), by the radio's rule.
pub fn solitude(samples: &[TrackSample], radio: Hysteresis) -> Solitude {
    let mut s = Solitude { time_alone_s: 0.0, spells: 0, rejoined: None, rejoined_at_s: None, max_nearest_uav_m: 0.0 };
    let mut alone = false;
    let mut prev_t: Option<f64> = None;
    for &TrackSample { t_s: t, nearest_uav_m: nearest, .. } in samples {
        s.max_nearest_uav_m = s.max_nearest_uav_m.max(if nearest.is_nan() { f64::INFINITY } else { nearest });
        if alone {
            s.time_alone_s += prev_t.map_or(0.0, |p| t - p);
        }
        // Linked to the nearest other UAV by the radio's rule; no other UAV (inf) or no number
        // (NaN) is alone too.
        let linked = radio.linked(!alone, nearest);
        if !alone && !linked {
            alone = true;
            s.spells += 1;
        } else if alone && linked {
            alone = false;
            s.rejoined_at_s = Some(t);
        }
        prev_t = Some(t);
    }
    if s.spells > 0 {
        s.rejoined = Some(!alone);
        if alone {
            s.rejoined_at_s = None;
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn track(nearest: &[f64]) -> Vec<TrackSample> {
        let sample = |(k, &d): (usize, &f64)| TrackSample {
            t_s: k as f64,
            x_m: 0.0,
            y_m: 0.0,
            obstacle_m: 1.0,
            nearest_uav_m: d,
        };
        nearest.iter().enumerate().map(sample).collect()
    }

    #[test]
    fn never_alone() {
        let s = solitude(&track(&[2.0, 10.5, 3.0]), Hysteresis::new(10.0, 1.0));
        assert_eq!(
            s,
            Solitude { time_alone_s: 0.0, spells: 0, rejoined: None, rejoined_at_s: None, max_nearest_uav_m: 10.5 }
        );
    }

    #[test]
    fn alone_then_back_with_the_radio_hysteresis() {
        // Alone at t = 1 (12 > 11), still alone at 10.5 (not yet within 10), back at t = 4.
        let s = solitude(&track(&[5.0, 12.0, 15.0, 10.5, 9.0, 20.0]), Hysteresis::new(10.0, 1.0));
        assert_eq!(s.spells, 2);
        assert_eq!(s.rejoined, Some(false), "alone again at the end");
        assert_eq!(s.rejoined_at_s, None);
        assert_eq!(s.time_alone_s, 3.0, "t 1 to 4");
        assert_eq!(s.max_nearest_uav_m, 20.0);
        let back = solitude(&track(&[5.0, 12.0, 15.0, 10.5, 9.0]), Hysteresis::new(10.0, 1.0));
        assert_eq!((back.rejoined, back.rejoined_at_s, back.spells), (Some(true), Some(4.0), 1));
        // At range itself a link does not come up (the radio links below range): still alone.
        let edge = solitude(&track(&[5.0, 12.0, 10.0]), Hysteresis::new(10.0, 1.0));
        assert_eq!((edge.rejoined, edge.time_alone_s), (Some(false), 1.0));
    }

    #[test]
    fn a_uav_with_no_other_is_alone_all_along() {
        let s = solitude(&track(&[f64::INFINITY, f64::INFINITY]), Hysteresis::new(10.0, 1.0));
        assert_eq!((s.spells, s.rejoined, s.time_alone_s), (1, Some(false), 1.0));
        assert!(s.max_nearest_uav_m.is_infinite());
    }
}

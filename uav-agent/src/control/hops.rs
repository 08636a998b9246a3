//! The hop count to the nearest informed UAV, a distance-vector count that every share carries
//! (see `swarm_config::LostContactParams`): how a group learns it has lost whoever knew the goal
//! without anyone learning who that was.
//!
//! Each UAV keeps the latest count of every sender it hears; its own count is 0 when informed,
//! else one more than the smallest count heard within [`HEARD_S`], and [`NO_PATH`] when that
//! reaches `max_hops`. Once the informed are gone a group's counts rise by one a round (the
//! classic count to infinity), which `max_hops` cuts short.

use crate::world_model::Estimate;
use nalgebra::Vector2;
use std::collections::BTreeMap;
use swarm_types::UavId;
use swarm_wire::NO_PATH;

/// A sender's count is used for this long after its share [sim s]: the neighbour database's
/// drop time, so a UAV that left radio range stops vouching for a path.
pub const HEARD_S: f64 = 0.5;

/// The counts heard, by sender.
#[derive(Debug, Default)]
pub struct Hops {
    heard: BTreeMap<UavId, (u8, f64)>,
}

impl Hops {
    /// Notes sender `from`'s count, sent at sim time `t_s`.
    pub fn hear(&mut self, from: UavId, hops: u8, t_s: f64) {
        let e = self.heard.entry(from).or_insert((hops, t_s));
        if t_s >= e.1 {
            *e = (hops, t_s);
        }
    }

    /// The latest count heard from `from` (none if not heard within [`HEARD_S`] of the last
    /// [`Hops::own`]).
    pub fn of(&self, from: UavId) -> u8 {
        self.heard.get(&from).map_or(NO_PATH, |(h, _)| *h)
    }

    /// The nearest of `neighbours` whose sender's count is below `own`, body frame (anonymous
    /// estimates carry no count): whom to follow towards the UAV the counts lead to.
    pub fn nearest_lower(&self, neighbours: &[Estimate], own: u8) -> Option<Vector2<f64>> {
        neighbours
            .iter()
            .filter(|e| e.id.map_or(NO_PATH, |id| self.of(id)) < own)
            .map(|e| e.pos_in_body)
            .min_by(|a, b| a.norm().total_cmp(&b.norm()))
    }

    /// Our own count at sim time `now`: 0 if `informed`, else one more than the smallest count
    /// heard within [`HEARD_S`], [`NO_PATH`] from `max_hops` on.
    pub fn own(&mut self, informed: bool, now: f64, max_hops: u8) -> u8 {
        self.heard.retain(|_, (_, t)| now - *t <= HEARD_S + 1e-9);
        if informed {
            return 0;
        }
        let best = self.heard.values().map(|(h, _)| *h).min().unwrap_or(NO_PATH);
        match best.saturating_add(1) {
            h if h >= max_hops => NO_PATH,
            h => h,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_are_one_more_than_the_best_heard_and_none_without_a_path() {
        let mut h = Hops::default();
        assert_eq!(h.own(false, 0.0, 32), NO_PATH, "nothing heard");
        assert_eq!(h.own(true, 0.0, 32), 0, "informed");
        h.hear(UavId::new(2), 3, 1.0);
        h.hear(UavId::new(3), 0, 1.0);
        assert_eq!(h.own(false, 1.1, 32), 1);
        h.hear(UavId::new(3), 0, 0.9);
        h.hear(UavId::new(3), NO_PATH, 1.2);
        assert_eq!(h.own(false, 1.3, 32), 4, "the latest count of each sender counts, not an older one");
        assert_eq!(h.own(false, 1.8, 32), NO_PATH, "silent senders stop vouching");
        h.hear(UavId::new(4), 30, 2.0);
        assert_eq!(h.own(false, 2.0, 32), 31);
        h.hear(UavId::new(4), 31, 2.1);
        assert_eq!(h.own(false, 2.1, 32), NO_PATH, "the cap cuts the count to infinity short");
    }

    #[test]
    fn a_group_without_its_informed_counts_up_to_no_path() {
        // Three UAVs in a line; the informed one at the end of it leaves after round 5.
        let mut uavs: Vec<Hops> = (0..3).map(|_| Hops::default()).collect();
        let mut counts = [0u8, NO_PATH, NO_PATH];
        for round in 0..60 {
            let t = f64::from(round) * 0.1;
            let informed_here = round < 5;
            let sent = counts;
            for (i, hops) in uavs.iter_mut().enumerate() {
                for j in [i.wrapping_sub(1), i + 1] {
                    if j < 3 && (j != 0 || informed_here) {
                        hops.hear(UavId::from_index(j), sent[j], t);
                    }
                }
                counts[i] = hops.own(i == 0, t + 0.1, 8);
            }
            if round == 4 {
                assert_eq!(counts, [0, 1, 2], "a path: the counts are the hops");
            }
        }
        assert_eq!(&counts[1..], &[NO_PATH, NO_PATH], "no path once the informed is gone");
    }
}

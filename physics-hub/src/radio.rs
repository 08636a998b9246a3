//! Who can hear whom, from ground truth: range with hysteresis ([`Hysteresis`], the rule the
//! recorder's solitude uses too). A link comes up inside `range_m` and goes down only beyond
//! `range_m + hysteresis_m`, so a pair balancing on the edge does not flap. Agents subscribe only to the share keys of the UAVs in their set. Optionally
//! each link that is up also loses messages with a probability that grows with distance
//! (`radio.distance_loss`); the agent applies it per message from the link's seeded stream.
//!
//! The links are kept as sorted neighbour lists and updated from a [`Grid`] of the positions, so
//! an update costs about n · (UAVs within range + hysteresis) instead of n²/2 pair tests.

use crate::grid::Grid;
use std::cmp::Ordering;
use swarm_types::Hysteresis;

/// `dx.hypot(dy).partial_cmp(&t)`, bit for bit, without the `hypot` call when the squared
/// distance is clearly on one side (all but a band of 1e-9 relative around `t`): `hypot` was
/// 4 % of open-1000's hub (`perf`), and the radio asks it for every candidate pair every tick.
/// The squared distance and `t²` are each within a few units in the last place of their exact
/// values, so a margin of 1e-9 decides exactly; `t` is held to a range where `t²` is a normal
/// number, and NaN or infinite input falls through to `hypot`.
fn compare_distance(dx: f64, dy: f64, t: f64) -> Option<Ordering> {
    if (1e-100..=1e100).contains(&t) {
        let (d2, t2) = (dx * dx + dy * dy, t * t);
        if d2 < t2 * (1.0 - 1e-9) {
            return Some(Ordering::Less);
        }
        if d2 > t2 * (1.0 + 1e-9) {
            return Some(Ordering::Greater);
        }
    }
    dx.hypot(dy).partial_cmp(&t)
}

/// Symmetric radio links between UAVs (indices 0..n).
#[derive(Debug, Clone)]
pub struct Radio {
    rule: Hysteresis,
    distance_loss: Option<swarm_config::DistanceLoss>,
    /// `links[i]`: the indices linked with i, ascending (each link is in both lists).
    links: Vec<Vec<usize>>,
    /// The positions of the last update, for the distance loss.
    positions: Vec<[f64; 2]>,
}

impl Radio {
    /// No links yet.
    pub fn new(range_m: f64, hysteresis_m: f64) -> Radio {
        Radio {
            rule: Hysteresis::new(range_m, hysteresis_m),
            distance_loss: None,
            links: Vec::new(),
            positions: Vec::new(),
        }
    }

    /// The radio of a scenario.
    pub fn of(r: &swarm_config::Radio) -> Radio {
        Radio { distance_loss: r.distance_loss, ..Radio::new(r.range_m, r.hysteresis_m) }
    }

    /// The loss probability of each link of `i` (in [`Radio::in_range`] order) at the positions of
    /// the last update; empty when the radio has no distance loss.
    pub fn losses(&self, i: usize) -> Vec<f32> {
        let Some(l) = self.distance_loss else { return Vec::new() };
        let p = &self.positions;
        self.in_range(i)
            .into_iter()
            .map(|j| l.at((p[i][0] - p[j][0]).hypot(p[i][1] - p[j][1]), self.rule.range_m) as f32)
            .collect()
    }

    /// Updates the links from positions (index = UAV index).
    #[cfg(test)]
    pub fn update(&mut self, positions: &[[f64; 2]]) {
        self.update_with(&Grid::new(positions, self.rule.keep_m()));
    }

    /// Updates the links from the positions `grid` was built from (any cell size).
    pub fn update_with(&mut self, grid: &Grid) {
        let positions = grid.points();
        if self.distance_loss.is_some() {
            self.positions = positions.to_vec();
        }
        self.links.resize(positions.len(), Vec::new());
        self.links = (0..positions.len()).map(|i| self.links_of(i, grid)).collect();
    }

    /// UAV index `i`'s links after this update, ascending: up inside range; once up, down only
    /// beyond range + hysteresis.
    fn links_of(&self, i: usize, grid: &Grid) -> Vec<usize> {
        let positions = grid.points();
        let p = positions[i];
        let keep_m = self.rule.keep_m();
        let mut out = Vec::new();
        grid.for_each_near(p, keep_m, |j| {
            if j == i {
                return;
            }
            let (dx, dy) = (p[0] - positions[j][0], p[1] - positions[j][1]);
            let linked = Hysteresis::linked_by(
                compare_distance(dx, dy, self.rule.range_m),
                compare_distance(dx, dy, keep_m),
                || self.links[i].binary_search(&j).is_ok(),
            );
            if linked {
                out.push(j);
            }
        });
        out.sort_unstable();
        out
    }

    /// Indices in range of `i`, sorted.
    pub fn in_range(&self, i: usize) -> Vec<usize> {
        self.links.get(i).cloned().unwrap_or_default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The radio as it was before the grid and the distance shortcut: every pair, `hypot`.
    fn brute_force(prev: &[Vec<usize>], positions: &[[f64; 2]], range_m: f64, keep_m: f64) -> Vec<Vec<usize>> {
        (0..positions.len())
            .map(|i| {
                (0..positions.len())
                    .filter(|&j| j != i)
                    .filter(|&j| {
                        let d = (positions[i][0] - positions[j][0]).hypot(positions[i][1] - positions[j][1]);
                        if prev[i].binary_search(&j).is_ok() {
                            d <= keep_m
                        } else {
                            d < range_m
                        }
                    })
                    .collect()
            })
            .collect()
    }

    proptest::proptest! {
        /// The shortcut decides as `hypot` does, at the threshold itself too (points placed at
        /// exactly `t` along an axis, and a hair either side).
        #[test]
        fn the_distance_shortcut_compares_as_hypot(dx in -50.0..50.0f64, dy in -50.0..50.0f64, t in 0.0..60.0f64, k in 0usize..4) {
            let (dx, dy) = match k {
                0 => (dx, dy),
                1 => (t, 0.0),
                2 => (f64::from_bits(t.to_bits() + 1), 0.0),
                _ => (0.0, f64::from_bits(t.to_bits().saturating_sub(1))),
            };
            proptest::prop_assert_eq!(compare_distance(dx, dy, t), dx.hypot(dy).partial_cmp(&t));
        }

        /// The links are those of every pair tested with `hypot`, over several updates (so links
        /// in the hysteresis band are kept).
        #[test]
        fn links_equal_the_pairwise_rule(seed in 0u64..1000, n in 2usize..200) {
            use rand::{Rng, SeedableRng};
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let side = (n as f64 * 18.0).sqrt();
            let mut pos: Vec<[f64; 2]> = (0..n).map(|_| [rng.gen_range(0.0..side), rng.gen_range(0.0..side)]).collect();
            let mut r = Radio::new(10.0, 1.0);
            let mut expect = vec![Vec::new(); n];
            for _ in 0..3 {
                r.update(&pos);
                expect = brute_force(&expect, &pos, 10.0, 11.0);
                proptest::prop_assert_eq!(&r.links, &expect);
                pos.iter_mut().for_each(|p| *p = [p[0] + rng.gen_range(-1.5..1.5), p[1] + rng.gen_range(-1.5..1.5)]);
            }
        }
    }

    #[test]
    fn links_come_up_in_range_and_drop_only_past_hysteresis() {
        let mut r = Radio::new(10.0, 1.0);
        r.update(&[[0.0, 0.0], [9.0, 0.0], [30.0, 0.0]]);
        assert_eq!(r.in_range(0), vec![1]);
        assert_eq!(r.in_range(1), vec![0]);
        assert!(r.in_range(2).is_empty());
        r.update(&[[0.0, 0.0], [10.5, 0.0], [30.0, 0.0]]);
        assert_eq!(r.in_range(0), vec![1], "inside hysteresis: still up");
        r.update(&[[0.0, 0.0], [11.5, 0.0], [30.0, 0.0]]);
        assert!(r.in_range(0).is_empty(), "past range + hysteresis: down");
        r.update(&[[0.0, 0.0], [10.5, 0.0], [30.0, 0.0]]);
        assert!(r.in_range(0).is_empty(), "does not come back until inside range");
    }

    #[test]
    fn distance_loss_ramps_from_its_start_to_its_value_at_range() {
        let cfg = swarm_config::Radio {
            range_m: 10.0,
            hysteresis_m: 2.0,
            distance_loss: Some(swarm_config::DistanceLoss { from_m: 6.0, at_range: 0.4 }),
        };
        let mut r = Radio::of(&cfg);
        let pos = [[0.0, 0.0], [5.0, 0.0], [0.0, 8.0], [-9.99, 0.0]];
        r.update(&pos);
        assert_eq!(r.in_range(0), vec![1, 2, 3]);
        let l = r.losses(0);
        // 5 m: below the start; 8 m: (8 - 6) / (10 - 6) * 0.4 = 0.2; 9.99 m: 0.399.
        assert_eq!(l[0], 0.0);
        assert!((l[1] - 0.2).abs() < 1e-6, "{l:?}");
        assert!((l[2] - 0.399).abs() < 1e-4, "{l:?}");
        // In the hysteresis band it goes on at the same slope: 11.5 m → 0.55.
        let pos = [[0.0, 0.0], [11.5, 0.0]];
        let mut r = Radio::of(&cfg);
        r.update(&[[0.0, 0.0], [9.0, 0.0]]);
        r.update(&pos);
        assert!((r.losses(0)[0] - 0.55).abs() < 1e-6);
        let mut plain = Radio::new(10.0, 1.0);
        plain.update(&pos);
        assert!(plain.losses(0).is_empty(), "no model, no losses");
    }
}

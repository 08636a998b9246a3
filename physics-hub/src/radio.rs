//! Who can hear whom, from ground truth: range with hysteresis. A link comes up inside
//! `range_m` and goes down only beyond `range_m + hysteresis_m`, so a pair balancing on the edge
//! does not flap. Agents subscribe only to the share keys of the UAVs in their set. Optionally
//! each link that is up also loses messages with a probability that grows with distance
//! (`radio.distance_loss`); the agent applies it per message from the link's seeded stream.
//!
//! The links are kept as sorted neighbour lists and updated from a [`Grid`] of the positions, so
//! an update costs about n · (UAVs within range + hysteresis) instead of n²/2 pair tests.

use crate::grid::Grid;

/// Symmetric radio links between UAVs (indices 0..n).
#[derive(Debug, Clone)]
pub struct Radio {
    range_m: f64,
    hysteresis_m: f64,
    distance_loss: Option<swarm_config::DistanceLoss>,
    /// `links[i]`: the indices linked with i, ascending (each link is in both lists).
    links: Vec<Vec<usize>>,
    /// The positions of the last update, for the distance loss.
    positions: Vec<[f64; 2]>,
}

impl Radio {
    /// No links yet.
    pub fn new(range_m: f64, hysteresis_m: f64) -> Radio {
        Radio { range_m, hysteresis_m, distance_loss: None, links: Vec::new(), positions: Vec::new() }
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
            .map(|j| l.at((p[i][0] - p[j][0]).hypot(p[i][1] - p[j][1]), self.range_m) as f32)
            .collect()
    }

    /// Updates the links from positions (index = UAV index).
    #[cfg(test)]
    pub fn update(&mut self, positions: &[[f64; 2]]) {
        self.update_with(&Grid::new(positions, self.range_m + self.hysteresis_m));
    }

    /// Updates the links from the positions `grid` was built from (any cell size).
    pub fn update_with(&mut self, grid: &Grid) {
        let positions = grid.points();
        if self.distance_loss.is_some() {
            self.positions = positions.to_vec();
        }
        self.links.resize(positions.len(), Vec::new());
        let keep_m = self.range_m + self.hysteresis_m;
        let links: Vec<Vec<usize>> = (0..positions.len())
            .map(|i| {
                let p = positions[i];
                grid.near_sorted(i, keep_m)
                    .into_iter()
                    .filter(|&j| {
                        let d = (p[0] - positions[j][0]).hypot(p[1] - positions[j][1]);
                        // Up inside range; once up, down only beyond range + hysteresis.
                        let up = self.links[i].binary_search(&j).is_ok();
                        if up {
                            d <= keep_m
                        } else {
                            d < self.range_m
                        }
                    })
                    .collect()
            })
            .collect();
        self.links = links;
    }

    /// Indices in range of `i`, sorted.
    pub fn in_range(&self, i: usize) -> Vec<usize> {
        self.links.get(i).cloned().unwrap_or_default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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

//! Who can hear whom, from ground truth: range with hysteresis. A link comes up inside
//! `range_m` and goes down only beyond `range_m + hysteresis_m`, so a pair balancing on the edge
//! does not flap. Agents subscribe only to the share keys of the UAVs in their set.

use std::collections::BTreeSet;

/// Symmetric radio links between UAVs (indices 0..n).
#[derive(Debug, Clone)]
pub struct Radio {
    range_m: f64,
    hysteresis_m: f64,
    links: BTreeSet<(usize, usize)>,
}

impl Radio {
    /// No links yet.
    pub fn new(range_m: f64, hysteresis_m: f64) -> Radio {
        Radio { range_m, hysteresis_m, links: BTreeSet::new() }
    }

    /// Updates the links from positions (index = UAV index).
    pub fn update(&mut self, positions: &[[f64; 2]]) {
        for i in 0..positions.len() {
            for j in i + 1..positions.len() {
                let d = (positions[i][0] - positions[j][0]).hypot(positions[i][1] - positions[j][1]);
                let up = self.links.contains(&(i, j));
                if !up && d < self.range_m {
                    self.links.insert((i, j));
                } else if up && d > self.range_m + self.hysteresis_m {
                    self.links.remove(&(i, j));
                }
            }
        }
    }

    /// Indices in range of `i`, sorted.
    pub fn in_range(&self, i: usize) -> Vec<usize> {
        self.links
            .iter()
            .filter_map(|&(a, b)| if a == i { Some(b) } else if b == i { Some(a) } else { None })
            .collect::<BTreeSet<_>>()
            .into_iter()
            .collect()
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
}

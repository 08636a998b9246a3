//! The own set's search structure for the full grid's first pass: for each cell of a raster over
//! the plane, the reference points that can be the nearest one to a block of starts anchored in
//! that cell.
//!
//! Why this module exists: the first pass of a full-grid ICP (seed 000 5.1) needs, for every
//! source point at every start (21×21 cells × 16 headings), the squared distance to the nearest
//! reference point. Against every reference point that was 14 million distances per full grid on
//! a crowd's 45-point sets, two thirds of an agent host's CPU at 1000 UAVs (`perf`). A block of
//! starts lies on a short segment of one grid column, and only a few reference points can be
//! nearest to any point of it: those no farther from the segment's surroundings than the point
//! whose farthest distance to them is least. The table lists them per raster cell, once per full
//! grid (its raster covers that grid's starts), and each block is searched against its anchor
//! cell's list.
//!
//! The distances are bit for bit the ones of the search over every point: the caller computes
//! each candidate's distance with the same operations, and a point left out of a cell's list is
//! farther from every point of the region than some listed point, by more than rounding could
//! make up ([`SLACK`]). The nearest value is the minimum of the same numbers over a set that holds
//! every point that could attain it. A block whose anchor falls outside the raster is searched
//! against every point.

use nalgebra::Point2;

/// Relative slack on the cut-off distance: rounding in a squared distance is a few ulps
/// (≈ 1e-15 relative), so a point beyond the cut-off by more than this cannot be nearest.
const SLACK: f64 = 1e-9;

/// Each region is widened by this much on every side [m], so a start whose rounded raster index
/// puts it on the wrong side of a cell boundary is still inside its cell's region. (Random
/// tests do not hit such a start; the margin is there by argument, not by a failing case.)
const MARGIN_M: f64 = 1e-6;

/// The widest raster built, in cells per side (far beyond any use: a LIDAR's reach is tens of
/// cells); wider is left empty, so its size cannot overflow.
const MAX_SIDE: usize = 1 << 12;

/// The candidate table of one reference set.
#[derive(Debug, Clone)]
pub(super) struct Candidates {
    /// Raster origin (lower left corner) [m].
    x0: f64,
    y0: f64,
    /// 1 / cell size [1/m].
    inv_cell: f64,
    /// Raster cells per side.
    n: usize,
    /// Cell `(ix, iy)`, k = ix·n + iy, lists `points[starts[k]..starts[k + 1]]`.
    starts: Vec<usize>,
    /// The candidates' coordinates, by cell, each cell's in reference order: read in a row,
    /// with no indirection, by the first pass's innermost loop.
    points: Vec<[f64; 2]>,
    /// Their indices into the reference set (the tests).
    #[cfg(test)]
    index: Vec<usize>,
    /// Every reference point: the list outside the raster.
    everyone: Vec<[f64; 2]>,
}

impl Candidates {
    /// The table for `reference`, over anchors in `[-reach, reach]²`, for regions of `cell` ×
    /// (`cell` + `span_y`) [m]: a block anchored at (x, y) covers x and y to y + `span_y`.
    /// An empty raster (every block searched against every point) when an input is not finite,
    /// `cell` is not positive, `span_y` is negative or the raster would be more than
    /// [`MAX_SIDE`] cells wide. Building costs about a search of every point per raster cell,
    /// so the caller keeps `reach` / `cell` small ([`super::grid`]'s `Layout`).
    pub(super) fn new(reference: &[Point2<f64>], reach: f64, span_y: f64, cell: f64) -> Candidates {
        let everyone: Vec<[f64; 2]> = reference.iter().map(|a| [a.x, a.y]).collect();
        let usable = reach.is_finite() && span_y.is_finite() && cell.is_finite() && cell > 0.0 && span_y >= 0.0;
        let side = raster_side(reach, cell);
        let n = if usable && side <= MAX_SIDE as f64 { side as usize } else { 0 };
        let origin = -reach.max(0.0);
        let words = reference.len().div_ceil(64).max(1);
        let sets = bit_sets(reference, origin, n, cell, span_y, words);
        // The bit sets written out as lists of coordinates.
        let mut starts = Vec::with_capacity(n * n + 1);
        let mut index = Vec::new();
        starts.push(0);
        for cell_set in sets.chunks_exact(words) {
            for (w, &word) in cell_set.iter().enumerate() {
                let mut bits = word;
                while bits != 0 {
                    index.push(w * 64 + bits.trailing_zeros() as usize);
                    bits &= bits - 1;
                }
            }
            starts.push(index.len());
        }
        let points = index.iter().map(|&k| everyone[k]).collect();
        Candidates {
            x0: origin,
            y0: origin,
            inv_cell: 1.0 / cell,
            n,
            starts,
            points,
            #[cfg(test)]
            index,
            everyone,
        }
    }

    /// The candidates of a block anchored at (x, y), as (x, y) coordinates in reference order;
    /// every point outside the raster.
    #[inline]
    pub(super) fn at(&self, x: f64, y: f64) -> &[[f64; 2]] {
        match self.cell(x, y) {
            Some(k) => &self.points[self.starts[k]..self.starts[k + 1]],
            None => &self.everyone,
        }
    }

    /// The raster cell of (x, y), if inside.
    #[inline]
    fn cell(&self, x: f64, y: f64) -> Option<usize> {
        let fx = (x - self.x0) * self.inv_cell;
        let fy = (y - self.y0) * self.inv_cell;
        if !(fx >= 0.0 && fy >= 0.0) {
            return None;
        }
        let (ix, iy) = (fx as usize, fy as usize);
        (ix < self.n && iy < self.n).then_some(ix * self.n + iy)
    }

    /// The indices of [`Candidates::at`]'s points (all of them outside the raster).
    #[cfg(test)]
    fn listed(&self, x: f64, y: f64) -> Vec<usize> {
        match self.cell(x, y) {
            Some(k) => self.index[self.starts[k]..self.starts[k + 1]].to_vec(),
            None => (0..self.everyone.len()).collect(),
        }
    }

    /// Mean candidates per cell (the tests).
    #[cfg(test)]
    fn mean_len(&self) -> f64 {
        self.points.len() as f64 / (self.n * self.n).max(1) as f64
    }
}

/// Cells per side of the raster of `cell` [m] over anchors in `[-reach, reach]²` (as a float, so
/// an absurd reach gives a large number, not an overflow): what [`Candidates::new`] builds, and
/// what its caller weighs against the work the table would save.
pub(super) fn raster_side(reach: f64, cell: f64) -> f64 {
    (2.0 * reach.max(0.0) / cell).floor() + 1.0
}

/// Each raster cell's candidates as a bit set over the reference points (point k is bit k % 64
/// of the cell's word k / 64; `words` per cell, cell (ix, iy) at (ix·n + iy)·`words`), for the
/// `n` × `n` raster of `cell` from (`origin`, `origin`) and regions `span_y` taller than a cell.
fn bit_sets(reference: &[Point2<f64>], origin: f64, n: usize, cell: f64, span_y: f64, words: usize) -> Vec<u64> {
    let m = reference.len();
    // A cell's region is the product of its column's x interval and its row's y interval, so
    // its squared distances to a point are sums of the two axes'.
    let (far_x, near_x) = axis(reference, origin, n, cell, 0.0, |a| a.x);
    let (far_y, near_y) = axis(reference, origin, n, cell, span_y, |a| a.y);
    let mut sets = vec![0u64; n * n * words];
    let mut cut = vec![f64::INFINITY; n];
    let mut bits = vec![0u64; n];
    for ix in 0..n {
        // Down the raster column: the least farthest distance. Every point of the region has a
        // reference point this close, so a reference point nearer than that to no point of the
        // region is never nearest.
        cut.fill(f64::INFINITY);
        for k in 0..m {
            let fx = far_x[k * n + ix];
            for (c, &fy) in cut.iter_mut().zip(&far_y[k * n..(k + 1) * n]) {
                *c = c.min(fx + fy);
            }
        }
        cut.iter_mut().for_each(|c| *c *= 1.0 + SLACK);
        for w in 0..words {
            bits.fill(0);
            for k in w * 64..m.min((w + 1) * 64) {
                let (nx, bit) = (near_x[k * n + ix], 1u64 << (k % 64));
                for ((set, &ny), &c) in bits.iter_mut().zip(&near_y[k * n..(k + 1) * n]).zip(&cut) {
                    *set |= if nx + ny <= c { bit } else { 0 };
                }
            }
            for (iy, &set) in bits.iter().enumerate() {
                sets[(ix * n + iy) * words + w] = set;
            }
        }
    }
    sets
}

/// One axis of the raster: for each of `count` intervals `[origin + i·cell, origin + (i + 1)·cell
/// + extra]` (widened by [`MARGIN_M`]) and each point, the largest and the least squared distance
/// along the axis (`coord`) from the point to the interval. Laid out by point, then interval.
fn axis(
    reference: &[Point2<f64>],
    origin: f64,
    count: usize,
    cell: f64,
    extra: f64,
    coord: fn(&Point2<f64>) -> f64,
) -> (Vec<f64>, Vec<f64>) {
    let mut far = Vec::with_capacity(count * reference.len());
    let mut near = Vec::with_capacity(count * reference.len());
    for a in reference {
        let v = coord(a);
        for i in 0..count {
            let lo = origin + i as f64 * cell - MARGIN_M;
            let hi = origin + (i + 1) as f64 * cell + extra + MARGIN_M;
            let (dl, dh) = (v - lo, hi - v);
            far.push(dl.abs().max(dh.abs()).powi(2));
            near.push((-dl).max(-dh).max(0.0).powi(2));
        }
    }
    (far, near)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig {
            cases: 64,
            rng_seed: proptest::test_runner::RngSeed::Fixed(0x000C_A4D1),
            failure_persistence: None,
            ..ProptestConfig::default()
        })]

        /// The invariant the first pass relies on: from any point of a cell's region (its
        /// corners, where the cut-off is tight, and points inside), the nearest reference point
        /// is one of the cell's candidates.
        #[test]
        fn prop_every_point_of_a_region_has_its_nearest_among_the_candidates(
            points in proptest::collection::vec((-12.0..12.0f64, -12.0..12.0f64), 1..80),
            cell in 0.2..2.0f64,
            span_y in 0.0..4.0f64,
            fx in 0.0..1.0f64,
            fy in 0.0..1.0f64,
        ) {
            let reference: Vec<Point2<f64>> = points.iter().map(|&(x, y)| Point2::new(x, y)).collect();
            let table = Candidates::new(&reference, 15.0, span_y, cell);
            let nearest = |x: f64, y: f64| {
                let d = |a: &Point2<f64>| (a.x - x).powi(2) + (a.y - y).powi(2);
                (0..reference.len()).min_by(|&i, &j| d(&reference[i]).total_cmp(&d(&reference[j]))).unwrap_or(0)
            };
            for ix in 0..table.n {
                for iy in 0..table.n {
                    let (x0, y0) = (table.x0 + ix as f64 * cell, table.y0 + iy as f64 * cell);
                    let listed = table.listed(x0 + 0.5 * cell, y0 + 0.5 * cell);
                    let (x1, y1) = (x0 + cell, y0 + cell + span_y);
                    for (x, y) in [(x0, y0), (x1, y0), (x0, y1), (x1, y1), (x0 + fx * cell, y0 + fy * (y1 - y0))] {
                        let k = nearest(x, y);
                        prop_assert!(listed.contains(&k), "cell ({}, {}): nearest {} to ({}, {}) not listed", ix, iy, k, x, y);
                    }
                }
            }
        }
    }

    /// On a crowd's set (45 points in 20 m × 20 m, as `cargo bench -p uav-agent --bench icp`
    /// has it) the table's cells list few of the points, and none outside the raster lists fewer
    /// than all of them: the first pass's exactness is `alignment`'s proptest, this is the gain.
    #[test]
    fn a_crowds_cells_list_a_few_points_each() {
        let mut s = 11u64;
        let mut unit = || {
            s = s.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        let points: Vec<Point2<f64>> =
            (0..45).map(|_| Point2::new(unit() * 20.0 - 10.0, unit() * 20.0 - 10.0)).collect();
        let table = Candidates::new(&points, 17.0, 3.5, 1.0);
        assert!(table.mean_len() < 10.0, "mean candidates {}", table.mean_len());
        assert!(table.at(0.0, 0.0).len() < 45);
        assert_eq!(table.listed(30.0, 0.0).len(), 45);
        assert_eq!(table.at(f64::NAN, 0.0).len(), 45);
        // The coordinates are the listed points', in reference order.
        let listed = table.listed(1.0, -2.0);
        assert!(listed.windows(2).all(|w| w[0] < w[1]));
        let want: Vec<[f64; 2]> = listed.iter().map(|&k| [points[k].x, points[k].y]).collect();
        assert_eq!(table.at(1.0, -2.0), &want[..]);
    }
}

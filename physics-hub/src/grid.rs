//! A uniform grid over the UAV positions of one tick: the spatial index that keeps the hub's
//! pairwise work (radio links, UAV–UAV contacts, the UAVs a scan can hit, the nearest other UAV)
//! near linear in the number of UAVs instead of quadratic.
//!
//! Why a grid and not a tree: the UAVs are many, of one size, rebuilt every tick, and the
//! queries are all "within radius r" with r known (radio range, 2·r_uav, LIDAR range); a grid of
//! cells of about that size is built in O(n) with no balancing and answers a query by looking at
//! the few cells the query square overlaps.
//!
//! Determinism: a query visits candidates cell by cell and, inside a cell, in ascending index;
//! callers that need an order (radio links, collision events) sort or keep index order, and the
//! callers that reduce (minimum distance, nearest hit per beam) are order-independent, so every
//! result equals the brute-force pairwise loop it replaces. Candidates are a superset: the caller
//! applies its exact predicate, so a query never changes which pairs qualify.

use std::collections::HashMap;

/// Slack added to every query radius [m], so that rounding in the cell arithmetic can never leave
/// out a point the caller's exact predicate would accept.
const SLACK_M: f64 = 1e-6;

/// The smallest cell side [m].
const MIN_CELL_M: f64 = 0.5;

/// Points (index = UAV index) bucketed by square cells of side `cell_m`.
#[derive(Debug, Clone)]
pub struct Grid {
    cell_m: f64,
    points: Vec<[f64; 2]>,
    /// Cell → indices of the points in it, ascending.
    cells: Cells,
    /// Smallest and largest cell coordinates used: bounds the nearest-neighbour ring search.
    lo: (i64, i64),
    hi: (i64, i64),
}

/// The buckets. A swarm's cells fill a small box, so they are kept dense, box row by box row:
/// a lookup is an index, where a hash map spent a sixth of the hub's integration step hashing
/// cell coordinates (`perf` of `hub_step/1000`). Points spread over a box of more than
/// [`DENSE_CELLS_PER_POINT`] cells per point keep the hash map.
#[derive(Debug, Clone)]
enum Cells {
    /// Cell (cx, cy) is slot `(cx − lo.0) · rows + (cy − lo.1)`; its points are
    /// `items[starts[slot]..starts[slot + 1]]`, ascending.
    Dense {
        rows: usize,
        starts: Vec<u32>,
        items: Vec<u32>,
    },
    Sparse(HashMap<(i64, i64), Vec<usize>>),
}

/// Most cells per point (plus [`DENSE_CELLS_SLACK`]) a dense grid may hold.
const DENSE_CELLS_PER_POINT: usize = 16;
/// See [`DENSE_CELLS_PER_POINT`].
const DENSE_CELLS_SLACK: usize = 1 << 16;

impl Grid {
    /// Buckets `points` into cells of side `cell_m` (> 0). Non-finite points are kept in no cell:
    /// no query finds them.
    pub fn new(points: &[[f64; 2]], cell_m: f64) -> Grid {
        // A degenerate size (zero range, say) still gives a usable grid; an infinite one, one cell.
        let cell_m = if cell_m.is_finite() { cell_m.max(MIN_CELL_M) } else { f64::MAX };
        let of: Vec<Option<(i64, i64)>> =
            points.iter().map(|p| (p[0].is_finite() && p[1].is_finite()).then(|| cell_of(*p, cell_m))).collect();
        let (mut lo, mut hi) = ((i64::MAX, i64::MAX), (i64::MIN, i64::MIN));
        for c in of.iter().flatten() {
            lo = (lo.0.min(c.0), lo.1.min(c.1));
            hi = (hi.0.max(c.0), hi.1.max(c.1));
        }
        let cells = dense_size(lo, hi, points.len())
            .map(|(cols, rows)| dense(&of, lo, cols, rows))
            .unwrap_or_else(|| sparse(&of));
        Grid { cell_m, points: points.to_vec(), cells, lo, hi }
    }

    /// Calls `f(j)` for the points of cell `c`, ascending.
    #[inline]
    fn visit(&self, c: (i64, i64), f: &mut impl FnMut(usize)) {
        match &self.cells {
            Cells::Dense { rows, starts, items } => {
                if c.0 < self.lo.0 || c.0 > self.hi.0 || c.1 < self.lo.1 || c.1 > self.hi.1 {
                    return;
                }
                // Inside the box, so both differences are small and non-negative.
                let slot = (c.0 - self.lo.0) as usize * rows + (c.1 - self.lo.1) as usize;
                items[starts[slot] as usize..starts[slot + 1] as usize].iter().for_each(|&j| f(j as usize));
            }
            Cells::Sparse(m) => {
                if let Some(v) = m.get(&c) {
                    v.iter().for_each(|&j| f(j));
                }
            }
        }
    }

    /// The points the grid was built from.
    pub fn points(&self) -> &[[f64; 2]] {
        &self.points
    }

    /// Calls `f(j)` for every point j whose cell meets the square of half-side `radius_m`
    /// around `p`: a superset of the points within `radius_m` of `p` (including `p`'s own index
    /// if it is one of the points).
    pub fn for_each_near(&self, p: [f64; 2], radius_m: f64, mut f: impl FnMut(usize)) {
        let r = radius_m + SLACK_M;
        let (x0, y0) = cell_of([p[0] - r, p[1] - r], self.cell_m);
        let (x1, y1) = cell_of([p[0] + r, p[1] + r], self.cell_m);
        // Clamp to the occupied cells, so a huge radius costs no more than the grid itself.
        for cx in x0.max(self.lo.0)..=x1.min(self.hi.0) {
            for cy in y0.max(self.lo.1)..=y1.min(self.hi.1) {
                self.visit((cx, cy), &mut f);
            }
        }
    }

    /// The indices j ≠ `i` near point `i` (see [`Grid::for_each_near`]), ascending.
    pub fn near_sorted(&self, i: usize, radius_m: f64) -> Vec<usize> {
        let mut out = Vec::new();
        self.for_each_near(self.points[i], radius_m, |j| {
            if j != i {
                out.push(j);
            }
        });
        out.sort_unstable();
        out
    }

    /// The smallest `dist(i, j)` over the points j ≠ `i`, `f64::INFINITY` when there is none:
    /// rings of cells around `i`'s cell are searched outward until no farther ring can hold a
    /// nearer point. `dist` must be a distance (symmetric, at least the larger axis difference).
    pub fn nearest(&self, i: usize, dist: impl Fn(usize) -> f64) -> f64 {
        let p = self.points[i];
        if self.lo.0 > self.hi.0 || !(p[0].is_finite() && p[1].is_finite()) {
            return f64::INFINITY;
        }
        let c = cell_of(p, self.cell_m);
        let reach = (c.0.saturating_sub(self.lo.0))
            .max(self.hi.0.saturating_sub(c.0))
            .max(c.1.saturating_sub(self.lo.1))
            .max(self.hi.1.saturating_sub(c.1));
        let mut best = f64::INFINITY;
        for k in 0..=reach {
            self.for_each_in_ring(c, k, |j| {
                if j != i {
                    best = best.min(dist(j));
                }
            });
            // After rings 0..=k every point closer than (k − 1)·cell (one cell of margin for
            // rounding) has been seen.
            if best <= (k - 1) as f64 * self.cell_m {
                break;
            }
        }
        best
    }

    /// Calls `f` for the points in the cells at Chebyshev distance exactly `k` from cell `c`.
    fn for_each_in_ring(&self, c: (i64, i64), k: i64, mut f: impl FnMut(usize)) {
        let mut visit = |cx: i64, cy: i64| self.visit((cx, cy), &mut f);
        if k == 0 {
            visit(c.0, c.1);
            return;
        }
        for dx in -k..=k {
            visit(c.0 + dx, c.1 - k);
            visit(c.0 + dx, c.1 + k);
        }
        for dy in -k + 1..k {
            visit(c.0 - k, c.1 + dy);
            visit(c.0 + k, c.1 + dy);
        }
    }
}

/// The columns and rows of a dense grid over cells `lo..=hi`, if it is small enough for `n`
/// points (see [`Cells`]); `None` for no cell at all or a box too large.
fn dense_size(lo: (i64, i64), hi: (i64, i64), n: usize) -> Option<(usize, usize)> {
    let cols = usize::try_from(hi.0.checked_sub(lo.0)?.checked_add(1)?).ok()?;
    let rows = usize::try_from(hi.1.checked_sub(lo.1)?.checked_add(1)?).ok()?;
    let limit = n.saturating_mul(DENSE_CELLS_PER_POINT).saturating_add(DENSE_CELLS_SLACK);
    (cols.checked_mul(rows)? <= limit && n < u32::MAX as usize).then_some((cols, rows))
}

/// Dense buckets of the cells `of` (a counting sort by slot, stable, so each cell's points stay
/// ascending).
fn dense(of: &[Option<(i64, i64)>], lo: (i64, i64), cols: usize, rows: usize) -> Cells {
    let slot = |c: (i64, i64)| (c.0 - lo.0) as usize * rows + (c.1 - lo.1) as usize;
    let mut starts = vec![0u32; cols * rows + 1];
    for c in of.iter().flatten() {
        starts[slot(*c) + 1] += 1;
    }
    for k in 1..starts.len() {
        starts[k] += starts[k - 1];
    }
    let mut next = starts.clone();
    let mut items = vec![0u32; starts[cols * rows] as usize];
    for (i, c) in of.iter().enumerate() {
        if let Some(c) = c {
            let k = &mut next[slot(*c)];
            items[*k as usize] = i as u32;
            *k += 1;
        }
    }
    Cells::Dense { rows, starts, items }
}

/// Hashed buckets of the cells `of`.
fn sparse(of: &[Option<(i64, i64)>]) -> Cells {
    let mut cells: HashMap<(i64, i64), Vec<usize>> = HashMap::new();
    for (i, c) in of.iter().enumerate() {
        if let Some(c) = c {
            cells.entry(*c).or_default().push(i);
        }
    }
    Cells::Sparse(cells)
}

/// The cell holding `p`.
fn cell_of(p: [f64; 2], cell_m: f64) -> (i64, i64) {
    // `as` saturates for huge values, so far-away points share an edge cell rather than wrap.
    ((p[0] / cell_m).floor() as i64, (p[1] / cell_m).floor() as i64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
        (a[0] - b[0]).hypot(a[1] - b[1])
    }

    proptest! {
        #[test]
        fn near_and_nearest_agree_with_brute_force(
            pts in proptest::collection::vec((-50.0..50.0f64, -50.0..50.0f64), 1..60),
            radius in 0.0..30.0f64,
            cell in 0.5..12.0f64,
        ) {
            let points: Vec<[f64; 2]> = pts.iter().map(|&(x, y)| [x, y]).collect();
            let g = Grid::new(&points, cell);
            for i in 0..points.len() {
                let near = g.near_sorted(i, radius);
                let brute: Vec<usize> =
                    (0..points.len()).filter(|&j| j != i && dist(points[i], points[j]) <= radius).collect();
                prop_assert!(brute.iter().all(|j| near.contains(j)), "missed a point within the radius");
                let nearest = (0..points.len()).filter(|&j| j != i).map(|j| dist(points[i], points[j])).fold(f64::INFINITY, f64::min);
                prop_assert_eq!(g.nearest(i, |j| dist(points[i], points[j])), nearest);
            }
        }
    }

    proptest! {
        /// A point far out makes the box too large for dense cells: the hashed cells answer every
        /// query with the same points in the same order as dense ones.
        #[test]
        fn dense_and_hashed_cells_visit_the_same_points_in_the_same_order(
            pts in proptest::collection::vec((-50.0..50.0f64, -50.0..50.0f64), 1..60),
            radius in 0.0..30.0f64,
            cell in 0.5..12.0f64,
        ) {
            let mut points: Vec<[f64; 2]> = pts.iter().map(|&(x, y)| [x, y]).collect();
            let dense = Grid::new(&points, cell);
            prop_assert!(matches!(dense.cells, Cells::Dense { .. }), "dense cells");
            points.push([1e9, 1e9]);
            points.push([f64::NAN, 0.0]);
            let sparse = Grid::new(&points, cell);
            prop_assert!(matches!(sparse.cells, Cells::Sparse(_)), "hashed cells");
            for &p in &points[..pts.len()] {
                let (mut a, mut b) = (Vec::new(), Vec::new());
                dense.for_each_near(p, radius, |j| a.push(j));
                sparse.for_each_near(p, radius, |j| b.push(j));
                prop_assert_eq!(a, b);
            }
        }
    }

    #[test]
    fn a_lone_point_has_no_nearest_and_far_points_are_not_near() {
        let g = Grid::new(&[[0.0, 0.0], [100.0, 0.0]], 5.0);
        assert_eq!(g.near_sorted(0, 10.0), Vec::<usize>::new());
        assert_eq!(g.nearest(0, |_| 100.0), 100.0);
        let lone = Grid::new(&[[3.0, 4.0]], 5.0);
        assert_eq!(lone.nearest(0, |_| 0.0), f64::INFINITY);
    }
}

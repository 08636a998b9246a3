//! A* on 8-connected cells, shared by the planners of the occupancy grid (A21, seed 003 IV-C)
//! and of the costmap (M23, seed 004 3.3): each hands in what entering a cell costs and its
//! heuristic, and gets cells back; the grid and the costmap turn them into a [`Path`].
//!
//! Why a module of its own: the search is the same for both maps (the A* of Hart, Nilsson and
//! Raphael 1968 that seeds 003 and 004 name), so it lives once, below both, knowing nothing of
//! occupancy or cost layers. [`astar`] is the search; [`CellSearch`] is a planning problem
//! (A* preceded by an escape from a start cell that cannot be entered).
//!
//! Choices where the seeds are silent:
//! - **A\***: 8-connected, a diagonal step only where both orthogonal neighbours are passable (no
//!   squeezing between two diagonal obstacle cells); a step costs the entered cell's unit cost
//!   times 1 or √2. Expanded cells are never reopened (no loss with a consistent heuristic, much
//!   less work with the inconsistent A21 one); f-ties go to the deepest cell. The search stays
//!   inside a window: the known map plus start and goal, widened by a margin. It stops after `max_expanded` expansions and then returns the path to the
//!   expanded cell closest to the goal, marked `reached_goal = false`, so a far goal never stalls
//!   a control step; `None` means the whole window was searched and the goal is unreachable, or the
//!   goal cell itself is blocked. A start cell inside an obstacle's inflation first escapes to the
//!   nearest free cell through non-obstacle cells (global_planner clears the robot cell for the
//!   same reason).

use std::cmp::Ordering;
use std::collections::{BinaryHeap, VecDeque};

use nalgebra::Point2;

use super::cells::{Cell, CellBox, CellMap};

/// Edge lengths of the 8-connected moves, in cells.
const DIAGONAL: f64 = std::f64::consts::SQRT_2;
/// The 8 moves: orthogonal first, then diagonal.
pub(super) const MOVES: [(i32, i32); 8] = [(1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1)];

/// Octile distance between cells: the length of the shortest 8-connected path with no obstacle,
/// `max(dx, dy) + (√2 − 1)·min(dx, dy)` [cells].
pub fn octile_cells(a: Cell, b: Cell) -> f64 {
    let dx = (f64::from(a.ix) - f64::from(b.ix)).abs();
    let dy = (f64::from(a.iy) - f64::from(b.iy)).abs();
    dx.max(dy) + (DIAGONAL - 1.0) * dx.min(dy)
}

/// A path found on a grid.
#[derive(Debug, Clone, PartialEq)]
pub struct Path {
    /// Way points in the odometry frame [m]: the exact start, the centres of the following cells,
    /// and the exact goal in place of the last cell's centre when the goal was reached.
    pub points: Vec<Point2<f64>>,
    /// The cells, start cell first.
    pub cells: Vec<Cell>,
    /// Sum of the step costs after the escape (see [`CellPath::cost`]).
    pub cost: f64,
    /// `false` for a partial path towards the goal (search limit hit).
    pub reached_goal: bool,
    /// Cells expanded by the search.
    pub expanded: usize,
}

impl Path {
    pub(crate) fn from_cells(
        cells: CellPath,
        start: Point2<f64>,
        goal: Point2<f64>,
        center_of: impl Fn(Cell) -> Point2<f64>,
    ) -> Path {
        let mut points: Vec<Point2<f64>> =
            std::iter::once(start).chain(cells.cells.iter().skip(1).map(|&c| center_of(c))).collect();
        if cells.reached_goal {
            if cells.cells.len() > 1 {
                points.pop();
            }
            points.push(goal);
        }
        Path {
            points,
            cells: cells.cells,
            cost: cells.cost,
            reached_goal: cells.reached_goal,
            expanded: cells.expanded,
        }
    }
}

/// The result of [`astar`]: cells from start to goal (or to the expanded cell closest to it).
#[derive(Debug, Clone, PartialEq)]
pub struct CellPath {
    /// The cells, start first.
    pub cells: Vec<Cell>,
    /// Sum of the step costs: entered cell's unit cost × 1 or √2 (an escape prefix, see
    /// [`CellSearch`], is not counted).
    pub cost: f64,
    /// Whether the last cell is the goal.
    pub reached_goal: bool,
    /// Cells expanded.
    pub expanded: usize,
}

/// `f` with its mantissa rounded to 36 bits (relative step 2^-36 ≈ 1.5e-11), so that costs equal
/// in exact arithmetic but apart by float rounding (sums of 1 and √2) compare as ties; monotone,
/// so the order stays a total order. Without it, the equal-f cells of an 8-connected grid are
/// taken in rounding-noise order instead of deepest first, and a long diagonal plan floods the
/// whole parallelogram between the two extreme octile paths.
fn tie_key(f: f64) -> f64 {
    const DROP: u32 = 16;
    if !f.is_finite() {
        return f;
    }
    f64::from_bits((f.to_bits() + (1 << (DROP - 1))) & !((1u64 << DROP) - 1))
}

/// An entry of the open list; the heap pops the smallest f (up to rounding, see [`tie_key`]),
/// then the smallest h (deepest first), then the lowest cell, so ties are broken the same way in
/// every run.
#[derive(Debug, Clone, Copy)]
struct Open {
    f: f64,
    h: f64,
    g: f64,
    cell: Cell,
}

impl Ord for Open {
    fn cmp(&self, other: &Self) -> Ordering {
        other.f.total_cmp(&self.f).then(other.h.total_cmp(&self.h)).then(other.cell.cmp(&self.cell))
    }
}
impl PartialOrd for Open {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl PartialEq for Open {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl Eq for Open {}

#[derive(Debug, Clone, Copy)]
struct Node {
    g: f64,
    h: f64,
    parent: Option<Cell>,
    closed: bool,
}

/// A* on 8-connected cells inside `window` (Hart, Nilsson and Raphael 1968, the A* of seeds 003
/// and 004).
///
/// `cell_cost(c)` is the cost per cell length of entering `c`, `None` (or a negative or
/// non-finite value) if `c` cannot be entered; a step costs it times 1 (orthogonal) or √2
/// (diagonal), and a diagonal step needs both orthogonal neighbours enterable. The start cell's
/// own cost is never asked. `heuristic(c)` estimates the cost from `c` to the goal; if it never
/// overestimates (admissible) and is consistent, the path is optimal; expanded cells are never
/// reopened. Each function is called at most once per cell. At most `max_expanded` cells are expanded; then the path to the expanded
/// cell closest to the goal is returned with `reached_goal = false`. `None`: start or goal outside
/// the window, the goal cannot be entered, or the window holds no path.
pub fn astar(
    start: Cell,
    goal: Cell,
    window: CellBox,
    max_expanded: usize,
    cell_cost: impl FnMut(Cell) -> Option<f64>,
    heuristic: impl FnMut(Cell) -> f64,
) -> Option<CellPath> {
    AStar::new(window, cell_cost, heuristic).run(start, goal, max_expanded)
}

struct AStar<C, H> {
    window: CellBox,
    cell_cost: C,
    heuristic: H,
    costs: CellMap<Cell, Option<f64>>,
    nodes: CellMap<Cell, Node>,
    open: BinaryHeap<Open>,
}

impl<C: FnMut(Cell) -> Option<f64>, H: FnMut(Cell) -> f64> AStar<C, H> {
    fn new(window: CellBox, cell_cost: C, heuristic: H) -> Self {
        AStar {
            window,
            cell_cost,
            heuristic,
            costs: CellMap::default(),
            nodes: CellMap::default(),
            open: BinaryHeap::new(),
        }
    }

    /// The unit cost of entering `c`, cached; `None` outside the window or if blocked.
    fn cost(&mut self, c: Cell) -> Option<f64> {
        if !self.window.contains(c) {
            return None;
        }
        let f = &mut self.cell_cost;
        *self.costs.entry(c).or_insert_with(|| f(c).filter(|v| v.is_finite() && *v >= 0.0))
    }

    fn h(&mut self, c: Cell) -> f64 {
        let h = (self.heuristic)(c);
        if h.is_nan() {
            0.0
        } else {
            h
        }
    }

    fn run(mut self, start: Cell, goal: Cell, max_expanded: usize) -> Option<CellPath> {
        if !self.window.contains(start) || (start != goal && self.cost(goal).is_none()) {
            return None;
        }
        let h0 = self.h(start);
        self.nodes.insert(start, Node { g: 0.0, h: h0, parent: None, closed: false });
        self.open.push(Open { f: tie_key(h0), h: h0, g: 0.0, cell: start });
        let (mut expanded, mut best) = (0usize, start);
        while let Some(top) = self.open.pop() {
            let Some(node) = self.nodes.get_mut(&top.cell) else { continue };
            if node.closed || top.g > node.g {
                continue;
            }
            node.closed = true;
            expanded += 1;
            if top.cell == goal {
                return Some(self.path_to(goal, true, expanded));
            }
            best = self.closer(best, top.cell, goal);
            if expanded >= max_expanded {
                return Some(self.path_to(best, false, expanded));
            }
            self.expand(top.cell, top.g);
        }
        None
    }

    /// The one of `a`, `b` closer to `goal` (straight line; ties: the cheaper one, then `a`).
    fn closer(&self, a: Cell, b: Cell, goal: Cell) -> Cell {
        let g = |c: Cell| self.nodes.get(&c).map_or(f64::INFINITY, |n| n.g);
        match b.dist2(goal).total_cmp(&a.dist2(goal)).then(g(b).total_cmp(&g(a))) {
            Ordering::Less => b,
            _ => a,
        }
    }

    fn expand(&mut self, cell: Cell, g: f64) {
        for (dx, dy) in MOVES {
            let next = cell.offset(dx, dy);
            let Some(unit) = self.cost(next) else { continue };
            let diagonal = dx != 0 && dy != 0;
            if diagonal && (self.cost(cell.offset(dx, 0)).is_none() || self.cost(cell.offset(0, dy)).is_none()) {
                continue;
            }
            let ng = g + unit * if diagonal { DIAGONAL } else { 1.0 };
            self.relax(cell, next, ng);
        }
    }

    /// Offers `cell` the cost `g` through `parent`. A closed cell is never reopened: with a
    /// consistent heuristic it cannot improve, and with an inconsistent one (A21) reopening
    /// would re-expand much of the map for a marginally shorter path.
    fn relax(&mut self, parent: Cell, cell: Cell, g: f64) {
        let h = match self.nodes.get(&cell) {
            Some(n) if n.closed || g >= n.g => return,
            Some(n) => n.h,
            None => self.h(cell),
        };
        self.nodes.insert(cell, Node { g, h, parent: Some(parent), closed: false });
        self.open.push(Open { f: tie_key(g + h), h, g, cell });
    }

    fn path_to(&self, end: Cell, reached_goal: bool, expanded: usize) -> CellPath {
        let mut cells = vec![end];
        let mut at = end;
        while let Some(p) = self.nodes.get(&at).and_then(|n| n.parent) {
            cells.push(p);
            at = p;
        }
        cells.reverse();
        let cost = self.nodes.get(&end).map_or(0.0, |n| n.g);
        CellPath { cells, cost, reached_goal, expanded }
    }
}

/// A planning problem on cells: A* preceded, when the start cell cannot be entered, by an escape
/// to the nearest enterable cell through `escapable` cells. Shared by the grid and costmap
/// planners.
pub(crate) struct CellSearch<C, E, H> {
    pub(crate) start: Cell,
    pub(crate) goal: Cell,
    pub(crate) window: CellBox,
    pub(crate) max_expanded: usize,
    pub(crate) cell_cost: C,
    pub(crate) escapable: E,
    pub(crate) heuristic: H,
}

impl<C, E, H> CellSearch<C, E, H>
where
    C: FnMut(Cell) -> Option<f64>,
    E: FnMut(Cell) -> bool,
    H: FnMut(Cell) -> f64,
{
    pub(crate) fn run(mut self) -> Option<CellPath> {
        let prefix = if (self.cell_cost)(self.start).is_some() || self.start == self.goal {
            vec![self.start]
        } else {
            self.escape()?
        };
        let from = *prefix.last()?;
        let mut rest = astar(from, self.goal, self.window, self.max_expanded, self.cell_cost, self.heuristic)?;
        let mut cells = prefix;
        cells.extend(rest.cells.drain(1..));
        Some(CellPath { cells, ..rest })
    }

    /// Breadth-first from the start through escapable cells to the first enterable one.
    fn escape(&mut self) -> Option<Vec<Cell>> {
        let mut parent: CellMap<Cell, Cell> = CellMap::default();
        let mut queue = VecDeque::from([self.start]);
        parent.insert(self.start, self.start);
        let mut visited = 0usize;
        while let Some(c) = queue.pop_front() {
            visited += 1;
            if visited > self.max_expanded {
                return None;
            }
            for (dx, dy) in MOVES {
                let n = c.offset(dx, dy);
                if !self.window.contains(n) || parent.contains_key(&n) || !(self.escapable)(n) {
                    continue;
                }
                parent.insert(n, c);
                if (self.cell_cost)(n).is_some() {
                    return Some(unwind(&parent, n));
                }
                queue.push_back(n);
            }
        }
        None
    }
}

/// The chain of parents from the root (its own parent) to `end`.
fn unwind(parent: &CellMap<Cell, Cell>, end: Cell) -> Vec<Cell> {
    let mut cells = vec![end];
    let mut at = end;
    while let Some(&p) = parent.get(&at).filter(|&&p| p != at) {
        cells.push(p);
        at = p;
    }
    cells.reverse();
    cells
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::collections::{HashMap, HashSet};

    /// Plain Dijkstra over every cell of `w × h`, same moves and costs as `astar`: the reference.
    fn dijkstra(w: i32, h: i32, cost: &dyn Fn(Cell) -> Option<f64>, start: Cell, goal: Cell) -> Option<f64> {
        let inside = |c: Cell| (0..w).contains(&c.ix) && (0..h).contains(&c.iy);
        let passable = |c: Cell| if inside(c) { cost(c) } else { None };
        let mut dist: HashMap<Cell, f64> = HashMap::new();
        let mut done: HashSet<Cell> = HashSet::new();
        dist.insert(start, 0.0);
        loop {
            let next = dist.iter().filter(|(c, _)| !done.contains(*c)).min_by(|a, b| a.1.total_cmp(b.1));
            let (&c, &d) = next?;
            if c == goal {
                return Some(d);
            }
            done.insert(c);
            for (dx, dy) in MOVES {
                let n = c.offset(dx, dy);
                let Some(unit) = passable(n) else { continue };
                let diagonal = dx != 0 && dy != 0;
                if diagonal && (passable(c.offset(dx, 0)).is_none() || passable(c.offset(0, dy)).is_none()) {
                    continue;
                }
                let nd = d + unit * if diagonal { DIAGONAL } else { 1.0 };
                if dist.get(&n).is_none_or(|&old| nd < old) {
                    dist.insert(n, nd);
                }
            }
        }
    }

    /// Width, height, unit cost of each cell (row-major, `None` = blocked), start, goal.
    type RandomGrid = (i32, i32, Vec<Option<f64>>, (i32, i32), (i32, i32));

    fn random_grid() -> impl Strategy<Value = RandomGrid> {
        (2i32..9, 2i32..9).prop_flat_map(|(w, h)| {
            let cell = prop_oneof![1 => Just(None), 3 => (1.0f64..5.0).prop_map(Some)];
            (Just(w), Just(h), prop::collection::vec(cell, (w * h) as usize), (0..w, 0..h), (0..w, 0..h))
        })
    }

    proptest! {
        #[test]
        fn astar_with_an_admissible_heuristic_is_optimal((w, h, costs, s, g) in random_grid()) {
            let cost = |c: Cell| costs[(c.iy * w + c.ix) as usize];
            let (start, goal) = (Cell::new(s.0, s.1), Cell::new(g.0, g.1));
            let window = CellBox { min: Cell::new(0, 0), max: Cell::new(w - 1, h - 1) };
            // Every unit cost is ≥ 1, so 1 × the octile distance (the free-space path length)
            // never overestimates; nor does the straight-line distance, which is shorter still.
            let found = astar(start, goal, window, 10_000, cost, |c| octile_cells(c, goal));
            let by_line = astar(start, goal, window, 10_000, cost, |c| c.dist2(goal).sqrt());
            let best = dijkstra(w, h, &cost, start, goal);
            prop_assert_eq!(found.is_some(), by_line.is_some());
            if let (Some(a), Some(b)) = (&found, &by_line) {
                prop_assert!((a.cost - b.cost).abs() < 1e-9);
            }
            match (&found, best) {
                (None, None) => {}
                (Some(p), Some(d)) => {
                    prop_assert!(p.reached_goal);
                    prop_assert!((p.cost - d).abs() < 1e-9, "A* {} vs Dijkstra {}", p.cost, d);
                    prop_assert_eq!(p.cells.first(), Some(&start));
                    prop_assert_eq!(p.cells.last(), Some(&goal));
                    // The path is a chain of legal moves whose costs add up to the reported cost.
                    let mut sum = 0.0;
                    for pair in p.cells.windows(2) {
                        let (dx, dy) = (pair[1].ix - pair[0].ix, pair[1].iy - pair[0].iy);
                        prop_assert!(dx.abs() <= 1 && dy.abs() <= 1 && (dx, dy) != (0, 0));
                        let unit = cost(pair[1]);
                        prop_assert!(unit.is_some());
                        sum += unit.unwrap_or(0.0) * if dx != 0 && dy != 0 { DIAGONAL } else { 1.0 };
                    }
                    prop_assert!((sum - p.cost).abs() < 1e-9);
                }
                _ => prop_assert!(false, "A* {:?} but Dijkstra {:?}", found, best),
            }
        }
    }
}

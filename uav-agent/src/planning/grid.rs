//! Occupancy grid built from this UAV's own LIDAR scans, and the seed 003 IV-C planner on it.
//!
//! The search itself, A* on cells with the escape from an inflated start, is [`super::astar`];
//! the cells, their hashing and the tiled storage are [`super::cells`].
//!
//! Why this module exists: the A21 navigation vector (seed 003 eq. 7) needs a path to the goal,
//! planned on the agent's own map (seed 003 section IV-C: Hector SLAM's occupancy grid, obstacles
//! inflated by the UAV size, A* whose heuristic is "the sum of euclidean distance to the goal and
//! the closest obstacle", unknown cells free). The M23 costmap ([`super::costmap`]) is built on
//! the same grid and reuses the same A*. The grid lives in the agent's odometry frame (its start
//! pose, a fixed world-like frame); SLAM itself is not simulated, the odometry pose is used as is.
//!
//! Choices where the seeds are silent:
//! - **Unbounded map by hashed tiles**: cells are grouped in 16 × 16 tiles kept in a hash map
//!   keyed by tile index, created on first write, so the map grows in every direction as the UAV
//!   flies, costs nothing where it never looked, and needs no re-centring. The hasher is a fixed
//!   multiply-rotate (no random seed), so runs are deterministic.
//! - **Cell update**: log-odds as in Hector mapping (the SLAM of seeds 003 and 004): a hit adds
//!   `ln(p_occ/(1−p_occ))`, a pass-through adds `ln(p_free/(1−p_free))`, with Hector's update
//!   factors of seed 004 Fig. 27 (0.8 and 0.45). Occupied means log-odds > 0. As in Hector, each
//!   cell is updated at most once per scan and a hit wins over a pass-through in the same scan.
//!   Values are clamped to [ln(0.12/0.88), ln(0.97/0.03)] (OctoMap's clamping), so a neighbour UAV
//!   that flew away is erased after a few scans instead of never.
//! - **Clearing along beams**: yes. Each beam clears the cells from the sensor cell up to, not
//!   including, its hit cell (Bresenham, as Hector). Points beyond `max_range_m` mark nothing but
//!   their beam clears up to `max_range_m` (costmap_2d's obstacle/raytrace range, 9 m in seed 004
//!   Fig. 30a).
//! - **The A21 heuristic** is implemented as written: `h = |c − goal| + d_obs(c)`, with d_obs the
//!   distance from cell c to the closest occupied cell, capped at `obstacle_cap_m` (an unbounded
//!   search for the closest obstacle would cost a control step, and with no obstacle in sight the
//!   term must be finite). It is NOT admissible: `d_obs` can exceed the remaining path length
//!   (h(goal) = d_obs(goal) > 0), so the path found need not be the shortest. Taken literally it
//!   also makes cells near obstacles look cheaper; with obstacles inflated by the UAV size that
//!   draws the path towards the inflated boundary. The tests compare it with
//!   [`Heuristic::Octile`] (admissible, the shortest path); what its looseness costs in
//!   expansions is at [`Heuristic::A21`].

use std::cell::RefCell;

use nalgebra::Point2;

use super::astar::{CellSearch, Path};
use super::cells::{Cell, CellBox, CellMap, TileMap, MAX_CELL, TILE};
use crate::geometry::{OdomPose, Pose2};

/// The closest-obstacle search never looks farther than this many cells.
const MAX_SEARCH_CELLS: i32 = 1024;

/// Map-building parameters. The defaults are seed 004's Hector mapping and costmap values.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridParams {
    /// Cell size [m] (seed 004 Fig. 27: Hector `map_resolution` 0.050).
    pub resolution_m: f64,
    /// Probability a hit gives its cell (seed 004 Fig. 27: `update_factor_occupied` 0.8).
    pub p_occupied: f64,
    /// Probability a pass-through gives a cell (seed 004 Fig. 27: `update_factor_free` 0.45).
    pub p_free: f64,
    /// Lower clamp of a cell's probability (OctoMap's 0.12; seeds silent).
    pub p_clamp_min: f64,
    /// Upper clamp of a cell's probability (OctoMap's 0.97; seeds silent).
    pub p_clamp_max: f64,
    /// Points farther than this mark nothing; beams clear at most this far [m] (seed 004
    /// Fig. 30a: `obstacle_range` = `raytrace_range` = 9.0).
    pub max_range_m: f64,
    /// Whether each beam clears the cells it passes through.
    pub clear_along_beams: bool,
}

impl Default for GridParams {
    fn default() -> Self {
        GridParams {
            resolution_m: 0.05,
            p_occupied: 0.8,
            p_free: 0.45,
            p_clamp_min: 0.12,
            p_clamp_max: 0.97,
            max_range_m: 9.0,
            clear_along_beams: true,
        }
    }
}

/// `ln(p / (1 − p))`.
fn log_odds(p: f64) -> f64 {
    (p / (1.0 - p)).ln()
}

/// What a cell is known to be.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CellState {
    /// Never seen; planners treat it as free (seed 003 IV-C).
    Unknown,
    /// Seen, log-odds ≤ 0.
    Free,
    /// Seen, log-odds > 0.
    Occupied,
}

/// Cells whose occupied/not-occupied state flipped in one [`OccupancyGrid::update`], in the
/// order they were updated.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct GridChanges {
    /// Cells that became occupied.
    pub occupied: Vec<Cell>,
    /// Cells that were occupied and are not any more.
    pub freed: Vec<Cell>,
}

/// One cell: its log-odds (NaN = unknown) and the last scan that touched it.
#[derive(Debug, Clone, Copy)]
struct CellData {
    log_odds: f32,
    /// `2·scan + 1` if the scan hit the cell, `2·scan` if a beam passed through it.
    mark: u32,
}

const UNKNOWN_CELL: CellData = CellData { log_odds: f32::NAN, mark: 0 };

/// The occupancy grid of one UAV, in its odometry frame, unbounded.
#[derive(Debug, Clone)]
pub struct OccupancyGrid {
    params: GridParams,
    cells: TileMap<CellData>,
    /// Occupied cells, grouped by tile, for closest-obstacle queries and inflation.
    occupied: CellMap<Cell, Vec<Cell>>,
    occupied_count: usize,
    known: Option<CellBox>,
    scan: u32,
}

impl OccupancyGrid {
    /// An empty grid (every cell unknown).
    pub fn new(params: GridParams) -> Self {
        OccupancyGrid {
            params,
            cells: TileMap::new(UNKNOWN_CELL),
            occupied: CellMap::default(),
            occupied_count: 0,
            known: None,
            scan: 0,
        }
    }

    /// The cell containing `p` (odometry frame), or `None` if `p` is not finite or too far out.
    pub fn cell_of(&self, p: &Point2<f64>) -> Option<Cell> {
        let res = self.params.resolution_m;
        let fx = (p.x / res).floor();
        let fy = (p.y / res).floor();
        if !(fx.abs() < MAX_CELL && fy.abs() < MAX_CELL) {
            return None;
        }
        Some(Cell::new(fx as i32, fy as i32))
    }

    /// The centre of cell `c` (odometry frame) [m].
    pub fn center_of(&self, c: Cell) -> Point2<f64> {
        let res = self.params.resolution_m;
        Point2::new((f64::from(c.ix) + 0.5) * res, (f64::from(c.iy) + 0.5) * res)
    }

    /// What cell `c` is known to be.
    pub fn state(&self, c: Cell) -> CellState {
        let l = self.cells.get(c).log_odds;
        if l.is_nan() {
            CellState::Unknown
        } else if l > 0.0 {
            CellState::Occupied
        } else {
            CellState::Free
        }
    }

    /// The log-odds of cell `c`, `None` if unknown (the tests check the updates with it).
    #[cfg(test)]
    pub fn log_odds(&self, c: Cell) -> Option<f64> {
        let l = self.cells.get(c).log_odds;
        (!l.is_nan()).then_some(f64::from(l))
    }

    /// Whether cell `c` is occupied.
    pub fn is_occupied(&self, c: Cell) -> bool {
        self.state(c) == CellState::Occupied
    }

    /// The smallest box holding every cell ever seen, `None` before the first scan (the planner
    /// reads the field; the tests check it here).
    #[cfg(test)]
    pub fn known_bounds(&self) -> Option<CellBox> {
        self.known
    }

    /// Number of occupied cells (the tests check the bookkeeping).
    #[cfg(test)]
    pub fn occupied_count(&self) -> usize {
        self.occupied_count
    }

    /// Number of 16 × 16 storage tiles allocated (memory grows with the area seen, not with the
    /// distance from the origin; the tests check it).
    #[cfg(test)]
    pub fn tile_count(&self) -> usize {
        self.cells.tile_count()
    }

    /// Every occupied cell, in a deterministic order (the costmap's tests inflate from it).
    #[cfg(test)]
    pub fn occupied_cells(&self) -> impl Iterator<Item = Cell> + '_ {
        self.occupied.values().flatten().copied()
    }

    /// Occupied cells in the tiles overlapping the square of half-width `radius_cells` around
    /// `c` (a superset of those within that distance).
    pub fn occupied_near(&self, c: Cell, radius_cells: i32) -> impl Iterator<Item = Cell> + '_ {
        let r = radius_cells.clamp(0, MAX_SEARCH_CELLS);
        let (lo, hi) = (c.offset(-r, -r).tile(), c.offset(r, r).tile());
        (lo.iy..=hi.iy)
            .flat_map(move |ty| (lo.ix..=hi.ix).map(move |tx| Cell::new(tx, ty)))
            .filter_map(|t| self.occupied.get(&t))
            .flatten()
            .copied()
    }

    /// Distance from the centre of `c` to the centre of the closest occupied cell [m], if one lies
    /// within `cap_m` (the search never looks farther, nor farther than 1024 cells).
    pub fn nearest_occupied_m(&self, c: Cell, cap_m: f64) -> Option<f64> {
        let res = self.params.resolution_m;
        let cap_cells = if cap_m.is_finite() && cap_m >= 0.0 { cap_m / res } else { 0.0 };
        let r = (cap_cells.ceil() as i32).clamp(0, MAX_SEARCH_CELLS);
        let limit2 = cap_cells * cap_cells + 1e-9;
        let mut best2 = f64::INFINITY;
        let (lo, hi) = (c.offset(-r, -r).tile(), c.offset(r, r).tile());
        for ty in lo.iy..=hi.iy {
            for tx in lo.ix..=hi.ix {
                let Some(list) = self.occupied.get(&Cell::new(tx, ty)) else { continue };
                let floor2 = tile_dist2(c, Cell::new(tx, ty));
                if floor2 >= best2 || floor2 > limit2 {
                    continue;
                }
                best2 = list.iter().fold(best2, |b, o| b.min(c.dist2(*o)));
            }
        }
        (best2 <= limit2).then(|| best2.sqrt() * res)
    }

    /// Integrates one scan taken at `pose` (odometry frame). `points_in_body` are the LIDAR hits
    /// in the body frame (no-return beams left out); non-finite points are ignored, a non-finite
    /// pose ignores the scan. Returns the cells whose occupancy flipped.
    pub fn update(&mut self, pose: Pose2, points_in_body: &[Point2<f64>]) -> GridChanges {
        let mut changes = GridChanges::default();
        if !pose.is_finite() {
            return changes;
        }
        let Some(origin) = self.cell_of(&pose.point()) else { return changes };
        self.scan = self.scan.wrapping_add(1);
        let ends: Vec<(Cell, bool)> = points_in_body.iter().filter_map(|p| self.beam_end(&pose, p)).collect();
        // Hits first, so a pass-through of another beam cannot undo them (Hector: the hit wins).
        let l_hit = log_odds(self.params.p_occupied);
        for &(end, hit) in &ends {
            if hit {
                self.touch(end, true, l_hit, &mut changes);
            }
        }
        if self.params.clear_along_beams {
            let l_free = log_odds(self.params.p_free);
            for &(end, hit) in &ends {
                for c in bresenham(origin, end, !hit) {
                    self.touch(c, false, l_free, &mut changes);
                }
            }
        }
        changes
    }

    /// The cell a beam ends in, and whether it is a hit (within range) or a range-limited beam.
    fn beam_end(&self, pose: &Pose2, p: &Point2<f64>) -> Option<(Cell, bool)> {
        let range = p.coords.norm();
        if !range.is_finite() {
            return None;
        }
        let max = self.params.max_range_m;
        if range <= max {
            return self.cell_of(&pose.odom_from_body(p)).map(|c| (c, true));
        }
        if max.is_nan() || max <= 0.0 {
            return None;
        }
        let p_max = Point2::from(p.coords * (max / range));
        self.cell_of(&pose.odom_from_body(&p_max)).map(|c| (c, false))
    }

    /// Applies one hit or pass-through to cell `c`, at most once per scan; a hit of this scan is
    /// never followed by a pass-through.
    fn touch(&mut self, c: Cell, hit: bool, delta: f64, changes: &mut GridChanges) {
        let miss_mark = self.scan.wrapping_mul(2);
        let hit_mark = miss_mark.wrapping_add(1);
        let (lo, hi) = (log_odds(self.params.p_clamp_min), log_odds(self.params.p_clamp_max));
        let cell = self.cells.get_mut(c);
        if cell.mark == hit_mark || (!hit && cell.mark == miss_mark) {
            return;
        }
        let was = cell.log_odds > 0.0;
        let base = if cell.log_odds.is_nan() { 0.0 } else { f64::from(cell.log_odds) };
        // Hector log-odds update, clamped: l ← clamp(l + ln(p/(1−p))).
        cell.log_odds = (base + delta).clamp(lo.min(hi), hi.max(lo)) as f32;
        cell.mark = if hit { hit_mark } else { miss_mark };
        let now = cell.log_odds > 0.0;
        self.known = Some(self.known.map_or(CellBox::around(c), |b| b.including(c)));
        if was != now {
            self.set_occupied(c, now, changes);
        }
    }

    fn set_occupied(&mut self, c: Cell, occupied: bool, changes: &mut GridChanges) {
        if occupied {
            self.occupied.entry(c.tile()).or_default().push(c);
            self.occupied_count += 1;
            changes.occupied.push(c);
            return;
        }
        let Some(list) = self.occupied.get_mut(&c.tile()) else { return };
        if let Some(i) = list.iter().position(|&o| o == c) {
            list.swap_remove(i);
            self.occupied_count -= 1;
            changes.freed.push(c);
        }
        if list.is_empty() {
            self.occupied.remove(&c.tile());
        }
    }

    /// Sets cell `c` to the clamp value of its state, as if seen many times (tests build maps
    /// cell by cell with it).
    #[cfg(test)]
    pub(crate) fn set_cell(&mut self, c: Cell, occupied: bool) -> GridChanges {
        let mut changes = GridChanges::default();
        let p = if occupied { self.params.p_clamp_max } else { self.params.p_clamp_min };
        let cell = self.cells.get_mut(c);
        let was = cell.log_odds > 0.0;
        cell.log_odds = log_odds(p) as f32;
        self.known = Some(self.known.map_or(CellBox::around(c), |b| b.including(c)));
        if was != occupied {
            self.set_occupied(c, occupied, &mut changes);
        }
        changes
    }

    /// The search window for a plan from `start` to `goal`: the known map plus both cells,
    /// widened by `margin_m`.
    pub fn search_window(&self, start: Cell, goal: Cell, margin_m: f64) -> CellBox {
        let margin = if margin_m.is_finite() && margin_m > 0.0 {
            (margin_m / self.params.resolution_m).ceil().min(MAX_CELL) as i32
        } else {
            0
        };
        let b = self.known.map_or(CellBox::around(start), |k| k.including(start));
        b.including(goal).grown(margin.max(1))
    }

    /// Plans from `start` to `goal` (odometry frame) with the seed 003 IV-C planner: cells within
    /// `inflation_radius_m` of an occupied cell are blocked, unknown cells are free, and the
    /// heuristic is `params.heuristic`. Step costs are metres.
    pub fn plan(&self, start: Point2<f64>, goal: Point2<f64>, params: &PlanParams) -> Option<Path> {
        let (s, g) = (self.cell_of(&start)?, self.cell_of(&goal)?);
        let window = self.search_window(s, g, params.limits.margin_m);
        let cap = match params.heuristic {
            #[cfg(test)]
            Heuristic::Octile => params.inflation_radius_m,
            Heuristic::A21 => params.inflation_radius_m.max(params.obstacle_cap_m),
        };
        let memo: RefCell<CellMap<Cell, Option<f64>>> = RefCell::default();
        let d_obs = |c: Cell| *memo.borrow_mut().entry(c).or_insert_with(|| self.nearest_occupied_m(c, cap));
        let res = self.params.resolution_m;
        let blocked = |c: Cell| self.is_occupied(c) || d_obs(c).is_some_and(|d| d <= params.inflation_radius_m);
        let goal_center = self.center_of(g);
        let heuristic = |c: Cell| {
            let to_goal = (self.center_of(c) - goal_center).norm();
            match params.heuristic {
                #[cfg(test)]
                Heuristic::Octile => super::astar::octile_cells(c, g) * res,
                Heuristic::A21 => a21_heuristic(to_goal, d_obs(c).unwrap_or(cap)),
            }
        };
        let search = CellSearch {
            start: s,
            goal: g,
            window,
            max_expanded: params.limits.max_expanded,
            cell_cost: |c: Cell| (!blocked(c)).then_some(res),
            escapable: |c: Cell| !self.is_occupied(c),
            heuristic,
        };
        let cells = search.run()?;
        Some(Path::from_cells(cells, start, goal, |c| self.center_of(c)))
    }
}

/// Squared distance in cells² from cell `c` to the nearest cell of tile `t` (0 inside it).
fn tile_dist2(c: Cell, t: Cell) -> f64 {
    let axis = |v: i32, tile: i32| {
        let lo = i64::from(tile) * i64::from(TILE);
        let hi = lo + i64::from(TILE) - 1;
        let v = i64::from(v);
        (lo - v).max(v - hi).max(0) as f64
    };
    let (dx, dy) = (axis(c.ix, t.ix), axis(c.iy, t.iy));
    dx * dx + dy * dy
}

/// The cells of a Bresenham line from `a` towards `b`: `a` included, `b` included only if
/// `include_end`.
fn bresenham(a: Cell, b: Cell, include_end: bool) -> impl Iterator<Item = Cell> {
    let (x1, y1) = (i64::from(b.ix), i64::from(b.iy));
    let (dx, dy) = ((x1 - i64::from(a.ix)).abs(), -(y1 - i64::from(a.iy)).abs());
    let (sx, sy) = (if x1 >= i64::from(a.ix) { 1 } else { -1 }, if y1 >= i64::from(a.iy) { 1 } else { -1 });
    let mut state = Some((i64::from(a.ix), i64::from(a.iy), dx + dy));
    std::iter::from_fn(move || {
        let (x, y, err) = state?;
        let here = Cell::new(x as i32, y as i32);
        if x == x1 && y == y1 {
            state = None;
            return include_end.then_some(here);
        }
        let (mut nx, mut ny, mut ne) = (x, y, err);
        if 2 * err >= dy {
            ne += dy;
            nx += sx;
        }
        if 2 * err <= dx {
            ne += dx;
            ny += sy;
        }
        state = Some((nx, ny, ne));
        Some(here)
    })
}

/// Which heuristic [`OccupancyGrid::plan`] uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Heuristic {
    /// Octile distance to the goal, the exact 8-connected path length in free space: admissible
    /// and consistent, so the path is the shortest; the tests' baseline to compare A21 with (the
    /// agent plans with A21).
    #[cfg(test)]
    Octile,
    /// Seed 003 IV-C as written: Euclidean distance to the goal plus distance to the closest
    /// obstacle (inadmissible). It is loose on an 8-connected grid, and its obstacle term makes
    /// every cell near a tree look up to `obstacle_cap_m` cheaper: a 30 m plan through a test
    /// forest on 0.1 m cells expanded ≈ 13 500 cells, where the same obstacle term with the
    /// octile goal distance expanded ≈ 4 500 and [`Heuristic::Octile`] ≈ 500; on 0.05 m cells it
    /// hit the 50 000 limit.
    A21,
}

/// Where the search stops.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SearchLimits {
    /// At most this many cells are expanded; then the best partial path is returned (seeds
    /// silent; project default 50 000).
    pub max_expanded: usize,
    /// The search window is the known map plus start and goal, widened by this much [m] (seeds
    /// silent; project default 2 m).
    pub margin_m: f64,
}

impl Default for SearchLimits {
    fn default() -> Self {
        SearchLimits { max_expanded: 50_000, margin_m: 2.0 }
    }
}

/// Parameters of the seed 003 IV-C planner on the occupancy grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanParams {
    /// The heuristic.
    pub heuristic: Heuristic,
    /// Cells whose centre is within this distance of an occupied cell's centre are blocked:
    /// "obstacles in the map are inflated w.r.t. the UAV size" (seed 003 IV-C) [m]. Default 0.3,
    /// the project's default body radius.
    pub inflation_radius_m: f64,
    /// The closest-obstacle term of the A21 heuristic is capped here [m] (seed silent; default
    /// 2.0, the collision-control range dr of seed 003 Table I).
    pub obstacle_cap_m: f64,
    /// Search limits.
    pub limits: SearchLimits,
}

impl Default for PlanParams {
    fn default() -> Self {
        PlanParams {
            heuristic: Heuristic::A21,
            inflation_radius_m: 0.3,
            obstacle_cap_m: 2.0,
            limits: SearchLimits::default(),
        }
    }
}

/// The A21 heuristic of seed 003 IV-C: "the sum of euclidean distance to the goal and the closest
/// obstacle", `h = d_goal + d_obs` [m]. Inadmissible (see the module doc).
pub fn a21_heuristic(distance_to_goal_m: f64, distance_to_closest_obstacle_m: f64) -> f64 {
    // seed 003 section IV-C
    distance_to_goal_m + distance_to_closest_obstacle_m
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::planning::astar::MOVES;
    use std::f64::consts::FRAC_PI_2;

    /// ln(0.8/0.2) = ln 4, Hector's occupied update of seed 004 Fig. 27.
    const L_HIT: f64 = 1.386_294_361_119_890_6;
    /// ln(0.45/0.55), Hector's free update of seed 004 Fig. 27.
    const L_FREE: f64 = -0.200_670_695_462_151_1;

    fn grid(resolution_m: f64) -> OccupancyGrid {
        OccupancyGrid::new(GridParams { resolution_m, ..GridParams::default() })
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-6
    }

    /// LIDAR hits on a circle (centre, radius) in the body frame, `beams` beams over 360°.
    fn scan_circle(cx: f64, cy: f64, r: f64, beams: usize) -> Vec<Point2<f64>> {
        (0..beams)
            .filter_map(|i| {
                let th = i as f64 * std::f64::consts::TAU / beams as f64;
                let (dx, dy) = (th.cos(), th.sin());
                let b = dx * cx + dy * cy;
                let disc = b * b - (cx * cx + cy * cy - r * r);
                let t = b - disc.sqrt();
                (disc >= 0.0 && t > 0.0).then(|| Point2::new(t * dx, t * dy))
            })
            .collect()
    }

    #[test]
    fn log_odds_constants_are_the_hector_factors_of_seed_004() {
        assert!(close(log_odds(0.8), L_HIT));
        assert!(close(log_odds(0.45), L_FREE));
    }

    #[test]
    fn cells_floor_negative_coordinates() {
        let g = grid(0.5);
        // floor(-0.1/0.5) = floor(-0.2) = -1; floor(0.74/0.5) = floor(1.48) = 1.
        assert_eq!(g.cell_of(&Point2::new(-0.1, 0.74)), Some(Cell::new(-1, 1)));
        assert_eq!(g.center_of(Cell::new(-1, 1)), Point2::new(-0.25, 0.75));
        assert_eq!(g.cell_of(&Point2::new(f64::NAN, 0.0)), None);
        assert_eq!(g.cell_of(&Point2::new(1e300, 0.0)), None);
    }

    #[test]
    fn a_synthetic_scan_marks_the_right_cells() {
        let mut g = grid(0.5);
        // Pose (1.2, 2.2), yaw 90°: sensor cell (floor 2.4, floor 4.4) = (2, 4).
        // Body (2.0, 0.1) -> world (1.2 − 0.1, 2.2 + 2.0) = (1.1, 4.2) -> cell (2, 8).
        // Body (0.0, −1.1) -> world (1.2 + 1.1, 2.2) = (2.3, 2.2) -> cell (4, 4).
        // Body (0.05, −1.15) -> world (2.35, 2.25) -> cell (4, 4) again: one hit only.
        // Body (0.0, −2.1) -> world (3.3, 2.2) -> cell (6, 4); its beam crosses (4, 4), which
        // keeps its hit (Hector: the hit wins within a scan).
        let pts = [Point2::new(2.0, 0.1), Point2::new(0.0, -1.1), Point2::new(0.05, -1.15), Point2::new(0.0, -2.1)];
        let changes = g.update(Pose2::new(1.2, 2.2, FRAC_PI_2), &pts);
        assert_eq!(changes.occupied, vec![Cell::new(2, 8), Cell::new(4, 4), Cell::new(6, 4)]);
        assert!(changes.freed.is_empty());
        for c in [Cell::new(2, 8), Cell::new(4, 4), Cell::new(6, 4)] {
            assert_eq!(g.state(c), CellState::Occupied, "{c:?}");
            assert!(close(g.log_odds(c).expect("known"), L_HIT), "{c:?}");
        }
        // Beam cells, each passed once in this scan (the sensor cell is on every beam).
        for c in [(2, 4), (2, 5), (2, 6), (2, 7), (3, 4), (5, 4)].map(|(x, y)| Cell::new(x, y)) {
            assert_eq!(g.state(c), CellState::Free, "{c:?}");
            assert!(close(g.log_odds(c).expect("known"), L_FREE), "{c:?}");
        }
        // Behind a hit and beside the beams: never seen.
        for c in [(2, 9), (3, 5), (7, 4), (1, 4)].map(|(x, y)| Cell::new(x, y)) {
            assert_eq!(g.state(c), CellState::Unknown, "{c:?}");
        }
        assert_eq!(g.known_bounds(), Some(CellBox { min: Cell::new(2, 4), max: Cell::new(6, 8) }));
        assert_eq!(g.occupied_count(), 3);
    }

    #[test]
    fn beams_clear_a_cell_after_enough_passes_and_values_are_clamped() {
        let mut g = grid(0.5);
        let pose = Pose2::new(0.25, 0.25, 0.0); // sensor cell (0, 0)
                                                // Scan 1 hits (4, 0): world (2.25, 0.25).
        g.update(pose, &[Point2::new(2.0, 0.0)]);
        // Then every scan hits (8, 0) and passes through (4, 0).
        for k in 1..=6 {
            let ch = g.update(pose, &[Point2::new(4.0, 0.0)]);
            assert!(ch.freed.is_empty(), "scan {k}");
        }
        // ln4 − 6 · 0.2006707 = 0.182270 > 0: still occupied.
        assert!(close(g.log_odds(Cell::new(4, 0)).expect("known"), L_HIT + 6.0 * L_FREE));
        assert!(g.is_occupied(Cell::new(4, 0)));
        let ch = g.update(pose, &[Point2::new(4.0, 0.0)]);
        // ln4 − 7 · 0.2006707 = −0.018402 <= 0: freed.
        assert_eq!(ch.freed, vec![Cell::new(4, 0)]);
        assert_eq!(g.state(Cell::new(4, 0)), CellState::Free);
        // (8, 0) was hit 7 times: 7 ln4 = 9.7 is clamped to ln(0.97/0.03) = 3.476099.
        assert!(close(g.log_odds(Cell::new(8, 0)).expect("known"), 3.476_098_714_273_987));
        // (1, 0) was passed 8 times: 8 · −0.2007 = −1.605; 3 more scans give −2.207, clamped to
        // ln(0.12/0.88) = −1.992430.
        assert!(close(g.log_odds(Cell::new(1, 0)).expect("known"), 8.0 * L_FREE));
        for _ in 0..3 {
            g.update(pose, &[Point2::new(4.0, 0.0)]);
        }
        assert!(close(g.log_odds(Cell::new(1, 0)).expect("known"), -1.992_430_164_690_206));
    }

    #[test]
    fn points_beyond_max_range_clear_but_do_not_mark() {
        let mut g = OccupancyGrid::new(GridParams { resolution_m: 0.5, max_range_m: 2.0, ..GridParams::default() });
        // A hit 4 m ahead is out of range: the beam clears (0,0)..=(4,0) (x ≤ 2.25 m), marks nothing.
        let ch = g.update(Pose2::new(0.25, 0.25, 0.0), &[Point2::new(4.0, 0.0)]);
        assert!(ch.occupied.is_empty());
        assert_eq!(g.state(Cell::new(4, 0)), CellState::Free);
        assert_eq!(g.state(Cell::new(5, 0)), CellState::Unknown);
        assert_eq!(g.state(Cell::new(8, 0)), CellState::Unknown);
    }

    #[test]
    fn non_finite_input_is_ignored() {
        let mut g = grid(0.5);
        assert_eq!(g.update(Pose2::new(f64::NAN, 0.0, 0.0), &[Point2::new(1.0, 0.0)]), GridChanges::default());
        let ch = g.update(Pose2::new(0.25, 0.25, 0.0), &[Point2::new(f64::INFINITY, 0.0), Point2::new(1.0, 0.0)]);
        assert_eq!(ch.occupied, vec![Cell::new(2, 0)]);
        assert_eq!(g.plan(Point2::new(f64::NAN, 0.0), Point2::new(1.0, 1.0), &PlanParams::default()), None);
    }

    #[test]
    fn the_map_grows_far_from_the_origin() {
        let mut g = grid(0.1);
        let pose = Pose2::new(10_000.3, -20_000.7, 0.3);
        // A trunk of radius 0.3 m, 3 m ahead of the UAV.
        let pts = scan_circle(3.0, 0.0, 0.3, 720);
        assert!(pts.len() > 10);
        g.update(pose, &pts);
        let trunk = pose.odom_from_body(&Point2::new(3.0, 0.0));
        // The hit closest to the UAV: 2.7 m ahead.
        let near_side = g.cell_of(&pose.odom_from_body(&Point2::new(2.7, 0.0))).expect("cell");
        assert!(g.is_occupied(near_side));
        let b = g.known_bounds().expect("bounds");
        assert!(b.contains(g.cell_of(&pose.point()).expect("cell")));
        assert!(b.min.ix > 99_000 && b.max.iy < -199_000, "{b:?}");
        // Only the area seen is stored: 9 m range, 16 × 0.1 m tiles -> well under 1000 tiles.
        assert!(g.tile_count() < 1000, "{}", g.tile_count());
        // Plan past the trunk to a goal 20 m beyond it, in space never seen (unknown = free).
        let goal = pose.odom_from_body(&Point2::new(23.0, 0.0));
        let path = g.plan(pose.point(), goal, &PlanParams::default()).expect("path");
        assert!(path.reached_goal);
        assert_eq!(path.points.last(), Some(&goal));
        let octile = PlanParams { heuristic: Heuristic::Octile, ..PlanParams::default() };
        let shortest = g.plan(pose.point(), goal, &octile).expect("path");
        assert!(shortest.reached_goal && path.cost >= shortest.cost - 1e-9);
        // Inflated by 0.3 m: no way point comes within 0.3 m of a hit cell (0.3 m + the trunk's
        // 0.3 m of the centre), allowing a cell diagonal of discretisation.
        let clearance = path.points.iter().map(|p| (p - trunk).norm()).fold(f64::INFINITY, f64::min);
        assert!(clearance > 0.6 - 0.15, "{clearance}");
    }

    #[test]
    fn nearest_occupied_distance_and_cap() {
        let mut g = grid(0.5);
        g.set_cell(Cell::new(5, 0), true);
        g.set_cell(Cell::new(40, 0), true);
        // From (2, 4): (3, −4) cells = 5 cells = 2.5 m.
        assert_eq!(g.nearest_occupied_m(Cell::new(2, 4), 10.0), Some(2.5));
        assert_eq!(g.nearest_occupied_m(Cell::new(2, 4), 2.5), Some(2.5));
        assert_eq!(g.nearest_occupied_m(Cell::new(2, 4), 2.0), None);
        assert_eq!(g.nearest_occupied_m(Cell::new(5, 0), 0.0), Some(0.0));
        // (38, 0) is 2 cells from (40, 0), 33 from (5, 0) across tiles.
        assert_eq!(g.nearest_occupied_m(Cell::new(38, 0), 100.0), Some(1.0));
    }

    #[test]
    fn the_a21_heuristic_is_goal_distance_plus_obstacle_distance() {
        // seed 003 IV-C: h = d_goal + d_obs.
        assert_eq!(a21_heuristic(3.0, 4.0), 7.0);
        // On a map: one obstacle at cell (5, 0), res 0.5, cell (2, 4) with the goal at cell
        // (2, 0): d_goal = 4 cells = 2 m, d_obs = 5 cells = 2.5 m, h = 4.5 m. This h overestimates
        // the true remaining cost (2 m): inadmissible.
        let mut g = grid(0.5);
        g.set_cell(Cell::new(5, 0), true);
        let d_goal = (g.center_of(Cell::new(2, 4)) - g.center_of(Cell::new(2, 0))).norm();
        let d_obs = g.nearest_occupied_m(Cell::new(2, 4), 10.0).expect("obstacle");
        assert_eq!(a21_heuristic(d_goal, d_obs), 4.5);
    }

    /// A wall of occupied cells at column 10, rows −5..=5.
    fn walled(res: f64) -> OccupancyGrid {
        let mut g = grid(res);
        for iy in -5..=5 {
            g.set_cell(Cell::new(10, iy), true);
        }
        g
    }

    #[test]
    fn the_a21_planner_finds_a_path_around_a_wall() {
        let g = walled(0.1);
        let (start, goal) = (Point2::new(0.05, 0.05), Point2::new(2.05, 0.05));
        let params = PlanParams { inflation_radius_m: 0.2, ..PlanParams::default() };
        // The admissible heuristic gives the shortest path.
        let octile = g.plan(start, goal, &PlanParams { heuristic: Heuristic::Octile, ..params }).expect("path");
        assert!(octile.reached_goal);
        let a21 = g.plan(start, goal, &params).expect("path");
        assert!(a21.reached_goal);
        assert_eq!(a21.points.first(), Some(&start));
        assert_eq!(a21.points.last(), Some(&goal));
        for w in a21.cells.windows(2) {
            assert!((w[0].ix - w[1].ix).abs() <= 1 && (w[0].iy - w[1].iy).abs() <= 1, "{w:?}");
        }
        for c in &a21.cells {
            let d = g.nearest_occupied_m(*c, 1.0);
            assert!(d.is_none_or(|d| d > 0.2 + 1e-9), "{c:?} is inside the inflation: {d:?}");
        }
        // Inadmissible: never shorter than the shortest.
        assert!(a21.cost >= octile.cost - 1e-9, "{} < {}", a21.cost, octile.cost);
        // The wall spans rows −5..=5, inflated by 2 cells: the path detours to |row| ≥ 8.
        assert!(a21.cells.iter().any(|c| c.iy.abs() >= 8), "{:?}", a21.cells);
    }

    #[test]
    fn astar_returns_none_when_the_goal_is_walled_in() {
        let mut g = grid(0.1);
        // A closed ring around the goal cell (20, 0).
        for (dx, dy) in MOVES {
            g.set_cell(Cell::new(20 + dx, dy), true);
        }
        let params = PlanParams { heuristic: Heuristic::Octile, inflation_radius_m: 0.0, ..PlanParams::default() };
        assert_eq!(g.plan(Point2::new(0.05, 0.05), Point2::new(2.05, 0.05), &params), None);
        // Open one side of the ring: now reachable.
        g.set_cell(Cell::new(21, 0), false);
        let path = g.plan(Point2::new(0.05, 0.05), Point2::new(2.05, 0.05), &params).expect("path");
        assert!(path.reached_goal);
        assert_eq!(path.cells.last(), Some(&Cell::new(20, 0)));
    }

    #[test]
    fn a_far_goal_stops_at_the_expansion_limit_with_a_partial_path() {
        let g = grid(0.1);
        let params = PlanParams {
            heuristic: Heuristic::Octile,
            limits: SearchLimits { max_expanded: 10, margin_m: 2.0 },
            ..PlanParams::default()
        };
        let path = g.plan(Point2::new(0.05, 0.05), Point2::new(1000.05, 0.05), &params).expect("partial");
        assert!(!path.reached_goal);
        assert_eq!(path.expanded, 10);
        // Straight at the goal: the 10th expanded cell is 9 cells ahead.
        assert_eq!(path.cells.last(), Some(&Cell::new(9, 0)));
        assert!(close(path.cost, 0.9));
    }

    #[test]
    fn a_start_inside_the_inflation_escapes_first() {
        let mut g = grid(0.1);
        g.set_cell(Cell::new(1, 0), true);
        // Start in cell (0, 0), 0.1 m from the obstacle, inflation 0.25 m.
        let params = PlanParams { heuristic: Heuristic::Octile, inflation_radius_m: 0.25, ..PlanParams::default() };
        let path = g.plan(Point2::new(0.05, 0.05), Point2::new(-1.95, 0.05), &params).expect("path");
        assert!(path.reached_goal);
        assert_eq!(path.cells.first(), Some(&Cell::new(0, 0)));
        // Escape: BFS reaches the first cell farther than 0.25 m = 2.5 cells from (1, 0), i.e.
        // (−2, ·) in three steps; from there on every cell is free of the inflation.
        let free_from = path.cells.iter().position(|c| g.nearest_occupied_m(*c, 0.25).is_none()).expect("escaped");
        assert!(path.cells[free_from..].iter().all(|c| g.nearest_occupied_m(*c, 0.25).is_none()));
    }
}

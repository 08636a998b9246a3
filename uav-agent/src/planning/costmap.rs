//! The costmap of seed 004 chapter 3 (M23): obstacles from this UAV's occupancy grid, inflated
//! the costmap_2d way, plus a social layer for the neighbours, and the global_planner-style A* on
//! it.
//!
//! Why this module exists: the M23 controller plans its global path by A* on a costmap (seed 004
//! 3.3, Fig. 32–33), validates formation goals against it (Fig. 40–42), and keeps away from its
//! neighbours through the social layer (2.4, eq. 11). The seed ran ROS `move_base` with
//! costmap_2d, the ProxemicLayer of `social_navigation_layers` and `global_planner`; this module
//! reproduces those cost rules with the seed's parameters (Fig. 30a and 33, in
//! [`CostmapParams`]). The map is a [`super::grid::OccupancyGrid`] in the odometry frame, so it
//! grows as the UAV flies.
//!
//! Cost values are costmap_2d's: [`FREE_SPACE`] 0, inflated 1..=252, [`INSCRIBED_INFLATED_OBSTACLE`]
//! 253 (closer than the robot radius), [`LETHAL_OBSTACLE`] 254 (an occupied cell),
//! [`NO_INFORMATION`] 255 (never seen and no cost from any layer).
//!
//! Choices where the seed is silent or where the ROS packages and the seed's text differ:
//! - **Inflation radius** is measured from the obstacle, as costmap_2d does: cells up to
//!   `inflation_radius_m` from an occupied cell's centre get a cost, those within
//!   `robot_radius_m` get 253 (seed 004 Fig. 30a: 1.0 and 0.6 m). Comparisons allow 1e-9 m so a
//!   distance of exactly 12 cells of 0.05 m counts as 0.6 m.
//! - **Inflation is kept up to date incrementally**: a cell that becomes occupied stamps its
//!   kernel (max); when cells stop being occupied, the cells within the inflation radius of them
//!   are recomputed from the occupied cells nearby. The result equals inflating from scratch.
//! - **Social layer, eq. 11 as written**: an axis-aligned Gaussian in the odometry frame with
//!   standard deviations σ·f·|v_x| and σ·f·|v_y|, centred on the neighbour; (i, j) is read as the
//!   cell centre in metres. Eq. 11 collapses for a slow neighbour (a zero deviation), so each
//!   deviation is at least σ: a hovering neighbour is a round bump of deviation σ. Eq. 11
//!   stretches the bump along both axes symmetrically (behind as much as ahead) and does not
//!   rotate it with the velocity; the ProxemicLayer the seed ran rotates it and stretches only
//!   ahead. Values below the cut-off are not written, the rest are truncated to an integer and
//!   combined by max, as the ProxemicLayer does; its default cut-off 10 is the default here. The
//!   social cost is evaluated on demand (a few neighbours, one exponential each), not stored.
//!   Unlike the ProxemicLayer it also applies to unknown cells, since those are free for us.
//! - **Planner costs**: global_planner's rule (seed 004 Fig. 33: lethal 253, neutral 50,
//!   factor 3): entering a cell costs `min(neutral + factor·cost, lethal − 1)` per cell length
//!   (× √2 diagonally), and a cell whose cost is ≥ lethal − 1 cannot be entered. Unknown cells
//!   cost the neutral cost (seed 004 3.3: "the cost assigned to ... neutral or unknown areas";
//!   seed 003 IV-C: unknown is free), where global_planner would charge them 252. The heuristic is
//!   neutral × octile distance, admissible since no step costs less than neutral; global_planner's
//!   A* uses Manhattan distance, which overestimates on an 8-connected grid.
//! - **Search limits, escape, window**: those of [`super::astar::astar`] and
//!   [`super::grid::OccupancyGrid::plan`]: the search stops after `max_expanded_cells` with a
//!   partial path, and a start inside the inscribed zone first escapes through non-lethal cells.

use nalgebra::{Point2, Vector2};
use swarm_config::CostmapParams;

use super::astar::{octile_cells, CellSearch, Path};
use super::cells::{Cell, CellSet, TileMap};
use super::grid::{CellState, GridChanges, GridParams, OccupancyGrid};
use crate::geometry::Pose2;

/// costmap_2d: no cost.
pub const FREE_SPACE: u8 = 0;
/// costmap_2d: closer to an obstacle than the robot radius.
pub const INSCRIBED_INFLATED_OBSTACLE: u8 = 253;
/// costmap_2d: an obstacle cell.
pub const LETHAL_OBSTACLE: u8 = 254;
/// costmap_2d: never seen, no cost from any layer.
pub const NO_INFORMATION: u8 = 255;

/// Distance tolerance of the inflation comparisons [m].
const EPS_M: f64 = 1e-9;
/// The inflation kernel never reaches farther than this many cells (validation keeps real
/// parameters far below).
const MAX_KERNEL_CELLS: i32 = 200;

/// The inflation cost of a cell `distance_m` from the closest obstacle cell: costmap_2d's
/// InflationLayer rule with seed 004's robot radius, inflation radius and cost scaling factor.
/// 0 for a NaN distance.
pub fn inflation_cost(distance_m: f64, params: &CostmapParams) -> u8 {
    if distance_m.is_nan() || distance_m > params.inflation_radius_m + EPS_M {
        return FREE_SPACE;
    }
    if distance_m <= 0.0 {
        return LETHAL_OBSTACLE;
    }
    if distance_m <= params.robot_radius_m + EPS_M {
        return INSCRIBED_INFLATED_OBSTACLE;
    }
    // seed 004 3.2 (Fig. 30a, costmap_2d InflationLayer::computeCost):
    // cost = 252 · exp(−cost_scaling_factor · (d − inscribed_radius)), truncated.
    let factor = (-params.cost_scaling_factor * (distance_m - params.robot_radius_m)).exp();
    (f64::from(INSCRIBED_INFLATED_OBSTACLE - 1) * factor) as u8
}

/// A neighbour as the social layer sees it, in the odometry frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SocialAgent {
    /// Position (x, y) of eq. 11 [m].
    pub position: Point2<f64>,
    /// Velocity (v_x, v_y) of eq. 11 [m/s].
    pub velocity: Vector2<f64>,
}

/// The standard deviations of the eq. 11 kernel along x and y: σ·f·|v|, at least σ [m].
fn social_deviations(velocity: &Vector2<f64>, params: &CostmapParams) -> (f64, f64) {
    let along = |v: f64| params.social_covariance * (params.social_factor * v.abs()).max(1.0);
    (along(velocity.x), along(velocity.y))
}

/// The social kernel of seed 004 eq. 11 at `point`:
/// `A · exp(−½ ((i − x)²/(σ f v_x)² + (j − y)²/(σ f v_y)²))`, each deviation at least σ.
pub fn social_kernel(point: &Point2<f64>, agent: &SocialAgent, params: &CostmapParams) -> f64 {
    let (sx, sy) = social_deviations(&agent.velocity, params);
    let d = point - agent.position;
    // seed 004 eq. 11
    params.social_amplitude * (-0.5 * (d.x * d.x / (sx * sx) + d.y * d.y / (sy * sy))).exp()
}

/// The social layer's cost at `point`: eq. 11 truncated to an integer, 0 below the cut-off (and
/// everywhere if the cut-off is not below the amplitude), as the ProxemicLayer writes it.
pub fn social_cost(point: &Point2<f64>, agent: &SocialAgent, params: &CostmapParams) -> u8 {
    if params.social_cutoff >= params.social_amplitude {
        return FREE_SPACE;
    }
    let a = social_kernel(point, agent, params);
    if a >= params.social_cutoff {
        (a as u8).min(LETHAL_OBSTACLE)
    } else {
        FREE_SPACE
    }
}

/// The cost per cell length of entering a cell of cost `cost` (global_planner's `getCost`, seed
/// 004 Fig. 33): `min(neutral + factor·cost, lethal − 1)`; `None` (cannot enter) if
/// `cost ≥ lethal − 1`; the neutral cost for an unknown cell.
pub fn step_cost(cost: u8, params: &CostmapParams) -> Option<f64> {
    let neutral = f64::from(params.neutral_cost);
    if cost == NO_INFORMATION {
        return Some(neutral);
    }
    let lethal = f64::from(params.lethal_cost);
    let c = f64::from(cost);
    if c >= lethal - 1.0 {
        return None;
    }
    // seed 004 Fig. 33 (global_planner): c · cost_factor + neutral_cost, at most lethal − 1.
    Some((c * params.cost_factor + neutral).min(lethal - 1.0))
}

/// One neighbour's term of the social layer, with the half-widths beyond which it is below the
/// cut-off.
#[derive(Debug, Clone, Copy)]
struct SocialTerm {
    agent: SocialAgent,
    reach_x: f64,
    reach_y: f64,
}

/// The costmap of one UAV: its occupancy grid, the inflation of the obstacles in it, and the
/// social layer of its neighbours.
#[derive(Debug, Clone)]
pub struct Costmap {
    params: CostmapParams,
    grid: OccupancyGrid,
    inflation: TileMap<u8>,
    /// (dx, dy, cost) for every cell offset with a non-zero inflation cost.
    kernel: Vec<(i32, i32, u8)>,
    social: Vec<SocialTerm>,
}

impl Costmap {
    /// An empty costmap (every cell unknown, no neighbour).
    pub fn new(params: &CostmapParams) -> Self {
        let grid = OccupancyGrid::new(GridParams {
            resolution_m: params.resolution_m,
            p_occupied: params.update_factor_occupied,
            p_free: params.update_factor_free,
            max_range_m: params.obstacle_range_m,
            ..GridParams::default()
        });
        Costmap {
            params: params.clone(),
            grid,
            inflation: TileMap::new(FREE_SPACE),
            kernel: inflation_kernel(params),
            social: Vec::new(),
        }
    }

    /// The parameters (for the tests).
    #[cfg(test)]
    pub fn params(&self) -> &CostmapParams {
        &self.params
    }

    /// The occupancy grid underneath (for the tests).
    #[cfg(test)]
    pub fn grid(&self) -> &OccupancyGrid {
        &self.grid
    }

    /// Integrates one scan (see [`OccupancyGrid::update`]) and updates the inflation; returns the
    /// cells whose occupancy flipped.
    pub fn update(&mut self, pose: Pose2, points_in_body: &[Point2<f64>]) -> GridChanges {
        let changes = self.grid.update(pose, points_in_body);
        self.apply(&changes);
        changes
    }

    /// Replaces the neighbours of the social layer (odometry frame); non-finite ones are ignored.
    pub fn set_neighbours(&mut self, agents: &[SocialAgent]) {
        let finite = |a: &&SocialAgent| a.position.coords.iter().chain(a.velocity.iter()).all(|v| v.is_finite());
        // The kernel is below the cut-off beyond s·sqrt(2 ln(A/cut-off)) along each axis.
        let reach = (2.0 * (self.params.social_amplitude / self.params.social_cutoff).ln()).max(0.0).sqrt();
        self.social = agents
            .iter()
            .filter(finite)
            .map(|&agent| {
                let (sx, sy) = social_deviations(&agent.velocity, &self.params);
                SocialTerm { agent, reach_x: sx * reach, reach_y: sy * reach }
            })
            .collect();
    }

    /// The cost of cell `c`: the max of its inflation and social costs, [`NO_INFORMATION`] if
    /// both are 0 and the cell was never seen.
    pub fn cost(&self, c: Cell) -> u8 {
        let v = self.inflation.get(c).max(self.social_cost_of(c));
        if v == FREE_SPACE && self.grid.state(c) == CellState::Unknown {
            NO_INFORMATION
        } else {
            v
        }
    }

    /// The cost of the cell containing `p` (odometry frame); [`NO_INFORMATION`] if `p` is not
    /// finite. (The agent reads it through [`CostQuery::cost_at`]; this form is the tests'.)
    #[cfg(test)]
    pub fn cost_at(&self, p: &Point2<f64>) -> u8 {
        self.cost_of_point(p)
    }

    fn cost_of_point(&self, p: &Point2<f64>) -> u8 {
        self.grid.cell_of(p).map_or(NO_INFORMATION, |c| self.cost(c))
    }

    /// The inflation layer's cost of cell `c` (254 on an occupied cell; for the tests).
    #[cfg(test)]
    pub fn inflation_cost_of(&self, c: Cell) -> u8 {
        self.inflation.get(c)
    }

    /// The social layer's cost of cell `c`: the max over the neighbours of [`social_cost`] at the
    /// cell centre.
    pub fn social_cost_of(&self, c: Cell) -> u8 {
        let p = self.grid.center_of(c);
        self.social
            .iter()
            .filter(|t| (p.x - t.agent.position.x).abs() <= t.reach_x && (p.y - t.agent.position.y).abs() <= t.reach_y)
            .map(|t| social_cost(&p, &t.agent, &self.params))
            .max()
            .unwrap_or(FREE_SPACE)
    }

    /// A* from `start` to `goal` (odometry frame) on this costmap with global_planner costs (see
    /// the module doc). `None` if the goal cell cannot be entered or no path exists in the search
    /// window; a partial path (`reached_goal == false`) if the expansion limit was hit.
    pub fn plan(&self, start: Point2<f64>, goal: Point2<f64>) -> Option<Path> {
        let (s, g) = (self.grid.cell_of(&start)?, self.grid.cell_of(&goal)?);
        let neutral = f64::from(self.params.neutral_cost);
        let search = CellSearch {
            start: s,
            goal: g,
            window: self.grid.search_window(s, g, self.params.search_margin_m),
            max_expanded: self.params.max_expanded_cells as usize,
            cell_cost: |c: Cell| step_cost(self.cost(c), &self.params),
            escapable: |c: Cell| self.cost(c) != LETHAL_OBSTACLE,
            // Admissible: no step costs less than neutral per cell length.
            heuristic: |c: Cell| neutral * octile_cells(c, g),
        };
        let cells = search.run()?;
        Some(Path::from_cells(cells, start, goal, |c| self.grid.center_of(c)))
    }

    fn apply(&mut self, changes: &GridChanges) {
        for &c in &changes.occupied {
            self.stamp(c, None);
        }
        if !changes.freed.is_empty() {
            self.reinflate(&changes.freed);
        }
    }

    /// Writes the inflation kernel around `source` (max with what is there), only into `only`
    /// if given.
    fn stamp(&mut self, source: Cell, only: Option<&CellSet<Cell>>) {
        for &(dx, dy, cost) in &self.kernel {
            let c = source.offset(dx, dy);
            if only.is_some_and(|set| !set.contains(&c)) {
                continue;
            }
            let v = self.inflation.get_mut(c);
            *v = (*v).max(cost);
        }
    }

    /// Recomputes the inflation around cells that stopped being occupied: clears every cell the
    /// kernel of a freed cell reached, then restamps, into those cells only, every occupied cell
    /// that can reach them.
    fn reinflate(&mut self, freed: &[Cell]) {
        let reach = self.kernel.iter().map(|&(dx, dy, _)| dx.abs().max(dy.abs())).max().unwrap_or(0);
        let affected: CellSet<Cell> =
            freed.iter().flat_map(|f| self.kernel.iter().map(move |&(dx, dy, _)| f.offset(dx, dy))).collect();
        for &c in &affected {
            *self.inflation.get_mut(c) = FREE_SPACE;
        }
        let sources: CellSet<Cell> = freed.iter().flat_map(|&f| self.grid.occupied_near(f, 2 * reach)).collect();
        for s in sources {
            self.stamp(s, Some(&affected));
        }
    }

    /// Marks cell `c` occupied or free directly and updates the inflation (tests build maps
    /// with it).
    #[cfg(test)]
    pub(crate) fn set_cell(&mut self, c: Cell, occupied: bool) {
        let changes = self.grid.set_cell(c, occupied);
        self.apply(&changes);
    }
}

/// The inflation kernel: every cell offset within the inflation radius with a non-zero cost,
/// distances measured between cell centres as costmap_2d does.
fn inflation_kernel(params: &CostmapParams) -> Vec<(i32, i32, u8)> {
    let ratio = params.inflation_radius_m / params.resolution_m;
    let r = if ratio.is_finite() { (ratio.ceil() as i32).clamp(0, MAX_KERNEL_CELLS) } else { 0 };
    let mut kernel = Vec::new();
    for dy in -r..=r {
        for dx in -r..=r {
            let d = f64::from(dx).hypot(f64::from(dy)) * params.resolution_m;
            let cost = inflation_cost(d, params);
            if cost > FREE_SPACE {
                kernel.push((dx, dy, cost));
            }
        }
    }
    kernel
}

/// Costs on the ROS scale (0 free … 253 inscribed, 254 lethal), as the formation layer and the
/// tracker of M23 read them: from this costmap, or from a costmap with more on it.
pub trait CostQuery {
    /// Cost of the cell containing `p` (world frame); `None` when unknown or outside the map,
    /// which is treated as free.
    fn cost_at(&self, p: Point2<f64>) -> Option<u8>;
    /// Cell size [m].
    fn resolution(&self) -> f64;
}

/// The M23 formation layer reads this costmap through [`CostQuery`].
impl CostQuery for Costmap {
    fn cost_at(&self, p: Point2<f64>) -> Option<u8> {
        Some(self.cost_of_point(&p))
    }
    fn resolution(&self) -> f64 {
        self.params.resolution_m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> CostmapParams {
        CostmapParams::default()
    }

    #[test]
    fn inflation_falls_off_as_costmap_2d_with_the_seed_values() {
        let p = params(); // robot radius 0.6 m, inflation radius 1.0 m, scaling 5.0 (Fig. 30a)
        assert_eq!(inflation_cost(0.0, &p), LETHAL_OBSTACLE);
        assert_eq!(inflation_cost(0.3, &p), INSCRIBED_INFLATED_OBSTACLE);
        assert_eq!(inflation_cost(0.6, &p), INSCRIBED_INFLATED_OBSTACLE);
        // 252 · exp(−5 · 0.1) = 252 · 0.606531 = 152.85 -> 152
        assert_eq!(inflation_cost(0.7, &p), 152);
        // 252 · exp(−5 · 0.15) = 252 · 0.472367 = 119.04 -> 119
        assert_eq!(inflation_cost(0.75, &p), 119);
        // 252 · exp(−5 · 0.2) = 252 · 0.367879 = 92.70 -> 92
        assert_eq!(inflation_cost(0.8, &p), 92);
        // 252 · exp(−5 · 0.4) = 252 · 0.135335 = 34.10 -> 34
        assert_eq!(inflation_cost(1.0, &p), 34);
        // Beyond the inflation radius: nothing.
        assert_eq!(inflation_cost(1.0001, &p), FREE_SPACE);
        assert_eq!(inflation_cost(f64::NAN, &p), FREE_SPACE);
        // Scaling factor 1.0 (Fig. 31c's setting): 252 · exp(−0.2) = 206.32 -> 206
        assert_eq!(inflation_cost(0.8, &CostmapParams { cost_scaling_factor: 1.0, ..p }), 206);
    }

    #[test]
    fn global_planner_step_costs_with_the_seed_values() {
        let p = params(); // lethal 253, neutral 50, factor 3 (Fig. 33)
        assert_eq!(step_cost(0, &p), Some(50.0));
        assert_eq!(step_cost(10, &p), Some(80.0)); // 50 + 3·10
        assert_eq!(step_cost(67, &p), Some(251.0)); // 50 + 3·67
        assert_eq!(step_cost(68, &p), Some(252.0)); // 254 capped at lethal − 1
        assert_eq!(step_cost(251, &p), Some(252.0));
        assert_eq!(step_cost(252, &p), None); // ≥ lethal − 1
        assert_eq!(step_cost(INSCRIBED_INFLATED_OBSTACLE, &p), None);
        assert_eq!(step_cost(LETHAL_OBSTACLE, &p), None);
        assert_eq!(step_cost(NO_INFORMATION, &p), Some(50.0)); // unknown = neutral
    }

    fn agent(x: f64, y: f64, vx: f64, vy: f64) -> SocialAgent {
        SocialAgent { position: Point2::new(x, y), velocity: Vector2::new(vx, vy) }
    }

    fn near(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-9
    }

    #[test]
    fn the_social_kernel_is_eq_11() {
        let p = params(); // A = 150, σ = 0.3, f = 7, cut-off 10
                          // v = (1, 0): deviation along x σ·f·|v_x| = 0.3·7·1 = 2.1 m; along y σ·f·0 = 0, floored
                          // to σ = 0.3 m.
        let a = agent(0.0, 0.0, 1.0, 0.0);
        let at = |x: f64, y: f64| social_kernel(&Point2::new(x, y), &a, &p);
        let cost = |x: f64, y: f64| social_cost(&Point2::new(x, y), &a, &p);
        assert!(near(at(0.0, 0.0), 150.0));
        // One deviation: 150 · exp(−1/2) = 90.98 -> 90, along x at 2.1 m, along y at 0.3 m.
        let one = 150.0 * (-0.5f64).exp();
        assert!(near(at(2.1, 0.0), one) && near(at(0.0, 0.3), one));
        assert_eq!((cost(2.1, 0.0), cost(0.0, 0.3)), (90, 90));
        // Eq. 11 is symmetric: as much behind as ahead.
        assert!(near(at(-2.1, 0.0), one));
        // Two deviations: 150 · exp(−2) = 20.30 -> 20, at 4.2 m along x but 0.6 m along y.
        let two = 150.0 * (-2.0f64).exp();
        assert!(near(at(4.2, 0.0), two) && near(at(0.0, 0.6), two));
        assert_eq!((cost(4.2, 0.0), cost(0.0, 0.6)), (20, 20));
        // 2.5 deviations along y: 150 · exp(−3.125) = 6.59 < cut-off 10 -> not written.
        assert!(near(at(0.0, 0.75), 150.0 * (-3.125f64).exp()));
        assert_eq!(cost(0.0, 0.75), 0);
        // v = (0.5, −1): deviations 0.3·7·0.5 = 1.05 and 0.3·7·1 = 2.1; at (1.05, 2.1) the
        // exponent is −½(1 + 1): 150 · exp(−1) = 55.18 -> 55.
        let b = agent(10.0, -5.0, 0.5, -1.0);
        assert!(near(social_kernel(&Point2::new(11.05, -2.9), &b, &p), 150.0 * (-1.0f64).exp()));
        assert_eq!(social_cost(&Point2::new(11.05, -2.9), &b, &p), 55);
        // Hovering: a round bump of deviation σ: 150 · exp(−1/2) at 0.3 m in any axis.
        let c = agent(0.0, 0.0, 0.0, 0.0);
        assert_eq!(social_cost(&Point2::new(-0.3, 0.0), &c, &p), 90);
        // A cut-off at or above the amplitude writes nothing (ProxemicLayer).
        assert_eq!(social_cost(&Point2::new(0.0, 0.0), &a, &CostmapParams { social_cutoff: 150.0, ..p }), 0);
    }

    /// Pose whose sensor sits in the centre of cell (0, 0) of a 0.05 m grid.
    fn origin() -> Pose2 {
        Pose2::new(0.025, 0.025, 0.0)
    }

    fn c(ix: i32, iy: i32) -> Cell {
        Cell::new(ix, iy)
    }

    #[test]
    fn a_scanned_obstacle_is_inflated_around_its_cell() {
        let mut m = Costmap::new(&params());
        // Body (3.0, 0) -> world (3.025, 0.025) -> cell (60, 0).
        let ch = m.update(origin(), &[Point2::new(3.0, 0.0)]);
        assert_eq!(ch.occupied, vec![c(60, 0)]);
        assert_eq!(m.cost(c(60, 0)), LETHAL_OBSTACLE);
        // Distances in cells of 0.05 m, costs as in the fall-off test.
        assert_eq!(m.inflation_cost_of(c(60, 12)), INSCRIBED_INFLATED_OBSTACLE); // 0.6 m
        assert_eq!(m.inflation_cost_of(c(74, 0)), 152); // 0.7 m
        assert_eq!(m.inflation_cost_of(c(45, 0)), 119); // 0.75 m
        assert_eq!(m.inflation_cost_of(c(60, 16)), 92); // 0.8 m
        assert_eq!(m.inflation_cost_of(c(72, 16)), 34); // hypot(12, 16) = 20 cells = 1.0 m
        assert_eq!(m.inflation_cost_of(c(60, 21)), FREE_SPACE); // 1.05 m
                                                                // Behind the obstacle, never seen: inflated cells still carry their cost, the rest is
                                                                // unknown; on the beam, seen free and beyond the inflation: free.
        assert_eq!(m.cost(c(74, 0)), 152);
        assert_eq!(m.cost(c(82, 0)), NO_INFORMATION);
        assert_eq!(m.cost(c(30, 0)), FREE_SPACE);
        assert_eq!(m.cost_at(&Point2::new(3.025, 0.025)), LETHAL_OBSTACLE);
        assert_eq!(m.cost_at(&Point2::new(f64::NAN, 0.0)), NO_INFORMATION);
    }

    /// The inflation of every cell of `cells`, computed from scratch from the occupied cells.
    fn from_scratch(m: &Costmap, cells: impl Iterator<Item = Cell>) -> Vec<(Cell, u8)> {
        let res = m.params().resolution_m;
        let occupied: Vec<Cell> = m.grid().occupied_cells().collect();
        cells
            .map(|x| {
                let cost =
                    occupied.iter().map(|o| inflation_cost(x.dist2(*o).sqrt() * res, m.params())).max().unwrap_or(0);
                (x, cost)
            })
            .collect()
    }

    #[test]
    fn a_cleared_obstacle_takes_its_inflation_with_it() {
        let mut m = Costmap::new(&params());
        // Scan 1 hits (60, 0) and (60, 10) (body (3.0, 0.5) -> world (3.025, 0.525)).
        m.update(origin(), &[Point2::new(3.0, 0.0), Point2::new(3.0, 0.5)]);
        // (60, −10) is 10 cells (0.5 m) from (60, 0): inscribed.
        assert_eq!(m.inflation_cost_of(c(60, -10)), INSCRIBED_INFLATED_OBSTACLE);
        // Then each scan hits (100, 0) and (60, 10); the beam to (100, 0) passes (60, 0).
        // ln 4 − k · 0.2007 > 0 for k ≤ 6, < 0 for k = 7 (grid tests).
        let scan = [Point2::new(5.0, 0.0), Point2::new(3.0, 0.5)];
        for _ in 0..6 {
            assert!(m.update(origin(), &scan).freed.is_empty());
        }
        assert_eq!(m.cost(c(60, 0)), LETHAL_OBSTACLE);
        assert_eq!(m.update(origin(), &scan).freed, vec![c(60, 0)]);
        // Now (60, 0) is 10 cells from (60, 10): inscribed; (60, −10) is 20 cells = 1.0 m from
        // (60, 10): 34.
        assert_eq!(m.cost(c(60, 0)), INSCRIBED_INFLATED_OBSTACLE);
        assert_eq!(m.inflation_cost_of(c(60, -10)), 34);
        // And the whole neighbourhood equals an inflation from scratch.
        let area = (-30..=30).flat_map(|dy| (30..=130).map(move |ix| c(ix, dy)));
        for (x, want) in from_scratch(&m, area) {
            assert_eq!(m.inflation_cost_of(x), want, "{x:?}");
        }
    }

    #[test]
    fn neighbours_add_their_social_cost_to_the_map() {
        let mut m = Costmap::new(&params());
        m.update(origin(), &[Point2::new(3.0, 0.0)]);
        // A hovering neighbour at the centre of cell (20, 0): (1.025, 0.025).
        m.set_neighbours(&[agent(1.025, 0.025, 0.0, 0.0)]);
        // Cell (26, 0) is 6 cells = 0.3 m away: one deviation: 150 · exp(−1/2) -> 90. It was
        // seen free, so its cost is the social one.
        assert_eq!(m.cost(c(26, 0)), 90);
        assert_eq!(m.cost(c(20, 0)), 150);
        // Unknown cell (20, 6), 0.3 m off the beam: social cost, not "unknown".
        assert_eq!(m.grid().state(c(20, 6)), CellState::Unknown);
        assert_eq!(m.cost(c(20, 6)), 90);
        // The layers combine by max: (46, 0) is 0.7 m from the obstacle (152) and 1.3 m from the
        // neighbour (150 · exp(−½ (1.3/0.3)²) ≈ 0, below the cut-off).
        assert_eq!(m.cost(c(46, 0)), 152);
        // Non-finite neighbours are ignored; an empty list removes the layer.
        m.set_neighbours(&[agent(f64::NAN, 0.0, 0.0, 0.0)]);
        assert_eq!(m.cost(c(26, 0)), FREE_SPACE);
    }

    /// A costmap with a wall of obstacle cells at column 20, rows −10..=10.
    fn walled() -> Costmap {
        let mut m = Costmap::new(&params());
        for iy in -10..=10 {
            m.set_cell(c(20, iy), true);
        }
        m
    }

    fn centre(ix: i32, iy: i32) -> Point2<f64> {
        Point2::new((f64::from(ix) + 0.5) * 0.05, (f64::from(iy) + 0.5) * 0.05)
    }

    #[test]
    fn plans_in_unknown_space_cost_the_neutral_cost() {
        let m = Costmap::new(&params());
        // Nothing known: ten orthogonal steps at neutral 50 = 500.
        let path = m.plan(centre(0, 0), centre(10, 0)).expect("path");
        assert!(path.reached_goal);
        assert!(near(path.cost, 500.0));
        assert_eq!(path.cells.len(), 11);
        // A goal 20 m away in never-seen space is planned to all the same.
        let far = m.plan(centre(0, 0), Point2::new(20.0, 7.0)).expect("path");
        assert!(far.reached_goal);
        assert_eq!(far.points.last(), Some(&Point2::new(20.0, 7.0)));
    }

    #[test]
    fn plans_go_around_inflated_obstacles() {
        let m = walled();
        let path = m.plan(centre(0, 0), centre(40, 0)).expect("path");
        assert!(path.reached_goal);
        for x in &path.cells[1..] {
            assert!(step_cost(m.cost(*x), m.params()).is_some(), "{x:?} cost {}", m.cost(*x));
        }
        // The wall ends at row ±10 and cells within 0.6 m = 12 cells cannot be entered (≥ 252):
        // the path passes at |row| ≥ 23.
        assert!(path.cells.iter().any(|x| x.iy.abs() >= 23));
        // Its cost adds up from the step costs.
        let sum: f64 = path
            .cells
            .windows(2)
            .map(|w| {
                let len = if w[0].ix != w[1].ix && w[0].iy != w[1].iy { std::f64::consts::SQRT_2 } else { 1.0 };
                step_cost(m.cost(w[1]), m.params()).unwrap_or(f64::NAN) * len
            })
            .sum();
        assert!((sum - path.cost).abs() < 1e-6, "{sum} vs {}", path.cost);
    }

    #[test]
    fn a_neighbour_on_the_line_diverts_the_path() {
        let mut m = Costmap::new(&params());
        let straight = m.plan(centre(0, 0), centre(40, 0)).expect("path");
        assert!(straight.cells.contains(&c(20, 0)));
        // Hovering at the centre of (20, 0): within 0.3 m the step cost is
        // min(50 + 3·≥90, 252) = 252 instead of 50, so going round is cheaper.
        let neighbour = agent(1.025, 0.025, 0.0, 0.0);
        m.set_neighbours(&[neighbour]);
        let path = m.plan(centre(0, 0), centre(40, 0)).expect("path");
        assert!(path.reached_goal);
        let closest = path.points.iter().map(|p| (p - neighbour.position).norm()).fold(f64::INFINITY, f64::min);
        assert!(closest > 0.3, "{closest}");
        assert!(path.cost > straight.cost);
    }

    #[test]
    fn unreachable_or_lethal_goals_give_none() {
        let m = walled();
        // A goal on the wall.
        assert_eq!(m.plan(centre(0, 0), centre(20, 0)), None);
        // A goal inside the inscribed zone of the wall.
        assert_eq!(m.plan(centre(0, 0), centre(25, 0)), None);
        // A goal walled in by a ring of obstacle cells 30 cells across: the inside stays
        // reachable only through the ring, which is lethal, and inscribed 12 cells deep.
        let mut ring_map = Costmap::new(&params());
        for k in -15..=15 {
            for (x, y) in [(k, -15), (k, 15), (-15, k), (15, k)] {
                ring_map.set_cell(c(100 + x, y), true);
            }
        }
        assert_eq!(ring_map.plan(centre(0, 0), centre(100, 0)), None);
        // Open a gap 31 cells wide in the ring's left side: now reachable.
        for k in -15..=15 {
            ring_map.set_cell(c(85, k), false);
        }
        assert!(ring_map.plan(centre(0, 0), centre(100, 0)).is_some_and(|p| p.reached_goal));
    }

    #[test]
    fn a_start_inside_the_inscribed_zone_escapes() {
        let m = walled();
        // Cell (15, 0) is 5 cells (0.25 m) from the wall: inscribed, cannot be entered.
        assert_eq!(m.cost(c(15, 0)), INSCRIBED_INFLATED_OBSTACLE);
        let path = m.plan(centre(15, 0), centre(-20, 0)).expect("path");
        assert!(path.reached_goal);
        assert_eq!(path.cells[0], c(15, 0));
        // The escape ends at the first enterable cell; every cell after it is enterable.
        let first = path.cells.iter().position(|x| step_cost(m.cost(*x), m.params()).is_some()).expect("escaped");
        assert!(path.cells[first..].iter().all(|x| step_cost(m.cost(*x), m.params()).is_some()));
    }
}

//! The full-grid initial estimate of seed 000 5.1 (Figure 5.1): where a neighbour is when
//! nothing is known of it yet, by ICP from every start of a grid around the agent at every
//! relative heading.
//!
//! Why a module of its own: nearly all of a full grid's time goes to its first pass, which scores
//! every start and is written for speed (eight starts at once on SIMD lanes, compiled for AVX2
//! and AVX-512 too and picked at run time by `multiversion`, a table of candidate points, a
//! sorting network) under one rule: every score is bit for bit what a start-by-start loop gives.
//! That code changes for speed and is tested by bit equality with the plain loop; the ICP
//! iteration it hands its best starts to ([`super::alignment`]) is a numerical method, changed
//! for accuracy and tested by properties of rigid motions. Apart, each stays readable, and the
//! imports run one way: this module uses the alignment, never the reverse.
//!
//! - [`initial_icp`] is the initial estimate of seed 000 5.1: ICP from every point of a
//!   (2·h+1)² grid around the agent at every one of `grid_headings` relative headings, keeping
//!   the lowest FRMSD.
//! - [`initial_icp_ranked`] adds the best *distinct* alignment (the runner-up, [`Ranked`]), from
//!   which the placement policy tells an unambiguous match from an ambiguous one.
//!
//! Speed (441 positions × 16 headings = 7056 starts): a full ICP from every start would cost tens
//! of milliseconds. Instead a cheap first pass scores every start by the FRMSD of its *initial*
//! pairing only (source pre-rotated once per heading, distance-only nearest neighbour, squared
//! FRMSD from a precomputed weight table, so no allocation, no `sqrt` and no `powf` in the inner
//! loop); the best few starts, at least one per heading and a shortlist overall, are then run
//! through the full ICP, and the lowest final FRMSD wins. Nearest-neighbour search goes one heading
//! at a time and eight cells at once (independent lanes the compiler packs into SIMD). From
//! [`TABLE_FROM_POINTS`] reference points the eight are a stretch of one grid column, searched
//! against only the reference points that can be nearest to it ([`super::nearest`]'s table, built
//! once per full grid: about 6 of a crowd's 45 points; a sorted-by-x candidate window, tried
//! before, cost more to pick the candidates than it saved); a smaller own set (a sparse forest's
//! dozen trunks) is searched whole, in blocks that run on across columns, since the columns'
//! padding would cost more than the table saves ([`Layout`]). Each start's distances are sorted for
//! eq. 3.16's prefixes, eight starts at once by a sorting network on the same lanes
//! ([`super::network`]: the same scores as a sort, without its mispredicted branches); a sort-free
//! lower bound on the score (counts and sums by binary exponent) proved 83 % of a crowd grid's
//! starts unable to rank, but cost half a sort to compute.

use super::alignment::{
    best_prefix, distinct, icp_core, rot, validate, AgentFromNeighbour, Match, NoEstimate, Workspace, TIE_M,
};
use super::nearest::{raster_side, Candidates};
use super::network::{block_scores, Network, LANES};
use super::pairing::distance2;
use crate::geometry::wrap_angle;
use nalgebra::{Point2, Vector2};
use swarm_config::IcpParams;

/// Starts of the initial grid refined by a full ICP: the best this many of the first pass overall
/// (in addition to the best start of every heading).
const SHORTLIST: usize = 24;

/// Raster cell of the first pass's candidate table [m] ([`Candidates`]).
const RASTER_M: f64 = 1.0;

/// Own sets of this many points or more are searched through the candidate table
/// ([`Layout::Columns`]), smaller ones against every point ([`Layout::All`]): `cargo bench -p
/// uav-agent --bench icp` put the crossover between 12 and 20 points.
const TABLE_FROM_POINTS: usize = 16;

/// Non-maximum suppression radius of the shortlist, in grid cells (see [`offer`]).
const SUPPRESS_CELLS: f64 = 2.0;

/// A start of the initial grid with its first-pass score (FRMSD² of its initial pairing).
#[derive(Debug, Clone, Copy)]
struct Start {
    score: f64,
    agent_from_neighbour: AgentFromNeighbour,
}

/// Inserts `s` into `list` (kept ≤ `cap` long, best first) if it ranks, with non-maximum
/// suppression: of two starts at the same heading with squared distance ≤ `suppress2` only the
/// better is kept, so the shortlist covers distinct basins instead of neighbouring cells of one.
fn offer(list: &mut Vec<Start>, cap: usize, suppress2: f64, s: Start) {
    // Scores compare by `total_cmp`, so a NaN score (only from absurd λ) ranks last.
    if list.len() == cap && list.last().is_none_or(|w| s.score.total_cmp(&w.score).is_ge()) {
        return;
    }
    let near = |q: &Start| {
        q.agent_from_neighbour.rotation_rad == s.agent_from_neighbour.rotation_rad
            && (q.agent_from_neighbour.translation_m - s.agent_from_neighbour.translation_m).norm_squared() <= suppress2
    };
    if let Some(i) = list.iter().position(near) {
        if s.score.total_cmp(&list[i].score).is_ge() {
            return;
        }
        list.remove(i);
    }
    let at = list.partition_point(|q| q.score.total_cmp(&s.score).is_le());
    if list.len() == cap {
        list.pop();
    }
    list.insert(at, s);
}

/// Query points searched together by [`nearest_all`] and [`nearest_by_column`] (grid cells) and
/// the pairing's `pair_into` (source points, its own `BLOCK` of the same lanes): a block's
/// running minima stay in registers while each reference point it searches is visited once, and
/// its lanes are independent, so the compiler turns the loop into packed SIMD (SSE2's two lanes
/// on the baseline x86-64 target; the first pass 1.5× faster than start by start on a crowd's
/// 45-point sets, `cargo bench -p uav-agent --bench icp`). The functions are also compiled for
/// AVX2 (four lanes) and AVX-512 (all eight in one register) and pick the widest version the CPU
/// has at run time (`multiversion`): the same operations in the same order per lane (Rust never
/// fuses a multiply and an add on its own), so the distances are bit for bit those of the
/// baseline build. AVX-512 made the full grid 13–21 % and the short ICP 12–33 % faster on a Zen 4
/// (12 to 45 points). The first pass's blocks are then scored lane by lane too
/// ([`super::network`], which stays at AVX2: see [`block_scores`]).
const BLOCK: usize = LANES;

/// The shifts of the grid of seed 000 5.1 and Figure 5.1: cell (i, j) shifts by
/// g = (i, j)·spacing, i, j ∈ [−h, h], centred on the agent, in cell order
/// c = (i + h)·(2h + 1) + (j + h).
fn grid_cells(h: i64, spacing: f64) -> Vec<Vector2<f64>> {
    (-h..=h).flat_map(|i| (-h..=h).map(move |j| Vector2::new(i as f64, j as f64) * spacing)).collect()
}

/// How the first pass lays out its cells in blocks and searches them.
enum Layout {
    /// Cells in cell order, [`BLOCK`] to a block (only the last block padded), each searched
    /// against every reference point ([`nearest_all`]): a small own set, where the table would
    /// save less than a column's padding costs. The blocks' shifts, padded with zeros.
    All { cx: Vec<f64>, cy: Vec<f64> },
    /// [`BLOCK`] cells of one grid column to a block (each column's last block padded), each
    /// searched against the table's candidates ([`nearest_by_column`]).
    Columns(Candidates),
}

impl Layout {
    /// The layout for `reference` and the grid `cells` of `side` × `side` at `headings`
    /// headings: the table from `table_from` reference points ([`TABLE_FROM_POINTS`]), as long
    /// as its raster over `reach` (which bounds every start's anchor, see [`Candidates::new`])
    /// has no more cells than the first pass has starts. Building the table costs about a
    /// search of every point per raster cell, so a reach far beyond the LIDAR's (a stray far
    /// point, an absurd grid spacing) would cost more than it saves, or more memory than there is.
    fn new(
        reference: &[Point2<f64>],
        cells: &[Vector2<f64>],
        side: usize,
        headings: u32,
        reach: f64,
        spacing: f64,
        table_from: usize,
    ) -> Layout {
        let side_cells = raster_side(reach, RASTER_M);
        let starts = cells.len() as f64 * f64::from(headings);
        let fits = side_cells * side_cells <= starts;
        if reference.len() < table_from || !fits {
            let (cx, cy) = block_shifts(cells);
            return Layout::All { cx, cy };
        }
        Layout::Columns(Candidates::new(reference, reach, block_span(side, spacing), RASTER_M))
    }

    /// Lanes (cells and padding) a grid column takes in this layout; [`Layout::All`] packs the
    /// columns one after the other.
    fn slots_per_column(&self, side: usize) -> usize {
        match self {
            Layout::All { .. } => side,
            Layout::Columns(_) => blocks_per_column(side) * BLOCK,
        }
    }

    /// Rows of the first pass's distances for `cells` (`side` per column) and `n` source points.
    fn rows(&self, cells: usize, side: usize, n: usize) -> usize {
        match self {
            Layout::All { .. } => cells.div_ceil(BLOCK) * n,
            Layout::Columns(_) => cells.div_ceil(side) * blocks_per_column(side) * n,
        }
    }

    /// Fills `out` with one heading's distances ([`nearest_all`], [`nearest_by_column`]).
    fn nearest(
        &self,
        reference: &[Point2<f64>],
        rotated: &[Vector2<f64>],
        cells: &[Vector2<f64>],
        side: usize,
        out: &mut [[f64; BLOCK]],
    ) {
        match self {
            Layout::All { cx, cy } => nearest_all(reference, rotated, cx, cy, out),
            Layout::Columns(table) => nearest_by_column(table, rotated, cells, side, out),
        }
    }
}

/// The x and y of `cells`' shifts, padded with zeros to whole blocks of [`BLOCK`].
fn block_shifts(cells: &[Vector2<f64>]) -> (Vec<f64>, Vec<f64>) {
    let padded = cells.len().div_ceil(BLOCK) * BLOCK;
    let pad = |v: Vec<f64>| v.into_iter().chain(std::iter::repeat(0.0)).take(padded).collect();
    (pad(cells.iter().map(|g| g.x).collect()), pad(cells.iter().map(|g| g.y).collect()))
}

/// First pass, one heading, for a small reference set ([`Layout::All`]): for every source point
/// `s` (pre-rotated) and every cell `c` (shift `(cx[c], cy[c])`), the squared distance from
/// `rotated[s] + g_c` to the nearest reference point (seed 000 eq. 3.17 squared), into
/// `out[b·|S| + s][l]` for cell c = b·[`BLOCK`] + l (a block's distances as rows of lanes, as
/// [`block_scores`] takes them), searching every reference point. Each distance is computed as a
/// start-by-start loop would, operation for operation, so the scores are bit-identical; only
/// the loops are turned around (cells in blocks of [`BLOCK`], innermost). `cx`/`cy` are padded
/// to whole blocks; padded cells are computed and dropped.
#[multiversion::multiversion(targets("x86_64+avx512f+avx512vl", "x86_64+avx2"))]
fn nearest_all(reference: &[Point2<f64>], rotated: &[Vector2<f64>], cx: &[f64], cy: &[f64], out: &mut [[f64; BLOCK]]) {
    let n = rotated.len();
    debug_assert!(out.len() >= cx.len() / BLOCK * n, "a row for every block and source point");
    for (b, (bx, by)) in cx.chunks_exact(BLOCK).zip(cy.chunks_exact(BLOCK)).enumerate() {
        for (s, q) in rotated.iter().enumerate() {
            let mut qx = [0.0; BLOCK];
            let mut qy = [0.0; BLOCK];
            for l in 0..BLOCK {
                qx[l] = q.x + bx[l];
                qy[l] = q.y + by[l];
            }
            let mut best = [f64::INFINITY; BLOCK];
            for a in reference {
                for l in 0..BLOCK {
                    let d = distance2(*a, qx[l], qy[l]);
                    best[l] = if d < best[l] { d } else { best[l] };
                }
            }
            if let Some(row) = out.get_mut(b * n + s) {
                *row = best;
            }
        }
    }
}

/// First pass, one heading, for a larger reference set ([`Layout::Columns`]): for every source
/// point `s` (pre-rotated) and every cell `c` (shift `cells[c]`), the squared distance from
/// `rotated[s] + g_c` to the nearest reference point (seed 000 eq. 3.17 squared). Cells go in
/// blocks of [`BLOCK`] consecutive cells of one grid column (`side` = 2h + 1 cells, so
/// [`blocks_per_column`] blocks, the last one padded with copies of the column's last cell):
/// cell j of column `col` is lane j % [`BLOCK`] of block b = `col` · [`blocks_per_column`] +
/// j / [`BLOCK`], and its distance for source `s` goes to `out[b·|S| + s]` (a block's distances
/// as rows of lanes, as [`block_scores`] takes them).
///
/// Each block is searched against the candidates of [`Candidates`] for its lowest cell (all
/// points outside the table). Each distance is computed as a start-by-start loop would,
/// operation for operation (`q + g` first, then the difference to each reference point), and
/// the nearest one is the least of them over a set that holds every point that could be least,
/// so the scores are bit-identical; only the loops are turned around and cut short.
#[multiversion::multiversion(targets("x86_64+avx512f+avx512vl", "x86_64+avx2"))]
fn nearest_by_column(
    candidates: &Candidates,
    rotated: &[Vector2<f64>],
    cells: &[Vector2<f64>],
    side: usize,
    out: &mut [[f64; BLOCK]],
) {
    let n = rotated.len();
    let per_column = blocks_per_column(side);
    debug_assert!(
        out.len() >= cells.len().div_ceil(side.max(1)) * per_column * n,
        "a row for every block and source point"
    );
    for (s, q) in rotated.iter().enumerate() {
        for (col, column) in cells.chunks(side.max(1)).enumerate() {
            // One column: the same x shift for all its cells.
            let qx = q.x + column[0].x;
            for (k, block) in column.chunks(BLOCK).enumerate() {
                let last = block.len() - 1;
                let qy: [f64; BLOCK] = std::array::from_fn(|l| q.y + block[l.min(last)].y);
                let mut best = [f64::INFINITY; BLOCK];
                // Anchored at the block's lowest start (the grid's spacing may be negative).
                for a in candidates.at(qx, qy[0].min(qy[last])) {
                    let dx = a[0] - qx;
                    let dx2 = dx * dx;
                    for l in 0..BLOCK {
                        let dy = a[1] - qy[l];
                        let d = dx2 + dy * dy;
                        best[l] = if d < best[l] { d } else { best[l] };
                    }
                }
                if let Some(row) = out.get_mut((col * per_column + k) * n + s) {
                    *row = best;
                }
            }
        }
    }
}

/// How far a block of [`nearest_by_column`] reaches along its grid column beyond its first cell,
/// for a grid of `side` cells per column and `spacing` [m]: its table regions' extra height.
fn block_span(side: usize, spacing: f64) -> f64 {
    (side.min(BLOCK) - 1) as f64 * spacing.abs()
}

/// Blocks of [`BLOCK`] cells in a grid column of `side` cells ([`nearest_by_column`]).
fn blocks_per_column(side: usize) -> usize {
    side.div_ceil(BLOCK)
}

/// First-pass scores of one block of cells from their distances `rows` (as [`nearest_all`] or
/// [`nearest_by_column`] leaves them; sorted in place): by the sorting network on lanes, or, for
/// a block with a NaN, start by start with [`first_pass_score`]. The same scores either way.
fn block_first_pass(rows: &mut [[f64; BLOCK]], net: &Network, weights: &[f64], k_min: usize) -> [f64; BLOCK] {
    block_scores(rows, net, weights, k_min, TIE_M * TIE_M).unwrap_or_else(|| {
        let mut lane = Vec::with_capacity(rows.len());
        std::array::from_fn(|l| {
            lane.clear();
            lane.extend(rows.iter().map(|r| r[l]));
            first_pass_score(&mut lane, weights, k_min)
        })
    })
}

/// First-pass score of one start from its nearest squared distances `d2` (any order; sorted in
/// place): FRMSD² of the initial pairing (seed 000 eq. 3.16 squared).
fn first_pass_score(d2: &mut [f64], weights: &[f64], k_min: usize) -> f64 {
    // Squared distances are ≥ +0 (or NaN/+∞ from absurd input), and for such values the IEEE bit
    // patterns as integers sort exactly as `f64::total_cmp` does: the same order, at a fraction
    // of the cost (this sort was a third of `swarm icp-eval`'s CPU time, by `perf`).
    d2.sort_unstable_by_key(|d| d.to_bits());
    best_prefix(d2.iter().copied(), weights, k_min).1
}

/// Initial estimate (seed 000 5.1): ICP from every point of the (2·`grid_half_cells`+1)² grid with
/// `grid_spacing_m` spacing centred on the agent, at `grid_headings` evenly spaced relative
/// headings (0, 2π/H, …); keep the lowest FRMSD.
///
/// For speed every start is first scored by the FRMSD of its initial pairing; the best start of
/// each heading and the best few overall get the full ICP (see the module documentation).
/// Errors as for [`icp`](super::alignment::icp); a non-finite `grid_spacing_m` is [`NoEstimate::NonFinite`]; when no
/// refined start gives an estimate, the error of the best-ranked one.
pub fn initial_icp(reference: &[Point2<f64>], source: &[Point2<f64>], p: &IcpParams) -> Result<Match, NoEstimate> {
    initial_icp_ranked(reference, source, p).map(|ranked| ranked.best)
}

/// The outcome of a full-grid ICP: the best alignment, and the best one that is a different
/// alignment (see [`Ranked::runner_up`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ranked {
    /// Lowest FRMSD.
    pub best: Match,
    /// Lowest FRMSD among the refined alignments that place the neighbour more than
    /// [`DISTINCT_M`](super::alignment::DISTINCT_M) from `best` or turn it more than
    /// [`DISTINCT_RAD`](super::alignment::DISTINCT_RAD) from it; `None` if every refined start
    /// converged to `best`'s alignment.
    pub runner_up: Option<Match>,
}

/// [`initial_icp`] with its runner-up: how well the second-best different alignment fits tells an
/// unambiguous match (one basin fits) from an ambiguous one (several places fit about as well).
pub fn initial_icp_ranked(
    reference: &[Point2<f64>],
    source: &[Point2<f64>],
    p: &IcpParams,
) -> Result<Ranked, NoEstimate> {
    initial_icp_ranked_from(reference, source, p, TABLE_FROM_POINTS, &every_heading(p))
}

/// The indices k of every grid heading θ_k = 2π·k/H, in the full grid's order.
fn every_heading(p: &IcpParams) -> Vec<u32> {
    (0..p.grid_headings.max(1)).collect()
}

/// [`initial_icp_ranked`] over the whole grid of positions but only the `count` grid headings
/// nearest `heading_rad` (all of them when `count` is 0 or at least `grid_headings`): the
/// placement of a neighbour whose relative heading is expected (the crowd rules'
/// `crowd_placement_headings`). Every position is still scored, so a look-alike place anywhere in
/// the grid at those headings still makes the match ambiguous.
pub fn initial_icp_ranked_near(
    reference: &[Point2<f64>],
    source: &[Point2<f64>],
    p: &IcpParams,
    heading_rad: f64,
    count: u32,
) -> Result<Ranked, NoEstimate> {
    let nearest = nearest_headings(p.grid_headings.max(1), heading_rad, count);
    initial_icp_ranked_from(reference, source, p, TABLE_FROM_POINTS, &nearest)
}

/// The indices k of the `count` grid headings θ_k = 2π·k/H nearest `heading_rad` (by angle,
/// ties to the lower index), in increasing k; every k when `count` is 0 or at least H, or when
/// the heading is not finite.
fn nearest_headings(headings: u32, heading_rad: f64, count: u32) -> Vec<u32> {
    if count == 0 || count >= headings || !heading_rad.is_finite() {
        return (0..headings).collect();
    }
    let off = |k: u32| wrap_angle(std::f64::consts::TAU * f64::from(k) / f64::from(headings) - heading_rad).abs();
    let mut ks: Vec<u32> = (0..headings).collect();
    ks.sort_by(|&a, &b| off(a).total_cmp(&off(b)).then(a.cmp(&b)));
    ks.truncate(count as usize);
    ks.sort_unstable();
    ks
}

/// [`initial_icp_ranked`] at the grid headings `ks` (indices k of θ_k = 2π·k/H, in the order
/// scored), with the first pass's candidate table from `table_from` reference points (the tests
/// compare both layouts).
fn initial_icp_ranked_from(
    reference: &[Point2<f64>],
    source: &[Point2<f64>],
    p: &IcpParams,
    table_from: usize,
    ks: &[u32],
) -> Result<Ranked, NoEstimate> {
    let k_min = validate(reference, source, p)?;
    if !p.grid_spacing_m.is_finite() {
        return Err(NoEstimate::NonFinite);
    }
    let mut ws = Workspace::new(source.len(), p.lambda, k_min);
    // The source rotated by one grid heading.
    let mut rotated: Vec<Vector2<f64>> = Vec::with_capacity(source.len());
    let h = i64::from(p.grid_half_cells);
    let headings = p.grid_headings.max(1);
    // Within SUPPRESS_CELLS cells (with a margin for rounding).
    let suppress2 = (SUPPRESS_CELLS * p.grid_spacing_m).powi(2) * (1.0 + 1e-9);

    // First pass: score all starts, keep the best of each heading and a shortlist overall.
    let mut shortlist: Vec<Start> = Vec::with_capacity(SHORTLIST + 1);
    let mut per_heading: Vec<Start> = Vec::with_capacity(ks.len());
    let cells = grid_cells(h, p.grid_spacing_m);
    let side = (2 * h + 1) as usize;
    // Every start's anchor lies within the source's reach plus the grid's half width.
    let reach = source.iter().map(|q| q.coords.norm()).fold(0.0, f64::max) + h as f64 * p.grid_spacing_m.abs();
    let scored = u32::try_from(ks.len()).unwrap_or(u32::MAX);
    let layout = Layout::new(reference, &cells, side, scored, reach * (1.0 + 1e-9), p.grid_spacing_m, table_from);
    let n = source.len();
    let slots_per_column = layout.slots_per_column(side);
    let mut by_cell = vec![[0.0; BLOCK]; layout.rows(cells.len(), side, n)];
    let net = Network::new(n);
    for &k in ks {
        // seed 000, 5.1 ("all relative headings"): θ_k = 2π·k/H, evenly spaced.
        let heading = wrap_angle(std::f64::consts::TAU * f64::from(k) / f64::from(headings));
        let r = rot(heading);
        rotated.clear();
        rotated.extend(source.iter().map(|q| r * q.coords));
        layout.nearest(reference, &rotated, &cells, side, &mut by_cell);
        let mut best_here: Option<Start> = None;
        // Block lanes back to cells, in cell order: the columns' padding lanes are skipped by
        // their slot in the column, the last block's (`Layout::All`) when the cells run out.
        // A plain loop: as an iterator chain it was not inlined, 5 % of a 12-point full grid.
        let mut next_cell = cells.iter();
        let mut slot = 0;
        for rows in by_cell.chunks_exact_mut(n) {
            for score in block_first_pass(rows, &net, &ws.weights, k_min) {
                let padding = slot >= side;
                slot = if slot + 1 == slots_per_column { 0 } else { slot + 1 };
                if padding {
                    continue;
                }
                let Some(g) = next_cell.next() else { break };
                let s = Start {
                    score,
                    agent_from_neighbour: AgentFromNeighbour { rotation_rad: heading, translation_m: *g },
                };
                if best_here.is_none_or(|b| score.total_cmp(&b.score).is_lt()) {
                    best_here = Some(s);
                }
                offer(&mut shortlist, SHORTLIST, suppress2, s);
            }
        }
        // The best start of this heading, unless the shortlist already has it.
        per_heading
            .extend(best_here.filter(|b| !shortlist.iter().any(|q| q.agent_from_neighbour == b.agent_from_neighbour)));
    }

    // Second pass: full ICP from the shortlist and the per-heading bests; lowest FRMSD wins.
    let mut refined: Vec<Match> = Vec::with_capacity(shortlist.len() + per_heading.len());
    let mut first_err = None;
    for s in shortlist.iter().chain(per_heading.iter()) {
        match icp_core(reference, source, s.agent_from_neighbour, p, &mut ws) {
            Ok(run) => refined.push(run.m),
            Err(e) => {
                first_err.get_or_insert(e);
            }
        }
    }
    // The first of the lowest FRMSD wins (start order breaks ties, as before).
    let best = refined.iter().copied().reduce(|b, m| if m.frmsd < b.frmsd { m } else { b });
    let Some(best) = best else { return Err(first_err.unwrap_or(NoEstimate::Degenerate)) };
    let runner_up = refined
        .iter()
        .copied()
        .filter(|m| distinct(&m.agent_from_neighbour, &best.agent_from_neighbour))
        .reduce(|b, m| if m.frmsd < b.frmsd { m } else { b });
    Ok(Ranked { best, runner_up })
}

#[cfg(test)]
mod tests {
    use super::super::alignment::icp;
    use super::super::alignment::tests::{close, config, scatter, scenario, square_ish, to_source, Rng};
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn runner_up_tells_a_unique_scene_from_a_lattice() {
        let p = IcpParams::default();
        // A scattered forest: the second-best different alignment fits far worse than the true one.
        let mut rng = Rng(7);
        let reference = scatter(&mut rng, 20, Vector2::zeros(), 10.0, 1.5, &[]);
        let truth = AgentFromNeighbour { rotation_rad: 0.2, translation_m: Vector2::new(1.0, -0.5) };
        let ranked = initial_icp_ranked(&reference, &to_source(&truth, &reference), &p).expect("estimate");
        assert!(close(&ranked.best, &truth, 1e-6, 1e-6), "{ranked:?}");
        assert!(ranked.runner_up.is_none_or(|u| u.frmsd > 100.0 * ranked.best.frmsd.max(1e-3)), "{ranked:?}");
        // A 1.6 m square lattice (a crowd's bodies): shifting by one cell fits almost as well.
        let lattice: Vec<Point2<f64>> =
            (-3..=3).flat_map(|i| (-3..=3).map(move |j| Point2::new(1.6 * f64::from(i), 1.6 * f64::from(j)))).collect();
        let shifted = AgentFromNeighbour { rotation_rad: 0.0, translation_m: Vector2::new(0.3, 0.2) };
        let ranked = initial_icp_ranked(&lattice, &to_source(&shifted, &lattice), &p).expect("estimate");
        let u = ranked.runner_up.expect("another alignment");
        assert!(distinct(&u.agent_from_neighbour, &ranked.best.agent_from_neighbour));
        assert!(u.frmsd <= 1.5 * ranked.best.frmsd.max(1e-3) + 0.2, "{ranked:?}");
    }

    /// The first pass sorts squared distances by their bits: for values ≥ +0 (and +∞, NaN) that
    /// is `f64::total_cmp`'s order, so the scores, and every result, are unchanged.
    #[test]
    fn squared_distances_sort_by_bits_as_by_total_cmp() {
        let mut rng = Rng(11);
        for _ in 0..200 {
            let mut v: Vec<f64> = (0..20).map(|_| rng.range(0.0, 50.0).powi(2)).collect();
            v.extend([0.0, f64::INFINITY, f64::NAN, 1e-300, f64::MIN_POSITIVE / 2.0, 3.0, 3.0]);
            let mut by_bits = v.clone();
            by_bits.sort_unstable_by_key(|d| d.to_bits());
            v.sort_unstable_by(f64::total_cmp);
            assert_eq!(
                v.iter().map(|d| d.to_bits()).collect::<Vec<_>>(),
                by_bits.iter().map(|d| d.to_bits()).collect::<Vec<_>>()
            );
        }
    }

    /// The candidate table is built only while its raster has no more cells than the first pass
    /// has starts: a reach far beyond the LIDAR's leaves the search over every point, and a grid
    /// spacing of 2e8 m (once a 640 GB table and an abort) runs the full grid as before.
    #[test]
    fn a_far_reach_searches_every_point_instead_of_building_a_huge_table() {
        let reference: Vec<Point2<f64>> =
            (0..20).map(|i| Point2::new(f64::from(i % 5) * 2.3, f64::from(i / 5) * 1.7 + 0.1 * f64::from(i))).collect();
        let cells = grid_cells(10, 0.5);
        let layout = |reach: f64| Layout::new(&reference, &cells, 21, 16, reach, 0.5, TABLE_FROM_POINTS);
        assert!(matches!(layout(17.0), Layout::Columns(_)));
        assert!(matches!(layout(500.0), Layout::All { .. }));
        assert!(matches!(layout(f64::INFINITY), Layout::All { .. }));
        let source: Vec<Point2<f64>> = reference.iter().map(|q| Point2::new(q.y + 0.4, -q.x + 0.2)).collect();
        let p = IcpParams { grid_spacing_m: 2e8, ..IcpParams::default() };
        let all = initial_icp_ranked_from(&reference, &source, &p, usize::MAX, &every_heading(&p));
        assert_eq!(
            format!("{all:?}"),
            format!("{:?}", initial_icp_ranked_from(&reference, &source, &p, 0, &every_heading(&p)))
        );
    }

    #[test]
    fn a_placement_scores_the_grid_headings_nearest_the_expected_one() {
        let step = std::f64::consts::TAU / 16.0;
        assert_eq!(nearest_headings(16, 0.1, 3), vec![0, 1, 15]);
        assert_eq!(nearest_headings(16, -0.1, 3), vec![0, 1, 15]);
        assert_eq!(nearest_headings(16, std::f64::consts::PI, 3), vec![7, 8, 9]);
        // 0.4 of a step past heading 5: the two nearest are 5 and 6, then 4 before 7.
        assert_eq!(nearest_headings(16, 5.4 * step, 2), vec![5, 6]);
        assert_eq!(nearest_headings(16, 5.4 * step, 4), vec![4, 5, 6, 7]);
        assert_eq!(nearest_headings(16, 5.4 * step, 1), vec![5]);
        // Off, too many, or no heading to go by: every heading.
        for (heading, count) in [(0.3, 0), (0.3, 16), (0.3, 40), (f64::NAN, 3), (f64::INFINITY, 3)] {
            assert_eq!(nearest_headings(16, heading, count), (0..16).collect::<Vec<_>>(), "{heading} {count}");
        }
    }

    /// With the expected heading known to within a grid step (±22.5°), three headings place a
    /// neighbour anywhere in the grid as well as all sixteen do; with every heading it is the
    /// full grid, bit for bit.
    #[test]
    fn a_placement_near_the_expected_heading_places_as_the_full_grid_does() {
        let p = IcpParams::default();
        let mut rng = Rng(0x5EED_0048);
        let cases = 200;
        let (mut full_ok, mut near_ok) = (0, 0);
        for _ in 0..cases {
            let (reference, source, truth) = scenario(&mut rng, 0.03);
            let lost = truth.rotation_rad + rng.range(-0.39, 0.39);
            let near = initial_icp_ranked_near(&reference, &source, &p, lost, 3);
            let full = initial_icp_ranked(&reference, &source, &p);
            let every = initial_icp_ranked_near(&reference, &source, &p, lost, 0);
            assert_eq!(format!("{full:?}"), format!("{every:?}"));
            let placed =
                |r: &Result<Ranked, NoEstimate>| r.is_ok_and(|r| close(&r.best, &truth, 0.1, 2f64.to_radians()));
            full_ok += usize::from(placed(&full));
            near_ok += usize::from(placed(&near));
        }
        eprintln!("placed: full grid {full_ok}/{cases}, three headings {near_ok}/{cases}");
        assert!(near_ok as f64 >= 0.95 * cases as f64 && near_ok + 2 >= full_ok, "{near_ok} vs {full_ok} of {cases}");
    }

    #[test]
    fn degenerate_inputs_are_rejected() {
        let p = IcpParams::default();
        let id = AgentFromNeighbour { rotation_rad: 0.0, translation_m: Vector2::zeros() };
        let good = square_ish();
        let both = |r: &[Point2<f64>], s: &[Point2<f64>]| (icp(r, s, id, &p).err(), initial_icp(r, s, &p).err());
        let expect = |r: &[Point2<f64>], s: &[Point2<f64>], e: NoEstimate| {
            assert_eq!(both(r, s), (Some(e), Some(e)), "{r:?} / {s:?}");
            assert_eq!(both(s, r), (Some(e), Some(e)), "{s:?} / {r:?}");
        };
        expect(&[], &good, NoEstimate::TooFewPoints);
        expect(&good[..1], &good, NoEstimate::TooFewPoints);
        expect(&good[..2], &good, NoEstimate::TooFewPoints);
        let p9 = IcpParams { min_points: 9, ..IcpParams::default() };
        assert_eq!(icp(&good, &good, id, &p9), Err(NoEstimate::TooFewPoints));
        assert_eq!(initial_icp(&good, &good, &p9), Err(NoEstimate::TooFewPoints));

        let line: Vec<Point2<f64>> = (0..8).map(|i| Point2::new(i as f64 * 2.0, 1.0 + i as f64 * 0.5)).collect();
        expect(&line, &good, NoEstimate::Degenerate);
        let same = vec![Point2::new(1.0, 2.0); 6];
        expect(&same, &good, NoEstimate::Degenerate);

        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let mut s = good.clone();
            s[2].y = bad;
            expect(&s, &good, NoEstimate::NonFinite);
            let t = AgentFromNeighbour { rotation_rad: bad, translation_m: Vector2::zeros() };
            assert_eq!(icp(&good, &good, t, &p), Err(NoEstimate::NonFinite));
            let t = AgentFromNeighbour { rotation_rad: 0.0, translation_m: Vector2::new(0.0, bad) };
            assert_eq!(icp(&good, &good, t, &p), Err(NoEstimate::NonFinite));
            let pl = IcpParams { lambda: bad, ..IcpParams::default() };
            assert_eq!(icp(&good, &good, id, &pl), Err(NoEstimate::NonFinite));
            let pg = IcpParams { grid_spacing_m: bad, ..IcpParams::default() };
            assert_eq!(initial_icp(&good, &good, &pg), Err(NoEstimate::NonFinite));
        }
        // Sane sets pass the checks.
        assert!(icp(&good, &good, id, &p).is_ok());
    }

    #[test]
    fn initial_icp_exact_without_noise() {
        let p = IcpParams::default();
        let mut rng = Rng(6);
        for _ in 0..20 {
            let (reference, source, truth) = scenario(&mut rng, 0.0);
            let m = initial_icp(&reference, &source, &p).expect("estimate");
            assert!(close(&m, &truth, 1e-9, 1e-9), "{m:?} vs {truth:?}");
            assert_eq!(m.pairs, 14);
        }
    }

    /// The acceptance test (SPEC section 5, seed 000 5.1): 20 trees in 20 m × 20 m, a neighbour
    /// at a random heading in [−π, π) and within ±5 m, σ = 0.03 m, 30 % of each side one-sided;
    /// `initial_icp` must place it within 0.1 m and 2° in ≥ 95 % of the cases.
    /// Measured with this seed: 500/500 (100 %); the same seed over 2000 cases: 1999/2000
    /// (99.95 %; the miss is a neighbour 12° off the nearest grid heading at the grid's edge, from
    /// where no start converges).
    #[test]
    fn initial_icp_recovery_rate() {
        let p = IcpParams::default();
        let mut rng = Rng(0x000C_1CF0);
        let cases = 500;
        let mut ok = 0;
        for _ in 0..cases {
            let (reference, source, truth) = scenario(&mut rng, 0.03);
            if initial_icp(&reference, &source, &p).is_ok_and(|m| close(&m, &truth, 0.1, 2f64.to_radians())) {
                ok += 1;
            }
        }
        eprintln!("initial_icp success rate: {ok}/{cases}");
        assert!(ok as f64 >= 0.95 * cases as f64, "success {ok}/{cases}");
    }

    proptest! {
        #![proptest_config(config(64))]

        /// A block's scores by the sorting network equal bit for bit the start-by-start sort
        /// and prefix scan, ties, +∞ and NaN lanes included.
        #[test]
        fn prop_block_scores_are_the_start_by_start_scores(seed in any::<u64>(), n in 3usize..60, k_min in 3usize..8, coarse in any::<bool>(), nan in any::<bool>()) {
            let mut rng = Rng(seed);
            let k_min = k_min.min(n);
            let ws = Workspace::new(n, 1.3, k_min);
            let mut rows: Vec<[f64; BLOCK]> = (0..n)
                .map(|_| std::array::from_fn(|_| if coarse { (rng.range(0.0, 8.0) as u32) as f64 } else { rng.range(0.0, 30.0).powi(2) }))
                .collect();
            rows[n / 2][3] = f64::INFINITY;
            if nan {
                rows[n - 1][5] = f64::NAN;
            }
            let want: Vec<u64> = (0..BLOCK)
                .map(|l| first_pass_score(&mut rows.iter().map(|r| r[l]).collect::<Vec<_>>(), &ws.weights, k_min).to_bits())
                .collect();
            let got = block_first_pass(&mut rows, &Network::new(n), &ws.weights, k_min);
            prop_assert_eq!(got.map(f64::to_bits).to_vec(), want);
        }

        /// The first pass's distances, cells in SIMD blocks, equal bit for bit the ones of a
        /// start-by-start loop (`q + g` first, then the difference to each reference point).
        #[test]
        fn prop_nearest_all_is_the_start_by_start_loop(seed in any::<u64>(), n_ref in 3usize..50, n_src in 3usize..50, h in 0i64..6, spacing in 0.05..2.0f64) {
            let mut rng = Rng(seed);
            let reference: Vec<Point2<f64>> = (0..n_ref).map(|_| Point2::new(rng.range(-10.0, 10.0), rng.range(-10.0, 10.0))).collect();
            let rotated: Vec<Vector2<f64>> = (0..n_src).map(|_| Vector2::new(rng.range(-10.0, 10.0), rng.range(-10.0, 10.0))).collect();
            let cells = grid_cells(h, spacing);
            let (cx, cy) = block_shifts(&cells);
            let mut out = vec![[f64::NAN; BLOCK]; cells.len().div_ceil(BLOCK) * n_src];
            nearest_all(&reference, &rotated, &cx, &cy, &mut out);
            for (c, g) in cells.iter().enumerate() {
                for (s, q) in rotated.iter().enumerate() {
                    let (qx, qy) = (q.x + g.x, q.y + g.y);
                    let want = reference.iter().map(|a| (a.x - qx) * (a.x - qx) + (a.y - qy) * (a.y - qy)).fold(f64::INFINITY, f64::min);
                    prop_assert_eq!(out[c / BLOCK * n_src + s][c % BLOCK].to_bits(), want.to_bits(), "cell {} source {}", c, s);
                }
            }
        }

        /// The first pass's distances, cells in SIMD blocks searched against the candidate
        /// table, equal bit for bit the ones of a start-by-start loop over every reference point
        /// (`q + g` first, then the difference to each reference point): whatever the table's
        /// raster and reach (starts outside it included), on scattered points and on a lattice
        /// full of ties, for either sign of the grid's spacing, with sets of more than 64 points
        /// (bit sets of several words).
        #[test]
        fn prop_nearest_by_column_is_the_start_by_start_loop(seed in any::<u64>(), n_ref in 3usize..150, n_src in 3usize..50, h in 0i64..11, spacing in 0.05..2.0f64, negative in any::<bool>(), lattice in any::<bool>(), raster in 0.05..3.0f64, reach in 0.0..25.0f64) {
            let mut rng = Rng(seed);
            let point = |rng: &mut Rng| if lattice {
                Vector2::new(rng.range(-8.0, 8.0).round() * 0.5, rng.range(-8.0, 8.0).round() * 0.5)
            } else {
                Vector2::new(rng.range(-12.0, 12.0), rng.range(-12.0, 12.0))
            };
            let reference: Vec<Point2<f64>> = (0..n_ref).map(|_| Point2::from(point(&mut rng))).collect();
            let rotated: Vec<Vector2<f64>> = (0..n_src).map(|_| point(&mut rng)).collect();
            let spacing = if negative { -spacing } else { spacing };
            let cells = grid_cells(h, spacing);
            let side = (2 * h + 1) as usize;
            let candidates = Candidates::new(&reference, reach, block_span(side, spacing), raster);
            let per_column = blocks_per_column(side);
            let mut out = vec![[f64::NAN; BLOCK]; side * per_column * n_src];
            nearest_by_column(&candidates, &rotated, &cells, side, &mut out);
            for (c, g) in cells.iter().enumerate() {
                let (col, j) = (c / side, c % side);
                for (s, q) in rotated.iter().enumerate() {
                    let (qx, qy) = (q.x + g.x, q.y + g.y);
                    let want = reference.iter().map(|a| (a.x - qx) * (a.x - qx) + (a.y - qy) * (a.y - qy)).fold(f64::INFINITY, f64::min);
                    let got = out[(col * per_column + j / BLOCK) * n_src + s][j % BLOCK];
                    prop_assert_eq!(got.to_bits(), want.to_bits(), "cell {} source {}", c, s);
                }
            }
            // Padding lanes repeat their column's last cell: real distances, never NaN.
            prop_assert!(out.iter().flatten().all(|d| !d.is_nan()));
        }
    }

    proptest! {
        #![proptest_config(config(32))]

        /// The initial estimate finds any pose within the grid on noise-free data with 30 %
        /// one-sided points, and reports the 14 shared pairs.
        #[test]
        fn prop_initial_icp_recovers_pose(seed in any::<u64>()) {
            let mut rng = Rng(seed);
            let (reference, source, truth) = scenario(&mut rng, 0.0);
            let m = initial_icp(&reference, &source, &IcpParams::default());
            prop_assert!(m.is_ok_and(|m| close(&m, &truth, 1e-6, 1e-6) && m.pairs == 14), "{m:?} vs {truth:?}");
        }

        /// The full grid's outcome is the same whichever way its first pass searches, against
        /// every point or through the candidate table, for own sets of any size, scattered or on
        /// a lattice of look-alike places.
        #[test]
        fn prop_both_first_pass_layouts_give_the_same_outcome(seed in any::<u64>(), n_ref in 5usize..40, n_src in 5usize..40, lattice in any::<bool>()) {
            let mut rng = Rng(seed);
            let point = |rng: &mut Rng| if lattice {
                Point2::new(rng.range(-6.0, 6.0).round() * 1.6, rng.range(-6.0, 6.0).round() * 1.6)
            } else {
                Point2::new(rng.range(-12.0, 12.0), rng.range(-12.0, 12.0))
            };
            let reference: Vec<Point2<f64>> = (0..n_ref).map(|_| point(&mut rng)).collect();
            let source: Vec<Point2<f64>> = (0..n_src).map(|_| point(&mut rng)).collect();
            let p = IcpParams::default();
            let all = initial_icp_ranked_from(&reference, &source, &p, usize::MAX, &every_heading(&p));
            let table = initial_icp_ranked_from(&reference, &source, &p, 0, &every_heading(&p));
            prop_assert_eq!(format!("{all:?}"), format!("{table:?}"));
        }
    }
}

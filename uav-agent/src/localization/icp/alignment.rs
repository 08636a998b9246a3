//! The ICP alignment of seed 000 ("K21", sections 3.1, 3.3 and 5.1): where a neighbour is, from
//! its obstacle set and ours.
//!
//! Why this module exists: in `icp` localization mode (SPEC section 5) agents are anonymous and
//! share only the obstacle centres they see, in their own body frame. To know where a neighbour
//! is and where it is heading, the receiver aligns the received set S to its own set R. This
//! module is that alignment, as pure functions with no IO and no clock, so the neighbour database
//! (seed 000 5.2–5.3) can call it freely and it can be tested and benchmarked in isolation. What
//! to make of an alignment (place a neighbour, keep a track) is not decided here but in
//! [`super::placement`].
//!
//! - [`icp`] is the ICP of Algorithm 1 (the "short ICP" of seed 000 5.1): nearest-neighbour
//!   pairing, FRMSD outlier rejection (eq. 3.16–3.17, Algorithm 3), rigid transform from the kept
//!   pairs by centroids + SVD of the cross-covariance with the reflection fix (eq. 3.1–3.12),
//!   composed onto the running estimate.
//! - [`initial_icp`] is the initial estimate of seed 000 5.1: ICP from every point of a
//!   (2·h+1)² grid around the agent at every one of `grid_headings` relative headings, keeping
//!   the lowest FRMSD.
//! - [`initial_icp_ranked`] adds the best *distinct* alignment (the runner-up, [`Ranked`]), from
//!   which the placement policy tells an unambiguous match from an ambiguous one.
//!
//! Choices where seed 000 is silent:
//! - The error E of Algorithm 1 is the FRMSD of the current pairing (the quantity the outlier
//!   rejection minimises). The loop stops when E < `tolerance_m`, when E grows (the previous
//!   estimate and its pairing are kept), at `max_iterations`, or — the fixed point — when the
//!   update moves the kept source points by less than `tolerance_m` (RMS). The returned FRMSD is
//!   the one of the pairing at the returned transform.
//! - Algorithm 3 initialises `best_frmsd = 0` and tests `<`, which would never select anything;
//!   we start from +∞, and on ties keep the longer prefix (with exact data every prefix has
//!   FRMSD 0, and all pairs should be kept). Prefixes shorter than max(3, `min_points`) are not
//!   candidates: fewer pairs cannot pin down a 2D rigid transform robustly, and a "shared
//!   obstacles" count below `min_points` gives no estimate by the configuration's definition.
//! - Degenerate input gives `Err`, never a confident guess: too few points, non-finite values,
//!   a side whose points are all coincident or collinear (a line slides along itself, so the
//!   alignment is not unique), or a final kept set that is collinear on either side.
//! - Speed of [`initial_icp`] (441 positions × 16 headings = 7056 starts): a full ICP from every
//!   start would cost tens of milliseconds. Instead a cheap first pass scores every start by the
//!   FRMSD of its *initial* pairing only (source pre-rotated once per heading, distance-only
//!   nearest neighbour, squared FRMSD from a precomputed weight table, so no allocation, no
//!   `sqrt` and no `powf` in the inner loop); the best few starts, at least one per heading and a
//!   shortlist overall, are then run through the full ICP, and the lowest final FRMSD wins.
//!   Nearest-neighbour search goes one heading at a time and eight cells at once (independent
//!   lanes the compiler packs into SIMD). From [`TABLE_FROM_POINTS`] reference points the eight
//!   are a stretch of one grid column, searched against only the reference points that can be
//!   nearest to it ([`super::nearest`]'s table, built once per full grid: about 6 of a crowd's
//!   45 points; a sorted-by-x candidate window, tried before, cost more to pick the candidates
//!   than it saved); a smaller own set (a sparse forest's dozen trunks) is searched whole, in
//!   blocks that run on across columns, since the columns' padding would cost more than the
//!   table saves ([`Layout`]). The pairing of the full ICP is [`super::pairing`]'s: brute
//!   force over every reference point at first, then each point's previous partner where it is
//!   certainly still the nearest. Each start's
//!   distances are sorted for eq. 3.16's prefixes, eight starts at once by a sorting network on
//!   the same lanes ([`super::network`]: the same scores as a sort, without its mispredicted
//!   branches); a sort-free lower bound on the score (counts and sums by binary exponent) proved
//!   83 % of a crowd grid's starts unable to rank, but cost half a sort to compute.

use super::nearest::{raster_side, Candidates};
use super::network::{block_scores, Network, LANES};
use super::pairing::{distance2, Pair, Pairing};
use crate::geometry::wrap_angle;
use nalgebra::{Matrix2, Point2, Vector2};
use std::cmp::Ordering;
use std::rc::Rc;
use swarm_config::IcpParams;

/// The rigid transform `agent_from_neighbour`: it maps points from the neighbour's body frame
/// (the source set S) into this agent's body frame (the reference set R),
/// `p_R = Rot(rotation_rad) · p_S + translation_m`. So `translation_m` is where the neighbour is,
/// and `rotation_rad` its heading, relative to us.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AgentFromNeighbour {
    /// Relative heading of the neighbour [rad].
    pub rotation_rad: f64,
    /// Relative position of the neighbour, this agent's body frame [m].
    pub translation_m: Vector2<f64>,
}

/// The outcome of aligning a received set to our own.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Match {
    /// The alignment.
    pub agent_from_neighbour: AgentFromNeighbour,
    /// Fractional root mean square distance of the kept pairs (seed 000 eq. 3.16).
    pub frmsd: f64,
    /// Pairs kept after FRMSD outlier rejection.
    pub pairs: usize,
}

/// Why no estimate could be made.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum NoEstimate {
    /// A side has fewer than max(3, `min_points`) points (an empty set included).
    #[error("too few points for an ICP estimate")]
    TooFewPoints,
    /// A coordinate, the initial transform or a parameter is NaN or infinite.
    #[error("non-finite point, transform or parameter")]
    NonFinite,
    /// The points cannot pin down a 2D rigid transform: a side is all coincident or collinear,
    /// or the pairs kept at the end are.
    #[error("degenerate (coincident or collinear) point set")]
    Degenerate,
}

/// Below this RMS spread along the major axis a point set is "coincident" [m].
const MIN_SPREAD_M: f64 = 1e-6;

/// A point set is "collinear" when the RMS spread across its major axis is below this fraction of
/// the spread along it (a 20 m line with 3 cm noise is a line; three trees 5 m apart with one
/// 0.3 m off the line between the other two are not).
const MAX_COLLINEAR_RATIO: f64 = 1e-2;

/// FRMSD values closer than this are a tie, won by the longer prefix [m]: with exact data every
/// inlier distance is rounding noise (≈ 1e-15 m), and a prefix of exact zeros must not beat it.
const TIE_M: f64 = 1e-9;

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

/// Stop rule that ended an ICP run (exposed to the tests).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Stop {
    /// E < `tolerance_m`.
    Tolerance,
    /// The update moved the kept points by less than `tolerance_m` (RMS).
    Converged,
    /// E grew; the previous estimate was kept.
    Increase,
    /// `max_iterations` reached.
    MaxIterations,
}

/// The FRMSD of one pairing, after rejection.
#[derive(Debug, Clone, Copy)]
struct Eval {
    /// FRMSD of the best prefix (eq. 3.16); +∞ when no prefix qualifies.
    frmsd: f64,
    /// Length of the best prefix (the kept pairs).
    kept: usize,
}

/// Reusable buffers, so the ICP loop allocates nothing.
struct Workspace {
    /// The source set under the current transform.
    moved: Vec<Point2<f64>>,
    /// Pairing at the current estimate, sorted by distance.
    cur: Vec<Pair>,
    /// Pairing at the candidate estimate.
    next: Vec<Pair>,
    /// The pairings' buffers and the reference set's safe radii.
    pairing: Pairing,
    /// FRMSD² weights: `weights[i−1] = f^(−2λ) / i`, f = i/|D| (eq. 3.16 squared).
    weights: Rc<[f64]>,
    /// The bits of the λ `weights` were made for.
    lambda_bits: u64,
    /// Smallest prefix that may be kept: max(3, `min_points`).
    k_min: usize,
    /// First-pass scratch: the source rotated by one grid heading.
    rotated: Vec<Vector2<f64>>,
}

impl Workspace {
    /// Runs `f` on a workspace for `n_source` points, made from this thread's spare buffers when
    /// it has them (and handed back after). Why: a crowd's agent runs a few dozen short ICPs per
    /// step, and a fresh workspace was five allocations and a weight-table lookup each (1.3 %
    /// of a forest-1000-icp agent host, `perf`), and it keeps the pairing's safe radii of the
    /// agent's own set between them. Every buffer is cleared before it is read.
    fn reused<R>(n_source: usize, lambda: f64, k_min: usize, f: impl FnOnce(&mut Workspace) -> R) -> R {
        thread_local! {
            static SPARE: std::cell::RefCell<Option<Workspace>> = const { std::cell::RefCell::new(None) };
        }
        let spare = SPARE.with_borrow_mut(Option::take);
        let mut ws = match spare {
            Some(mut ws) => {
                if ws.weights.len() != n_source || ws.lambda_bits != lambda.to_bits() {
                    ws.weights = frmsd_weights(n_source, lambda);
                    ws.lambda_bits = lambda.to_bits();
                }
                ws.k_min = k_min;
                ws
            }
            None => Workspace::new(n_source, lambda, k_min),
        };
        let out = f(&mut ws);
        SPARE.with_borrow_mut(|spare| *spare = Some(ws));
        out
    }

    fn new(n_source: usize, lambda: f64, k_min: usize) -> Self {
        let weights = frmsd_weights(n_source, lambda);
        Workspace {
            moved: Vec::with_capacity(n_source),
            cur: Vec::with_capacity(n_source),
            next: Vec::with_capacity(n_source),
            pairing: Pairing::default(),
            weights,
            lambda_bits: lambda.to_bits(),
            k_min,
            rotated: Vec::with_capacity(n_source),
        }
    }
}

/// The FRMSD² weight table of [`Workspace::weights`] for `n_source` points and `lambda`.
///
/// Each thread keeps the tables it made, by set size and λ, and hands out shared references to
/// them: every ICP needs one, a crowd's short ICPs run by the hundred per step on sets of a few
/// dozen sizes, and `powf` per entry was 2 % of an agent host's CPU at 100 UAVs (`perf`). The
/// same calls on the same values, so the same bits.
fn frmsd_weights(n_source: usize, lambda: f64) -> Rc<[f64]> {
    /// Tables by (set size, λ's bits).
    type Tables = std::collections::HashMap<(usize, u64), Rc<[f64]>>;
    thread_local! {
        static TABLES: std::cell::RefCell<Tables> = std::cell::RefCell::new(Tables::new());
    }
    TABLES.with_borrow_mut(|tables| {
        tables
            .entry((n_source, lambda.to_bits()))
            .or_insert_with(|| {
                let n = n_source as f64;
                (1..=n_source)
                    .map(|i| {
                        let i = i as f64;
                        // seed 000, eq. 3.16 squared: FRMSD_i² = f^(−2λ) · (1/|D_f|) Σ d², f = i/|D|, |D_f| = i.
                        (i / n).powf(-2.0 * lambda) / i
                    })
                    .collect()
            })
            .clone()
    })
}

/// The rotation matrix of angle `a`.
fn rot(a: f64) -> Matrix2<f64> {
    let (s, c) = a.sin_cos();
    Matrix2::new(c, -s, s, c)
}

/// Checks the counts and finiteness of both sides; returns max(3, `min_points`).
fn validate(reference: &[Point2<f64>], source: &[Point2<f64>], p: &IcpParams) -> Result<usize, NoEstimate> {
    let k_min = (p.min_points as usize).max(3);
    if reference.len() < k_min || source.len() < k_min {
        return Err(NoEstimate::TooFewPoints);
    }
    let finite = |s: &[Point2<f64>]| s.iter().all(|q| q.x.is_finite() && q.y.is_finite());
    if !finite(reference) || !finite(source) || !p.lambda.is_finite() {
        return Err(NoEstimate::NonFinite);
    }
    if degenerate(reference.iter().copied()) || degenerate(source.iter().copied()) {
        return Err(NoEstimate::Degenerate);
    }
    Ok(k_min)
}

/// True when the points are (numerically) coincident or collinear: from the eigenvalues of their
/// 2×2 covariance, the major-axis RMS spread is < [`MIN_SPREAD_M`] or the minor/major spread
/// ratio is < [`MAX_COLLINEAR_RATIO`].
fn degenerate(points: impl Iterator<Item = Point2<f64>> + Clone) -> bool {
    let mut n = 0.0;
    let mut c = Vector2::zeros();
    for q in points.clone() {
        c += q.coords;
        n += 1.0;
    }
    if n < 1.0 {
        return true;
    }
    c /= n;
    let (sxx, sxy, syy) = crate::geometry::scatter(points, c);
    let (sxx, sxy, syy) = (sxx / n, sxy / n, syy / n);
    // Not in seed 000 (degeneracy test): eigenvalues of the 2×2 covariance [[sxx, sxy], [sxy, syy]]:
    // λ± = (sxx + syy)/2 ± sqrt(((sxx − syy)/2)² + sxy²).
    let mean = 0.5 * (sxx + syy);
    let rad = (0.25 * (sxx - syy) * (sxx - syy) + sxy * sxy).sqrt();
    let major = mean + rad;
    let minor = (mean - rad).max(0.0);
    !(major >= MIN_SPREAD_M * MIN_SPREAD_M && minor >= MAX_COLLINEAR_RATIO * MAX_COLLINEAR_RATIO * major)
}

/// Writes `t(source)` into `moved`.
fn apply(t: &AgentFromNeighbour, source: &[Point2<f64>], moved: &mut Vec<Point2<f64>>) {
    let r = rot(t.rotation_rad);
    moved.clear();
    // seed 000, eq. 3.12 form (tranSource): p_R = Rot(rotation_rad) · p_S + translation_m.
    moved.extend(source.iter().map(|q| Point2::from(r * q.coords + t.translation_m)));
}

/// FRMSD outlier rejection on squared distances sorted ascending (seed 000, Algorithm 3): the
/// prefix of length ≥ `k_min` with the smallest FRMSD, the longest on ties (within [`TIE_M`]).
/// Returns `(kept, FRMSD²)`, or `(0, +∞)` when no prefix qualifies (too few pairs, or NaN).
fn best_prefix(sorted_d2: impl Iterator<Item = f64>, weights: &[f64], k_min: usize) -> (usize, f64) {
    let mut cum = 0.0;
    let mut best = (0, f64::INFINITY);
    for (i, (d2, w)) in sorted_d2.zip(weights).enumerate() {
        cum += d2;
        if i + 1 >= k_min {
            // seed 000, eq. 3.16 squared: FRMSD_i² = f^(−2λ)/i · Σ_{k≤i} d_k².
            let f2 = w * cum;
            // Ties (to within TIE_M, i.e. rounding noise on exact data) go to the longer prefix.
            if f2 <= best.1 + TIE_M * TIE_M {
                best = (i + 1, f2);
            }
        }
    }
    best
}

/// Transforms the source by `t`, pairs, rejects; leaves the sorted pairing in `pairs` (`hint`:
/// the pairing of the iteration before, or empty; [`Pairing::pair`]).
#[allow(clippy::too_many_arguments)] // the workspace's buffers, borrowed apart
fn evaluate(
    reference: &[Point2<f64>],
    source: &[Point2<f64>],
    t: &AgentFromNeighbour,
    moved: &mut Vec<Point2<f64>>,
    pairing: &mut Pairing,
    hint: &[Pair],
    pairs: &mut Vec<Pair>,
    weights: &[f64],
    k_min: usize,
) -> Eval {
    apply(t, source, moved);
    pairing.pair(reference, moved, hint, pairs);
    let (kept, f2) = best_prefix(pairs.iter().map(|q| q.d2), weights, k_min);
    Eval { frmsd: f2.sqrt(), kept }
}

/// The rigid transform that best maps the kept moved source points onto their reference points
/// (seed 000, eq. 3.1–3.12): `(Rot, t)` with `a ↦ Rot·a + t`. `None` if the SVD fails.
fn estimate(reference: &[Point2<f64>], moved: &[Point2<f64>], kept: &[Pair]) -> Option<(Matrix2<f64>, Vector2<f64>)> {
    if kept.is_empty() {
        return None;
    }
    let k = kept.len() as f64;
    // seed 000, eq. 3.1: c_S = (1/N) Σ a_i, a_i ∈ S (the kept, currently transformed, source points).
    let c_s = kept.iter().fold(Vector2::zeros(), |acc, q| acc + moved[q.s].coords) / k;
    // seed 000, eq. 3.2: c_R = (1/N) Σ a_i, a_i ∈ R (their reference partners).
    let c_r = kept.iter().fold(Vector2::zeros(), |acc, q| acc + reference[q.r].coords) / k;
    // seed 000, eq. 3.3–3.9: W = R S'ᵀ with both sets centred, S' = S − c_S, R − c_R.
    let w = kept.iter().fold(Matrix2::zeros(), |acc: Matrix2<f64>, q| {
        acc + (reference[q.r].coords - c_r) * (moved[q.s].coords - c_s).transpose()
    });
    // seed 000, eq. 3.10: W = U Σ Vᵀ.
    let svd = w.try_svd(true, true, f64::EPSILON, 100)?;
    let u = svd.u?;
    let mut v_t = svd.v_t?;
    // seed 000, eq. 3.11: Rot = U Vᵀ.
    let mut r = u * v_t;
    if r.determinant() < 0.0 {
        // seed 000, 3.1 (after eq. 3.11): det = −1 is a reflection; negate the last column of V
        // (the last row of Vᵀ) to get the best proper rotation.
        v_t.row_mut(1).neg_mut();
        r = u * v_t;
    }
    if !r.iter().all(|x| x.is_finite()) {
        return None;
    }
    // seed 000, eq. 3.12: a_i ↦ Rot (a_i − c_S) + c_R = Rot a_i + (c_R − Rot c_S).
    Some((r, c_r - r * c_s))
}

/// Result of one ICP run (with the stop rule, for the tests).
#[derive(Debug, Clone, Copy)]
struct Run {
    m: Match,
    #[cfg_attr(not(test), allow(dead_code))] // read by the tests
    iterations: u32,
    #[cfg_attr(not(test), allow(dead_code))] // read by the tests
    stop: Stop,
}

/// ICP (seed 000, Algorithm 1) from `initial` on validated input, with `ws.weights` and
/// `ws.k_min` prepared for `source.len()`.
fn icp_core(
    reference: &[Point2<f64>],
    source: &[Point2<f64>],
    initial: AgentFromNeighbour,
    p: &IcpParams,
    ws: &mut Workspace,
) -> Result<Run, NoEstimate> {
    let Workspace { moved, cur, next, pairing, weights, k_min, .. } = ws;
    let k_min = *k_min;
    pairing.begin_run();
    let mut t = initial;
    let mut e = evaluate(reference, source, &t, moved, pairing, &[], cur, weights, k_min);
    if !e.frmsd.is_finite() {
        return Err(NoEstimate::NonFinite);
    }
    let mut iterations = 0;
    let stop = loop {
        // seed 000, Algorithm 1: while E > threshold and i < iter.
        if e.frmsd < p.tolerance_m {
            break Stop::Tolerance;
        }
        if iterations >= p.max_iterations {
            break Stop::MaxIterations;
        }
        // `moved` still holds the source under `t`, `cur` its pairing.
        let kept = &cur[..e.kept];
        let (r, tr) = estimate(reference, moved, kept).ok_or(NoEstimate::Degenerate)?;
        // Not in seed 000: mean squared displacement of the kept points by this update,
        // (1/N) Σ ‖ΔRot a + Δt − a‖², for the fixed-point stop.
        let step2 = kept.iter().map(|q| (r * moved[q.s].coords + tr - moved[q.s].coords).norm_squared()).sum::<f64>()
            / kept.len() as f64;
        let d_rot = r[(1, 0)].atan2(r[(0, 0)]);
        // seed 000, eq. 3.12 (tranSource) composed onto the estimate: p_R = ΔRot (Rot p_S + t) + Δt.
        let candidate = AgentFromNeighbour {
            rotation_rad: wrap_angle(t.rotation_rad + d_rot),
            translation_m: rot(d_rot) * t.translation_m + tr,
        };
        iterations += 1;
        let e_next = evaluate(reference, source, &candidate, moved, pairing, cur, next, weights, k_min);
        if !matches!(e_next.frmsd.partial_cmp(&e.frmsd), Some(Ordering::Less | Ordering::Equal)) {
            // seed 000, 3.1: stop "when the error in step k + 1 is higher than in step k"; keep
            // step k. `cur` still holds its pairing; `moved` is stale but no longer needed.
            break Stop::Increase;
        }
        t = candidate;
        e = e_next;
        std::mem::swap(cur, next);
        if step2 < p.tolerance_m * p.tolerance_m {
            break Stop::Converged;
        }
    };
    let kept = &cur[..e.kept];
    if degenerate(kept.iter().map(|q| reference[q.r])) || degenerate(kept.iter().map(|q| source[q.s])) {
        return Err(NoEstimate::Degenerate);
    }
    Ok(Run { m: Match { agent_from_neighbour: t, frmsd: e.frmsd, pairs: e.kept }, iterations, stop })
}

/// ICP from an initial transform (the "short ICP" of seed 000 5.1): pair every point of `source`
/// (transformed) with its nearest point of `reference`; FRMSD outlier rejection on the pairs
/// sorted by distance (best prefix by FRMSD = (1/f^λ)·sqrt(mean d²), f = i/|D|, eq. 3.16–3.17,
/// Algorithm 3), estimate the rigid transform from the kept pairs (centroids + SVD of the
/// cross-covariance, det = −1 → negate the last column of V), compose it onto the current
/// estimate; stop on error < tolerance, error increase (keep the previous estimate), a fixed
/// point (update below tolerance) or `max_iterations`. The returned frmsd is that of the final
/// pairing.
///
/// Errors: [`NoEstimate::TooFewPoints`] when a side has fewer than max(3, `min_points`) points,
/// [`NoEstimate::NonFinite`] for NaN/∞ in the points, `initial` or `lambda`,
/// [`NoEstimate::Degenerate`] when a side, or the final kept pairs, are coincident or collinear.
pub fn icp(
    reference: &[Point2<f64>],
    source: &[Point2<f64>],
    initial: AgentFromNeighbour,
    p: &IcpParams,
) -> Result<Match, NoEstimate> {
    let k_min = validate(reference, source, p)?;
    if !initial.rotation_rad.is_finite() || !initial.translation_m.iter().all(|x| x.is_finite()) {
        return Err(NoEstimate::NonFinite);
    }
    Workspace::reused(source.len(), p.lambda, k_min, |ws| icp_core(reference, source, initial, p, ws).map(|run| run.m))
}

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
/// AVX2 (four lanes) and pick that version at run time where the CPU has it (`multiversion`):
/// the same operations in the same order per lane (no fused multiply-add is enabled), so the
/// distances are bit for bit those of the baseline build. The first pass's blocks are then
/// scored lane by lane too ([`super::network`]).
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
#[multiversion::multiversion(targets("x86_64+avx2"))]
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
#[multiversion::multiversion(targets("x86_64+avx2"))]
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
/// Errors as for [`icp`]; a non-finite `grid_spacing_m` is [`NoEstimate::NonFinite`]; when no
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
    /// [`DISTINCT_M`] from `best` or turn it more than [`DISTINCT_RAD`] from it; `None` if every
    /// refined start converged to `best`'s alignment.
    pub runner_up: Option<Match>,
}

/// Two alignments farther apart than this place the neighbour in different places [m].
pub const DISTINCT_M: f64 = 0.5;

/// ... or turn it by more than this [rad] (about 17°).
pub const DISTINCT_RAD: f64 = 0.3;

/// True when `a` and `b` are different alignments (in place or in heading): the runner-up's
/// test here, and a jump's in [`super::placement::judge_long`].
pub(super) fn distinct(a: &AgentFromNeighbour, b: &AgentFromNeighbour) -> bool {
    (a.translation_m - b.translation_m).norm() > DISTINCT_M
        || wrap_angle(a.rotation_rad - b.rotation_rad).abs() > DISTINCT_RAD
}

/// [`initial_icp`] with its runner-up: how well the second-best different alignment fits tells an
/// unambiguous match (one basin fits) from an ambiguous one (several places fit about as well).
pub fn initial_icp_ranked(
    reference: &[Point2<f64>],
    source: &[Point2<f64>],
    p: &IcpParams,
) -> Result<Ranked, NoEstimate> {
    initial_icp_ranked_from(reference, source, p, TABLE_FROM_POINTS)
}

/// [`initial_icp_ranked`] with the first pass's candidate table from `table_from` reference
/// points (the tests compare both layouts).
fn initial_icp_ranked_from(
    reference: &[Point2<f64>],
    source: &[Point2<f64>],
    p: &IcpParams,
    table_from: usize,
) -> Result<Ranked, NoEstimate> {
    let k_min = validate(reference, source, p)?;
    if !p.grid_spacing_m.is_finite() {
        return Err(NoEstimate::NonFinite);
    }
    let mut ws = Workspace::new(source.len(), p.lambda, k_min);
    let h = i64::from(p.grid_half_cells);
    let headings = p.grid_headings.max(1);
    // Within SUPPRESS_CELLS cells (with a margin for rounding).
    let suppress2 = (SUPPRESS_CELLS * p.grid_spacing_m).powi(2) * (1.0 + 1e-9);

    // First pass: score all starts, keep the best of each heading and a shortlist overall.
    let mut shortlist: Vec<Start> = Vec::with_capacity(SHORTLIST + 1);
    let mut per_heading: Vec<Start> = Vec::with_capacity(headings as usize);
    let cells = grid_cells(h, p.grid_spacing_m);
    let side = (2 * h + 1) as usize;
    // Every start's anchor lies within the source's reach plus the grid's half width.
    let reach = source.iter().map(|q| q.coords.norm()).fold(0.0, f64::max) + h as f64 * p.grid_spacing_m.abs();
    let layout = Layout::new(reference, &cells, side, headings, reach * (1.0 + 1e-9), p.grid_spacing_m, table_from);
    let n = source.len();
    let slots_per_column = layout.slots_per_column(side);
    let mut by_cell = vec![[0.0; BLOCK]; layout.rows(cells.len(), side, n)];
    let net = Network::new(n);
    for k in 0..headings {
        // seed 000, 5.1 ("all relative headings"): θ_k = 2π·k/H, evenly spaced.
        let heading = wrap_angle(std::f64::consts::TAU * f64::from(k) / f64::from(headings));
        let r = rot(heading);
        ws.rotated.clear();
        ws.rotated.extend(source.iter().map(|q| r * q.coords));
        layout.nearest(reference, &ws.rotated, &cells, side, &mut by_cell);
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
pub(super) mod tests {
    use super::*;
    use proptest::prelude::*;
    use proptest::test_runner::RngSeed;
    use std::f64::consts::PI;

    /// SplitMix64: a tiny deterministic PRNG for the tests (the pairing's too).
    pub(in crate::localization::icp) struct Rng(pub(in crate::localization::icp) u64);
    impl Rng {
        fn next_u64(&mut self) -> u64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        }
        /// Uniform in [0, 1).
        fn unit(&mut self) -> f64 {
            (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
        }
        pub(in crate::localization::icp) fn range(&mut self, lo: f64, hi: f64) -> f64 {
            lo + (hi - lo) * self.unit()
        }
        /// Standard normal (Box–Muller).
        fn gauss(&mut self) -> f64 {
            let u1 = 1.0 - self.unit();
            let u2 = self.unit();
            (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
        }
    }

    /// `n` points in the square [c − half, c + half]², at least `spacing` from each other and
    /// from `avoid` (tree centres).
    fn scatter(
        rng: &mut Rng,
        n: usize,
        c: Vector2<f64>,
        half: f64,
        spacing: f64,
        avoid: &[Point2<f64>],
    ) -> Vec<Point2<f64>> {
        let mut out: Vec<Point2<f64>> = Vec::with_capacity(n);
        while out.len() < n {
            let q = Point2::new(c.x + rng.range(-half, half), c.y + rng.range(-half, half));
            if out.iter().chain(avoid).all(|a| (a - q).norm() >= spacing) {
                out.push(q);
            }
        }
        out
    }

    /// Expresses reference-frame points in the neighbour's frame: p_S = Rot(θ)ᵀ (p_R − t).
    fn to_source(t: &AgentFromNeighbour, pts: &[Point2<f64>]) -> Vec<Point2<f64>> {
        let r = rot(t.rotation_rad).transpose();
        pts.iter().map(|q| Point2::from(r * (q.coords - t.translation_m))).collect()
    }

    fn random_transform(rng: &mut Rng, max_t: f64) -> AgentFromNeighbour {
        AgentFromNeighbour {
            rotation_rad: rng.range(-PI, PI),
            translation_m: Vector2::new(rng.range(-max_t, max_t), rng.range(-max_t, max_t)),
        }
    }

    /// `t` perturbed by up to `dt` metres per axis and `da` radians.
    fn perturb(rng: &mut Rng, t: &AgentFromNeighbour, dt: f64, da: f64) -> AgentFromNeighbour {
        AgentFromNeighbour {
            rotation_rad: t.rotation_rad + rng.range(-da, da),
            translation_m: t.translation_m + Vector2::new(rng.range(-dt, dt), rng.range(-dt, dt)),
        }
    }

    fn angle_err(a: f64, b: f64) -> f64 {
        wrap_angle(a - b).abs()
    }

    fn close(m: &Match, truth: &AgentFromNeighbour, tol_m: f64, tol_rad: f64) -> bool {
        (m.agent_from_neighbour.translation_m - truth.translation_m).norm() < tol_m
            && angle_err(m.agent_from_neighbour.rotation_rad, truth.rotation_rad) < tol_rad
    }

    /// The scenario of the acceptance test: 20 reference points (trees, ≥ 1.5 m apart) in a 20 m ×
    /// 20 m square around us; the neighbour at a random pose (heading in [−π, π), translation
    /// within ±5 m); its set is 14 of the reference points in its frame plus 6 trees only it sees
    /// (in the 20 m square around it, ≥ 1.5 m from every tree), all with Gaussian noise `sigma`,
    /// shuffled. So 30 % of each side is one-sided.
    fn scenario(rng: &mut Rng, sigma: f64) -> (Vec<Point2<f64>>, Vec<Point2<f64>>, AgentFromNeighbour) {
        let reference = scatter(rng, 20, Vector2::zeros(), 10.0, 1.5, &[]);
        let truth = random_transform(rng, 5.0);
        let mut seen = reference[..14].to_vec();
        seen.extend(scatter(rng, 6, truth.translation_m, 10.0, 1.5, &reference));
        let mut source = to_source(&truth, &seen);
        for q in &mut source {
            q.x += sigma * rng.gauss();
            q.y += sigma * rng.gauss();
        }
        // Fisher–Yates, so the shared points are not the first ones.
        for i in (1..source.len()).rev() {
            let j = (rng.next_u64() % (i as u64 + 1)) as usize;
            source.swap(i, j);
        }
        (reference, source, truth)
    }

    /// Runs the internal ICP with a fresh workspace (validation included).
    fn run(
        reference: &[Point2<f64>],
        source: &[Point2<f64>],
        initial: AgentFromNeighbour,
        p: &IcpParams,
    ) -> Result<Run, NoEstimate> {
        let k_min = validate(reference, source, p)?;
        let mut ws = Workspace::new(source.len(), p.lambda, k_min);
        icp_core(reference, source, initial, p, &mut ws)
    }

    /// FRMSD (eq. 3.16) and the pairing at `t`, plus the transform one ICP step further.
    fn eval_and_step(
        reference: &[Point2<f64>],
        source: &[Point2<f64>],
        t: &AgentFromNeighbour,
        p: &IcpParams,
    ) -> (Eval, Option<AgentFromNeighbour>) {
        let k_min = validate(reference, source, p).expect("valid");
        let mut ws = Workspace::new(source.len(), p.lambda, k_min);
        let e = evaluate(reference, source, t, &mut ws.moved, &mut ws.pairing, &[], &mut ws.cur, &ws.weights, k_min);
        let step = estimate(reference, &ws.moved, &ws.cur[..e.kept]).map(|(r, tr)| {
            let d = r[(1, 0)].atan2(r[(0, 0)]);
            AgentFromNeighbour {
                rotation_rad: wrap_angle(t.rotation_rad + d),
                translation_m: rot(d) * t.translation_m + tr,
            }
        });
        (e, step)
    }

    fn square_ish() -> Vec<Point2<f64>> {
        vec![
            Point2::new(0.0, 0.0),
            Point2::new(4.0, 0.5),
            Point2::new(1.0, 3.0),
            Point2::new(-2.0, 2.0),
            Point2::new(3.0, -3.0),
        ]
    }

    #[test]
    fn exact_transform_recovered_from_nearby_estimate() {
        let p = IcpParams::default();
        let mut rng = Rng(1);
        for _ in 0..100 {
            let reference = scatter(&mut rng, 20, Vector2::zeros(), 10.0, 1.5, &[]);
            let truth = random_transform(&mut rng, 5.0);
            let source = to_source(&truth, &reference);
            let start = perturb(&mut rng, &truth, 0.3, 5f64.to_radians());
            let m = icp(&reference, &source, start, &p).expect("estimate");
            assert!(close(&m, &truth, 1e-9, 1e-9), "{m:?} vs {truth:?}");
            assert_eq!(m.pairs, 20);
            assert!(m.frmsd < 1e-9);
        }
    }

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

    #[test]
    fn exact_data_stops_on_tolerance() {
        let p = IcpParams::default();
        let mut rng = Rng(2);
        let reference = scatter(&mut rng, 20, Vector2::zeros(), 10.0, 1.5, &[]);
        let truth = random_transform(&mut rng, 5.0);
        let source = to_source(&truth, &reference);
        let r = run(&reference, &source, perturb(&mut rng, &truth, 0.3, 0.05), &p).expect("estimate");
        assert_eq!(r.stop, Stop::Tolerance);
        assert!(r.iterations >= 1 && r.iterations <= 3, "{r:?}");
    }

    #[test]
    fn reflection_fix_yields_proper_rotation() {
        // The moved source is the mirror image (x ↦ −x) of the reference, so det W < 0 and the
        // plain U Vᵀ is a reflection; the fix must give the best *proper* rotation instead.
        let reference = square_ish();
        let moved: Vec<Point2<f64>> = reference.iter().map(|q| Point2::new(-q.x, q.y)).collect();
        let kept: Vec<Pair> = (0..reference.len()).map(|i| Pair { d2: 0.0, s: i, r: i }).collect();
        let n = reference.len() as f64;
        let c_s = moved.iter().fold(Vector2::zeros(), |a, q| a + q.coords) / n;
        let c_r = reference.iter().fold(Vector2::zeros(), |a, q| a + q.coords) / n;
        let w = reference
            .iter()
            .zip(&moved)
            .fold(Matrix2::zeros(), |a: Matrix2<f64>, (r, s)| a + (r.coords - c_r) * (s.coords - c_s).transpose());
        let svd = w.svd(true, true);
        let plain = svd.u.expect("u") * svd.v_t.expect("v_t");
        assert!(plain.determinant() < 0.0, "the case must need the fix");

        let (r, t) = estimate(&reference, &moved, &kept).expect("estimate");
        assert!((r.determinant() - 1.0).abs() < 1e-12);
        assert!((r.transpose() * r - Matrix2::identity()).norm() < 1e-12);
        // Optimal among proper rotations: the closed form θ* = atan2(Σ s'×r', Σ s'·r').
        let (mut cross, mut dot) = (0.0, 0.0);
        for (a, b) in moved.iter().zip(&reference) {
            let (s, q) = (a.coords - c_s, b.coords - c_r);
            cross += s.x * q.y - s.y * q.x;
            dot += s.dot(&q);
        }
        let theta = r[(1, 0)].atan2(r[(0, 0)]);
        assert!(angle_err(theta, cross.atan2(dot)) < 1e-12, "{theta} vs {}", cross.atan2(dot));
        // eq. 3.12: the centroids map onto each other.
        assert!((r * c_s + t - c_r).norm() < 1e-12);
        // And ICP on the mirrored set still returns a proper (finite) transform or an error.
        if let Ok(m) = icp(
            &reference,
            &moved,
            AgentFromNeighbour { rotation_rad: 0.0, translation_m: Vector2::zeros() },
            &IcpParams::default(),
        ) {
            assert!(m.agent_from_neighbour.rotation_rad.is_finite() && m.frmsd.is_finite());
        }
    }

    #[test]
    fn frmsd_prefix_matches_eq_3_16() {
        let lambda = 1.3;
        let ws = Workspace::new(6, lambda, 3);
        let d = [0.01, 0.02, 0.02, 0.03, 2.0, 3.5];
        let direct = |i: usize| {
            let f = i as f64 / d.len() as f64;
            f.powf(-lambda) * (d[..i].iter().map(|x| x * x).sum::<f64>() / i as f64).sqrt()
        };
        let (kept, f2) = best_prefix(d.iter().map(|x| x * x), &ws.weights, 3);
        let best = (3..=6).min_by(|&a, &b| direct(a).total_cmp(&direct(b))).expect("some");
        assert_eq!(kept, best);
        assert_eq!(kept, 4, "the two far pairs are outliers");
        assert!((f2.sqrt() - direct(4)).abs() < 1e-12);
        // Exact data: every prefix has FRMSD 0 and all pairs are kept.
        assert_eq!(best_prefix([0.0; 6].into_iter(), &ws.weights, 3), (6, 0.0));
        // Never fewer than k_min, even when the first two pairs are perfect.
        let (kept, _) = best_prefix([0.0, 0.0, 4.0, 4.0, 4.0, 4.0].into_iter(), &ws.weights, 3);
        assert!(kept >= 3);
        // NaN gives no prefix.
        assert_eq!(best_prefix([f64::NAN; 6].into_iter(), &ws.weights, 3).0, 0);
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

    #[test]
    fn frmsd_rejects_30_percent_outliers() {
        let p = IcpParams::default();
        let mut rng = Rng(3);
        for _ in 0..100 {
            // Noise-free: the 14 shared points pair exactly, the 6 one-sided ones are ≥ 1.5 m off.
            let (reference, source, truth) = scenario(&mut rng, 0.0);
            let start = perturb(&mut rng, &truth, 0.3, 5f64.to_radians());
            let m = icp(&reference, &source, start, &p).expect("estimate");
            assert!(close(&m, &truth, 1e-9, 1e-9), "{m:?} vs {truth:?}");
            assert_eq!(m.pairs, 14);
        }
        // With noise σ = 0.03 m: still recovered to a few centimetres.
        for _ in 0..100 {
            let (reference, source, truth) = scenario(&mut rng, 0.03);
            let start = perturb(&mut rng, &truth, 0.3, 5f64.to_radians());
            let m = icp(&reference, &source, start, &p).expect("estimate");
            assert!(close(&m, &truth, 0.1, 2f64.to_radians()), "{m:?} vs {truth:?}");
        }
    }

    #[test]
    fn stops_on_error_increase_and_keeps_previous_estimate() {
        // Error increases happen from poor starts among outliers; find one deterministically.
        let p = IcpParams { tolerance_m: 0.0, ..IcpParams::default() };
        let mut rng = Rng(4);
        let mut found = 0;
        for _ in 0..500 {
            let (reference, source, truth) = scenario(&mut rng, 0.03);
            let start = perturb(&mut rng, &truth, 3.0, 0.6);
            let Ok(r) = run(&reference, &source, start, &p) else { continue };
            if r.stop != Stop::Increase {
                continue;
            }
            found += 1;
            // The returned FRMSD is that of the pairing at the returned transform ...
            let (e, next) = eval_and_step(&reference, &source, &r.m.agent_from_neighbour, &p);
            assert_eq!(e.frmsd, r.m.frmsd);
            assert_eq!(e.kept, r.m.pairs);
            // ... and one more step would have raised it: that step was refused.
            let next = next.expect("step");
            let (e_next, _) = eval_and_step(&reference, &source, &next, &p);
            assert!(e_next.frmsd > r.m.frmsd, "{} ≤ {}", e_next.frmsd, r.m.frmsd);
            assert!(r.iterations >= 1);
        }
        assert!(found >= 5, "only {found} increase stops found");
    }

    #[test]
    fn iteration_cap_is_respected() {
        let mut rng = Rng(5);
        let reference = scatter(&mut rng, 20, Vector2::zeros(), 10.0, 1.5, &[]);
        let truth = random_transform(&mut rng, 5.0);
        let source = to_source(&truth, &reference);
        let start = perturb(&mut rng, &truth, 0.5, 0.1);
        // Cap 0: the initial transform comes back, with the FRMSD of its pairing.
        let p0 = IcpParams { max_iterations: 0, ..IcpParams::default() };
        let m = icp(&reference, &source, start, &p0).expect("estimate");
        assert_eq!(m.agent_from_neighbour, start);
        assert_eq!(m.frmsd, eval_and_step(&reference, &source, &start, &p0).0.frmsd);
        // Cap 1: exactly one step, stopped by the cap, equal to the step computed by hand.
        let p1 = IcpParams { max_iterations: 1, tolerance_m: 0.0, ..IcpParams::default() };
        let r = run(&reference, &source, start, &p1).expect("estimate");
        assert_eq!((r.iterations, r.stop), (1, Stop::MaxIterations));
        assert_eq!(Some(r.m.agent_from_neighbour), eval_and_step(&reference, &source, &start, &p1).1);
        // Any cap: never more iterations than the cap, over random noisy runs from poor starts.
        for cap in [1, 2, 3, 5, 8] {
            let p = IcpParams { max_iterations: cap, tolerance_m: 0.0, ..IcpParams::default() };
            for _ in 0..20 {
                let (reference, source, truth) = scenario(&mut rng, 0.03);
                if let Ok(r) = run(&reference, &source, perturb(&mut rng, &truth, 2.0, 0.4), &p) {
                    assert!(r.iterations <= cap);
                    assert!(r.stop != Stop::MaxIterations || r.iterations == cap);
                }
            }
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
        let all = initial_icp_ranked_from(&reference, &source, &p, usize::MAX);
        assert_eq!(format!("{all:?}"), format!("{:?}", initial_icp_ranked_from(&reference, &source, &p, 0)));
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
    fn collinear_kept_set_is_degenerate() {
        // Both sets are 2D, but the only pairs that agree lie on a line: the 3 off-line points of
        // the source are far from everything and are rejected, leaving a collinear kept set that
        // could slide along the line.
        let mut reference: Vec<Point2<f64>> = (0..6).map(|i| Point2::new(i as f64 * 2.0, 0.0)).collect();
        reference.extend([Point2::new(1.0, 6.0), Point2::new(5.0, -7.0)]);
        let mut source: Vec<Point2<f64>> = (0..6).map(|i| Point2::new(i as f64 * 2.0, 0.0)).collect();
        source.extend([Point2::new(30.0, 30.0), Point2::new(-30.0, 25.0), Point2::new(20.0, -30.0)]);
        let id = AgentFromNeighbour { rotation_rad: 0.0, translation_m: Vector2::zeros() };
        assert_eq!(icp(&reference, &source, id, &IcpParams::default()), Err(NoEstimate::Degenerate));
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

    pub(in crate::localization::icp) fn config(cases: u32) -> ProptestConfig {
        ProptestConfig {
            cases,
            rng_seed: RngSeed::Fixed(0x000C_1CF0),
            failure_persistence: None,
            ..ProptestConfig::default()
        }
    }

    /// A coordinate: mostly ordinary, sometimes NaN/±∞ or a repeated value.
    fn coord() -> impl Strategy<Value = f64> {
        prop_oneof![
            20 => -15.0..15.0f64,
            1 => Just(f64::NAN),
            1 => Just(f64::INFINITY),
            1 => Just(f64::NEG_INFINITY),
            2 => Just(1.0),
        ]
    }

    fn points(max: usize) -> impl Strategy<Value = Vec<Point2<f64>>> {
        prop::collection::vec((coord(), coord()).prop_map(|(x, y)| Point2::new(x, y)), 0..max)
    }

    proptest! {
        #![proptest_config(config(256))]

        /// Whatever comes in, ICP returns an error or a finite, sane match; it never panics.
        #[test]
        fn prop_icp_is_total(reference in points(12), source in points(12), a in -10.0..10.0f64, x in -10.0..10.0f64, y in -10.0..10.0f64) {
            let p = IcpParams::default();
            match icp(&reference, &source, AgentFromNeighbour { rotation_rad: a, translation_m: Vector2::new(x, y) }, &p) {
                Ok(m) => {
                    prop_assert!(m.frmsd.is_finite() && m.frmsd >= 0.0);
                    prop_assert!(m.agent_from_neighbour.rotation_rad.is_finite() && (-PI..PI).contains(&m.agent_from_neighbour.rotation_rad));
                    prop_assert!(m.agent_from_neighbour.translation_m.iter().all(|v| v.is_finite()));
                    prop_assert!(m.pairs >= 3 && m.pairs <= source.len());
                }
                Err(e) => prop_assert!(matches!(e, NoEstimate::TooFewPoints | NoEstimate::NonFinite | NoEstimate::Degenerate)),
            }
        }

        /// A rigid motion of a 2D set is recovered exactly from a nearby start.
        #[test]
        fn prop_icp_recovers_rigid_motion(seed in any::<u64>(), a in -PI..PI, x in -5.0..5.0f64, y in -5.0..5.0f64, n in 5usize..25) {
            let mut rng = Rng(seed);
            let reference = scatter(&mut rng, n, Vector2::zeros(), 10.0, 1.5, &[]);
            let truth = AgentFromNeighbour { rotation_rad: a, translation_m: Vector2::new(x, y) };
            let source = to_source(&truth, &reference);
            let start = perturb(&mut rng, &truth, 0.3, 3f64.to_radians());
            let m = icp(&reference, &source, start, &IcpParams::default());
            prop_assert!(m.is_ok_and(|m| close(&m, &truth, 1e-9, 1e-9)), "{m:?} vs {truth:?}");
        }
    }

    proptest! {
        #![proptest_config(config(64))]

        /// A block's scores by the sorting network equal bit for bit the start-by-start sort
        /// and prefix scan, ties, +∞ and NaN lanes included.
        #[test]
        fn prop_block_scores_are_the_start_by_start_scores(seed in any::<u64>(), n in 3usize..60, k_min in 3usize..8, coarse in any::<bool>(), nan in any::<bool>()) {
            let mut rng = Rng(seed);
            let ws = Workspace::new(n, 1.3, k_min.min(n));
            let mut rows: Vec<[f64; BLOCK]> = (0..n)
                .map(|_| std::array::from_fn(|_| if coarse { (rng.range(0.0, 8.0) as u32) as f64 } else { rng.range(0.0, 30.0).powi(2) }))
                .collect();
            rows[n / 2][3] = f64::INFINITY;
            if nan {
                rows[n - 1][5] = f64::NAN;
            }
            let want: Vec<u64> = (0..BLOCK)
                .map(|l| first_pass_score(&mut rows.iter().map(|r| r[l]).collect::<Vec<_>>(), &ws.weights, ws.k_min).to_bits())
                .collect();
            let got = block_first_pass(&mut rows, &Network::new(n), &ws.weights, ws.k_min);
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
            let all = initial_icp_ranked_from(&reference, &source, &p, usize::MAX);
            let table = initial_icp_ranked_from(&reference, &source, &p, 0);
            prop_assert_eq!(format!("{all:?}"), format!("{table:?}"));
        }
    }
}

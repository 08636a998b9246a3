//! The ICP alignment of seed 000 ("K21", sections 3.1 and 3.3): where a neighbour is, from its
//! obstacle set and ours, starting from an estimate of it.
//!
//! Why this module exists: in `icp` localization mode (SPEC section 5) agents are anonymous and
//! share only the obstacle centres they see, in their own body frame. To know where a neighbour
//! is and where it is heading, the receiver aligns the received set S to its own set R. This
//! module is that alignment, as pure functions with no IO and no clock, so the neighbour database
//! (seed 000 5.2–5.3) can call it freely and it can be tested and benchmarked in isolation. What
//! to make of an alignment (place a neighbour, keep a track) is not decided here but in
//! [`super::placement`]; where to start it when nothing is known yet (the full-grid initial
//! estimate of seed 000 5.1, which runs this ICP from its best starts) is [`super::grid`]'s.
//!
//! - [`icp`] is the ICP of Algorithm 1 (the "short ICP" of seed 000 5.1): nearest-neighbour
//!   pairing, FRMSD outlier rejection (eq. 3.16–3.17, Algorithm 3), rigid transform from the kept
//!   pairs by centroids + SVD of the cross-covariance with the reflection fix (eq. 3.1–3.12),
//!   composed onto the running estimate.
//! - Its result: an [`AgentFromNeighbour`] in a [`Match`] with its FRMSD and kept pairs, or why
//!   there is none ([`NoEstimate`]); [`DISTINCT_M`] and [`DISTINCT_RAD`] say when two results
//!   are different alignments.
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
//! - The pairing is [`super::pairing`]'s: brute force over every reference point at first, then
//!   each point's previous partner where it is certainly still the nearest.

use super::network::LANES;
use super::pairing::{block_nearest, Pair, Pairing};
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
pub(super) const TIE_M: f64 = 1e-9;

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
pub(super) struct Workspace {
    /// The source set under the current transform.
    moved: Vec<Point2<f64>>,
    /// Pairing at the current estimate, sorted by distance.
    cur: Vec<Pair>,
    /// Pairing at the candidate estimate.
    next: Vec<Pair>,
    /// The pairings' buffers and the reference set's safe radii.
    pairing: Pairing,
    /// FRMSD² weights: `weights[i−1] = f^(−2λ) / i`, f = i/|D| (eq. 3.16 squared).
    pub(super) weights: Rc<[f64]>,
    /// The bits of the λ `weights` were made for.
    lambda_bits: u64,
    /// Smallest prefix that may be kept: max(3, `min_points`).
    k_min: usize,
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

    pub(super) fn new(n_source: usize, lambda: f64, k_min: usize) -> Self {
        let weights = frmsd_weights(n_source, lambda);
        Workspace {
            moved: Vec::with_capacity(n_source),
            cur: Vec::with_capacity(n_source),
            next: Vec::with_capacity(n_source),
            pairing: Pairing::default(),
            weights,
            lambda_bits: lambda.to_bits(),
            k_min,
        }
    }
}

/// The FRMSD² weight table of [`Workspace::weights`] for `n_source` points and `lambda`.
///
/// Each thread keeps the tables it made, one per set size (for the last λ asked at that size),
/// and hands out shared references to them: every ICP needs one, a crowd's short ICPs run by
/// the hundred per step on sets of a few dozen sizes, and `powf` per entry was 2 % of an agent
/// host's CPU at 100 UAVs (`perf`). Looked up by size in a list rather than hashed: the
/// localization budget's check asks for the table of its eight points dozens of times per agent
/// and step, and a hashed map's lookup was a tenth of the check's time (`cargo bench -p
/// uav-agent --bench icp -- fit_near_middle`). The same calls on the same values, so the same
/// bits.
fn frmsd_weights(n_source: usize, lambda: f64) -> Rc<[f64]> {
    /// Per set size, λ's bits and its table.
    type Tables = Vec<Option<(u64, Rc<[f64]>)>>;
    thread_local! {
        static TABLES: std::cell::RefCell<Tables> = const { std::cell::RefCell::new(Vec::new()) };
    }
    TABLES.with_borrow_mut(|tables| {
        if tables.len() <= n_source {
            tables.resize(n_source + 1, None);
        }
        match &tables[n_source] {
            Some((bits, w)) if *bits == lambda.to_bits() => Rc::clone(w),
            _ => {
                let n = n_source as f64;
                let w: Rc<[f64]> = (1..=n_source)
                    .map(|i| {
                        let i = i as f64;
                        // seed 000, eq. 3.16 squared: FRMSD_i² = f^(−2λ) · (1/|D_f|) Σ d², f = i/|D|, |D_f| = i.
                        (i / n).powf(-2.0 * lambda) / i
                    })
                    .collect();
                tables[n_source] = Some((lambda.to_bits(), Rc::clone(&w)));
                w
            }
        }
    })
}

/// The rotation matrix of angle `a`.
pub(super) fn rot(a: f64) -> Matrix2<f64> {
    let (s, c) = a.sin_cos();
    Matrix2::new(c, -s, s, c)
}

/// Checks the counts and finiteness of both sides; returns max(3, `min_points`).
pub(super) fn validate(reference: &[Point2<f64>], source: &[Point2<f64>], p: &IcpParams) -> Result<usize, NoEstimate> {
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
    moved.extend(source.iter().map(|q| move_by(&r, &t.translation_m, *q)));
}

/// FRMSD outlier rejection on squared distances sorted ascending (seed 000, Algorithm 3): the
/// prefix of length ≥ `k_min` with the smallest FRMSD, the longest on ties (within [`TIE_M`]).
/// Returns `(kept, FRMSD²)`, or `(0, +∞)` when no prefix qualifies (too few pairs, or NaN).
pub(super) fn best_prefix(sorted_d2: impl Iterator<Item = f64>, weights: &[f64], k_min: usize) -> (usize, f64) {
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
pub(super) struct Run {
    pub(super) m: Match,
    #[cfg_attr(not(test), allow(dead_code))] // read by the tests
    iterations: u32,
    #[cfg_attr(not(test), allow(dead_code))] // read by the tests
    stop: Stop,
}

/// ICP (seed 000, Algorithm 1) from `initial` on validated input, with `ws.weights` and
/// `ws.k_min` prepared for `source.len()`.
pub(super) fn icp_core(
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
    let k_min = validate_from(reference, source, &initial, p)?;
    Workspace::reused(source.len(), p.lambda, k_min, |ws| icp_core(reference, source, initial, p, ws).map(|run| run.m))
}

/// [`validate`], and a finite transform `t` to start from.
fn validate_from(
    reference: &[Point2<f64>],
    source: &[Point2<f64>],
    t: &AgentFromNeighbour,
    p: &IcpParams,
) -> Result<usize, NoEstimate> {
    let k_min = validate(reference, source, p)?;
    if !t.rotation_rad.is_finite() || !t.translation_m.iter().all(|x| x.is_finite()) {
        return Err(NoEstimate::NonFinite);
    }
    Ok(k_min)
}

/// How well `source` fits `reference` at `t` as it stands, with no iteration: the FRMSD of one
/// pairing after rejection (seed 000, eq. 3.16, Algorithm 3), the error an ICP from `t` starts
/// at. What the localization budget asks of a tracked neighbour's new set: does it still fit
/// where the estimate predicts it? About one ICP iteration's work.
///
/// Errors as [`icp`]'s for its inputs; [`NoEstimate::TooFewPoints`] when no prefix qualifies.
pub fn fit(
    reference: &[Point2<f64>],
    source: &[Point2<f64>],
    t: AgentFromNeighbour,
    p: &IcpParams,
) -> Result<f64, NoEstimate> {
    let k_min = validate_from(reference, source, &t, p)?;
    Workspace::reused(source.len(), p.lambda, k_min, |ws| {
        let e = evaluate(reference, source, &t, &mut ws.moved, &mut ws.pairing, &[], &mut ws.cur, &ws.weights, k_min);
        if e.kept == 0 {
            Err(NoEstimate::TooFewPoints)
        } else {
            Ok(e.frmsd)
        }
    })
}

/// How many source points [`fit_near_middle`] pairs: the localization budget's check of a
/// tracked neighbour's new set (one block of the pairing's lanes).
pub const FIT_POINTS: usize = LANES;

/// [`fit`] of the [`FIT_POINTS`] source points that land nearest the middle of the two UAVs at
/// `t` (ties: the lower index), or of all of them when there are no more: the FRMSD after
/// rejection of their pairing with `reference` (seed 000, eq. 3.16–3.17, Algorithm 3).
///
/// Why: the localization budget checks every tracked neighbour's new set each step, and [`fit`]
/// of the whole set was about half a short ICP (`perf` of forest-1000-icp with the budget: 18 %
/// of the floor). The middle is where both UAVs' scans overlap most, so its points are the
/// likeliest to be seen by both; eight of them are one block of the search, with no buffer and
/// no sort beyond eight numbers. The value is comparable only with the same check of a set at a
/// transform an ICP accepted (the budget keeps that as the entry's level), not with an ICP's
/// FRMSD of the whole set, which rejects a larger share and weighs its pairs up by more.
///
/// Errors: [`NoEstimate::TooFewPoints`] when either side has fewer than max(3, `min_points`)
/// points; [`NoEstimate::NonFinite`] for NaN/∞ in `t`, λ or a source point. No test of
/// degeneracy (a check needs no unique alignment); a NaN reference point is never the nearest.
pub fn fit_near_middle(
    reference: &[Point2<f64>],
    source: &[Point2<f64>],
    t: AgentFromNeighbour,
    p: &IcpParams,
) -> Result<f64, NoEstimate> {
    let k_min = (p.min_points as usize).max(3);
    if reference.len() < k_min || source.len() < k_min || FIT_POINTS < k_min {
        return Err(NoEstimate::TooFewPoints);
    }
    if !t.rotation_rad.is_finite() || !t.translation_m.iter().all(|x| x.is_finite()) || !p.lambda.is_finite() {
        return Err(NoEstimate::NonFinite);
    }
    let near = near_middle(source, &t).ok_or(NoEstimate::NonFinite)?;
    let mut d2 = nearest_d2(reference, &near.points);
    let d2 = &mut d2[..near.len];
    // Squared distances are ≥ +0 or +∞ (a NaN reference point is never the nearest), so their
    // bit patterns sort as `f64::total_cmp` does.
    d2.sort_unstable_by_key(|d| d.to_bits());
    match best_prefix(d2.iter().copied(), &frmsd_weights(near.len, p.lambda), k_min) {
        (0, _) => Err(NoEstimate::TooFewPoints),
        (_, f2) => Ok(f2.sqrt()),
    }
}

/// Up to [`FIT_POINTS`] source points moved by `t`, the nearest the middle first.
struct NearMiddle {
    /// The moved points; past `len`, copies of the last one.
    points: [Point2<f64>; FIT_POINTS],
    len: usize,
}

/// The [`FIT_POINTS`] points of `source` that `t` puts nearest the middle of the two UAVs (ties:
/// the lower index), moved; `None` when a point is not finite.
///
/// In two passes over blocks of [`MIDDLE_BLOCK`] points: every point's squared distance to the
/// middle (a loop with no branch, in vectors), then the insertion of those that beat the eighth
/// best so far into a list of distances and indices. Only the chosen points are moved again for
/// the check, by the same operations, so they are the same bits. Why: the check was 11 % of
/// forest-1000-icp's floor (`perf` of 60 s from 250 s in, 2026-12-08), nearly all of it this
/// function's one pass that moved every point and inserted whole points.
fn near_middle(source: &[Point2<f64>], t: &AgentFromNeighbour) -> Option<NearMiddle> {
    let r = rot(t.rotation_rad);
    let middle = t.translation_m / 2.0;
    // Kept sorted by (distance², index): an insertion per point that makes it.
    let mut best = [(f64::INFINITY, 0usize); FIT_POINTS];
    let mut len = 0;
    let mut d2 = [0.0; MIDDLE_BLOCK];
    for (b, block) in source.chunks(MIDDLE_BLOCK).enumerate() {
        if !middle_distances2(block, &r, &t.translation_m, &middle, &mut d2) {
            return None;
        }
        for (k, &d) in d2[..block.len()].iter().enumerate() {
            if len == FIT_POINTS && d >= best[len - 1].0 {
                continue;
            }
            let mut at = len.min(FIT_POINTS - 1);
            while at > 0 && best[at - 1].0 > d {
                best[at] = best[at - 1];
                at -= 1;
            }
            best[at] = (d, b * MIDDLE_BLOCK + k);
            len = (len + 1).min(FIT_POINTS);
        }
    }
    let moved = |k: usize| {
        let q = source.get(best[k.min(len.max(1) - 1)].1).copied().unwrap_or_else(Point2::origin);
        move_by(&r, &t.translation_m, q)
    };
    let points = std::array::from_fn(moved);
    Some(NearMiddle { points, len })
}

/// Points of `source` whose distances to the middle [`near_middle`] computes at a time.
const MIDDLE_BLOCK: usize = 64;

/// seed 000, eq. 3.12 form (tranSource): p_R = Rot(rotation_rad) · p_S + translation_m, as
/// `r · q + t` with the rotation matrix `r`. The one formula of every moved source point (the
/// ICP's [`apply`] and the check's [`near_middle`]), so both give the same bits.
#[inline(always)]
fn move_by(r: &Matrix2<f64>, t: &Vector2<f64>, q: Point2<f64>) -> Point2<f64> {
    Point2::from(r * q.coords + t)
}

/// Each point of `block` moved by (`r`, `t`) ([`move_by`]): its squared distance to `middle`,
/// into `out`; false when one is not finite.
#[multiversion::multiversion(targets("x86_64+avx512f+avx512vl", "x86_64+avx2"))]
fn middle_distances2(
    block: &[Point2<f64>],
    r: &Matrix2<f64>,
    t: &Vector2<f64>,
    middle: &Vector2<f64>,
    out: &mut [f64; MIDDLE_BLOCK],
) -> bool {
    let mut finite = true;
    for (q, d2) in block.iter().zip(out.iter_mut()) {
        let d = (move_by(r, t, *q).coords - middle).norm_squared();
        finite &= d.is_finite();
        *d2 = d;
    }
    finite
}

/// Each of `points`' squared distance to its nearest `reference` point (+∞ with none), the
/// pairing's search over one block of lanes.
#[multiversion::multiversion(targets("x86_64+avx512f+avx512vl", "x86_64+avx2"))]
fn nearest_d2(reference: &[Point2<f64>], points: &[Point2<f64>; FIT_POINTS]) -> [f64; FIT_POINTS] {
    let (qx, qy): ([f64; FIT_POINTS], [f64; FIT_POINTS]) =
        (std::array::from_fn(|l| points[l].x), std::array::from_fn(|l| points[l].y));
    let mut best = [f64::INFINITY; FIT_POINTS];
    block_nearest(reference, &qx, &qy, &mut best, &mut [0; FIT_POINTS]);
    best
}

/// Two alignments farther apart than this place the neighbour in different places [m].
pub const DISTINCT_M: f64 = 0.5;

/// ... or turn it by more than this [rad] (about 17°).
pub const DISTINCT_RAD: f64 = 0.3;

/// True when `a` and `b` are different alignments (in place or in heading): the runner-up's
/// test in [`super::grid`], and a jump's in [`super::placement::judge_long`].
pub(super) fn distinct(a: &AgentFromNeighbour, b: &AgentFromNeighbour) -> bool {
    (a.translation_m - b.translation_m).norm() > DISTINCT_M
        || wrap_angle(a.rotation_rad - b.rotation_rad).abs() > DISTINCT_RAD
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use proptest::prelude::*;
    use proptest::test_runner::RngSeed;
    use std::f64::consts::PI;

    /// SplitMix64: a tiny deterministic PRNG for the tests (the pairing's and the full grid's too).
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
    pub(in crate::localization::icp) fn scatter(
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
    pub(in crate::localization::icp) fn to_source(t: &AgentFromNeighbour, pts: &[Point2<f64>]) -> Vec<Point2<f64>> {
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

    pub(in crate::localization::icp) fn close(m: &Match, truth: &AgentFromNeighbour, tol_m: f64, tol_rad: f64) -> bool {
        (m.agent_from_neighbour.translation_m - truth.translation_m).norm() < tol_m
            && angle_err(m.agent_from_neighbour.rotation_rad, truth.rotation_rad) < tol_rad
    }

    /// The scenario of the acceptance test: 20 reference points (trees, ≥ 1.5 m apart) in a 20 m ×
    /// 20 m square around us; the neighbour at a random pose (heading in [−π, π), translation
    /// within ±5 m); its set is 14 of the reference points in its frame plus 6 trees only it sees
    /// (in the 20 m square around it, ≥ 1.5 m from every tree), all with Gaussian noise `sigma`,
    /// shuffled. So 30 % of each side is one-sided.
    pub(in crate::localization::icp) fn scenario(
        rng: &mut Rng,
        sigma: f64,
    ) -> (Vec<Point2<f64>>, Vec<Point2<f64>>, AgentFromNeighbour) {
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

    pub(in crate::localization::icp) fn square_ish() -> Vec<Point2<f64>> {
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
    fn the_fit_is_zero_at_the_truth_grows_off_it_and_is_where_the_icp_starts() {
        let p = IcpParams::default();
        let mut rng = Rng(7);
        for _ in 0..50 {
            let reference = scatter(&mut rng, 20, Vector2::zeros(), 10.0, 1.5, &[]);
            let truth = random_transform(&mut rng, 5.0);
            let source = to_source(&truth, &reference);
            assert!(fit(&reference, &source, truth, &p).expect("fit") < 1e-9);
            // 0.3 m off (points 1.5 m apart or more, so each still pairs with its own): the
            // FRMSD of the shifted pairing, which λ and the rejection keep at or above 0.3 m.
            let off = AgentFromNeighbour { translation_m: truth.translation_m + Vector2::new(0.3, 0.0), ..truth };
            let f = fit(&reference, &source, off, &p).expect("fit");
            assert!(f >= 0.3 - 1e-9, "{f}");
            // The ICP from there converges: the fit was its starting error, not its result.
            assert!(icp(&reference, &source, off, &p).expect("estimate").frmsd < f);
        }
        assert_eq!(
            fit(
                &[Point2::origin(); 2],
                &square_ish(),
                AgentFromNeighbour { rotation_rad: 0.0, translation_m: Vector2::zeros() },
                &p
            ),
            Err(NoEstimate::TooFewPoints)
        );
    }

    #[test]
    fn the_check_near_the_middle_is_the_fit_of_a_small_set_and_reads_only_its_middle() {
        let p = IcpParams::default();
        let mut rng = Rng(11);
        for n in 5..=FIT_POINTS {
            let reference = scatter(&mut rng, 20, Vector2::zeros(), 10.0, 1.5, &[]);
            let truth = random_transform(&mut rng, 5.0);
            let off = AgentFromNeighbour { translation_m: truth.translation_m + Vector2::new(0.2, -0.1), ..truth };
            let source = to_source(&truth, &reference[..n]);
            // No more points than a check pairs: the same number as the whole set's fit.
            let (a, b) = (fit_near_middle(&reference, &source, off, &p), fit(&reference, &source, off, &p));
            assert!((a.expect("check") - b.expect("fit")).abs() < 1e-12);
        }
        // Eight points near the middle, twelve far from it: the check reads only the eight. Where
        // `truth` puts the eight and not the twelve, it fits; the other way round, it does not,
        // though the whole set's fit (the twelve kept, the eight rejected) is exact.
        let truth = AgentFromNeighbour { rotation_rad: 0.4, translation_m: Vector2::new(6.0, 2.0) };
        let middle = truth.translation_m / 2.0;
        let near = scatter(&mut rng, FIT_POINTS, middle, 2.0, 0.8, &[]);
        let far = scatter(&mut rng, 12, middle + Vector2::new(15.0, 0.0), 5.0, 1.0, &near);
        let shift = |pts: &[Point2<f64>], d: Vector2<f64>| -> Vec<Point2<f64>> { pts.iter().map(|q| q + d).collect() };
        let reference = [near.clone(), far.clone()].concat();
        let (right, off) = (Vector2::zeros(), Vector2::new(0.3, 0.0));
        let source = |near_by, far_by| {
            [to_source(&truth, &shift(&far, far_by)), to_source(&truth, &shift(&near, near_by))].concat()
        };
        assert!(fit_near_middle(&reference, &source(right, off), truth, &p).expect("check") < 1e-9);
        assert!(fit_near_middle(&reference, &source(off, right), truth, &p).expect("check") >= 0.3 - 1e-9);
        assert!(fit(&reference, &source(off, right), truth, &p).expect("fit") < 1e-9);
        let source = source(right, right);
        // Its errors.
        let bad = AgentFromNeighbour { rotation_rad: f64::NAN, ..truth };
        assert_eq!(fit_near_middle(&reference, &source, bad, &p), Err(NoEstimate::NonFinite));
        let mut nan = source.clone();
        nan[3].x = f64::NAN;
        assert_eq!(fit_near_middle(&reference, &nan, truth, &p), Err(NoEstimate::NonFinite));
        assert_eq!(fit_near_middle(&reference[..4], &source, truth, &p), Err(NoEstimate::TooFewPoints));
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

        /// The points near the middle are those of a sort of every moved point by (distance² to
        /// the middle, index), bit for bit and in that order, padded with the last: sets of up
        /// to four blocks, and on a grid of whole metres, full of ties and repeated points. A NaN
        /// anywhere leaves none.
        #[test]
        fn prop_near_middle_is_the_sort_of_every_point(seed in any::<u64>(), n in 1usize..200, grid in any::<bool>()) {
            let mut rng = Rng(seed);
            let source: Vec<Point2<f64>> = (0..n)
                .map(|_| {
                    let (x, y) = (rng.range(-8.0, 8.0), rng.range(-8.0, 8.0));
                    if grid { Point2::new(x.round(), y.round()) } else { Point2::new(x, y) }
                })
                .collect();
            let t = if grid {
                AgentFromNeighbour { rotation_rad: 0.0, translation_m: Vector2::new(rng.range(-4.0, 4.0).round() * 2.0, 0.0) }
            } else {
                random_transform(&mut rng, 5.0)
            };
            let r = rot(t.rotation_rad);
            let moved: Vec<Point2<f64>> = source.iter().map(|q| Point2::from(r * q.coords + t.translation_m)).collect();
            let mut order: Vec<usize> = (0..n).collect();
            let d2 = |k: usize| (moved[k].coords - t.translation_m / 2.0).norm_squared();
            order.sort_by(|&a, &b| d2(a).total_cmp(&d2(b)).then(a.cmp(&b)));
            let near = near_middle(&source, &t).expect("finite points");
            let bits = |q: &Point2<f64>| (q.x.to_bits(), q.y.to_bits());
            prop_assert_eq!(near.len, n.min(FIT_POINTS));
            let want: Vec<_> = order[..near.len].iter().map(|&k| bits(&moved[k])).collect();
            let got: Vec<_> = near.points[..near.len].iter().map(bits).collect();
            prop_assert_eq!(got, want);
            let last = bits(&near.points[near.len - 1]);
            prop_assert!(near.points[near.len..].iter().all(|q| bits(q) == last), "padded with the last point");
            // A point that is not finite, in any block, leaves no choice.
            let mut bad = source.clone();
            bad[(seed % n as u64) as usize].y = f64::NAN;
            prop_assert!(near_middle(&bad, &t).is_none());
        }

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
}

//! Walls (seed 001 section 3.2.2, seed 004's indoor walls) are not circles: the straight face of
//! a wall fits no plausible trunk, its group fails the radius check and would vanish from the
//! agent's view. [`extract`](super::extract) therefore also returns straight [`Segment`]s (the visible faces).
//! No seed says how to find them (seed 001 chapter 1 takes obstacle types and positions as
//! input); the classical split-and-merge line extraction is used: iterative end-point fit splits
//! a group into straight runs, adjacent runs that are straight together are merged back, each
//! kept run is fitted by total least squares (principal axis) and clipped to its points' extreme
//! projections. Choices made for walls:
//! - circle first: a group whose circle [`extract_obstacles`](super::circles::extract_obstacles) accepts, and whose points lie on
//!   that circle (RMS residual ≤ [`SegmentParams::circle_max_rms_m`]), is a circle and yields no
//!   segment. Every other group is offered to the segment extractor; when that finds nothing the
//!   group stays what [`extract_obstacles`](super::circles::extract_obstacles) makes of it (its circle if accepted, else nothing);
//! - why the residual test: the algebraic circle fit of a straight wall (nearly collinear points,
//!   near-singular normal equations) often returns a plausible radius far from the points, 91 of
//!   300 noisy scans of a 4 m wall 2.9 m away, so the radius check alone turns walls into trees.
//!   [`extract_obstacles`](super::circles::extract_obstacles) is unchanged and still does; code that flies among walls should take
//!   the circles of [`extract`](super::extract);
//! - so `extract(..).circles` equals [`extract_obstacles`](super::circles::extract_obstacles) on every scan where no group yields a
//!   segment. On forests none does, since trunk arcs are too short and gaps between trunks are cut
//!   (see [`SegmentParams`]; checked on 60 dense noisy and noise-free forest scans), and a
//!   well-fitted trunk is never cut into segments;
//! - the price of that rule: a tree closer than `group_gap_m` to a wall shares the wall's group,
//!   and its points, straight runs too short to keep, are dropped with the rest of the group;
//! - the split test measures the distance to the chord *segment* (not its infinite line), so a
//!   degenerate chord (a closed ring of points, whose first and last points are neighbours) still
//!   splits;
//! - a run must be at least [`SegmentParams::min_points`] points and
//!   [`SegmentParams::min_length_m`] long, and no two consecutive points of it may be farther
//!   apart than [`SegmentParams::max_point_gap_m`] (a "wall" bridging the gap between two trunks of
//!   one group is not a wall);
//! - corners: the split point belongs to both runs it separates, and two consecutive kept
//!   segments of a group whose lines cross within [`SegmentParams::corner_snap_m`] of their
//!   facing end points are both ended at that crossing, so an L-shaped corner comes out as two
//!   segments meeting at the corner;
//! - a group that closes on itself (inside a room, every beam returned) is cut where the group
//!   starts; a wall across the cut comes out as two collinear segments.

use nalgebra::{Point2, Vector2};

use crate::world_model::Segment;

/// Thresholds of the segment extractor. No seed gives them (seed 001 takes walls as input); each
/// default is argued from the default LIDAR of SPEC section 3 (750 beams over 360°, so
/// Δθ = 2π/750 ≈ 0.0084 rad; range noise σ = 0.02 m; 12 m range).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SegmentParams {
    /// A run is split where a point is farther than this from its chord [m]. Default 0.1 m = 5σ:
    /// a point of a straight wall passes 5σ with probability 6·10⁻⁷, so noise does not cut a
    /// wall, while the corner between two legs of at least `min_length_m` = 0.7 m at 90° is
    /// 0.7/√2 ≈ 0.49 m from the chord and always splits.
    pub split_tolerance_m: f64,
    /// A run with fewer points is dropped. Default 5: two points fix a line, the other three
    /// average the noise; the direction error of the shortest kept run, σ/(L·sqrt(n/12)) =
    /// 0.02/(0.7·sqrt(5/12)) ≈ 0.044 rad (2.5°).
    pub min_points: u32,
    /// A fitted segment shorter than this is dropped [m]. Default 0.7 m: longer than a wall's end
    /// face (the hub's walls are 0.2 m thick) and than any piece of a trunk (radius ≤ 0.4 m,
    /// SPEC section 2) that passes the split test: 2·sqrt(2·0.4·0.1 − 0.1²) ≈ 0.53 m without
    /// noise, and at most 0.62 m measured over 400 single-trunk scans with and without noise.
    pub min_length_m: f64,
    /// A run is also split where two consecutive points are farther apart than this [m], so no
    /// segment bridges the gap between two obstacles of one group. Default 0.35 m: the spacing
    /// of beams along a wall at range r and incidence α is r·Δθ/cos α, at the 12 m range 0.1 m
    /// head-on and 0.35 m at α ≈ 73°; closer walls stay whole up to steeper incidence. Without
    /// this rule 40 of 600 dense-forest scans (the forest test's, 300 seeds) showed a phantom
    /// segment between two trunks; with it, none.
    pub max_point_gap_m: f64,
    /// Corner rule: two consecutive kept segments of one group whose lines cross within this
    /// distance of both facing end points are both ended at the crossing [m]. Default 0.25 m: a
    /// fitted end lies within about one beam spacing (≤ 0.1 m head-on at 12 m) plus a few σ of
    /// the true corner, and the split point may fall to the other leg, leaving a short run
    /// between the two; and the rule never closes an opening wider than 2·0.25 = 0.5 m, less than
    /// the 0.6 m diameter of the default UAV, so no passable gap is walled up.
    pub corner_snap_m: f64,
    /// A circle the circle pipeline accepts is a trunk only if the RMS distance of its group's
    /// points from it is at most this [m]; otherwise the group is offered to the segment
    /// extractor too. Default 0.06 m = 3σ: a trunk's points lie σ = 0.02 m from their fitted
    /// circle, while the algebraic fit of a straight wall (whose normal equations are nearly
    /// singular) can return a plausible radius far from the points.
    pub circle_max_rms_m: f64,
}

impl Default for SegmentParams {
    fn default() -> Self {
        SegmentParams {
            split_tolerance_m: 0.1,
            min_points: 5,
            min_length_m: 0.7,
            max_point_gap_m: 0.35,
            corner_snap_m: 0.25,
            circle_max_rms_m: 0.06,
        }
    }
}

/// The point of `seg` closest to `p` (the wall point of seed 001 eq. 24–26, p_w "the closest
/// point on the wall border"). A degenerate segment (a = b) gives a; a non-finite `p` gives a
/// non-finite point, never a panic.
pub fn closest_point(seg: &Segment, p: &Point2<f64>) -> Point2<f64> {
    let d = seg.b - seg.a;
    let len2 = d.norm_squared();
    if !(len2 > 0.0 && len2.is_finite()) {
        return seg.a;
    }
    // Projection of p on the line a + t·d, t clamped to the segment: t = (p − a)·d / |d|².
    let t = ((p - seg.a).dot(&d) / len2).clamp(0.0, 1.0);
    seg.a + d * t
}

/// Distance from `p` to `seg` [m]: |p − closest_point(seg, p)|.
pub fn distance(seg: &Segment, p: &Point2<f64>) -> f64 {
    (p - closest_point(seg, p)).norm()
}

/// Total least-squares line through `points` (the principal axis of their scatter), clipped to
/// the extreme projections of the points on it; `a` is at the end of the first point. None for
/// fewer than 2 points, non-finite input, or coincident points.
///
/// Not from a seed: orthogonal regression. With centred sums Sxx, Sxy, Syy the axis angle is
/// θ = ½·atan2(2·Sxy, Sxx − Syy), the direction of the larger eigenvalue of the scatter matrix,
/// which minimises the sum of squared perpendicular distances.
pub fn fit_segment(points: &[Point2<f64>]) -> Option<Segment> {
    let (first, last) = (points.first()?, points.last()?);
    if points.len() < 2 || points.iter().any(|p| !p.x.is_finite() || !p.y.is_finite()) {
        return None;
    }
    let n = points.len() as f64;
    let mean = points.iter().fold(Vector2::zeros(), |acc, p| acc + p.coords) / n;
    let (sxx, sxy, syy) = crate::geometry::scatter(points.iter().copied(), mean);
    if !(sxx + syy > 0.0 && (sxx + syy).is_finite()) {
        return None;
    }
    // Orthogonal regression: principal-axis angle θ = ½·atan2(2·Sxy, Sxx − Syy).
    let theta = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    let mut u = Vector2::new(theta.cos(), theta.sin());
    if u.dot(&(last - first)) < 0.0 {
        u = -u;
    }
    // Clip to the extreme projections t = u·(p − mean).
    let (t_min, t_max) = points.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
        let t = u.dot(&(p.coords - mean));
        (lo.min(t), hi.max(t))
    });
    Some(Segment { a: Point2::from(mean + u * t_min), b: Point2::from(mean + u * t_max) })
}

/// Index of the interior point of `points[i..=j]` farthest from the chord segment
/// points[i]–points[j], with its distance; None when there is no interior point.
pub(super) fn farthest_from_chord(points: &[Point2<f64>], i: usize, j: usize) -> Option<(usize, f64)> {
    let chord = Segment { a: points[i], b: points[j] };
    (i + 1..j).map(|k| (k, distance(&chord, &points[k]))).fold(None, |best, (k, d)| match best {
        Some((_, bd)) if bd >= d => best,
        _ => Some((k, d)),
    })
}

/// Iterative end-point fit: cuts `points` (finite) into straight runs, inclusive index ranges in
/// order, where each interior point is within `tol` of its run's chord. The point where a run is
/// split belongs to both halves.
pub(super) fn split_runs(points: &[Point2<f64>], tol: f64) -> Vec<(usize, usize)> {
    let mut runs = Vec::new();
    if points.len() < 2 {
        return runs;
    }
    let mut todo = vec![(0, points.len() - 1)];
    // Depth first, left half first: runs come out in index order.
    while let Some((i, j)) = todo.pop() {
        match farthest_from_chord(points, i, j) {
            Some((k, d)) if d > tol => {
                todo.push((k, j));
                todo.push((i, k));
            }
            _ => runs.push((i, j)),
        }
    }
    runs
}

/// Largest perpendicular distance of `points` from their total least-squares line (∞ when there
/// is no line).
pub(super) fn max_line_residual(points: &[Point2<f64>]) -> f64 {
    let Some(seg) = fit_segment(points) else { return f64::INFINITY };
    let Some(normal) = (seg.b - seg.a).try_normalize(0.0).map(|u| Vector2::new(-u.y, u.x)) else {
        return f64::INFINITY;
    };
    points.iter().map(|p| (p - seg.a).dot(&normal).abs()).fold(0.0, f64::max)
}

/// The merge step of split-and-merge: two adjacent runs whose union lies within `tol` of its own
/// least-squares line become one run (undoes a split caused by noise on a chord's end points).
pub(super) fn merge_runs(points: &[Point2<f64>], runs: Vec<(usize, usize)>, tol: f64) -> Vec<(usize, usize)> {
    let mut merged: Vec<(usize, usize)> = Vec::with_capacity(runs.len());
    for (i, j) in runs {
        match merged.last_mut() {
            Some(prev) if prev.1 == i && max_line_residual(&points[prev.0..=j]) <= tol => prev.1 = j,
            _ => merged.push((i, j)),
        }
    }
    merged
}

/// Cuts runs where two consecutive points are farther apart than `max_gap` (the sub-runs share
/// no point).
pub(super) fn split_at_gaps(points: &[Point2<f64>], runs: Vec<(usize, usize)>, max_gap: f64) -> Vec<(usize, usize)> {
    let mut out = Vec::with_capacity(runs.len());
    for (i, j) in runs {
        let mut start = i;
        for k in i..j {
            // A NaN max_gap cuts nothing (the comparison is false).
            if (points[k + 1] - points[k]).norm() > max_gap {
                out.push((start, k));
                start = k + 1;
            }
        }
        out.push((start, j));
    }
    out
}

/// Where the lines through `s` and `t` cross, or None for parallel lines.
pub(super) fn line_crossing(s: &Segment, t: &Segment) -> Option<Point2<f64>> {
    let (d, e) = (s.b - s.a, t.b - t.a);
    let cross = d.perp(&e);
    // Parallel (or NaN): no crossing.
    if cross.abs().partial_cmp(&(1e-12 * d.norm() * e.norm())) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    // s.a + λ·d = t.a + μ·e  ⇒  λ = ((t.a − s.a) × e) / (d × e).
    let lambda = (t.a - s.a).perp(&e) / cross;
    Some(s.a + d * lambda)
}

/// The corner rule of [`SegmentParams::corner_snap_m`]: two consecutive segments of one group
/// both end at their lines' crossing when it is within `snap` of the two facing ends.
pub(super) fn snap_corners(segments: &mut [Segment], snap: f64) {
    for k in 1..segments.len() {
        let (prev, next) = (segments[k - 1], segments[k]);
        if let Some(x) = line_crossing(&prev, &next) {
            if (x - prev.b).norm() <= snap && (x - next.a).norm() <= snap {
                segments[k - 1].b = x;
                segments[k].a = x;
            }
        }
    }
}

/// Straight wall faces in one group of points (in scan order): split-and-merge into runs, cut at
/// gaps, keep runs of at least `min_points` points, fit each by [`fit_segment`], keep segments
/// at least `min_length_m` long, then apply the corner rule. Non-finite points are ignored.
/// Does not look at circles: [`extract`](super::extract) decides which groups come here.
pub fn segments_in_group(group: &[Point2<f64>], params: &SegmentParams) -> Vec<Segment> {
    let points: Vec<Point2<f64>> = group.iter().copied().filter(|p| p.x.is_finite() && p.y.is_finite()).collect();
    let tol = params.split_tolerance_m;
    let runs = merge_runs(&points, split_runs(&points, tol), tol);
    let runs = split_at_gaps(&points, runs, params.max_point_gap_m);
    let min_points = usize::try_from(params.min_points).unwrap_or(usize::MAX);
    let mut kept: Vec<Segment> = runs
        .into_iter()
        .filter(|&(i, j)| j + 1 - i >= min_points)
        .filter_map(|(i, j)| fit_segment(&points[i..=j]))
        .filter(|s| s.length() >= params.min_length_m)
        .collect();
    snap_corners(&mut kept, params.corner_snap_m);
    kept
}

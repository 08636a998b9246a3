//! Obstacle extraction from one LIDAR scan (seed 000, section 3.2).
//!
//! Why this module exists: K21 assumes a forest whose trunks cut the plane of flight in circles.
//! The ≈750 raw scan points are reduced to ≈20 circle centres, which are (a) the agent's local
//! obstacle map fed to collision avoidance (seed 000 section 4.4), (b) the point set matched by
//! ICP for relative localization and (c) what an agent shares with its neighbours ("only lower
//! tens of coordinates", seed 000 section 3.2). The pipeline is Algorithm 2 (group consecutive
//! points by depth jump), a drop of groups with fewer than 3 points, and the linear least-squares
//! circle fit of eq. 3.13–3.15.
//!
//! Everything here is a pure function of its arguments, in the body (rotational) frame of the
//! scanning UAV (seed 000 section 2.4), in `f64`.
//!
//! Choices where seed 000 is silent (documented at the functions):
//! - a beam with a non-finite or negative range is "no return" and ends the current group;
//! - because the scanner covers 360°, the group that ends at the last beam and the group that
//!   starts at beam 0 are one obstacle when the two end points are close (Algorithm 2 scans a
//!   list, the sensor scans a ring);
//! - the normal equations are formed on centred and scaled points (the same least-squares
//!   problem, better conditioned), then shifted back.
//!
//! Walls (seed 001 section 3.2.2, seed 004's indoor walls) are not circles: the straight face of
//! a wall fits no plausible trunk, its group fails the radius check and would vanish from the
//! agent's view. [`extract`] therefore also returns straight [`Segment`]s (the visible faces).
//! No seed says how to find them (seed 001 chapter 1 takes obstacle types and positions as
//! input); the classical split-and-merge line extraction is used: iterative end-point fit splits
//! a group into straight runs, adjacent runs that are straight together are merged back, each
//! kept run is fitted by total least squares (principal axis) and clipped to its points' extreme
//! projections. Choices made for walls:
//! - circle first: a group whose circle [`extract_obstacles`] accepts, and whose points lie on
//!   that circle (RMS residual ≤ [`SegmentParams::circle_max_rms_m`]), is a circle and yields no
//!   segment. Every other group is offered to the segment extractor; when that finds nothing the
//!   group stays what [`extract_obstacles`] makes of it (its circle if accepted, else nothing);
//! - why the residual test: the algebraic circle fit of a straight wall (nearly collinear points,
//!   near-singular normal equations) often returns a plausible radius far from the points, 91 of
//!   300 noisy scans of a 4 m wall 2.9 m away, so the radius check alone turns walls into trees.
//!   [`extract_obstacles`] is unchanged and still does; code that flies among walls should take
//!   the circles of [`extract`];
//! - so `extract(..).circles` equals [`extract_obstacles`] on every scan where no group yields a
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

use nalgebra::{Matrix3, Point2, Vector2, Vector3};
use swarm_config::PerceptionParams;
use swarm_wire::Scan;

use crate::world_model::{Circle, Segment};

/// Smallest accepted ratio of the smallest to the largest eigenvalue of the (centred, scaled)
/// normal matrix AᵀA; below it the fit is ill-conditioned (e.g. collinear points) and refused.
const MIN_RCOND: f64 = 1e-10;

/// The point hit by beam `i`, or `None` when the beam has no return.
fn beam_point(angle_min: f64, angle_increment: f64, i: usize, range: f32) -> Option<Point2<f64>> {
    let r = f64::from(range);
    if !r.is_finite() || r < 0.0 {
        return None;
    }
    // Scan convention (swarm-wire `Scan`): beam i points at angle_min + i·angle_increment.
    let theta = angle_min + i as f64 * angle_increment;
    // Polar to Cartesian in the body frame: p = r·(cos θ, sin θ).
    Some(Point2::new(r * theta.cos(), r * theta.sin()))
}

/// The point of every beam of the scan, body frame, in beam order (`None`: no return).
fn beam_points(scan: &Scan) -> Vec<Option<Point2<f64>>> {
    let (angle_min, angle_increment) = (f64::from(scan.angle_min), f64::from(scan.angle_increment));
    scan.ranges_m.iter().enumerate().map(|(i, &r)| beam_point(angle_min, angle_increment, i, r)).collect()
}

/// Every returned point of the scan, body frame, in beam order.
pub fn scan_points(scan: &Scan) -> Vec<Point2<f64>> {
    beam_points(scan).into_iter().flatten().collect()
}

/// True when `n` beams spaced by `angle_increment` cover a full turn (to within half a beam), so
/// that the last beam and beam 0 are neighbours on the ring.
fn covers_full_turn(n: usize, angle_increment: f64) -> bool {
    let step = angle_increment.abs();
    step.is_finite() && step > 0.0 && n as f64 * step >= std::f64::consts::TAU - 0.5 * step
}

/// Groups consecutive beams of a scan: a new group starts where the distance between consecutive returned points exceeds gap_m, or where a beam has no return (non-finite range). Because the scan covers 360°, the last group and the first group are joined when they are contiguous across beam 0 (last beam and beam 0 both returned and close).
///
/// Details (seed 000, Algorithm 2): a point stays in the current group iff its distance to the
/// previous point is `< gap_m` (the `until dist < 1` test of Algorithm 2; a distance of exactly
/// `gap_m` therefore starts a new group, and a NaN `gap_m` makes every point its own group).
/// A beam with a non-finite or negative range has no return. Points are in beam order.
/// The wrap-around join is done only when the beams cover a full turn (`n·|angle_increment| ≥
/// 2π − |angle_increment|/2`); the joined group replaces the last group and holds the last
/// group's points followed by the first group's, so its points stay contiguous along the ring.
/// A ring where every beam returned and every step is short is one group, never duplicated.
pub fn group_scan(scan: &Scan, gap_m: f64) -> Vec<Vec<Point2<f64>>> {
    group_beams(&beam_points(scan), f64::from(scan.angle_increment), gap_m)
}

/// [`group_scan`] on the scan's beam points (see [`beam_points`]).
fn group_beams(beams: &[Option<Point2<f64>>], angle_increment: f64, gap_m: f64) -> Vec<Vec<Point2<f64>>> {
    let n = beams.len();

    let mut groups: Vec<Vec<Point2<f64>>> = Vec::new();
    let mut current: Vec<Point2<f64>> = Vec::new();
    // Does groups[0] start at beam 0?
    let mut first_starts_at_beam_zero = false;

    for (i, &beam) in beams.iter().enumerate() {
        match beam {
            None => {
                // No return: the obstacle (if any) ends here.
                if !current.is_empty() {
                    groups.push(std::mem::take(&mut current));
                }
            }
            Some(p) => {
                if let Some(prev) = current.last() {
                    // seed 000, Algorithm 2: dist ← distance(p, next point); same group iff dist < 1.
                    let joins = (p - prev).norm() < gap_m;
                    if !joins {
                        groups.push(std::mem::take(&mut current));
                    }
                }
                if i == 0 {
                    first_starts_at_beam_zero = true;
                }
                current.push(p);
            }
        }
    }
    // The open group, if any, ends at the last beam.
    let last_ends_at_last_beam = !current.is_empty();
    if last_ends_at_last_beam {
        groups.push(current);
    }

    if first_starts_at_beam_zero && last_ends_at_last_beam && groups.len() >= 2 && covers_full_turn(n, angle_increment)
    {
        let close = match (groups.first().and_then(|g| g.first()), groups.last().and_then(|g| g.last())) {
            // seed 000, Algorithm 2 distance test, applied across beam 0 of the 360° ring.
            (Some(first), Some(last)) => (first - last).norm() < gap_m,
            _ => false,
        };
        if close {
            let head = groups.remove(0);
            if let Some(tail) = groups.last_mut() {
                tail.extend(head);
            }
        }
    }
    groups
}

/// Linear least-squares circle fit (eq. 3.13–3.15): solve AᵀA p = Aᵀb for p=(x0,y0,c), r0=sqrt(c+x0²+y0²). None for fewer than 3 points, a singular/ill-conditioned system (e.g. collinear points), non-finite input or a negative radicand.
///
/// Numerics: the points are first centred on their mean m and divided by their RMS distance s
/// from it (u = (x − m)/s). Eq. 3.13 is invariant under this change of variables (a circle maps
/// to a circle), so the same algebraic least-squares problem is solved, only far better
/// conditioned for a small trunk seen 10 m away. The fitted centre and radius are mapped back
/// (x0 = m + s·u0, r0 = s·ru). The 3×3 normal matrix is refused when its smallest eigenvalue is
/// below 1e-10 times its largest, then solved by Cholesky.
///
/// Known property of this algebraic (Kåsa) fit: with noisy points on a short arc (≲ 90°) the
/// radius is biased small and the centre pulled towards the points. A LIDAR sees about 170° of a
/// trunk, where the bias is negligible (see the noisy-arc tests).
pub fn fit_circle(points: &[Point2<f64>]) -> Option<Circle> {
    if points.len() < 3 {
        // seed 000 section 3.2: with fewer than 3 points the 3 unknowns are not unique.
        return None;
    }
    if points.iter().any(|p| !p.x.is_finite() || !p.y.is_finite()) {
        return None;
    }
    let n = points.len() as f64;
    let mean = points.iter().fold(Vector2::zeros(), |acc, p| acc + p.coords) / n;
    let scale = (points.iter().map(|p| (p.coords - mean).norm_squared()).sum::<f64>() / n).sqrt();
    if !(scale.is_finite() && scale > 0.0) {
        // All points coincide (or overflow).
        return None;
    }

    let mut ata = Matrix3::<f64>::zeros();
    let mut atb = Vector3::<f64>::zeros();
    for p in points {
        let u = (p.coords - mean) / scale;
        // seed 000, eq. 3.13: 2x·x0 + 2y·y0 + (r0² − x0² − y0²) = x² + y²; one row of A and b.
        let row = Vector3::new(2.0 * u.x, 2.0 * u.y, 1.0);
        let b = u.norm_squared();
        // seed 000, eq. 3.14: accumulate AᵀA and Aᵀb.
        ata += row * row.transpose();
        atb += row * b;
    }

    let eig = ata.symmetric_eigenvalues();
    let max_eig = eig.iter().fold(0.0_f64, |m, e| m.max(e.abs()));
    let min_eig = eig.iter().fold(f64::INFINITY, |m, e| m.min(*e));
    if !(max_eig.is_finite() && max_eig > 0.0 && min_eig > MIN_RCOND * max_eig) {
        return None;
    }
    // seed 000, eq. 3.15: p = (AᵀA)⁻¹Aᵀb, via Cholesky (AᵀA is symmetric positive definite here).
    let sol = ata.cholesky()?.solve(&atb);
    let (u0x, u0y, c) = (sol[0], sol[1], sol[2]);
    // seed 000, eq. 3.13: c = r0² − x0² − y0²  ⇒  r0² = c + x0² + y0².
    let r2 = c + u0x * u0x + u0y * u0y;
    if r2.is_nan() || r2 < 0.0 {
        return None;
    }
    // Undo the centring and scaling: x0 = m + s·u0, r0 = s·ru.
    let center = Point2::from(mean + Vector2::new(u0x, u0y) * scale);
    let radius = r2.sqrt() * scale;
    if !(center.x.is_finite() && center.y.is_finite() && radius.is_finite()) {
        return None;
    }
    Some(Circle { center, radius })
}

/// Full pipeline: group, drop groups with fewer than params.min_points points, fit, reject radii outside params.radius_range_m. Returns obstacle circles in the body frame.
///
/// The radius range is inclusive at both ends. Groups whose fit fails ([`fit_circle`] returns
/// `None`) are dropped. Circles are returned in the order of their groups (see [`group_scan`]).
/// Telling a neighbouring UAV apart from a tree (`params.neighbour_match_m`) needs the
/// neighbours' positions and is not done here.
pub fn extract_obstacles(scan: &Scan, params: &PerceptionParams) -> Vec<Circle> {
    group_scan(scan, params.group_gap_m).iter().filter_map(|g| accepted_circle(g, params)).collect()
}

/// The circle of one group, if the pipeline of [`extract_obstacles`] accepts it as a trunk.
fn accepted_circle(group: &[Point2<f64>], params: &PerceptionParams) -> Option<Circle> {
    let min_points = usize::try_from(params.min_points).unwrap_or(usize::MAX);
    let [r_min, r_max] = params.radius_range_m;
    // seed 000 section 3.2: groups of fewer than 3 points are filtered out before fitting.
    if group.len() < min_points {
        return None;
    }
    // SPEC section 4.2: reject fits with an implausible radius.
    fit_circle(group).filter(|c| c.radius >= r_min && c.radius <= r_max)
}

/// What one scan shows: trunks as circles, walls as segments (see [`extract`]), and every point
/// the scan returned.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Extracted {
    /// Circular obstacles: those of [`extract_obstacles`] minus any whose group is a wall.
    pub circles: Vec<Circle>,
    /// Straight wall faces, from the groups that are not trunks (see [`extract`]).
    pub segments: Vec<Segment>,
    /// Each beam's point, body frame (`None`: no return); kept as the scan gave them, since
    /// only the map-building controllers want them (see [`Extracted::points`]).
    pub(crate) beams: Vec<Option<Point2<f64>>>,
}

impl Extracted {
    /// Every returned point, body frame, in beam order (as [`scan_points`]).
    pub fn points(&self) -> impl Iterator<Item = &Point2<f64>> {
        self.beams.iter().flatten()
    }
}

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

/// Most points [`segment_points`] puts on one segment (bounds the output for a tiny spacing).
const MAX_POINTS_PER_SEGMENT: f64 = 1000.0;

/// A wall as points, for controllers that take point obstacles only (K21's avoidance): each
/// segment contributes both end points and points between them, equally spaced at most
/// `spacing_m` apart (n = ⌈length/spacing_m⌉ intervals, at most 1000). A zero-length segment
/// gives one point; a non-finite or non-positive `spacing_m` gives the two end points; a segment
/// with a non-finite end is skipped. Segments in order, each from a to b.
pub fn segment_points(segments: &[Segment], spacing_m: f64) -> Vec<Point2<f64>> {
    let mut out = Vec::new();
    for seg in segments {
        let len = seg.length();
        if !len.is_finite() {
            continue;
        }
        let intervals = if len == 0.0 {
            0
        } else if spacing_m.is_finite() && spacing_m > 0.0 {
            (len / spacing_m).ceil().clamp(1.0, MAX_POINTS_PER_SEGMENT) as usize
        } else {
            1
        };
        if intervals == 0 {
            out.push(seg.a);
            continue;
        }
        let step = (seg.b - seg.a) / intervals as f64;
        out.extend((0..=intervals).map(|i| seg.a + step * i as f64));
    }
    out
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
fn farthest_from_chord(points: &[Point2<f64>], i: usize, j: usize) -> Option<(usize, f64)> {
    let chord = Segment { a: points[i], b: points[j] };
    (i + 1..j).map(|k| (k, distance(&chord, &points[k]))).fold(None, |best, (k, d)| match best {
        Some((_, bd)) if bd >= d => best,
        _ => Some((k, d)),
    })
}

/// Iterative end-point fit: cuts `points` (finite) into straight runs, inclusive index ranges in
/// order, where each interior point is within `tol` of its run's chord. The point where a run is
/// split belongs to both halves.
fn split_runs(points: &[Point2<f64>], tol: f64) -> Vec<(usize, usize)> {
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
fn max_line_residual(points: &[Point2<f64>]) -> f64 {
    let Some(seg) = fit_segment(points) else { return f64::INFINITY };
    let Some(normal) = (seg.b - seg.a).try_normalize(0.0).map(|u| Vector2::new(-u.y, u.x)) else {
        return f64::INFINITY;
    };
    points.iter().map(|p| (p - seg.a).dot(&normal).abs()).fold(0.0, f64::max)
}

/// The merge step of split-and-merge: two adjacent runs whose union lies within `tol` of its own
/// least-squares line become one run (undoes a split caused by noise on a chord's end points).
fn merge_runs(points: &[Point2<f64>], runs: Vec<(usize, usize)>, tol: f64) -> Vec<(usize, usize)> {
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
fn split_at_gaps(points: &[Point2<f64>], runs: Vec<(usize, usize)>, max_gap: f64) -> Vec<(usize, usize)> {
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
fn line_crossing(s: &Segment, t: &Segment) -> Option<Point2<f64>> {
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
fn snap_corners(segments: &mut [Segment], snap: f64) {
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
/// Does not look at circles: [`extract`] decides which groups come here.
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

/// Circles and wall segments of one scan, body frame, both lists in group order. Each group of
/// [`group_scan`] becomes the circle [`extract_obstacles`] makes of it when that pipeline
/// accepts it and the points' RMS distance from it is at most `params.circle_max_rms_m`;
/// otherwise it is offered to [`segments_in_group`], and if that finds no segment the group gives
/// what [`extract_obstacles`] gives (its circle, if accepted). So `circles` differs from
/// `extract_obstacles(scan, perception)` only by circles whose groups yielded segments.
pub fn extract(scan: &Scan, perception: &PerceptionParams, params: &SegmentParams) -> Extracted {
    let mut out = Extracted::default();
    let beams = beam_points(scan);
    for group in group_beams(&beams, f64::from(scan.angle_increment), perception.group_gap_m) {
        let circle = accepted_circle(&group, perception);
        if let Some(c) = circle.filter(|c| rms_circle_residual(&group, c) <= params.circle_max_rms_m) {
            out.circles.push(c);
            continue;
        }
        let segments = segments_in_group(&group, params);
        if segments.is_empty() {
            // Nothing straight: the group is whatever extract_obstacles makes of it.
            out.circles.extend(circle);
        } else {
            out.segments.extend(segments);
        }
    }
    out.beams = beams;
    out
}

/// Root mean square of the geometric residuals |‖p − c‖ − r| of `points` from `circle` [m].
fn rms_circle_residual(points: &[Point2<f64>], circle: &Circle) -> f64 {
    let n = points.len() as f64;
    let sum: f64 = points.iter().map(|p| ((p - circle.center).norm() - circle.radius).powi(2)).sum();
    (sum / n).sqrt()
}

/// The segments of [`extract`] alone.
pub fn extract_segments(scan: &Scan, perception: &PerceptionParams, params: &SegmentParams) -> Vec<Segment> {
    extract(scan, perception, params).segments
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use std::f64::consts::{PI, TAU};

    /// Deterministic Gaussian noise: a 64-bit LCG (Knuth's MMIX constants) feeding Box–Muller.
    struct Noise {
        state: u64,
    }

    impl Noise {
        fn new(seed: u64) -> Self {
            Noise { state: seed.wrapping_mul(0x9E37_79B9_7F4A_7C15).wrapping_add(1) }
        }
        /// Uniform in (0, 1).
        fn uniform(&mut self) -> f64 {
            self.state = self.state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((self.state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        }
        /// Standard normal (Box–Muller).
        fn gauss(&mut self) -> f64 {
            let u1 = self.uniform();
            let u2 = self.uniform();
            (-2.0 * u1.ln()).sqrt() * (TAU * u2).cos()
        }
    }

    fn scan_from(angle_min: f64, angle_increment: f64, ranges: Vec<f32>) -> Scan {
        Scan {
            tick: 0,
            t_secs: 0.0,
            angle_min: angle_min as f32,
            angle_increment: angle_increment as f32,
            max_range_m: 12.0,
            ranges_m: ranges,
        }
    }

    /// Range along the ray at `theta` to the nearest of `circles` (cx, cy, r), ray–circle
    /// intersection: |t·d − c|² = r²  ⇒  t = d·c − sqrt((d·c)² − |c|² + r²).
    fn ray_range(theta: f64, circles: &[(f64, f64, f64)], max_range: f64) -> f64 {
        let d = Vector2::new(theta.cos(), theta.sin());
        let mut best = f64::INFINITY;
        for &(cx, cy, r) in circles {
            let c = Vector2::new(cx, cy);
            let dc = d.dot(&c);
            let disc = dc * dc - c.norm_squared() + r * r;
            if disc < 0.0 {
                continue;
            }
            let t = dc - disc.sqrt();
            if t > 0.0 && t < best {
                best = t;
            }
        }
        if best <= max_range {
            best
        } else {
            f64::INFINITY
        }
    }

    /// A 360° scan of `beams` beams starting at `angle_min`, of the given circles, with optional
    /// Gaussian range noise.
    fn synthetic_scan(beams: usize, angle_min: f64, circles: &[(f64, f64, f64)], noise: Option<(f64, u64)>) -> Scan {
        world_scan(beams, angle_min, circles, &[], noise)
    }

    fn arc(cx: f64, cy: f64, r: f64, from: f64, to: f64, n: usize) -> Vec<Point2<f64>> {
        (0..n)
            .map(|i| {
                let a = from + (to - from) * i as f64 / (n - 1) as f64;
                Point2::new(cx + r * a.cos(), cy + r * a.sin())
            })
            .collect()
    }

    #[test]
    fn scan_points_are_the_returned_beams_in_order() {
        // Four beams from 0 by 90°: 2 m ahead, no return, 1 m behind, a negative range.
        let scan = scan_from(0.0, TAU / 4.0, vec![2.0, f32::INFINITY, 1.0, -1.0]);
        let pts = scan_points(&scan);
        assert_eq!(pts.len(), 2);
        assert!(
            (pts[0] - Point2::new(2.0, 0.0)).norm() < 1e-9 && (pts[1] - Point2::new(-1.0, 0.0)).norm() < 1e-6,
            "{pts:?}"
        );
    }

    #[test]
    fn fit_circle_exact_full_circle() {
        let pts = arc(3.2, -1.7, 0.45, 0.0, TAU * 11.0 / 12.0, 12);
        let c = fit_circle(&pts).unwrap();
        assert!((c.center.x - 3.2).abs() < 1e-9, "{c:?}");
        assert!((c.center.y + 1.7).abs() < 1e-9, "{c:?}");
        assert!((c.radius - 0.45).abs() < 1e-9, "{c:?}");
    }

    #[test]
    fn fit_circle_exact_three_points() {
        // Three points determine the circle: (0,0), (2,0), (0,2) → centre (1,1), r = √2.
        let pts = [Point2::new(0.0, 0.0), Point2::new(2.0, 0.0), Point2::new(0.0, 2.0)];
        let c = fit_circle(&pts).unwrap();
        assert!((c.center - Point2::new(1.0, 1.0)).norm() < 1e-12, "{c:?}");
        assert!((c.radius - 2f64.sqrt()).abs() < 1e-12, "{c:?}");
    }

    #[test]
    fn fit_circle_exact_partial_arc_40deg() {
        // 40° of a 0.3 m trunk 5 m ahead, the side facing the sensor.
        let pts = arc(5.0, 2.0, 0.3, PI - 20f64.to_radians(), PI + 20f64.to_radians(), 10);
        let c = fit_circle(&pts).unwrap();
        assert!((c.center - Point2::new(5.0, 2.0)).norm() < 1e-9, "{c:?}");
        assert!((c.radius - 0.3).abs() < 1e-9, "{c:?}");
    }

    #[test]
    fn fit_circle_exact_small_arc_far_away() {
        // Conditioning: a 40° arc of a 0.1 m circle 1 km from the origin.
        let pts = arc(800.0, -600.0, 0.1, 1.0, 1.0 + 40f64.to_radians(), 8);
        let c = fit_circle(&pts).unwrap();
        assert!((c.center - Point2::new(800.0, -600.0)).norm() < 1e-9, "{c:?}");
        assert!((c.radius - 0.1).abs() < 1e-9, "{c:?}");
    }

    #[test]
    fn fit_circle_noisy_lidar_arc() {
        // A 0.3 m trunk 5 m ahead seen by a 750-beam 360° LIDAR with σ = 0.02 m range noise:
        // about 14 beams hit it. Repeat over 50 noise seeds.
        let (cx, cy, r) = (5.0, 0.0, 0.3);
        let mut worst: f64 = 0.0;
        let mut sum = 0.0;
        let trials = 50;
        for seed in 0..trials {
            let scan = synthetic_scan(750, -PI, &[(cx, cy, r)], Some((0.02, seed)));
            let groups = group_scan(&scan, 1.0);
            assert_eq!(groups.len(), 1, "seed {seed}");
            assert!(groups[0].len() >= 12, "seed {seed}: {} points", groups[0].len());
            let c = fit_circle(&groups[0]).unwrap();
            let err = (c.center - Point2::new(cx, cy)).norm();
            worst = worst.max(err);
            sum += err;
            assert!((c.radius - r).abs() < 0.1, "seed {seed}: {c:?}");
        }
        let mean = sum / trials as f64;
        assert!(mean < 0.03, "mean centre error {mean}");
        assert!(worst < 0.06, "worst centre error {worst}");
    }

    #[test]
    fn fit_circle_noisy_half_circle() {
        // The side of a 0.3 m trunk 5 m away that faces the sensor (180°), 30 points with
        // isotropic σ = 0.02 m noise, over 50 seeds.
        let mut worst: f64 = 0.0;
        for seed in 0..50 {
            let mut rng = Noise::new(1000 + seed);
            let pts: Vec<_> = arc(5.0, 0.0, 0.3, 0.5 * PI, 1.5 * PI, 30)
                .into_iter()
                .map(|p| Point2::new(p.x + 0.02 * rng.gauss(), p.y + 0.02 * rng.gauss()))
                .collect();
            let c = fit_circle(&pts).unwrap();
            worst = worst.max((c.center - Point2::new(5.0, 0.0)).norm());
            assert!((c.radius - 0.3).abs() < 0.05, "seed {seed}: {c:?}");
        }
        assert!(worst < 0.05, "worst centre error {worst}");
    }

    #[test]
    fn fit_circle_too_few_points() {
        assert_eq!(fit_circle(&[]), None);
        assert_eq!(fit_circle(&[Point2::new(1.0, 1.0)]), None);
        assert_eq!(fit_circle(&[Point2::new(1.0, 1.0), Point2::new(2.0, 1.5)]), None);
    }

    #[test]
    fn fit_circle_collinear_is_none() {
        let pts: Vec<_> = (0..10).map(|i| Point2::new(0.1 * i as f64, 0.3 * i as f64 + 0.7)).collect();
        assert_eq!(fit_circle(&pts), None);
        let horizontal: Vec<_> = (0..5).map(|i| Point2::new(i as f64, 2.0)).collect();
        assert_eq!(fit_circle(&horizontal), None);
    }

    #[test]
    fn fit_circle_coincident_points_is_none() {
        let pts = [Point2::new(1.0, 2.0); 5];
        assert_eq!(fit_circle(&pts), None);
    }

    #[test]
    fn fit_circle_non_finite_is_none() {
        let mut pts = arc(0.0, 0.0, 1.0, 0.0, 3.0, 6);
        pts[2].x = f64::NAN;
        assert_eq!(fit_circle(&pts), None);
        let mut pts = arc(0.0, 0.0, 1.0, 0.0, 3.0, 6);
        pts[4].y = f64::INFINITY;
        assert_eq!(fit_circle(&pts), None);
    }

    #[test]
    fn group_scan_depth_jump_splits() {
        // Full ring of 360 beams, all returned: 2 m for beams 0..180, 5 m for 180..360. Jumps of
        // 3 m at beam 180 and across beam 0 → two groups, no wrap join.
        let ranges: Vec<f32> = (0..360).map(|i| if i < 180 { 2.0 } else { 5.0 }).collect();
        let scan = scan_from(0.0, TAU / 360.0, ranges);
        let groups = group_scan(&scan, 1.0);
        assert_eq!(groups.len(), 2);
        assert_eq!(groups[0].len(), 180);
        assert_eq!(groups[1].len(), 180);
    }

    #[test]
    fn group_scan_two_trees_give_two_groups() {
        // Trees at (4, 0) and (0, 4), nothing else: one group per tree.
        let scan = synthetic_scan(750, -PI, &[(4.0, 0.0, 0.3), (0.0, 4.0, 0.3)], None);
        let hits = scan.ranges_m.iter().filter(|r| r.is_finite()).count();
        let groups = group_scan(&scan, 1.0);
        assert_eq!(groups.len(), 2);
        assert_eq!(groups.iter().map(Vec::len).sum::<usize>(), hits);
        for g in &groups {
            let c = fit_circle(g).unwrap();
            let near_a = (c.center - Point2::new(4.0, 0.0)).norm() < 1e-3;
            let near_b = (c.center - Point2::new(0.0, 4.0)).norm() < 1e-3;
            assert!(near_a || near_b, "{c:?}");
        }
    }

    #[test]
    fn group_scan_adjacent_trees_at_different_depth_split() {
        // Two trees side by side in angle but 3 m apart in depth: the front one at (3, 0.25),
        // the back one at (6, -0.6); their returns touch in beam order but jump in depth.
        let scan = synthetic_scan(750, -PI, &[(3.0, 0.25, 0.3), (6.0, -0.6, 0.3)], None);
        let groups = group_scan(&scan, 1.0);
        assert_eq!(groups.len(), 2);
    }

    #[test]
    fn group_scan_no_return_beam_splits_group() {
        // 10 beams 1° apart, a flat-ish surface at 3 m, beam 5 has no return.
        let mut ranges = vec![3.0_f32; 10];
        ranges[5] = f32::INFINITY;
        let scan = scan_from(0.0, 1f64.to_radians(), ranges.clone());
        let groups = group_scan(&scan, 1.0);
        assert_eq!(groups.iter().map(Vec::len).collect::<Vec<_>>(), vec![5, 4]);
        // NaN and negative ranges are no returns as well.
        ranges[5] = f32::NAN;
        ranges[7] = -1.0;
        let groups = group_scan(&scan_from(0.0, 1f64.to_radians(), ranges), 1.0);
        assert_eq!(groups.iter().map(Vec::len).collect::<Vec<_>>(), vec![5, 1, 2]);
    }

    #[test]
    fn group_scan_wraps_across_beam_zero() {
        // A tree straight ahead (4, 0) with beam 0 at angle 0: its returns sit at the end and
        // the start of the scan, and must come out as one group.
        let scan = synthetic_scan(750, 0.0, &[(4.0, 0.0, 0.3)], None);
        assert!(scan.ranges_m[0].is_finite());
        assert!(scan.ranges_m[749].is_finite());
        let hits = scan.ranges_m.iter().filter(|r| r.is_finite()).count();
        let groups = group_scan(&scan, 1.0);
        assert_eq!(groups.len(), 1);
        assert_eq!(groups[0].len(), hits);
        // Contiguous along the ring: every step inside the group is short.
        for w in groups[0].windows(2) {
            assert!((w[1] - w[0]).norm() < 0.1);
        }
        let c = fit_circle(&groups[0]).unwrap();
        assert!((c.center - Point2::new(4.0, 0.0)).norm() < 1e-3, "{c:?}");
        // With another tree elsewhere the join still happens and the other group stays.
        let scan = synthetic_scan(750, 0.0, &[(4.0, 0.0, 0.3), (-3.0, 2.0, 0.3)], None);
        let groups = group_scan(&scan, 1.0);
        assert_eq!(groups.len(), 2);
    }

    #[test]
    fn group_scan_no_wrap_for_partial_scan() {
        // Same ranges at the two ends, but the beams cover only 20°: the ends are not adjacent.
        let mut ranges = vec![f32::INFINITY; 21];
        for i in [0, 1, 2, 18, 19, 20] {
            ranges[i] = 0.5;
        }
        let scan = scan_from(0.0, 1f64.to_radians(), ranges);
        let groups = group_scan(&scan, 1.0);
        assert_eq!(groups.len(), 2);
    }

    #[test]
    fn group_scan_full_ring_is_one_group() {
        // Inside a ring: every beam returns at 2 m; one group holding every point once.
        let scan = scan_from(-PI, TAU / 100.0, vec![2.0; 100]);
        let groups = group_scan(&scan, 1.0);
        assert_eq!(groups.len(), 1);
        assert_eq!(groups[0].len(), 100);
    }

    #[test]
    fn group_scan_empty_and_blind() {
        assert!(group_scan(&scan_from(0.0, 0.01, vec![]), 1.0).is_empty());
        assert!(group_scan(&scan_from(0.0, 0.01, vec![f32::INFINITY; 50]), 1.0).is_empty());
    }

    #[test]
    fn extract_obstacles_finds_two_circles() {
        let trees = [(4.0, 1.0, 0.3), (-2.0, -5.0, 0.4)];
        let params = PerceptionParams::default();
        for noise in [None, Some((0.02, 11)), Some((0.02, 12))] {
            let scan = synthetic_scan(750, -PI, &trees, noise);
            let found = extract_obstacles(&scan, &params);
            assert_eq!(found.len(), 2, "{noise:?}: {found:?}");
            for &(x, y, r) in &trees {
                let hit = found.iter().find(|c| (c.center - Point2::new(x, y)).norm() < 0.05);
                let hit = hit.unwrap_or_else(|| panic!("{noise:?}: no circle near ({x}, {y}) in {found:?}"));
                assert!((hit.radius - r).abs() < 0.1, "{hit:?}");
            }
        }
    }

    #[test]
    fn extract_obstacles_drops_two_point_group() {
        // A tree at (4, 0) plus two isolated returns (a thin pole hit by two beams) behind.
        let mut scan = synthetic_scan(360, -PI, &[(4.0, 0.0, 0.3)], None);
        scan.ranges_m[10] = 6.0;
        scan.ranges_m[11] = 6.0;
        let params = PerceptionParams::default();
        assert_eq!(group_scan(&scan, params.group_gap_m).len(), 2);
        let found = extract_obstacles(&scan, &params);
        assert_eq!(found.len(), 1, "{found:?}");
        assert!((found[0].center - Point2::new(4.0, 0.0)).norm() < 1e-3);
    }

    #[test]
    fn extract_obstacles_respects_min_points() {
        let scan = synthetic_scan(750, -PI, &[(4.0, 0.0, 0.3)], None);
        let hits = scan.ranges_m.iter().filter(|r| r.is_finite()).count() as u32;
        let exact = PerceptionParams { min_points: hits, ..PerceptionParams::default() };
        assert_eq!(extract_obstacles(&scan, &exact).len(), 1);
        let one_more = PerceptionParams { min_points: hits + 1, ..PerceptionParams::default() };
        assert!(extract_obstacles(&scan, &one_more).is_empty());
    }

    #[test]
    fn extract_obstacles_rejects_implausible_radius() {
        // A 3 m "trunk" (radius above the default 1.5 m) and a 0.3 m one.
        let scan = synthetic_scan(750, -PI, &[(8.0, 0.0, 3.0), (0.0, -4.0, 0.3)], None);
        let params = PerceptionParams::default();
        let found = extract_obstacles(&scan, &params);
        assert_eq!(found.len(), 1, "{found:?}");
        assert!((found[0].center - Point2::new(0.0, -4.0)).norm() < 1e-3);
        // Widening the range accepts it.
        let wide = PerceptionParams { radius_range_m: [0.03, 5.0], ..PerceptionParams::default() };
        assert_eq!(extract_obstacles(&scan, &wide).len(), 2);
    }

    // ----- Walls: segment extraction -----

    /// A wall as the hub builds it (physics-hub `World`): the rectangle of `thickness` around the
    /// centre line (x1, y1)–(x2, y2), as its four faces.
    fn wall_faces(x1: f64, y1: f64, x2: f64, y2: f64, thickness: f64) -> Vec<Segment> {
        let (p, q) = (Point2::new(x1, y1), Point2::new(x2, y2));
        let u = (q - p).normalize();
        let n = Vector2::new(-u.y, u.x) * (0.5 * thickness);
        let c = [p + n, q + n, q - n, p - n];
        (0..4).map(|i| Segment { a: c[i], b: c[(i + 1) % 4] }).collect()
    }

    /// Range along the ray at `theta` to the nearest face. Ray t·d, face a + s·e (e = b − a):
    /// t·d − s·e = a  ⇒  t = (a × e)/(d × e), s = (a × d)/(d × e); a hit iff t > 0, 0 ≤ s ≤ 1.
    fn ray_range_faces(theta: f64, faces: &[Segment]) -> f64 {
        let d = Vector2::new(theta.cos(), theta.sin());
        let mut best = f64::INFINITY;
        for f in faces {
            let (a, e) = (f.a.coords, f.b - f.a);
            let den = d.perp(&e);
            if den.abs() < 1e-15 {
                continue;
            }
            let (t, s) = (a.perp(&e) / den, a.perp(&d) / den);
            if t > 0.0 && (0.0..=1.0).contains(&s) && t < best {
                best = t;
            }
        }
        best
    }

    /// Like `synthetic_scan`, with wall faces as well as circles (12 m range).
    fn world_scan(
        beams: usize,
        angle_min: f64,
        circles: &[(f64, f64, f64)],
        faces: &[Segment],
        noise: Option<(f64, u64)>,
    ) -> Scan {
        let inc = TAU / beams as f64;
        let mut rng = noise.map(|(sigma, seed)| (sigma, Noise::new(seed)));
        let ranges = (0..beams)
            .map(|i| {
                let theta = angle_min + i as f64 * inc;
                let r = ray_range(theta, circles, 12.0).min(ray_range_faces(theta, faces));
                let r = if r <= 12.0 { r } else { f64::INFINITY };
                let r = match (&mut rng, r.is_finite()) {
                    (Some((sigma, rng)), true) => r + *sigma * rng.gauss(),
                    _ => r,
                };
                r as f32
            })
            .collect();
        scan_from(angle_min, inc, ranges)
    }

    fn pt(x: f64, y: f64) -> Point2<f64> {
        Point2::new(x, y)
    }

    fn seg(ax: f64, ay: f64, bx: f64, by: f64) -> Segment {
        Segment { a: pt(ax, ay), b: pt(bx, by) }
    }

    fn near(p: Point2<f64>, q: Point2<f64>, tol: f64) -> bool {
        (p - q).norm() <= tol
    }

    #[test]
    fn closest_point_and_distance_by_hand() {
        let s = seg(0.0, 0.0, 4.0, 0.0);
        // Inside: t = (1·4 + 3·0)/16 = 0.25 → (1, 0), distance 3.
        assert_eq!(closest_point(&s, &pt(1.0, 3.0)), pt(1.0, 0.0));
        assert_eq!(distance(&s, &pt(1.0, 3.0)), 3.0);
        // Before a: t = −12/16 → 0 → (0, 0), distance sqrt(3² + 4²) = 5.
        assert_eq!(closest_point(&s, &pt(-3.0, 4.0)), pt(0.0, 0.0));
        assert_eq!(distance(&s, &pt(-3.0, 4.0)), 5.0);
        // Past b: t = 28/16 → 1 → (4, 0), distance sqrt(3² + 4²) = 5.
        assert_eq!(closest_point(&s, &pt(7.0, -4.0)), pt(4.0, 0.0));
        assert_eq!(distance(&s, &pt(7.0, -4.0)), 5.0);
        // Diagonal: a = (0, 0), b = (2, 2), p = (2, 0): t = (2·2 + 0·2)/8 = 0.5 → (1, 1), √2.
        let d = seg(0.0, 0.0, 2.0, 2.0);
        assert!(near(closest_point(&d, &pt(2.0, 0.0)), pt(1.0, 1.0), 1e-15));
        assert!((distance(&d, &pt(2.0, 0.0)) - 2f64.sqrt()).abs() < 1e-15);
        // Degenerate a = b = (1, 1): the point a, distance to (4, 5) is 5.
        let z = seg(1.0, 1.0, 1.0, 1.0);
        assert_eq!(closest_point(&z, &pt(4.0, 5.0)), pt(1.0, 1.0));
        assert_eq!(distance(&z, &pt(4.0, 5.0)), 5.0);
        // Non-finite p: a non-finite answer, no panic.
        assert!(distance(&s, &pt(f64::NAN, 1.0)).is_nan());
        assert!(!distance(&s, &pt(f64::INFINITY, 1.0)).is_finite());
    }

    #[test]
    fn segment_points_by_hand() {
        let s = seg(0.0, 0.0, 1.0, 0.0);
        let xs = |pts: Vec<Point2<f64>>| pts.iter().map(|p| p.x).collect::<Vec<_>>();
        // ⌈1/0.3⌉ = 4 intervals of 0.25 m.
        assert_eq!(xs(segment_points(&[s], 0.3)), vec![0.0, 0.25, 0.5, 0.75, 1.0]);
        // ⌈1/0.5⌉ = 2 intervals.
        assert_eq!(xs(segment_points(&[s], 0.5)), vec![0.0, 0.5, 1.0]);
        // Spacing longer than the segment: the two ends.
        assert_eq!(xs(segment_points(&[s], 5.0)), vec![0.0, 1.0]);
        // Two segments: concatenated, each from a to b; the second (0,0)–(0,−2) at spacing 1.
        let t = seg(0.0, 0.0, 0.0, -2.0);
        let both = segment_points(&[s, t], 0.5);
        assert_eq!(both.len(), 3 + 5);
        assert_eq!(both[3..], [pt(0.0, 0.0), pt(0.0, -0.5), pt(0.0, -1.0), pt(0.0, -1.5), pt(0.0, -2.0)]);
        // Degenerate inputs: zero length → one point; bad spacing → the ends; non-finite → none.
        assert_eq!(segment_points(&[seg(2.0, 3.0, 2.0, 3.0)], 0.1), vec![pt(2.0, 3.0)]);
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert_eq!(xs(segment_points(&[s], bad)), vec![0.0, 1.0], "{bad}");
        }
        assert!(segment_points(&[seg(f64::NAN, 0.0, 1.0, 0.0)], 0.1).is_empty());
        // A tiny spacing is capped at 1000 intervals.
        assert_eq!(segment_points(&[s], 1e-12).len(), 1001);
    }

    #[test]
    fn fit_segment_by_hand() {
        // Six points symmetric about y = 0: Sxx = 2·(2² + 0 + 2²) = 16, Syy = 6, Sxy = 0 ⇒
        // θ = ½·atan2(0, 10) = 0, the x axis through the mean (2, 0); projections −2 … 2.
        let pts = [pt(0.0, 1.0), pt(0.0, -1.0), pt(2.0, 1.0), pt(2.0, -1.0), pt(4.0, 1.0), pt(4.0, -1.0)];
        let s = fit_segment(&pts).unwrap();
        assert!(near(s.a, pt(0.0, 0.0), 1e-12) && near(s.b, pt(4.0, 0.0), 1e-12), "{s:?}");
        // Orientation follows the points: reversed input, reversed segment.
        let rev: Vec<_> = pts.iter().rev().copied().collect();
        let r = fit_segment(&rev).unwrap();
        assert!(near(r.a, pt(4.0, 0.0), 1e-12) && near(r.b, pt(0.0, 0.0), 1e-12), "{r:?}");
        // Exact points on y = 0.5x + 1 give the line through them, clipped to (0, 1)–(4, 3).
        let line: Vec<_> = (0..5).map(|i| pt(i as f64, 0.5 * i as f64 + 1.0)).collect();
        let l = fit_segment(&line).unwrap();
        assert!(near(l.a, pt(0.0, 1.0), 1e-12) && near(l.b, pt(4.0, 3.0), 1e-12), "{l:?}");
        // Vertical: Sxx = 0, Syy > 0 ⇒ θ = ½·atan2(0, −Syy) = π/2.
        let v = fit_segment(&[pt(1.0, 0.0), pt(1.0, 1.0), pt(1.0, 3.0)]).unwrap();
        assert!(near(v.a, pt(1.0, 0.0), 1e-12) && near(v.b, pt(1.0, 3.0), 1e-12), "{v:?}");
        // Undefined lines.
        assert_eq!(fit_segment(&[]), None);
        assert_eq!(fit_segment(&[pt(1.0, 1.0)]), None);
        assert_eq!(fit_segment(&[pt(1.0, 1.0); 4]), None);
        assert_eq!(fit_segment(&[pt(1.0, 1.0), pt(f64::NAN, 2.0), pt(3.0, 3.0)]), None);
    }

    #[test]
    fn split_runs_by_hand() {
        // (0,0) (1,0) (2,0) (2,1) (2,2): chord (0,0)–(2,2); distances of the interior points
        // (projection t = p·(2,2)/8): (1,0) t = 0.25 → (0.5,0.5), 0.707; (2,0) t = 0.5 → (1,1),
        // 1.414; (2,1) t = 0.75 → (1.5,1.5), 0.707. Split at index 2, both halves straight.
        let pts = [pt(0.0, 0.0), pt(1.0, 0.0), pt(2.0, 0.0), pt(2.0, 1.0), pt(2.0, 2.0)];
        assert_eq!(split_runs(&pts, 0.1), vec![(0, 2), (2, 4)]);
        // A tolerance above 1.414 keeps one run.
        assert_eq!(split_runs(&pts, 1.5), vec![(0, 4)]);
        // Closed ring (square of side 2, first and last points neighbours): the chord is short,
        // the distance is to the chord segment, so the ring still splits at its corners.
        let ring = [pt(0.0, 0.0), pt(2.0, 0.0), pt(2.0, 2.0), pt(0.0, 2.0), pt(0.0, 0.1)];
        assert_eq!(split_runs(&ring, 0.1), vec![(0, 1), (1, 2), (2, 3), (3, 4)]);
        assert!(split_runs(&pts[..1], 0.1).is_empty());
    }

    #[test]
    fn corner_rule_joins_legs_when_the_corner_beam_is_missing() {
        // Leg 1: (0,0) … (1.8,0), 10 points; leg 2: (2,0.2) … (2,2.2), 11 points; no point at
        // the corner (2,0). Chord (0,0)–(2,2.2), |chord| = 2.973: (1.8,0) is 1.8·2.2/2.973 =
        // 1.332 from it, (2,0.2) is (2·2.2 − 0.2·2)/2.973 = 1.345 → split at (2,0.2). The left
        // half splits again at (1.8,0) (0.2·1.8/2.01 = 0.179 > 0.1), leaving the 2-point run
        // (1.8,0)–(2,0.2), dropped. Fitted legs (0,0)–(1.8,0) and (2,0.2)–(2,2.2): their lines
        // cross at (2,0), 0.2 m ≤ 0.25 m from both facing ends ⇒ both end there.
        let mut pts: Vec<_> = (0..10).map(|i| pt(0.2 * i as f64, 0.0)).collect();
        pts.extend((0..11).map(|i| pt(2.0, 0.2 + 0.2 * i as f64)));
        let segs = segments_in_group(&pts, &SegmentParams::default());
        assert_eq!(segs.len(), 2, "{segs:?}");
        assert!(near(segs[0].a, pt(0.0, 0.0), 1e-9) && near(segs[0].b, pt(2.0, 0.0), 1e-9), "{segs:?}");
        assert!(near(segs[1].a, pt(2.0, 0.0), 1e-9) && near(segs[1].b, pt(2.0, 2.2), 1e-9), "{segs:?}");
        // With a snap distance below 0.2 m the legs keep their own ends.
        let strict = SegmentParams { corner_snap_m: 0.19, ..SegmentParams::default() };
        let segs = segments_in_group(&pts, &strict);
        assert!(near(segs[0].b, pt(1.8, 0.0), 1e-9) && near(segs[1].a, pt(2.0, 0.2), 1e-9), "{segs:?}");
    }

    #[test]
    fn segments_in_group_thresholds() {
        // 9 points 0.1 m apart on a line: 0.8 m long, 9 points: kept at the defaults (≥ 5
        // points, ≥ 0.7 m).
        let line: Vec<_> = (0..9).map(|i| pt(1.0, 0.1 * i as f64)).collect();
        let p = SegmentParams::default();
        assert_eq!(segments_in_group(&line, &p).len(), 1);
        // One point too few, or 1 cm too short: dropped.
        assert!(segments_in_group(&line, &SegmentParams { min_points: 10, ..p }).is_empty());
        assert!(segments_in_group(&line, &SegmentParams { min_length_m: 0.81, ..p }).is_empty());
        // A gap of 0.4 m (> 0.35 m) in a straight run cuts it: (1,0)…(1,0.8), (1,1.2)…(1,2).
        let mut gapped = line.clone();
        gapped.extend((0..9).map(|i| pt(1.0, 1.2 + 0.1 * i as f64)));
        let segs = segments_in_group(&gapped, &p);
        assert_eq!(segs.len(), 2, "{segs:?}");
        assert!(near(segs[0].b, pt(1.0, 0.8), 1e-9) && near(segs[1].a, pt(1.0, 1.2), 1e-9), "{segs:?}");
        // The parallel halves never meet, so the corner rule leaves them; a gap of 0.3 m does
        // not cut.
        let mut closer = line.clone();
        closer.extend((0..9).map(|i| pt(1.0, 1.1 + 0.1 * i as f64)));
        assert_eq!(segments_in_group(&closer, &p).len(), 1);
        // Non-finite points are ignored; NaN thresholds do not panic.
        let mut dirty = line.clone();
        dirty.insert(3, pt(f64::NAN, 0.0));
        assert_eq!(segments_in_group(&dirty, &p), segments_in_group(&line, &p));
        let nan = SegmentParams {
            split_tolerance_m: f64::NAN,
            min_length_m: f64::NAN,
            max_point_gap_m: f64::NAN,
            corner_snap_m: f64::NAN,
            circle_max_rms_m: f64::NAN,
            ..p
        };
        let _ = segments_in_group(&gapped, &nan);
        let _ = extract(&world_scan(750, -PI, &[(2.0, 0.0, 0.3)], &[], None), &PerceptionParams::default(), &nan);
        assert!(segments_in_group(&[], &p).is_empty());
    }

    #[test]
    fn straight_wall_is_one_segment() {
        // The hub's wall (3,−2)–(3,2), 0.2 m thick: the face seen from the origin is x = 2.9,
        // y ∈ [−2, 2] (the end faces look away). Beam spacing along it is at most
        // r·Δθ/cos α = 3.52·0.00838/cos 34.6° ≈ 0.036 m at its ends, so with σ = 0.02 m noise the
        // fitted ends are within 0.05 m of the true ones.
        let faces = wall_faces(3.0, -2.0, 3.0, 2.0, 0.2);
        let (perception, params) = (PerceptionParams::default(), SegmentParams::default());
        for seed in 0..20 {
            let scan = world_scan(750, -PI, &[], &faces, Some((0.02, 100 + seed)));
            let found = extract(&scan, &perception, &params);
            assert!(found.circles.is_empty(), "seed {seed}: {found:?}");
            assert_eq!(found.segments.len(), 1, "seed {seed}: {found:?}");
            let s = found.segments[0];
            // Scan order is counter-clockwise from −π: a is the y = −2 end.
            assert!(near(s.a, pt(2.9, -2.0), 0.05), "seed {seed}: {s:?}");
            assert!(near(s.b, pt(2.9, 2.0), 0.05), "seed {seed}: {s:?}");
            assert_eq!(extract_segments(&scan, &perception, &params), found.segments);
        }
    }

    #[test]
    fn l_corner_seen_from_inside_is_two_segments_meeting_at_the_corner() {
        // Walls (4,−3)–(4,2) and (4,2)–(−1,2), 0.2 m thick: inner faces x = 3.9 (y ∈ [−3, 1.9])
        // and y = 1.9 (x ∈ [−1, 3.9]), inner corner (3.9, 1.9).
        let mut faces = wall_faces(4.0, -3.0, 4.0, 2.0, 0.2);
        faces.extend(wall_faces(4.0, 2.0, -1.0, 2.0, 0.2));
        let (perception, params) = (PerceptionParams::default(), SegmentParams::default());
        for seed in 0..20 {
            let scan = world_scan(750, -PI, &[], &faces, Some((0.02, 200 + seed)));
            let found = extract(&scan, &perception, &params);
            assert!(found.circles.is_empty(), "seed {seed}: {found:?}");
            assert_eq!(found.segments.len(), 2, "seed {seed}: {found:?}");
            let (s, t) = (found.segments[0], found.segments[1]);
            // Beam spacing at the far end: 4.93·0.00838/cos α, cos α = 3.9/4.93 ⇒ 0.052 m.
            assert!(near(s.a, pt(3.9, -3.0), 0.08), "seed {seed}: {s:?}");
            assert_eq!(s.b, t.a, "seed {seed}: the corner rule joins the legs");
            assert!(near(s.b, pt(3.9, 1.9), 0.05), "seed {seed}: {s:?}");
            assert!(near(t.b, pt(-1.0, 1.9), 0.05), "seed {seed}: {t:?}");
        }
    }

    #[test]
    fn building_corner_seen_from_outside_is_two_segments() {
        // A solid block [3, 5] × [1.5, 4]: the faces y = 1.5 (x from 5 to 3 in scan order) and
        // x = 3 (y from 1.5 to 4) are visible, meeting at the convex corner (3, 1.5). Beam
        // spacing r·Δθ/cos α at the far ends: (5, 1.5): 5.22·0.00838/(1.5/5.22) = 0.152 m;
        // (3, 4): 5·0.00838/(3/5) = 0.070 m.
        let block =
            [seg(3.0, 1.5, 5.0, 1.5), seg(5.0, 1.5, 5.0, 4.0), seg(5.0, 4.0, 3.0, 4.0), seg(3.0, 4.0, 3.0, 1.5)];
        let (perception, params) = (PerceptionParams::default(), SegmentParams::default());
        for seed in 0..20 {
            let scan = world_scan(750, -PI, &[], &block, Some((0.02, 300 + seed)));
            let found = extract(&scan, &perception, &params);
            assert!(found.circles.is_empty(), "seed {seed}: {found:?}");
            assert_eq!(found.segments.len(), 2, "seed {seed}: {found:?}");
            let (s, t) = (found.segments[0], found.segments[1]);
            assert!(near(s.a, pt(5.0, 1.5), 0.2), "seed {seed}: {s:?}");
            assert_eq!(s.b, t.a, "seed {seed}");
            assert!(near(s.b, pt(3.0, 1.5), 0.05), "seed {seed}: {s:?}");
            assert!(near(t.b, pt(3.0, 4.0), 0.1), "seed {seed}: {t:?}");
        }
    }

    #[test]
    fn wall_the_circle_fit_accepts_is_still_a_segment() {
        // Noise seed 103 on the wall of `straight_wall_is_one_segment`: the algebraic circle fit
        // of the nearly collinear points (near-singular normal equations) returns a circle with a
        // plausible radius that passes nowhere near the wall's ends, so extract_obstacles keeps
        // it. Its RMS residual is far above circle_max_rms_m, so extract offers the group to the
        // segment extractor, which finds the wall; the bogus circle is not in `circles`.
        let faces = wall_faces(3.0, -2.0, 3.0, 2.0, 0.2);
        let scan = world_scan(750, -PI, &[], &faces, Some((0.02, 103)));
        let perception = PerceptionParams::default();
        let bogus = extract_obstacles(&scan, &perception);
        assert_eq!(bogus.len(), 1, "{bogus:?}");
        let groups = group_scan(&scan, perception.group_gap_m);
        assert_eq!(groups.len(), 1);
        assert!(rms_circle_residual(&groups[0], &bogus[0]) > 0.2, "{bogus:?}");
        let found = extract(&scan, &perception, &SegmentParams::default());
        assert!(found.circles.is_empty(), "{found:?}");
        assert_eq!(found.segments.len(), 1, "{found:?}");
    }

    #[test]
    fn rms_circle_residual_by_hand() {
        // Unit circle at the origin; points at distances 1, 1.1 and 0.8 from the centre:
        // residuals 0, 0.1, −0.2 ⇒ RMS = sqrt((0 + 0.01 + 0.04)/3) = sqrt(0.05/3) ≈ 0.1291.
        let c = Circle { center: pt(0.0, 0.0), radius: 1.0 };
        let pts = [pt(1.0, 0.0), pt(0.0, 1.1), pt(-0.8, 0.0)];
        assert!((rms_circle_residual(&pts, &c) - (0.05f64 / 3.0).sqrt()).abs() < 1e-12);
    }

    #[test]
    fn wall_and_tree_give_one_segment_and_one_circle() {
        // The wall of `straight_wall_is_one_segment` and a 0.3 m tree at (0, −4) on the right.
        let faces = wall_faces(3.0, -2.0, 3.0, 2.0, 0.2);
        let trees = [(0.0, -4.0, 0.3)];
        let (perception, params) = (PerceptionParams::default(), SegmentParams::default());
        for seed in 0..20 {
            let scan = world_scan(750, -PI, &trees, &faces, Some((0.02, 400 + seed)));
            let found = extract(&scan, &perception, &params);
            assert_eq!(found.circles.len(), 1, "seed {seed}: {found:?}");
            // Kåsa fit of a noisy 0.3 m trunk 4 m away: centre within a few cm (see
            // `fit_circle_noisy_lidar_arc`, worst 0.06 m at 5 m).
            assert!(near(found.circles[0].center, pt(0.0, -4.0), 0.08), "seed {seed}: {found:?}");
            assert!((found.circles[0].radius - 0.3).abs() < 0.1, "seed {seed}: {found:?}");
            assert_eq!(found.segments.len(), 1, "seed {seed}: {found:?}");
            let s = found.segments[0];
            assert!(near(s.a, pt(2.9, -2.0), 0.05) && near(s.b, pt(2.9, 2.0), 0.05), "seed {seed}: {s:?}");
        }
    }

    /// A forest like the hub's generator makes: `n` trunks of radius 0.1–0.4 m within 12 m,
    /// none closer than 1 m to the origin, gaps between trunks of at least `min_gap_m`.
    fn forest(seed: u64, n: usize, min_gap_m: f64) -> Vec<(f64, f64, f64)> {
        let mut rng = Noise::new(seed);
        let mut trees: Vec<(f64, f64, f64)> = Vec::new();
        while trees.len() < n {
            let (x, y) = (24.0 * rng.uniform() - 12.0, 24.0 * rng.uniform() - 12.0);
            let r = 0.1 + 0.3 * rng.uniform();
            let clear_of_origin = x.hypot(y) > 1.0 + r;
            let clear_of_trees = trees.iter().all(|&(tx, ty, tr)| (x - tx).hypot(y - ty) >= r + tr + min_gap_m);
            if clear_of_origin && clear_of_trees {
                trees.push((x, y, r));
            }
        }
        trees
    }

    #[test]
    fn forest_gives_no_segment_and_the_same_circles() {
        // 40 trunks in 24 m × 24 m (≈ 7 per 100 m²), trunks as close as 0.2 m: many groups hold
        // two or more trunks (depth jumps under 1 m), which the circle pipeline may reject.
        let (perception, params) = (PerceptionParams::default(), SegmentParams::default());
        let mut offered_groups = 0;
        for seed in 0..30 {
            let trees = forest(seed, 40, 0.2);
            for noise in [None, Some((0.02, 500 + seed))] {
                let scan = synthetic_scan(750, -PI, &trees, noise);
                let found = extract(&scan, &perception, &params);
                assert_eq!(found.circles, extract_obstacles(&scan, &perception), "seed {seed}");
                assert!(found.segments.is_empty(), "seed {seed} {noise:?}: {:?}", found.segments);
                // Groups that are not a well-fitted accepted circle reach segments_in_group.
                offered_groups += group_scan(&scan, perception.group_gap_m)
                    .iter()
                    .filter(|g| {
                        accepted_circle(g, &perception)
                            .filter(|c| rms_circle_residual(g, c) <= params.circle_max_rms_m)
                            .is_none()
                    })
                    .count();
            }
        }
        // The segment extractor was really offered forest groups.
        assert!(offered_groups > 0);
    }

    #[test]
    fn room_is_its_walls_cut_once_where_the_ring_starts() {
        // Inside the room [−3, 3] × [−2, 2]: every beam returns, one group. Beam 0 (−π) hits the
        // west wall at (−3, 0), so the west wall comes out in two halves (module doc); the other
        // corners are joined by the corner rule. In scan order: west lower half, south, east,
        // north, west upper half.
        let room = [
            seg(-3.0, -2.0, 3.0, -2.0),
            seg(3.0, -2.0, 3.0, 2.0),
            seg(3.0, 2.0, -3.0, 2.0),
            seg(-3.0, 2.0, -3.0, -2.0),
        ];
        let corners = [pt(-3.0, 0.0), pt(-3.0, -2.0), pt(3.0, -2.0), pt(3.0, 2.0), pt(-3.0, 2.0), pt(-3.0, 0.0)];
        let (perception, params) = (PerceptionParams::default(), SegmentParams::default());
        for seed in 0..10 {
            let scan = world_scan(750, -PI, &[], &room, Some((0.02, 600 + seed)));
            assert_eq!(group_scan(&scan, perception.group_gap_m).len(), 1);
            let found = extract(&scan, &perception, &params);
            assert!(found.circles.is_empty(), "seed {seed}: {found:?}");
            assert_eq!(found.segments.len(), 5, "seed {seed}: {found:?}");
            for (k, s) in found.segments.iter().enumerate() {
                assert!(near(s.a, corners[k], 0.05) && near(s.b, corners[k + 1], 0.05), "seed {seed} {k}: {s:?}");
            }
            for w in found.segments.windows(2) {
                assert_eq!(w[0].b, w[1].a, "seed {seed}");
            }
        }
    }

    fn config(cases: u32) -> proptest::test_runner::Config {
        proptest::test_runner::Config {
            cases,
            rng_seed: proptest::test_runner::RngSeed::Fixed(0x0057_A115),
            failure_persistence: None,
            ..proptest::test_runner::Config::default()
        }
    }

    proptest::proptest! {
        #![proptest_config(config(256))]

        /// closest_point lies on the segment and no point of the segment is closer to p.
        #[test]
        fn prop_closest_point_is_closest(
            ax in -10.0..10.0f64, ay in -10.0..10.0f64, bx in -10.0..10.0f64, by in -10.0..10.0f64,
            px in -20.0..20.0f64, py in -20.0..20.0f64,
        ) {
            let s = seg(ax, ay, bx, by);
            let p = pt(px, py);
            let q = closest_point(&s, &p);
            // On the segment: |a − q| + |q − b| = |a − b|.
            proptest::prop_assert!(((s.a - q).norm() + (q - s.b).norm() - s.length()).abs() < 1e-9);
            let d = distance(&s, &p);
            for k in 0..=100 {
                let on = s.a + (s.b - s.a) * (k as f64 / 100.0);
                proptest::prop_assert!(d <= (p - on).norm() + 1e-9);
            }
        }

        /// segment_points starts at a, ends at b, and its points are equally spaced, at most
        /// spacing_m apart.
        #[test]
        fn prop_segment_points_spacing(
            ax in -10.0..10.0f64, ay in -10.0..10.0f64, bx in -10.0..10.0f64, by in -10.0..10.0f64,
            spacing in 0.05..5.0f64,
        ) {
            let s = seg(ax, ay, bx, by);
            let pts = segment_points(&[s], spacing);
            proptest::prop_assert_eq!(pts[0], s.a);
            proptest::prop_assert!(near(*pts.last().unwrap(), s.b, 1e-9));
            let step = s.length() / (pts.len() - 1) as f64;
            proptest::prop_assert!(step <= spacing + 1e-12);
            for w in pts.windows(2) {
                proptest::prop_assert!(((w[1] - w[0]).norm() - step).abs() < 1e-9);
            }
        }
    }
}

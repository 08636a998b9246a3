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

use nalgebra::{Matrix3, Point2, Vector2, Vector3};
use swarm_config::PerceptionParams;
use swarm_wire::Scan;

/// A circular obstacle (a trunk cut by the plane of flight), body frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Circle {
    /// Centre [m], body frame.
    pub center: Point2<f64>,
    /// Radius [m].
    pub radius: f64,
}

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
    let angle_min = f64::from(scan.angle_min);
    let angle_increment = f64::from(scan.angle_increment);
    let n = scan.ranges_m.len();

    let mut groups: Vec<Vec<Point2<f64>>> = Vec::new();
    let mut current: Vec<Point2<f64>> = Vec::new();
    // Does groups[0] start at beam 0?
    let mut first_starts_at_beam_zero = false;

    for (i, &range) in scan.ranges_m.iter().enumerate() {
        match beam_point(angle_min, angle_increment, i, range) {
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

    if first_starts_at_beam_zero
        && last_ends_at_last_beam
        && groups.len() >= 2
        && covers_full_turn(n, angle_increment)
    {
        let close =
            match (groups.first().and_then(|g| g.first()), groups.last().and_then(|g| g.last())) {
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
    let min_points = usize::try_from(params.min_points).unwrap_or(usize::MAX);
    let [r_min, r_max] = params.radius_range_m;
    group_scan(scan, params.group_gap_m)
        .into_iter()
        // seed 000 section 3.2: groups of fewer than 3 points are filtered out before fitting.
        .filter(|g| g.len() >= min_points)
        .filter_map(|g| fit_circle(&g))
        // SPEC section 4.2: reject fits with an implausible radius.
        .filter(|c| c.radius >= r_min && c.radius <= r_max)
        .collect()
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
            self.state =
                self.state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
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
    fn synthetic_scan(
        beams: usize,
        angle_min: f64,
        circles: &[(f64, f64, f64)],
        noise: Option<(f64, u64)>,
    ) -> Scan {
        let inc = TAU / beams as f64;
        let mut rng = noise.map(|(sigma, seed)| (sigma, Noise::new(seed)));
        let ranges = (0..beams)
            .map(|i| {
                let r = ray_range(angle_min + i as f64 * inc, circles, 12.0);
                let r = match (&mut rng, r.is_finite()) {
                    (Some((sigma, rng)), true) => r + *sigma * rng.gauss(),
                    _ => r,
                };
                r as f32
            })
            .collect();
        scan_from(angle_min, inc, ranges)
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
        let pts: Vec<_> =
            (0..10).map(|i| Point2::new(0.1 * i as f64, 0.3 * i as f64 + 0.7)).collect();
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
                let hit = hit
                    .unwrap_or_else(|| panic!("{noise:?}: no circle near ({x}, {y}) in {found:?}"));
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
}

//! Trunks as circles: the linear least-squares circle fit of seed 000 eq. 3.13–3.15 and the
//! pipeline around it (drop groups of fewer than 3 points, fit, reject implausible radii).
//!
//! Choice where seed 000 is silent: the normal equations are formed on centred and scaled points
//! (the same least-squares problem, better conditioned), then shifted back.

use nalgebra::{Matrix3, Point2, Vector2, Vector3};
use swarm_config::PerceptionParams;

use crate::world_model::Circle;

/// Smallest accepted ratio of the smallest to the largest eigenvalue of the (centred, scaled)
/// normal matrix AᵀA; below it the fit is ill-conditioned (e.g. collinear points) and refused.
pub(super) const MIN_RCOND: f64 = 1e-10;

/// Whether the normal matrix passes the conditioning test: its smallest eigenvalue above
/// [`MIN_RCOND`] times its largest (in magnitude).
///
/// Most fits are far from the limit, and for them a bound decides without the eigenvalues (an
/// iterative decomposition was 8 % of an agent host's CPU at 1000 UAVs, by `perf`): AᵀA is a
/// Gram matrix, so its eigenvalues 0 ≤ λ1 ≤ λ2 ≤ λ3 give λ3 ≤ trace and λ1 = det/(λ2·λ3) ≥
/// det/trace², hence det > 2·MIN_RCOND·trace³ implies λ1 > 2·MIN_RCOND·λ3. The factor 2 is far
/// above the rounding of det and trace (about 1e-15·trace³), so the bound never passes a matrix
/// the eigenvalues would refuse; anything it cannot settle goes to the eigenvalues as before, so
/// every decision is the one the eigenvalues make.
pub(super) fn well_conditioned(ata: &Matrix3<f64>) -> bool {
    let trace = ata.trace();
    if trace.is_finite() && trace > 0.0 && ata.determinant() > 2.0 * MIN_RCOND * trace * trace * trace {
        return true;
    }
    let eig = ata.symmetric_eigenvalues();
    let max_eig = eig.iter().fold(0.0_f64, |m, e| m.max(e.abs()));
    let min_eig = eig.iter().fold(f64::INFINITY, |m, e| m.min(*e));
    max_eig.is_finite() && max_eig > 0.0 && min_eig > MIN_RCOND * max_eig
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

    if !well_conditioned(&ata) {
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
/// `None`) are dropped. Circles are returned in the order of their groups (see [`group_scan`](super::scan::group_scan)).
/// Telling a neighbouring UAV apart from a tree (`params.neighbour_match_m`) needs the
/// neighbours' positions and is not done here.
///
/// The agent runs [`extract`](super::extract), which makes the same circle of each group through
/// [`accepted_circle`]; this whole-scan pipeline is the seed's, kept for the tests that hold
/// `extract` to it.
#[cfg(test)]
pub fn extract_obstacles(scan: &swarm_wire::Scan, params: &PerceptionParams) -> Vec<Circle> {
    super::scan::group_scan(scan, params.group_gap_m).iter().filter_map(|g| accepted_circle(g, params)).collect()
}

/// The circle of one group, if the pipeline of [`extract_obstacles`] accepts it as a trunk.
pub(super) fn accepted_circle(group: &[Point2<f64>], params: &PerceptionParams) -> Option<Circle> {
    let min_points = usize::try_from(params.min_points).unwrap_or(usize::MAX);
    let [r_min, r_max] = params.radius_range_m;
    // seed 000 section 3.2: groups of fewer than 3 points are filtered out before fitting.
    if group.len() < min_points {
        return None;
    }
    // SPEC section 4.2: reject fits with an implausible radius.
    fit_circle(group).filter(|c| c.radius >= r_min && c.radius <= r_max)
}

/// Root mean square of the geometric residuals |‖p − c‖ − r| of `points` from `circle` [m].
pub(super) fn rms_circle_residual(points: &[Point2<f64>], circle: &Circle) -> f64 {
    let n = points.len() as f64;
    let sum: f64 = points.iter().map(|p| ((p - circle.center).norm() - circle.radius).powi(2)).sum();
    (sum / n).sqrt()
}

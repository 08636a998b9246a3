//! Small helpers on 2D vectors that every controller needs the same way: what counts as zero,
//! and how non-finite values are kept out of a command.

use nalgebra::Vector2;

/// Lengths below this are treated as zero (directions undefined) [m].
pub const EPS: f64 = 1e-9;

/// Whether both components are finite.
pub fn is_finite(v: &Vector2<f64>) -> bool {
    v.x.is_finite() && v.y.is_finite()
}

/// `v`, or zero when a component is not finite (a command never carries NaN).
pub fn finite_or_zero(v: Vector2<f64>) -> Vector2<f64> {
    if is_finite(&v) {
        v
    } else {
        Vector2::zeros()
    }
}

/// The scatter sums Σ dx², Σ dx·dy, Σ dy² of the points about `centre` (unnormalised).
pub fn scatter(points: impl Iterator<Item = nalgebra::Point2<f64>>, centre: Vector2<f64>) -> (f64, f64, f64) {
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for p in points {
        let d = p.coords - centre;
        sxx += d.x * d.x;
        sxy += d.x * d.y;
        syy += d.y * d.y;
    }
    (sxx, sxy, syy)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn non_finite_vectors_become_zero() {
        assert_eq!(finite_or_zero(Vector2::new(1.0, -2.0)), Vector2::new(1.0, -2.0));
        assert_eq!(finite_or_zero(Vector2::new(f64::NAN, 1.0)), Vector2::zeros());
        assert!(!is_finite(&Vector2::new(1.0, f64::INFINITY)));
        let pts = [nalgebra::Point2::new(0.0, 0.0), nalgebra::Point2::new(2.0, 2.0)];
        assert_eq!(scatter(pts.into_iter(), Vector2::new(1.0, 1.0)), (2.0, 2.0, 2.0));
    }
}

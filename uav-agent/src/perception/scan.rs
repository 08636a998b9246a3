//! A scan's beams as points, and Algorithm 2's groups of consecutive points (seed 000 section
//! 3.2): what both extractors start from. Pure, in the scanning UAV's body frame.
//!
//! Choices where seed 000 is silent (documented at the functions):
//! - a beam with a non-finite or negative range is "no return" and ends the current group;
//! - because the scanner covers 360°, the group that ends at the last beam and the group that
//!   starts at beam 0 are one obstacle when the two end points are close (Algorithm 2 scans a
//!   list, the sensor scans a ring).

use nalgebra::Point2;
use std::cell::RefCell;
use swarm_wire::Scan;

/// The point hit by a beam of direction `(cos θ, sin θ)` (see [`Directions`]), or `None` when
/// the beam has no return.
fn beam_point((cos, sin): (f64, f64), range: f32) -> Option<Point2<f64>> {
    let r = f64::from(range);
    if !r.is_finite() || r < 0.0 {
        return None;
    }
    // Polar to Cartesian in the body frame: p = r·(cos θ, sin θ).
    Some(Point2::new(r * cos, r * sin))
}

/// The beam directions of one scan layout: `(cos θ_i, sin θ_i)` for θ_i = angle_min +
/// i·angle_increment (the swarm-wire `Scan` convention). Every scan of a run has the same layout,
/// so each thread keeps the directions of the last layout it saw instead of two trigonometric
/// calls per returned beam (6 % of an agent host's CPU at 1000 UAVs, by `perf`); they are the
/// same calls on the same angles, so the points are bit for bit the same.
struct Directions {
    angle_min: u64,
    angle_increment: u64,
    dirs: Vec<(f64, f64)>,
}

impl Directions {
    /// Runs `f` on the directions of `n` beams from `angle_min` by `angle_increment`.
    fn with<R>(angle_min: f64, angle_increment: f64, n: usize, f: impl FnOnce(&[(f64, f64)]) -> R) -> R {
        thread_local! {
            static LAST: RefCell<Directions> =
                const { RefCell::new(Directions { angle_min: 0, angle_increment: 0, dirs: Vec::new() }) };
        }
        LAST.with_borrow_mut(|last| {
            let key = (angle_min.to_bits(), angle_increment.to_bits());
            if (last.angle_min, last.angle_increment) != key || last.dirs.len() != n {
                last.dirs.clear();
                last.dirs.extend((0..n).map(|i| {
                    let theta = angle_min + i as f64 * angle_increment;
                    (theta.cos(), theta.sin())
                }));
                (last.angle_min, last.angle_increment) = key;
            }
            f(&last.dirs)
        })
    }
}

/// The point of every beam of the scan, body frame, in beam order (`None`: no return).
pub(super) fn beam_points(scan: &Scan) -> Vec<Option<Point2<f64>>> {
    let (angle_min, angle_increment) = (f64::from(scan.angle_min), f64::from(scan.angle_increment));
    Directions::with(angle_min, angle_increment, scan.ranges_m.len(), |dirs| {
        dirs.iter().zip(&scan.ranges_m).map(|(&d, &r)| beam_point(d, r)).collect()
    })
}

/// True when `n` beams spaced by `angle_increment` cover a full turn (to within half a beam), so
/// that the last beam and beam 0 are neighbours on the ring.
pub(super) fn covers_full_turn(n: usize, angle_increment: f64) -> bool {
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
///
/// The agent groups the beam points it keeps ([`group_beams`]); this form on a whole scan is for
/// the tests.
#[cfg(test)]
pub fn group_scan(scan: &Scan, gap_m: f64) -> Vec<Vec<Point2<f64>>> {
    group_beams(&beam_points(scan), f64::from(scan.angle_increment), gap_m)
}

/// [`group_scan`] on the scan's beam points (see [`beam_points`]).
pub(super) fn group_beams(beams: &[Option<Point2<f64>>], angle_increment: f64, gap_m: f64) -> Vec<Vec<Point2<f64>>> {
    let n = beams.len();

    let mut groups: Vec<Vec<Point2<f64>>> = Vec::new();
    // The group being read keeps its buffer; each finished group is copied out at its size, one
    // allocation per group instead of a vector grown push by push.
    let mut current: Vec<Point2<f64>> = Vec::with_capacity(n);
    // Does groups[0] start at beam 0?
    let mut first_starts_at_beam_zero = false;

    for (i, &beam) in beams.iter().enumerate() {
        match beam {
            None => {
                // No return: the obstacle (if any) ends here.
                if !current.is_empty() {
                    groups.push(current.clone());
                    current.clear();
                }
            }
            Some(p) => {
                if let Some(prev) = current.last() {
                    // seed 000, Algorithm 2: dist ← distance(p, next point); same group iff dist < 1.
                    let joins = (p - prev).norm() < gap_m;
                    if !joins {
                        groups.push(current.clone());
                        current.clear();
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

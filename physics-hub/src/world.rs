//! The static world: trees and walls, and the geometric queries the hub asks of them.
//!
//! This module exists so that every other part of the hub (bodies, collisions, the LIDAR, the
//! onboard relative sensing) asks the same two questions of the same obstacle set: "how far is
//! the nearest obstacle surface from this point?" ([`World::clearance`]) and "where does this ray
//! first hit?" ([`World::cast_ray`]). It is pure geometry: no IO, no clock, no RNG.
//!
//! Shapes (SPEC §2):
//! - a tree is a solid disc (`swarm_config::Tree { x, y, r }`);
//! - a wall is a solid **oriented rectangle** (a parry-style cuboid): the segment
//!   `(x1,y1)-(x2,y2)` thickened to its full `thickness`, i.e. half-extents
//!   `(length/2, thickness/2)`, centred on the segment midpoint and rotated along the segment.
//!   The ends are flat and do not extend past the end points (it is not a capsule).
//!
//! Exactness: every per-shape test (ray–disc, ray–rectangle, signed distance) is analytic in
//! `f64`. parry2d's [`Bvh`] (which works in `f32`) is only used to *prune*: each leaf AABB is
//! loosened by a margin far larger than the `f32` rounding of the coordinates, so pruning is
//! conservative and results are the same as a brute-force scan over all obstacles.
//!
//! Speed: both queries are sub-linear in the number of obstacles. [`World::cast_ray`] is a
//! best-first BVH ray cast; [`World::clearance`] is a BVH nearest-neighbour search (one pass
//! for the obstacles whose AABB contains the point, then a best-first search), so the hub can
//! call it for every UAV every tick in a forest of thousands of trees.

use parry2d::bounding_volume::Aabb;
use parry2d::math::{Point, Real, Vector};
use parry2d::partitioning::{Bvh, BvhBuildStrategy};
use parry2d::query::{PointQuery, Ray};
use std::cell::Cell;

/// One obstacle in analytic `f64` form (crate-internal; the LIDAR rasterises these).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Obstacle {
    /// A solid disc.
    Circle {
        /// Centre [m].
        c: [f64; 2],
        /// Radius [m], ≥ 0.
        r: f64,
    },
    /// A solid rectangle with half-extents `(hx, hy)` along the unit axes `u` and `v = perp(u)`.
    Rect {
        /// Centre [m].
        c: [f64; 2],
        /// Unit vector along the wall (local x axis).
        u: [f64; 2],
        /// Half length along `u` [m].
        hx: f64,
        /// Half thickness along `perp(u)` [m].
        hy: f64,
    },
}

impl Obstacle {
    /// The disc of a tree (a negative radius is treated as 0).
    pub(crate) fn from_tree(t: &swarm_config::Tree) -> Obstacle {
        Obstacle::Circle { c: [t.x, t.y], r: t.r.max(0.0) }
    }

    /// The rectangle of a wall: half-extents (len/2, thickness/2) at the midpoint, rotated.
    pub(crate) fn from_wall(w: &swarm_config::Wall) -> Obstacle {
        let (dx, dy) = (w.x2 - w.x1, w.y2 - w.y1);
        let len = dx.hypot(dy);
        // A zero-length wall is a square-ended stub of width `thickness`; its axis is arbitrary.
        let u = if len > 0.0 { [dx / len, dy / len] } else { [1.0, 0.0] };
        Obstacle::Rect {
            c: [0.5 * (w.x1 + w.x2), 0.5 * (w.y1 + w.y2)],
            u,
            hx: 0.5 * len,
            hy: 0.5 * w.thickness.max(0.0),
        }
    }

    /// The four corners of a rectangle (counter-clockwise), or `None` for a circle.
    pub(crate) fn rect_corners(&self) -> Option<[[f64; 2]; 4]> {
        match *self {
            Obstacle::Circle { .. } => None,
            Obstacle::Rect { c, u, hx, hy } => {
                let v = [-u[1], u[0]];
                let corner =
                    |sx: f64, sy: f64| [c[0] + sx * hx * u[0] + sy * hy * v[0], c[1] + sx * hx * u[1] + sy * hy * v[1]];
                Some([corner(1.0, 1.0), corner(-1.0, 1.0), corner(-1.0, -1.0), corner(1.0, -1.0)])
            }
        }
    }

    /// Axis-aligned bounds `(min, max)` of the shape, exact in `f64`.
    fn bounds(&self) -> ([f64; 2], [f64; 2]) {
        match *self {
            Obstacle::Circle { c, r } => ([c[0] - r, c[1] - r], [c[0] + r, c[1] + r]),
            Obstacle::Rect { c, u, hx, hy } => {
                // Half-widths of the rotated rectangle along world x and y.
                let ex = hx * u[0].abs() + hy * u[1].abs();
                let ey = hx * u[1].abs() + hy * u[0].abs();
                ([c[0] - ex, c[1] - ey], [c[0] + ex, c[1] + ey])
            }
        }
    }

    /// Signed distance from `p` to the surface: positive outside, negative inside, 0 on it.
    #[inline]
    pub(crate) fn signed_distance(&self, p: [f64; 2]) -> f64 {
        match *self {
            Obstacle::Circle { c, r } => (p[0] - c[0]).hypot(p[1] - c[1]) - r,
            Obstacle::Rect { c, u, hx, hy } => {
                let (px, py) = (p[0] - c[0], p[1] - c[1]);
                // Box signed distance in the local frame (x along u, y along perp(u)).
                let qx = (px * u[0] + py * u[1]).abs() - hx;
                let qy = (-px * u[1] + py * u[0]).abs() - hy;
                if qx > 0.0 || qy > 0.0 {
                    qx.max(0.0).hypot(qy.max(0.0))
                } else {
                    qx.max(qy)
                }
            }
        }
    }

    /// Distance along the unit ray `origin + t·dir` (t ≥ 0) to the first point of the solid
    /// shape: 0 when `origin` is inside or on it, `None` when the ray misses.
    #[inline]
    pub(crate) fn cast_ray(&self, origin: [f64; 2], dir: [f64; 2]) -> Option<f64> {
        match *self {
            Obstacle::Circle { c, r } => ray_circle(origin, dir, c, r),
            Obstacle::Rect { c, u, hx, hy } => ray_rect(origin, dir, c, u, hx, hy),
        }
    }
}

/// Ray (unit `dir`) against a solid disc: the smallest t ≥ 0 with |o + t·d − c| ≤ r.
///
/// Solves t² + 2bt + k = 0 with b = (o−c)·d, k = |o−c|² − r²; the near root is written as
/// k / (−b + √(b² − k)) to avoid cancellation when the disc is small and far.
#[inline]
pub(crate) fn ray_circle(origin: [f64; 2], dir: [f64; 2], c: [f64; 2], r: f64) -> Option<f64> {
    let (ox, oy) = (origin[0] - c[0], origin[1] - c[1]);
    let k = ox * ox + oy * oy - r * r;
    if k <= 0.0 {
        return Some(0.0); // origin inside or on the disc
    }
    let b = ox * dir[0] + oy * dir[1];
    if b >= 0.0 {
        return None; // outside and moving away
    }
    let disc = b * b - k;
    if disc < 0.0 {
        return None;
    }
    Some(k / (-b + disc.sqrt()))
}

/// Ray (unit `dir`) against a solid rectangle (slab method in the rectangle's frame).
#[inline]
pub(crate) fn ray_rect(origin: [f64; 2], dir: [f64; 2], c: [f64; 2], u: [f64; 2], hx: f64, hy: f64) -> Option<f64> {
    let (px, py) = (origin[0] - c[0], origin[1] - c[1]);
    let (ox, oy) = (px * u[0] + py * u[1], -px * u[1] + py * u[0]);
    let (dx, dy) = (dir[0] * u[0] + dir[1] * u[1], -dir[0] * u[1] + dir[1] * u[0]);
    let mut t_near = 0.0_f64;
    let mut t_far = f64::INFINITY;
    for (o, d, h) in [(ox, dx, hx), (oy, dy, hy)] {
        if d == 0.0 {
            if o.abs() > h {
                return None; // parallel to this slab and outside it
            }
            continue;
        }
        let inv = 1.0 / d;
        let (t1, t2) = ((-h - o) * inv, (h - o) * inv);
        let (lo, hi) = if t1 <= t2 { (t1, t2) } else { (t2, t1) };
        t_near = t_near.max(lo);
        t_far = t_far.min(hi);
        if t_near > t_far {
            return None;
        }
    }
    Some(t_near)
}

/// The static obstacles with an acceleration structure for ray casts and distance queries.
///
/// Trees are solid discs; walls are solid oriented rectangles (cuboids with half-extents
/// `(length/2, thickness/2)` at the segment midpoint, rotated along the segment — flat ends, not
/// capsules). Obstacle `i < trees.len()` is tree `i`, the rest are the walls in order. A parry2d
/// [`Bvh`] over the (loosened) obstacle AABBs makes both queries sub-linear; the per-shape
/// answers are analytic in `f64`, so results equal a brute-force scan.
///
/// Inputs are assumed validated by `swarm-config` (finite coordinates, r ≥ 0, thickness ≥ 0).
#[derive(Debug, Clone)]
pub struct World {
    trees: Vec<swarm_config::Tree>,
    walls: Vec<swarm_config::Wall>,
    obstacles: Vec<Obstacle>,
    bvh: Bvh,
}

/// Conservative AABB loosening: covers the `f32` rounding of coordinates of magnitude `scale`
/// (relative error ≤ 6e-8 per rounding) with a wide safety factor, plus 1 mm.
fn aabb_margin(scale: f64) -> f64 {
    1e-3 + 1e-6 * scale
}

impl World {
    /// Builds the world and its BVH (binned SAH build; O(n log n)).
    pub fn new(trees: Vec<swarm_config::Tree>, walls: Vec<swarm_config::Wall>) -> World {
        let obstacles: Vec<Obstacle> =
            trees.iter().map(Obstacle::from_tree).chain(walls.iter().map(Obstacle::from_wall)).collect();
        let aabbs: Vec<Aabb> = obstacles
            .iter()
            .map(|o| {
                let (lo, hi) = o.bounds();
                let scale = lo[0].abs().max(lo[1].abs()).max(hi[0].abs()).max(hi[1].abs());
                let m = aabb_margin(scale);
                Aabb::new(
                    Point::new((lo[0] - m) as Real, (lo[1] - m) as Real),
                    Point::new((hi[0] + m) as Real, (hi[1] + m) as Real),
                )
            })
            .collect();
        let bvh = Bvh::from_leaves(BvhBuildStrategy::Binned, &aabbs);
        World { trees, walls, obstacles, bvh }
    }

    /// The trees, as given to [`World::new`].
    pub fn trees(&self) -> &[swarm_config::Tree] {
        &self.trees
    }

    /// The walls, as given to [`World::new`].
    pub fn walls(&self) -> &[swarm_config::Wall] {
        &self.walls
    }

    /// All obstacles in analytic form: the trees, then the walls.
    pub(crate) fn obstacles(&self) -> &[Obstacle] {
        &self.obstacles
    }

    /// Calls `f` on every obstacle whose (loosened) AABB meets the box `[lo, hi]`; no allocation.
    pub(crate) fn for_each_in_box(&self, lo: [f64; 2], hi: [f64; 2], mut f: impl FnMut(&Obstacle)) {
        if self.obstacles.is_empty() {
            return;
        }
        let scale = lo[0].abs().max(lo[1].abs()).max(hi[0].abs()).max(hi[1].abs());
        let m = aabb_margin(scale);
        let query = Aabb::new(
            Point::new((lo[0] - m) as Real, (lo[1] - m) as Real),
            Point::new((hi[0] + m) as Real, (hi[1] + m) as Real),
        );
        for leaf in self.bvh.intersect_aabb(&query) {
            if let Some(o) = self.obstacles.get(leaf as usize) {
                f(o);
            }
        }
    }

    /// Distance from point p (world, metres) to the nearest obstacle surface (negative inside one); f64::INFINITY when there are no obstacles.
    ///
    /// Exactly `min` over obstacles of the analytic signed distance (disc: |p − c| − r;
    /// rectangle: the usual box SDF in its frame). Inside overlapping obstacles this is minus
    /// the deepest penetration. Cost: one BVH pass over the AABBs containing `p` (only those
    /// obstacles can contain it), then a best-first BVH nearest search — O(log n) typically.
    pub fn clearance(&self, p: [f64; 2]) -> f64 {
        if self.obstacles.is_empty() {
            return f64::INFINITY;
        }
        // Pass 1: obstacles that may contain p. If p is inside any, the answer is among them.
        let mut best = f64::INFINITY;
        self.for_each_in_box(p, p, |o| best = best.min(o.signed_distance(p)));
        if best <= 0.0 {
            return best;
        }
        // Pass 2: best-first nearest search; every remaining candidate has a positive distance,
        // and the distance to a loosened AABB is a lower bound for it.
        let best_cell = Cell::new(best);
        let pt = Point::new(p[0] as Real, p[1] as Real);
        let _ = self.bvh.find_best(
            Real::INFINITY,
            |node, _| node.aabb().distance_to_local_point(&pt, true),
            |leaf, _| {
                let d = self.obstacles.get(leaf as usize)?.signed_distance(p);
                if d < best_cell.get() {
                    best_cell.set(d);
                }
                Some(d as Real)
            },
        );
        best_cell.get()
    }

    /// First hit of a ray from `origin` along unit `dir` within `max_range`, as a distance.
    ///
    /// Obstacles are solid: a ray starting inside (or on) one returns `Some(0.0)`. A hit at
    /// exactly `max_range` counts. One best-first BVH traversal with analytic `f64` leaf tests.
    pub fn cast_ray(&self, origin: [f64; 2], dir: [f64; 2], max_range: f64) -> Option<f64> {
        if self.obstacles.is_empty() || max_range.is_nan() || max_range < 0.0 {
            return None;
        }
        let best = Cell::new(f64::INFINITY);
        let ray =
            Ray::new(Point::new(origin[0] as Real, origin[1] as Real), Vector::new(dir[0] as Real, dir[1] as Real));
        // The f32 bound passed to the BVH is rounded up a little so no hit ≤ max_range is pruned.
        let max_toi = (max_range + aabb_margin(max_range)) as Real;
        let _ = self.bvh.cast_ray(&ray, max_toi, |leaf, _| {
            let t = self.obstacles.get(leaf as usize)?.cast_ray(origin, dir)?;
            if t < best.get() {
                best.set(t);
            }
            Some(t as Real)
        });
        let t = best.get();
        (t <= max_range).then_some(t)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use parry2d::math::Isometry;
    use parry2d::query::RayCast;
    use parry2d::shape::{Ball, Cuboid};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    pub(crate) fn tree(x: f64, y: f64, r: f64) -> swarm_config::Tree {
        swarm_config::Tree { x, y, r }
    }

    pub(crate) fn wall(x1: f64, y1: f64, x2: f64, y2: f64, thickness: f64) -> swarm_config::Wall {
        swarm_config::Wall { x1, y1, x2, y2, thickness }
    }

    /// Clearance by brute force over every obstacle (the reference for the fast query).
    fn brute_clearance(w: &World, p: [f64; 2]) -> f64 {
        w.obstacles().iter().map(|o| sdf_reference(o, p)).fold(f64::INFINITY, f64::min)
    }

    /// A random forest with a few random walls, in the square [0, side]².
    /// `n` walls with random ends inside a `side` square, lengths up to `max_len`.
    pub(crate) fn random_walls(rng: &mut ChaCha8Rng, n: usize, side: f64, max_len: f64) -> Vec<swarm_config::Wall> {
        (0..n)
            .map(|_| {
                let (x, y) = (rng.gen_range(0.0..side), rng.gen_range(0.0..side));
                let a: f64 = rng.gen_range(0.0..std::f64::consts::TAU);
                let len = rng.gen_range(0.5..max_len);
                wall(x, y, x + len * a.cos(), y + len * a.sin(), rng.gen_range(0.05..0.5))
            })
            .collect()
    }

    fn random_world(rng: &mut ChaCha8Rng, n_trees: usize, n_walls: usize, side: f64) -> World {
        let trees = (0..n_trees)
            .map(|_| tree(rng.gen_range(0.0..side), rng.gen_range(0.0..side), rng.gen_range(0.1..0.4)))
            .collect();
        let walls = random_walls(rng, n_walls, side, 8.0);
        World::new(trees, walls)
    }

    /// Independent reference for the signed distance: a rectangle as four edge segments.
    fn sdf_reference(o: &Obstacle, p: [f64; 2]) -> f64 {
        match *o {
            Obstacle::Circle { c, r } => ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2)).sqrt() - r,
            Obstacle::Rect { c, u, hx, hy } => {
                let (lx, ly) =
                    ((p[0] - c[0]) * u[0] + (p[1] - c[1]) * u[1], -(p[0] - c[0]) * u[1] + (p[1] - c[1]) * u[0]);
                if lx.abs() <= hx && ly.abs() <= hy {
                    return -(hx - lx.abs()).min(hy - ly.abs());
                }
                let corners = o.rect_corners().unwrap_or([[0.0; 2]; 4]);
                (0..4)
                    .map(|i| {
                        let (a, b) = (corners[i], corners[(i + 1) % 4]);
                        let ab = [b[0] - a[0], b[1] - a[1]];
                        let l2 = ab[0] * ab[0] + ab[1] * ab[1];
                        let t = if l2 > 0.0 {
                            (((p[0] - a[0]) * ab[0] + (p[1] - a[1]) * ab[1]) / l2).clamp(0.0, 1.0)
                        } else {
                            0.0
                        };
                        let q = [a[0] + t * ab[0], a[1] + t * ab[1]];
                        ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt()
                    })
                    .fold(f64::INFINITY, f64::min)
            }
        }
    }

    #[test]
    fn empty_world_has_infinite_clearance_and_no_hits() {
        let w = World::new(vec![], vec![]);
        assert_eq!(w.clearance([1.0, 2.0]), f64::INFINITY);
        assert_eq!(w.cast_ray([0.0, 0.0], [1.0, 0.0], 100.0), None);
    }

    #[test]
    fn single_tree_clearance_and_ray() {
        let w = World::new(vec![tree(5.0, 0.0, 0.5)], vec![]);
        assert_eq!(w.clearance([0.0, 0.0]), 4.5);
        assert_eq!(w.clearance([5.0, 0.0]), -0.5);
        assert_eq!(w.cast_ray([0.0, 0.0], [1.0, 0.0], 12.0), Some(4.5));
        assert_eq!(w.cast_ray([0.0, 0.0], [-1.0, 0.0], 12.0), None);
        assert_eq!(w.cast_ray([0.0, 0.0], [1.0, 0.0], 4.0), None);
        assert_eq!(w.cast_ray([0.0, 0.0], [1.0, 0.0], 4.5), Some(4.5));
        assert_eq!(w.cast_ray([5.1, 0.1], [0.0, 1.0], 12.0), Some(0.0));
    }

    #[test]
    fn wall_is_a_flat_ended_rectangle() {
        // Wall along x from (0, 2) to (4, 2), thickness 0.2: occupies x∈[0,4], y∈[1.9, 2.1].
        let w = World::new(vec![], vec![wall(0.0, 2.0, 4.0, 2.0, 0.2)]);
        let hit = w.cast_ray([1.0, 0.0], [0.0, 1.0], 12.0).unwrap_or(f64::NAN);
        assert!((hit - 1.9).abs() < 1e-12, "{hit}");
        // Flat end: a ray along the axis from the left hits x = 0, not x = -0.1.
        let hit = w.cast_ray([-3.0, 2.0], [1.0, 0.0], 12.0).unwrap_or(f64::NAN);
        assert!((hit - 3.0).abs() < 1e-12, "{hit}");
        assert!((w.clearance([2.0, 0.0]) - 1.9).abs() < 1e-12);
        assert!((w.clearance([2.0, 2.05]) + 0.05).abs() < 1e-12);
        assert!((w.clearance([-3.0, 5.0]) - (3.0f64.powi(2) + 2.9f64.powi(2)).sqrt()).abs() < 1e-12);
        // Rotated 45°: the ray along the diagonal hits the near end face.
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let w = World::new(vec![], vec![wall(1.0, 1.0, 3.0, 3.0, 0.4)]);
        let hit = w.cast_ray([0.0, 0.0], [s, s], 12.0).unwrap_or(f64::NAN);
        assert!((hit - 2f64.sqrt()).abs() < 1e-12, "{hit}");
    }

    #[test]
    fn analytic_ray_tests_match_parry() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for _ in 0..2000 {
            let o = [rng.gen_range(-5.0..5.0), rng.gen_range(-5.0..5.0)];
            let a: f64 = rng.gen_range(0.0..std::f64::consts::TAU);
            let d = [a.cos(), a.sin()];
            let ray = Ray::new(Point::new(o[0] as f32, o[1] as f32), Vector::new(d[0] as f32, d[1] as f32));
            // Disc at a random place.
            let (c, r) = ([rng.gen_range(-3.0..3.0), rng.gen_range(-3.0..3.0)], rng.gen_range(0.05..1.5));
            let ours = ray_circle(o, d, c, r);
            let iso = Isometry::translation(c[0] as f32, c[1] as f32);
            let theirs = Ball::new(r as f32).cast_ray(&iso, &ray, 100.0, true);
            match (ours, theirs) {
                (Some(a), Some(b)) => assert!((a - b as f64).abs() < 1e-3, "{a} vs {b}"),
                (None, None) => {}
                // Grazing rays may disagree between f32 and f64; accept only near-tangent cases.
                (x, y) => {
                    let perp = ((o[0] - c[0]) * d[1] - (o[1] - c[1]) * d[0]).abs();
                    assert!((perp - r).abs() < 1e-4, "{x:?} vs {y:?}");
                }
            }
            // Rectangle at a random place and angle.
            let w = swarm_config::Wall {
                x1: rng.gen_range(-3.0..3.0),
                y1: rng.gen_range(-3.0..3.0),
                x2: rng.gen_range(-3.0..3.0),
                y2: rng.gen_range(-3.0..3.0),
                thickness: rng.gen_range(0.05..1.0),
            };
            let ob = Obstacle::from_wall(&w);
            let Obstacle::Rect { c, u, hx, hy } = ob else { panic!("wall is not a rect") };
            let ours = ob.cast_ray(o, d);
            let iso = Isometry::new(Vector::new(c[0] as f32, c[1] as f32), u[1].atan2(u[0]) as f32);
            let theirs = Cuboid::new(Vector::new(hx as f32, hy as f32)).cast_ray(&iso, &ray, 100.0, true);
            match (ours, theirs) {
                (Some(a), Some(b)) => assert!((a - b as f64).abs() < 1e-3, "{a} vs {b}"),
                (None, None) => {}
                (x, y) => {
                    // Near-miss at a corner: the inflated rectangle must hit, the deflated miss.
                    let big = ray_rect(o, d, c, u, hx + 1e-4, hy + 1e-4);
                    let small = ray_rect(o, d, c, u, (hx - 1e-4).max(0.0), (hy - 1e-4).max(0.0));
                    assert!(big.is_some() && small.is_none(), "{x:?} vs {y:?}");
                }
            }
        }
    }

    #[test]
    fn clearance_matches_brute_force_on_random_points() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let side = 60.0;
        let w = random_world(&mut rng, 400, 30, side);
        for _ in 0..5000 {
            let p = [rng.gen_range(-5.0..side + 5.0), rng.gen_range(-5.0..side + 5.0)];
            let fast = w.clearance(p);
            let brute = brute_clearance(&w, p);
            assert!((fast - brute).abs() < 1e-9, "at {p:?}: {fast} vs {brute}");
        }
        // Points inside trees, including overlapping ones, give the deepest penetration.
        for t in w.trees().iter().take(200) {
            let p = [t.x + 0.3 * t.r, t.y - 0.2 * t.r];
            let fast = w.clearance(p);
            let brute = brute_clearance(&w, p);
            assert!(fast < 0.0);
            assert!((fast - brute).abs() < 1e-9, "at {p:?}: {fast} vs {brute}");
        }
    }

    #[test]
    fn clearance_inside_overlapping_obstacles_is_deepest_penetration() {
        let w = World::new(vec![tree(0.0, 0.0, 1.0), tree(0.5, 0.0, 2.0)], vec![]);
        assert_eq!(w.clearance([0.0, 0.0]), -1.5);
    }

    #[test]
    fn cast_ray_matches_brute_force_on_random_rays() {
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let side = 60.0;
        let w = random_world(&mut rng, 400, 30, side);
        for _ in 0..5000 {
            let p = [rng.gen_range(-5.0..side + 5.0), rng.gen_range(-5.0..side + 5.0)];
            let a: f64 = rng.gen_range(0.0..std::f64::consts::TAU);
            let d = [a.cos(), a.sin()];
            let max_range = rng.gen_range(1.0..30.0);
            let fast = w.cast_ray(p, d, max_range);
            let brute = w.obstacles().iter().filter_map(|o| o.cast_ray(p, d)).fold(f64::INFINITY, f64::min);
            let brute = (brute <= max_range).then_some(brute);
            assert_eq!(fast, brute, "from {p:?} at {a}");
        }
    }
}

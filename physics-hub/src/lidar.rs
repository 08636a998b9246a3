//! The simulated 2D LIDAR (SPEC §3): one 360° scan per UAV per tick, in the UAV's body frame.
//!
//! This module exists because the scan is the hub's hottest path (every UAV, every tick, up to
//! 750 beams) and the only sensor through which an agent sees the forest. It is pure: the world,
//! the pose, the other UAVs, the sensor spec and the RNG come in as parameters.
//!
//! Method — obstacle rasterisation instead of 750 ray casts:
//! 1. one BVH query ([`World`]'s parry2d `Bvh`) returns the obstacles whose AABB meets the
//!    square of half-side `max_range_m` around the sensor (typically a few tens of trees);
//! 2. each candidate (and each other UAV's disc) is culled by range, and the arc of bearings
//!    it covers is computed (±asin(r/d) around the centre bearing for a disc, the extreme corner
//!    bearings for a wall rectangle), widened by one beam on each side for safety;
//! 3. only the beams inside that arc are intersected analytically with that obstacle
//!    (ray–disc quadratic, ray–rectangle slabs, both in `f64`), keeping the nearest hit per beam.
//!
//! The cost is one BVH query plus O(candidates + beams covered), independent of the number of
//! beams that see nothing, and nothing is allocated beyond `out`. The result equals a
//! brute-force per-beam ray cast against every obstacle (checked by the tests and a proptest).
//!
//! Noise and dropout (drawn after the geometry, beam by beam in ascending index): if
//! `dropout > 0`, one uniform `f64` is drawn (dropped when `< dropout`); then, if
//! `noise_std_m > 0`, one standard normal. Both are drawn for every beam whatever the geometry,
//! so the RNG stream a scan consumes depends only on the spec, and a given RNG state always
//! gives the same ranges.

use crate::body::wrap_angle;
use crate::world::{ray_circle, Obstacle, World};
use rand_distr::StandardNormal;
use std::f64::consts::TAU;

/// Casts one 360° scan. Beam i points at body angle i·2π/beams (beam 0 along the body x axis); world angle = yaw + that. Rays hit the world's obstacles AND the circles in `others` (other UAVs: [x, y, radius]; the scanning UAV itself is not in `others`). `out` is cleared and filled with `beams` ranges (f32 metres): the true hit distance plus Gaussian noise N(0, noise_std_m) clamped to ≥ 0, or f32::INFINITY for no hit within max_range or a dropout (probability `dropout`, drawn per beam). Draw order must be deterministic for a given rng state.
///
/// Obstacles are solid: a sensor inside a tree, wall or other UAV reads 0 on every beam. A hit
/// at distance ≤ `max_range_m` counts (beam directions are exact to ~1e-13 rad). RNG draws per beam, in ascending beam order: one uniform
/// `f64` if `dropout > 0`, then one standard normal if `noise_std_m > 0` (see the module docs).
/// `out` only allocates when its capacity is below `beams`.
pub fn scan(
    world: &World,
    pose: [f64; 3],
    others: &[[f64; 3]],
    spec: &swarm_config::Lidar,
    rng: &mut impl rand::Rng,
    out: &mut Vec<f32>,
) {
    out.clear();
    let beams = spec.beams as usize;
    if beams == 0 {
        return;
    }
    out.resize(beams, f32::INFINITY);
    let max_range = spec.max_range_m;
    if max_range >= 0.0 {
        let raster = Raster::new(pose, beams, max_range);
        if max_range.is_finite() {
            let (x, y) = (pose[0], pose[1]);
            world.for_each_in_box([x - max_range, y - max_range], [x + max_range, y + max_range], |o| {
                raster.obstacle(o, out)
            });
        } else {
            world.obstacles().iter().for_each(|o| raster.obstacle(o, out));
        }
        for other in others {
            raster.circle([other[0], other[1]], other[2].max(0.0), out);
        }
    }
    apply_noise_and_dropout(spec, rng, out);
}

/// Angle of beam 0 and the increment, for the Scan message: (0.0, 2π/beams).
///
/// Body frame, radians, counter-clockwise from the body x axis; `(0.0, 0.0)` when `beams == 0`.
pub fn beam_angles(spec: &swarm_config::Lidar) -> (f32, f32) {
    if spec.beams == 0 {
        return (0.0, 0.0);
    }
    (0.0, (TAU / f64::from(spec.beams)) as f32)
}

/// Per-beam noise and dropout, in ascending beam order (see the module docs for the draw order).
fn apply_noise_and_dropout(spec: &swarm_config::Lidar, rng: &mut impl rand::Rng, out: &mut [f32]) {
    let p_drop = spec.dropout;
    let sigma = spec.noise_std_m;
    let draw_drop = p_drop > 0.0;
    let draw_noise = sigma > 0.0;
    if !draw_drop && !draw_noise {
        return;
    }
    for range in out.iter_mut() {
        let dropped = draw_drop && rng.gen::<f64>() < p_drop;
        let noise = if draw_noise { sigma * rng.sample::<f64, _>(StandardNormal) } else { 0.0 };
        if dropped {
            *range = f32::INFINITY;
        } else if range.is_finite() {
            *range = (f64::from(*range) + noise).max(0.0) as f32;
        }
    }
}

/// One scan's geometry: sensor pose and beam layout, and the per-obstacle rasteriser.
struct Raster {
    /// Sensor position in the world [m].
    origin: [f64; 2],
    /// World angle of beam 0 [rad].
    yaw: f64,
    /// Beam count (> 0).
    beams: usize,
    /// Angle between beams, 2π/beams [rad].
    step: f64,
    /// cos and sin of `step`, to walk the beam directions by rotation.
    step_cos: f64,
    step_sin: f64,
    /// Hits farther than this are not seen [m].
    max_range: f64,
}

impl Raster {
    fn new(pose: [f64; 3], beams: usize, max_range: f64) -> Raster {
        let step = TAU / beams as f64;
        let (step_sin, step_cos) = step.sin_cos();
        Raster { origin: [pose[0], pose[1]], yaw: pose[2], beams, step, step_cos, step_sin, max_range }
    }

    /// Rasterises one world obstacle.
    #[inline]
    fn obstacle(&self, o: &Obstacle, out: &mut [f32]) {
        match *o {
            Obstacle::Circle { c, r } => self.circle(c, r, out),
            Obstacle::Rect { .. } => self.rect(o, out),
        }
    }

    /// Rasterises a solid disc (a tree or another UAV).
    fn circle(&self, c: [f64; 2], r: f64, out: &mut [f32]) {
        let (dx, dy) = (c[0] - self.origin[0], c[1] - self.origin[1]);
        // Same inside test as `ray_circle`, so both agree on the boundary.
        if dx * dx + dy * dy - r * r <= 0.0 {
            out.iter_mut().for_each(|v| *v = 0.0);
            return;
        }
        // A disc clearly out of reach is left before `hypot` (about half the UAVs a grid query
        // hands a scan at open-1000's density): a margin of 1e-9 on the squares is far wider than
        // their rounding, so every disc left here is one the test below would leave too.
        let reach = self.max_range + r;
        if (1e-100..=1e100).contains(&reach) && dx * dx + dy * dy > reach * reach * (1.0 + 1e-9) {
            return;
        }
        let dist = dx.hypot(dy);
        if dist - r > self.max_range {
            return;
        }
        let centre = dy.atan2(dx);
        let half = (r / dist).min(1.0).asin();
        let origin = self.origin;
        self.beams_between(centre - half, centre + half, out, |dir| ray_circle(origin, dir, c, r));
    }

    /// Rasterises a solid rectangle (a wall).
    fn rect(&self, o: &Obstacle, out: &mut [f32]) {
        let Some(corners) = o.rect_corners() else {
            return;
        };
        let sd = o.signed_distance(self.origin);
        if sd > self.max_range {
            return;
        }
        let inside = match *o {
            Obstacle::Rect { c, u, hx, hy } => {
                let (px, py) = (self.origin[0] - c[0], self.origin[1] - c[1]);
                (px * u[0] + py * u[1]).abs() <= hx && (-px * u[1] + py * u[0]).abs() <= hy
            }
            Obstacle::Circle { .. } => false,
        };
        if inside {
            out.iter_mut().for_each(|v| *v = 0.0);
            return;
        }
        // The origin is outside the convex rectangle, so the rectangle lies within less than a
        // half-turn of bearings around the bearing of its centre: measure corners from there.
        let centre = match *o {
            Obstacle::Rect { c, .. } => (c[1] - self.origin[1]).atan2(c[0] - self.origin[0]),
            Obstacle::Circle { .. } => 0.0,
        };
        let (mut lo, mut hi) = (0.0_f64, 0.0_f64);
        for k in corners {
            let bearing = (k[1] - self.origin[1]).atan2(k[0] - self.origin[0]);
            let rel = wrap_angle(bearing - centre);
            lo = lo.min(rel);
            hi = hi.max(rel);
        }
        let origin = self.origin;
        self.beams_between(centre + lo, centre + hi, out, |dir| o.cast_ray(origin, dir));
    }

    /// Runs `hit` on every beam whose world angle lies in `[lo, hi]` (widened by one beam each
    /// side), keeping the nearest hit within range per beam.
    #[inline]
    fn beams_between(&self, lo: f64, hi: f64, out: &mut [f32], hit: impl Fn([f64; 2]) -> Option<f64>) {
        let beams = self.beams as i64;
        let mut first = ((lo - self.yaw) / self.step).ceil() as i64 - 1;
        let last = ((hi - self.yaw) / self.step).floor() as i64 + 1;
        let mut count = last - first + 1;
        if count <= 0 {
            return;
        }
        if count >= beams {
            first = 0;
            count = beams;
        }
        let (mut sin, mut cos) = (self.yaw + first as f64 * self.step).sin_cos();
        let mut idx = first.rem_euclid(beams) as usize;
        for _ in 0..count {
            if let Some(t) = hit([cos, sin]) {
                if t <= self.max_range {
                    if let Some(slot) = out.get_mut(idx) {
                        let t = t as f32;
                        if t < *slot {
                            *slot = t;
                        }
                    }
                }
            }
            // Next beam direction: rotate by `step` (drift over 750 beams is ~1e-13 rad).
            (cos, sin) = (cos * self.step_cos - sin * self.step_sin, sin * self.step_cos + cos * self.step_sin);
            idx += 1;
            if idx == self.beams {
                idx = 0;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::tests::{random_walls, tree, wall};
    use proptest::prelude::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use std::f64::consts::{FRAC_PI_4, SQRT_2};

    fn spec(beams: u32, max_range_m: f64) -> swarm_config::Lidar {
        swarm_config::Lidar { beams, max_range_m, noise_std_m: 0.0, dropout: 0.0 }
    }

    fn run(world: &World, pose: [f64; 3], others: &[[f64; 3]], s: &swarm_config::Lidar) -> Vec<f32> {
        let mut rng = ChaCha8Rng::seed_from_u64(0);
        let mut out = Vec::new();
        scan(world, pose, others, s, &mut rng, &mut out);
        out
    }

    // ---- Independent brute-force reference (no shared code with the fast path) ----

    /// Classic ray–disc: t = −b − √(b² − k); 0 inside.
    fn ref_ray_disc(o: [f64; 2], d: [f64; 2], c: [f64; 2], r: f64) -> f64 {
        let (px, py) = (o[0] - c[0], o[1] - c[1]);
        if px * px + py * py <= r * r {
            return 0.0;
        }
        let b = px * d[0] + py * d[1];
        let disc = b * b - (px * px + py * py - r * r);
        if disc < 0.0 {
            return f64::INFINITY;
        }
        let t = -b - disc.sqrt();
        if t >= 0.0 {
            t
        } else {
            f64::INFINITY
        }
    }

    /// Ray against the segment a–b (parametric solve with cross products).
    fn ref_ray_segment(o: [f64; 2], d: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
        let e = [b[0] - a[0], b[1] - a[1]];
        let denom = d[0] * e[1] - d[1] * e[0];
        if denom == 0.0 {
            return f64::INFINITY; // parallel: the adjacent edges catch any hit
        }
        let ao = [a[0] - o[0], a[1] - o[1]];
        let t = (ao[0] * e[1] - ao[1] * e[0]) / denom;
        let s = (ao[0] * d[1] - ao[1] * d[0]) / denom;
        if t >= 0.0 && (0.0..=1.0).contains(&s) {
            t
        } else {
            f64::INFINITY
        }
    }

    /// Ray against a wall as a rectangle built directly from the wall's end points, with its
    /// half-extents grown by `eps` (negative shrinks): inside → 0, else nearest of 4 edges.
    fn ref_ray_wall(o: [f64; 2], d: [f64; 2], w: &swarm_config::Wall, eps: f64) -> f64 {
        let (dx, dy) = (w.x2 - w.x1, w.y2 - w.y1);
        let len = (dx * dx + dy * dy).sqrt();
        let u = if len > 0.0 { [dx / len, dy / len] } else { [1.0, 0.0] };
        let v = [-u[1], u[0]];
        let (hx, hy) = ((0.5 * len + eps).max(0.0), (0.5 * w.thickness + eps).max(0.0));
        let c = [0.5 * (w.x1 + w.x2), 0.5 * (w.y1 + w.y2)];
        let (lx, ly) = ((o[0] - c[0]) * u[0] + (o[1] - c[1]) * u[1], (o[0] - c[0]) * v[0] + (o[1] - c[1]) * v[1]);
        if lx.abs() <= hx && ly.abs() <= hy {
            return 0.0;
        }
        let k = |sx: f64, sy: f64| [c[0] + sx * hx * u[0] + sy * hy * v[0], c[1] + sx * hx * u[1] + sy * hy * v[1]];
        let ks = [k(1.0, 1.0), k(-1.0, 1.0), k(-1.0, -1.0), k(1.0, -1.0)];
        (0..4).map(|i| ref_ray_segment(o, d, ks[i], ks[(i + 1) % 4])).fold(f64::INFINITY, f64::min)
    }

    /// Brute-force scan: every beam against every tree, wall and other UAV, obstacles grown by
    /// `eps` (radius and half-extents). Direction of beam i = (cos, sin)(yaw + i·2π/beams).
    fn reference_scan(
        world: &World,
        pose: [f64; 3],
        others: &[[f64; 3]],
        s: &swarm_config::Lidar,
        eps: f64,
    ) -> Vec<f64> {
        let n = s.beams as usize;
        (0..n)
            .map(|i| {
                let a = pose[2] + i as f64 * TAU / n as f64;
                let (o, d) = ([pose[0], pose[1]], [a.cos(), a.sin()]);
                let t = world
                    .trees()
                    .iter()
                    .map(|t| ref_ray_disc(o, d, [t.x, t.y], (t.r + eps).max(0.0)))
                    .chain(world.walls().iter().map(|w| ref_ray_wall(o, d, w, eps)))
                    .chain(others.iter().map(|u| ref_ray_disc(o, d, [u[0], u[1]], (u[2] + eps).max(0.0))))
                    .fold(f64::INFINITY, f64::min);
                if t <= s.max_range_m {
                    t
                } else {
                    f64::INFINITY
                }
            })
            .collect()
    }

    /// Checks a noise-free fast scan against the reference. Growing every obstacle can only
    /// shorten a range and shrinking can only lengthen it, so the fast range must lie between
    /// the two (±`tol`); this makes grazing beams (tangent to a disc, through a corner, at
    /// exactly max range) well defined instead of flaky.
    fn check_against_reference(
        world: &World,
        pose: [f64; 3],
        others: &[[f64; 3]],
        s: &swarm_config::Lidar,
        tol: f64,
    ) -> Result<(), String> {
        let fast = run(world, pose, others, s);
        let grown = reference_scan(world, pose, others, s, 1e-6);
        let shrunk = reference_scan(world, pose, others, s, -1e-6);
        if fast.len() != s.beams as usize {
            return Err(format!("{} ranges for {} beams", fast.len(), s.beams));
        }
        for (i, &f) in fast.iter().enumerate() {
            let f = f64::from(f);
            let ok = if f.is_infinite() {
                shrunk[i].is_infinite()
            } else {
                grown[i].is_finite() && f >= grown[i] - tol && f <= shrunk[i] + tol
            };
            if !ok {
                return Err(format!("beam {i} at pose {pose:?}: fast {f}, reference in [{}, {}]", grown[i], shrunk[i]));
            }
        }
        Ok(())
    }

    fn forest(rng: &mut ChaCha8Rng, n: usize) -> (World, f64) {
        let side = (n as f64 / 0.05).sqrt();
        let trees =
            (0..n).map(|_| tree(rng.gen_range(0.0..side), rng.gen_range(0.0..side), rng.gen_range(0.1..0.4))).collect();
        (World::new(trees, vec![]), side)
    }

    // ---- Tests ----

    #[test]
    fn single_tree_straight_ahead_reads_d_minus_r() {
        let w = World::new(vec![tree(5.0, 0.0, 0.5)], vec![]);
        let out = run(&w, [0.0, 0.0, 0.0], &[], &spec(750, 12.0));
        assert_eq!(out.len(), 750);
        assert_eq!(out[0], 4.5);
        // The opposite beam sees nothing.
        assert_eq!(out[375], f32::INFINITY);
        // Exactly d − r also from elsewhere, for a few distances.
        for d in [1.0, 2.5, 7.25, 11.0] {
            let w = World::new(vec![tree(10.0 + d, -3.0, 0.25)], vec![]);
            let out = run(&w, [10.0, -3.0, 0.0], &[], &spec(360, 12.0));
            assert_eq!(out[0], (d - 0.25) as f32, "d = {d}");
        }
    }

    #[test]
    fn tree_at_45_degrees_is_hit_by_the_45_degree_beam() {
        // Disc at (4, 3), r = 1: the 45° ray (s, s) enters it at (3, 3), distance 3√2.
        let w = World::new(vec![tree(4.0, 3.0, 1.0)], vec![]);
        let out = run(&w, [0.0, 0.0, 0.0], &[], &spec(8, 12.0));
        assert!((f64::from(out[1]) - 3.0 * SQRT_2).abs() < 1e-6, "{}", out[1]);
        // And with many beams the 45° beam (index beams/8) matches the analytic distance.
        let out = run(&w, [0.0, 0.0, 0.0], &[], &spec(720, 12.0));
        assert!((f64::from(out[90]) - 3.0 * SQRT_2).abs() < 1e-6, "{}", out[90]);
        // A tree centred exactly on the 45° bearing: d − r.
        let w = World::new(vec![tree(5.0 * FRAC_PI_4.cos(), 5.0 * FRAC_PI_4.sin(), 0.3)], vec![]);
        let out = run(&w, [0.0, 0.0, 0.0], &[], &spec(8, 12.0));
        assert!((f64::from(out[1]) - 4.7).abs() < 1e-6, "{}", out[1]);
    }

    #[test]
    fn matches_brute_force_reference_in_a_random_forest() {
        let mut rng = ChaCha8Rng::seed_from_u64(42);
        let (mut w, side) = forest(&mut rng, 1000);
        // Add a few walls so rectangles are covered too.
        let walls = random_walls(&mut rng, 20, side, 10.0);
        w = World::new(w.trees().to_vec(), walls);
        for _ in 0..20 {
            let pose = [rng.gen_range(0.0..side), rng.gen_range(0.0..side), rng.gen_range(-10.0..10.0)];
            let others: Vec<[f64; 3]> =
                (0..3).map(|_| [pose[0] + rng.gen_range(-6.0..6.0), pose[1] + rng.gen_range(-6.0..6.0), 0.3]).collect();
            if let Err(e) = check_against_reference(&w, pose, &others, &spec(750, 12.0), 1e-3) {
                panic!("{e}");
            }
        }
    }

    #[test]
    fn yaw_rotates_the_scan_by_whole_beams() {
        let w = World::new(
            vec![tree(3.0, 0.5, 0.3), tree(-2.0, 4.0, 0.4), tree(0.7, -5.0, 0.2)],
            vec![wall(-6.0, -6.0, -6.0, 6.0, 0.2)],
        );
        let s = spec(360, 12.0);
        let base = run(&w, [0.0, 0.0, 0.0], &[], &s);
        for k in [1usize, 45, 90, 200, 359] {
            let yaw = k as f64 * TAU / 360.0;
            let turned = run(&w, [0.0, 0.0, yaw], &[], &s);
            for i in 0..360 {
                let (a, b) = (turned[i], base[(i + k) % 360]);
                assert!(a == b || (a - b).abs() < 1e-4, "k {k} beam {i}: {a} vs {b}");
            }
        }
    }

    #[test]
    fn another_uav_shows_up_as_a_small_obstacle() {
        let w = World::new(vec![], vec![]);
        let s = spec(360, 12.0);
        let out = run(&w, [1.0, 1.0, 0.0], &[[1.0, 4.0, 0.3]], &s);
        // Beam 90 points along +y: the UAV disc is 3 m away, radius 0.3.
        assert!((out[90] - 2.7).abs() < 1e-6, "{}", out[90]);
        let seen = out.iter().filter(|r| r.is_finite()).count();
        // asin(0.3 / 3) ≈ 5.7° each side: about 11 beams.
        assert!((9..=13).contains(&seen), "{seen}");
        assert!(run(&w, [1.0, 1.0, 0.0], &[], &s).iter().all(|r| r.is_infinite()));
    }

    #[test]
    fn beyond_max_range_is_infinite() {
        let w = World::new(vec![tree(13.0, 0.0, 0.5)], vec![wall(0.0, 20.0, 5.0, 20.0, 0.2)]);
        assert!(run(&w, [0.0, 0.0, 0.0], &[], &spec(750, 12.0)).iter().all(|r| r.is_infinite()));
        // A hit just inside the max range counts (beam directions carry ~1e-13 rad of rounding,
        // so "exactly at max range" is decided to within that).
        assert_eq!(run(&w, [0.0, 0.0, 0.0], &[], &spec(750, 12.5 + 1e-9))[0], 12.5);
        assert!(run(&w, [0.0, 0.0, 0.0], &[], &spec(750, 12.5 - 1e-9)).iter().all(|r| r.is_infinite()));
    }

    #[test]
    fn dropout_one_gives_all_infinite() {
        let w = World::new(vec![tree(2.0, 0.0, 0.5), tree(0.0, 2.0, 0.5)], vec![]);
        let s = swarm_config::Lidar { beams: 750, max_range_m: 12.0, noise_std_m: 0.02, dropout: 1.0 };
        assert!(run(&w, [0.0, 0.0, 0.0], &[], &s).iter().all(|r| *r == f32::INFINITY));
    }

    #[test]
    fn origin_inside_a_tree_reads_zero() {
        let w = World::new(vec![tree(0.1, 0.0, 0.5), tree(3.0, 0.0, 0.5)], vec![]);
        assert!(run(&w, [0.0, 0.0, 1.0], &[], &spec(750, 12.0)).iter().all(|r| *r == 0.0));
        // Inside a wall too, and inside another UAV.
        let w = World::new(vec![], vec![wall(-1.0, 0.0, 1.0, 0.0, 0.2)]);
        assert!(run(&w, [0.0, 0.05, 0.0], &[], &spec(100, 12.0)).iter().all(|r| *r == 0.0));
        let w = World::new(vec![], vec![]);
        assert!(run(&w, [0.0, 0.0, 0.0], &[[0.1, 0.0, 0.3]], &spec(100, 12.0)).iter().all(|r| *r == 0.0));
    }

    #[test]
    fn walls_are_hit_at_the_right_distance() {
        // Wall along y at x = 4 (thickness 0.2 → near face at x = 3.9), from y = -3 to 3.
        let w = World::new(vec![], vec![wall(4.0, -3.0, 4.0, 3.0, 0.2)]);
        let s = spec(360, 12.0);
        let out = run(&w, [0.0, 0.0, 0.0], &[], &s);
        for (i, &r) in out.iter().enumerate() {
            let a = i as f64 * TAU / 360.0;
            let (c, sn) = (a.cos(), a.sin());
            // Expected: the near face x = 3.9 if the crossing lies within |y| ≤ 3.
            let expected = if c > 0.0 && (3.9 * sn / c).abs() <= 3.0 { 3.9 / c } else { f64::INFINITY };
            if expected.is_finite() {
                assert!((f64::from(r) - expected).abs() < 1e-5, "beam {i}: {r} vs {expected}");
            } else {
                // The end faces at y = ±3 can be hit by beams just past the corners.
                assert!(r.is_infinite() || (f64::from(r) * sn).abs() >= 2.999, "beam {i}: {r}");
            }
        }
        assert!((out[0] - 3.9).abs() < 1e-6);
        // A diagonal wall, seen from its side, and its flat end face seen along its axis.
        let w = World::new(vec![], vec![wall(2.0, -2.0, -2.0, 2.0, 0.4)]);
        let out = run(&w, [-1.0, -1.0, FRAC_PI_4], &[], &spec(8, 12.0));
        assert!((f64::from(out[0]) - (SQRT_2 - 0.2)).abs() < 1e-6, "{}", out[0]);
        let along = run(&w, [4.0, -4.0, 3.0 * FRAC_PI_4], &[], &spec(8, 12.0));
        assert!((f64::from(along[0]) - 2.0 * SQRT_2).abs() < 1e-6, "{}", along[0]);
    }

    #[test]
    fn same_seed_gives_identical_ranges() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let (w, side) = forest(&mut rng, 300);
        let s = swarm_config::Lidar { beams: 750, max_range_m: 12.0, noise_std_m: 0.02, dropout: 0.05 };
        let pose = [side / 2.0, side / 2.0, 0.3];
        let others = [[side / 2.0 + 1.0, side / 2.0, 0.3]];
        let mut a = Vec::new();
        let mut b = Vec::new();
        scan(&w, pose, &others, &s, &mut ChaCha8Rng::seed_from_u64(9), &mut a);
        scan(&w, pose, &others, &s, &mut ChaCha8Rng::seed_from_u64(9), &mut b);
        assert_eq!(
            a.iter().map(|r| r.to_bits()).collect::<Vec<_>>(),
            b.iter().map(|r| r.to_bits()).collect::<Vec<_>>()
        );
        let mut c = Vec::new();
        scan(&w, pose, &others, &s, &mut ChaCha8Rng::seed_from_u64(10), &mut c);
        assert_ne!(a, c);
        // The stream consumed depends only on the spec: two draws per beam here.
        let mut r1 = ChaCha8Rng::seed_from_u64(9);
        scan(&w, pose, &others, &s, &mut r1, &mut c);
        let mut r2 = ChaCha8Rng::seed_from_u64(9);
        scan(&World::new(vec![], vec![]), pose, &[], &s, &mut r2, &mut c);
        assert_eq!(r1.gen::<u64>(), r2.gen::<u64>());
    }

    #[test]
    fn noise_has_the_configured_spread_and_never_goes_negative() {
        let w = World::new(vec![tree(3.0, 0.0, 0.5)], vec![]);
        let s = swarm_config::Lidar { beams: 8, max_range_m: 12.0, noise_std_m: 0.1, dropout: 0.0 };
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut out = Vec::new();
        let samples: Vec<f64> = (0..4000)
            .map(|_| {
                scan(&w, [0.0, 0.0, 0.0], &[], &s, &mut rng, &mut out);
                f64::from(out[0]) - 2.5
            })
            .collect();
        let mean = samples.iter().sum::<f64>() / samples.len() as f64;
        let std = (samples.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / samples.len() as f64).sqrt();
        assert!(mean.abs() < 0.01 && (std - 0.1).abs() < 0.01, "mean {mean} std {std}");
        // Near a surface, large noise is clamped at 0.
        let s = swarm_config::Lidar { beams: 8, max_range_m: 12.0, noise_std_m: 5.0, dropout: 0.0 };
        for _ in 0..100 {
            scan(&w, [2.4, 0.0, 0.0], &[], &s, &mut rng, &mut out);
            assert!(out[0] >= 0.0 && out[0].is_finite());
        }
    }

    #[test]
    fn beam_angles_and_zero_beams() {
        let (a0, da) = beam_angles(&spec(750, 12.0));
        assert_eq!(a0, 0.0);
        assert!((f64::from(da) - TAU / 750.0).abs() < 1e-7);
        assert_eq!(beam_angles(&spec(0, 12.0)), (0.0, 0.0));
        let mut out = vec![1.0];
        scan(&World::new(vec![], vec![]), [0.0; 3], &[], &spec(0, 12.0), &mut ChaCha8Rng::seed_from_u64(0), &mut out);
        assert!(out.is_empty());
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]
        #[test]
        fn fast_scan_matches_reference_on_small_worlds(
            trees in prop::collection::vec((-6.0..6.0f64, -6.0..6.0f64, 0.02..1.2f64), 0..12),
            walls in prop::collection::vec((-6.0..6.0f64, -6.0..6.0f64, -6.0..6.0f64, -6.0..6.0f64, 0.01..0.8f64), 0..4),
            others in prop::collection::vec((-6.0..6.0f64, -6.0..6.0f64, 0.05..0.5f64), 0..3),
            pose in (-6.0..6.0f64, -6.0..6.0f64, -20.0..20.0f64),
            beams in 1u32..400,
            max_range in 0.2..15.0f64,
        ) {
            let w = World::new(
                trees.iter().map(|&(x, y, r)| tree(x, y, r)).collect(),
                walls.iter().map(|&(x1, y1, x2, y2, t)| wall(x1, y1, x2, y2, t)).collect(),
            );
            let others: Vec<[f64; 3]> = others.iter().map(|&(x, y, r)| [x, y, r]).collect();
            let res = check_against_reference(&w, [pose.0, pose.1, pose.2], &others, &spec(beams, max_range), 1e-3);
            prop_assert!(res.is_ok(), "{:?}", res);
        }
    }
}

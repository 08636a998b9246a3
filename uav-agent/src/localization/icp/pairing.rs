//! The nearest-neighbour pairing of one ICP iteration (seed 000, Algorithm 1 `pairing`, and the
//! sort of Algorithm 3): every moved source point with its nearest reference point, sorted by
//! distance.
//!
//! Why a module of its own: it is where a crowd's short ICPs spend most of their time (`perf` of
//! a forest-1000-icp agent host: the pairing's search 15 % of its CPU and its sort 13 %, before
//! this module's shortcuts), and both shortcuts below rest on arguments of their own that the
//! rest of the ICP need not know: the pairs come out bit for bit as a brute-force search over
//! every reference point and a sort would give them.
//!
//! - The search. A first pairing searches every reference point, a block of source points at a
//!   time ([`pair_into`]). A later iteration moves the source a little, so each source point is
//!   first tried against its partner of the iteration before ([`Pairing::pair_from`]): a
//!   reference point r is the only nearest of every point closer to it than half the distance
//!   to r's nearest other reference point (any other one is then farther by the triangle
//!   inequality). Within that safe radius, less a relative margin of 10⁻⁶ that covers rounding
//!   many times over, the guess is the pair the search would find, with the same distance
//!   computed by the same operations. The points outside it are searched as before. The
//!   radii cost about a search, so they are kept for the one reference set that recurs across
//!   ICP runs (a step's tracked neighbours all pair with the agent's own set), and none is
//!   trusted where a squared gap leaves the normal floats.
//! - The sort. Pairs go by distance, ties by source index ([`pair_order`]): one total order, so
//!   the result does not depend on where the sort starts. A later iteration starts from the order
//!   of the one before, and an insertion sort finishes it in about one pass ([`order_pairs`]).
//!   Without exact ties this is the order of the sort used before; with them, that sort's order
//!   was unspecified, and the kept pairs' sums in `alignment` follow the order.

use super::network::LANES;
use nalgebra::Point2;

/// One pair of the nearest-neighbour pairing (seed 000 eq. 3.17).
#[derive(Debug, Clone, Copy)]
pub(super) struct Pair {
    /// Squared distance d² between the transformed source point and its reference point.
    pub(super) d2: f64,
    /// Index into the source set.
    pub(super) s: usize,
    /// Index into the reference set.
    pub(super) r: usize,
}

/// Source points searched together by [`pair_into`] (see `grid`'s `BLOCK`).
const BLOCK: usize = LANES;

/// Relative margin on a safe radius (module doc): far wider than the rounding of any squared
/// distance, far narrower than what it gives away.
const SAFE_MARGIN: f64 = 1e-6;

/// Pairs every moved source point with its nearest reference point (seed 000, Algorithm 1
/// `pairing`), in source order: `out[s]` is source point s's pair, and the nearest is the first
/// reference point of least distance. [`order_pairs`] sorts them.
#[multiversion::multiversion(targets("x86_64+avx512f+avx512vl", "x86_64+avx2"))]
pub(super) fn pair_into(reference: &[Point2<f64>], moved: &[Point2<f64>], out: &mut Vec<Pair>) {
    out.clear();
    // Source points in blocks of BLOCK lanes (the last block padded with copies of the last
    // point, dropped); each lane keeps the first reference point of least distance, as a
    // point-by-point loop would.
    for (b, chunk) in moved.chunks(BLOCK).enumerate() {
        let last = chunk[chunk.len() - 1];
        let (mut qx, mut qy) = ([last.x; BLOCK], [last.y; BLOCK]);
        for (l, q) in chunk.iter().enumerate() {
            (qx[l], qy[l]) = (q.x, q.y);
        }
        let mut best = [f64::INFINITY; BLOCK];
        let mut at = [0usize; BLOCK];
        block_nearest(reference, &qx, &qy, &mut best, &mut at);
        out.extend((0..chunk.len()).map(|l| Pair { d2: best[l], s: b * BLOCK + l, r: at[l] }));
    }
}

/// Each lane's nearest reference point to (`qx[l]`, `qy[l]`): its squared distance (+∞ with
/// none) and the index of the first reference point of least distance, one block of lanes
/// searched against every point ([`pair_into`]'s search, and the localization budget's check in
/// `alignment`, which reads only the distances), into `best` and `at` (given as +∞, and
/// overwritten: 0 where no distance is below +∞).
/// Written into the caller's arrays rather than returned as a pair: returned, the AVX2 build of
/// the short ICP took 4.67 µs instead of 3.78 at 45 points (3.65 with this loop written out in
/// `pair_into`; `cargo bench -p uav-agent --bench icp -- short`).
#[inline(always)]
pub(super) fn block_nearest(
    reference: &[Point2<f64>],
    qx: &[f64; BLOCK],
    qy: &[f64; BLOCK],
    best: &mut [f64; BLOCK],
    at: &mut [usize; BLOCK],
) {
    // The index kept as a float, exact below 2^53, so that a lane's pick is one blend of
    // vectors: kept as integers, the compiler tested the lanes one by one.
    let mut found = [0.0; BLOCK];
    for (r, a) in reference.iter().enumerate() {
        let rf = r as f64;
        for l in 0..BLOCK {
            let d2 = distance2(*a, qx[l], qy[l]);
            let closer = d2 < best[l];
            best[l] = if closer { d2 } else { best[l] };
            found[l] = if closer { rf } else { found[l] };
        }
    }
    *at = found.map(|r| r as usize);
}

/// seed 000, eq. 3.17 squared: d² = ‖p − µ(p)‖², from reference point `a` to (`qx`, `qy`). The
/// one formula of every pairing and of the full grid's search over every point, so a guessed
/// pair has the distance the search would compute.
#[inline(always)]
pub(super) fn distance2(a: Point2<f64>, qx: f64, qy: f64) -> f64 {
    let (dx, dy) = (a.x - qx, a.y - qy);
    dx * dx + dy * dy
}

/// The order of a pairing (seed 000, Algorithm 3 `QuickSort(D)`): by distance, ties by source
/// index. Squared distances are ≥ +0, so their bit patterns sort as `f64::total_cmp` does. As
/// one 128-bit number (the bits, then the index), compared without a branch: as a pair of
/// integers, the short ICP took 2.85 and 2.83 µs against 2.64 and 2.76, alternated (`cargo bench
/// -p uav-agent --bench icp -- short_45`).
pub(super) fn pair_order(q: &Pair) -> u128 {
    (u128::from(q.d2.to_bits()) << 64) | q.s as u128
}

/// Sorts the pairing `by_source` (in source order) into `out` by [`pair_order`]. When `hint` is
/// a sorted pairing of the same source set (the previous iteration's), `out` starts in its order
/// and an insertion sort finishes it; otherwise the pairs are sorted from source order.
pub(super) fn order_pairs(by_source: &[Pair], hint: &[Pair], out: &mut Vec<Pair>) {
    out.clear();
    if hint.len() != by_source.len() {
        out.extend_from_slice(by_source);
        out.sort_unstable_by_key(pair_order);
        return;
    }
    out.extend(hint.iter().map(|h| by_source[h.s]));
    for i in 1..out.len() {
        let q = out[i];
        let key = pair_order(&q);
        let mut j = i;
        while j > 0 && pair_order(&out[j - 1]) > key {
            out[j] = out[j - 1];
            j -= 1;
        }
        out[j] = q;
    }
}

/// The buffers of the pairings of one ICP run, and the safe radii of the last reference set.
#[derive(Debug, Default)]
pub(super) struct Pairing {
    /// A pairing in source order, before [`order_pairs`] sorts it.
    by_source: Vec<Pair>,
    /// The reference set `safe2` was computed for (compared bit for bit before each use).
    reference: Vec<Point2<f64>>,
    /// The reference set of the last pairing that found no radii, and the run it came in
    /// ([`Pairing::safe_radii`]).
    asked: Vec<Point2<f64>>,
    asked_in: u64,
    /// ICP runs begun ([`Pairing::begin_run`]).
    run: u64,
    /// Per reference point, the squared safe radius (module doc); 0 where none is safe.
    safe2: Vec<f64>,
    /// The source points whose guess missed, and their indices and pairs.
    missed: Vec<usize>,
    missed_points: Vec<Point2<f64>>,
    missed_pairs: Vec<Pair>,
}

impl Pairing {
    /// The sorted pairing of `moved` with `reference` into `out`. `hint`: the sorted pairing of
    /// the same source set in the iteration before, or empty for a first pairing.
    pub(super) fn pair(
        &mut self,
        reference: &[Point2<f64>],
        moved: &[Point2<f64>],
        hint: &[Pair],
        out: &mut Vec<Pair>,
    ) {
        if hint.len() == moved.len() {
            self.pair_from(reference, moved, hint);
        } else {
            pair_into(reference, moved, &mut self.by_source);
        }
        order_pairs(&self.by_source, hint, out);
    }

    /// Fills `by_source` trying each source point's partner in `hint` first (module doc), or
    /// searching every reference point while `reference` has no safe radii ([`Self::safe_radii`]).
    fn pair_from(&mut self, reference: &[Point2<f64>], moved: &[Point2<f64>], hint: &[Pair]) {
        if !self.safe_radii(reference) {
            pair_into(reference, moved, &mut self.by_source);
            return;
        }
        self.by_source.clear();
        self.by_source.resize(moved.len(), Pair { d2: f64::NAN, s: usize::MAX, r: 0 });
        self.missed.clear();
        for h in hint {
            debug_assert!(h.s < moved.len() && h.r < reference.len(), "a pairing of this source and reference");
            let q = moved[h.s];
            let d2 = distance2(reference[h.r], q.x, q.y);
            if d2 < self.safe2[h.r] {
                self.by_source[h.s] = Pair { d2, s: h.s, r: h.r };
            } else {
                self.missed.push(h.s);
            }
        }
        if !self.missed.is_empty() {
            self.missed_points.clear();
            self.missed_points.extend(self.missed.iter().map(|&s| moved[s]));
            pair_into(reference, &self.missed_points, &mut self.missed_pairs);
            for p in &self.missed_pairs {
                let s = self.missed[p.s];
                self.by_source[s] = Pair { d2: p.d2, s, r: p.r };
            }
        }
        debug_assert!(self.by_source.iter().enumerate().all(|(s, p)| p.s == s), "every source point paired once");
    }

    /// Starts an ICP run: its pairings share one source set and one reference set.
    pub(super) fn begin_run(&mut self) {
        self.run += 1;
    }

    /// Whether `safe2` holds the safe radii of `reference`, computing them if an earlier ICP run
    /// asked for the same set last. Why only then: the radii cost about as much as a pairing's
    /// search, and pay off over many runs with one reference set, as a step's short ICPs of
    /// tracked neighbours all pair with the agent's own set; each of findBestMatch's short ICPs
    /// pairs with another entry's set, in one run, and leaves the own set's radii in place.
    fn safe_radii(&mut self, reference: &[Point2<f64>]) -> bool {
        if same_points(&self.reference, reference) {
            return true;
        }
        if !same_points(&self.asked, reference) {
            self.asked.clear();
            self.asked.extend_from_slice(reference);
            self.asked_in = self.run;
            return false;
        }
        if self.asked_in == self.run {
            return false;
        }
        self.reference.clear();
        self.reference.extend_from_slice(reference);
        self.safe2.clear();
        self.safe2.extend(reference.iter().enumerate().map(|(i, a)| safe_radius2(reference, i, *a)));
        true
    }
}

/// Whether two point sets are the same, bit for bit.
fn same_points(a: &[Point2<f64>], b: &[Point2<f64>]) -> bool {
    let bits = |p: &Point2<f64>| (p.x.to_bits(), p.y.to_bits());
    a.len() == b.len() && a.iter().zip(b).all(|(p, q)| bits(p) == bits(q))
}

/// The squared safe radius of `reference[i]` = `a` (module doc; not in seed 000): a quarter of
/// the squared distance to its nearest other point, less [`SAFE_MARGIN`]. 0 (nothing is safe)
/// where that distance is not well inside the range of normal floats, where the margin would
/// no longer cover rounding: below 10⁻²⁰⁰ m² (subnormal squares) or infinite (an overflowed
/// square, or no other point). NaN coordinates are skipped, as the search never picks them.
fn safe_radius2(reference: &[Point2<f64>], i: usize, a: Point2<f64>) -> f64 {
    let nearest_other = reference
        .iter()
        .enumerate()
        .filter(|&(j, _)| j != i)
        .map(|(_, b)| distance2(*b, a.x, a.y))
        .fold(f64::INFINITY, f64::min);
    if (1e-200..f64::INFINITY).contains(&nearest_other) {
        0.25 * nearest_other * (1.0 - SAFE_MARGIN)
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::localization::icp::alignment::tests::{config, Rng};
    use proptest::prelude::*;

    fn key(v: &[Pair]) -> Vec<(u64, usize, usize)> {
        v.iter().map(|q| (q.d2.to_bits(), q.s, q.r)).collect()
    }

    /// The pairing a point-by-point loop over every reference point gives, sorted.
    fn brute(reference: &[Point2<f64>], moved: &[Point2<f64>]) -> Vec<Pair> {
        let mut want = Vec::new();
        for (s, q) in moved.iter().enumerate() {
            let (mut best, mut r_best) = (f64::INFINITY, 0);
            for (r, a) in reference.iter().enumerate() {
                let d2 = (a.x - q.x) * (a.x - q.x) + (a.y - q.y) * (a.y - q.y);
                if d2 < best {
                    (best, r_best) = (d2, r);
                }
            }
            want.push(Pair { d2: best, s, r: r_best });
        }
        want.sort_by(|a, b| a.d2.total_cmp(&b.d2).then(a.s.cmp(&b.s)));
        want
    }

    /// `n` points scattered over a 20 m square, or on a grid of whole metres where many
    /// distances tie (the first reference point of least distance wins).
    fn points(rng: &mut Rng, n: usize, grid: bool) -> Vec<Point2<f64>> {
        (0..n)
            .map(|_| {
                if grid {
                    Point2::new(rng.range(-4.0, 4.0).round(), rng.range(-4.0, 4.0).round())
                } else {
                    Point2::new(rng.range(-10.0, 10.0), rng.range(-10.0, 10.0))
                }
            })
            .collect()
    }

    proptest! {
        #![proptest_config(config(256))]

        /// The first pairing, source points in SIMD blocks, equals bit for bit (distances,
        /// indices, order) the point-by-point loop's, sorted by distance then source index.
        #[test]
        fn prop_first_pairing_is_the_point_by_point_loop(seed in any::<u64>(), n_ref in 1usize..50, n_src in 1usize..50, grid in any::<bool>()) {
            let mut rng = Rng(seed);
            let reference = points(&mut rng, n_ref, grid);
            let moved = points(&mut rng, n_src, grid);
            let mut got = Vec::new();
            Pairing::default().pair(&reference, &moved, &[], &mut got);
            prop_assert_eq!(key(&got), key(&brute(&reference, &moved)));
        }

        /// A later pairing, from any earlier pairing of the same source set as its hint (guessed
        /// partners near and far, on their safe radius, duplicates and grids full of ties in the
        /// reference set), equals the point-by-point loop's bit for bit, in the run that finds
        /// no safe radii yet and in the next, which computes and uses them.
        #[test]
        fn prop_hinted_pairing_is_the_point_by_point_loop(
            seed in any::<u64>(), n_ref in 1usize..50, n_src in 1usize..50, grid in any::<bool>(), jitter in 0.0f64..3.0,
        ) {
            let mut rng = Rng(seed);
            let reference = points(&mut rng, n_ref, grid);
            let before = points(&mut rng, n_src, grid);
            // The next iteration: every point moved a little, one of them halfway between two
            // reference points (on both safe radii, if they are each other's nearest).
            let mut moved: Vec<Point2<f64>> =
                before.iter().map(|q| Point2::new(q.x + rng.range(-jitter, jitter), q.y + rng.range(-jitter, jitter))).collect();
            if n_ref >= 2 {
                let (a, b) = (reference[0], reference[1]);
                moved[0] = Point2::new(0.5 * (a.x + b.x), 0.5 * (a.y + b.y));
            }
            let mut pairing = Pairing::default();
            let (mut hint, mut got) = (Vec::new(), Vec::new());
            for run in 0..2 {
                pairing.begin_run();
                pairing.pair(&reference, &before, &[], &mut hint);
                pairing.pair(&reference, &moved, &hint, &mut got);
                prop_assert_eq!(same_points(&pairing.reference, &reference), run == 1, "radii from the second run on");
                prop_assert_eq!(key(&got), key(&brute(&reference, &moved)));
            }
        }

        /// Sorting a pairing from any earlier pairing's order gives the order sorted from
        /// scratch, ties (a grid) included.
        #[test]
        fn prop_hinted_order_is_the_sorted_order(seed in any::<u64>(), n in 1usize..60, grid in any::<bool>()) {
            let mut rng = Rng(seed);
            let d2 = |rng: &mut Rng| if grid { rng.range(0.0, 4.0).round() } else { rng.range(0.0, 30.0) };
            let by_source: Vec<Pair> = (0..n).map(|s| Pair { d2: d2(&mut rng), s, r: s % 7 }).collect();
            let earlier: Vec<Pair> = (0..n).map(|s| Pair { d2: d2(&mut rng), s, r: 0 }).collect();
            let mut hint = Vec::new();
            order_pairs(&earlier, &[], &mut hint);
            let (mut cold, mut warm) = (Vec::new(), Vec::new());
            order_pairs(&by_source, &[], &mut cold);
            order_pairs(&by_source, &hint, &mut warm);
            prop_assert_eq!(key(&warm), key(&cold));
            prop_assert!(cold.windows(2).all(|w| pair_order(&w[0]) < pair_order(&w[1])));
        }
    }

    /// Two runs with one reference set: the second computes its safe radii.
    fn with_radii(reference: &[Point2<f64>]) -> Pairing {
        let mut pairing = Pairing::default();
        for _ in 0..2 {
            pairing.begin_run();
            pairing.safe_radii(reference);
        }
        assert!(same_points(&pairing.reference, reference));
        pairing
    }

    /// A source point right on its partner, and one just outside every safe radius: both pairs
    /// are the search's, and the safe radius is half the gap to the nearest other point.
    #[test]
    fn safe_radius_is_half_the_gap_less_the_margin() {
        let reference = [Point2::new(0.0, 0.0), Point2::new(2.0, 0.0), Point2::new(0.0, 10.0)];
        let mut pairing = with_radii(&reference);
        assert!((pairing.safe2[0] - 1.0).abs() < 1e-5 && pairing.safe2[0] < 1.0);
        assert!((pairing.safe2[2] - 25.0).abs() < 1e-4 && pairing.safe2[2] < 25.0);
        let hint = [Pair { d2: 0.0, s: 0, r: 0 }, Pair { d2: 0.0, s: 1, r: 0 }];
        let moved = [Point2::new(0.0, 0.0), Point2::new(1.0, 0.0)];
        pairing.pair_from(&reference, &moved, &hint);
        assert_eq!(pairing.missed, vec![1], "1 m out is on the safe radius, not inside it");
        assert_eq!((pairing.by_source[1].r, pairing.by_source[1].d2), (0, 1.0), "the search's pair: the first of two");
    }

    /// A reference set that differs from the one with radii in one coordinate is another set:
    /// its point moved next to the source point is found, not the stale guess.
    #[test]
    fn a_set_changed_in_one_coordinate_has_no_radii() {
        let mut reference = vec![Point2::new(0.0, 0.0), Point2::new(0.15, 10.0), Point2::new(20.0, 0.0)];
        let moved = [Point2::new(0.1, 0.0)];
        let hint = [Pair { d2: 0.0, s: 0, r: 0 }];
        let mut pairing = with_radii(&reference);
        let mut got = Vec::new();
        pairing.pair(&reference, &moved, &hint, &mut got);
        assert_eq!(got[0].r, 0);
        reference[1].y = 0.0;
        pairing.begin_run();
        pairing.pair(&reference, &moved, &hint, &mut got);
        assert_eq!(got[0].r, 1, "0.05 m away, against 0.1 m");
    }

    /// findBestMatch's pattern: runs on other sets, one run each, keep the own set's radii.
    #[test]
    fn a_set_of_one_run_does_not_evict_the_radii() {
        let own = [Point2::new(0.0, 0.0), Point2::new(3.0, 0.0), Point2::new(0.0, 4.0)];
        let mut pairing = with_radii(&own);
        for k in 1..4 {
            let other = [Point2::new(f64::from(k), 0.0), Point2::new(5.0, 1.0), Point2::new(2.0, 7.0)];
            pairing.begin_run();
            assert!(!pairing.safe_radii(&other) && !pairing.safe_radii(&other), "not within its run");
        }
        assert!(same_points(&pairing.reference, &own));
    }

    /// Where the squared gap leaves the normal floats (overflow to +inf, or subnormal), nothing
    /// is safe: the margin no longer covers rounding there, and the search decides.
    #[test]
    fn no_safe_radius_outside_normal_floats() {
        let huge = [Point2::new(0.0, 0.0), Point2::new(2e154, 0.0), Point2::new(0.0, 2e154)];
        assert_eq!(safe_radius2(&huge, 0, huge[0]), 0.0);
        let mut pairing = with_radii(&huge);
        let mut got = Vec::new();
        pairing.pair(&huge, &[Point2::new(1.3e154, 0.0)], &[Pair { d2: 0.0, s: 0, r: 0 }], &mut got);
        assert_eq!(got[0].r, 1, "the search's nearest, not the guess");
        let tiny = [Point2::new(0.0, 0.0), Point2::new(5e-162, 0.0), Point2::new(1.0, 1.0)];
        assert_eq!(safe_radius2(&tiny, 0, tiny[0]), 0.0);
        let single = [Point2::new(1.0, 2.0)];
        assert_eq!(safe_radius2(&single, 0, single[0]), 0.0, "no other point: searched (one point)");
        let three = [Point2::new(0.0, 0.0), Point2::new(3.0, 0.0), Point2::new(0.0, 4.0)];
        assert_eq!(safe_radius2(&three, 0, three[0]), 0.25 * 9.0 * (1.0 - SAFE_MARGIN));
    }
}

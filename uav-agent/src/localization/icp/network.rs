//! The full-grid ICP's first-pass score of eight starts at once: their nearest distances sorted
//! by one sorting network run on SIMD lanes, then eq. 3.16's best prefix, lane by lane.
//!
//! Why this module exists: the first pass scores 7056 starts per full grid (21×21 cells × 16
//! headings, seed 000 5.1), and each score needs its start's squared nearest distances in order.
//! A comparison sort of 20–50 values per start spends most of its time on mispredicted branches:
//! `perf` put the sorts at a third of the agents' CPU at 1000 UAVs. A sorting network does the
//! same comparisons whatever the data, so the eight cells of a block ([`super::grid`]'s
//! `BLOCK`) go through it together, one lane each, as packed minimum and maximum instructions
//! with no branch at all (a full grid of 20 points a side: 2.17 → 0.90 ms, `cargo bench -p
//! uav-agent --bench icp`).
//!
//! The scores are bit for bit the ones of the sort and [`super::alignment`]'s `best_prefix`:
//! sorting leaves the same values in the same order whatever the method (equal values are equal
//! bits: the distances are ≥ +0 and never −0), and the prefix sums and weights are then computed
//! with the same operations in the same order. A block holding a NaN (only from absurd input) is
//! left to the caller's scalar path, since a minimum instruction does not order NaN the way
//! `f64::total_cmp` does.
//!
//! The network is Batcher's odd–even merge sort for the next power of two, with every comparator
//! that touches a position beyond the real length dropped: padding positions would hold +∞, and
//! a comparator of a finite value with +∞ changes nothing, so the padding need not exist.

/// Lanes per block: eight starts (cells) scored together.
pub(super) const LANES: usize = 8;

/// A sorting network on `len` positions: compare-exchanges `(i, j)`, i < j, applied in order,
/// leave the smaller value at `i`.
#[derive(Debug, Clone)]
pub(super) struct Network {
    len: usize,
    pairs: Vec<(u16, u16)>,
}

impl Network {
    /// Batcher's odd–even merge sort on `len` positions (`len` ≤ 65 535).
    pub(super) fn new(len: usize) -> Network {
        let padded = len.next_power_of_two();
        let mut pairs = Vec::new();
        let mut p = 1;
        while p < padded {
            let mut k = p;
            while k >= 1 {
                let mut j = k % p;
                while j + k < padded {
                    for i in 0..k.min(padded - j - k) {
                        // Only elements of the same merge (blocks of 2p) are compared.
                        if (i + j) / (2 * p) == (i + j + k) / (2 * p) && i + j + k < len {
                            pairs.push(((i + j) as u16, (i + j + k) as u16));
                        }
                    }
                    j += 2 * k;
                }
                k /= 2;
            }
            p *= 2;
        }
        Network { len, pairs }
    }

    /// Positions sorted.
    pub(super) fn len(&self) -> usize {
        self.len
    }
}

/// Sorts each lane of `rows` (row = position, column = lane) ascending by the network. NaN-free
/// input only (see the module docs).
#[inline(always)]
fn sort_lanes(rows: &mut [[f64; LANES]], net: &Network) {
    for &(i, j) in &net.pairs {
        let (lo, hi) = rows.split_at_mut(usize::from(j));
        let (a, b) = (&mut lo[usize::from(i)], &mut hi[0]);
        // `min`/`max`, not a select on `<`: the compiler turns a select that keeps `a`'s own
        // value into a masked store, whose reload then stalls (measured: twice the time).
        let (x, y) = (*a, *b);
        *a = std::array::from_fn(|l| x[l].min(y[l]));
        *b = std::array::from_fn(|l| x[l].max(y[l]));
    }
}

/// First-pass scores of a block: for each lane, FRMSD² of its best prefix (seed 000 eq. 3.16
/// squared, ties within `tie2` to the longer prefix), exactly as `best_prefix` computes it on the
/// sorted distances. `rows` are `net.len()` positions of squared nearest distances, sorted in
/// place; `None` when a lane holds a NaN (the caller then scores the block one start at a time).
///
/// Compiled for AVX2 but not AVX-512, unlike the nearest-neighbour kernels: with AVX-512 the full
/// grid took 7 % longer at 20 points a side and 28 % longer at 12 and 16 (`cargo bench -p
/// uav-agent --bench icp`, Zen 4), for 3 % less at 45.
#[multiversion::multiversion(targets("x86_64+avx2"))]
pub(super) fn block_scores(
    rows: &mut [[f64; LANES]],
    net: &Network,
    weights: &[f64],
    k_min: usize,
    tie2: f64,
) -> Option<[f64; LANES]> {
    debug_assert_eq!(rows.len(), net.len());
    if rows.iter().flatten().any(|d| d.is_nan()) {
        return None;
    }
    sort_lanes(rows, net);
    let mut cum = [0.0; LANES];
    let mut best = [f64::INFINITY; LANES];
    for (i, (row, &w)) in rows.iter().zip(weights).enumerate() {
        for l in 0..LANES {
            cum[l] += row[l];
        }
        if i + 1 >= k_min {
            for l in 0..LANES {
                // seed 000, eq. 3.16 squared: FRMSD_i² = f^(−2λ)/i · Σ_{k≤i} d_k².
                let f2 = w * cum[l];
                best[l] = if f2 <= best[l] + tie2 { f2 } else { best[l] };
            }
        }
    }
    Some(best)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Every 0/1 input of up to 16 positions comes out sorted: by the 0–1 principle, the network
    /// then sorts any input of that length.
    #[test]
    fn sorts_every_zero_one_input() {
        for len in 1..=16 {
            let net = Network::new(len);
            for bits in 0u32..(1 << len) {
                let mut rows: Vec<[f64; LANES]> = (0..len).map(|p| [f64::from((bits >> p) & 1); LANES]).collect();
                sort_lanes(&mut rows, &net);
                assert!(rows.windows(2).all(|w| w[0][0] <= w[1][0]), "len {len}, input {bits:b}");
            }
        }
    }

    #[test]
    fn comparators_stay_inside_the_real_length() {
        for len in [1, 2, 3, 7, 20, 33, 45, 64, 100] {
            let net = Network::new(len);
            assert!(net.pairs.iter().all(|&(i, j)| i < j && usize::from(j) < len), "len {len}");
        }
        assert!(Network::new(1).pairs.is_empty());
    }

    fn distances(max: usize) -> impl Strategy<Value = Vec<[f64; LANES]>> {
        // Few distinct values, so ties are common; +∞ and exact zeros included.
        let value = prop_oneof![
            8 => (0u32..40).prop_map(|k| f64::from(k) * 0.25),
            2 => 0.0..500.0f64,
            1 => Just(f64::INFINITY),
        ];
        (1..=max).prop_flat_map(move |len| proptest::collection::vec(proptest::array::uniform8(value.clone()), len))
    }

    proptest! {
        /// Each lane sorts to exactly the bits `sort_unstable_by(total_cmp)` gives.
        #[test]
        fn prop_lanes_sort_as_total_cmp(mut rows in distances(70)) {
            let net = Network::new(rows.len());
            let want: Vec<Vec<u64>> = (0..LANES)
                .map(|l| {
                    let mut v: Vec<f64> = rows.iter().map(|r| r[l]).collect();
                    v.sort_unstable_by(f64::total_cmp);
                    v.into_iter().map(f64::to_bits).collect()
                })
                .collect();
            sort_lanes(&mut rows, &net);
            for (l, want) in want.iter().enumerate() {
                let got: Vec<u64> = rows.iter().map(|r| r[l].to_bits()).collect();
                prop_assert_eq!(&got, want, "lane {}", l);
            }
        }
    }

    #[test]
    fn a_nan_leaves_the_block_to_the_caller() {
        let mut rows = vec![[1.0; LANES]; 5];
        rows[3][6] = f64::NAN;
        assert_eq!(block_scores(&mut rows, &Network::new(5), &[1.0; 5], 3, 0.0), None);
    }
}

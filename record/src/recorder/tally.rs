//! A multiset of sampled values kept as a count per distinct value, with the running sum of the
//! finite ones: the recorder's mean and nearest-rank quantile of a quantity that takes few
//! distinct values, in memory that does not grow with the run.
//!
//! Why: the recorder kept every neighbour estimate's information age and every delivered share's
//! delay as an `f64` to take their 95th percentile at the end. At 1000 UAVs on the ICP stack
//! that is about a million values per sim second (`forest-1000-icp`: 68 shares delivered and 31
//! estimates per agent and tick), 8 MB a sim second, most of the recorder's growth, and the end
//! of a long run sorted copies of them. Both quantities are `f32` on the wire and move in steps
//! of the tick, so they repeat a few values over and over: their memory is one entry per distinct
//! value, not one per sample.
//!
//! The quantile is exactly the one of the sorted values (`f64::total_cmp` order, nearest rank).
//! The mean sums the finite values as they come, so one tally's mean is the one of its values in
//! arrival order; tallies merged add their sums, which equals one sum of all the values whenever
//! those sums are exact (`f32` values summed in `f64`, as ages and delays are, up to about a
//! million of them with a spread of exponents) and differs in the last bits beyond.

use std::collections::BTreeMap;

/// A multiset of `f64` values (see the module docs).
#[derive(Debug, Default, Clone)]
pub struct Tally {
    /// Values by their [`order_key`], with how many times each came.
    counts: BTreeMap<i64, u64>,
    /// Values pushed.
    len: u64,
    /// Sum of the finite values, in arrival order.
    sum_finite: f64,
    /// How many values were finite.
    finite: u64,
}

/// A key whose integer order is `f64::total_cmp`'s (the sign bit flips the rest for negatives),
/// and which gives the value back bit for bit.
fn order_key(x: f64) -> i64 {
    let b = x.to_bits() as i64;
    b ^ (((b >> 63) as u64) >> 1) as i64
}

/// The value of an [`order_key`].
fn from_key(k: i64) -> f64 {
    f64::from_bits((k ^ (((k >> 63) as u64) >> 1) as i64) as u64)
}

impl Tally {
    /// Counts one value.
    pub fn push(&mut self, x: f64) {
        *self.counts.entry(order_key(x)).or_default() += 1;
        self.len += 1;
        if x.is_finite() {
            self.sum_finite += x;
            self.finite += 1;
        }
    }

    /// How many values were pushed.
    #[cfg(test)]
    pub fn len(&self) -> u64 {
        self.len
    }

    /// Mean of the finite values, NaN if none.
    pub fn mean_finite(&self) -> f64 {
        if self.finite == 0 {
            f64::NAN
        } else {
            self.sum_finite / self.finite as f64
        }
    }

    /// The `q`-quantile (nearest rank) of the values in `f64::total_cmp` order, NaN if none.
    pub fn quantile(&self, q: f64) -> f64 {
        if self.len == 0 {
            return f64::NAN;
        }
        let rank = ((q * self.len as f64).ceil() as u64).clamp(1, self.len);
        let mut seen = 0;
        for (&k, &c) in &self.counts {
            seen += c;
            if seen >= rank {
                return from_key(k);
            }
        }
        f64::NAN
    }

    /// Adds `other`'s values (its sum after this one's: see the module docs).
    pub fn merge(&mut self, other: &Tally) {
        for (&k, &c) in &other.counts {
            *self.counts.entry(k).or_default() += c;
        }
        self.len += other.len;
        self.sum_finite += other.sum_finite;
        self.finite += other.finite;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The recorder's way for values kept one by one (its localization errors).
    fn quantile_of(v: &[f64], q: f64) -> f64 {
        super::super::metrics::quantile(v, q)
    }

    fn mean_of(v: &[f64]) -> f64 {
        super::super::metrics::mean_finite(v.iter().copied())
    }

    fn special() -> impl Strategy<Value = f64> {
        prop_oneof![
            (-5i32..50).prop_map(|k| f64::from(k as f32 * 0.1)),
            Just(0.0),
            Just(-0.0),
            Just(f64::INFINITY),
            Just(f64::NEG_INFINITY),
            Just(f64::NAN),
            any::<f64>(),
        ]
    }

    proptest! {
        #[test]
        fn quantiles_and_means_are_those_of_the_kept_values(v in proptest::collection::vec(special(), 0..300), q in 0.0..1.0f64) {
            let mut t = Tally::default();
            v.iter().for_each(|&x| t.push(x));
            prop_assert_eq!(t.len(), v.len() as u64);
            for q in [q, 0.5, 0.95, 1.0, 0.0] {
                prop_assert_eq!(t.quantile(q).to_bits(), quantile_of(&v, q).to_bits(), "q = {}", q);
            }
            prop_assert_eq!(t.mean_finite().to_bits(), mean_of(&v).to_bits());
        }

        /// Merged tallies of `f32` steps (ages, delays) give the quantile and mean of all values.
        #[test]
        fn merged_tallies_equal_one_of_all_values(parts in proptest::collection::vec(proptest::collection::vec(0u32..200, 0..100), 0..8)) {
            let mut all = Tally::default();
            let mut flat = Vec::new();
            for p in &parts {
                let mut t = Tally::default();
                for &k in p {
                    let x = f64::from(k as f32 * 0.1);
                    t.push(x);
                    flat.push(x);
                }
                all.merge(&t);
            }
            prop_assert_eq!(all.quantile(0.95).to_bits(), quantile_of(&flat, 0.95).to_bits());
            prop_assert_eq!(all.mean_finite().to_bits(), mean_of(&flat).to_bits());
        }
    }
}

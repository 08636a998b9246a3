//! The two statistics every part of the summary takes of values kept one by one: the mean of
//! the finite ones and the nearest-rank quantile. Why a module: each concern's summary (errors,
//! wall times, distances) and `tally`'s tests must compute them the one same way, operation for
//! operation, or two summaries of one run differ in their last bits.

/// Mean of the finite values (agents with no steps, such as failed UAVs, have NaN), NaN if none.
pub(in crate::recorder) fn mean_finite(v: impl Iterator<Item = f64>) -> f64 {
    let (sum, n) = v.filter(|x| x.is_finite()).fold((0.0, 0u32), |(s, n), x| (s + x, n + 1));
    if n == 0 {
        f64::NAN
    } else {
        sum / f64::from(n)
    }
}

/// The `q`-quantile (nearest rank) of unsorted values.
pub(in crate::recorder) fn quantile(v: &[f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s[((q * s.len() as f64).ceil() as usize).clamp(1, s.len()) - 1]
}

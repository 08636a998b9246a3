//! The statistics of the studies (`swarm sweep-seeds` and every `study` of variants), pure and
//! tested against published values, and how a table prints them: the mean of a
//! metric over runs with its 95 % confidence interval from Student's t (runs are independent
//! draws: each seed is its own forest, start and noise), and a success rate with its Wilson score
//! interval (which, unlike the normal approximation, stays inside [0, 1] and is not zero-wide at
//! 0 or n successes).
//!
//! No statistics crate is pulled in for two formulas: the t quantile inverts the t distribution
//! function, written with the regularized incomplete beta function (continued fraction,
//! Numerical Recipes 3rd ed. section 6.4) and the Lanczos log-gamma, by bisection.

/// Two-sided 95 %: the upper quantile taken is 0.975.
pub const LEVEL: f64 = 0.95;

/// The standard normal quantile at 0.975 (Wilson's z for 95 %).
pub const Z_95: f64 = 1.959_963_984_540_054;

/// A mean with its confidence interval `mean ± half_width`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MeanCi {
    /// Values the mean is over.
    pub n: usize,
    /// Sample mean (NaN with no value).
    pub mean: f64,
    /// Half-width of the 95 % interval, t(0.975, n − 1) · s / √n (NaN below two values).
    pub half_width: f64,
    /// Smallest value.
    pub min: f64,
    /// Largest value.
    pub max: f64,
}

/// Mean and 95 % Student-t interval of `values` (non-finite ones are left out).
pub fn mean_ci(values: &[f64]) -> MeanCi {
    let v: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    let n = v.len();
    let mean = if n == 0 { f64::NAN } else { v.iter().sum::<f64>() / n as f64 };
    let half_width = if n < 2 {
        f64::NAN
    } else {
        // Sample standard deviation, n − 1 in the denominator.
        let s = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt();
        t_quantile(0.5 + LEVEL / 2.0, (n - 1) as f64) * s / (n as f64).sqrt()
    };
    let min = v.iter().copied().fold(f64::INFINITY, f64::min);
    let max = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    MeanCi { n, mean, half_width, min, max }
}

/// A share `k / n` with its 95 % Wilson score interval `[lo, hi]`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Rate {
    /// Successes.
    pub k: usize,
    /// Trials.
    pub n: usize,
    /// Lower bound of the interval.
    pub lo: f64,
    /// Upper bound.
    pub hi: f64,
}

impl Rate {
    /// `k / n` (NaN with no trial).
    pub fn share(&self) -> f64 {
        if self.n == 0 {
            f64::NAN
        } else {
            self.k as f64 / self.n as f64
        }
    }
}

/// Wilson score interval (Wilson 1927): centre `(p̂ + z²/2n) / (1 + z²/n)`, half-width
/// `z / (1 + z²/n) · √(p̂(1 − p̂)/n + z²/4n²)`.
pub fn wilson(k: usize, n: usize) -> Rate {
    if n == 0 {
        return Rate { k, n, lo: 0.0, hi: 1.0 };
    }
    let (nf, z2) = (n as f64, Z_95 * Z_95);
    let p = k as f64 / nf;
    let centre = (p + z2 / (2.0 * nf)) / (1.0 + z2 / nf);
    let half = Z_95 / (1.0 + z2 / nf) * (p * (1.0 - p) / nf + z2 / (4.0 * nf * nf)).sqrt();
    Rate { k, n, lo: (centre - half).max(0.0), hi: (centre + half).min(1.0) }
}

/// The `p` quantile (p > 0.5) of Student's t with `df` degrees of freedom, by bisection on the
/// distribution function to 1e-10.
pub fn t_quantile(p: f64, df: f64) -> f64 {
    let (mut lo, mut hi) = (0.0_f64, 1.0e4_f64);
    while hi - lo > 1e-10 {
        let mid = 0.5 * (lo + hi);
        if t_cdf(mid, df) < p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Student's t distribution function at t ≥ 0: `1 − ½ I_{df/(df+t²)}(df/2, ½)`.
fn t_cdf(t: f64, df: f64) -> f64 {
    1.0 - 0.5 * inc_beta(df / (df + t * t), 0.5 * df, 0.5)
}

/// Regularized incomplete beta `I_x(a, b)` (Numerical Recipes 3rd ed. eq. 6.4.5 with the
/// symmetry `I_x(a, b) = 1 − I_{1−x}(b, a)` to keep the continued fraction convergent).
fn inc_beta(x: f64, a: f64, b: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 1.0;
    }
    let front = (ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b) + a * x.ln() + b * (1.0 - x).ln()).exp();
    if x < (a + 1.0) / (a + b + 2.0) {
        front * beta_cf(x, a, b) / a
    } else {
        1.0 - front * beta_cf(1.0 - x, b, a) / b
    }
}

/// The continued fraction of the incomplete beta by the modified Lentz method (Numerical
/// Recipes 3rd ed. `Beta::betacf`).
fn beta_cf(x: f64, a: f64, b: f64) -> f64 {
    const TINY: f64 = 1e-300;
    let (qab, qap, qam) = (a + b, a + 1.0, a - 1.0);
    let mut c = 1.0;
    let mut d = 1.0 - qab * x / qap;
    d = 1.0 / if d.abs() < TINY { TINY } else { d };
    let mut h = d;
    for m in 1..300 {
        let m = m as f64;
        let m2 = 2.0 * m;
        for aa in [m * (b - m) * x / ((qam + m2) * (a + m2)), -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2))] {
            d = 1.0 + aa * d;
            d = 1.0 / if d.abs() < TINY { TINY } else { d };
            c = 1.0 + aa / c;
            c = if c.abs() < TINY { TINY } else { c };
            h *= d * c;
        }
        if (d * c - 1.0).abs() < 1e-15 {
            break;
        }
    }
    h
}

/// ln Γ(x) for x > 0 (Lanczos, g = 7, nine coefficients).
fn ln_gamma(x: f64) -> f64 {
    const G: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    let x = x - 1.0;
    let t = x + 7.5;
    let s = G[0] + G.iter().enumerate().skip(1).map(|(i, g)| g / (x + i as f64)).sum::<f64>();
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + s.ln()
}

/// `mean ± half-width`, or the mean alone with one value, or `-`.
pub fn mean_pm(c: &MeanCi) -> String {
    match (c.mean.is_finite(), c.half_width.is_finite()) {
        (true, true) => format!("{} ± {}", num(c.mean), num(c.half_width)),
        (true, false) => num(c.mean),
        _ => "-".into(),
    }
}

/// Three significant-ish digits: 2 decimals, 3 below 1, `-` when not finite.
pub fn num(v: f64) -> String {
    match v {
        v if !v.is_finite() => "-".into(),
        v if v.abs() < 1.0 && v != 0.0 => format!("{v:.3}"),
        v => format!("{v:.2}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    /// Published two-sided 95 % critical values (any t table, e.g. NIST/SEMATECH e-Handbook
    /// 1.3.6.7.2).
    #[test]
    fn t_quantiles_match_the_table() {
        for (df, t) in [
            (1.0, 12.706_205),
            (2.0, 4.302_653),
            (4.0, 2.776_445),
            (9.0, 2.262_157),
            (10.0, 2.228_139),
            (29.0, 2.045_230),
            (100.0, 1.983_972),
        ] {
            let got = t_quantile(0.975, df);
            assert!(close(got, t, 1e-5), "df {df}: {got} vs {t}");
        }
        assert!(close(t_quantile(0.95, 5.0), 2.015_048, 1e-5));
        assert!(close(t_quantile(0.975, 1e6), Z_95, 1e-4), "t tends to the normal");
    }

    #[test]
    fn ln_gamma_matches_factorials() {
        assert!(close(ln_gamma(5.0), 24f64.ln(), 1e-12));
        assert!(close(ln_gamma(0.5), std::f64::consts::PI.sqrt().ln(), 1e-12));
    }

    /// 95 % Wilson intervals as published (e.g. Newcombe 1998, Table I: 81/263 gives
    /// 0.2553–0.3662; 15/148 gives 0.0624–0.1605; 0/20 gives 0–0.1611; 1/29 gives 0.0061–0.1718).
    #[test]
    fn wilson_matches_newcombe() {
        for (k, n, lo, hi) in
            [(81, 263, 0.2553, 0.3662), (15, 148, 0.0624, 0.1605), (0, 20, 0.0, 0.1611), (1, 29, 0.0061, 0.1718)]
        {
            let r = wilson(k, n);
            assert!(close(r.lo, lo, 1e-4) && close(r.hi, hi, 1e-4), "{k}/{n}: {r:?}");
        }
        let all = wilson(30, 30);
        assert!(close(all.hi, 1.0, 1e-12) && close(all.lo, 0.8865, 1e-4), "{all:?}");
        assert_eq!((wilson(0, 0).lo, wilson(0, 0).hi), (0.0, 1.0), "no trial: nothing known");
    }

    #[test]
    fn mean_ci_by_hand() {
        // 1, 2, 3, 4, 5: mean 3, s = √2.5, t(0.975, 4) = 2.776445 → 2.776445·1.581139/√5 = 1.963243.
        let m = mean_ci(&[1.0, 2.0, 3.0, 4.0, 5.0, f64::NAN, f64::INFINITY]);
        assert_eq!((m.n, m.mean, m.min, m.max), (5, 3.0, 1.0, 5.0));
        assert!(close(m.half_width, 1.963_243, 1e-5), "{m:?}");
        let one = mean_ci(&[7.0]);
        assert!(one.mean == 7.0 && one.half_width.is_nan(), "one value: no interval");
        assert!(mean_ci(&[]).mean.is_nan());
    }
}

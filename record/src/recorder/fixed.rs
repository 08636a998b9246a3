//! Numbers with a fixed count of decimals for the run folder's CSVs: the same text as std's
//! `{:.N}`, made without its exact algorithm where that algorithm is not needed.
//!
//! Why: at 1000 UAVs the recorder writes about 17 000 numbers a tick, and std's fixed-precision
//! formatting is exact: it falls back to arbitrary-precision arithmetic (Dragon4) whenever its
//! fast path cannot prove the rounding, which happens for the many small values of a tick
//! (velocities, control vectors near zero). `perf` of open-1000 put float formatting at about a
//! tenth of the recorder's CPU. Here the value is scaled by 10^N in `f64` and rounded to an
//! integer, which is the exact answer whenever the scaled value is clearly away from a midpoint
//! between two integers: the product's rounding error (at most half an ulp, under 10^-7 below
//! [`LIMIT`]) cannot then change which integer is nearest. Values near a midpoint, non-finite
//! values and values beyond [`LIMIT`] go to std, so the text is always std's.

use std::fmt;

/// Scaled values from here on go to std (the product's error stays under 10^-7 below it).
const LIMIT: f64 = 1e9;
/// A scaled value this close to a midpoint goes to std, where its rounding is decided exactly.
const MARGIN: f64 = 1e-6;
/// 10^N for the decimals a [`Fixed`] may ask for (each exact in `f64`).
const POW10: [f64; 10] = [1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9];

/// `value` written with `decimals` decimals, as `format!("{:.decimals$}", value)` (std writes
/// it beyond 9 decimals).
#[derive(Debug, Clone, Copy)]
pub struct Fixed(pub f64, pub usize);

impl fmt::Display for Fixed {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let Fixed(value, decimals) = *self;
        match fast(value, decimals) {
            Some(n) => write_scaled(f, value.is_sign_negative(), n, decimals),
            None => write!(f, "{value:.decimals$}"),
        }
    }
}

/// |value| · 10^decimals rounded to the nearest integer, where that is exact without ties.
fn fast(value: f64, decimals: usize) -> Option<u64> {
    let scaled = value.abs() * *POW10.get(decimals)?;
    // NaN fails the first test too.
    let small = scaled < LIMIT;
    if !small || ((scaled - scaled.floor()) - 0.5).abs() < MARGIN {
        return None;
    }
    Some(scaled.round() as u64)
}

/// Writes `n` / 10^decimals with `decimals` decimals, with a minus sign when `negative` (std
/// writes one for every negative value, -0 and values that round to 0 included).
fn write_scaled(f: &mut fmt::Formatter<'_>, negative: bool, n: u64, decimals: usize) -> fmt::Result {
    let mut buf = [0u8; 32];
    let mut at = buf.len();
    let mut rest = n;
    let mut put = |b: u8, at: &mut usize| {
        *at -= 1;
        buf[*at] = b;
    };
    for _ in 0..decimals {
        put(b'0' + (rest % 10) as u8, &mut at);
        rest /= 10;
    }
    if decimals > 0 {
        put(b'.', &mut at);
    }
    loop {
        put(b'0' + (rest % 10) as u8, &mut at);
        rest /= 10;
        if rest == 0 {
            break;
        }
    }
    if negative {
        put(b'-', &mut at);
    }
    // Only ASCII digits, '.' and '-' were written.
    f.write_str(std::str::from_utf8(&buf[at..]).map_err(|_| fmt::Error)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn std_text(v: f64, d: usize) -> String {
        format!("{v:.d$}")
    }

    fn check(v: f64, d: usize) {
        assert_eq!(Fixed(v, d).to_string(), std_text(v, d), "{v:e} with {d} decimals");
    }

    #[test]
    fn the_same_text_as_std_at_the_edges() {
        let edges = [
            0.0,
            -0.0,
            1e-300,
            -1e-300,
            f64::MIN_POSITIVE,
            5e-324,
            0.5,
            -0.5,
            1.5,
            2.5,
            0.125,
            0.00005,
            -0.00005,
            0.00015,
            0.99995,
            9.99995,
            1e5 - 0.00005,
            123_456.789_05,
            1e5,
            99_999.999_95,
            1e9,
            -1e9,
            1e15,
            f64::MAX,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        for d in 0..=POW10.len() {
            for v in edges {
                check(v, d);
                check(-v, d);
            }
        }
    }

    #[test]
    fn midpoints_go_to_std() {
        // 0.125 is exactly a midpoint at 2 decimals; std decides it.
        assert_eq!(fast(0.125, 2), None);
        assert_eq!(fast(1.25, 4), Some(12_500));
        check(0.125, 2);
    }

    proptest! {
        #[test]
        fn any_float_is_written_as_std_writes_it(bits in any::<u64>(), d in 0usize..=10) {
            let v = f64::from_bits(bits);
            prop_assert_eq!(Fixed(v, d).to_string(), std_text(v, d));
        }

        #[test]
        fn values_of_a_run_are_written_as_std_writes_it(v in -2e5f64..2e5, d in 0usize..=9) {
            prop_assert_eq!(Fixed(v, d).to_string(), std_text(v, d));
        }

        #[test]
        fn values_near_a_midpoint_are_written_as_std_writes_it(
            k in -1_000_000_000i64..1_000_000_000,
            ulps in -64i64..=64,
            d in 1usize..=6,
        ) {
            let mid = (k as f64 + 0.5) / 10f64.powi(d as i32);
            let v = f64::from_bits((mid.to_bits() as i64 + ulps) as u64);
            prop_assert_eq!(Fixed(v, d).to_string(), std_text(v, d));
        }

        #[test]
        fn small_values_are_written_as_std_writes_it(v in -0.01f64..0.01, d in 2usize..=5) {
            prop_assert_eq!(Fixed(v, d).to_string(), std_text(v, d));
        }

        #[test]
        fn singles_are_written_as_std_writes_them(bits in any::<u32>(), d in 0usize..=6) {
            let v = f32::from_bits(bits);
            prop_assert_eq!(Fixed(f64::from(v), d).to_string(), format!("{v:.d$}"));
        }
    }
}

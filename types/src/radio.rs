//! The radio's range with hysteresis: a link comes up strictly inside `range_m` and, once up,
//! goes down only beyond `range_m + hysteresis_m`, so a pair balancing on the edge of range does
//! not flap. The hub decides links by it; the recorder decides by the same rule when a UAV is out
//! of reach of every other and when it rejoins.

use std::cmp::Ordering;

/// Range with hysteresis [m].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hysteresis {
    /// A link comes up at a distance below this [m].
    pub range_m: f64,
    /// And goes down only beyond `range_m` plus this [m].
    pub hysteresis_m: f64,
}

impl Hysteresis {
    /// The rule for `range_m` and `hysteresis_m`.
    pub fn new(range_m: f64, hysteresis_m: f64) -> Hysteresis {
        Hysteresis { range_m, hysteresis_m }
    }

    /// The distance within which a link that is up stays up [m].
    pub fn keep_m(&self) -> f64 {
        self.range_m + self.hysteresis_m
    }

    /// Whether a pair is linked, from how its distance compares with `range_m` and with
    /// [`Hysteresis::keep_m`] (`None`: not comparable, a NaN distance) and, where the two rules
    /// disagree (in the band), from whether it was (asked only then).
    pub fn linked_by(vs_range: Option<Ordering>, vs_keep: Option<Ordering>, was_linked: impl FnOnce() -> bool) -> bool {
        let inside_range = vs_range == Some(Ordering::Less);
        let inside_keep = matches!(vs_keep, Some(Ordering::Less | Ordering::Equal));
        if inside_range == inside_keep {
            inside_range
        } else if was_linked() {
            inside_keep
        } else {
            inside_range
        }
    }

    /// Whether a pair `distance_m` apart is linked, given whether it was.
    pub fn linked(&self, was_linked: bool, distance_m: f64) -> bool {
        Hysteresis::linked_by(distance_m.partial_cmp(&self.range_m), distance_m.partial_cmp(&self.keep_m()), || {
            was_linked
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn up_strictly_inside_range_down_only_past_the_band() {
        let h = Hysteresis::new(10.0, 2.0);
        assert!(!h.linked(false, 10.0), "at range: not yet");
        assert!(h.linked(false, 9.99));
        assert!(h.linked(true, 12.0), "at range + hysteresis: still up");
        assert!(!h.linked(true, 12.01));
        assert!(!h.linked(true, f64::NAN) && !h.linked(false, f64::NAN));
    }
}

//! Time on the simulation's clock. A run advances in ticks of a fixed `dt`; tick k is at
//! t = k · dt. Kept as one type so a sim time is never mistaken for a wall-clock one, and the
//! tick arithmetic is written once.

use serde::{Deserialize, Serialize};

/// A time on the simulation's clock [s] since the run's start.
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Default, Serialize, Deserialize)]
#[serde(transparent)]
pub struct SimTime(f64);

impl SimTime {
    /// The time of tick `tick` at a fixed step `dt_s` [s]: `tick · dt_s`.
    pub fn of_tick(tick: u64, dt_s: f64) -> SimTime {
        SimTime(tick as f64 * dt_s)
    }

    /// Seconds since the start.
    pub const fn s(self) -> f64 {
        self.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_and_seconds() {
        let t = SimTime::of_tick(25, 0.1);
        assert_eq!(t.s(), 25.0 * 0.1, "the same product as written out");
        assert_eq!(postcard::to_stdvec(&t).expect("encodes"), postcard::to_stdvec(&2.5f64).expect("encodes"));
    }
}

//! Time on the simulation's clock. A run advances in ticks of a fixed `dt`; tick k is at
//! t = k · dt. Kept as one type so a sim time is never mistaken for a wall-clock one, and the
//! tick arithmetic is written once.

use serde::{Deserialize, Serialize};
use std::fmt;
use std::ops::{Add, Sub};

/// A time on the simulation's clock [s] since the run's start.
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Default, Serialize, Deserialize)]
#[serde(transparent)]
pub struct SimTime(f64);

impl SimTime {
    /// The start of the run.
    pub const ZERO: SimTime = SimTime(0.0);

    /// The time `s` seconds after the start.
    pub const fn from_s(s: f64) -> SimTime {
        SimTime(s)
    }

    /// The time of tick `tick` at a fixed step `dt_s` [s]: `tick · dt_s`.
    pub fn of_tick(tick: u64, dt_s: f64) -> SimTime {
        SimTime(tick as f64 * dt_s)
    }

    /// Seconds since the start.
    pub const fn s(self) -> f64 {
        self.0
    }
}

impl Add<f64> for SimTime {
    type Output = SimTime;
    fn add(self, s: f64) -> SimTime {
        SimTime(self.0 + s)
    }
}

impl Sub for SimTime {
    type Output = f64;
    /// The seconds from `rhs` to `self`.
    fn sub(self, rhs: SimTime) -> f64 {
        self.0 - rhs.0
    }
}

impl fmt::Display for SimTime {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:.3} s", self.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_and_seconds() {
        let t = SimTime::of_tick(25, 0.1);
        assert_eq!(t.s(), 25.0 * 0.1);
        assert_eq!((t + 0.5) - t, 0.5);
        assert_eq!(t.to_string(), "2.500 s");
        assert_eq!(postcard::to_stdvec(&t).expect("encodes"), postcard::to_stdvec(&2.5f64).expect("encodes"));
    }
}

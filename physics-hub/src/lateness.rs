//! Late commands: how many of the commands the hub took arrived after their tick had closed, and
//! by how much. In `realtime` mode a tick closes on the wall clock whether or not every agent has
//! answered, so a slow agent's command for tick k lands during tick k+1 or later and steers the
//! body late; the share of such commands and their lateness tell whether a swarm keeps up with
//! real time (issue 11, item 6). In `lockstep` a command arrives late only after a tick timeout.
//!
//! The node stamps each command with its wall arrival instant as it is received and tells this
//! module when each tick closes; lateness = arrival − the instant the command's tick closed. Pure
//! bookkeeping with the instants handed in, so it is tested without a clock. The per-tick result
//! rides on `truth/step` ([`HubTiming`]); the recorder folds it into the run's share and p99.

use std::collections::VecDeque;
use std::time::{Duration, Instant};
use swarm_wire::HubTiming;

/// Close instants kept: a command older than this many ticks is measured against the oldest
/// kept close, a lower bound of its lateness (10 s at 100 Hz).
const KEPT_TICKS: usize = 1000;

/// Tick close instants, and the commands counted since the last truth step.
#[derive(Debug, Default)]
pub struct Lateness {
    /// `(tick, wall instant it closed)`, oldest first.
    closed: VecDeque<(u64, Instant)>,
    /// Commands counted since the last [`Lateness::take`].
    cmds: u32,
    /// Lateness of the late ones among them [ms].
    late_ms: Vec<f32>,
}

impl Lateness {
    /// Tick `tick` closed at `at`: a command for it arriving after `at` is late.
    pub fn close(&mut self, tick: u64, at: Instant) {
        if self.closed.len() == KEPT_TICKS {
            self.closed.pop_front();
        }
        self.closed.push_back((tick, at));
    }

    /// Counts a command for tick `cmd_tick` that arrived at `arrived`; returns how late it was
    /// [ms], `None` when it arrived before its tick closed (or its tick has not closed yet).
    pub fn command(&mut self, cmd_tick: u64, arrived: Instant) -> Option<f32> {
        self.cmds = self.cmds.saturating_add(1);
        let (_, oldest) = *self.closed.front()?;
        let closed_at = match self.closed.binary_search_by_key(&cmd_tick, |&(t, _)| t) {
            Ok(i) => self.closed[i].1,
            Err(0) => oldest,
            Err(_) => return None,
        };
        let late = arrived.checked_duration_since(closed_at).filter(|d| !d.is_zero())?;
        let ms = late.as_secs_f64() * 1000.0;
        self.late_ms.push(ms as f32);
        Some(ms as f32)
    }

    /// This step's timing: the hub's own work `work` and the commands counted since the last
    /// call, which starts a fresh count.
    pub fn take(&mut self, work: Duration) -> HubTiming {
        let work_us = u32::try_from(work.as_micros()).unwrap_or(u32::MAX);
        HubTiming { work_us, cmds: std::mem::take(&mut self.cmds), late_ms: std::mem::take(&mut self.late_ms) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(n: u64) -> Duration {
        Duration::from_millis(n)
    }

    #[test]
    fn a_command_after_its_tick_closed_is_late_by_the_gap() {
        let t0 = Instant::now();
        let mut l = Lateness::default();
        assert_eq!(l.command(0, t0), None, "nothing closed yet: on time");
        l.close(0, t0 + ms(100));
        l.close(1, t0 + ms(200));
        assert_eq!(l.command(2, t0 + ms(250)), None, "tick 2 is still open");
        let late = l.command(1, t0 + ms(230)).expect("tick 1 closed at 200 ms");
        assert!((late - 30.0).abs() < 0.01, "{late}");
        let late = l.command(0, t0 + ms(260)).expect("tick 0 closed at 100 ms");
        assert!((late - 160.0).abs() < 0.01, "{late}");
        assert_eq!(l.command(1, t0 + ms(150)), None, "arrived before tick 1 closed");
        let step = l.take(Duration::from_micros(1500));
        assert_eq!(step, HubTiming { work_us: 1500, cmds: 5, late_ms: step.late_ms.clone() });
        assert_eq!(step.late_ms.len(), 2);
        assert_eq!(l.take(Duration::ZERO), HubTiming::default(), "each step counts afresh");
    }

    #[test]
    fn a_command_older_than_the_kept_ticks_is_measured_from_the_oldest_close() {
        let t0 = Instant::now();
        let mut l = Lateness::default();
        for k in 0..(KEPT_TICKS as u64 + 10) {
            l.close(k, t0 + ms(10 * k));
        }
        let late = l.command(3, t0 + ms(10 * (KEPT_TICKS as u64 + 10))).expect("long closed");
        // Ticks 0..=9 are forgotten; the oldest kept close is tick 10's, at 100 ms.
        assert!(
            (late - (10.0 * (KEPT_TICKS as f32 + 10.0) - 100.0)).abs() < 0.01,
            "lower bound from tick 10's close: {late}"
        );
    }
}

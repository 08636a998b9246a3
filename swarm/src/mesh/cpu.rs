//! The CPU a mesh flight used, by piece: nothing inside a run sees every process of it, so while
//! the pieces fly this samples `/proc/<pid>/stat` (user + system time) of each one it started,
//! and `/proc/stat` for the whole machine, every [`SAMPLE`]. Why: whether the delivery of border
//! shares and the late commands come from the design or from a saturated machine can only be
//! told beside how busy its cores were (issue 46, item 4).
//!
//! The parsing and the sampling thread are `swarm scale`'s ([`crate::scale::proc_fs`]: its
//! memory peak is read the same way); [`Watch`] names what to read. A piece that exits between
//! two samples loses at most its last [`SAMPLE`] of CPU time.

use crate::scale::proc_fs::{machine_ticks, process_ticks, Sampler};
use crate::scale::USER_HZ;
use serde::Serialize;
use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// How often the processes' CPU times are read.
const SAMPLE: Duration = Duration::from_millis(200);

/// What one kind of piece used over the flight.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RoleCpu {
    /// `hub`, `recorder`, `routers` or `agents`.
    pub role: String,
    /// Processes of that kind.
    pub processes: usize,
    /// CPU seconds, user + system.
    pub cpu_s: f64,
    /// CPU seconds per wall second: the cores it kept busy.
    pub cores: f64,
}

/// The CPU of a flight, by role and for the whole machine.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct CpuUse {
    /// Wall seconds watched (from the agents' start to the recorder's end).
    pub wall_s: f64,
    /// The machine's cores (as `/proc/stat` counts them, the same cores `machine_busy` is of).
    pub cores: usize,
    /// Share of all cores' time busy over that window, whatever ran (0 to 1).
    pub machine_busy: f64,
    /// Each kind of piece.
    pub by_role: Vec<RoleCpu>,
}

impl CpuUse {
    /// The cores `role` kept busy (0 when absent).
    pub fn cores_of(&self, role: &str) -> f64 {
        self.by_role.iter().find(|r| r.role == role).map_or(0.0, |r| r.cores)
    }
}

/// The samples so far: each watched pid's first and latest ticks, the machine's (busy, total)
/// first and latest, and its cores.
#[derive(Debug, Default)]
struct Samples {
    pids: BTreeMap<u32, (u64, u64)>,
    machine: Option<((u64, u64), (u64, u64))>,
    cores: usize,
}

impl Samples {
    fn take(&mut self, pids: &[(String, u32)]) {
        for (_, pid) in pids {
            if let Some(t) =
                std::fs::read_to_string(format!("/proc/{pid}/stat")).ok().as_deref().and_then(process_ticks)
            {
                self.pids.entry(*pid).and_modify(|e| e.1 = t).or_insert((t, t));
            }
        }
        if let Some((busy, total, cores)) =
            std::fs::read_to_string("/proc/stat").ok().as_deref().and_then(machine_ticks)
        {
            let m = (busy, total);
            self.machine = Some(self.machine.map_or((m, m), |(first, _)| (first, m)));
            self.cores = cores;
        }
    }

    fn result(&self, pids: &[(String, u32)], wall_s: f64) -> CpuUse {
        let mut by_role: BTreeMap<&str, (usize, u64)> = BTreeMap::new();
        for (role, pid) in pids {
            let used = self.pids.get(pid).map_or(0, |(first, last)| last - first);
            let e = by_role.entry(role).or_default();
            e.0 += 1;
            e.1 += used;
        }
        let machine_busy = self.machine.map_or(
            0.0,
            |((b0, t0), (b1, t1))| {
                if t1 > t0 {
                    (b1 - b0) as f64 / (t1 - t0) as f64
                } else {
                    0.0
                }
            },
        );
        let by_role = by_role
            .into_iter()
            .map(|(role, (processes, ticks))| {
                let cpu_s = ticks as f64 / USER_HZ;
                RoleCpu { role: role.to_string(), processes, cpu_s, cores: cpu_s / wall_s.max(1e-9) }
            })
            .collect();
        CpuUse { wall_s, cores: self.cores, machine_busy, by_role }
    }
}

/// Samples the CPU of `(role, pid)` pieces until stopped.
pub struct Watch {
    sampler: Sampler<Samples>,
    pids: Arc<Vec<(String, u32)>>,
    started: Instant,
}

impl Watch {
    /// Starts sampling now.
    pub fn start(pids: Vec<(String, u32)>) -> Watch {
        let pids = Arc::new(pids);
        let watched = pids.clone();
        let sampler = Sampler::start(SAMPLE, Samples::default(), move |s: &mut Samples| s.take(&watched));
        Watch { sampler, pids, started: Instant::now() }
    }

    /// Stops sampling and says what was used.
    pub async fn stop(self) -> CpuUse {
        let wall_s = self.started.elapsed().as_secs_f64();
        self.sampler.stop().await.result(&self.pids, wall_s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_sum_by_role_over_the_window() {
        let mut s = Samples::default();
        s.pids.insert(1, (100, 300));
        s.pids.insert(2, (0, 100));
        s.pids.insert(3, (50, 50));
        s.machine = Some(((1000, 4000), (1400, 4800)));
        s.cores = 2;
        let pids = vec![("hub".to_string(), 1), ("agents".to_string(), 2), ("agents".to_string(), 3)];
        let u = s.result(&pids, 4.0);
        assert_eq!((u.machine_busy, u.cores), (0.5, 2));
        assert_eq!(u.by_role[0], RoleCpu { role: "agents".into(), processes: 2, cpu_s: 1.0, cores: 0.25 });
        assert_eq!(u.cores_of("hub"), 0.5);
        assert_eq!(u.cores_of("routers"), 0.0);
    }

    #[tokio::test]
    async fn a_busy_child_is_seen_using_the_cpu() {
        if !std::path::Path::new("/proc/self/stat").exists() {
            return;
        }
        let mut child = std::process::Command::new("sh")
            .args(["-c", "i=0; while [ $i -lt 400000 ]; do i=$((i+1)); done"])
            .spawn()
            .expect("sh starts");
        let w = Watch::start(vec![("agents".into(), child.id())]);
        tokio::time::sleep(Duration::from_millis(600)).await;
        let u = w.stop().await;
        let _ = child.kill();
        let _ = child.wait();
        assert!(u.cores_of("agents") > 0.1, "a shell loop keeps a core busy: {u:?}");
        assert!(u.machine_busy > 0.0 && u.machine_busy <= 1.0, "{u:?}");
        assert!(u.cores >= 1, "{u:?}");
    }
}

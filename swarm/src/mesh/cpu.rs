//! The CPU a mesh flight used, by piece: nothing inside a run sees every process of it, so while
//! the pieces fly this samples `/proc/<pid>/stat` (user + system time) of each one it started,
//! and `/proc/stat` for the whole machine, every [`SAMPLE`]. Why: whether the delivery of border
//! shares and the late commands come from the design or from a saturated machine can only be
//! told beside how busy its cores were (issue 46, item 4).
//!
//! The parsing is pure (tested on text); [`Watch`] is the one part that reads the files. A piece
//! that exits between two samples loses at most its last [`SAMPLE`] of CPU time.

use serde::Serialize;
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// How often the processes' CPU times are read.
const SAMPLE: Duration = Duration::from_millis(200);

/// Clock ticks per second of `/proc`'s times: Linux's `USER_HZ`, 100 on every architecture
/// it exports to user space.
const USER_HZ: f64 = 100.0;

/// User + system time [clock ticks] in the text of `/proc/<pid>/stat`: fields 14 and 15, counted
/// from the pid, after the command name in parentheses (the last `)` ends it).
pub fn process_ticks(stat: &str) -> Option<u64> {
    let rest = stat[stat.rfind(')')? + 1..].split_whitespace().collect::<Vec<_>>();
    // `rest[0]` is field 3 (the state), so field k is `rest[k - 3]`.
    Some(rest.get(11)?.parse::<u64>().ok()? + rest.get(12)?.parse::<u64>().ok()?)
}

/// (busy, total) clock ticks of all cores in the text of `/proc/stat` (its `cpu` line): busy is
/// everything but idle and iowait.
pub fn machine_ticks(stat: &str) -> Option<(u64, u64)> {
    let line = stat.lines().find(|l| l.starts_with("cpu "))?;
    let v: Vec<u64> = line.split_whitespace().skip(1).map(|f| f.parse().ok()).collect::<Option<_>>()?;
    let total: u64 = v.iter().take(8).sum();
    let idle = v.get(3)? + v.get(4).copied().unwrap_or(0);
    Some((total - idle, total))
}

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
    /// The machine's cores.
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

/// The samples so far: each watched pid's first and latest ticks, and the machine's.
#[derive(Debug, Default)]
struct Samples {
    pids: BTreeMap<u32, (u64, u64)>,
    machine: Option<((u64, u64), (u64, u64))>,
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
        if let Some(m) = std::fs::read_to_string("/proc/stat").ok().as_deref().and_then(machine_ticks) {
            self.machine = Some(self.machine.map_or((m, m), |(first, _)| (first, m)));
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
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        CpuUse { wall_s, cores, machine_busy, by_role }
    }
}

/// Samples the CPU of `(role, pid)` pieces until stopped.
pub struct Watch {
    stop: Arc<AtomicBool>,
    task: tokio::task::JoinHandle<CpuUse>,
}

impl Watch {
    /// Starts sampling now.
    pub fn start(pids: Vec<(String, u32)>) -> Watch {
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let task = tokio::spawn(async move {
            let started = Instant::now();
            let mut s = Samples::default();
            s.take(&pids);
            while !flag.load(Ordering::Relaxed) {
                tokio::time::sleep(SAMPLE).await;
                s.take(&pids);
            }
            s.result(&pids, started.elapsed().as_secs_f64())
        });
        Watch { stop, task }
    }

    /// Stops sampling and says what was used.
    pub async fn stop(self) -> CpuUse {
        self.stop.store(true, Ordering::Relaxed);
        self.task.await.unwrap_or_default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_process_time_is_user_plus_system() {
        let stat = "4242 (swarm (agent)) S 1 4242 1 0 -1 4194560 120 0 0 0 250 37 0 0 20 0 9 0 100 0 0";
        assert_eq!(process_ticks(stat), Some(287), "utime 250 + stime 37, the name's `)` skipped");
        assert_eq!(process_ticks("1 (x) S 1"), None);
    }

    #[test]
    fn the_machine_is_busy_but_for_idle_and_iowait() {
        let stat = "cpu  100 5 45 800 50 0 0 0 0 0\ncpu0 50 2 20 400 25 0 0 0 0 0\n";
        assert_eq!(machine_ticks(stat), Some((150, 1000)));
        assert_eq!(machine_ticks("intr 1 2\n"), None);
    }

    #[test]
    fn samples_sum_by_role_over_the_window() {
        let mut s = Samples::default();
        s.pids.insert(1, (100, 300));
        s.pids.insert(2, (0, 100));
        s.pids.insert(3, (50, 50));
        s.machine = Some(((1000, 4000), (1400, 4800)));
        let pids = vec![("hub".to_string(), 1), ("agents".to_string(), 2), ("agents".to_string(), 3)];
        let u = s.result(&pids, 4.0);
        assert_eq!(u.machine_busy, 0.5);
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
    }
}

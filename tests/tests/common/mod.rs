//! Shared harness of the end-to-end tests: the `swarm` binary under test, unique run ids, a hub
//! started by hand whose locator is read from its stdout, and a bounded wait for processes.

#![allow(dead_code)]

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, ChildStdin, Command, Output, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant};

/// The binary under test (the same code as the shipped `swarm`).
pub const SWARM: &str = env!("CARGO_BIN_EXE_swarm-e2e");

/// A run id no other test (or test process) uses: keys never cross-talk.
pub fn run_id(tag: &str) -> String {
    static N: AtomicU32 = AtomicU32::new(0);
    format!("t{}-{}-{tag}", std::process::id(), N.fetch_add(1, Ordering::Relaxed))
}

/// Runs `swarm run` to completion and returns its output.
pub fn swarm_run(args: &[&str]) -> Output {
    Command::new(SWARM).arg("run").args(args).arg("--quiet").output().expect("swarm runs")
}

/// Parses the summary of a run folder.
pub fn summary(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("summary.json")).expect("summary.json written");
    serde_json::from_str(&text).expect("summary.json is JSON")
}

/// A child process that is killed when dropped; its stdin is held open (the pieces started with
/// `--exit-with-stdin` exit when it closes).
pub struct Proc {
    pub child: Child,
    pub stdin: Option<ChildStdin>,
}

impl Drop for Proc {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Proc {
    /// Starts `swarm <args>` with piped stdin and stdout, stderr to `log`.
    pub fn start(args: &[&str], log: &Path) -> Proc {
        let err = std::fs::File::create(log).expect("log file");
        let mut child = Command::new(SWARM)
            .args(args)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::from(err))
            .spawn()
            .expect("spawn swarm");
        let stdin = child.stdin.take();
        Proc { child, stdin }
    }

    /// Waits for exit up to `limit`; `None` if it is still running.
    pub fn wait_for(&mut self, limit: Duration) -> Option<std::process::ExitStatus> {
        let end = Instant::now() + limit;
        while Instant::now() < end {
            if let Some(s) = self.child.try_wait().expect("try_wait") {
                return Some(s);
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        None
    }
}

/// Starts a hub on a free loopback port and returns it with its locator.
pub fn start_hub(scenario: &str, run: &str, dir: &Path) -> (Proc, String) {
    let mut hub = Proc::start(
        &["hub", scenario, "--run", run, "--listen", "tcp/127.0.0.1:0", "--exit-with-stdin"],
        &dir.join("hub.log"),
    );
    let stdout = hub.child.stdout.take().expect("piped stdout");
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            if let Some(rest) = line.strip_prefix("swarm-hub listening:") {
                let _ = tx.send(rest.split_whitespace().next().unwrap_or_default().to_string());
            }
        }
    });
    let locator = rx.recv_timeout(Duration::from_secs(30)).expect("hub prints its locator");
    assert!(locator.starts_with("tcp/127.0.0.1:"), "{locator}");
    (hub, locator)
}

//! Shared harness of the end-to-end tests: the `swarm` binary under test, unique run ids, a hub
//! started by hand whose locator is read from its stdout (insecure, or with credentials), and a
//! bounded wait for processes.
//!
//! Every wait on a child is bounded: [`output_within`] and [`wait_output`] kill a child that
//! outlives its limit and fail the test saying which command hung; [`Proc::wait_for`] returns
//! `None` for the caller to fail on; [`Proc`]'s drop kills before it reaps.

#![allow(dead_code)]

use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, ExitStatus, Output, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant};

/// The binary under test (the same code as the shipped `swarm`).
pub const SWARM: &str = env!("CARGO_BIN_EXE_swarm-e2e");
/// The `swarm-node` binary (hub, agent, router, credentials only), built in this package.
pub const NODE: &str = env!("CARGO_BIN_EXE_swarm-node-e2e");

/// A run id no other test (or test process) uses: keys never cross-talk.
pub fn run_id(tag: &str) -> String {
    static N: AtomicU32 = AtomicU32::new(0);
    format!("t{}-{}-{tag}", std::process::id(), N.fetch_add(1, Ordering::Relaxed))
}

/// The longest a whole `swarm run` may take before the test fails (a loaded machine flies the
/// longest scenario in well under this).
pub const RUN_LIMIT: Duration = Duration::from_secs(600);

/// The longest a tool (`tap`, `put`, `netem`, an agent refused at the door) may take.
pub const TOOL_LIMIT: Duration = Duration::from_secs(120);

/// Runs `swarm run` to completion (at most [`RUN_LIMIT`]) and returns its output.
pub fn swarm_run(args: &[&str]) -> Output {
    output_within(Command::new(SWARM).arg("run").args(args).arg("--quiet"), RUN_LIMIT)
}

/// Runs `cmd` to completion like [`Command::output`] (stdin null, stdout and stderr captured), but
/// kills it and fails the test if it has not exited within `limit`.
pub fn output_within(cmd: &mut Command, limit: Duration) -> Output {
    let what = format!("{cmd:?}");
    let child = cmd
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("cannot start {what}: {e}"));
    wait_output(child, limit, &what)
}

/// Waits for `child` to exit and collects what it wrote to its piped stdout and stderr (empty
/// where not piped); kills it and fails the test, naming `what`, if it outlives `limit`.
pub fn wait_output(mut child: Child, limit: Duration, what: &str) -> Output {
    let read_all = |pipe: Option<Box<dyn Read + Send>>| {
        std::thread::spawn(move || {
            let mut bytes = Vec::new();
            if let Some(mut p) = pipe {
                let _ = p.read_to_end(&mut bytes);
            }
            bytes
        })
    };
    let stdout = read_all(child.stdout.take().map(|p| Box::new(p) as Box<dyn Read + Send>));
    let stderr = read_all(child.stderr.take().map(|p| Box::new(p) as Box<dyn Read + Send>));
    let Some(status) = exit_within(&mut child, limit) else {
        let _ = child.kill();
        let _ = child.wait();
        panic!("{what} still running after {limit:?}: killed");
    };
    Output { status, stdout: stdout.join().expect("stdout reader"), stderr: stderr.join().expect("stderr reader") }
}

/// Polls `child` for its exit up to `limit`; `None` if it is still running.
fn exit_within(child: &mut Child, limit: Duration) -> Option<ExitStatus> {
    let end = Instant::now() + limit;
    loop {
        if let Some(s) = child.try_wait().expect("try_wait") {
            return Some(s);
        }
        if Instant::now() >= end {
            return None;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
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
        Proc::start_program(SWARM, args, log)
    }

    /// Starts `program <args>` (`SWARM` or `NODE`) with piped stdin and stdout, stderr to `log`.
    pub fn start_program(program: &str, args: &[&str], log: &Path) -> Proc {
        let err = std::fs::File::create(log).expect("log file");
        let mut child = Command::new(program)
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
    pub fn wait_for(&mut self, limit: Duration) -> Option<ExitStatus> {
        exit_within(&mut self.child, limit)
    }
}

/// Starts a hub on a free loopback port and returns it with its locator. It runs `--insecure`:
/// the tests that use it are about something else than access control, and their pieces and
/// tools connect without credentials (`security.rs` tests the secured hub, [`start_secure_hub`]).
pub fn start_hub(scenario: &str, run: &str, dir: &Path) -> (Proc, String) {
    start_hub_with(scenario, run, dir, &["--insecure"])
}

/// Credentials for a hub and the pieces of a test, made by `swarm credentials` in `dir/creds`:
/// `uav1`..`uav{uavs}`, `observer`, `operator`.
pub struct Creds(pub std::path::PathBuf);

impl Creds {
    /// Makes them.
    pub fn make(dir: &Path, uavs: u32) -> Creds {
        Creds::make_with(dir, uavs, &[])
    }

    /// As [`Creds::make`], and the users `more` (`ext3`, `ros`, `bridge`...).
    pub fn make_with(dir: &Path, uavs: u32, more: &[&str]) -> Creds {
        let creds = dir.join("creds");
        let users = more.iter().flat_map(|u| ["--user", u]);
        let o = output_within(
            Command::new(SWARM)
                .args(["credentials", "--out", creds.to_str().expect("utf8"), "--uavs", &uavs.to_string()])
                .args(users),
            TOOL_LIMIT,
        );
        assert!(o.status.success(), "swarm credentials: {}", String::from_utf8_lossy(&o.stderr));
        Creds(creds)
    }

    /// `--user USER --password-file FILE`.
    pub fn login(&self, user: &str) -> Vec<String> {
        let file = self.0.join(format!("{user}.password"));
        vec!["--user".into(), user.into(), "--password-file".into(), file.to_str().expect("utf8").into()]
    }

    /// The password of `user`.
    pub fn password(&self, user: &str) -> String {
        std::fs::read_to_string(self.0.join(format!("{user}.password"))).expect("password file").trim().to_string()
    }
}

/// Starts a hub that lets in only the users of `creds`, with access control by role.
pub fn start_secure_hub(scenario: &str, run: &str, dir: &Path, creds: &Creds) -> (Proc, String) {
    start_hub_with(scenario, run, dir, &["--users", creds.0.join("users.txt").to_str().expect("utf8")])
}

fn start_hub_with(scenario: &str, run: &str, dir: &Path, access: &[&str]) -> (Proc, String) {
    let mut args = vec!["hub", scenario, "--run", run, "--listen", "tcp/127.0.0.1:0", "--exit-with-stdin"];
    args.extend_from_slice(access);
    let mut hub = Proc::start(&args, &dir.join("hub.log"));
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

/// Starts `swarm record` into `out` and waits until it holds its token, i.e. is subscribed.
pub fn start_recorder(run: &str, loc: &str, out: &std::path::Path, dir: &std::path::Path) -> Proc {
    let rec = Proc::start(
        &["record", "--run", run, "--out", out.to_str().expect("utf8"), "--connect", loc],
        &dir.join("rec.log"),
    );
    let up =
        tap(&[&format!("swarm/{run}/alive/recorder"), "--alive", "--connect", loc, "--count", "1", "--duration", "30"]);
    assert!(up.contains("\"alive\":true"), "recorder is subscribed: {up}");
    rec
}

/// The alive column of one UAV in `trajectories.csv`, as (sim time, alive) at each change.
pub fn alive_changes(dir: &std::path::Path, id: &str) -> Vec<(f64, bool)> {
    let traj = std::fs::read_to_string(dir.join("trajectories.csv")).expect("csv");
    // Columns: tick,t_s,id,...,colliding,alive,cmd_on_time
    traj.lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
        .filter(|c| c[2] == id)
        .map(|c| (c[1].parse::<f64>().expect("t"), c[11] == "1"))
        .fold(Vec::new(), |mut v: Vec<(f64, bool)>, (t, a)| {
            if v.last().is_none_or(|&(_, prev)| prev != a) {
                v.push((t, a));
            }
            v
        })
}

/// Runs `swarm tap ARGS` (at most [`TOOL_LIMIT`]) and returns what it printed.
pub fn tap(args: &[&str]) -> String {
    let out = output_within(Command::new(SWARM).arg("tap").args(args), TOOL_LIMIT);
    assert!(out.status.success(), "tap failed: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).expect("utf8")
}

/// A `swarm tap` started in the background that is already listening: for samples a run may
/// publish right after the caller's next step (a lockstep run of a few UAVs can fly its whole
/// time limit in less than a tap's start-up).
pub struct Listening {
    child: Child,
    stderr: std::thread::JoinHandle<String>,
}

/// Starts `swarm tap ARGS` and returns once it says it is listening (its subscription is
/// declared), failing the test if it does not within [`TOOL_LIMIT`].
pub fn tap_listening(args: &[&str]) -> Listening {
    let mut child = Command::new(SWARM)
        .arg("tap")
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn swarm tap");
    let (ready_tx, ready_rx) = std::sync::mpsc::channel();
    let mut lines = BufReader::new(child.stderr.take().expect("piped stderr")).lines();
    let stderr = std::thread::spawn(move || {
        let mut all = String::new();
        for line in lines.by_ref().map_while(Result::ok) {
            if line.contains("tap listening") {
                let _ = ready_tx.send(());
            }
            all.push_str(&line);
            all.push('\n');
        }
        all
    });
    if ready_rx.recv_timeout(TOOL_LIMIT).is_err() {
        let _ = child.kill();
        panic!("swarm tap {args:?} never said it was listening");
    }
    Listening { child, stderr }
}

impl Listening {
    /// Waits for the tap to end (at most [`TOOL_LIMIT`]) and returns what it printed.
    pub fn output(self) -> String {
        let out = wait_output(self.child, TOOL_LIMIT, "swarm tap");
        let stderr = self.stderr.join().unwrap_or_default();
        assert!(out.status.success(), "tap failed: {stderr}");
        String::from_utf8(out.stdout).expect("utf8")
    }
}

/// The Python of the test environment (`<repo>/.venv`, made by `tools/test-env` from
/// `tests/requirements.txt`): tests that use a reader or client no one here wrote run it. A
/// missing venv fails the test with the command that makes it, never skips it.
pub fn python() -> std::path::PathBuf {
    let venv = Path::new(env!("CARGO_MANIFEST_DIR")).join("../.venv/bin/python");
    assert!(venv.exists(), "no test Python at {}: run tools/test-env first", venv.display());
    venv
}

/// The built-in forest-5 cut to `limit_s` sim seconds, written into `dir`; returns its path.
pub fn forest5_cut(dir: &Path, limit_s: f64) -> String {
    let src = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenarios/forest-5.toml");
    let text = std::fs::read_to_string(src).expect("forest-5.toml");
    let cut = text.replace("time_limit_s = 300.0", &format!("time_limit_s = {limit_s:.1}"));
    assert_ne!(cut, text, "forest-5's time limit line moved");
    let path = dir.join("forest-5-cut.toml");
    std::fs::write(&path, cut).expect("write scenario");
    path.to_str().expect("utf8").to_string()
}

/// The hub's first locator from a running `swarm run`'s folder (`hub.txt`), waited for up to
/// 60 s: what a piece started by hand (an external controller, a ROS client) connects to.
pub fn hub_locator(out: &Path) -> String {
    let start = Instant::now();
    loop {
        if let Some(loc) =
            std::fs::read_to_string(out.join("hub.txt")).ok().and_then(|t| t.lines().next().map(String::from))
        {
            return loc;
        }
        assert!(start.elapsed() < Duration::from_secs(60), "no hub.txt in {}", out.display());
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// The workspace root (this crate is one of its members).
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("the tests crate lives in the workspace").to_path_buf()
}

/// The text of a file the tests read, or a failure naming it.
pub fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()))
}

/// The folders of the workspace's members (the root `Cargo.toml`'s `workspace.members`).
pub fn member_dirs() -> Vec<String> {
    let manifest: toml::Table = read(&root().join("Cargo.toml")).parse().expect("root Cargo.toml parses");
    let dirs = manifest["workspace"]["members"].as_array().expect("workspace.members");
    dirs.iter().map(|d| d.as_str().expect("member path").to_string()).collect()
}

/// Every file under `dir` whose name ends in `.{ext}`, recursively, sorted.
pub fn files_with_extension(dir: &Path, ext: &str) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let Ok(entries) = std::fs::read_dir(dir) else { return out };
    for entry in entries.map(|e| e.expect("directory entry").path()) {
        if entry.is_dir() {
            out.extend(files_with_extension(&entry, ext));
        } else if entry.extension().is_some_and(|e| e == ext) {
            out.push(entry);
        }
    }
    out.sort();
    out
}

/// `path` relative to the workspace root, for messages.
pub fn rel(path: &Path) -> String {
    path.strip_prefix(root()).unwrap_or(path).display().to_string()
}

/// The Python of ROS 2 Jazzy's own wheels (`<repo>/.venv-ros`, made by `tools/test-env` from
/// `tests/requirements-ros.txt`): rclpy on Fast DDS and the message packages. Missing, it fails
/// the test with the command that makes it.
pub fn ros_python() -> PathBuf {
    let venv = root().join(".venv-ros/bin/python");
    assert!(venv.exists(), "no ROS 2 Python at {}: run tools/test-env first", venv.display());
    venv
}

/// The installed ROS 2 message packages' `share/` (their `.msg` and `.json` type descriptions).
pub fn ros_share() -> PathBuf {
    root().join(".venv-ros/share")
}

/// A network namespace of one test with its loopback interface up and nothing else: what runs in
/// it reaches only itself, so DDS discovery (multicast and the well-known ports) cannot meet
/// another test's participants, and no packet leaves the machine. Removed on drop (drop the
/// processes in it first).
pub struct LoopbackNs {
    name: String,
}

impl LoopbackNs {
    /// A fresh namespace named after `tag` and this test's run id.
    pub fn new(tag: &str) -> LoopbackNs {
        let name = run_id(tag);
        let ok = |args: &[&str]| {
            let o = Command::new("ip").args(args).output().expect("run ip (iproute2, tests/apt-packages.txt)");
            assert!(
                o.status.success(),
                "`ip {}` failed (this test runs as root, `.ci/run`): {}",
                args.join(" "),
                String::from_utf8_lossy(&o.stderr)
            );
        };
        ok(&["netns", "add", &name]);
        let ns = LoopbackNs { name };
        ok(&["-n", &ns.name, "link", "set", "lo", "up"]);
        ns
    }

    /// `program` to run inside the namespace.
    pub fn command(&self, program: impl AsRef<std::ffi::OsStr>) -> Command {
        let mut c = Command::new("ip");
        c.args(["netns", "exec", &self.name]).arg(program);
        c
    }

    /// The namespace's network interfaces, by name.
    pub fn interfaces(&self) -> Vec<String> {
        let o = Command::new("ip").args(["-n", &self.name, "-o", "link"]).output().expect("ip link");
        String::from_utf8_lossy(&o.stdout)
            .lines()
            .filter_map(|l| l.split(':').nth(1).map(|n| n.trim().to_string()))
            .collect()
    }

    /// Packets its loopback interface carried so far (received), from the kernel's counters.
    pub fn loopback_packets(&self) -> u64 {
        let o = self.command("cat").arg("/proc/net/dev").output().expect("cat /proc/net/dev");
        String::from_utf8_lossy(&o.stdout)
            .lines()
            .find_map(|l| l.trim().strip_prefix("lo:").map(str::to_string))
            .and_then(|rest| rest.split_whitespace().nth(1).and_then(|p| p.parse().ok()))
            .unwrap_or(0)
    }
}

impl Drop for LoopbackNs {
    fn drop(&mut self) {
        let _ = Command::new("ip").args(["netns", "del", &self.name]).output();
    }
}

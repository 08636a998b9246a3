//! `swarm scale --peer vmas`: a peer simulator flown at each row's size right after our run, so
//! the table quotes a speed as a ratio measured side by side (the two alternate through the
//! series), not as an absolute time that drifts with the shared machine's load.
//!
//! The peer is VMAS (PyPI `vmas`, PyTorch), the vectorized 2D multi-agent simulator swarm and
//! MARL researchers use, running its flocking scenario (agents with LIDAR among obstacles) on the
//! CPU with one environment. We do not ship it: `--peer-cmd` names the Python and the script that
//! drives it (the project's `vmas_flocking.py`, which prints one JSON line with `x_real_time`).
//! Each row gives it our row's UAVs as agents, our world's trees and walls as obstacles, our
//! LIDAR's beams as rays, and every core as torch threads.
//!
//! A peer that cannot reach a size in time is reported as not reached instead of holding the
//! study: a short probe (a few steps) first says how long a step takes, and the measured run
//! gets as many steps as fit in `--peer-budget-s` (at least [`MIN_STEPS`], at most
//! [`MAX_STEPS`]); a probe that itself overruns the budget is killed.

use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::time::Duration;

/// Fewest steps a measured peer run takes (fewer say little about a step's time).
const MIN_STEPS: u32 = 10;
/// Most steps a measured peer run takes.
const MAX_STEPS: u32 = 300;
/// Steps of the probe, after one warm-up step.
const PROBE_STEPS: u32 = 3;

/// Which peer `--peer` flies.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum Peer {
    /// VMAS's flocking scenario on the CPU (`vmas_flocking.py` protocol).
    Vmas,
}

/// The size a peer run reproduces: our row's.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PeerSize {
    /// Agents (our UAVs).
    pub agents: usize,
    /// Obstacles (our trees and walls).
    pub obstacles: usize,
    /// LIDAR rays per agent (our beams).
    pub rays: u32,
}

/// What one peer run gave, beside a row.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PeerRow {
    /// The peer's name and version, as it reported them (e.g. `vmas 1.5.2`).
    pub peer: String,
    /// Sim seconds per wall second; `None` when the size was out of the peer's reach.
    pub x_real_time: Option<f64>,
    /// Steps measured.
    pub steps: u32,
    /// Obstacles the peer's world held (our trees and walls).
    pub obstacles: usize,
    /// LIDAR rays per agent.
    pub rays: u32,
    /// Why there is no figure, when there is none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

/// The peer's command line: a program and its leading arguments (`PYTHON SCRIPT`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PeerCmd {
    program: String,
    args: Vec<String>,
}

impl PeerCmd {
    /// Parses `--peer-cmd` (whitespace-separated; the first word is the program).
    pub fn parse(text: &str) -> Result<PeerCmd> {
        let mut words = text.split_whitespace().map(str::to_string);
        let Some(program) = words.next() else { bail!("--peer-cmd is empty") };
        Ok(PeerCmd { program, args: words.collect() })
    }

    /// The arguments of one `vmas_flocking.py` run.
    fn vmas_args(&self, size: PeerSize, steps: u32, warmup: u32, threads: usize) -> Vec<String> {
        let mut a = self.args.clone();
        for (flag, v) in [
            ("--agents", size.agents.to_string()),
            ("--obstacles", size.obstacles.to_string()),
            ("--rays", size.rays.to_string()),
            ("--threads", threads.to_string()),
            ("--steps", steps.to_string()),
            ("--warmup", warmup.to_string()),
        ] {
            a.push(flag.into());
            a.push(v);
        }
        a
    }
}

/// What `vmas_flocking.py` prints (the fields we read).
#[derive(Debug, Clone, Deserialize)]
struct VmasLine {
    vmas: String,
    x_real_time: f64,
    steps_per_s: f64,
    #[serde(default)]
    make_s: f64,
}

/// The last line of `stdout` that is the peer's JSON result.
fn parse_vmas(stdout: &str) -> Result<VmasLine> {
    stdout
        .lines()
        .rev()
        .find_map(|l| serde_json::from_str::<VmasLine>(l.trim()).ok())
        .filter(|v| v.x_real_time.is_finite() && v.steps_per_s > 0.0)
        .context("the peer printed no JSON line with x_real_time and steps_per_s")
}

/// Runs the peer once; `Ok(None)` when it did not finish within `timeout` (killed).
async fn run_once(cmd: &PeerCmd, args: &[String], timeout: Duration) -> Result<Option<VmasLine>> {
    let child = tokio::process::Command::new(&cmd.program)
        .args(args)
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .kill_on_drop(true)
        .spawn()
        .with_context(|| format!("cannot start the peer `{}`", cmd.program))?;
    let Ok(out) = tokio::time::timeout(timeout, child.wait_with_output()).await else {
        return Ok(None);
    };
    let out = out.context("the peer did not finish")?;
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        let tail: Vec<&str> = err.lines().rev().take(5).collect();
        bail!("the peer failed ({}): {}", out.status, tail.into_iter().rev().collect::<Vec<_>>().join(" | "));
    }
    parse_vmas(&String::from_utf8_lossy(&out.stdout)).map(Some)
}

/// Steps that fit in `budget_s` at `steps_per_s`, leaving the environment's making time.
fn steps_for(budget_s: f64, make_s: f64, steps_per_s: f64) -> u32 {
    let fit = ((budget_s - 2.0 * make_s).max(0.0) * steps_per_s).floor();
    (fit as u32).clamp(MIN_STEPS, MAX_STEPS)
}

/// Flies the peer at `size`: a probe, then a run of as many steps as fit in `budget`.
pub async fn fly(cmd: &PeerCmd, size: PeerSize, budget: Duration) -> Result<PeerRow> {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let probe = run_once(cmd, &cmd.vmas_args(size, PROBE_STEPS, 1, threads), budget).await?;
    let Some(probe) = probe else {
        return Ok(PeerRow {
            peer: "vmas".into(),
            x_real_time: None,
            steps: 0,
            obstacles: size.obstacles,
            rays: size.rays,
            note: Some(format!("a {PROBE_STEPS}-step probe took over {:.0} s", budget.as_secs_f64())),
        });
    };
    let steps = steps_for(budget.as_secs_f64(), probe.make_s, probe.steps_per_s);
    // The measured run may take longer than the probe foretold (the probe is short): twice the
    // budget, then it is out of reach.
    let line = run_once(cmd, &cmd.vmas_args(size, steps, 5, threads), budget * 2).await?;
    Ok(match line {
        Some(v) => PeerRow {
            peer: format!("vmas {}", v.vmas),
            x_real_time: Some(v.x_real_time),
            steps,
            obstacles: size.obstacles,
            rays: size.rays,
            note: None,
        },
        None => PeerRow {
            peer: format!("vmas {}", probe.vmas),
            x_real_time: None,
            steps,
            obstacles: size.obstacles,
            rays: size.rays,
            note: Some(format!("{steps} steps took over {:.0} s", 2.0 * budget.as_secs_f64())),
        },
    })
}

/// Obstacles in a run folder's `world.json`: its trees and walls.
pub fn obstacles_in(run_dir: &Path) -> Result<usize> {
    let path = run_dir.join("world.json");
    let text = std::fs::read_to_string(&path).with_context(|| format!("cannot read {}", path.display()))?;
    let v: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("{} is not JSON", path.display()))?;
    let count = |k: &str| v.get(k).and_then(serde_json::Value::as_array).map_or(0, Vec::len);
    Ok(count("trees") + count("walls"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_command_gets_our_size_as_vmas_arguments() {
        let cmd = PeerCmd::parse("  /v/bin/python  /b/vmas_flocking.py ").expect("parses");
        let a = cmd.vmas_args(PeerSize { agents: 40, obstacles: 51, rays: 750 }, 120, 5, 2);
        assert_eq!(cmd.program, "/v/bin/python");
        assert_eq!(
            a.join(" "),
            "/b/vmas_flocking.py --agents 40 --obstacles 51 --rays 750 --threads 2 --steps 120 --warmup 5"
        );
        assert!(PeerCmd::parse("   ").is_err());
    }

    #[test]
    fn the_result_is_the_last_json_line() {
        let out = "loading\n{\"vmas\": \"1.5.2\", \"x_real_time\": 0.5, \"steps_per_s\": 5.0, \"make_s\": 1.2}\n";
        let v = parse_vmas(out).expect("found");
        assert_eq!((v.vmas.as_str(), v.x_real_time, v.steps_per_s, v.make_s), ("1.5.2", 0.5, 5.0, 1.2));
        assert!(parse_vmas("no json here\n{\"other\": 1}\n").is_err());
        assert!(parse_vmas("{\"vmas\": \"1\", \"x_real_time\": 0.5, \"steps_per_s\": 0.0}").is_err());
    }

    #[test]
    fn the_steps_fit_the_budget_within_bounds() {
        assert_eq!(steps_for(120.0, 1.0, 1.0), 118);
        assert_eq!(steps_for(120.0, 1.0, 100.0), MAX_STEPS);
        assert_eq!(steps_for(120.0, 1.0, 0.01), MIN_STEPS);
        assert_eq!(steps_for(1.0, 5.0, 10.0), MIN_STEPS);
    }

    #[test]
    fn obstacles_are_the_worlds_trees_and_walls() {
        let dir = std::env::temp_dir().join(format!("swarm-peer-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        std::fs::write(dir.join("world.json"), r#"{"trees": [1, 2, 3], "walls": [4], "starts": [5]}"#).expect("write");
        assert_eq!(obstacles_in(&dir).expect("read"), 4);
        std::fs::write(dir.join("world.json"), "not json").expect("write");
        assert!(obstacles_in(&dir).is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }
}

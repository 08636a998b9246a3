//! `swarm sweep-seeds SCENARIO --seeds 1..N`: one run is an anecdote (issue 14, item 4). This
//! flies the same scenario with the master seed set to each of `1..N` (so each run has its own
//! generated forest, sensor noise and link draws; fixed start positions stay fixed), several at
//! once, and reports every headline metric as a mean with its 95 % Student-t interval and the
//! success rate (goal reached and no collision) with its Wilson interval ([`crate::stats`]).
//!
//! Named apart from `swarm sweep-error`, which sweeps seed 001's broadcast error δa on one seed:
//! this one sweeps seeds and changes nothing else.
//!
//! Each run is the studies' own runner ([`crate::study::run_variant`], as `swarm compare` and
//! `swarm scale` fly theirs): a full `swarm run` in `<out>/seed-NNN`, whose `summary.json` stays
//! there. The sweep is resumable: a seed whose `summary.json` already exists is read back, not
//! flown again, so an interrupted sweep is finished by running the same command. Runs go
//! `--jobs` at a time (default: one per core) on this process's runtime (`study::run_bounded`,
//! which `swarm fuzz` shares), under an indicatif progress bar.
//!
//! Writes `sweep.md` (the table), `sweep.json` (per-seed values and the statistics) and
//! `sweep.svg` / `sweep.png` (each metric's distribution over seeds: [`chart`]). In lockstep the
//! outcomes repeat byte for byte; x real time is a wall-clock measurement and depends on how many
//! runs share the machine.

use crate::study::{run_bounded, run_variant, VariantRun};
use anyhow::{bail, Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use swarm_args::scenario_value;
use swarm_config::{LocalizationMode, Scenario};
use swarm_record::summary::Summary;
use uav_agent::Controllers;

mod chart;

use crate::stats::{self, mean_ci, mean_pm, num, wilson, MeanCi, Rate};
use crate::study::parse_seeds;

/// `swarm sweep-seeds`.
#[derive(Args, Debug, Clone)]
pub struct SweepSeedsArgs {
    /// Scenario file or built-in name.
    pub scenario: String,
    /// Seeds to fly: `A..B` (inclusive), a comma-separated list, or both (`1..5,9`).
    #[arg(long, default_value = "1..30")]
    pub seeds: String,
    /// Runs flown at once (default: one per core).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub jobs: Option<u32>,
    /// Override the localization mode (`icp`, `broadcast`, `uvdar`).
    #[arg(long)]
    pub localization: Option<String>,
    /// Cap every run's sim time [s] (default: the scenario's `end.time_limit_s`).
    #[arg(long)]
    pub time_limit: Option<f64>,
    /// Set a scenario field for every run, `SECTION.FIELD=VALUE` as `swarm run --set` takes it
    /// (repeatable); the default study folder then names the settings.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Fly each seed in this process as `swarm floor` does (one thread per run, no message,
    /// no process): the same flight as a lockstep run, at a fraction of its CPU. Refuses what the
    /// floor refuses (failures other than freezes, external controllers).
    #[arg(long)]
    pub floor: bool,
    /// Study folder (default: runs/sweep-seeds/<scenario>-<localization>[-<settings>]); seeds
    /// whose `seed-NNN/summary.json` is already in it are read back, not flown again.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// A headline metric: its key in `sweep.json`, its label in the table, and how to read it from
/// a run's summary (NaN: not defined for this run, left out of the mean).
pub struct Metric {
    /// Key in `sweep.json`.
    pub key: &'static str,
    /// Row label, with its unit.
    pub label: &'static str,
    /// The value of one run.
    pub value: fn(&Summary) -> f64,
}

/// Every headline metric of the results table in docs/results.md.
pub const METRICS: &[Metric] = &[
    Metric {
        key: "time_to_goal_s",
        label: "time to goal s (runs that arrived)",
        value: |s| s.time_to_goal_s.unwrap_or(f64::NAN),
    },
    Metric { key: "collisions", label: "collisions", value: |s| s.collisions as f64 },
    Metric { key: "min_obstacle_distance_m", label: "min obstacle distance m", value: |s| s.min_obstacle_distance_m },
    Metric { key: "min_agent_distance_m", label: "min UAV distance m", value: |s| s.min_agent_distance_m },
    Metric {
        key: "localization_mean_error_m",
        label: "localization mean error m",
        value: |s| s.localization.mean_error_m,
    },
    Metric {
        key: "localization_p95_error_m",
        label: "localization p95 error m",
        value: |s| s.localization.p95_error_m,
    },
    Metric {
        key: "false_estimates",
        label: "false estimates (> 1 m off)",
        value: |s| s.localization.false_estimates as f64,
    },
    Metric { key: "false_estimate_share_pct", label: "false estimate share %", value: false_share_pct },
    Metric {
        key: "stable_neighbour_share_pct",
        label: "stable neighbour count % of time",
        value: |s| 100.0 * s.localization.stable_neighbour_share,
    },
    Metric { key: "x_real_time", label: "x real time (wall clock, shared machine)", value: |s| s.sim_speed },
];

/// False estimates over estimates scored [%] (NaN: none scored).
fn false_share_pct(s: &Summary) -> f64 {
    let l = &s.localization;
    if l.estimates_scored == 0 {
        f64::NAN
    } else {
        100.0 * l.false_estimates as f64 / l.estimates_scored as f64
    }
}

/// A run succeeds when the goal rule was met with no collision at all.
pub fn succeeded(s: &Summary) -> bool {
    s.reached_goal && s.collisions == 0
}

/// One seed's run in `sweep.json`.
#[derive(Debug, Serialize)]
pub struct RunRow {
    /// Master seed.
    pub seed: u64,
    /// Goal reached and no collision.
    pub success: bool,
    /// Each metric of [`METRICS`], in order (null: undefined for this run).
    pub values: Vec<f64>,
}

/// One metric's statistics in `sweep.json`.
#[derive(Debug, Serialize)]
pub struct MetricRow {
    /// [`Metric::key`].
    pub key: &'static str,
    /// [`Metric::label`].
    pub label: &'static str,
    /// Mean, 95 % half-width, min, max over the runs where it is defined.
    #[serde(flatten)]
    pub stats: MeanCi,
}

/// `sweep.json`, schema `swarm.sweep-seeds.v1`.
#[derive(Debug, Serialize)]
pub struct Report {
    /// Always `swarm.sweep-seeds.v1`.
    pub schema: &'static str,
    /// Scenario name.
    pub scenario: String,
    /// Localization mode flown.
    pub localization: String,
    /// Confidence level of every interval.
    pub level: f64,
    /// Goal reached and no collision, with its Wilson interval.
    pub success: Rate,
    /// Statistics per metric.
    pub metrics: Vec<MetricRow>,
    /// Per seed, in seed order.
    pub runs: Vec<RunRow>,
}

impl Report {
    /// The report of `runs` (seed, summary), sorted by seed.
    pub fn new(scenario: &str, localization: &str, runs: &[(u64, Summary)]) -> Report {
        let rows: Vec<RunRow> = runs
            .iter()
            .map(|(seed, s)| RunRow {
                seed: *seed,
                success: succeeded(s),
                values: METRICS.iter().map(|m| (m.value)(s)).collect(),
            })
            .collect();
        let metrics = METRICS
            .iter()
            .enumerate()
            .map(|(i, m)| MetricRow {
                key: m.key,
                label: m.label,
                stats: mean_ci(&rows.iter().map(|r| r.values[i]).collect::<Vec<_>>()),
            })
            .collect();
        let k = rows.iter().filter(|r| r.success).count();
        Report {
            schema: "swarm.sweep-seeds.v1",
            scenario: scenario.to_string(),
            localization: localization.to_string(),
            level: stats::LEVEL,
            success: wilson(k, rows.len()),
            metrics,
            runs: rows,
        }
    }

    /// The Markdown table.
    pub fn table(&self) -> String {
        let mut t = String::new();
        let seeds = self.runs.iter().map(|r| r.seed);
        let (lo, hi) = (seeds.clone().min().unwrap_or(0), seeds.max().unwrap_or(0));
        let _ = writeln!(
            t,
            "# {} ({}), {} seeds ({lo}..{hi}): mean ± 95 % CI (Student t)\n",
            self.scenario,
            self.localization,
            self.runs.len()
        );
        let _ = writeln!(t, "| metric | runs | mean ± 95 % CI | min | max |");
        let _ = writeln!(t, "|---|---|---|---|---|");
        let s = &self.success;
        let _ = writeln!(
            t,
            "| success (goal, no collision) % | {} | {} ({}/{}; Wilson {}–{}) | | |",
            s.n,
            num(100.0 * s.share()),
            s.k,
            s.n,
            num(100.0 * s.lo),
            num(100.0 * s.hi)
        );
        for m in &self.metrics {
            let c = &m.stats;
            let _ = writeln!(t, "| {} | {} | {} | {} | {} |", m.label, c.n, mean_pm(c), num(c.min), num(c.max));
        }
        t
    }
}

/// The folder of one seed's run.
fn tag(seed: u64) -> String {
    format!("seed-{seed:03}")
}

/// The summary left by an earlier sweep in `out`, if that run finished.
fn flown(out: &Path, seed: u64) -> Option<Summary> {
    crate::study::finished(&out.join(tag(seed)))
}

/// The default study folder's name: the scenario, its localization mode, and the `--set`
/// settings (each `SECTION.FIELD=VALUE` with what a file name should not hold turned to `_`),
/// so runs of two settings never share a folder.
fn folder_name(scenario: &str, mode: &str, sets: &[String]) -> String {
    let mut name = format!("{scenario}-{mode}");
    for kv in sets {
        name.push('-');
        name.extend(kv.chars().map(|c| if c.is_ascii_alphanumeric() || "._=-".contains(c) { c } else { '_' }));
    }
    name
}

/// Runs `swarm sweep-seeds`.
pub async fn sweep_seeds(a: SweepSeedsArgs, controllers: &Controllers) -> Result<ExitCode> {
    let seeds = parse_seeds(&a.seeds)?;
    let (mut base, _) = Scenario::from_arg(&a.scenario)?;
    if let Some(m) = a.localization.as_deref() {
        base.localization.mode = scenario_value::<LocalizationMode>("--localization", m)?;
    }
    if let Some(t) = a.time_limit {
        base.end.time_limit_s = t;
    }
    if !a.set.is_empty() {
        (base, _) = crate::launch::with_sets(&base, &a.set, &a.scenario)?;
    }
    let mode = base.localization.mode.name();
    let out = a
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("runs").join("sweep-seeds").join(folder_name(&base.name, mode, &a.set)));
    std::fs::create_dir_all(&out).with_context(|| format!("cannot create {}", out.display()))?;
    let jobs = a.jobs.map_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()), |j| j as usize);

    let pb = ProgressBar::new(seeds.len() as u64);
    pb.set_style(
        ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} runs, {elapsed_precise} (eta {eta}) {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    pb.set_prefix(format!("{} {mode}", base.name));
    let (mut runs, todo): (Vec<_>, Vec<_>) = seeds.iter().map(|&s| (s, flown(&out, s))).partition(|(_, s)| s.is_some());
    let mut runs: Vec<(u64, Summary)> = runs.drain(..).filter_map(|(seed, s)| s.map(|s| (seed, s))).collect();
    for (seed, s) in &runs {
        // A run kept in the folder must be of this scenario and mode, or the table would mix
        // two experiments under one name.
        crate::study::same_variant(&out.join(tag(*seed)), s, &base)?;
    }
    pb.inc(runs.len() as u64);
    if !runs.is_empty() {
        // Not `pb.println`: a hidden bar (stderr not a terminal) prints nothing.
        pb.suspend(|| eprintln!("{} seeds already flown in {}: read back", runs.len(), out.display()));
    }
    let todo = todo.into_iter().map(|(s, _)| s).collect();
    let floor = a.floor.then_some(controllers);
    let failed = fly(&base, &out, todo, jobs, floor, &pb, &mut runs).await;
    pb.finish_and_clear();
    runs.sort_by_key(|(seed, _)| *seed);

    let report = Report::new(&base.name, mode, &runs);
    let table = report.table();
    std::fs::write(out.join("sweep.md"), &table)?;
    std::fs::write(out.join("sweep.json"), serde_json::to_string_pretty(&report)?)?;
    chart::write(&report, &out.join("sweep.svg"), &out.join("sweep.png"))?;
    print!("{table}");
    eprintln!("study folder: {} (sweep.md, sweep.json, sweep.svg, sweep.png; seed-NNN/ per run)", out.display());
    if failed.is_empty() {
        Ok(ExitCode::SUCCESS)
    } else {
        for (seed, e) in &failed {
            eprintln!("seed {seed}: {e:#}");
        }
        bail!(
            "{} of {} runs failed (left out of the table; run the same command again to retry them)",
            failed.len(),
            seeds.len()
        )
    }
}

/// The scenario of one seed's run.
fn seeded(base: &Scenario, seed: u64) -> Scenario {
    let mut sc = base.clone();
    sc.seed = seed;
    sc
}

/// Flies `todo` at most `jobs` at a time, pushing each finished run onto `runs`; returns the
/// seeds whose run failed. With `floor` (the controllers it flies), each seed is flown in this
/// process as `swarm floor` does ([`crate::floor::fly`], on a blocking thread) into its run
/// folder, whose summary is read back; otherwise as a `swarm run`.
async fn fly(
    base: &Scenario,
    out: &Path,
    todo: Vec<u64>,
    jobs: usize,
    floor: Option<&Controllers>,
    pb: &ProgressBar,
    runs: &mut Vec<(u64, Summary)>,
) -> Vec<(u64, anyhow::Error)> {
    let mut failed = Vec::new();
    let start = |seed: u64| {
        let sc = seeded(base, seed);
        let floor = floor.cloned();
        async move {
            let result = match floor {
                Some(controllers) => {
                    let dir = out.join(tag(seed));
                    tokio::task::spawn_blocking(move || {
                        crate::floor::fly(&sc, &controllers, Some(&dir), true)?;
                        crate::study::finished(&dir)
                            .with_context(|| format!("{}: no summary.json after the flight", dir.display()))
                    })
                    .await
                    .context("the flight's thread panicked")
                    .and_then(|r| r)
                }
                None => run_variant(&sc, out, &tag(seed), VariantRun::default()).await,
            };
            (seed, result)
        }
    };
    run_bounded(todo, jobs, start, |(seed, result)| {
        match result {
            Ok(s) => {
                pb.set_message(format!("seed {seed}: {}", if succeeded(&s) { "success" } else { "no success" }));
                runs.push((seed, s));
            }
            Err(e) => failed.push((seed, e)),
        }
        pb.inc(1);
    })
    .await;
    failed
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_setting_names_its_own_folder() {
        assert_eq!(folder_name("forest-5", "icp", &[]), "forest-5-icp");
        let sets = ["localization.icp.budget_per_step=8".to_string(), "end.goal_rule=\"any\" /x".to_string()];
        assert_eq!(
            folder_name("forest-5", "icp", &sets),
            "forest-5-icp-localization.icp.budget_per_step=8-end.goal_rule=_any___x"
        );
    }

    #[test]
    fn seeds_parse_as_ranges_and_lists() {
        assert_eq!(parse_seeds("1..3").expect("range"), vec![1, 2, 3]);
        assert_eq!(parse_seeds("1..=2, 5,2").expect("mixed"), vec![1, 2, 5]);
        assert_eq!(parse_seeds("7").expect("one"), vec![7]);
        assert!(parse_seeds("3..1").is_err() && parse_seeds("x").is_err() && parse_seeds("").is_err());
    }
}

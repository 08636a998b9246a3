//! `swarm fuzz`: Jepsen for swarms. From one seed, generate scenarios ([`case`]: forest density
//! and layout, start layout, swarm size, controller and localization mode, a nemesis schedule of
//! `netem::nemesis`), fly each in lockstep through the study runner (`study::run_variant`, `--jobs`
//! at a time), judge the invariants of `swarm_record::checks`, and shrink each failure ([`shrink`]) while the same
//! check still fails. The minimal failing scenario is written as a TOML file anyone can
//! `swarm run`, and printed; `fuzz.json` lists every case and finding. `--jobs` cases fly at once,
//! polled together in one task.
//!
//! Deterministic for a seed: case `i` is drawn from its own seed (the `i`-th draw of the master
//! stream), lockstep runs repeat, and shrinking tries candidates in a fixed order, one at a time.
//! `--minutes` only decides how many cases are started.
//!
//! Each case is drawn inside its controller's envelope ([`envelope`]); one outside it all the
//! same is printed with its reason and not flown, and the report has a table by controller.

mod case;
mod envelope;
mod shrink;

use crate::study::{run_bounded, run_variant, VariantRun};
use anyhow::{Context, Result};
use case::{Case, Space, Weaken};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use netem::nemesis::NemesisKind;
use rand::{Rng, SeedableRng};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};
use swarm_args::unix_secs;
use swarm_config::ControllerKind;
use swarm_record::summary::{CheckResult, Summary};

/// `swarm fuzz`.
#[derive(Args, Debug, Clone)]
pub struct FuzzArgs {
    /// Master seed: the same seed generates, flies and shrinks the same cases.
    #[arg(long)]
    pub seed: u64,
    /// Cases to fly (default 20 unless `--minutes` is given).
    #[arg(long)]
    pub runs: Option<usize>,
    /// Start no new case after this many wall minutes.
    #[arg(long)]
    pub minutes: Option<f64>,
    /// Cases flown at once.
    #[arg(long, default_value_t = 2)]
    pub jobs: usize,
    /// Output folder (default: runs/fuzz-<seed>-<time>).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Controllers to draw from, comma-separated (each flies from its built-in forest scenario).
    #[arg(long, default_value = "k21,p17,a21")]
    pub controllers: String,
    /// Largest swarm drawn.
    #[arg(long, default_value_t = 6)]
    pub max_uavs: u32,
    /// Nemesis kinds, comma-separated (partition, loss, burst, delay, duplicate, freeze,
    /// kill_restart, link_stall); default: those decided in sim time alone.
    #[arg(long, default_value = "partition,loss,burst,delay,duplicate,freeze")]
    pub nemesis: String,
    /// Most faults per case.
    #[arg(long, default_value_t = 3)]
    pub max_faults: usize,
    /// Weaken every case on purpose (`separation`: K21 separation gain 0 and cohesion pulling all
    /// the way in), to show a failure is found and shrunk.
    #[arg(long, value_enum)]
    pub weaken: Option<Weaken>,
    /// Runs each failure's shrinking may spend.
    #[arg(long, default_value_t = 30)]
    pub shrink_runs: usize,
}

/// One flown case, as `fuzz.json` lists it.
#[derive(Debug, Clone, Serialize)]
struct Flown {
    case: usize,
    label: String,
    /// `controller/localization`, the row of the summary by controller.
    controller: String,
    failed: Vec<String>,
    end_reason: String,
    /// Why the case is outside its controller's envelope (then it was not flown).
    #[serde(skip_serializing_if = "Option::is_none")]
    outside: Option<String>,
}

impl Flown {
    fn new(case: &Case, failed: Vec<String>, end_reason: &str) -> Flown {
        Flown {
            case: case.index,
            label: case.label(),
            controller: case.row(),
            failed,
            end_reason: end_reason.into(),
            outside: None,
        }
    }
}

/// A failure and its shrunk scenario.
#[derive(Debug, Clone, Serialize)]
struct Finding {
    case: usize,
    check: String,
    original: String,
    shrunk: String,
    first_failure: String,
    file: PathBuf,
    shrink_runs: usize,
}

/// A failed check a case is shrunk on: its first failing moment and what went wrong there.
#[derive(Debug, Clone, PartialEq)]
struct Failure {
    check: String,
    /// Sim time [s] (the run's end when the check says no moment).
    t_s: f64,
    what: String,
}

impl Failure {
    /// Check `c` of run `s` as failed: its first failure, or the run's end and no text when the
    /// check names no moment.
    fn of(c: &CheckResult, s: &Summary) -> Failure {
        let (t_s, what) = c.first_failure.as_ref().map_or((s.sim_time_s, String::new()), |f| (f.t_s, f.what.clone()));
        Failure { check: c.name.clone(), t_s, what }
    }
}

/// The check to shrink: the failed check whose first failure came first (checks judged as
/// they happen before those judged at the end).
fn first_failed(s: &Summary) -> Option<Failure> {
    s.failed_checks().map(|c| Failure::of(c, s)).min_by(|a, b| {
        (shrink::judged_at_end(&a.check), a.t_s)
            .partial_cmp(&(shrink::judged_at_end(&b.check), b.t_s))
            .unwrap_or(std::cmp::Ordering::Equal)
    })
}

fn space(a: &FuzzArgs) -> Result<Space> {
    let controllers: Vec<ControllerKind> =
        a.controllers.split(',').map(|c| swarm_args::scenario_value("--controllers", c)).collect::<Result<_>>()?;
    let nemesis: Vec<NemesisKind> = a
        .nemesis
        .split(',')
        .filter(|n| !n.trim().is_empty())
        .map(|n| swarm_args::scenario_value("--nemesis", n))
        .collect::<Result<_>>()?;
    anyhow::ensure!(!controllers.is_empty(), "--controllers: none given");
    if let Some(own) = controllers.iter().find(|k| matches!(k, ControllerKind::Own(_))) {
        anyhow::bail!(
            "--controllers: `{}` is not one of k21, p17, a21, m23 (the fuzzer flies the built-in controllers)",
            own.name()
        );
    }
    Ok(Space { controllers, max_uavs: a.max_uavs, nemesis, max_faults: a.max_faults, weaken: a.weaken })
}

/// Why `case` is outside its controller's envelope ([`envelope::outside`]), or `None`.
fn outside(case: &Case) -> Result<Option<String>> {
    Ok(envelope::outside(&case.render()?))
}

/// Flies `case` as `<out>/<tag>` and returns its summary.
async fn fly(case: &Case, out: &Path, tag: &str) -> Result<Summary> {
    run_variant(&case.render()?, out, tag, VariantRun { per_process: None, progress: false }).await
}

/// Flies a batch of cases at once (the study runner, as many at a time as the batch holds);
/// results come back in case order.
async fn fly_all(cases: Vec<Case>, out: &Path, pb: &ProgressBar) -> Vec<(Case, Result<Summary>)> {
    let jobs = cases.len();
    let mut flown = Vec::with_capacity(jobs);
    let start = |case: Case| async move {
        let r = fly(&case, out, &format!("case-{}", case.index)).await;
        (case, r)
    };
    run_bounded(cases, jobs, start, |done| {
        pb.inc(1);
        flown.push(done);
    })
    .await;
    flown.sort_by_key(|(case, _)| case.index);
    flown
}

/// Shrinks `case`, which fails as `first` says, while the same check still fails; returns the
/// smallest case, its failure (`first` itself when no candidate still fails) and the runs spent.
async fn shrink(case: Case, first: Failure, out: &Path, budget: usize, pb: &ProgressBar) -> (Case, Failure, usize) {
    let (mut best, mut failure, mut spent) = (case, first, 0);
    'outer: while spent < budget {
        for cand in shrink::candidates(&best, &failure.check, failure.t_s) {
            if spent >= budget {
                break 'outer;
            }
            // A smaller case outside the envelope (two groups once a UAV is gone) shows nothing.
            if !matches!(outside(&cand), Ok(None)) {
                continue;
            }
            spent += 1;
            pb.set_message(format!("shrinking case {}: {}", best.index, cand.label()));
            let tag = format!("shrink-{}-{spent}", best.index);
            let Ok(s) = fly(&cand, out, &tag).await else { continue };
            let hit = s.failed_checks().find(|c| c.name == failure.check).map(|c| Failure::of(c, &s));
            if let Some(f) = hit {
                failure = f;
                best = cand;
                continue 'outer;
            }
        }
        break;
    }
    (best, failure, spent)
}

/// Writes the shrunk case as a scenario file with a header saying what it shows; returns its text.
fn write_found(case: &Case, seed: u64, failure: &Failure, path: &Path) -> Result<String> {
    let Failure { check, t_s: at, what } = failure;
    let mut sc = case.render()?;
    sc.name = format!("found-{seed}-{}", case.index);
    let header = format!(
        "# Found by `swarm fuzz --seed {seed}` (case {}), shrunk: `swarm run {} --check` fails check\n# `{check}` first at t = {at:.1} s: {what}\n",
        case.index,
        path.display()
    );
    // Only what the case sets: the rest is every scenario's default.
    let text = format!("{header}{}", crate::scenarios::minimal_toml(&sc)?);
    std::fs::write(path, &text).with_context(|| format!("cannot write {}", path.display()))?;
    Ok(text)
}

/// Runs `swarm fuzz`.
pub async fn fuzz(a: FuzzArgs) -> Result<ExitCode> {
    let space = space(&a)?;
    let out = a.out.clone().unwrap_or_else(|| PathBuf::from("runs").join(format!("fuzz-{}-{}", a.seed, unix_secs())));
    std::fs::create_dir_all(&out).with_context(|| format!("cannot create {}", out.display()))?;
    let runs = a.runs.unwrap_or(if a.minutes.is_some() { usize::MAX } else { 20 });
    let deadline = a.minutes.map(|m| Instant::now() + Duration::from_secs_f64(m * 60.0));
    let pb = ProgressBar::new(if runs == usize::MAX { 0 } else { runs as u64 });
    pb.set_style(
        ProgressStyle::with_template("{elapsed:>4} [{bar:32}] {pos}/{len} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let mut master = rand_chacha::ChaCha8Rng::seed_from_u64(a.seed);
    let (mut flown, mut findings, mut next) = (Vec::new(), Vec::new(), 0usize);
    // Batches of `jobs` cases, so `--minutes` is checked between batches.
    while next < runs && deadline.is_none_or(|d| Instant::now() < d) {
        let drawn: Vec<Case> = (next..(next + a.jobs.max(1)).min(runs))
            .map(|i| Case::generate(&space, i, master.gen()))
            .collect::<Result<_>>()?;
        next += drawn.len();
        let mut batch = Vec::with_capacity(drawn.len());
        for case in drawn {
            match outside(&case)? {
                Some(why) => {
                    pb.inc(1);
                    pb.suspend(|| {
                        swarm_node::process::out(&format!(
                            "case {}: outside the envelope, not flown: {why}",
                            case.index
                        ))
                    });
                    flown.push(Flown { outside: Some(why), ..Flown::new(&case, Vec::new(), "outside_envelope") });
                }
                None => batch.push(case),
            }
        }
        if runs == usize::MAX {
            pb.set_length(next as u64);
        }
        let flights = if batch.is_empty() { Vec::new() } else { fly_all(batch, &out, &pb).await };
        for (case, r) in flights {
            let s = match r {
                Ok(s) => s,
                Err(e) => {
                    // A run that could not be flown is reported, not shrunk: the fuzz goes on.
                    tracing::warn!("case {} ({}): {e:#}", case.index, case.label());
                    flown.push(Flown::new(&case, vec!["run_error".into()], "error"));
                    continue;
                }
            };
            let failed: Vec<String> = s.failed_checks().map(|c| c.name.clone()).collect();
            flown.push(Flown::new(&case, failed, &s.end_reason));
            if let Some(first) = first_failed(&s) {
                let original = case.label();
                let (small, failure, spent) = shrink(case, first, &out, a.shrink_runs, &pb).await;
                let file = out.join(format!("found-{}-{}.toml", a.seed, small.index));
                write_found(&small, a.seed, &failure, &file)?;
                let Failure { check, what, .. } = failure;
                pb.suspend(|| {
                    swarm_node::process::out(&format!(
                        "case {}: `{check}` failed; shrunk from {original} to {}: {}",
                        small.index,
                        small.label(),
                        file.display()
                    ))
                });
                findings.push(Finding {
                    case: small.index,
                    check,
                    original,
                    shrunk: small.label(),
                    first_failure: what,
                    file,
                    shrink_runs: spent,
                });
            }
        }
    }
    pb.finish_and_clear();
    flown.sort_by_key(|f| f.case);
    report(&out, a.seed, &flown, &findings)
}

/// One row of the summary by controller and localization.
#[derive(Debug, Clone, Default, Serialize)]
struct Row {
    cases: usize,
    outside: usize,
    failed: usize,
    /// The checks its findings were shrunk on, with counts.
    shrunk_on: std::collections::BTreeMap<String, usize>,
}

/// The summary by `controller/localization`, in name order.
fn by_controller(flown: &[Flown], findings: &[Finding]) -> std::collections::BTreeMap<String, Row> {
    let mut rows: std::collections::BTreeMap<String, Row> = Default::default();
    for f in flown {
        let row = rows.entry(f.controller.clone()).or_default();
        row.cases += 1;
        row.outside += usize::from(f.outside.is_some());
        row.failed += usize::from(!f.failed.is_empty());
        if let Some(found) = findings.iter().find(|x| x.case == f.case) {
            *row.shrunk_on.entry(found.check.clone()).or_default() += 1;
        }
    }
    rows
}

/// Prints the tally and writes `fuzz.json`; exit status 2 when something failed.
fn report(out: &Path, seed: u64, flown: &[Flown], findings: &[Finding]) -> Result<ExitCode> {
    let rows = by_controller(flown, findings);
    let mut table = format!("fuzz seed {seed}, by controller:\n| controller | cases | outside the envelope | flown | failed | shrunk on |\n|---|---|---|---|---|---|\n");
    for (name, r) in &rows {
        let on: Vec<String> = r.shrunk_on.iter().map(|(c, n)| format!("`{c}` {n}")).collect();
        let flown = r.cases - r.outside;
        table += &format!("| {name} | {} | {} | {flown} | {} | {} |\n", r.cases, r.outside, r.failed, on.join(", "));
    }
    swarm_node::process::out(table.trim_end());
    let mut by_check: std::collections::BTreeMap<&str, usize> = Default::default();
    for f in flown {
        for c in &f.failed {
            *by_check.entry(c.as_str()).or_default() += 1;
        }
    }
    let failed = flown.iter().filter(|f| !f.failed.is_empty()).count();
    let outside = flown.iter().filter(|f| f.outside.is_some()).count();
    swarm_node::process::out(&format!(
        "fuzz seed {seed}: {} cases flown, {failed} failed, {outside} outside the envelope (not flown); failures by check: {by_check:?}",
        flown.len() - outside
    ));
    for f in findings {
        swarm_node::process::out(&format!(
            "  case {} `{}`: {} -> {} ({})",
            f.case,
            f.check,
            f.original,
            f.shrunk,
            f.file.display()
        ));
    }
    let json = serde_json::json!({
        "seed": seed,
        "flown": flown,
        "findings": findings,
        "failures_by_check": by_check,
        "by_controller": rows,
    });
    std::fs::write(out.join("fuzz.json"), serde_json::to_string_pretty(&json)?)?;
    swarm_node::process::out(&format!("fuzz folder: {}", out.display()));
    Ok(if failed > 0 { ExitCode::from(2) } else { ExitCode::SUCCESS })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn a_case() -> Case {
        let space = Space {
            controllers: vec![ControllerKind::K21],
            max_uavs: 4,
            nemesis: NemesisKind::DETERMINISTIC.to_vec(),
            max_faults: 2,
            weaken: None,
        };
        Case::generate(&space, 0, 7).expect("generates")
    }

    /// A shrink that makes no progress (here: no run to spend) keeps the failure it started from,
    /// text included: the finding's first-failure line is never left empty by the shrink.
    #[test]
    fn a_shrink_without_progress_keeps_the_first_failure_text() {
        let first = Failure { check: "min_separation".into(), t_s: 12.5, what: "UAV 1 and 2 at 0.4 m < 0.8 m".into() };
        let rt = tokio::runtime::Builder::new_current_thread().build().expect("runtime");
        let out = std::env::temp_dir().join(format!("fuzz-shrink-test-{}", std::process::id()));
        let (small, failure, spent) = rt.block_on(shrink(a_case(), first.clone(), &out, 0, &ProgressBar::hidden()));
        assert_eq!((small.index, spent), (0, 0));
        assert_eq!(failure, first);
    }

    #[test]
    fn a_found_file_says_the_first_failure() {
        let failure = Failure { check: "collision".into(), t_s: 3.5, what: "UAV 2 hit a tree".into() };
        let path = std::env::temp_dir().join(format!("fuzz-found-test-{}.toml", std::process::id()));
        let text = write_found(&a_case(), 9, &failure, &path).expect("written");
        let _ = std::fs::remove_file(&path);
        assert!(text.contains("# `collision` first at t = 3.5 s: UAV 2 hit a tree\n"), "{text}");
    }
}

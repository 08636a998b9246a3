//! Studies that run one scenario many times with one thing changed, and print (and plot) the
//! results side by side:
//!
//! - `swarm compare`: the same world and start flown by each controller (seed 000 section 6.5
//!   compares its method with the older one: 147 s vs 340 s to the goal).
//! - `swarm sweep-error`: the artificial broadcast-position error δa of seed 001 section 6, from
//!   0 to 4 m, on one UAV and on all, in free space and in a forest; min inter-UAV and min
//!   obstacle distance against δa (seed 001: safe up to 3 m in free space, 2 m in the forest).
//!
//! - `swarm formations`: seed 004's four topologies on its indoor world, optionally over lossy
//!   inter-agent links, in the shape of its Table 8 with the seed's numbers beside ours.
//!
//! Each run is a full `swarm run` (hub, agent processes, recorder) with its own run id and folder
//! under the study's folder, so any of them can be looked at afterwards. `swarm compare` and
//! `swarm formations` fly each variant once at the scenario's own seed, or once per master seed
//! with `--seeds` ([`Trials`]), and then print every number as a mean with its 95 % interval
//! (the `sweep-seeds` statistics); such a study is resumable like `sweep-seeds`.

use crate::launch::{agents_per_process, execute, How};
use crate::stats::{mean_ci, mean_pm, wilson};
use anyhow::{bail, Context, Result};
use clap::Args;
use std::fmt::Write as _;
use std::future::Future;
use std::path::{Path, PathBuf};
use std::pin::Pin;
use std::process::ExitCode;
use std::task::Poll;
use swarm_args::{default_run_id, scenario_value, unix_secs};
use swarm_config::{BroadcastError, ControllerKind, LocalizationMode, Scenario, UavSet};
use swarm_plot::{line_chart, Series};
use swarm_record::summary::{f, Summary};
use swarm_types::UavId;

/// `swarm compare`.
#[derive(Args, Debug, Clone)]
pub struct CompareArgs {
    /// Scenario file or built-in name (its controller is replaced by each of `--controllers`).
    #[arg(default_value = "compare-4")]
    pub scenario: String,
    /// Controllers to fly, comma-separated; `kind@mode` flies that one with its own localization
    /// (`k21@icp,a21@uvdar`: seed 000 6.5's K21 against its older method as it sensed).
    #[arg(long, default_value = "k21,a21,p17")]
    pub controllers: String,
    /// Override the localization mode of every run without its own `@mode` (`broadcast`, `icp`,
    /// `uvdar`).
    #[arg(long)]
    pub localization: Option<String>,
    /// Study folder (default: runs/compare-<time>).
    #[arg(long)]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub trials: Trials,
}

/// How many times a study flies each variant.
#[derive(Args, Debug, Clone, Default)]
pub struct Trials {
    /// Fly every variant once per master seed (`A..B`, a list, or both: `1..10,15`; each seed its
    /// own forest, noise and link draws) and print each number as a mean ± 95 % CI. Default: once,
    /// at the scenario's own seed. Runs already in `--out` are read back, not flown again.
    #[arg(long)]
    pub seeds: Option<String>,
    /// Runs flown at once (default: one, or one per core with `--seeds`).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub jobs: Option<u32>,
}

/// `swarm formations`.
#[derive(Args, Debug, Clone)]
pub struct FormationsArgs {
    /// The scenarios, one per topology, as `topology=scenario` pairs.
    #[arg(long, default_value = "none=m23-indoor-none,lf=m23-indoor-lf,pf=m23-indoor-pf,tnpf=m23-indoor-tnpf")]
    pub scenarios: String,
    /// i.i.d. loss on every inter-agent link [%] (0: none), added from the start.
    #[arg(long, default_value_t = 0.0)]
    pub loss: f64,
    /// Study folder (default: runs/formations-<time>).
    #[arg(long)]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub trials: Trials,
}

/// `swarm sweep-error`.
#[derive(Args, Debug, Clone)]
pub struct SweepArgs {
    /// Error magnitudes δa [m], comma-separated.
    #[arg(long, default_value = "0,0.5,1,1.5,2,2.5,3,3.5,4")]
    pub deltas: String,
    /// The free-space scenario.
    #[arg(long, default_value = "p17-error-free")]
    pub free: String,
    /// The forest scenario.
    #[arg(long, default_value = "p17-error-forest")]
    pub forest: String,
    /// Study folder (default: runs/sweep-error-<time>).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// How a study runs each variant.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct VariantRun {
    /// Agents per process (`None`: as `swarm run` picks).
    pub per_process: Option<u32>,
    /// Draw the run's sim-time progress bar.
    pub progress: bool,
}

/// Runs `sc` (after re-validating it) as `<out>/<tag>`; returns its summary.
pub(crate) async fn run_variant(sc: &Scenario, out: &Path, tag: &str, how: VariantRun) -> Result<Summary> {
    let text = toml::to_string(sc).context("cannot serialize the scenario")?;
    let sc = Scenario::from_toml_str(&text, &format!("{} ({tag})", sc.name))?;
    let run_id = default_run_id(&format!("{}-{tag}", sc.name)).replace(['.', '/'], "_");
    eprintln!("{tag}: running");
    let per_process = agents_per_process(sc.count(), how.per_process);
    // A study's runs are for its table: no MCAP recording each, and no journal (a killed
    // study flies its runs again).
    let show =
        crate::launch::Show { quiet: !how.progress, mcap: None, journal: false, view: None, ros2: None, gym: false };
    let run = How { zenoh_cfg: &[], show, per_process, insecure: false };
    let (summary, _) = execute(&sc, &text, &run_id, &out.join(tag), &run).await?;
    Ok(summary)
}

/// Drives the futures `start` makes of `items` (runs, as a rule), at most `jobs` at a time, and
/// hands each output to `done` as it finishes (in finishing order). `swarm sweep-seeds` and
/// `swarm fuzz` share it. The futures are polled together in this one task, not spawned: a run's
/// future is not `Send` (the recorder's tick callback) and blocks in place now and then; what
/// the runs wait on is their child processes, which fly in parallel.
pub(crate) async fn run_bounded<I, F: Future>(
    items: impl IntoIterator<Item = I>,
    jobs: usize,
    mut start: impl FnMut(I) -> F,
    mut done: impl FnMut(F::Output),
) {
    let mut queue = items.into_iter();
    let mut running: Vec<Pin<Box<F>>> = Vec::new();
    loop {
        while running.len() < jobs.max(1) {
            let Some(item) = queue.next() else { break };
            running.push(Box::pin(start(item)));
        }
        if running.is_empty() {
            return;
        }
        let (i, output) = std::future::poll_fn(|cx| {
            running
                .iter_mut()
                .enumerate()
                .find_map(|(i, f)| match f.as_mut().poll(cx) {
                    Poll::Ready(v) => Some(Poll::Ready((i, v))),
                    Poll::Pending => None,
                })
                .unwrap_or(Poll::Pending)
        })
        .await;
        drop(running.swap_remove(i));
        done(output);
    }
}

/// The runs of one study variant (a controller, a topology), in seed order.
pub(crate) struct Variant {
    /// Its tag: the row label and the folder under the study's.
    pub tag: String,
    /// The scenario it flies.
    pub scenario: Scenario,
    /// Its runs' summaries.
    pub runs: Vec<Summary>,
}

impl Variant {
    /// A variant not flown yet.
    pub fn new(tag: &str, scenario: Scenario) -> Variant {
        Variant { tag: tag.to_string(), scenario, runs: Vec::new() }
    }

    /// `value` over the runs: the value of a single run, or mean ± 95 % CI (`-` when undefined).
    pub fn cell(&self, value: impl Fn(&Summary) -> f64) -> String {
        mean_pm(&mean_ci(&self.runs.iter().map(value).collect::<Vec<_>>()))
    }

    /// A count summed over the runs, with how many runs had any: `0`, `3`, `3 (2 of 10 runs)`.
    pub fn count_cell(&self, value: impl Fn(&Summary) -> u64) -> String {
        let counts: Vec<u64> = self.runs.iter().map(value).collect();
        let (total, with) = (counts.iter().sum::<u64>(), counts.iter().filter(|&&c| c > 0).count());
        if self.runs.len() <= 1 || total == 0 {
            total.to_string()
        } else {
            format!("{total} ({with} of {} runs)", self.runs.len())
        }
    }

    /// Goal reached: `yes`/`no` for a single run, else `k/n` with the Wilson interval.
    pub fn goal_cell(&self) -> String {
        let k = self.runs.iter().filter(|s| s.reached_goal).count();
        match self.runs.len() {
            0 => "-".to_string(),
            1 => (if k == 1 { "yes" } else { "no" }).to_string(),
            n => {
                let r = wilson(k, n);
                format!("{k}/{n} ({:.0}–{:.0} %)", 100.0 * r.lo, 100.0 * r.hi)
            }
        }
    }
}

/// The summary of a finished run in `dir`, if there is one (an interrupted study resumes).
pub(crate) fn finished(dir: &Path) -> Option<Summary> {
    let text = std::fs::read_to_string(dir.join("summary.json")).ok()?;
    serde_json::from_str(&text).ok()
}

/// A run read back from a study's folder must be of the variant's scenario and localization mode,
/// or one row would mix two experiments.
pub(crate) fn same_variant(dir: &Path, s: &Summary, sc: &Scenario) -> Result<()> {
    let mode = sc.localization.mode.name();
    if s.scenario != sc.name || s.localization.mode != mode {
        bail!(
            "{} was flown as {} ({}), not {} ({mode}): give another --out, or remove the folder to fly it again",
            dir.display(),
            s.scenario,
            s.localization.mode,
            sc.name
        );
    }
    Ok(())
}

/// Flies every variant as `trials` says: once at its own seed in `<out>/<tag>`, or once per seed
/// in `<out>/<tag>/seed-NNN` (read back when already there), `--jobs` at a time. Returns the
/// runs that failed: the others are in the variants, for a table of what flew.
pub(crate) async fn fly_trials(variants: &mut [Variant], out: &Path, trials: &Trials) -> Result<Vec<anyhow::Error>> {
    let mut tags: Vec<&str> = variants.iter().map(|v| v.tag.as_str()).collect();
    tags.sort_unstable();
    if let Some(w) = tags.windows(2).find(|w| w[0] == w[1]) {
        bail!("`{}` is named twice: each variant flies into its own folder", w[0]);
    }
    let seeds = trials.seeds.as_deref().map(parse_seeds).transpose()?;
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let jobs = trials.jobs.map_or(if seeds.is_some() { cores } else { 1 }, |j| j as usize);
    let mut todo = Vec::new();
    let mut done: Vec<Vec<(u64, Summary)>> = vec![Vec::new(); variants.len()];
    for (i, v) in variants.iter().enumerate() {
        for seed in seeds.clone().unwrap_or_else(|| vec![v.scenario.seed]) {
            let tag = if seeds.is_some() { format!("{}/seed-{seed:03}", v.tag) } else { v.tag.clone() };
            match seeds.as_ref().and_then(|_| finished(&out.join(&tag))) {
                Some(s) => {
                    same_variant(&out.join(&tag), &s, &v.scenario)?;
                    done[i].push((seed, s))
                }
                None => todo.push((i, seed, tag)),
            }
        }
    }
    let mut failed = Vec::new();
    let start = |(i, seed, tag): (usize, u64, String)| {
        let mut sc = variants[i].scenario.clone();
        sc.seed = seed;
        async move {
            (i, seed, run_variant(&sc, out, &tag, VariantRun::default()).await.with_context(|| format!("{tag} failed")))
        }
    };
    run_bounded(todo, jobs, start, |(i, seed, result)| match result {
        Ok(s) => done[i].push((seed, s)),
        Err(e) => failed.push(e),
    })
    .await;
    for (v, mut runs) in variants.iter_mut().zip(done) {
        runs.sort_by_key(|(seed, _)| *seed);
        v.runs = runs.into_iter().map(|(_, s)| s).collect();
    }
    Ok(failed)
}

/// After the table: every failed run, then the study's error.
fn fail_after_table(failed: Vec<anyhow::Error>) -> Result<ExitCode> {
    if failed.is_empty() {
        return Ok(ExitCode::SUCCESS);
    }
    for e in &failed {
        eprintln!("{e:#}");
    }
    bail!(
        "{} run(s) failed, left out of the table (with --seeds, the same command and --out flies only those again)",
        failed.len()
    )
}

/// The line under a study's title: how many seeds each number is over.
fn over_seeds(variants: &[Variant]) -> String {
    match variants.first().map_or(0, |v| v.runs.len()) {
        0 | 1 => String::new(),
        n => format!(", each number the mean ± 95 % CI (Student t) over {n} seeds"),
    }
}

/// Runs `swarm compare`.
pub async fn compare(a: CompareArgs) -> Result<ExitCode> {
    let (base, _) = Scenario::from_arg(&a.scenario)?;
    let out = a.out.clone().unwrap_or_else(|| PathBuf::from("runs").join(format!("compare-{}", unix_secs())));
    // Every value is checked before the first run starts.
    let mode: Option<LocalizationMode> =
        a.localization.as_deref().map(|l| scenario_value("--localization", l)).transpose()?;
    let mut variants = Vec::new();
    for spec in a.controllers.split(',').map(str::trim) {
        let (kind, own) = match spec.split_once('@') {
            Some((k, m)) => (k, Some(scenario_value::<LocalizationMode>("--controllers", m)?)),
            None => (spec, None),
        };
        let mut sc = base.clone();
        sc.controller.kind = scenario_value::<ControllerKind>("--controllers", kind)?;
        if let Some(m) = own.or(mode) {
            sc.localization.mode = m;
        }
        variants.push(Variant::new(&spec.replace('@', "-"), sc));
    }
    let failed = fly_trials(&mut variants, &out, &a.trials).await?;
    let mut t = String::new();
    let _ = writeln!(t, "# {} — same world and start, one controller per run{}\n", base.name, over_seeds(&variants));
    let _ = writeln!(t, "| controller | goal | time to goal s (runs that arrived) | collisions | min obstacle m | min UAV m | mean path m |");
    let _ = writeln!(t, "|---|---|---|---|---|---|---|");
    for v in &variants {
        let _ = writeln!(
            t,
            "| {} | {} | {} | {} | {} | {} | {} |",
            v.tag,
            v.goal_cell(),
            v.cell(|s| s.time_to_goal_s.unwrap_or(f64::NAN)),
            v.count_cell(|s| s.collisions as u64),
            v.cell(|s| s.min_obstacle_distance_m),
            v.cell(|s| s.min_agent_distance_m),
            v.cell(|s| s.agents.iter().map(|a| a.path_length_m).sum::<f64>() / s.agents.len().max(1) as f64),
        );
    }
    let _ = writeln!(
        t,
        "\nseed 000 section 6.5 (4 UAVs, one informed): its method 147 s to the goal, the older one 340 s (2.3x)."
    );
    print!("{t}");
    std::fs::create_dir_all(&out)?;
    std::fs::write(out.join("compare.md"), &t)?;
    swarm_node::process::out(&format!("study folder: {}", out.display()));
    fail_after_table(failed)
}

/// Seed 004 Table 8: LF, PF, TNPF (obstacle distance, trajectory length, deviation) [m].
const TABLE_8: [(&str, [f64; 3]); 3] =
    [("lf", [1.81, 50.04, 0.89]), ("pf", [1.67, 48.13, 0.09]), ("tnpf", [1.62, 48.71, 0.08])];

/// Runs `swarm formations`.
pub async fn formations(a: FormationsArgs) -> Result<ExitCode> {
    if !(0.0..=100.0).contains(&a.loss) {
        bail!("--loss: a percentage in [0, 100], got {}", a.loss);
    }
    let out = a.out.clone().unwrap_or_else(|| PathBuf::from("runs").join(format!("formations-{}", unix_secs())));
    let mut variants = Vec::new();
    for pair in a.scenarios.split(',') {
        let (topology, name) = pair.split_once('=').with_context(|| format!("`{pair}`: expected topology=scenario"))?;
        let (mut sc, _) = Scenario::from_arg(name.trim())?;
        if a.loss > 0.0 {
            let rule = netem::impair::Impairment {
                loss: netem::impair::LossModel::Random { p: a.loss / 100.0 },
                ..netem::impair::Impairment::IDENTITY
            };
            sc.netem.push(swarm_config::NetemRule::link(0.0, UavSet::default(), UavSet::default(), rule));
        }
        variants.push(Variant::new(topology.trim(), sc));
    }
    let failed = fly_trials(&mut variants, &out, &a.trials).await?;
    let mut t = String::new();
    let loss = if a.loss > 0.0 { format!(", {} % inter-agent loss", a.loss) } else { String::new() };
    let _ = writeln!(
        t,
        "# seed 004 Table 8, ours beside the seed's (seed values in brackets){loss}{}\n",
        over_seeds(&variants)
    );
    let _ = writeln!(t, "| topology | collisions | goal s | obstacle distance m | trajectory m | deviation from neighbours m | blocking s |");
    let _ = writeln!(t, "|---|---|---|---|---|---|---|");
    for v in &variants {
        let seed = TABLE_8.iter().find(|(n, _)| *n == v.tag).map(|(_, v)| *v);
        let with = |value: fn(&Summary) -> f64, i: usize| match seed {
            Some(s) => format!("{} ({:.2})", v.cell(value), s[i]),
            None => v.cell(value),
        };
        let _ = writeln!(
            t,
            "| {} | {} | {} | {} | {} | {} | {} |",
            v.tag,
            v.count_cell(|s| s.collisions as u64),
            v.cell(|s| s.time_to_goal_s.unwrap_or(f64::NAN)),
            with(|s| s.formation.mean_obstacle_distance_m, 0),
            with(|s| s.formation.mean_trajectory_length_m, 1),
            with(|s| s.formation.neighbour_distance_deviation_m, 2),
            v.cell(|s| s.formation.mean_blocking_time_s)
        );
    }
    let _ = writeln!(
        t,
        "\nseed 004: PF and TNPF keep the formation far better than LF (deviation 0.09 / 0.08 m vs 0.89 m)."
    );
    print!("{t}");
    std::fs::create_dir_all(&out)?;
    std::fs::write(out.join("formations.md"), &t)?;
    swarm_node::process::out(&format!("study folder: {}", out.display()));
    fail_after_table(failed)
}

/// One point of the sweep.
struct Point {
    world: &'static str,
    who: &'static str,
    delta: f64,
    s: Summary,
}

/// Runs `swarm sweep-error`.
pub async fn sweep_error(a: SweepArgs) -> Result<ExitCode> {
    let deltas: Vec<f64> = a
        .deltas
        .split(',')
        .map(|d| d.trim().parse::<f64>().with_context(|| format!("`{d}` is not a number")))
        .collect::<Result<_>>()?;
    let out = a.out.clone().unwrap_or_else(|| PathBuf::from("runs").join(format!("sweep-error-{}", unix_secs())));
    let mut points = Vec::new();
    for (world, name) in [("free", &a.free), ("forest", &a.forest)] {
        let (base, _) = Scenario::from_arg(name)?;
        for (who, uavs) in [("one", UavSet::Ids(vec![UavId::new(1)])), ("all", UavSet::default())] {
            for &delta in &deltas {
                let mut sc = base.clone();
                sc.localization.mode = LocalizationMode::Broadcast;
                sc.localization.broadcast_error =
                    Some(BroadcastError { delta_a_m: delta, uavs: uavs.clone(), from_s: 0.0, until_s: None });
                let s = run_variant(&sc, &out, &format!("{world}-{who}-{delta}"), VariantRun::default()).await?;
                points.push(Point { world, who, delta, s });
            }
        }
    }
    let mut t = String::new();
    let _ = writeln!(t, "| world | error on | δa m | collisions | min UAV m | min obstacle m | goal |");
    let _ = writeln!(t, "|---|---|---|---|---|---|---|");
    for p in &points {
        let _ = writeln!(
            t,
            "| {} | {} | {:.1} | {} | {} | {} | {} |",
            p.world,
            p.who,
            p.delta,
            p.s.collisions,
            f(p.s.min_agent_distance_m),
            f(p.s.min_obstacle_distance_m),
            if p.s.reached_goal { "yes" } else { "no" }
        );
    }
    let _ = writeln!(t, "\nseed 001 section 6.1 (its parameters, d = w = 8 m, 30 Hz): safe up to δa = 3 m in free space (error on one UAV), 2 m in the forest.");
    print!("{t}");
    std::fs::create_dir_all(&out)?;
    std::fs::write(out.join("sweep.md"), &t)?;
    std::fs::write(out.join("sweep.svg"), sweep_svg(&points)?)?;
    swarm_node::process::out(&format!("study folder: {} (sweep.md, sweep.svg)", out.display()));
    Ok(ExitCode::SUCCESS)
}

/// Min distances against δa, one line per (world, error on, distance kind).
fn sweep_svg(points: &[Point]) -> anyhow::Result<String> {
    let mut series = Vec::new();
    for world in ["free", "forest"] {
        for who in ["one", "all"] {
            for obstacle in [false, true] {
                let pts: Vec<[f64; 2]> = points
                    .iter()
                    .filter(|p| p.world == world && p.who == who)
                    .map(|p| [p.delta, if obstacle { p.s.min_obstacle_distance_m } else { p.s.min_agent_distance_m }])
                    .filter(|p| p[1].is_finite())
                    .collect();
                if !pts.is_empty() {
                    let what = if obstacle { "obstacle" } else { "UAV" };
                    series.push(Series {
                        label: format!("{world}, error on {who}: min {what}"),
                        points: pts,
                        dashed: obstacle,
                    });
                }
            }
        }
    }
    // The red line: two bodies of the default radius touch.
    line_chart(
        "min distances against the broadcast error δa (seed 001 section 6)",
        "δa [m]",
        "distance [m]",
        &series,
        Some(0.6),
    )
}

/// `A..B`, `A`, comma-separated, in order, without repeats.
pub fn parse_seeds(text: &str) -> Result<Vec<u64>> {
    let mut seeds = Vec::new();
    for part in text.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let n = |s: &str| s.trim().parse::<u64>().with_context(|| format!("--seeds: `{s}` is not a seed"));
        let range = match part.split_once("..") {
            Some((a, b)) => n(a)?..=n(b.trim_start_matches('='))?,
            None => n(part)?..=n(part)?,
        };
        if range.is_empty() {
            bail!("--seeds: `{part}` is an empty range");
        }
        seeds.extend(range.filter(|s| !seeds.contains(s)).collect::<Vec<_>>());
    }
    anyhow::ensure!(!seeds.is_empty(), "--seeds: no seed in `{text}`");
    Ok(seeds)
}

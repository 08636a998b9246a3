//! `swarm icp-eval`: is the initial ICP ever confidently wrong (issue 14, item 2)? Runs pairs of
//! obstacle sets ([`cases`]: generated from a seed, or read from `--cases FILE`) through the very
//! decision the neighbour database takes on a neighbour it has not placed yet,
//! [`uav_agent::icp::place_unknown`] (full-grid ICP, ambiguity test, FRMSD threshold), and counts
//! per case one of three outcomes: *right* (placed within [`RIGHT_M`] and [`RIGHT_DEG`] of the
//! truth), *no estimate* (refused: ambiguous, FRMSD too high, or degenerate), or *wrong but
//! accepted* (placed anywhere else: what the controller would then fly on). Split by the trees
//! the two views share (≥ 5, 3–4, fewer), with the wall time per case.
//!
//! The peer is Open3D's point-to-point ICP from the same grid of starts, as issue 14 measured it
//! (82.5 % right, 44.7 ms a pair): quoted, not run here. Targets from the issue: right on ≥ 99 %
//! of the pairs sharing ≥ 5 trees, wrong-but-accepted on ≤ 1 % of all pairs, ≤ 1 ms a pair.
//! Each case is timed on the wall clock and in CPU time of this thread (Linux schedstat), which
//! is what the target is judged on: the wall clock counts whatever else the machine is doing.

use anyhow::{Context, Result};
use clap::Args;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;
use swarm_config::Scenario;
use uav_agent::icp::{place_unknown, Placement};

pub mod cases;

use cases::{Case, Views};

/// A placement this close to the truth is right [m] ...
pub const RIGHT_M: f64 = 0.1;
/// ... and turned this little from it [deg].
pub const RIGHT_DEG: f64 = 2.0;

/// Open3D's point-to-point ICP from the same grid of starts, as issue 14 quotes it: share right,
/// and wall time per pair [ms].
pub const OPEN3D_PEER: (f64, f64) = (0.825, 44.7);

/// `swarm icp-eval`.
#[derive(Args, Debug, Clone)]
pub struct IcpEvalArgs {
    /// Cases as JSON: a list of `{"reference": [[x, y], ...], "source": [[x, y], ...], "truth":
    /// {"x", "y", "heading"}}`, truth = the source UAV's pose in the reference UAV's body frame
    /// [m, rad]. Without it, cases are generated from `--seed`.
    #[arg(long)]
    pub cases: Option<PathBuf>,
    /// Seed of the generated cases.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Number of generated cases.
    #[arg(long = "cases-n", default_value_t = 300)]
    pub cases_n: usize,
    /// Tree density of the generated cases [trees per 100 m²].
    #[arg(long, default_value_t = 5.0)]
    pub density: f64,
    /// Scenario whose `[localization.icp]` parameters are used (file or built-in name).
    #[arg(long, default_value = "forest-5")]
    pub scenario: String,
    /// Write the generated (or read) cases to this JSON file.
    #[arg(long)]
    pub save_cases: Option<PathBuf>,
    /// Print one JSON line instead of the table.
    #[arg(long)]
    pub json: bool,
    /// After the table, one line per case: shared trees, outcome, FRMSD and pairs of the best
    /// alignment, runner-up FRMSD over the best's, error from the truth.
    #[arg(long)]
    pub details: bool,
}

/// What the decision made of one case.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Outcome {
    /// Placed within [`RIGHT_M`] and [`RIGHT_DEG`].
    Right,
    /// Not placed because another alignment fits nearly as well.
    Ambiguous,
    /// Not placed: no alignment, or FRMSD above the threshold.
    NoFit,
    /// Placed, but not right.
    WrongAccepted,
}

/// The outcome of `placement` against `case`'s truth.
pub fn outcome(case: &Case, placement: &Placement) -> Outcome {
    match placement {
        Placement::Ambiguous(_) => Outcome::Ambiguous,
        Placement::NoFit(_) => Outcome::NoFit,
        Placement::Placed(m) => {
            let t = &m.agent_from_neighbour;
            let off_m = (t.translation_m.x - case.truth.x).hypot(t.translation_m.y - case.truth.y);
            let d = t.rotation_rad - case.truth.heading;
            // The heading difference wrapped to (−π, π].
            let off_rad = d.sin().atan2(d.cos()).abs();
            if off_m < RIGHT_M && off_rad < RIGHT_DEG.to_radians() {
                Outcome::Right
            } else {
                Outcome::WrongAccepted
            }
        }
    }
}

/// Counts over a group of cases.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Group {
    /// Cases in the group.
    pub cases: usize,
    /// Placed right.
    pub right: usize,
    /// Refused as ambiguous.
    pub ambiguous: usize,
    /// Refused for no fit.
    pub no_fit: usize,
    /// Placed wrong.
    pub wrong_accepted: usize,
    /// Wall time of the decision, summed [ms].
    pub total_ms: f64,
    /// Its mean per case [ms].
    pub ms_per_case: f64,
    /// CPU time of the decision, summed [ms] (NaN where the OS does not say, see [`thread_cpu_ms`]).
    pub cpu_total_ms: f64,
    /// Its mean per case [ms]: what the decision costs whatever else the machine is doing.
    pub cpu_ms_per_case: f64,
}

impl Group {
    fn add(&mut self, o: Outcome, ms: f64, cpu_ms: f64) {
        self.cases += 1;
        self.total_ms += ms;
        self.ms_per_case = self.total_ms / self.cases as f64;
        self.cpu_total_ms += cpu_ms;
        self.cpu_ms_per_case = self.cpu_total_ms / self.cases as f64;
        match o {
            Outcome::Right => self.right += 1,
            Outcome::Ambiguous => self.ambiguous += 1,
            Outcome::NoFit => self.no_fit += 1,
            Outcome::WrongAccepted => self.wrong_accepted += 1,
        }
    }
    /// `k` as a share of the group's cases (NaN if empty).
    fn share(&self, k: usize) -> f64 {
        if self.cases == 0 {
            f64::NAN
        } else {
            k as f64 / self.cases as f64
        }
    }
}

/// The evaluation: every case, and the groups by shared trees (`--json` prints it on one line).
#[derive(Debug, Clone, Default, Serialize)]
pub struct Report {
    /// What was evaluated.
    pub source: String,
    /// The quoted peer: Open3D's share right and ms per pair (issue 14).
    pub peer_open3d: (f64, f64),
    /// All cases.
    pub all: Group,
    /// Cases whose views share at least 5 trees.
    pub shared_5_plus: Group,
    /// ... 3 or 4 trees.
    pub shared_3_4: Group,
    /// ... fewer than 3.
    pub shared_0_2: Group,
    /// Per case, in order.
    #[serde(skip)]
    pub details: Vec<Detail>,
}

/// One case as `--details` prints it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Detail {
    /// Trees both views share.
    pub shared: usize,
    /// What the decision made of it.
    pub outcome: Outcome,
    /// FRMSD of the best alignment (NaN: none).
    pub frmsd: f64,
    /// Pairs it kept (0: none).
    pub pairs: usize,
    /// Runner-up FRMSD over the best's (NaN: no runner-up, or not known).
    pub runner_up_ratio: f64,
    /// Distance of the best alignment's position from the truth [m] (NaN: none).
    pub error_m: f64,
}

impl Detail {
    fn new(case: &Case, shared: usize, outcome: Outcome, placement: &Placement) -> Detail {
        let (best, ratio) = match placement {
            Placement::Placed(m) => (Some(*m), f64::NAN),
            Placement::NoFit(m) => (*m, f64::NAN),
            Placement::Ambiguous(r) => (Some(r.best), r.runner_up.map_or(f64::NAN, |u| u.frmsd / r.best.frmsd)),
        };
        let error_m = best.map_or(f64::NAN, |m| {
            (m.agent_from_neighbour.translation_m.x - case.truth.x)
                .hypot(m.agent_from_neighbour.translation_m.y - case.truth.y)
        });
        Detail {
            shared,
            outcome,
            frmsd: best.map_or(f64::NAN, |m| m.frmsd),
            pairs: best.map_or(0, |m| m.pairs),
            runner_up_ratio: ratio,
            error_m,
        }
    }
}

/// Runs every case through the database's decision with `params`.
pub fn evaluate(all: &[Case], params: &swarm_config::IcpParams) -> Report {
    let mut r = Report { peer_open3d: OPEN3D_PEER, ..Report::default() };
    for case in all {
        let pts = |v: &[[f64; 2]]| v.iter().map(|p| nalgebra::Point2::new(p[0], p[1])).collect::<Vec<_>>();
        let (reference, source) = (pts(&case.reference), pts(&case.source));
        let (started, cpu_before) = (Instant::now(), thread_cpu_ms());
        let placement = place_unknown(&reference, &source, params);
        let ms = started.elapsed().as_secs_f64() * 1e3;
        let cpu_ms = thread_cpu_ms() - cpu_before;
        let o = outcome(case, &placement);
        let shared = case.shared();
        r.all.add(o, ms, cpu_ms);
        match shared {
            5.. => r.shared_5_plus.add(o, ms, cpu_ms),
            3..=4 => r.shared_3_4.add(o, ms, cpu_ms),
            _ => r.shared_0_2.add(o, ms, cpu_ms),
        }
        r.details.push(Detail::new(case, shared, o, &placement));
    }
    r
}

/// CPU time this thread has run so far [ms]: the first field of Linux's
/// `/proc/thread-self/schedstat` (ns on the CPU); NaN where it cannot be read.
fn thread_cpu_ms() -> f64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse::<f64>().ok())
        .map_or(f64::NAN, |ns| ns / 1e6)
}

fn pct(v: f64) -> String {
    if v.is_finite() {
        format!("{:.1} %", 100.0 * v)
    } else {
        "-".into()
    }
}

impl Report {
    /// The Markdown table, the peer's row and the targets.
    pub fn table(&self) -> String {
        let mut t = String::new();
        let _ = writeln!(t, "# swarm icp-eval: {}\n", self.source);
        let _ = writeln!(t, "| cases | n | right | no estimate (ambiguous + no fit) | wrong but accepted | CPU ms per case | wall ms per case |");
        let _ = writeln!(t, "|---|---|---|---|---|---|---|");
        for (name, g) in [
            ("all", &self.all),
            ("sharing >= 5 trees", &self.shared_5_plus),
            ("sharing 3-4 trees", &self.shared_3_4),
            ("sharing < 3 trees", &self.shared_0_2),
        ] {
            let _ = writeln!(
                t,
                "| {name} | {} | {} | {} ({} + {}) | {} | {:.2} | {:.2} |",
                g.cases,
                pct(g.share(g.right)),
                pct(g.share(g.ambiguous + g.no_fit)),
                g.ambiguous,
                g.no_fit,
                pct(g.share(g.wrong_accepted)),
                g.cpu_ms_per_case,
                g.ms_per_case
            );
        }
        let (right, ms) = OPEN3D_PEER;
        let _ = writeln!(t, "| peer: Open3D point-to-point ICP, same grid of starts (issue 14, quoted, not measured) | 300 | {} | | | | {ms:.1} |", pct(right));
        let ok = |b: bool| if b { "met" } else { "NOT met" };
        let r5 = self.shared_5_plus.share(self.shared_5_plus.right);
        let wa = self.all.share(self.all.wrong_accepted);
        let _ = writeln!(
            t,
            "\ntargets: right >= 99 % sharing >= 5 trees: {} ({}); wrong but accepted <= 1 % of all: {} ({}); <= 1 ms a case: {} ({:.2} ms of CPU).",
            ok(r5 >= 0.99),
            pct(r5),
            ok(wa <= 0.01),
            pct(wa),
            ok(self.all.cpu_ms_per_case <= 1.0),
            self.all.cpu_ms_per_case
        );
        let _ = writeln!(t, "right: placed within {RIGHT_M} m and {RIGHT_DEG} deg of the truth; every other placement is wrong but accepted.");
        t
    }
}

/// Runs `swarm icp-eval`.
pub async fn icp_eval(a: IcpEvalArgs) -> Result<ExitCode> {
    let (sc, _) = Scenario::from_arg(&a.scenario)?;
    let (all, what) = match &a.cases {
        Some(path) => {
            let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
            let all: Vec<Case> =
                serde_json::from_str(&text).with_context(|| format!("{}: not a list of cases", path.display()))?;
            let what = format!("{} cases from {}", all.len(), path.display());
            (all, what)
        }
        None => {
            let v = Views { density_per_100m2: a.density, ..Views::default() };
            let all = cases::generate(a.seed, a.cases_n, &v);
            let what = format!(
                "seed {}, trees within {} m, {} % missed, sigma {} m, {}-{} m apart, {} trees/100 m2",
                a.seed,
                v.range_m,
                100.0 * v.miss,
                v.sigma_m,
                v.distance_m.0,
                v.distance_m.1,
                v.density_per_100m2
            );
            (all, what)
        }
    };
    if let Some(p) = &a.save_cases {
        std::fs::write(p, serde_json::to_string(&all)?).with_context(|| format!("cannot write {}", p.display()))?;
    }
    let report = Report { source: what, ..evaluate(&all, &sc.localization.icp) };
    if a.json {
        swarm_node::process::out(&serde_json::to_string(&report)?);
    } else {
        print!("{}", report.table());
    }
    if a.details {
        swarm_node::process::out("\ncase shared outcome frmsd pairs runner_up_ratio error_m");
        for (i, d) in report.details.iter().enumerate() {
            swarm_node::process::out(&format!(
                "{i} {} {:?} {:.3} {} {:.2} {:.2}",
                d.shared, d.outcome, d.frmsd, d.pairs, d.runner_up_ratio, d.error_m
            ));
        }
    }
    Ok(ExitCode::SUCCESS)
}

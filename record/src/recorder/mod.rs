//! The recorder: a Zenoh client that listens to `truth/**` and every agent's `state`, writes
//! `trajectories.csv` (one row per UAV per tick), `agent_states.csv` and `localization.csv`, `run.mcap` (through
//! [`crate::scene`], unless `--no-mcap`), and
//! folds everything into the run's [`Summary`](crate::summary::Summary) (`summary.json`) when
//! the hub marks the last step; then it writes `world.json`, `connectivity.csv` and the figures
//! of [`swarm_plot`].
//!
//! - [`metrics`]: the pure folding, [`Metrics`](metrics::Metrics), fed message by message and
//!   tested without a network.
//! - [`solitude`]: each UAV's time out of radio reach of every other, its rejoining and how far it
//!   strayed (ground truth; the lost-contact behaviour's yardstick).
//! - `tally`: a count per distinct value with a running sum, for the quantiles of quantities
//!   that take few values (estimate ages, share delays) in memory that does not grow with the run.
//! - `fixed`: numbers with a fixed count of decimals, std's text without std's exact algorithm
//!   where it is not needed (the CSVs write about 17 000 a tick at 1000 UAVs).
//! - `files`: the run folder's files: the CSVs that grow while the run goes, and those written
//!   at its end.
//! - `recording`: the Zenoh side, [`Recording`]: session, subscriptions, the loop that ends with
//!   the run; and [`replay`], the same folding from a killed run's journal.
//! - [`journal`]: the payloads the recorder folded, kept until the run ends cleanly, and the
//!   whole-chunk salvage of an MCAP file whose writer was killed (`swarm recover`).
//! - `recover`: `swarm recover`, a killed run's folder made whole from its journal and chunks.
//!
//! `swarm run` starts a [`Recording`] beside its children; `swarm record` ([`record`]) is the
//! recorder alone, for a run whose pieces were started by hand.

mod files;
mod fixed;
pub mod journal;
pub mod metrics;
mod recording;
mod recover;
pub mod solitude;
mod tally;

pub use files::write_trajectory_rows;
pub use recording::{replay, Offline, Recording};
pub use recover::{cut_short, recover, RecoverArgs};

use crate::scene::Detail;
use anyhow::{Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;
use std::process::ExitCode;
use swarm_args::ZenohArgs;
use swarm_config::Scenario;

/// `swarm record`.
#[derive(Args, Debug, Clone)]
pub struct RecordArgs {
    /// Run id.
    #[arg(long)]
    pub run: String,
    /// Run folder.
    #[arg(long)]
    pub out: PathBuf,
    /// Endpoints.
    #[command(flatten)]
    pub zenoh: ZenohArgs,
    /// What `run.mcap` keeps.
    #[command(flatten)]
    pub mcap: McapArgs,
}

/// What `run.mcap` keeps (`swarm run`, `swarm record`; docs/watching-and-recording.md).
#[derive(Args, Debug, Clone, Default)]
pub struct McapArgs {
    /// Do not write `run.mcap` (the Foxglove recording of the run).
    #[arg(long)]
    pub no_mcap: bool,
    /// Keep each UAV's scans, estimates and numbers, and the radio graph, every K-th time only
    /// (poses, trails and events always). Default: 1 up to 50 UAVs, then ceil(UAVs / 50).
    #[arg(long, value_name = "K", value_parser = clap::value_parser!(u64).range(1..))]
    pub mcap_every: Option<u64>,
    /// Keep scans, estimates and numbers of these UAVs only, e.g. `1-4,9` (default: all).
    #[arg(long, value_parser = swarm_args::parse_ids, value_name = "IDS")]
    pub mcap_uavs: Option<swarm_args::UavIds>,
    /// Keep no journal (`journal.mcap`, removed at a clean end): a killed run's summary, CSVs
    /// and figures then cannot be rebuilt by `swarm recover` (its run.mcap still can).
    #[arg(long)]
    pub no_journal: bool,
}

impl McapArgs {
    /// What a recording of `uavs` UAVs keeps, or `None` with `--no-mcap`.
    pub fn detail(&self, uavs: usize) -> Option<Detail> {
        if self.no_mcap {
            return None;
        }
        let mut d = Detail::auto(uavs as u64);
        if let Some(k) = self.mcap_every {
            d.every = k;
        }
        d.uavs = self.mcap_uavs.as_ref().map(|ids| ids.0.iter().copied().collect());
        Some(d)
    }
}

/// Runs `swarm record`: the recorder alone, for a run whose pieces were started by hand.
pub async fn record(a: RecordArgs) -> Result<ExitCode> {
    anyhow::ensure!(!a.zenoh.connect.is_empty(), "the recorder needs --connect <hub endpoint>");
    std::fs::create_dir_all(&a.out).with_context(|| format!("cannot create {}", a.out.display()))?;
    let mut rec = Recording::start(&a.run, &a.zenoh.connect, &a.zenoh.session_cfg()?, !a.mcap.no_mcap).await?;
    let (sc, text) = rec.fetch_scenario().await?;
    // What `swarm recover` reads, as `swarm run` leaves it.
    let scenario_path = a.out.join("scenario.toml");
    std::fs::write(&scenario_path, text).with_context(|| format!("cannot write {}", scenario_path.display()))?;
    rec.write_mcap(&sc, &a.out, a.mcap.detail(sc.count()))?;
    if a.mcap.no_journal {
        rec.without_journal();
    }
    let progress = progress_bar(&sc, false);
    let summary = rec.record(&a.out, &sc, &progress, None, &mut |_| Ok(())).await?;
    progress.finish_and_clear();
    println!("{}", summary.human());
    Ok(summary.exit_code(true))
}

/// The progress bar a recording draws (hidden when `quiet`), one position per control tick.
pub fn progress_bar(sc: &Scenario, quiet: bool) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let ticks = (sc.end.time_limit_s * sc.time.control_hz).ceil() as u64;
    let pb = ProgressBar::new(ticks);
    pb.set_style(
        ProgressStyle::with_template("{elapsed:>4} [{bar:32}] {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    pb
}

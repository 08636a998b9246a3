//! The recorder: a Zenoh client that listens to `truth/**` and every agent's `state`, writes
//! `trajectories.csv` (one row per UAV per tick), `agent_states.csv` and `localization.csv`, `run.mcap` (through
//! [`crate::scene`], unless `--no-mcap`), and
//! folds everything into the run's [`Summary`](crate::summary::Summary) (`summary.json`) when
//! the hub marks the last step; then it writes `world.json`, `connectivity.csv` and the figures
//! of [`crate::plot`].
//!
//! - [`metrics`]: the pure folding, [`Metrics`](metrics::Metrics), fed message by message and
//!   tested without a network.
//! - [`solitude`]: each UAV's time out of radio reach of every other, its rejoining and how far it
//!   strayed (ground truth; the lost-contact behaviour's yardstick).
//! - `files`: the run folder's files: the CSVs that grow while the run goes, and those written
//!   at its end.
//! - `recording`: the Zenoh side, [`Recording`]: session, subscriptions, the loop that ends with
//!   the run.
//!
//! `swarm run` starts a [`Recording`] beside its children; `swarm record` ([`record`]) is the
//! recorder alone, for a run whose pieces were started by hand.

mod files;
pub mod metrics;
mod recording;
pub mod solitude;

pub use recording::Recording;

use crate::args::ZenohArgs;
use anyhow::{Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;
use std::process::ExitCode;
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
    /// Do not write `run.mcap` (the Foxglove recording of the run).
    #[arg(long)]
    pub no_mcap: bool,
}

/// Runs `swarm record`: the recorder alone, for a run whose pieces were started by hand.
pub async fn record(a: RecordArgs) -> Result<ExitCode> {
    anyhow::ensure!(!a.zenoh.connect.is_empty(), "the recorder needs --connect <hub endpoint>");
    std::fs::create_dir_all(&a.out).with_context(|| format!("cannot create {}", a.out.display()))?;
    let mut rec = Recording::start(&a.run, &a.zenoh.connect, &a.zenoh.session_cfg()?, !a.no_mcap).await?;
    let sc = rec.fetch_scenario().await?;
    rec.write_mcap(&sc, &a.out)?;
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

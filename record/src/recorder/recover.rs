//! `swarm recover RUN`: the run folder of a run whose launcher (and so its recorder) was killed
//! made whole again. The recorder hands its files to the file system once every
//! [`CHECKPOINT_S`](super::CHECKPOINT_S) of sim time, so at most that much is lost:
//! - the journal's payloads are folded again, through the recorder's own code, into the CSVs,
//!   `summary.json` (end reason `cut_short`), `world.json`, `connectivity.csv` and the figures;
//! - `run.mcap` is rewritten from its whole chunks with a summary section, so every MCAP reader
//!   (Foxglove, the Python `mcap` package, `swarm replay`) opens it;
//! - the journal is removed last, so a recovery that fails part way can be run again.

use super::journal::{salvage, JOURNAL_FILE};
use crate::summary::Summary;
use anyhow::{bail, Context, Result};
use clap::Args;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use swarm_config::Scenario;

/// `swarm recover`.
#[derive(Args, Debug, Clone)]
pub struct RecoverArgs {
    /// The run folder of a run that was cut short (it still holds `journal.mcap`).
    pub run: PathBuf,
}

/// Whether `dir` holds a run that was cut short and not yet recovered.
pub fn cut_short(dir: &Path) -> bool {
    dir.join(JOURNAL_FILE).is_file()
}

/// Runs `swarm recover`.
pub fn recover(a: RecoverArgs) -> Result<ExitCode> {
    let dir = &a.run;
    let mcap_path = dir.join("run.mcap");
    if !cut_short(dir) {
        if dir.join("summary.json").is_file() {
            println!("nothing to recover: {} ended with its summary written", dir.display());
            return Ok(ExitCode::SUCCESS);
        }
        if mcap_path.is_file() {
            // Flown with --no-journal: only the recording can be made whole.
            let m = salvage::rewrite(&mcap_path)?;
            println!("no journal (--no-journal): no summary rebuilt; run.mcap rewritten with {} messages and a summary section{}", m.messages, stopped(&m));
            return Ok(ExitCode::SUCCESS);
        }
        bail!(
            "{} has no {JOURNAL_FILE}, run.mcap or summary.json: not the folder of a `swarm run` (or `swarm record`)",
            dir.display()
        );
    }
    let (summary, journal, mcap) = recover_dir(dir)?;
    println!("{}", summary.human());
    println!(
        "recovered {}: {} ticks to t = {:.1} s from {} journaled messages{}",
        dir.display(),
        summary.ticks,
        summary.sim_time_s,
        journal.messages,
        stopped(&journal)
    );
    match mcap {
        Some(m) => println!("run.mcap rewritten with {} messages and a summary section{}", m.messages, stopped(&m)),
        None => println!("no run.mcap (the run was flown with --no-mcap)"),
    }
    Ok(ExitCode::SUCCESS)
}

/// Recovers the run folder `dir`: the summary, what the journal held, and what `run.mcap` held
/// (if the run wrote one).
fn recover_dir(dir: &Path) -> Result<(Summary, salvage::Cut, Option<salvage::Cut>)> {
    let sc = Scenario::from_file(&dir.join("scenario.toml"))?;
    let (summary, journal) = super::replay(dir, &sc)?;
    let mcap_path = dir.join("run.mcap");
    let mcap = if mcap_path.is_file() { Some(salvage::rewrite(&mcap_path)?) } else { None };
    let journal_path = dir.join(JOURNAL_FILE);
    std::fs::remove_file(&journal_path).with_context(|| format!("cannot remove {}", journal_path.display()))?;
    Ok((summary, journal, mcap))
}

/// ", the rest dropped: why" when reading stopped before the end of a file.
fn stopped(c: &salvage::Cut) -> String {
    c.stopped.as_ref().map(|why| format!(" (the open chunk after them dropped: {why})")).unwrap_or_default()
}

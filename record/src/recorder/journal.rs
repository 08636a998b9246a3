//! The recorder's journal: every truth and state payload it folds, byte for byte and in the order
//! it folded them, so a run whose recorder was killed can be folded again afterwards
//! (`swarm recover`) into the summary, CSVs and figures the run would have written up to then.
//!
//! Why a journal and not the CSVs: the summary is folded from whole messages (neighbour
//! estimates, link classes, traffic, the hub's timing), most of which no CSV holds; replaying the
//! very payloads through the very same [`Sink`](super::recording) makes the recovered summary
//! the one a clean end at that tick would have written.
//!
//! The journal is itself an MCAP file (`journal.mcap`, zstd chunks, topics `/swarm/truth` and
//! `/swarm/state`, postcard payloads of [`swarm_wire::Msg`]), so the one whole-chunk salvage of
//! [`salvage`] serves both it and `run.mcap`, and anyone can read it with an MCAP reader. It is
//! cut into a chunk at every [`Journal::flush`] (the recorder flushes once a sim second), and
//! removed when the run ends cleanly: a folder that still has one was cut short.

use anyhow::{Context, Result};
use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufReader, BufWriter, Write};
use std::path::Path;

/// The journal's file name in a run folder.
pub const JOURNAL_FILE: &str = "journal.mcap";

const TRUTH_TOPIC: &str = "/swarm/truth";
const STATE_TOPIC: &str = "/swarm/state";
/// The channel metadata key of the run id.
const RUN_ID: &str = "run_id";

/// Which of the recorder's two subscriptions a payload came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// `truth/**`: the world and the truth steps.
    Truth,
    /// `uav/*/state` and `host/*/state`.
    State,
}

/// The journal being written.
pub struct Journal {
    w: mcap::Writer<BufWriter<File>>,
    truth: u16,
    state: u16,
    sequence: u32,
}

impl Journal {
    /// Starts `dir/journal.mcap` for run `run_id` (kept in its channels' metadata).
    pub fn create(dir: &Path, run_id: &str) -> Result<Journal> {
        let path = dir.join(JOURNAL_FILE);
        let file = File::create(&path).with_context(|| format!("cannot create {}", path.display()))?;
        let mut w = mcap::WriteOptions::new()
            .compression(Some(mcap::Compression::Zstd))
            .profile("swarm-journal")
            .create(BufWriter::new(file))
            .context("cannot start the journal")?;
        let meta = BTreeMap::from([(RUN_ID.to_string(), run_id.to_string())]);
        let truth = w.add_channel(0, TRUTH_TOPIC, "postcard", &meta)?;
        let state = w.add_channel(0, STATE_TOPIC, "postcard", &meta)?;
        Ok(Journal { w, truth, state, sequence: 0 })
    }

    /// Appends one payload, stamped with the sim time the recorder was at [s].
    pub fn append(&mut self, kind: Kind, payload: &[u8], t_s: f64) -> Result<()> {
        let channel_id = match kind {
            Kind::Truth => self.truth,
            Kind::State => self.state,
        };
        let ns = crate::scene::log_time_ns(t_s);
        let header =
            mcap::records::MessageHeader { channel_id, sequence: self.sequence, log_time: ns, publish_time: ns };
        self.sequence = self.sequence.wrapping_add(1);
        self.w.write_to_known_channel(&header, payload).context("cannot write the journal")
    }

    /// Ends the open chunk and hands it to the file: a kill after this loses nothing before it.
    pub fn flush(&mut self) -> Result<()> {
        self.w.flush().context("cannot flush the journal")
    }

    /// Closes the journal and removes it (the run ended cleanly; its summary is written).
    pub fn discard(mut self, dir: &Path) -> Result<()> {
        self.w.finish().context("cannot close the journal")?;
        drop(self.w);
        let path = dir.join(JOURNAL_FILE);
        let bytes = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
        tracing::info!(bytes, "the run ended cleanly: journal removed");
        std::fs::remove_file(&path).with_context(|| format!("cannot remove {}", path.display()))
    }
}

/// Calls `f` with every payload of the journal in `dir` that a whole chunk holds, in order,
/// streaming (a long run's journal need not fit in memory); returns the run id (empty if not
/// one message was kept) and where reading stopped.
pub fn each(dir: &Path, mut f: impl FnMut(Kind, &[u8])) -> Result<(String, salvage::Cut)> {
    let path = dir.join(JOURNAL_FILE);
    let file = File::open(&path).with_context(|| format!("cannot open {}", path.display()))?;
    let mut run_id = String::new();
    let cut = salvage::each_message(BufReader::new(file), |m| {
        let kind = match m.channel.topic.as_str() {
            TRUTH_TOPIC => Kind::Truth,
            STATE_TOPIC => Kind::State,
            _ => return,
        };
        if run_id.is_empty() {
            run_id = m.channel.metadata.get(RUN_ID).cloned().unwrap_or_default();
        }
        f(kind, &m.data);
    });
    Ok((run_id, cut))
}

pub mod salvage {
    //! Whole-chunk salvage of an MCAP file whose writer was killed: its last chunk is open (its
    //! length is still the placeholder `u64::MAX`, so readers refuse the file), and it has no
    //! summary section. Every message before the point where reading fails is kept.

    use super::*;
    use std::io::Read;

    /// What reading a file to its end (or its first unreadable record) found.
    #[derive(Debug, Clone, Default, PartialEq)]
    pub struct Cut {
        /// Messages read.
        pub messages: u64,
        /// Whether the file ended cleanly (`None`) or why reading stopped.
        pub stopped: Option<String>,
    }

    /// Calls `f` with every message of `source` in file order until the end or the first record
    /// that cannot be read.
    pub fn each_message(source: impl Read, mut f: impl FnMut(mcap::Message<'static>)) -> Cut {
        let mut cut = Cut::default();
        for m in mcap::io::MessageReader::new(source) {
            match m {
                Ok(m) => {
                    cut.messages += 1;
                    f(m);
                }
                Err(e) => {
                    cut.stopped = Some(e.to_string());
                    break;
                }
            }
        }
        cut
    }

    /// Rewrites the MCAP file `path` with every message it still holds, as a whole file with a
    /// summary section (so any reader opens it): written beside it, then renamed over it.
    pub fn rewrite(path: &Path) -> Result<Cut> {
        let file = File::open(path).with_context(|| format!("cannot open {}", path.display()))?;
        let tmp = path.with_extension("mcap.recovering");
        let out = File::create(&tmp).with_context(|| format!("cannot create {}", tmp.display()))?;
        let mut w = mcap::WriteOptions::new().compression(Some(mcap::Compression::Zstd)).create(BufWriter::new(out))?;
        let mut failed = None;
        let cut = each_message(BufReader::new(file), |m| {
            if failed.is_none() {
                failed = w.write(&m).err();
            }
        });
        if let Some(e) = failed {
            return Err(e).with_context(|| format!("cannot write {}", tmp.display()));
        }
        w.finish().with_context(|| format!("cannot finish {}", tmp.display()))?;
        let mut inner = w.into_inner();
        inner.flush()?;
        inner.get_mut().sync_all()?;
        std::fs::rename(&tmp, path).with_context(|| format!("cannot replace {}", path.display()))?;
        Ok(cut)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh folder for test `tag` (removed first, if a killed test left one).
    fn folder(tag: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("swarm-journal-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("folder");
        dir
    }

    /// A journal "killed" (dropped without its destructor) after three flushes and with five
    /// payloads in its open chunk.
    fn killed_journal(dir: &Path) -> Vec<Vec<u8>> {
        let mut j = Journal::create(dir, "run-x").expect("journal");
        let mut flushed = Vec::new();
        for i in 0..30u32 {
            let payload = i.to_le_bytes().repeat(50);
            let kind = if i % 2 == 0 { Kind::Truth } else { Kind::State };
            j.append(kind, &payload, f64::from(i) * 0.1).expect("append");
            flushed.push(payload);
            if i % 10 == 9 {
                j.flush().expect("flush");
            }
        }
        for i in 30..35u32 {
            j.append(Kind::State, &i.to_le_bytes().repeat(50), 3.0).expect("append");
        }
        std::mem::forget(j);
        flushed
    }

    /// Every payload `each` gives back, with its kind, and the run id.
    fn read(dir: &Path) -> (String, Vec<(Kind, Vec<u8>)>) {
        let mut payloads = Vec::new();
        let (run_id, _) = each(dir, |k, b| payloads.push((k, b.to_vec()))).expect("read");
        (run_id, payloads)
    }

    #[test]
    fn a_killed_journal_gives_back_every_flushed_payload_in_order() {
        let dir = folder("read");
        let flushed = killed_journal(&dir);
        let (run_id, payloads) = read(&dir);
        assert_eq!(run_id, "run-x");
        assert!(payloads.len() >= flushed.len(), "{} payloads", payloads.len());
        let got: Vec<&Vec<u8>> = payloads.iter().map(|(_, b)| b).take(flushed.len()).collect();
        assert_eq!(got, flushed.iter().collect::<Vec<_>>());
        assert_eq!(payloads[1].0, Kind::State);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_rewritten_file_has_a_summary_and_every_message_read_before() {
        let dir = folder("rewrite");
        killed_journal(&dir);
        let path = dir.join(JOURNAL_FILE);
        let before = read(&dir).1.len() as u64;
        assert!(
            !matches!(mcap::Summary::read(&std::fs::read(&path).expect("bytes")), Ok(Some(_))),
            "a cut file has no summary"
        );
        let cut = salvage::rewrite(&path).expect("rewrite");
        assert_eq!(cut.messages, before);
        let bytes = std::fs::read(&path).expect("bytes");
        let summary = mcap::Summary::read(&bytes).expect("readable").expect("a summary section");
        assert_eq!(summary.stats.expect("statistics").message_count, before);
        assert_eq!(salvage::each_message(&bytes[..], |_| ()).stopped, None, "read to its end");
        let _ = std::fs::remove_dir_all(&dir);
    }
}

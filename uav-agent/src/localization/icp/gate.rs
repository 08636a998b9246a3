//! The spatial gate of the neighbour database: which entries a received obstacle set is matched
//! against first (see [`Gate`]).
//!
//! Why a module of its own: it is the one place that makes identification (seed 000's
//! findBestMatch) cost about one short ICP per nearby neighbour instead of one per entry, a
//! geometric argument (a rigid alignment preserves distance) with its own slack, apart from the
//! database's bookkeeping. It sees an entry only as the sender of its last set and where it is
//! placed, so it knows nothing of the database's entries or of the ICP.

use nalgebra::Vector2;
use swarm_types::UavId;

/// Slack of the [`Gate`] beyond `match_shift_m` [m]: what the two neighbours and this agent may
/// have moved, and the placements may be off, between the estimates the gate compares (entries in
/// use were placed at most `stale_after_s` = 0.5 s apart, at walking-pace speeds of about 1 m/s).
const GATE_MARGIN_M: f64 = 2.0;

/// Which entries a received set is matched against: the ones placed near where its sender should
/// be, instead of every entry (which made identification quadratic in the neighbours).
///
/// Matching a set to an entry's ID set succeeds only by a plausible motion, a shift of at most
/// `match_shift_m` (seed 000 5.2 as refined here). The shift that aligns neighbour a's new set
/// with neighbour b's last one is |p_a − p_b|, their separation (a rigid alignment preserves
/// distance), so an entry whose neighbour was placed farther than `match_shift_m` (plus the
/// [`GATE_MARGIN_M`] slack) from where the set's sender is expected cannot be the match. Where the
/// sender is expected: where the entry that took the last set on the same link was placed. The
/// link only says where to look; the entry is still chosen by matching, so anonymity is kept. A
/// set with no such located entry (a new link, or its entry is unplaced or suspended) is matched
/// against every entry, and entries with no position (unplaced or suspended) are always tried.
#[derive(Debug)]
pub(super) struct Gate {
    /// Per entry, its neighbour's position in this agent's body frame [m], if placed and usable.
    located: Vec<Option<Vector2<f64>>>,
    /// Every entry's sender (of the set it took last), sorted, and beside it the entries in the
    /// same order: a sender's entries are one run, in entry order (sorted lists, not a map of
    /// lists: the gate is rebuilt every step, and a list per sender was an allocation per entry).
    senders: Vec<UavId>,
    entries: Vec<usize>,
    /// Candidates lie within this distance of an expected position [m].
    radius_m: f64,
}

impl Gate {
    /// The gate over the database's entries, in entry order, each given as the sender of the set
    /// it took last and its neighbour's position if placed and usable; `match_shift_m` is the
    /// database's plausible-motion bound, widened here by [`GATE_MARGIN_M`].
    pub(super) fn new(entries: impl Iterator<Item = (UavId, Option<Vector2<f64>>)>, match_shift_m: f64) -> Gate {
        let mut located = Vec::new();
        let mut by_sender = Vec::new();
        for (idx, (sender, at)) in entries.enumerate() {
            located.push(at);
            by_sender.push((sender, idx));
        }
        by_sender.sort_unstable();
        let (senders, entries) = by_sender.into_iter().unzip();
        Gate { located, senders, entries, radius_m: match_shift_m + GATE_MARGIN_M }
    }

    /// The entries that took the last set of `sender`'s link, in entry order.
    pub(super) fn on_link(&self, sender: UavId) -> &[usize] {
        let from = self.senders.partition_point(|&s| s < sender);
        let to = self.senders.partition_point(|&s| s <= sender);
        &self.entries[from..to]
    }

    /// The entries a set from `sender` is matched against first, in entry order: the entries that
    /// took the link's last set, and the located entries near where they placed it.
    pub(super) fn candidates(&self, sender: UavId) -> Vec<usize> {
        let on_link = self.on_link(sender);
        let all = 0..self.located.len();
        if on_link.is_empty() {
            return all.collect();
        }
        let expected: Vec<Vector2<f64>> = on_link.iter().filter_map(|&idx| self.located[idx]).collect();
        all.filter(|idx| {
            on_link.contains(idx)
                || self.located[*idx].is_some_and(|p| expected.iter().any(|q| (p - q).norm() <= self.radius_m))
        })
        .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `match_shift_m` 1 m: candidates lie within 1 + 2 = 3 m of where the link's entry is placed.
    #[test]
    fn candidates_are_the_links_entries_and_the_located_entries_near_them() {
        let at = |x: f64| Some(Vector2::new(x, 0.0));
        // Entries 0..4: sender 1 at 0 m, sender 2 at 2.5 m, sender 3 at 10 m, sender 4 unplaced.
        let gate = Gate::new(
            [(UavId::new(1), at(0.0)), (UavId::new(2), at(2.5)), (UavId::new(3), at(10.0)), (UavId::new(4), None)]
                .into_iter(),
            1.0,
        );
        assert_eq!(gate.candidates(UavId::new(1)), vec![0, 1], "entry 1 is 2.5 m away, entry 2 10 m");
        assert_eq!(gate.candidates(UavId::new(3)), vec![2]);
        assert_eq!(gate.candidates(UavId::new(4)), vec![3], "an unplaced entry's link: that entry first");
        assert_eq!(gate.candidates(UavId::new(9)), vec![0, 1, 2, 3], "a new link: every entry");
    }
}

//! A UAV's id. Scenarios, keys (`uav/{id}/…`), messages and files number UAVs from 1; arrays of
//! per-UAV state are indexed from 0 in id order. The one place the two meet is here.

use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// A UAV's id, 1-based, as scenarios, keys and messages carry it.
/// `Default` is id 0, which is no UAV: a placeholder for tests and benches to fill in. `Debug`
/// prints the number alone, as `Display` does, so a list of ids reads `[3, 7]` in a message.
#[derive(Clone, Copy, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(transparent)]
pub struct UavId(u32);

impl UavId {
    /// The UAV with this id (as the scenario numbers it). Id 0 is not a UAV, but a number read
    /// off the wire may be anything: checks against the swarm happen where the swarm is known.
    pub const fn new(id: u32) -> UavId {
        UavId(id)
    }

    /// The UAV at index `i` of an array in id order (index 0 is id 1).
    pub fn from_index(i: usize) -> UavId {
        UavId(u32::try_from(i + 1).expect("a UAV index fits u32"))
    }

    /// The id as a number.
    pub const fn get(self) -> u32 {
        self.0
    }

    /// This UAV's index in an array in id order, `None` for id 0.
    pub fn try_index(self) -> Option<usize> {
        (self.0 as usize).checked_sub(1)
    }

    /// This UAV's index in an array in id order. Panics on id 0, which no scenario has: use
    /// [`UavId::try_index`] for an id read off the wire.
    pub fn index(self) -> usize {
        self.try_index().expect("UAV ids start at 1")
    }

    /// Whether this is a UAV of a swarm of `count`: 1..=count.
    pub fn within(self, count: usize) -> bool {
        self.0 >= 1 && self.0 as usize <= count
    }

    /// Ids 1..=n: a swarm of `n` UAVs.
    pub fn all(n: usize) -> impl DoubleEndedIterator<Item = UavId> + ExactSizeIterator {
        (0..n).map(UavId::from_index)
    }
}

impl fmt::Debug for UavId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.0.fmt(f)
    }
}

impl fmt::Display for UavId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.0.fmt(f)
    }
}

impl From<u32> for UavId {
    fn from(id: u32) -> UavId {
        UavId(id)
    }
}

impl From<UavId> for u32 {
    fn from(id: UavId) -> u32 {
        id.0
    }
}

/// A UAV id that is not a positive whole number.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ParseUavIdError(String);

impl fmt::Display for ParseUavIdError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:?} is not a UAV id (a whole number from 1)", self.0)
    }
}

impl std::error::Error for ParseUavIdError {}

impl FromStr for UavId {
    type Err = ParseUavIdError;

    fn from_str(s: &str) -> Result<UavId, ParseUavIdError> {
        match s.parse::<u32>() {
            Ok(id) if id >= 1 => Ok(UavId(id)),
            _ => Err(ParseUavIdError(s.to_string())),
        }
    }
}

/// `ids` (ascending) as runs of ranges, the `--ids` syntax: `[1, 2, 3, 4, 7]` is `1-4,7`. The
/// agent-host user names (`uavs1-4,7`) and the host keys (`host/1-4,7/sense`) spell their UAVs
/// so; [`parse_ids`] reads it back.
pub fn ids_text(ids: &[UavId]) -> String {
    let mut parts: Vec<String> = Vec::new();
    let mut i = 0;
    while i < ids.len() {
        let mut j = i;
        while j + 1 < ids.len() && ids[j + 1].get() == ids[j].get() + 1 {
            j += 1;
        }
        parts.push(if i == j { ids[i].to_string() } else { format!("{}-{}", ids[i], ids[j]) });
        i = j + 1;
    }
    parts.join(",")
}

/// Parses `1-4,7` into `[1, 2, 3, 4, 7]` (in the order written): ranges that go up, no
/// repeats, ids from 1. The error says which part is wrong.
pub fn parse_ids(text: &str) -> Result<Vec<UavId>, String> {
    let mut ids: Vec<UavId> = Vec::new();
    for part in text.split(',').map(str::trim) {
        let num = |s: &str| s.trim().parse::<u32>().map_err(|_| format!("`{s}` in `{text}` is not a UAV id"));
        let (lo, hi) = match part.split_once('-') {
            Some((a, b)) => (num(a)?, num(b)?),
            None => (num(part)?, num(part)?),
        };
        if lo == 0 || hi < lo {
            return Err(format!("`{part}` in `{text}`: ids start at 1 and ranges go up"));
        }
        ids.extend((lo..=hi).map(UavId::new));
    }
    let mut sorted = ids.clone();
    sorted.sort_unstable();
    sorted.dedup();
    if sorted.len() != ids.len() {
        return Err(format!("`{text}` names a UAV twice"));
    }
    Ok(ids)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_and_id_meet_here_only() {
        assert_eq!(UavId::from_index(0), UavId::new(1));
        assert_eq!(UavId::new(7).index(), 6);
        assert_eq!(UavId::new(0).try_index(), None);
        assert_eq!(UavId::all(3).map(UavId::get).collect::<Vec<_>>(), vec![1, 2, 3]);
        assert_eq!("12".parse::<UavId>(), Ok(UavId::new(12)));
        assert!("0".parse::<UavId>().is_err());
        assert!("x".parse::<UavId>().expect_err("an error").to_string().contains("\"x\" is not a UAV id"));
    }

    #[test]
    fn id_lists_read_back_as_written() {
        let ids: Vec<UavId> = [1, 2, 3, 4, 7, 9, 10].map(UavId::new).to_vec();
        assert_eq!(ids_text(&ids), "1-4,7,9-10");
        assert_eq!(parse_ids("1-4,7,9-10"), Ok(ids));
        assert_eq!(ids_text(&[]), "");
        assert!(parse_ids("3-1").expect_err("down").contains("ranges go up"));
        assert!(parse_ids("1-3,2").expect_err("twice").contains("twice"));
        assert!(parse_ids("0").is_err() && parse_ids("a").is_err() && parse_ids("").is_err());
    }

    #[test]
    fn an_id_is_its_number_on_the_wire_and_in_text() {
        assert_eq!(
            postcard::to_stdvec(&UavId::new(300)).expect("encodes"),
            postcard::to_stdvec(&300u32).expect("encodes")
        );
        assert_eq!(serde_json::to_string(&UavId::new(3)).expect("encodes"), "3");
        assert_eq!(UavId::new(3).to_string(), "3");
        assert_eq!(format!("{:?}", [UavId::new(3), UavId::new(7)]), "[3, 7]", "a list reads as numbers");
    }
}

//! Which of a tick's sensor frames go to an agent host in one message, and when that message is
//! complete: pure, so the hub's node only puts what this hands back.
//!
//! Why: a frame a UAV costs a put and a route each, the hub's largest share of a tick at 1000
//! UAVs (docs/performance.md, "The hub's tick"). An agent host that holds the token
//! `alive/host/{ids}` takes its UAVs' frames in one `Msg::Senses` on `host/{ids}/sense`
//! instead; every other UAV's frame still goes alone on `uav/{id}/sense`. The frames come from
//! the sensor workers in the order [`Batches::order`] picks (the hosts' UAVs in turn), and a
//! host's message goes out as soon as its last frame is encoded.

use std::collections::HashMap;
use swarm_types::UavId;

/// What to do with one encoded frame.
#[derive(Debug, PartialEq)]
pub enum Route {
    /// Put it alone on the UAV's key.
    Alone(Vec<u8>),
    /// Kept for its host's message, which is not complete yet.
    Held,
    /// The host's message is complete: host `.0` (an index into the hosts given to
    /// [`Batches::new`]) and its frames in the order taken.
    Complete(usize, Vec<(UavId, Vec<u8>)>),
}

/// A host's frames of the tick so far.
#[derive(Debug)]
struct Pending {
    expected: usize,
    frames: Vec<(UavId, Vec<u8>)>,
}

/// The grouping of one tick's frames.
#[derive(Debug)]
pub struct Batches {
    host_of: HashMap<UavId, usize>,
    pending: Vec<Pending>,
}

impl Batches {
    /// The tick's frames for `sent` (the UAVs sensed this tick), grouped by the `hosts` alive
    /// (each its UAVs). A UAV that two hosts claim goes to the first; a host with no UAV sent
    /// gets no message.
    pub fn new(hosts: &[Vec<UavId>], sent: &[UavId]) -> Batches {
        let mut claimed: HashMap<UavId, usize> = HashMap::new();
        for (h, ids) in hosts.iter().enumerate() {
            for &id in ids {
                claimed.entry(id).or_insert(h);
            }
        }
        let mut pending: Vec<Pending> = hosts.iter().map(|_| Pending { expected: 0, frames: Vec::new() }).collect();
        let mut host_of = HashMap::new();
        for &id in sent {
            if let Some(&h) = claimed.get(&id) {
                host_of.insert(id, h);
                pending[h].expected += 1;
            }
        }
        Batches { host_of, pending }
    }

    /// The order to compute the sensors of `sent` (the UAVs given to [`Batches::new`]) in: the
    /// frames that go alone first, in the order given, then the hosts' UAVs in turn, each host's
    /// first, then each host's second, and so on, so that every host's message is complete at
    /// about the same moment, near the end of the tick's sensors.
    ///
    /// Why: in id order, the first host's message went out halfway through the sensors. With one
    /// runtime worker per host (one host per core), that host then finished its agents' steps
    /// first and left its core idle while the last host, started later, finished its own; with
    /// the messages complete together, the sensor threads have both cores until then and the
    /// hosts end their steps together. Each UAV draws from its own streams, so the order changes
    /// no frame.
    pub fn order(&self, sent: &[UavId]) -> Vec<UavId> {
        let mut out = Vec::with_capacity(sent.len());
        let mut per_host: Vec<Vec<UavId>> = self.pending.iter().map(|p| Vec::with_capacity(p.expected)).collect();
        for &id in sent {
            match self.host_of.get(&id) {
                Some(&h) => per_host[h].push(id),
                None => out.push(id),
            }
        }
        let longest = per_host.iter().map(Vec::len).max().unwrap_or(0);
        for k in 0..longest {
            out.extend(per_host.iter().filter_map(|ids| ids.get(k)));
        }
        out
    }

    /// Takes UAV `id`'s encoded frame.
    pub fn take(&mut self, id: UavId, frame: Vec<u8>) -> Route {
        let Some(&h) = self.host_of.get(&id) else { return Route::Alone(frame) };
        let p = &mut self.pending[h];
        p.frames.push((id, frame));
        if p.frames.len() == p.expected {
            Route::Complete(h, std::mem::take(&mut p.frames))
        } else {
            Route::Held
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ids(v: &[u32]) -> Vec<UavId> {
        v.iter().copied().map(UavId::new).collect()
    }

    #[test]
    fn a_hosts_frames_go_together_once_the_last_is_in_and_the_rest_alone() {
        let hosts = vec![ids(&[1, 2, 3]), ids(&[5, 6])];
        // UAV 3 is not sensed this tick (its agent is gone): host 0's message holds 1 and 2.
        let mut b = Batches::new(&hosts, &ids(&[1, 2, 4, 5, 6]));
        assert_eq!(b.take(UavId::new(1), vec![1]), Route::Held);
        assert_eq!(
            b.take(UavId::new(2), vec![2]),
            Route::Complete(0, vec![(UavId::new(1), vec![1]), (UavId::new(2), vec![2])])
        );
        assert_eq!(b.take(UavId::new(4), vec![4]), Route::Alone(vec![4]), "no host holds 4");
        assert_eq!(b.take(UavId::new(5), vec![5]), Route::Held);
        assert_eq!(
            b.take(UavId::new(6), vec![6]),
            Route::Complete(1, vec![(UavId::new(5), vec![5]), (UavId::new(6), vec![6])])
        );
    }

    #[test]
    fn the_alone_go_first_then_the_hosts_in_turn_so_their_messages_end_together() {
        let hosts = vec![ids(&[1, 2, 3]), ids(&[5, 6])];
        let sent = ids(&[1, 2, 3, 4, 5, 6, 7]);
        let mut b = Batches::new(&hosts, &sent);
        let order = b.order(&sent);
        assert_eq!(order, ids(&[4, 7, 1, 5, 2, 6, 3]));
        // Taken in that order, both hosts' messages complete in the last three frames.
        let routes: Vec<Route> = order.iter().map(|&id| b.take(id, vec![id.get() as u8])).collect();
        let complete: Vec<usize> =
            routes.iter().enumerate().filter(|(_, r)| matches!(r, Route::Complete(..))).map(|(i, _)| i).collect();
        assert_eq!(complete, vec![5, 6]);
        assert!(matches!(&routes[6], Route::Complete(0, f) if f.iter().map(|(id, _)| id.get()).eq([1, 2, 3])));
    }

    #[test]
    fn a_uav_two_hosts_claim_goes_to_the_first_and_no_host_means_all_alone() {
        let mut b = Batches::new(&[ids(&[1, 2]), ids(&[2])], &ids(&[1, 2]));
        assert_eq!(b.take(UavId::new(1), vec![1]), Route::Held);
        assert!(matches!(b.take(UavId::new(2), vec![2]), Route::Complete(0, f) if f.len() == 2));
        let mut none = Batches::new(&[], &ids(&[1]));
        assert_eq!(none.take(UavId::new(1), vec![1]), Route::Alone(vec![1]));
    }
}

//! A nemesis vocabulary after Jepsen's (`jepsen.nemesis`, `jepsen.nemesis.combined`): faults that
//! can be generated at random, each a start and a stop in sim time, and rendered into the
//! scenario's own `[[netem]]` and `[[failures]]` tables, so that a generated schedule is an
//! ordinary scenario anyone can `swarm run`.
//!
//! - partitions by each of Jepsen's schemes ([`Partition`]: halves, bridge, majorities-ring,
//!   isolate a node, random two groups), stopped by a heal;
//! - loss, i.i.d. or in bursts (Gilbert–Elliott), delay with jitter, duplication: per-link rules
//!   on all links or from a few UAVs, stopped by an identity rule;
//! - a freeze (the UAV hovers, mute, for the rest of the run: the timeline has no thaw);
//! - a kill and a restart of one agent, and a link stall and restore (Zenoh link to the hub) —
//!   carried out by `swarm run` on the wall clock, so they are in the vocabulary but not in
//!   [`NemesisKind::DETERMINISTIC`]: a lockstep fuzz that must repeat leaves them out.
//!
//! [`schedule`] draws faults one after another (a fault stops before the next starts, so a
//! heal never cancels another fault's rule) from one seeded ChaCha stream: same seed, same
//! schedule. Pure data in, data out; the shrinker in `swarm fuzz` removes and shortens
//! [`Fault`]s and renders again.

use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use swarm_config::{Failure, FailureKind, Impairment, LossModel, NetemRule, Partition, UavSet};
use swarm_types::UavId;

/// What a fault does.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Nemesis {
    /// A partition by one of Jepsen's schemes, healed at the stop.
    Partition {
        /// The scheme and its nodes.
        partition: Partition,
    },
    /// A per-link rule from `from` (all UAVs when empty) to every UAV, identity again at the stop.
    Link {
        /// Senders (empty: all).
        from: Vec<UavId>,
        /// The rule (loss, bursts, delay and jitter, duplication).
        rule: Impairment,
    },
    /// The UAV hovers, mute, from the start on (no thaw: the stop is ignored).
    Freeze {
        /// Which UAV.
        uav: UavId,
    },
    /// The agent is killed at the start and restarted at the stop (wall clock: not repeatable).
    KillRestart {
        /// Which UAV.
        uav: UavId,
    },
    /// The agent's Zenoh link to the hub stalls at the start and is restored at the stop
    /// (realtime mode only).
    LinkStall {
        /// Which UAV.
        uav: UavId,
    },
}

/// The families of [`Nemesis`] a schedule may draw from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NemesisKind {
    /// Partitions, each scheme equally likely.
    Partition,
    /// i.i.d. loss.
    Loss,
    /// Burst loss (Gilbert–Elliott).
    Burst,
    /// Delay and jitter.
    Delay,
    /// Duplication.
    Duplicate,
    /// Freezes.
    Freeze,
    /// Kills and restarts.
    KillRestart,
    /// Link stalls.
    LinkStall,
}

impl NemesisKind {
    /// The kinds whose effect is decided in sim time alone, so a lockstep run repeats.
    pub const DETERMINISTIC: [NemesisKind; 6] = [
        NemesisKind::Partition,
        NemesisKind::Loss,
        NemesisKind::Burst,
        NemesisKind::Delay,
        NemesisKind::Duplicate,
        NemesisKind::Freeze,
    ];
}

/// One fault: what, from when, for how long.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Fault {
    /// Sim time it starts [s].
    pub start_s: f64,
    /// How long it lasts [s].
    pub duration_s: f64,
    /// What it does.
    pub nemesis: Nemesis,
}

/// How a schedule is drawn.
#[derive(Debug, Clone, PartialEq)]
pub struct ScheduleSpec {
    /// UAV ids are `1..=uavs`.
    pub uavs: u32,
    /// No fault starts after this [s].
    pub horizon_s: f64,
    /// At most this many faults.
    pub max_faults: usize,
    /// Each lasts between these [s].
    pub duration_s: (f64, f64),
    /// The kinds to draw from (empty: no fault).
    pub kinds: Vec<NemesisKind>,
}

/// A random schedule of faults, one after another with random gaps, all from `seed`.
pub fn schedule(seed: u64, spec: &ScheduleSpec) -> Vec<Fault> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut faults = Vec::new();
    if spec.kinds.is_empty() || spec.uavs == 0 {
        return faults;
    }
    let n = rng.gen_range(0..=spec.max_faults);
    let mut t = rng.gen_range(0.0..(spec.horizon_s / 4.0).max(1.0));
    for _ in 0..n {
        if t > spec.horizon_s {
            break;
        }
        let duration_s = rng.gen_range(spec.duration_s.0..=spec.duration_s.1);
        let kind = spec.kinds[rng.gen_range(0..spec.kinds.len())];
        faults.push(Fault {
            start_s: round(t),
            duration_s: round(duration_s),
            nemesis: draw(&mut rng, kind, spec.uavs),
        });
        t += duration_s + rng.gen_range(1.0..10.0);
    }
    faults
}

/// Tenths of a second: schedules read well in TOML and land on control ticks.
fn round(v: f64) -> f64 {
    (v * 10.0).round() / 10.0
}

/// Two decimals for probabilities and delays.
fn round2(v: f64) -> f64 {
    (v * 100.0).round() / 100.0
}

/// A few senders (empty: all of them).
fn senders(rng: &mut ChaCha8Rng, uavs: u32) -> Vec<UavId> {
    if rng.gen_bool(0.5) {
        return Vec::new();
    }
    let mut ids: Vec<UavId> = (1..=uavs).map(UavId::new).collect();
    ids.shuffle(rng);
    ids.truncate(rng.gen_range(1..=uavs as usize));
    ids.sort_unstable();
    ids
}

fn draw(rng: &mut ChaCha8Rng, kind: NemesisKind, uavs: u32) -> Nemesis {
    let one = |rng: &mut ChaCha8Rng| rng.gen_range(1..=uavs);
    let link = |rng: &mut ChaCha8Rng, rule: Impairment| Nemesis::Link { from: senders(rng, uavs), rule };
    match kind {
        NemesisKind::Partition => Nemesis::Partition { partition: partition(rng, uavs) },
        NemesisKind::Loss => {
            let p = round2(rng.gen_range(0.1..0.7));
            link(rng, Impairment { loss: LossModel::Random { p }, ..Impairment::IDENTITY })
        }
        NemesisKind::Burst => {
            let (p, r) = (round2(rng.gen_range(0.02..0.2)), round2(rng.gen_range(0.1..0.5)));
            link(
                rng,
                Impairment {
                    loss: LossModel::GilbertElliott { p, r, one_minus_h: 1.0, one_minus_k: 0.0 },
                    ..Impairment::IDENTITY
                },
            )
        }
        NemesisKind::Delay => {
            let delay_s = round2(rng.gen_range(0.05..0.8));
            let jitter_s = round2(rng.gen_range(0.0..delay_s / 2.0));
            link(rng, Impairment { delay_s, jitter_s, ..Impairment::IDENTITY })
        }
        NemesisKind::Duplicate => {
            let duplicate = round2(rng.gen_range(0.1..0.6));
            link(rng, Impairment { duplicate, ..Impairment::IDENTITY })
        }
        NemesisKind::Freeze => Nemesis::Freeze { uav: UavId::new(one(rng)) },
        NemesisKind::KillRestart => Nemesis::KillRestart { uav: UavId::new(one(rng)) },
        NemesisKind::LinkStall => Nemesis::LinkStall { uav: UavId::new(one(rng)) },
    }
}

/// A partition by one of Jepsen's schemes over the UAVs in a shuffled order.
fn partition(rng: &mut ChaCha8Rng, uavs: u32) -> Partition {
    let mut nodes: Vec<UavId> = (1..=uavs).map(UavId::new).collect();
    nodes.shuffle(rng);
    match rng.gen_range(0..5) {
        0 => Partition::Halves { nodes },
        1 if uavs >= 3 => Partition::Bridge { nodes },
        2 if uavs >= 3 => Partition::MajoritiesRing { ring: nodes },
        3 => {
            let cut = rng.gen_range(1..uavs.max(2) as usize).min(nodes.len());
            let rest = nodes.split_off(cut);
            Partition::Groups { groups: vec![nodes, rest] }
        }
        _ => Partition::Isolate { node: nodes[0] },
    }
}

impl Nemesis {
    /// The UAVs it names (all of them for rules on every sender and partitions over the swarm).
    pub fn uavs(&self) -> Vec<UavId> {
        match self {
            Nemesis::Partition { partition } => partition.nodes(),
            Nemesis::Link { from, .. } => from.clone(),
            Nemesis::Freeze { uav } | Nemesis::KillRestart { uav } | Nemesis::LinkStall { uav } => vec![*uav],
        }
    }

    /// The same fault over the UAVs `1..=uavs` only (ids above are dropped); `None` when
    /// nothing of it is left (a freeze of a UAV that is gone, a partition with fewer than two
    /// nodes).
    pub fn restricted(&self, uavs: u32) -> Option<Nemesis> {
        let keep = |v: &Vec<UavId>| v.iter().copied().filter(|&id| id.get() <= uavs).collect::<Vec<UavId>>();
        let n = match self {
            Nemesis::Partition { partition } => {
                let p = match partition {
                    Partition::Halves { nodes } => Partition::Halves { nodes: keep(nodes) },
                    Partition::Bridge { nodes } => Partition::Bridge { nodes: keep(nodes) },
                    Partition::MajoritiesRing { ring } => Partition::MajoritiesRing { ring: keep(ring) },
                    Partition::Groups { groups } => {
                        Partition::Groups { groups: groups.iter().map(keep).filter(|g| !g.is_empty()).collect() }
                    }
                    Partition::Isolate { node } if node.get() <= uavs => Partition::Isolate { node: *node },
                    Partition::OneWay { from, to } => Partition::OneWay { from: keep(from), to: keep(to) },
                    _ => return None,
                };
                if p.nodes().len() < 2 && !matches!(p, Partition::Isolate { .. }) {
                    return None;
                }
                Nemesis::Partition { partition: p }
            }
            Nemesis::Link { from, rule } => {
                let f = keep(from);
                if !from.is_empty() && f.is_empty() {
                    return None;
                }
                Nemesis::Link { from: f, rule: rule.clone() }
            }
            Nemesis::Freeze { uav } | Nemesis::KillRestart { uav } | Nemesis::LinkStall { uav } if uav.get() > uavs => {
                return None
            }
            other => other.clone(),
        };
        Some(n)
    }
}

impl Fault {
    /// The fault as the scenario's own timeline entries: its start and its stop.
    pub fn render(&self) -> (Vec<NetemRule>, Vec<Failure>) {
        let (start, stop) = (self.start_s, round(self.start_s + self.duration_s));
        let failure = |at_s, uav, kind| Failure { at_s, uav, kind };
        match &self.nemesis {
            Nemesis::Partition { partition } => (
                vec![
                    NetemRule::partition(start, partition.clone(), false),
                    NetemRule::partition(stop, Partition::Healed {}, false),
                ],
                vec![],
            ),
            Nemesis::Link { from, rule } => {
                let from = if from.is_empty() { UavSet::default() } else { UavSet::Ids(from.clone()) };
                (
                    vec![
                        NetemRule::link(start, from.clone(), UavSet::default(), rule.clone()),
                        NetemRule::link(stop, from, UavSet::default(), Impairment::IDENTITY),
                    ],
                    vec![],
                )
            }
            Nemesis::Freeze { uav } => (vec![], vec![failure(start, *uav, FailureKind::Freeze)]),
            Nemesis::KillRestart { uav } => {
                (vec![], vec![failure(start, *uav, FailureKind::Kill), failure(stop, *uav, FailureKind::Restart)])
            }
            Nemesis::LinkStall { uav } => (
                vec![],
                vec![failure(start, *uav, FailureKind::LinkStall), failure(stop, *uav, FailureKind::LinkRestore)],
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(kinds: Vec<NemesisKind>) -> ScheduleSpec {
        ScheduleSpec { uavs: 6, horizon_s: 100.0, max_faults: 6, duration_s: (2.0, 20.0), kinds }
    }

    #[test]
    fn a_seed_gives_one_schedule_and_faults_do_not_overlap() {
        let s = spec(NemesisKind::DETERMINISTIC.to_vec());
        assert_eq!(schedule(7, &s), schedule(7, &s));
        let many: Vec<Vec<Fault>> = (0..50).map(|seed| schedule(seed, &s)).collect();
        assert!(many.iter().any(|f| f.len() >= 3), "schedules of several faults");
        assert_ne!(many[0], many[1]);
        for faults in &many {
            for w in faults.windows(2) {
                assert!(w[0].start_s + w[0].duration_s < w[1].start_s, "one after another: {w:?}");
            }
            assert!(faults.iter().all(|f| (2.0..=20.0).contains(&f.duration_s) && f.start_s <= 100.0));
        }
        assert!(schedule(1, &spec(vec![])).is_empty());
    }

    #[test]
    fn every_kind_renders_to_a_valid_timeline_with_a_stop() {
        let all = [NemesisKind::DETERMINISTIC.as_slice(), &[NemesisKind::KillRestart, NemesisKind::LinkStall]].concat();
        for kind in all {
            let mut rng = ChaCha8Rng::seed_from_u64(3);
            let f = Fault { start_s: 5.0, duration_s: 4.0, nemesis: draw(&mut rng, kind, 6) };
            let (rules, failures) = f.render();
            assert_eq!(rules.len() + failures.len(), if kind == NemesisKind::Freeze { 1 } else { 2 }, "{kind:?}");
            for r in &rules {
                assert!(r.rule.validate().is_ok(), "{r:?}");
            }
            let last = rules.iter().map(|r| r.at_s).chain(failures.iter().map(|f| f.at_s)).fold(0.0, f64::max);
            assert!(last == 9.0 || kind == NemesisKind::Freeze, "{kind:?} stops at 9 s");
        }
    }

    #[test]
    fn restricting_drops_the_ids_that_are_gone() {
        let p = Nemesis::Partition {
            partition: Partition::Halves {
                nodes: vec![UavId::new(5), UavId::new(1), UavId::new(4), UavId::new(2), UavId::new(3)],
            },
        };
        assert_eq!(
            p.restricted(3),
            Some(Nemesis::Partition {
                partition: Partition::Halves { nodes: vec![UavId::new(1), UavId::new(2), UavId::new(3)] }
            })
        );
        assert_eq!(p.restricted(1), None, "one node cannot be cut from anyone");
        assert_eq!(Nemesis::Freeze { uav: UavId::new(4) }.restricted(3), None);
        let l = Nemesis::Link { from: vec![UavId::new(4), UavId::new(5)], rule: Impairment::IDENTITY };
        assert_eq!(l.restricted(3), None);
        assert_eq!(
            Nemesis::Partition { partition: Partition::Isolate { node: UavId::new(2) } }
                .restricted(2)
                .map(|n| n.uavs()),
            Some(vec![UavId::new(2)])
        );
    }
}

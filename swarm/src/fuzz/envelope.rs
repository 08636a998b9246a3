//! Each controller's envelope: the worlds and starts its seed (and our documentation) says it
//! flies. The generator draws inside it ([`Envelope::of`]: the start spacing, the forest's
//! density, A21's safety layer); a case that is outside it all the same, because a draw (start
//! positions in a disc) or a shrink (fewer UAVs) left it there, is reported with its reason
//! ([`outside`]) and not flown, so the failure rate counts only what the controllers promise.
//! The table is in docs/faults-and-experiments.md.

use swarm_config::{ControllerKind, LocalizationMode, Scenario};
use swarm_types::UavId;

/// What a controller's cases are drawn within.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Envelope {
    /// Start positions at least this far apart, centre to centre [m].
    pub min_start_spacing_m: f64,
    /// At most this many trees per 100 m² in the forest band.
    pub max_density_per_100m2: f64,
    /// A21's safety layer on (`[controller.a21] safety`).
    pub a21_safety: bool,
}

impl Envelope {
    /// The envelope of `kind`'s cases. Every controller flies starts 1.5 m apart (forest-40's
    /// crowd is 1.6 m apart) and forests up to 8 trees per 100 m² with trunks 2.5 m apart; A21
    /// only with its safety layer on, since seed 003's law lets an informed agent push through
    /// a neighbour closer than d_c = 1.93 m (`scenarios/found/found-2026-44.toml`).
    pub fn of(kind: &ControllerKind) -> Envelope {
        let a21_safety = matches!(kind, ControllerKind::A21);
        Envelope { min_start_spacing_m: 1.5, max_density_per_100m2: 8.0, a21_safety }
    }
}

/// Why the rendered case `sc` is outside its controller's envelope, or `None` when inside:
/// - its starts must be one group: every UAV reaches the others through UAVs within the radio
///   range (`uvdar`: the sensing range) of each other, the swarm every seed starts from;
/// - an A21 informed agent must see its flock at the start within d_max (seed 003 eq. 8:
///   φ = 0 beyond, and it would wait for ever where it stands);
/// - some UAV that knows the goal must stay live: when every informed UAV is frozen (or failed
///   from the start), no UAV left flying knows where the goal is, and no controller can meet a
///   goal rule the checks judge on the live UAVs;
/// - A21 over UVDAR flies with no UAV frozen or failed: UVDAR senses bodies, not whether their
///   agents live, so a frozen UAV stays a still flockmate to the others, and seed 003's law has
///   no failed flockmate: its cohesion and φ (eq. 8) hold the flock to the body for good. Over
///   broadcast the frozen UAV falls silent and is dropped (the fuzz of seed 20261203: all six
///   A21/UVDAR cases that froze a UAV fail `goal` and pass with broadcast).
pub fn outside(sc: &Scenario) -> Option<String> {
    if let Some(why) = no_informed_left(sc).or_else(|| frozen_flockmate(sc)) {
        return Some(why);
    }
    let starts = sc.swarm.start_positions.as_deref().unwrap_or_default();
    let range_m = match sc.localization.mode {
        LocalizationMode::Uvdar => sc.localization.uvdar.max_range_m,
        _ => sc.radio.range_m,
    };
    if let Some(apart) = first_apart(starts, range_m) {
        return Some(format!(
            "the starts are not one group within {range_m} m: UAV {apart} starts out of reach of UAV 1"
        ));
    }
    if sc.controller.kind == ControllerKind::A21 && starts.len() > 1 {
        let dmax = sc.controller.a21.dmax_m;
        for (id, p) in (1..).zip(starts).filter(|&(id, _)| sc.is_informed(UavId::new(id))) {
            let seen: Vec<f64> =
                starts.iter().map(|q| (p[0] - q[0]).hypot(p[1] - q[1])).filter(|&d| d > 0.0 && d <= range_m).collect();
            let mean = seen.iter().sum::<f64>() / seen.len().max(1) as f64;
            if mean >= dmax {
                return Some(format!(
                    "informed UAV {id} starts {mean:.2} m on average from the UAVs it sees, at or beyond A21's d_max = {dmax} m (seed 003 eq. 8: it would never move)"
                ));
            }
        }
    }
    None
}

/// Why no UAV that knows the goal stays live, or `None` when one does (or nobody ever knew it).
fn no_informed_left(sc: &Scenario) -> Option<String> {
    let informed: Vec<UavId> = (1..=sc.swarm.count).map(UavId::new).filter(|&id| sc.is_informed(id)).collect();
    let all_frozen = !informed.is_empty() && informed.iter().all(|&id| frozen(sc).any(|(f, _)| f == id));
    all_frozen.then(|| {
        let ids: Vec<String> = informed.iter().map(|id| id.to_string()).collect();
        format!("every informed UAV ({}) freezes: no live UAV knows the goal", ids.join(", "))
    })
}

/// Every UAV that stops for good, its body left where it stood, and when: those failed from the
/// start (at 0 s), then the timeline's freezes.
fn frozen(sc: &Scenario) -> impl Iterator<Item = (UavId, f64)> + '_ {
    let freezes = sc.failures.iter().filter(|f| f.kind == swarm_config::FailureKind::Freeze);
    sc.swarm.failed.iter().map(|&id| (id, 0.0)).chain(freezes.map(|f| (f.uav, f.at_s)))
}

/// Why an A21 flock over UVDAR has a frozen or failed UAV among the bodies it senses, or `None`.
fn frozen_flockmate(sc: &Scenario) -> Option<String> {
    if sc.controller.kind != ControllerKind::A21 || sc.localization.mode != LocalizationMode::Uvdar {
        return None;
    }
    let (uav, at_s) = frozen(sc).next()?;
    Some(format!(
        "A21 over UVDAR with UAV {uav} frozen at {at_s:.1} s: UVDAR senses its body as a live flockmate, and seed 003's cohesion holds the flock to it"
    ))
}

/// The first UAV (1-based) not connected to UAV 1 through starts within `range_m`, if any.
fn first_apart(starts: &[[f64; 2]], range_m: f64) -> Option<usize> {
    let mut reached = vec![false; starts.len()];
    let mut frontier = Vec::new();
    if !starts.is_empty() {
        reached[0] = true;
        frontier.push(0);
    }
    while let Some(i) = frontier.pop() {
        for (j, q) in starts.iter().enumerate() {
            if !reached[j] && (starts[i][0] - q[0]).hypot(starts[i][1] - q[1]) <= range_m {
                reached[j] = true;
                frontier.push(j);
            }
        }
    }
    reached.iter().position(|r| !r).map(|j| j + 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn a21(starts: Vec<[f64; 2]>) -> Scenario {
        let mut sc = swarm_config::builtin("a21-forest-uvdar").expect("built in");
        sc.swarm.count = starts.len() as u32;
        sc.swarm.start_positions = Some(starts);
        sc
    }

    #[test]
    fn a_start_of_two_groups_is_outside_with_the_first_uav_out_of_reach() {
        assert_eq!(first_apart(&[[0.0, 0.0], [3.0, 0.0], [30.0, 0.0]], 10.0), Some(3));
        assert_eq!(first_apart(&[[0.0, 0.0], [9.0, 0.0], [18.0, 0.0]], 10.0), None);
        let why = outside(&a21(vec![[0.0, 0.0], [2.0, 0.0], [40.0, 0.0]])).expect("outside");
        assert!(why.contains("UAV 3 starts out of reach"), "{why}");
        // UVDAR sees 8 m: 8.5 m apart is two groups there.
        assert!(outside(&a21(vec![[0.0, 0.0], [8.5, 0.0]])).is_some_and(|w| w.contains("within 8 m")));
    }

    #[test]
    fn an_a21_informed_uav_beyond_d_max_of_its_flock_is_outside() {
        // Over broadcast (radio 10 m) UAV 1, the informed one, hears both, 8.51 m away on average.
        let mut sc = a21(vec![[0.0, 0.0], [8.5, 0.5], [8.5, -0.5]]);
        sc.localization.mode = LocalizationMode::Broadcast;
        let why = outside(&sc);
        let why = why.expect("outside");
        assert!(why.contains("informed UAV 1") && why.contains("d_max = 8"), "{why}");
        assert_eq!(outside(&a21(vec![[0.0, 0.0], [2.0, 0.0], [0.0, 2.0]])), None);
    }

    #[test]
    fn a_freeze_of_every_informed_uav_is_outside_and_of_another_is_not() {
        let freeze = |uav: u32| swarm_config::Failure {
            at_s: 30.0,
            uav: UavId::new(uav),
            kind: swarm_config::FailureKind::Freeze,
        };
        let mut sc = a21(vec![[0.0, 0.0], [2.0, 0.0], [0.0, 2.0]]);
        sc.localization.mode = LocalizationMode::Broadcast;
        sc.failures = vec![freeze(2)];
        assert_eq!(outside(&sc), None, "UAV 1, the informed one, still flies");
        sc.failures.push(freeze(1));
        let why = outside(&sc).expect("outside");
        assert!(why.contains("every informed UAV (1) freezes"), "{why}");
    }

    #[test]
    fn a21_over_uvdar_with_a_frozen_or_failed_uav_is_outside() {
        let mut sc = a21(vec![[0.0, 0.0], [2.0, 0.0], [0.0, 2.0]]);
        assert_eq!(outside(&sc), None, "no fault");
        sc.failures =
            vec![swarm_config::Failure { at_s: 8.6, uav: UavId::new(3), kind: swarm_config::FailureKind::Freeze }];
        let why = outside(&sc).expect("outside");
        assert!(why.contains("UAV 3 frozen at 8.6 s") && why.contains("UVDAR"), "{why}");
        sc.failures.clear();
        sc.swarm.failed = vec![UavId::new(2)];
        assert!(outside(&sc).is_some_and(|w| w.contains("UAV 2 frozen at 0.0 s")));
        sc.controller.kind = ControllerKind::K21;
        assert_eq!(outside(&sc), None, "another controller");
    }
}

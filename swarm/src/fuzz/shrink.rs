//! Shrinking a failing [`Case`] (after QuickCheck and Jepsen): propose smaller cases one at a
//! time and keep the first that still fails the same check, until none does or the budget of
//! runs is spent. Smaller means, in this order: a shorter flight (to twice the first failing
//! moment and 5 s, for checks judged as they happen), fewer UAVs, fewer faults, fewer trees,
//! shorter faults.

use super::case::Case;
use swarm_config::CheckName;

/// Seconds of flight kept beyond twice the first failing moment when the flight is cut short.
pub const AFTER_FAILURE_S: f64 = 5.0;

/// Checks judged at the end of the run: cutting the flight short would fail them trivially.
pub fn judged_at_end(check: &str) -> bool {
    [CheckName::Goal, CheckName::ConnectedAtEnd, CheckName::Reconnect].iter().any(|c| c.as_str() == check)
}

/// The smaller cases to try next from `c`, most aggressive first. `failed_at_s` is the first
/// failing moment of the check being shrunk.
pub fn candidates(c: &Case, check: &str, failed_at_s: f64) -> Vec<Case> {
    let mut out = Vec::new();
    // Twice the time to the failure, and a little: a smaller swarm may take longer to fail.
    let cut_to = (2.0 * failed_at_s + AFTER_FAILURE_S).ceil();
    if !judged_at_end(check) && cut_to < c.time_limit_s {
        out.push(Case { time_limit_s: cut_to, ..c.clone() });
    }
    let n = c.starts.len();
    for keep in [1, 2, 3, n / 2, n - 1] {
        if keep >= 1 && keep < n && !out.iter().any(|o: &Case| o.starts.len() == keep) {
            out.push(with_uavs(c, keep));
        }
    }
    if !c.faults.is_empty() {
        out.push(Case { faults: Vec::new(), ..c.clone() });
        for i in 0..c.faults.len() {
            let mut faults = c.faults.clone();
            faults.remove(i);
            out.push(Case { faults, ..c.clone() });
        }
    }
    let t = c.trees.len();
    if t > 0 {
        out.push(Case { trees: Vec::new(), ..c.clone() });
        if t > 1 {
            out.push(Case { trees: c.trees[..t / 2].to_vec(), ..c.clone() });
            out.push(Case { trees: c.trees[t / 2..].to_vec(), ..c.clone() });
        }
    }
    if c.faults.iter().any(|f| f.duration_s > 1.0) {
        let mut faults = c.faults.clone();
        for f in &mut faults {
            f.duration_s = (f.duration_s / 2.0 * 10.0).round().max(10.0) / 10.0;
        }
        out.push(Case { faults, ..c.clone() });
    }
    out
}

/// `c` with its first `keep` UAVs only; faults on the UAVs that are gone are dropped or narrowed.
fn with_uavs(c: &Case, keep: usize) -> Case {
    let uavs = keep as u32;
    let faults = c
        .faults
        .iter()
        .filter_map(|f| f.nemesis.restricted(uavs).map(|nemesis| netem::nemesis::Fault { nemesis, ..f.clone() }))
        .collect();
    Case { starts: c.starts[..keep].to_vec(), faults, ..c.clone() }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fuzz::case::Space;
    use netem::nemesis::NemesisKind;

    /// A rough size: UAVs, trees, faults, flight time.
    fn size(c: &Case) -> (usize, usize, usize, f64) {
        (c.starts.len(), c.trees.len(), c.faults.len(), c.time_limit_s)
    }

    #[test]
    fn candidates_are_each_smaller_in_one_way() {
        let space = Space {
            controllers: vec![swarm_config::ControllerKind::K21],
            max_uavs: 8,
            nemesis: NemesisKind::DETERMINISTIC.to_vec(),
            max_faults: 4,
            weaken: None,
        };
        let c = (0..50)
            .map(|i| Case::generate(&space, i, i as u64).expect("generates"))
            .find(|c| c.uavs() >= 4 && !c.faults.is_empty() && c.trees.len() > 2)
            .expect("a case with UAVs, faults and trees");
        let (n, t, f, limit) = size(&c);
        let cands = candidates(&c, "min_separation", 10.0);
        assert_eq!(cands[0].time_limit_s, 25.0, "cut to twice the failure time and 5 s");
        for k in &cands {
            let (n2, t2, f2, l2) = size(k);
            assert!(n2 <= n && t2 <= t && f2 <= f && l2 <= limit, "never larger");
            assert!((n2, t2, f2) != (n, t, f) || l2 < limit || k.faults != c.faults, "each smaller in some way");
            k.render().expect("every candidate is a valid scenario");
        }
        assert!(cands.iter().any(|k| k.uavs() == 1) && cands.iter().any(|k| k.trees.is_empty()));
        assert!(candidates(&c, "goal", 10.0).iter().all(|k| k.time_limit_s == limit), "end checks keep the flight");
    }
}

//! Which UAVs' agents came, and which came and went: folded from the ground-truth steps (each
//! body's `alive`, whether its agent held its liveliness token that tick). Why a module: the
//! metrics (`summary.json`'s `never_joined` and `lost`) and the checks (a lost UAV's links count
//! as cut) ask the same question, and one fold answers both alike. Ids index a vector (they are
//! 1..=N), so a step costs one pass over its bodies and a question one lookup.

use swarm_types::UavId;
use swarm_wire::TruthStep;

/// Per UAV: whether its agent has held its token in some step, and since when it has not after
/// having held it.
#[derive(Debug, Clone, Default)]
pub(crate) struct Liveness {
    /// `ever[id - 1]`: the agent of UAV `id` held its token in some step.
    ever: Vec<bool>,
    /// `gone_since[id - 1]`: the sim time of the first step without its token since it last held
    /// it; `None` while it holds it, or if it never did.
    gone_since: Vec<Option<f64>>,
}

impl Liveness {
    /// Folds one step.
    pub(crate) fn on_step(&mut self, s: &TruthStep) {
        for b in &s.bodies {
            let Some(i) = b.id.try_index() else { continue };
            if i >= self.ever.len() {
                self.ever.resize(i + 1, false);
                self.gone_since.resize(i + 1, None);
            }
            if b.alive {
                self.ever[i] = true;
                self.gone_since[i] = None;
            } else if self.ever[i] && self.gone_since[i].is_none() {
                self.gone_since[i] = Some(s.t_s);
            }
        }
    }

    /// Whether the agent of UAV `id` has held its token in some step.
    pub(crate) fn ever_alive(&self, id: UavId) -> bool {
        id.try_index().and_then(|i| self.ever.get(i)).copied().unwrap_or(false)
    }

    /// Since when the agent of UAV `id`, alive before, has been gone; `None` while it is alive
    /// or if it never came.
    pub(crate) fn lost_since(&self, id: UavId) -> Option<f64> {
        id.try_index().and_then(|i| self.gone_since.get(i)).copied().flatten()
    }

    /// Every UAV gone now, with since when, by id.
    pub(crate) fn lost(&self) -> impl Iterator<Item = (UavId, f64)> + '_ {
        self.gone_since.iter().enumerate().filter_map(|(i, g)| g.map(|t| (UavId::from_index(i), t)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use swarm_wire::TruthBody;

    fn step(t_s: f64, alive: &[bool]) -> TruthStep {
        let bodies = alive
            .iter()
            .enumerate()
            .map(|(i, &alive)| TruthBody {
                id: UavId::from_index(i),
                x: 0.0,
                y: 0.0,
                yaw: 0.0,
                vx: 0.0,
                vy: 0.0,
                alive,
                cmd_on_time: alive,
                obstacle_distance_m: 1.0,
                agent_distance_m: 1.0,
                colliding: false,
            })
            .collect();
        TruthStep { t_s, bodies, ..TruthStep::default() }
    }

    #[test]
    fn an_agent_that_came_and_went_is_lost_from_its_first_step_gone_and_one_that_never_came_is_not() {
        let mut l = Liveness::default();
        l.on_step(&step(0.1, &[true, false, true]));
        l.on_step(&step(0.2, &[true, false, false]));
        l.on_step(&step(0.3, &[false, false, false]));
        assert_eq!(l.lost().collect::<Vec<_>>(), vec![(UavId::new(1), 0.3), (UavId::new(3), 0.2)]);
        assert!(
            l.ever_alive(UavId::new(1))
                && !l.ever_alive(UavId::new(2))
                && !l.ever_alive(UavId::new(9))
                && !l.ever_alive(UavId::new(0))
        );
        assert_eq!(l.lost_since(UavId::new(2)), None, "never came: not lost");
        l.on_step(&step(0.4, &[false, false, true]));
        assert_eq!((l.lost_since(UavId::new(1)), l.lost_since(UavId::new(3))), (Some(0.3), None), "UAV 3 is back");
    }
}

//! The [`Controllers`] registry that turns a scenario's `[controller] kind` into a
//! [`Controller`].
//!
//! Why a registry and not an enum: the built-in controllers (K21, P17, A21, M23) and a user's
//! own are the same kind of thing, a step from a [`View`](super::controller::View) to a
//! [`Command`](super::controller::Command) with memory of its own, and a user's crate must add
//! controllers without editing ours. The `swarm` command line is a library function taking a
//! registry (`swarm::cli::main_with`), and the agents it starts are the same executable, so a
//! binary that registers a controller flies it in every agent.
//!
//! Why a module of its own: the registry names the built-in pilots ([`super::pilot`]), and the
//! pilots implement the trait ([`super::controller`]), so the imports run one way, registry →
//! pilot → controller, and the trait never reaches back up to the pilots it is the seam for.
//!
//! The scenario's name is checked against the registry where a run starts (a clear error that
//! names the known controllers) and again where each agent starts.

use super::controller::Controller;
use super::pilot::{A21Pilot, K21Pilot, M23Pilot, P17Pilot};
use std::collections::BTreeMap;
use std::sync::Arc;
use swarm_config::{ControllerKind, Scenario};

/// Makes the controller of one UAV from the scenario (its parameters, its time step).
pub type MakeController = dyn Fn(&Scenario) -> Box<dyn Controller> + Send + Sync;

/// The controllers a program knows, by the name a scenario's `[controller] kind` gives.
#[derive(Clone)]
pub struct Controllers {
    makers: BTreeMap<String, Arc<MakeController>>,
}

/// A scenario names a controller the program does not know.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown controller `{name}` ([controller] kind); this program knows: {}", known.join(", "))]
pub struct UnknownController {
    /// The name the scenario gives.
    pub name: String,
    /// The names the program knows.
    pub known: Vec<String>,
}

impl Controllers {
    /// The four built-in controllers: `k21`, `p17`, `a21`, `m23`.
    pub fn builtin() -> Controllers {
        let mut c = Controllers { makers: BTreeMap::new() };
        c.insert(ControllerKind::K21, |sc| Box::new(K21Pilot::new(sc)));
        c.insert(ControllerKind::P17, |sc| Box::new(P17Pilot::new(sc)));
        c.insert(ControllerKind::A21, |sc| Box::new(A21Pilot::new(sc)));
        c.insert(ControllerKind::M23, |sc| Box::new(M23Pilot::new(sc)));
        c
    }

    fn insert(
        &mut self,
        kind: ControllerKind,
        make: impl Fn(&Scenario) -> Box<dyn Controller> + Send + Sync + 'static,
    ) {
        self.makers.insert(kind.name().to_string(), Arc::new(make));
    }

    /// These controllers and `make` under `name`, which a scenario names as
    /// `[controller] kind = "name"`.
    ///
    /// # Panics
    /// If `name` is taken (a built-in or one registered before) or is not a valid controller
    /// name (lower-case letters, digits, `-` and `_`, starting with a letter or digit): both are
    /// mistakes in the program, found the first time it runs.
    pub fn with(
        mut self,
        name: &str,
        make: impl Fn(&Scenario) -> Box<dyn Controller> + Send + Sync + 'static,
    ) -> Controllers {
        let kind =
            ControllerKind::try_from(name.to_string()).unwrap_or_else(|e| panic!("controller name `{name}`: {e}"));
        assert!(!self.makers.contains_key(name), "a controller named `{name}` is registered already");
        self.insert(kind, make);
        self
    }

    /// The names known, sorted.
    pub fn names(&self) -> Vec<String> {
        self.makers.keys().cloned().collect()
    }

    /// Whether the scenario's controller is known.
    pub fn check(&self, sc: &Scenario) -> Result<(), UnknownController> {
        self.maker(&sc.controller.kind).map(|_| ())
    }

    /// The controller of one UAV of `sc`.
    pub fn make(&self, sc: &Scenario) -> Result<Box<dyn Controller>, UnknownController> {
        Ok(self.maker(&sc.controller.kind)?(sc))
    }

    fn maker(&self, kind: &ControllerKind) -> Result<&Arc<MakeController>, UnknownController> {
        self.makers
            .get(kind.name())
            .ok_or_else(|| UnknownController { name: kind.name().to_string(), known: self.names() })
    }
}

impl Default for Controllers {
    fn default() -> Self {
        Controllers::builtin()
    }
}

impl std::fmt::Debug for Controllers {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_set().entries(self.makers.keys()).finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::{Command, View};
    use nalgebra::Vector2;
    use swarm_wire::{CmdKind, VectorMagnitudes};

    /// Hovers: the smallest controller there is.
    struct Hover;
    impl Controller for Hover {
        fn step(&mut self, _: &View) -> Command {
            Command {
                kind: CmdKind::Velocity,
                xy: Vector2::zeros(),
                yaw_rate: 0.0,
                vectors: VectorMagnitudes::default(),
            }
        }
    }

    fn scenario(kind: &str) -> Scenario {
        let mut sc = swarm_config::builtin("open-field-5").expect("builtin");
        sc.controller.kind = ControllerKind::try_from(kind.to_string()).expect("a controller name");
        sc
    }

    #[test]
    fn the_builtins_are_known_by_their_scenario_names() {
        let c = Controllers::builtin();
        assert_eq!(c.names(), ["a21", "k21", "m23", "p17"]);
        for name in c.names() {
            let sc = scenario(&name);
            assert!(c.make(&sc).is_ok(), "{name}");
        }
        assert!(c.make(&scenario("m23")).expect("m23").wants_scan_points());
        assert!(!c.make(&scenario("k21")).expect("k21").wants_scan_points());
    }

    #[test]
    fn an_unknown_name_is_an_error_naming_the_known_ones() {
        let e = Controllers::builtin().make(&scenario("hover")).err().expect("unknown");
        assert_eq!(
            e.to_string(),
            "unknown controller `hover` ([controller] kind); this program knows: a21, k21, m23, p17"
        );
    }

    #[test]
    fn a_registered_controller_is_made_by_name() {
        let c = Controllers::builtin().with("hover", |_| Box::new(Hover));
        assert!(c.check(&scenario("hover")).is_ok());
        assert_eq!(c.names().len(), 5);
    }

    #[test]
    #[should_panic(expected = "registered already")]
    fn a_builtin_name_cannot_be_taken() {
        let _ = Controllers::builtin().with("k21", |_| Box::new(Hover));
    }

    #[test]
    #[should_panic(expected = "controller name `Hover Craft`")]
    fn a_name_a_scenario_could_not_give_is_refused() {
        let _ = Controllers::builtin().with("Hover Craft", |_| Box::new(Hover));
    }
}

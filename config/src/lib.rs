//! Scenario schema of a swarm run, parsed from TOML and validated.
//!
//! A scenario says everything a run needs: the world (explicit trees and walls, or a generated
//! forest), the swarm (count, start, goal, who is informed), body limits, the LIDAR, the radio,
//! the time mode, the controller with its parameters, the localization mode and the end
//! conditions. Every struct rejects unknown fields, and every error names the file, the field
//! (as a dotted path) and what is wrong, so a typo never silently falls back to a default.
//!
//! Entry points: [`Scenario::from_file`], [`Scenario::from_toml_str`], [`Scenario::from_arg`],
//! [`builtin`] (the scenarios shipped in `scenarios/`, compiled in so `swarm run` works with no
//! argument).
//!
//! Architecture invariant: this crate is pure data plus validation, and depends on no other crate
//! of the workspace. It knows nothing of Zenoh, of geometry libraries or of how the world is
//! simulated; forest generation lives in `physics-hub`, which is the only holder of ground truth.
//! The `[[netem]]` rules and `[[failures]]` are data here too ([`Impairment`], [`Partition`],
//! [`NetemRule`], [`Timeline`]); which rule is in force at a sim time, and what it does to a
//! message, is the `netem` crate's (`netem::Timeline`, `netem::impair`).
//!
//! Modules (private, their items re-exported at the root, so every public item is
//! `swarm_config::X`), the way a scenario goes:
//! - `parse`: TOML text into the structs, and [`ScenarioError`], which names the file and the
//!   dotted field; `builtins`: the scenarios of `scenarios/`, compiled in ([`BUILTIN`]).
//! - `schema`: the scenario structs; `impairment`: a netem rule's impairment and partition; one
//!   module per controller or sensor with parameters of its own (`p17`, `a21`, `m23`, `costmap`,
//!   `uvdar`); `lost_contact` (what every controller does once its swarm is out of reach);
//!   `expect` (the `[expect]` table: which run invariants apply, with what bounds).
//! - `validate`: the checks of values and of how fields agree, each naming its dotted field, and
//!   [`Scenario::check_timeline`] for a timeline added later; the parameter modules check their
//!   own tables with its helpers.
//! - `mission`: where each UAV's goal is at a sim time ([`Scenario::goal_motion_of`]).
//!
//! This file holds the small accessors every user of a [`Scenario`] needs (ids, informed, period).

mod a21;
mod builtins;
mod costmap;
mod expect;
mod impairment;
mod lost_contact;
mod m23;
mod mission;
mod p17;
mod parse;
mod schema;
mod uvdar;
mod validate;
pub use a21::*;
pub use builtins::{builtin, BUILTIN, DEFAULT_SCENARIO};
pub use costmap::*;
pub use expect::*;
pub use impairment::*;
pub use lost_contact::*;
pub use m23::*;
pub use p17::*;
pub use parse::ScenarioError;
pub use schema::*;
pub use uvdar::*;
// The modes are the ground floor's (their names and share kinds with them); the scenario schema
// names them as its own.
pub use swarm_types::{LocalizationMode, TimeMode, UavId};

impl Scenario {
    /// Number of UAVs.
    pub fn count(&self) -> usize {
        self.swarm.count as usize
    }

    /// The UAV ids of this scenario, `1..=count`.
    pub fn uav_ids(&self) -> impl DoubleEndedIterator<Item = UavId> + ExactSizeIterator {
        UavId::all(self.count())
    }

    /// The ids that get an agent: every UAV but the failed ones.
    pub fn agent_ids(&self) -> impl Iterator<Item = UavId> + '_ {
        self.uav_ids().filter(|id| !self.swarm.failed.contains(id))
    }

    /// Whether UAV `id` knows the goal.
    pub fn is_informed(&self, id: UavId) -> bool {
        match &self.swarm.informed {
            Informed::All(_) => true,
            Informed::Ids(ids) => ids.contains(&id),
        }
    }

    /// Control period in seconds.
    pub fn dt_s(&self) -> f64 {
        1.0 / self.time.control_hz
    }
}

#[cfg(test)]
mod tests;

#[cfg(test)]
mod fuzz;

//! Control: from what perception and localization made of a tick to a command for the hub.
//!
//! - [`controller`]: the [`Controller`] trait (a [`View`] in, a [`Command`] out, memory of its
//!   own), the seam every controller, built in or a user's, plugs into.
//! - [`pilot`]: the built-in controllers' pilots: each runs its seed's controller step by step,
//!   with what it keeps between steps, and does the frame conversions.
//! - [`registry`]: the [`Controllers`] registry a scenario's `[controller] kind` names one from:
//!   the built-in pilots by name, and a user's crate adds its own there. Imports run registry →
//!   pilot → controller, never back.
//! - `k21`: the Boids-style K21 controller of seed 000 chapter 4.
//! - `barrier`: the velocity barrier K21 and A21's safety layer hold a command to, our extension.
//! - `detour`: how a K21 UAV the barrier holds at the mouth of a shut gap gets out (opt-in).
//! - `p17`: the P17 controller of seed 001 chapter 3 (β-agents for cylinders and walls).
//! - `a21`: the A21 controller of seed 003 section III (proximal control, φ-limited navigation).
//! - `m23`: the formation layer of seed 004 (topology goals, the leader's wait, the tracker).
//! - `neighbour_velocity`: each neighbour's velocity from its positions, for P17 and M23.
//! - [`lost_contact`]: what every controller's UAV does once it has lost its swarm (flies back
//!   to where it last estimated it, then hovers), or its group every informed UAV (flies back,
//!   flocking, to where it last had a path to one), a layer over the pilot's command.
//! - [`hops`]: the hop count to the nearest informed UAV that every share carries.
//! - [`arrival`]: how a K21 swarm settles at its goal (a second count, to the nearest arrived
//!   UAV, and K21 with its navigation faded towards it), a layer over the pilot's command.
//!
//! The controllers are pure functions of their seeds' inputs. A21 and M23 plan on maps from
//! [`crate::planning`]; nothing here reaches back up to the agent or the node.

mod a21;
pub(crate) mod arrival;
mod barrier;
pub(crate) mod controller;
mod detour;
pub(crate) mod hops;
mod k21;
pub(crate) mod lost_contact;
mod m23;
pub(crate) mod neighbour_velocity;
mod p17;
pub(crate) mod pilot;
pub(crate) mod registry;

pub use arrival::Arrival;
pub use controller::{Command, Controller, View};
pub use hops::Hops;
pub use lost_contact::LostContact;
pub use registry::{Controllers, MakeController, UnknownController};

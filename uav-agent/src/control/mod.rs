//! Control: from what perception and localization made of a tick to a command for the hub.
//!
//! - [`controller`]: the [`Controller`] trait (a [`View`] in, a [`Command`] out, memory of its
//!   own) and the [`Controllers`] registry a scenario's `[controller] kind` names one from; a
//!   user's crate adds its own there.
//! - [`pilot`]: the built-in controllers' pilots: each runs its seed's controller step by step,
//!   with what it keeps between steps, and does the frame conversions.
//! - `k21`: the Boids-style K21 controller of seed 000 chapter 4.
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
pub(crate) mod controller;
pub(crate) mod hops;
mod k21;
pub(crate) mod lost_contact;
// Seed API kept whole and tested, partly unused by the pilot (see `lib.rs`).
#[cfg_attr(not(test), allow(dead_code))]
mod m23;
#[cfg_attr(not(test), allow(dead_code))]
pub(crate) mod neighbour_velocity;
mod p17;
pub(crate) mod pilot;

pub use arrival::Arrival;
pub use controller::{Controller, Controllers, MakeController, UnknownController};
pub use hops::Hops;
pub use lost_contact::LostContact;
pub use pilot::{Command, View};

//! The seam a researcher plugs a controller into: the [`Controller`] trait, with the [`View`]
//! it reads each tick and the [`Command`] it returns.
//!
//! Why a module of its own, at the bottom of `control`: the built-in pilots, the registry that
//! names them and a user's own controller all stand on this trait and its two types, so it
//! imports none of them. The registry of controllers by name is [`super::registry`]; the
//! built-in controllers' pilots are [`super::pilot`].

use crate::world_model::{Body, Circle, Estimate, Segment};
use nalgebra::{Point2, Vector2};
use swarm_types::UavId;
use swarm_wire::{CmdKind, Odom, VectorMagnitudes};

/// A controller: each tick, what the UAV saw in, a command out. It keeps whatever it needs
/// between steps in `self`; one instance flies one UAV for a whole run.
pub trait Controller: Send {
    /// One control step. The view is in the body frame, odometry in the start frame (see
    /// [`View`]); the command goes out in the body frame.
    fn step(&mut self, view: &View) -> Command;

    /// Whether the step needs [`View::static_points`] (the scan points that are not a
    /// neighbour). Gathering them costs a pass over the scan, so it is off unless asked for.
    fn wants_scan_points(&self) -> bool {
        false
    }
}

/// What one step saw, in the body frame: the neighbours, and the obstacles once the neighbours
/// the LIDAR sees are taken out of them (built once per step by the agent).
#[derive(Debug, Clone, Copy)]
pub struct View<'a> {
    /// This UAV's id.
    pub id: UavId,
    /// Sim time [s].
    pub t_s: f64,
    /// Own odometry (pose and velocity in the start frame, and the goal of an informed UAV).
    pub odom: &'a Odom,
    /// Localized neighbours.
    pub neighbours: &'a [Estimate],
    /// Obstacle circles that are not a localized neighbour.
    pub trees: &'a [Circle],
    /// Wall faces.
    pub walls: &'a [Segment],
    /// The scan points that are not a localized neighbour: what goes into a map (empty unless the
    /// controller asks for them, see [`Controller::wants_scan_points`]).
    pub static_points: &'a [Point2<f64>],
    /// The bodies near the UAV inside scan groups that join several (neighbours or not), and the
    /// circles of localized neighbours within K21's `barrier_m`: what K21's barrier keeps off
    /// besides the trees.
    pub near_bodies: &'a [Body],
}

/// A command in the body frame, with the magnitudes of the controller's terms.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Command {
    /// Velocity or acceleration.
    pub kind: CmdKind,
    /// x, y [m/s or m/s²], body frame.
    pub xy: Vector2<f64>,
    /// Yaw rate [rad/s].
    pub yaw_rate: f64,
    /// Term magnitudes for diagnostics (the K21 names; other controllers map theirs).
    pub vectors: VectorMagnitudes,
}

impl Command {
    /// Hold position: for a tick nobody steered, or a UAV waiting where it should.
    pub fn hover() -> Command {
        Command { kind: CmdKind::Hover, xy: Vector2::zeros(), yaw_rate: 0.0, vectors: VectorMagnitudes::default() }
    }
}

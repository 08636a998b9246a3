//! Types shared by the ICP code and the neighbour database (being written).

use nalgebra::Vector2;

/// A rigid transform that maps points from the neighbour's body frame (the source set S) into
/// this agent's body frame (the reference set R): `p_R = Rot(rotation) · p_S + translation`.
/// So `translation` is where the neighbour is, and `rotation` its heading, relative to us.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transform {
    /// Relative heading [rad].
    pub rotation: f64,
    /// Relative position [m].
    pub translation: Vector2<f64>,
}

/// The outcome of aligning a received set to our own.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Match {
    /// The alignment.
    pub transform: Transform,
    /// Fractional root mean square distance of the kept pairs (seed 000 eq. 3.16).
    pub frmsd: f64,
    /// Pairs kept after FRMSD outlier rejection.
    pub pairs: usize,
}

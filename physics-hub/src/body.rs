//! A UAV body in the plane: position, velocity and heading, tracking a command within speed,
//! acceleration and yaw-rate limits. A point-mass double integrator; K21 commands a velocity
//! (tracked with bounded acceleration), A21 an acceleration.

use nalgebra::{Rotation2, Vector2};
use swarm_wire::{Cmd, CmdKind};

/// Limits of every body.
#[derive(Debug, Clone, Copy)]
pub struct Limits {
    /// Speed limit [m/s].
    pub max_speed_mps: f64,
    /// Acceleration limit [m/s²].
    pub max_accel_mps2: f64,
    /// Yaw-rate limit [rad/s].
    pub max_yaw_rate: f64,
}

/// One UAV body, world frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Body {
    /// Position [m].
    pub pos: Vector2<f64>,
    /// Velocity [m/s].
    pub vel: Vector2<f64>,
    /// Heading [rad], in (−π, π].
    pub yaw: f64,
    /// Stopped after a collision (`on_collision = "stop"`): never moves again.
    pub stopped: bool,
}

/// The one angle wrap of the whole swarm, to (−π, π].
pub use swarm_types::wrap_angle;

fn clamp_norm(v: Vector2<f64>, max: f64) -> Vector2<f64> {
    let n = v.norm();
    if n > max && n > 0.0 {
        v * (max / n)
    } else {
        v
    }
}

impl Body {
    /// A body at rest.
    pub fn at(x: f64, y: f64, yaw: f64) -> Body {
        Body { pos: Vector2::new(x, y), vel: Vector2::zeros(), yaw: wrap_angle(yaw), stopped: false }
    }

    /// Advances `dt` seconds under `cmd` (semi-implicit Euler: velocity first, then position).
    pub fn step(&mut self, cmd: &Cmd, lim: &Limits, dt: f64) {
        if self.stopped {
            self.vel = Vector2::zeros();
            return;
        }
        let world_from_body = Rotation2::new(self.yaw);
        let cmd_in_body = Vector2::new(f64::from(cmd.x), f64::from(cmd.y));
        let cmd_in_world = world_from_body * cmd_in_body;
        let sane = cmd_in_world.iter().all(|c| c.is_finite()) && cmd.yaw_rate.is_finite();
        let (kind, cmd_in_world, yaw_rate) = if sane {
            (cmd.kind, cmd_in_world, f64::from(cmd.yaw_rate))
        } else {
            (CmdKind::Hover, Vector2::zeros(), 0.0)
        };
        let accel = match kind {
            CmdKind::Velocity => (clamp_norm(cmd_in_world, lim.max_speed_mps) - self.vel) / dt,
            CmdKind::Acceleration => cmd_in_world,
            CmdKind::Hover => -self.vel / dt,
        };
        self.vel = clamp_norm(self.vel + clamp_norm(accel, lim.max_accel_mps2) * dt, lim.max_speed_mps);
        self.pos += self.vel * dt;
        let yaw_rate = if kind == CmdKind::Hover { 0.0 } else { yaw_rate.clamp(-lim.max_yaw_rate, lim.max_yaw_rate) };
        self.yaw = wrap_angle(self.yaw + yaw_rate * dt);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const LIM: Limits = Limits { max_speed_mps: 1.0, max_accel_mps2: 2.0, max_yaw_rate: 1.0 };

    fn vel(x: f32, y: f32, yaw_rate: f32) -> Cmd {
        Cmd { tick: 0, kind: CmdKind::Velocity, x, y, yaw_rate }
    }

    #[test]
    fn velocity_command_is_reached_with_bounded_acceleration() {
        let mut b = Body::at(0.0, 0.0, 0.0);
        b.step(&vel(0.5, 0.0, 0.0), &LIM, 0.1);
        assert!((b.vel.x - 0.2).abs() < 1e-12, "2 m/s² for 0.1 s");
        for _ in 0..10 {
            b.step(&vel(0.5, 0.0, 0.0), &LIM, 0.1);
        }
        assert!((b.vel.x - 0.5).abs() < 1e-12);
    }

    #[test]
    fn command_is_in_the_body_frame() {
        let mut b = Body::at(0.0, 0.0, std::f64::consts::FRAC_PI_2);
        for _ in 0..20 {
            b.step(&vel(0.5, 0.0, 0.0), &LIM, 0.1);
        }
        assert!(b.vel.x.abs() < 1e-9 && (b.vel.y - 0.5).abs() < 1e-9, "{:?}", b.vel);
    }

    #[test]
    fn speed_and_yaw_rate_are_limited() {
        let mut b = Body::at(0.0, 0.0, 0.0);
        for _ in 0..50 {
            b.step(&vel(5.0, 0.0, 10.0), &LIM, 0.1);
        }
        assert!(b.vel.norm() <= 1.0 + 1e-12);
        let mut c = Body::at(0.0, 0.0, 0.0);
        c.step(&vel(0.0, 0.0, 10.0), &LIM, 0.1);
        assert!((c.yaw - 0.1).abs() < 1e-12);
    }

    #[test]
    fn non_finite_commands_hover() {
        let mut b = Body::at(0.0, 0.0, 0.0);
        b.vel = Vector2::new(0.1, 0.0);
        b.step(&vel(f32::NAN, 0.0, 0.0), &LIM, 0.1);
        assert_eq!(b.vel, Vector2::zeros());
    }

    #[test]
    fn wrap_angle_stays_in_range() {
        for a in [-10.0, -3.2, 0.0, 3.2, 7.0, 100.0] {
            let w = wrap_angle(a);
            assert!(w > -std::f64::consts::PI - 1e-12 && w <= std::f64::consts::PI + 1e-12);
            assert!(
                ((w - a) / std::f64::consts::TAU).fract().abs() < 1e-9
                    || ((w - a) / std::f64::consts::TAU).fract().abs() > 1.0 - 1e-9
            );
        }
    }
}

//! The two messages between an agent and an external controller, as JSON: the tick's view out
//! (`uav/{id}/ext/view`), a command back (`uav/{id}/ext/cmd`).
//!
//! Why JSON and not postcard like every other key: a controller written in Python, C++ or
//! anything else must read and write these with its language's standard library and nothing of
//! ours, and a view is a few hundred bytes a tick (tens of neighbours and trees), so the text
//! costs nothing that matters. Field names carry their units; every length is in metres, every
//! angle in radians, every position in the UAV's body frame (x ahead, y left) unless named
//! `odom`. Unknown fields are ignored in both directions, so either side may grow.

use serde::{Deserialize, Serialize};

/// One tick's view of an externally controlled UAV: what our own controllers get.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExtView {
    /// The tick to answer (the command must carry it).
    pub tick: u64,
    /// Sim time [s].
    pub t_s: f64,
    /// UAV id.
    pub id: u32,
    /// Own pose and velocity in the odometry frame (the UAV's start frame).
    pub odom: ExtOdom,
    /// The goal in the odometry frame, for an informed UAV.
    pub goal: Option<[f64; 2]>,
    /// The localized neighbours.
    pub neighbours: Vec<ExtNeighbour>,
    /// Obstacle circles that are not a neighbour.
    pub trees: Vec<ExtTree>,
    /// Wall faces, as segments from `a` to `b`.
    pub walls: Vec<ExtWall>,
    /// Hops to the nearest informed UAV as the UAV's last step counted them (0: informed; 255:
    /// no path), from the counts its neighbours' shares carry. Appended: old readers skip it.
    #[serde(default = "no_path")]
    pub hops_informed: u8,
    /// Hops to the nearest UAV inside its goal disc, counted alike. Appended.
    #[serde(default = "no_path")]
    pub hops_arrived: u8,
}

/// A hop count of no path.
fn no_path() -> u8 {
    u8::MAX
}

/// Own pose and velocity, odometry frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ExtOdom {
    /// Position [m].
    pub x: f64,
    /// Position [m].
    pub y: f64,
    /// Heading [rad].
    pub yaw: f64,
    /// Velocity [m/s].
    pub vx: f64,
    /// Velocity [m/s].
    pub vy: f64,
}

/// A localized neighbour, body frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ExtNeighbour {
    /// Its id, where the localization mode knows it.
    pub id: Option<u32>,
    /// Position [m].
    pub x: f64,
    /// Position [m].
    pub y: f64,
    /// Its heading relative to ours [rad].
    pub heading: f64,
    /// Age of the estimate's information [s].
    pub age_s: f64,
    /// How its position in our body frame changes [m/s] (seed 001 eq. 9 on the successive
    /// estimates of one id): its velocity relative to ours, as seen from our turning body;
    /// `null` until an id has two estimates. Appended: old readers skip it.
    #[serde(default)]
    pub vel: Option<[f64; 2]>,
}

/// An obstacle circle, body frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ExtTree {
    /// Centre [m].
    pub x: f64,
    /// Centre [m].
    pub y: f64,
    /// Radius [m].
    pub r: f64,
}

/// A wall face, body frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ExtWall {
    /// One end [m].
    pub ax: f64,
    /// One end [m].
    pub ay: f64,
    /// The other end [m].
    pub bx: f64,
    /// The other end [m].
    pub by: f64,
}

/// What an external controller answers: a velocity (default) or an acceleration in the body
/// frame, and a yaw rate, for one tick.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ExtCmd {
    /// The tick of the view it answers.
    pub tick: u64,
    /// `"velocity"` (m/s, the default) or `"acceleration"` (m/s²).
    #[serde(default)]
    pub kind: ExtCmdKind,
    /// Body frame x [m/s or m/s²].
    pub x: f64,
    /// Body frame y [m/s or m/s²].
    pub y: f64,
    /// Yaw rate [rad/s].
    #[serde(default)]
    pub yaw_rate: f64,
}

/// The kind of an external command.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ExtCmdKind {
    /// Velocity [m/s].
    #[default]
    Velocity,
    /// Acceleration [m/s²].
    Acceleration,
}

impl ExtCmd {
    /// Reads a command; `None` for anything that is not one with finite numbers.
    pub fn parse(bytes: &[u8]) -> Option<ExtCmd> {
        let c: ExtCmd = serde_json::from_slice(bytes).ok()?;
        [c.x, c.y, c.yaw_rate].iter().all(|v| v.is_finite()).then_some(c)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_command_needs_only_tick_x_and_y() {
        let c = ExtCmd::parse(br#"{"tick": 7, "x": 0.5, "y": -0.25}"#).expect("a command");
        assert_eq!(c, ExtCmd { tick: 7, kind: ExtCmdKind::Velocity, x: 0.5, y: -0.25, yaw_rate: 0.0 });
        let a = ExtCmd::parse(br#"{"tick": 7, "kind": "acceleration", "x": 1, "y": 0, "yaw_rate": 0.1, "note": "hi"}"#);
        assert_eq!(a.map(|c| c.kind), Some(ExtCmdKind::Acceleration));
    }

    #[test]
    fn anything_else_is_not_a_command() {
        for bad in [
            &br#"{"x": 0.5, "y": 0}"#[..],
            br#"{"tick": 1, "x": "fast", "y": 0}"#,
            br#"{"tick": 1, "x": 1e999, "y": 0}"#,
            b"\xff",
            b"",
        ] {
            assert_eq!(ExtCmd::parse(bad), None, "{}", String::from_utf8_lossy(bad));
        }
    }

    #[test]
    fn a_view_is_plain_json_with_named_units() {
        let v = ExtView {
            tick: 3,
            t_s: 0.3,
            id: 2,
            odom: ExtOdom { x: 1.0, y: 2.0, yaw: 0.0, vx: 0.5, vy: 0.0 },
            goal: Some([30.0, 0.0]),
            neighbours: vec![ExtNeighbour { id: Some(1), x: 2.0, y: 0.0, heading: 0.1, age_s: 0.1, vel: None }],
            trees: vec![ExtTree { x: 3.0, y: 1.0, r: 0.2 }],
            walls: vec![],
            hops_informed: 0,
            hops_arrived: u8::MAX,
        };
        let text = serde_json::to_string(&v).expect("json");
        assert!(
            text.starts_with(
                r#"{"tick":3,"t_s":0.3,"id":2,"odom":{"x":1.0,"y":2.0,"yaw":0.0,"vx":0.5,"vy":0.0},"goal":[30.0,0.0]"#
            ),
            "{text}"
        );
        assert_eq!(serde_json::from_str::<ExtView>(&text).expect("back"), v);
        // A view of before the appended fields still reads.
        let old = r#"{"tick":1,"t_s":0.1,"id":2,"odom":{"x":0,"y":0,"yaw":0,"vx":0,"vy":0},"goal":null,
            "neighbours":[{"id":null,"x":1,"y":0,"heading":0,"age_s":0}],"trees":[],"walls":[]}"#;
        let v: ExtView = serde_json::from_str(old).expect("an old view");
        assert_eq!((v.hops_informed, v.neighbours[0].vel), (u8::MAX, None));
    }
}

//! `visualization_msgs/msg/MarkerArray`: the world for RViz (trees as cylinders, walls as
//! boxes, the goal as a flat disc), in Jazzy's `Marker` layout (with its texture, UV and mesh
//! fields, left empty).

use super::{pose_at, Header};
use crate::cdr::Writer;

/// `visualization_msgs/msg/Marker` shapes used here.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shape {
    /// `CUBE` (1).
    Cube,
    /// `CYLINDER` (3).
    Cylinder,
}

impl Shape {
    fn code(self) -> i32 {
        match self {
            Shape::Cube => 1,
            Shape::Cylinder => 3,
        }
    }
}

/// One marker, planar pose, with its size and colour.
#[derive(Debug, Clone, PartialEq)]
pub struct Marker {
    /// Namespace (`trees`, `walls`, `goal`).
    pub ns: &'static str,
    /// Id within the namespace.
    pub id: i32,
    /// Shape.
    pub shape: Shape,
    /// Centre x, y, z [m].
    pub at: [f64; 3],
    /// Rotation about z [rad].
    pub yaw: f64,
    /// Size along x, y, z [m] (a cylinder's x and y are its diameter).
    pub scale: [f64; 3],
    /// Colour r, g, b, a in [0, 1].
    pub rgba: [f32; 4],
}

/// `ADD` (0) or `DELETEALL` (3).
const ADD: i32 = 0;
const DELETEALL: i32 = 3;

fn marker(w: &mut Writer, header: &Header, m: &Marker, action: i32) {
    header.write(w);
    w.string(m.ns).i32(m.id).i32(m.shape.code()).i32(action);
    pose_at(w, m.at, m.yaw);
    for v in m.scale {
        w.f64(v);
    }
    for c in m.rgba {
        w.f32(c);
    }
    // lifetime 0 (for ever), frame_locked false, no points or colours, no texture resource.
    w.i32(0).u32(0).bool(false).count(0).count(0).string("");
    // texture: sensor_msgs/CompressedImage (header, format, data), empty.
    Header::new(0.0, "").write(w);
    w.string("").bytes(&[]);
    // uv_coordinates, text, mesh_resource, mesh_file (filename, data), embedded materials.
    w.count(0).string("").string("").string("").bytes(&[]).bool(false);
}

/// A `MarkerArray`: a `DELETEALL` first (so a re-sent array replaces the last), then `markers`,
/// each in `header`'s frame.
pub fn marker_array(header: &Header, markers: &[Marker]) -> Vec<u8> {
    let mut w = Writer::new();
    w.count(markers.len() + 1);
    let clear = Marker { ns: "", id: 0, shape: Shape::Cube, at: [0.0; 3], yaw: 0.0, scale: [0.0; 3], rgba: [0.0; 4] };
    marker(&mut w, header, &clear, DELETEALL);
    for m in markers {
        marker(&mut w, header, m, ADD);
    }
    w.finish()
}

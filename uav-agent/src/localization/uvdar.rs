//! The `uvdar` localization mode: onboard relative sensing (UV markers seen by cameras), with no
//! communication at all. Each tick's sensing, part of the sensor frame, gives range and bearing of
//! every neighbour seen; there is no heading, and nothing is kept between ticks or shared.

use crate::sensing::SensorFrame;
use crate::world_model::Estimate;
use nalgebra::Vector2;

/// The neighbours this tick's UVDAR sensing saw, in the body frame (heading unknown: 0).
pub(crate) fn estimates(frame: &SensorFrame) -> Vec<Estimate> {
    let now = frame.scan.t_s;
    let seen = frame.uvdar.as_ref().filter(|u| (u.t_s - now).abs() < 1e-6);
    seen.map(|u| {
        u.seen
            .iter()
            .map(|s| {
                let (r, b) = (f64::from(s.range_m), f64::from(s.bearing_rad));
                Estimate { id: Some(s.id), pos_in_body: r * Vector2::new(b.cos(), b.sin()), heading: 0.0, age_s: 0.0 }
            })
            .collect()
    })
    .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensing::tests::frame_at;
    use swarm_types::UavId;
    use swarm_wire::{Uvdar, UvdarSeen};

    #[test]
    fn range_and_bearing_become_a_body_frame_position() {
        let mut frame = frame_at(2);
        let seen = vec![UvdarSeen { id: UavId::new(3), range_m: 2.0, bearing_rad: std::f32::consts::FRAC_PI_2 }];
        frame.uvdar = Some(Uvdar { tick: 2, t_s: frame.scan.t_s, seen });
        let e = estimates(&frame);
        assert_eq!(e.len(), 1);
        assert_eq!(e[0].id, Some(UavId::new(3)));
        assert!((e[0].pos_in_body - Vector2::new(0.0, 2.0)).norm() < 1e-6, "{:?}", e[0]);
        assert!(estimates(&frame_at(2)).is_empty(), "nothing sensed, nobody placed");
    }
}

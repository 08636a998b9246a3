//! Encoding and decoding the payloads every tick carries most of: one UAV's sensor frame (the
//! hub encodes a thousand a tick at open-1000, on its worker threads; each agent decodes its own)
//! with a 750-beam scan, and an agent state with 20 neighbour estimates.
//!
//! Run: `cargo bench -p swarm-wire --bench codec`

use criterion::{black_box, criterion_main, Criterion};
use swarm_wire::*;

fn frame() -> Msg {
    let ranges_m = (0..750).map(|i| if i % 3 == 0 { f32::INFINITY } else { 2.0 + (i as f32) * 0.01 }).collect();
    Msg::Sense(Box::new(SenseFrame {
        radio: RadioSet {
            tick: 1234,
            id: UavId::new(7),
            in_range: (1..=18).map(UavId::new).collect(),
            loss: Vec::new(),
        },
        odom: Odom { tick: 1234, t_s: 123.4, x: 1.5, y: -2.5, yaw: 0.3, vx: 0.5, vy: 0.1, goal: None, goal_vel: None },
        gnss: Some(Gnss { tick: 1234, t_s: 123.4, x: 10.5, y: -20.5, yaw: 0.3, vx: 0.5, vy: 0.1 }),
        uvdar: None,
        scan: Scan {
            tick: 1234,
            t_s: 123.4,
            angle_min: -std::f32::consts::PI,
            angle_increment: 2.0 * std::f32::consts::PI / 750.0,
            max_range_m: 12.0,
            ranges_m,
        },
    }))
}

fn state() -> Msg {
    let neighbours = (1..=20)
        .map(|i| NeighbourEstimate { id: Some(UavId::new(i)), x: i as f32 * 0.5, y: -1.0, heading: 0.1, age_s: 0.1 })
        .collect();
    Msg::State(Box::new(AgentState {
        id: UavId::new(7),
        tick: 1234,
        t_s: 123.4,
        step_time_us: 150,
        obstacles: 12,
        neighbours,
        in_radio_range: 20,
        vectors: VectorMagnitudes::default(),
        link: LinkCounters::default(),
        icp: IcpCounts::default(),
        delays: Vec::new(),
        traffic: Traffic::default(),
    }))
}

fn bench_codec(c: &mut Criterion) {
    let mut group = c.benchmark_group("codec");
    for (name, msg) in [("sense_750b", frame()), ("state_20n", state())] {
        let bytes = msg.encode().expect("encodes");
        group.bench_function(format!("encode/{name}"), |b| b.iter(|| black_box(&msg).encode().expect("encodes")));
        group.bench_function(format!("decode/{name}"), |b| b.iter(|| Msg::decode(black_box(&bytes)).expect("decodes")));
    }
    group.finish();
}

/// The criterion group (in a private module: the macro's generated `pub fn` has no doc).
mod group {
    criterion::criterion_group!(benches, super::bench_codec);
}
criterion_main!(group::benches);

#![allow(missing_docs)] // criterion macros generate undocumented items
//! One control step of an agent (perception + localization + K21) on a realistic input: a
//! 750-beam scan of the forest-5 world from inside it, and 4 or 8 neighbours.

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use swarm_wire::{Gnss, Odom, PoseShare, Scan};
use uav_agent::agent::{Agent, Share};

/// A scan of circles at fixed places, computed analytically (no dependency on the hub).
fn forest_scan(beams: usize) -> Scan {
    let trees = [(3.0, 1.0, 0.3), (5.0, -2.5, 0.25), (-4.0, 3.0, 0.35), (7.0, 4.0, 0.2), (-2.0, -5.0, 0.3), (9.0, -1.0, 0.3), (0.5, 6.5, 0.2), (-7.5, -1.5, 0.25)];
    let inc = std::f32::consts::TAU / beams as f32;
    let ranges_m = (0..beams)
        .map(|i| {
            let a = f64::from(i as f32 * inc);
            let (dx, dy) = (a.cos(), a.sin());
            trees
                .iter()
                .filter_map(|&(cx, cy, r): &(f64, f64, f64)| {
                    let b = dx * cx + dy * cy;
                    let disc = b * b - (cx * cx + cy * cy - r * r);
                    (disc >= 0.0 && b > 0.0).then(|| b - disc.sqrt())
                })
                .fold(f64::INFINITY, f64::min)
        })
        .map(|d| if d <= 12.0 { d as f32 } else { f32::INFINITY })
        .collect();
    Scan { tick: 10, t_secs: 1.0, angle_min: 0.0, angle_increment: inc, max_range_m: 12.0, ranges_m }
}

fn bench_step(c: &mut Criterion) {
    let sc = swarm_config::builtin("forest-5").expect("builtin");
    let scan = forest_scan(750);
    let odom = Odom { tick: 10, t_secs: 1.0, x: 0.0, y: 0.0, yaw: 0.0, vx: 0.3, vy: 0.0, goal: Some([30.0, 0.0]) };
    let gnss = Gnss { tick: 10, t_secs: 1.0, x: 0.0, y: 0.0, yaw: 0.0, vx: 0.3, vy: 0.0 };
    for n in [4u32, 8] {
        let mut agent = Agent::new(1, sc.clone());
        c.bench_function(&format!("agent/step_750b_{n}_neighbours"), |b| {
            b.iter(|| {
                for j in 0..n {
                    let a = f64::from(j) * 0.8;
                    agent.on_share(Share::Pose(PoseShare { from: j + 2, tick: 9, t_secs: 0.9, x: 2.0 * a.cos(), y: 2.0 * a.sin(), yaw: 0.1, vx: 0.3, vy: 0.0 }));
                }
                black_box(agent.step(black_box(&scan), &odom, Some(&gnss)))
            })
        });
    }
}

criterion_group!(benches, bench_step);
criterion_main!(benches);

#![allow(missing_docs)] // criterion macros generate undocumented items
//! One control step of an agent (perception + localization + K21) on a realistic input: a
//! 750-beam scan of a forest from inside it, and 4 or 8 neighbours, in broadcast mode and in ICP
//! mode. The ICP bench advances sim time by one tick per iteration, so its mean includes the
//! long ICPs the database schedules (every 5 s per neighbour, at most 2 per step; seed 000 6.2
//! reports 31.7 ms for 8 UAVs).

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use swarm_wire::{Gnss, ObstacleShare, Odom, PoseShare, Scan};
use uav_agent::{Agent, SensorFrame, Share};

/// About 5 trees per 100 m² in a 24 m square around the origin, ≥ 2.5 m apart, none within
/// 1.5 m of the origin (deterministic: a small LCG).
fn forest() -> Vec<(f64, f64, f64)> {
    let mut state: u64 = 0x5eed;
    let mut next = move || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut trees: Vec<(f64, f64, f64)> = Vec::new();
    while trees.len() < 29 {
        let (x, y, r) = (next() * 24.0 - 12.0, next() * 24.0 - 12.0, 0.15 + next() * 0.2);
        if x.hypot(y) > 1.5 && trees.iter().all(|t| (t.0 - x).hypot(t.1 - y) > 2.5) {
            trees.push((x, y, r));
        }
    }
    trees
}

/// A scan of the trees, computed analytically (no dependency on the hub).
fn forest_scan(beams: usize) -> Scan {
    let trees = forest();
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
    let odom = Odom { tick: 10, t_secs: 1.0, x: 0.0, y: 0.0, yaw: 0.0, vx: 0.3, vy: 0.0, goal: Some([30.0, 0.0]), goal_vel: None };
    let gnss = Gnss { tick: 10, t_secs: 1.0, x: 0.0, y: 0.0, yaw: 0.0, vx: 0.3, vy: 0.0 };
    let frame = SensorFrame { scan, odom, gnss: Some(gnss), uvdar: None };
    for n in [4u32, 8] {
        let mut agent = Agent::new(1, sc.clone());
        c.bench_function(&format!("agent/step_750b_{n}_neighbours"), |b| {
            b.iter(|| {
                for j in 0..n {
                    let a = f64::from(j) * 0.8;
                    agent.on_share(Share::Pose(PoseShare { from: j + 2, tick: 9, t_secs: 0.9, x: 2.0 * a.cos(), y: 2.0 * a.sin(), yaw: 0.1, vx: 0.3, vy: 0.0 }));
                }
                black_box(agent.step(black_box(&frame)))
            })
        });
    }
}

/// What neighbour `j` at pose (x, y, θ) shares: the tree centres within 12 m, its body frame.
fn share_of(j: u32, pose: (f64, f64, f64), tick: u64) -> Share {
    let (s, c) = pose.2.sin_cos();
    let pts = forest().into_iter().filter(|t| (t.0 - pose.0).hypot(t.1 - pose.1) < 12.0).map(|t| {
        let (dx, dy) = (t.0 - pose.0, t.1 - pose.1);
        [c * dx + s * dy, -s * dx + c * dy]
    });
    Share::Obstacles(ObstacleShare { from: j, tick, t_secs: tick as f64 * 0.1, centres_cm: ObstacleShare::quantize(pts) })
}

fn bench_icp_step(c: &mut Criterion) {
    let sc = swarm_config::builtin("forest-5").expect("builtin");
    assert_eq!(sc.localization.mode, swarm_config::LocalizationMode::Icp);
    let scan = forest_scan(750);
    for n in [4u32, 8] {
        let mut agent = Agent::new(1, sc.clone());
        let poses: Vec<(f64, f64, f64)> =
            (0..n).map(|j| (f64::from(j) * 0.8).sin_cos()).map(|(s, c)| (2.5 * c, 2.5 * s, 0.2 * s)).collect();
        let mut tick = 1u64;
        c.bench_function(&format!("agent/step_icp_750b_{n}_neighbours"), |b| {
            b.iter(|| {
                for (j, &p) in poses.iter().enumerate() {
                    agent.on_share(share_of(j as u32 + 2, p, tick - 1));
                }
                let t = tick as f64 * 0.1;
                let scan = Scan { tick, t_secs: t, ..scan.clone() };
                let odom = Odom { tick, t_secs: t, x: 0.0, y: 0.0, yaw: 0.0, vx: 0.0, vy: 0.0, goal: Some([30.0, 0.0]), goal_vel: None };
                let out = agent.step(black_box(&SensorFrame { scan, odom, gnss: None, uvdar: None }));
                tick += 1;
                black_box(out)
            })
        });
        // The bench measured real work: the neighbours were localized.
        let t = tick as f64 * 0.1;
        let odom = Odom { tick, t_secs: t, x: 0.0, y: 0.0, yaw: 0.0, vx: 0.0, vy: 0.0, goal: None, goal_vel: None };
        for (j, &p) in poses.iter().enumerate() {
            agent.on_share(share_of(j as u32 + 2, p, tick - 1));
        }
        let out = agent.step(&SensorFrame { scan: Scan { tick, t_secs: t, ..scan.clone() }, odom, gnss: None, uvdar: None });
        assert_eq!(out.report.neighbours.len(), n as usize, "all neighbours localized: {:?}", out.report.icp);
    }
}

criterion_group!(benches, bench_step, bench_icp_step);
criterion_main!(benches);

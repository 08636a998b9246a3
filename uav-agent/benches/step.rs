#![allow(missing_docs)] // criterion macros generate undocumented items
//! One control step of an agent (perception + localization + K21) on a realistic input: a
//! 750-beam scan of a forest from inside it, and 4 or 8 neighbours, in broadcast mode and in ICP
//! mode. The ICP bench advances sim time by one tick per iteration, so its mean includes the
//! long ICPs the database schedules (at most 2 per step; seed 000 6.2 reports 31.7 ms for 8
//! UAVs): by need (the shipped default, every 30 s per tightly fitting neighbour) and, in the
//! `_seed_clock` variants, on seed 000's clock (every 5 s per neighbour).
//! `agent/step_icp_crowd/N` is the ICP-mode step with N = 8, 16, 32, 64 neighbours in a crowd in
//! a larger forest, to show how the step grows with the crowd; after it, the same steps' mean
//! CPU time is printed (the wall clock of a shared machine is noisy).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use std::hint::black_box;
use swarm_types::UavId;
use swarm_wire::{Gnss, ObstacleShare, Odom, PoseShare, Scan};
use uav_agent::{Agent, Controllers, ObstacleSet, SensorFrame, Share};

/// About 5 trees per 100 m² in a 24 m square around the origin, ≥ 2.5 m apart, none within
/// 1.5 m of the origin (deterministic: a small LCG).
fn forest() -> Vec<(f64, f64, f64)> {
    forest_of(12.0, 29)
}

/// `count` trees (x, y, radius) [m] in a square of half side `half_m` around the origin, ≥ 2.5 m
/// apart, none within 1.5 m of the origin (deterministic: a small LCG).
fn forest_of(half_m: f64, count: usize) -> Vec<(f64, f64, f64)> {
    let mut state: u64 = 0x5eed;
    let mut next = move || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut trees: Vec<(f64, f64, f64)> = Vec::new();
    while trees.len() < count {
        let (x, y, r) = (next() * 2.0 * half_m - half_m, next() * 2.0 * half_m - half_m, 0.15 + next() * 0.2);
        if x.hypot(y) > 1.5 && trees.iter().all(|t| (t.0 - x).hypot(t.1 - y) > 2.5) {
            trees.push((x, y, r));
        }
    }
    trees
}

/// A scan of the trees, computed analytically (no dependency on the hub).
fn forest_scan(beams: usize) -> Scan {
    scan_of(&forest(), beams)
}

/// A scan of `trees` from the origin, computed analytically.
fn scan_of(trees: &[(f64, f64, f64)], beams: usize) -> Scan {
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
    Scan { tick: 10, t_s: 1.0, angle_min: 0.0, angle_increment: inc, max_range_m: 12.0, ranges_m }
}

fn bench_step(c: &mut Criterion) {
    let sc = swarm_config::builtin("forest-5").expect("builtin");
    let scan = forest_scan(750);
    let odom = Odom {
        tick: 10,
        t_s: 1.0,
        x: 0.0,
        y: 0.0,
        yaw: 0.0,
        vx: 0.3,
        vy: 0.0,
        goal: Some([30.0, 0.0]),
        goal_vel: None,
    };
    let gnss = Gnss { tick: 10, t_s: 1.0, x: 0.0, y: 0.0, yaw: 0.0, vx: 0.3, vy: 0.0 };
    let frame = SensorFrame { scan, odom, gnss: Some(gnss), uvdar: None };
    for n in [4u32, 8] {
        let mut agent = Agent::new(UavId::new(1), sc.clone(), &Controllers::builtin()).expect("agent");
        c.bench_function(&format!("agent/step_750b_{n}_neighbours"), |b| {
            b.iter(|| {
                for j in 0..n {
                    let a = f64::from(j) * 0.8;
                    agent.on_share(&Share::Pose(PoseShare {
                        from: UavId::new(j + 2),
                        tick: 9,
                        t_s: 0.9,
                        x: 2.0 * a.cos(),
                        y: 2.0 * a.sin(),
                        yaw: 0.1,
                        vx: 0.3,
                        vy: 0.0,
                        hops: 0,
                        arrival: 0,
                    }));
                }
                black_box(agent.step(black_box(&frame)))
            })
        });
    }
}

/// What neighbour `j` at pose (x, y, θ) shares: the tree centres within 12 m, its body frame.
fn share_of(j: UavId, pose: (f64, f64, f64), tick: u64) -> Share {
    share_in(&forest(), j, pose, tick)
}

/// What neighbour `j` at pose (x, y, θ) among `trees` shares: the centres within 12 m, its body frame.
fn share_in(trees: &[(f64, f64, f64)], j: UavId, pose: (f64, f64, f64), tick: u64) -> Share {
    let (s, c) = pose.2.sin_cos();
    let pts = trees.iter().copied().filter(|t| (t.0 - pose.0).hypot(t.1 - pose.1) < 12.0).map(|t| {
        let (dx, dy) = (t.0 - pose.0, t.1 - pose.1);
        [c * dx + s * dy, -s * dx + c * dy]
    });
    Share::Obstacles(ObstacleSet::new(ObstacleShare {
        from: j,
        tick,
        t_s: tick as f64 * 0.1,
        centres_cm: ObstacleShare::quantize(pts),
        hops: 0,
        arrival: 0,
    }))
}

fn bench_icp_step(c: &mut Criterion) {
    let sc = swarm_config::builtin("forest-5").expect("builtin");
    assert_eq!(sc.localization.mode, swarm_config::LocalizationMode::Icp);
    let scan = forest_scan(750);
    // Seed 000's clock: every tracked neighbour re-checked every `long_every_s`, fit or not.
    let mut seed_clock = sc.clone();
    seed_clock.localization.icp.tight_long_every_s = seed_clock.localization.icp.long_every_s;
    for (n, sc, schedule) in
        [(4u32, &sc, ""), (8, &sc, ""), (4, &seed_clock, "_seed_clock"), (8, &seed_clock, "_seed_clock")]
    {
        let mut agent = Agent::new(UavId::new(1), sc.clone(), &Controllers::builtin()).expect("agent");
        let poses: Vec<(f64, f64, f64)> =
            (0..n).map(|j| (f64::from(j) * 0.8).sin_cos()).map(|(s, c)| (2.5 * c, 2.5 * s, 0.2 * s)).collect();
        let mut tick = 1u64;
        c.bench_function(&format!("agent/step_icp_750b_{n}_neighbours{schedule}"), |b| {
            b.iter(|| {
                for (j, &p) in poses.iter().enumerate() {
                    agent.on_share(&share_of(UavId::from_index(j + 1), p, tick - 1));
                }
                let t = tick as f64 * 0.1;
                let scan = Scan { tick, t_s: t, ..scan.clone() };
                let odom = Odom {
                    tick,
                    t_s: t,
                    x: 0.0,
                    y: 0.0,
                    yaw: 0.0,
                    vx: 0.0,
                    vy: 0.0,
                    goal: Some([30.0, 0.0]),
                    goal_vel: None,
                };
                let out = agent.step(black_box(&SensorFrame { scan, odom, gnss: None, uvdar: None }));
                tick += 1;
                black_box(out)
            })
        });
        // The bench measured real work: the neighbours were localized (unless a filter skipped it).
        if tick == 1 {
            continue;
        }
        let t = tick as f64 * 0.1;
        let odom = Odom { tick, t_s: t, x: 0.0, y: 0.0, yaw: 0.0, vx: 0.0, vy: 0.0, goal: None, goal_vel: None };
        for (j, &p) in poses.iter().enumerate() {
            agent.on_share(&share_of(UavId::from_index(j + 1), p, tick - 1));
        }
        let out =
            agent.step(&SensorFrame { scan: Scan { tick, t_s: t, ..scan.clone() }, odom, gnss: None, uvdar: None });
        assert_eq!(out.report.neighbours.len(), n as usize, "all neighbours localized: {:?}", out.report.icp);
    }
}

/// A crowd of `n` neighbours around the agent at the origin, as in seed 000 6.4 (start disc,
/// 1.6 m apart): the nodes of a 1.6 m triangular lattice nearest the origin, at least 0.8 m from
/// every tree trunk, with headings spread over ±0.3 rad (deterministic).
fn crowd(trees: &[(f64, f64, f64)], n: usize) -> Vec<(f64, f64, f64)> {
    const SPACING_M: f64 = 1.6;
    let mut nodes: Vec<(f64, f64)> = Vec::new();
    for row in -12i32..=12 {
        for col in -12i32..=12 {
            let x = SPACING_M * (f64::from(col) + 0.5 * f64::from(row.rem_euclid(2)));
            let y = SPACING_M * f64::from(row) * 3f64.sqrt() / 2.0;
            let clear = trees.iter().all(|t| (t.0 - x).hypot(t.1 - y) > t.2 + 0.8);
            if x.hypot(y) > 1.0 && clear {
                nodes.push((x, y));
            }
        }
    }
    nodes.sort_by(|a, b| a.0.hypot(a.1).total_cmp(&b.0.hypot(b.1)).then(a.0.total_cmp(&b.0)).then(a.1.total_cmp(&b.1)));
    nodes.into_iter().take(n).enumerate().map(|(j, (x, y))| (x, y, 0.3 * (j as f64 * 1.7).sin())).collect()
}

/// One ICP-mode step of the agent at the origin at `tick`, after every neighbour's share of the
/// previous tick arrived.
fn crowd_step(
    agent: &mut Agent,
    trees: &[(f64, f64, f64)],
    poses: &[(f64, f64, f64)],
    scan: &Scan,
    tick: u64,
) -> uav_agent::StepOutput {
    for (j, &p) in poses.iter().enumerate() {
        agent.on_share(&share_in(trees, UavId::from_index(j + 1), p, tick - 1));
    }
    let t = tick as f64 * 0.1;
    let scan = Scan { tick, t_s: t, ..scan.clone() };
    let odom =
        Odom { tick, t_s: t, x: 0.0, y: 0.0, yaw: 0.0, vx: 0.0, vy: 0.0, goal: Some([30.0, 0.0]), goal_vel: None };
    agent.step(&SensorFrame { scan, odom, gnss: None, uvdar: None })
}

/// Ticks flown before measuring: every initial ICP (2 per step) and a round of retries (5 s).
const WARM_UP_TICKS: u64 = 120;

/// The ICP-mode step with 8 to 64 neighbours in a crowd in a forest (about 5 trees per 100 m² in
/// a 60 m square), in the steady state: the database is warmed up until every neighbour has been
/// placed (the initial ICPs, at most 2 per step, are not measured), then each iteration is one
/// tick, so the mean includes the long ICPs (by need with 8 neighbours, on seed 000's clock of
/// 5 s from 10, where the crowd rules apply) and the retries.
fn bench_icp_crowd(c: &mut Criterion) {
    let sc = swarm_config::builtin("forest-5").expect("builtin");
    let trees = forest_of(30.0, 180);
    let scan = scan_of(&trees, 750);
    let mut group = c.benchmark_group("agent/step_icp_crowd");
    for n in [8usize, 16, 32, 64] {
        let poses = crowd(&trees, n);
        let mut agent = Agent::new(UavId::new(1), sc.clone(), &Controllers::builtin()).expect("agent");
        let mut placed = 0;
        for tick in 1..=WARM_UP_TICKS {
            placed = crowd_step(&mut agent, &trees, &poses, &scan, tick).report.neighbours.len();
        }
        // Beyond about 5 m (the initial ICP's grid) neighbours are not placed, but their sets are
        // still received, matched and retried: they are part of the cost.
        assert!(placed * 2 >= n, "warm-up placed {placed} of {n} neighbours");
        let mut tick = WARM_UP_TICKS + 1;
        group.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
            b.iter(|| {
                let out = crowd_step(&mut agent, &trees, &poses, &scan, tick);
                tick += 1;
                black_box(out)
            })
        });
    }
    group.finish();
    cpu_table(sc, &trees, &scan);
}

/// CPU time of this thread so far [s] (`/proc/thread-self/schedstat`): criterion times the wall
/// clock, which on a shared machine measures the load as much as the step.
fn thread_cpu_s() -> f64 {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").unwrap_or_default();
    text.split_whitespace().next().and_then(|ns| ns.parse::<f64>().ok()).map_or(f64::NAN, |ns| ns * 1e-9)
}

/// Prints the crowd step's mean CPU time over 200 steady-state ticks (50 s of long-ICP
/// schedule: every neighbour's 5 s check comes round 4 times), beside criterion's wall times.
fn cpu_table(sc: swarm_config::Scenario, trees: &[(f64, f64, f64)], scan: &Scan) {
    const TICKS: u64 = 200;
    for n in [8usize, 16, 32, 64] {
        let poses = crowd(trees, n);
        let mut agent = Agent::new(UavId::new(1), sc.clone(), &Controllers::builtin()).expect("agent");
        for tick in 1..=WARM_UP_TICKS {
            crowd_step(&mut agent, trees, &poses, scan, tick);
        }
        let before = thread_cpu_s();
        for tick in WARM_UP_TICKS + 1..=WARM_UP_TICKS + TICKS {
            black_box(crowd_step(&mut agent, trees, &poses, scan, tick));
        }
        let ms = (thread_cpu_s() - before) * 1e3 / TICKS as f64;
        println!("agent/step_icp_crowd/{n} CPU: {ms:.3} ms per step ({:.1} us per neighbour)", 1e3 * ms / n as f64);
    }
}

criterion_group!(benches, bench_step, bench_icp_step, bench_icp_crowd);
criterion_main!(benches);

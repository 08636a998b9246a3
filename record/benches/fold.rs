//! The recorder's work per tick at 1000 UAVs, without the network: folding a tick (every agent's
//! state with about 18 neighbour estimates, as open-1000 sends them, then the tick's truth step,
//! which scores them: in a lockstep run the states of a tick come before its truth; then the
//! same past the first 200 ticks with the live recorder's settling of the estimate graph),
//! and writing a tick's `trajectories.csv` rows, with std's `{:.N}` and as the recorder writes them now
//! (`Fixed` of `record/src/recorder/fixed.rs`, the same text) side by side.

use criterion::{criterion_main, BatchSize, Criterion};
use std::hint::black_box;
use std::io::Write;
use swarm_record::recorder::metrics::Metrics;
use swarm_record::recorder::write_trajectory_rows;
use swarm_types::UavId;
use swarm_wire::{AgentState, NeighbourEstimate, Traffic, TruthBody, TruthStep, VectorMagnitudes};

const UAVS: u32 = 1000;
/// Neighbours each agent estimates (open-1000 hears about 18).
const NEIGHBOURS: u32 = 18;

/// UAVs on a lattice 3 m apart, moving slowly.
fn step(tick: u64) -> TruthStep {
    let side = (f64::from(UAVS)).sqrt().ceil() as u32;
    let bodies = (1..=UAVS)
        .map(|id| {
            let (i, j) = ((id - 1) % side, (id - 1) / side);
            let drift = tick as f64 * 0.01;
            TruthBody {
                id: UavId::new(id),
                x: f64::from(i) * 3.0 + drift,
                y: f64::from(j) * 3.0 - drift * 0.5,
                yaw: 0.1 * f64::from(id % 7),
                vx: 0.1 + 0.001 * f64::from(id % 13),
                vy: -0.05 + 0.0003 * f64::from(id % 11),
                alive: true,
                cmd_on_time: true,
                obstacle_distance_m: f64::INFINITY,
                agent_distance_m: 3.0 - 0.001 * f64::from(id % 5),
                colliding: false,
            }
        })
        .collect();
    TruthStep { tick, t_s: tick as f64 * 0.1, bodies, ..TruthStep::default() }
}

/// Every agent's state of `tick`: estimates of the next ids, a few centimetres off the truth.
fn states(s: &TruthStep) -> Vec<AgentState> {
    s.bodies
        .iter()
        .map(|me| {
            let neighbours = (1..=NEIGHBOURS)
                .map(|k| {
                    let other = &s.bodies[((me.id.get() - 1 + k) % UAVS) as usize];
                    let (dx, dy) = (other.x - me.x, other.y - me.y);
                    let (c, sn) = (me.yaw.cos(), me.yaw.sin());
                    NeighbourEstimate {
                        id: Some(other.id),
                        x: (c * dx + sn * dy) as f32 + 0.01 * (k % 3) as f32,
                        y: (-sn * dx + c * dy) as f32 - 0.02,
                        heading: 0.0,
                        age_s: 0.1 * (k % 2) as f32,
                    }
                })
                .collect();
            AgentState {
                id: me.id,
                tick: s.tick,
                t_s: s.t_s,
                step_time_us: 10,
                neighbours,
                in_radio_range: NEIGHBOURS,
                vectors: VectorMagnitudes {
                    cohesion: 0.01,
                    separation: 0.2,
                    avoidance: 0.0,
                    navigation: 0.7,
                    output: 1.0,
                },
                traffic: Traffic { session: "host-a".into(), ..Traffic::default() },
                ..AgentState::default()
            }
        })
        .collect()
}

/// Folds one tick as the recorder takes it: the tick's states, then its truth step, which scores
/// them.
fn fold_tick(m: &mut Metrics, s: &TruthStep, states: Vec<AgentState>) {
    states.into_iter().for_each(|st| m.on_state(st));
    m.on_step(s);
}

fn fold(c: &mut Criterion) {
    let mut g = c.benchmark_group("recorder");
    g.bench_function("fold_tick/1000", |b| {
        b.iter_batched(
            || {
                let mut m = Metrics::default();
                let first = step(0);
                fold_tick(&mut m, &first, states(&first));
                let next = step(1);
                let st = states(&next);
                (m, next, st)
            },
            |(mut m, next, st)| {
                fold_tick(&mut m, &next, st);
                black_box(m.take_scored().len())
            },
            BatchSize::PerIteration,
        );
    });
    // The live recorder's metrics settle each tick of the estimate graph once it is older than
    // every truth step they keep (200): past the first 200 ticks, every tick folded settles one.
    g.bench_function("fold_tick_settling/1000", |b| {
        let sc = swarm_config::builtin("open-1000").expect("builtin");
        let mut m = Metrics::settling(&sc);
        // The next tick's truth step and states, untimed.
        let mut tick = 0;
        let mut next_tick = || {
            let s = step(tick);
            tick += 1;
            let st = states(&s);
            (s, st)
        };
        for _ in 0..=200 {
            let (s, st) = next_tick();
            fold_tick(&mut m, &s, st);
            m.take_scored();
        }
        b.iter_batched(
            next_tick,
            |(s, st)| {
                fold_tick(&mut m, &s, st);
                black_box(m.take_scored().len())
            },
            BatchSize::PerIteration,
        );
    });
    g.finish();
}

/// A tick's trajectory rows as `Files::write_step` wrote them before `Fixed`.
fn rows_std(out: &mut Vec<u8>, s: &TruthStep) {
    for b in &s.bodies {
        writeln!(
            out,
            "{},{:.3},{},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{},{},{}",
            s.tick,
            s.t_s,
            b.id,
            b.x,
            b.y,
            b.yaw,
            b.vx,
            b.vy,
            b.obstacle_distance_m,
            b.agent_distance_m,
            u8::from(b.colliding),
            u8::from(b.alive),
            u8::from(b.cmd_on_time)
        )
        .expect("a vector takes every byte");
    }
}

/// The same rows as `Files::write_step` writes them now.
fn rows_fixed(out: &mut Vec<u8>, s: &TruthStep) {
    write_trajectory_rows(out, s).expect("a vector takes every byte");
}

fn rows(c: &mut Criterion) {
    let s = step(37);
    let (mut a, mut b) = (Vec::new(), Vec::new());
    rows_std(&mut a, &s);
    rows_fixed(&mut b, &s);
    assert_eq!(a, b, "the two ways write the same text");
    let mut g = c.benchmark_group("trajectory_rows");
    for (name, write) in [("std/1000", rows_std as fn(&mut Vec<u8>, &TruthStep)), ("fixed/1000", rows_fixed)] {
        g.bench_function(name, |bench| {
            let mut out = Vec::with_capacity(1 << 17);
            bench.iter(|| {
                out.clear();
                write(&mut out, &s);
                black_box(out.len())
            });
        });
    }
    g.finish();
}

/// The criterion group (in a private module: the macro's generated `pub fn` has no doc).
mod group {
    criterion::criterion_group!(benches, super::fold, super::rows);
}
criterion_main!(group::benches);

//! Hub tick benchmark: what the hub computes per tick for 40, 100 and 1000 UAVs, without the
//! network: every UAV's sensors (radio set, odometry, GNSS, 750-beam scan against the other UAVs)
//! then one integration step (radio links, contacts, ground truth with nearest distances).
//!
//! The swarm is open-1000's, scaled (`crowd`, shared with the `publish` bench): a start disc
//! holding the UAVs at least 3 m apart (about 18 m² each, so a UAV hears about 18 others within
//! the 10 m radio range), broadcast localization, every UAV flying 0.5 m/s forward. Each iteration is one tick of the running simulation, so the crowd
//! moves as the bench goes on. Throughput is the UAVs per tick, so criterion prints UAVs/s.
//!
//! `hub_step` times the integration step alone (radio links, contacts, ground truth): it runs on
//! the hub's thread after every command is in, while the agents wait, so it is the serial part
//! of a lockstep tick.
//!
//! Run: `cargo bench --workspace --bench tick -- --warm-up-time 1 --measurement-time 5`
//! (`--workspace`, so Zenoh is built with the features it has everywhere else).

use criterion::{black_box, criterion_main, BenchmarkId, Criterion, Throughput};
use physics_hub::sim::Sim;
use swarm_types::UavId;
use swarm_wire::{Cmd, CmdKind};

#[path = "common/crowd.rs"]
mod crowd;

/// open-1000's crowd scaled to `n` UAVs, every UAV commanded 0.5 m/s forward, all alive.
fn flying(n: usize, name: &str) -> (Sim, Vec<UavId>, Vec<Option<Cmd>>, Vec<bool>) {
    let sc = crowd::scenario(n, name);
    let forward = Some(Cmd { tick: 0, kind: CmdKind::Velocity, x: 0.5, y: 0.0, yaw_rate: 0.0 });
    (Sim::new(&sc), sc.uav_ids().collect(), vec![forward; n], vec![true; n])
}

fn bench_tick(c: &mut Criterion) {
    let mut group = c.benchmark_group("hub_tick");
    for n in [40usize, 100, 1000] {
        let (mut sim, ids, cmds, alive) = flying(n, "tick-bench");
        group.throughput(Throughput::Elements(n as u64));
        group.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
            b.iter(|| {
                let sensors = sim.sensors_all(black_box(&ids));
                black_box(&sensors);
                black_box(sim.step(&cmds, &alive, 0.0))
            })
        });
    }
    group.finish();
}

fn bench_step(c: &mut Criterion) {
    let mut group = c.benchmark_group("hub_step");
    for n in [100usize, 1000] {
        let (mut sim, _, cmds, alive) = flying(n, "step-bench");
        group.throughput(Throughput::Elements(n as u64));
        group.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
            b.iter(|| black_box(sim.step(&cmds, &alive, 0.0)))
        });
    }
    group.finish();
}

/// The criterion group (in a private module: the macro's generated `pub fn` has no doc).
mod group {
    criterion::criterion_group!(benches, super::bench_tick, super::bench_step);
}
criterion_main!(group::benches);

//! LIDAR scan benchmark: the hub's hottest path (every UAV, every tick).
//!
//! A forest of 5 trees per 100 m² (radii uniform 0.1–0.4 m) in a square of side
//! √(n / 0.05) m, built with a seeded ChaCha8 RNG; scans of 750 beams, 12 m range, from random
//! origins (cycled; origins closer than 0.3 m to a tree are redrawn, as a UAV body could not be
//! there). Throughput is 750 elements per scan, so criterion prints rays/s.
//!
//! Benches:
//! - `lidar/scan_750b_12m_{1000,100}trees`: [`physics_hub::lidar::scan`] with the default
//!   sensor noise (σ = 0.02 m, no dropout) — what the hub does;
//! - `lidar/scan_750b_12m_1000trees_noiseless`: the geometry alone (σ = 0), the same work as the
//!   pybullet baseline in `/work/shared/baselines`;
//! - `lidar/bvh_cast_ray_750b_12m_1000trees`: for comparison, 750 independent best-first BVH
//!   ray casts ([`physics_hub::world::World::cast_ray`]), the approach the scan avoids.
//!
//! Run: `cargo bench -p physics-hub --bench lidar -- --warm-up-time 1 --measurement-time 3`.

use criterion::{black_box, criterion_main, Criterion, Throughput};
use physics_hub::lidar::scan;
use physics_hub::world::World;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::TAU;

const BEAMS: u32 = 750;
const RANGE_M: f64 = 12.0;

/// A forest of `n` trees at 5 per 100 m², and 256 random sensor poses in it.
fn forest(n: usize, seed: u64) -> (World, Vec<[f64; 3]>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let side = (n as f64 / 0.05).sqrt();
    let trees = (0..n)
        .map(|_| swarm_config::Tree {
            x: rng.gen_range(0.0..side),
            y: rng.gen_range(0.0..side),
            r: rng.gen_range(0.1..0.4),
        })
        .collect();
    let world = World::new(trees, vec![]);
    let mut poses = Vec::with_capacity(256);
    while poses.len() < 256 {
        let p = [rng.gen_range(0.0..side), rng.gen_range(0.0..side), rng.gen_range(0.0..TAU)];
        if world.clearance([p[0], p[1]]) >= 0.3 {
            poses.push(p);
        }
    }
    (world, poses)
}

fn bench_scan(c: &mut Criterion) {
    let mut group = c.benchmark_group("lidar");
    group.throughput(Throughput::Elements(u64::from(BEAMS)));
    let noisy = swarm_config::Lidar { beams: BEAMS, max_range_m: RANGE_M, noise_std_m: 0.02, dropout: 0.0 };
    let clean = swarm_config::Lidar { noise_std_m: 0.0, ..noisy.clone() };

    for (n, spec, name) in [
        (1000, &noisy, "scan_750b_12m_1000trees"),
        (100, &noisy, "scan_750b_12m_100trees"),
        (1000, &clean, "scan_750b_12m_1000trees_noiseless"),
    ] {
        let (world, poses) = forest(n, 1);
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let mut out = Vec::with_capacity(BEAMS as usize);
        let mut k = 0usize;
        group.bench_function(name, |b| {
            b.iter(|| {
                let pose = poses[k % poses.len()];
                k += 1;
                scan(black_box(&world), black_box(pose), &[], spec, &mut rng, &mut out);
                black_box(&out);
            })
        });
    }

    let (world, poses) = forest(1000, 1);
    let mut k = 0usize;
    group.bench_function("bvh_cast_ray_750b_12m_1000trees", |b| {
        b.iter(|| {
            let pose = poses[k % poses.len()];
            k += 1;
            let mut hits = 0u32;
            for i in 0..BEAMS {
                let a = pose[2] + f64::from(i) * TAU / f64::from(BEAMS);
                if world.cast_ray([pose[0], pose[1]], [a.cos(), a.sin()], RANGE_M).is_some() {
                    hits += 1;
                }
            }
            black_box(hits)
        })
    });
    group.finish();
}

/// The criterion group (in a private module: the macro's generated `pub fn` has no doc).
mod group {
    criterion::criterion_group!(benches, super::bench_scan);
}
criterion_main!(group::benches);

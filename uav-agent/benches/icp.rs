#![allow(missing_docs)] // criterion macros generate undocumented items
//! ICP relative localization (seed 000 3.1, 3.3, 5.1) on the acceptance-test scenario: 20 trees
//! per side in 20 m × 20 m, the neighbour at a random pose within ±5 m, σ = 0.03 m, 30 % of each
//! side seen by one agent only.
//!
//! - `icp/initial_20pts`: one full-grid initial ICP (21×21 positions × 16 headings);
//! - `icp/short_20pts`: one short ICP from a nearby estimate (0.3 m, 5° off);
//! - `icp/fit_20pts`, `icp/fit_near_middle_20pts`: the localization budget's check from there,
//!   of the whole set (before) and of the eight points nearest the middle (now);
//! - `icp/initial_45pts`, `icp/short_45pts`: the same on a crowd's set (forest-40-icp,
//!   forest-100-icp: 40–50 obstacle centres per set), 34 shared + 11 one-sided per side;
//! - `icp/initial_12pts`, `icp/initial_16pts` (and their short ICPs): a sparse forest's sets
//!   (forest-5's own sets hold a median 11 obstacles where a full grid runs), 9 + 3 and 12 + 4,
//!   either side of where the full grid's first pass starts using its candidate table.

use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::{Point2, Rotation2, Vector2};
use std::hint::black_box;
use swarm_config::IcpParams;
use uav_agent::icp::{fit, fit_near_middle, icp, initial_icp, AgentFromNeighbour};

/// SplitMix64, so the bench needs no rand crate and is deterministic.
struct Rng(u64);
impl Rng {
    fn unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
    fn gauss(&mut self) -> f64 {
        let u1 = 1.0 - self.unit();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * self.unit()).cos()
    }
}

/// `n` tree centres ≥ 1.5 m apart (and from `avoid`) in the 20 m square around `c`.
fn scatter(rng: &mut Rng, n: usize, c: Vector2<f64>, avoid: &[Point2<f64>]) -> Vec<Point2<f64>> {
    let mut out: Vec<Point2<f64>> = Vec::new();
    while out.len() < n {
        let q = Point2::new(c.x + rng.range(-10.0, 10.0), c.y + rng.range(-10.0, 10.0));
        if out.iter().chain(avoid).all(|a| (a - q).norm() >= 1.5) {
            out.push(q);
        }
    }
    out
}

/// (reference, source, truth): `shared` trees both see + `own` one-sided per side, σ = 0.03 m.
fn scenario(seed: u64, shared: usize, own: usize) -> (Vec<Point2<f64>>, Vec<Point2<f64>>, AgentFromNeighbour) {
    let mut rng = Rng(seed);
    let reference = scatter(&mut rng, shared + own, Vector2::zeros(), &[]);
    let truth = AgentFromNeighbour {
        rotation_rad: rng.range(-std::f64::consts::PI, std::f64::consts::PI),
        translation_m: Vector2::new(rng.range(-5.0, 5.0), rng.range(-5.0, 5.0)),
    };
    let mut seen = reference[..shared].to_vec();
    seen.extend(scatter(&mut rng, own, truth.translation_m, &reference));
    let inv = Rotation2::new(-truth.rotation_rad);
    let source = seen
        .iter()
        .map(|q| {
            let p = inv * (q.coords - truth.translation_m);
            Point2::new(p.x + 0.03 * rng.gauss(), p.y + 0.03 * rng.gauss())
        })
        .collect();
    (reference, source, truth)
}

/// Benches the full-grid and a short ICP on `scenario(seed, shared, own)`, named by its size.
fn bench_case(c: &mut Criterion, seed: u64, shared: usize, own: usize) {
    let p = IcpParams::default();
    let (reference, source, truth) = scenario(seed, shared, own);
    let pts = shared + own;
    // Sanity: the benchmarked case is a successful one.
    let solved = initial_icp(&reference, &source, &p)
        .is_ok_and(|m| (m.agent_from_neighbour.translation_m - truth.translation_m).norm() < 0.1);
    assert!(solved, "the {pts}-point bench scenario must be solvable");
    c.bench_function(&format!("icp/initial_{pts}pts"), |b| {
        b.iter(|| initial_icp(black_box(&reference), black_box(&source), &p))
    });
    let start = AgentFromNeighbour {
        rotation_rad: truth.rotation_rad + 5f64.to_radians(),
        translation_m: truth.translation_m + Vector2::new(0.3, -0.2),
    };
    c.bench_function(&format!("icp/short_{pts}pts"), |b| {
        b.iter(|| icp(black_box(&reference), black_box(&source), start, &p))
    });
    c.bench_function(&format!("icp/fit_{pts}pts"), |b| {
        b.iter(|| fit(black_box(&reference), black_box(&source), start, &p))
    });
    c.bench_function(&format!("icp/fit_near_middle_{pts}pts"), |b| {
        b.iter(|| fit_near_middle(black_box(&reference), black_box(&source), start, &p))
    });
}

fn bench_icp(c: &mut Criterion) {
    bench_case(c, 5, 9, 3);
    bench_case(c, 3, 12, 4);
    bench_case(c, 7, 14, 6);
    // A crowd's set (forest-40-icp, forest-100-icp): 40–50 obstacle centres, most of them shared.
    bench_case(c, 11, 34, 11);
}

criterion_group!(benches, bench_icp);
criterion_main!(benches);

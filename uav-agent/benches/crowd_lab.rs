#![allow(missing_docs)] // a bench binary
//! A crowd lab for ICP localization, without the hub: `n` agents (the real [`Agent`], perception,
//! ICP database and K21) on forest-40's start disc, drifting at 0.3 m/s into a forest, each tick
//! scanned analytically (trees and the other UAVs' bodies, 2 cm noise), sharing with every UAV
//! within the radio range, and scored against the truth the way the recorder scores (estimate of
//! neighbour j vs j's true position in i's body frame at the state's tick; > 1 m is false).
//!
//! Why: a 40-UAV run on the full stack takes tens of minutes on a loaded 2-core machine, and it
//! mixes localization with the controller's crowd behaviour; this isolates localization, repeats
//! exactly, and prints the numbers the issue judges (mean and p95 error, false share, estimates
//! per agent, step CPU time) in minutes. `cargo bench -p uav-agent --bench crowd_lab -- [N] [TICKS]
//! [PLACEMENT_HEADINGS] [RECHECK_HEADINGS] [BUDGET]` (default 40 UAVs, 300 ticks = 30 s, every
//! heading in a placement and a re-check, no localization budget).

use swarm_types::UavId;
use swarm_wire::{Odom, Scan};
use uav_agent::{Agent, Controllers, SensorFrame, Share};

/// A small deterministic PRNG (an LCG) for the forest, the start disc and the range noise.
struct Lcg(u64);
impl Lcg {
    fn unit(&mut self) -> f64 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Standard normal (Box–Muller).
    fn gauss(&mut self) -> f64 {
        let u1 = 1.0 - self.unit();
        let u2 = self.unit();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}

/// forest-40's forest: 5 trees per 100 m² in x ∈ [9, 43], y ∈ [−15, 15], ≥ 2.5 m apart, trunk
/// radius 0.15–0.35 m (our own draw, not the hub's).
fn forest(rng: &mut Lcg) -> Vec<(f64, f64, f64)> {
    let count = (34.0 * 30.0 * 5.0 / 100.0) as usize;
    let mut trees: Vec<(f64, f64, f64)> = Vec::new();
    let mut tries = 0;
    while trees.len() < count && tries < 100_000 {
        tries += 1;
        let (x, y, r) = (9.0 + 34.0 * rng.unit(), -15.0 + 30.0 * rng.unit(), 0.15 + 0.2 * rng.unit());
        if trees.iter().all(|t| (t.0 - x).hypot(t.1 - y) >= 2.5) {
            trees.push((x, y, r));
        }
    }
    trees
}

/// `n` start positions in the disc around the origin of radius 7 m for 40 UAVs (forest-40's
/// density; its area grows with `n`), ≥ 1.6 m apart, and a yaw each.
fn starts(rng: &mut Lcg, n: usize) -> Vec<(f64, f64, f64)> {
    let r = 7.0 * (n.max(40) as f64 / 40.0).sqrt();
    let mut out: Vec<(f64, f64, f64)> = Vec::new();
    while out.len() < n {
        let (x, y) = (2.0 * r * rng.unit() - r, 2.0 * r * rng.unit() - r);
        if x.hypot(y) <= r && out.iter().all(|p| (p.0 - x).hypot(p.1 - y) >= 1.6) {
            out.push((x, y, 0.5 * (2.0 * rng.unit() - 1.0)));
        }
    }
    out
}

/// The scan of UAV `me` at `pose` among `circles` (x, y, r), with range noise.
fn scan(
    circles: &[(f64, f64, f64)],
    pose: (f64, f64, f64),
    me: usize,
    n_trees: usize,
    rng: &mut Lcg,
    tick: u64,
) -> Scan {
    const BEAMS: usize = 750;
    const RANGE_M: f64 = 12.0;
    let inc = std::f32::consts::TAU / BEAMS as f32;
    let near: Vec<(f64, f64, f64)> = circles
        .iter()
        .enumerate()
        .filter(|&(k, c)| k != n_trees + me && (c.0 - pose.0).hypot(c.1 - pose.1) < RANGE_M + 1.0)
        .map(|(_, &c)| (c.0 - pose.0, c.1 - pose.1, c.2))
        .collect();
    let ranges_m = (0..BEAMS)
        .map(|i| {
            let a = pose.2 + f64::from(i as f32 * inc);
            let (dx, dy) = (a.cos(), a.sin());
            let d = near
                .iter()
                .filter_map(|&(cx, cy, r)| {
                    let b = dx * cx + dy * cy;
                    let disc = b * b - (cx * cx + cy * cy - r * r);
                    (disc >= 0.0 && b > 0.0).then(|| b - disc.sqrt())
                })
                .fold(f64::INFINITY, f64::min);
            if d <= RANGE_M {
                (d + 0.02 * rng.gauss()) as f32
            } else {
                f32::INFINITY
            }
        })
        .collect();
    Scan { tick, t_s: tick as f64 * 0.1, angle_min: 0.0, angle_increment: inc, max_range_m: RANGE_M as f32, ranges_m }
}

/// CPU time of this thread so far [s] (`/proc/thread-self/schedstat`, nanoseconds on CPU), so the
/// step cost is measured apart from the machine's load.
fn thread_cpu_s() -> f64 {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").unwrap_or_default();
    text.split_whitespace().next().and_then(|ns| ns.parse::<f64>().ok()).map_or(f64::NAN, |ns| ns * 1e-9)
}

/// Where `j` is in `i`'s body frame.
fn relative(i: (f64, f64, f64), j: (f64, f64, f64)) -> (f64, f64) {
    let (dx, dy) = (j.0 - i.0, j.1 - i.1);
    let (s, c) = i.2.sin_cos();
    (c * dx + s * dy, -s * dx + c * dy)
}

fn main() {
    let args: Vec<usize> = std::env::args().skip(1).filter_map(|a| a.parse().ok()).collect();
    let n = args.first().copied().unwrap_or(40);
    let ticks = args.get(1).copied().unwrap_or(300) as u64;
    let mut sc = swarm_config::builtin("forest-40-icp").expect("builtin");
    // Optional third to fifth numbers: `crowd_placement_headings`, `crowd_recheck_headings` and
    // `budget_per_step` (docs/performance.md, "Placements at the expected heading", "Re-checks at
    // the swarm's heading", "The localization budget"); 0 when left out.
    let setting = |i: usize| args.get(i).map_or(0, |&h| u32::try_from(h).unwrap_or(u32::MAX));
    sc.localization.icp.crowd_placement_headings = setting(2);
    sc.localization.icp.crowd_recheck_headings = setting(3);
    sc.localization.icp.budget_per_step = setting(4);
    let radio_m = sc.radio.range_m;
    let mut rng = Lcg(0x5eed_0040);
    let trees = forest(&mut rng);
    let mut poses = starts(&mut rng, n);
    let mut agents: Vec<Agent> =
        (0..n).map(|i| Agent::new(UavId::from_index(i), sc.clone(), &Controllers::builtin()).expect("agent")).collect();
    let mut errors: Vec<f64> = Vec::new();
    let (mut step_s, mut steps, mut estimates) = (0.0, 0u64, 0u64);
    // Full-grid ICPs (placements and re-checks) and short ICPs, over all agents.
    let (mut full_grids, mut shorts) = (0u64, 0u64);
    let mut false_by_second: Vec<u64> = vec![0; ticks as usize / 10 + 1];
    let mut shares: Vec<Option<Share>> = vec![None; n];
    for tick in 1..=ticks {
        let circles: Vec<(f64, f64, f64)> =
            trees.iter().copied().chain(poses.iter().map(|p| (p.0, p.1, sc.body.radius_m))).collect();
        let mut next: Vec<Option<Share>> = vec![None; n];
        let t = tick as f64 * 0.1;
        let frames: Vec<SensorFrame> = poses
            .iter()
            .enumerate()
            .map(|(i, &p)| {
                let scan = scan(&circles, p, i, trees.len(), &mut rng, tick);
                let odom = Odom {
                    tick,
                    t_s: t,
                    x: p.0,
                    y: p.1,
                    yaw: p.2,
                    vx: 0.3,
                    vy: 0.0,
                    goal: Some([45.0, 0.0]),
                    goal_vel: None,
                };
                SensorFrame { scan, odom, gnss: None, uvdar: None }
            })
            .collect();
        let cpu_before = thread_cpu_s();
        let mut outs = Vec::with_capacity(n);
        for (i, frame) in frames.iter().enumerate() {
            for (j, s) in shares.iter().enumerate() {
                let in_range = (poses[j].0 - poses[i].0).hypot(poses[j].1 - poses[i].1) <= radio_m;
                if let Some(s) = s.as_ref().filter(|_| j != i && in_range) {
                    agents[i].on_share(s);
                }
            }
            outs.push(agents[i].step(frame));
        }
        step_s += thread_cpu_s() - cpu_before;
        steps += n as u64;
        for (i, out) in outs.into_iter().enumerate() {
            let p = poses[i];
            full_grids += u64::from(out.report.icp.long + out.report.icp.initial);
            shorts += u64::from(out.report.icp.short);
            for e in &out.report.neighbours {
                let Some(j) = e.id.map(UavId::index) else { continue };
                let (x, y) = relative(p, poses[j]);
                let err = (f64::from(e.x) - x).hypot(f64::from(e.y) - y);
                if err > 1.0 {
                    false_by_second[tick as usize / 10] += 1;
                }
                errors.push(err);
                estimates += 1;
            }
            next[i] = out.share;
        }
        shares = next;
        // Drift: 0.3 m/s along +x, each UAV turning slowly.
        for (k, p) in poses.iter_mut().enumerate() {
            p.0 += 0.03;
            p.2 += 0.01 * ((tick as f64 * 0.05) + k as f64).sin();
        }
    }
    errors.sort_by(f64::total_cmp);
    let mean = errors.iter().sum::<f64>() / errors.len().max(1) as f64;
    let p95 = errors.get(errors.len() * 95 / 100).copied().unwrap_or(f64::NAN);
    let falses = errors.iter().filter(|&&e| e > 1.0).count();
    println!(
        "crowd_lab n={n} ticks={ticks}: estimates {estimates} ({:.1} per agent-step), mean err {mean:.3} m, p95 {p95:.3} m, false {:.2} % ({falses}), agent step {:.3} ms CPU mean (sharing and stepping)",
        estimates as f64 / steps as f64,
        100.0 * falses as f64 / errors.len().max(1) as f64,
        1e3 * step_s / steps as f64
    );
    println!(
        "full-grid ICPs {:.3} and short ICPs {:.2} per agent-step",
        full_grids as f64 / steps as f64,
        shorts as f64 / steps as f64
    );
    println!("false estimates per second of flight: {false_by_second:?}");
}

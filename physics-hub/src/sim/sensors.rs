//! Sensors out: each UAV's sensor frame of a tick (radio set, odometry in its start frame, GNSS
//! fix with the broadcast error, UVDAR, scan), and the pipeline that computes a large swarm's on
//! worker threads. A module of its own so that the threads, chunks and channel stay apart from the
//! pure step in [`super`].
//!
//! The sensors of a large swarm are computed on every core, in chunks handed over in the order
//! asked as they are done, so the hub publishes the first chunks while the next are computed
//! ([`Sim::sensors_each`]). Each UAV draws only from its own seeded streams and the results are
//! taken in the order asked, so nothing depends on the number of threads or on that order.

use super::Sim;
use crate::body::wrap_angle;
use crate::forest::{rng, stream};
use crate::lidar;
use nalgebra::{Rotation2, Vector2};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use swarm_config::{LocalizationMode, Scenario};
use swarm_types::UavId;
use swarm_wire::{Gnss, Odom, RadioSet, Scan, SenseFrame, Uvdar, UvdarSeen};

/// The seeded random streams of one UAV's sensors.
pub(super) struct UavRngs {
    lidar: ChaCha8Rng,
    gnss: ChaCha8Rng,
    uvdar: ChaCha8Rng,
}

impl UavRngs {
    /// UAV `id`'s streams in a run of seed `seed`.
    pub(super) fn of(seed: u64, id: UavId) -> UavRngs {
        UavRngs {
            lidar: rng(seed, stream::LIDAR + u64::from(id.get())),
            gnss: rng(seed, stream::GNSS_ERROR + u64::from(id.get())),
            uvdar: rng(seed, stream::UVDAR + u64::from(id.get())),
        }
    }
}

/// Below this many UAVs the sensors of a tick are computed on the calling thread: spawning
/// workers costs more than it saves.
const PARALLEL_FROM_UAVS: usize = 32;

/// UAVs per chunk of a pipelined tick ([`Sim::sensors_each`]): small enough that publication
/// starts after a few milliseconds, large enough that a chunk's hand-over costs nothing next to
/// its scans.
const CHUNK_UAVS: usize = 25;

/// A chunk of a pipelined tick: its number, and its UAVs with their streams.
type Chunk<'s, 'r> = (usize, &'s mut [(UavId, &'r mut UavRngs)]);

impl Sim {
    /// The sensor frame of UAV `id` (1-based) for the current tick.
    #[cfg(test)]
    pub fn sensors(&mut self, id: UavId) -> SenseFrame {
        self.sensors_all(&[id]).pop().expect("one UAV asked, one answer")
    }

    /// The sensor frames of the UAVs `ids` (1-based, each at most once) for the current tick, in
    /// the order given. Large swarms are spread over the cores (see [`Sim::sensors_each`]); each
    /// UAV draws only from its own streams, so the result does not depend on the split.
    pub fn sensors_all(&mut self, ids: &[UavId]) -> Vec<SenseFrame> {
        let workers = std::thread::available_parallelism().map_or(1, |n| n.get());
        self.sensors_all_on(ids, workers)
    }

    /// [`Sim::sensors_all`] on `workers` threads at most (below 2: all on the calling thread, as
    /// `swarm floor` computes them, to measure a tick's work on one core).
    pub fn sensors_all_on(&mut self, ids: &[UavId], workers: usize) -> Vec<SenseFrame> {
        let mut out = Vec::with_capacity(ids.len());
        let done: Result<(), std::convert::Infallible> = self.sensors_each_on(
            ids,
            workers,
            |_, s| s,
            |_, s| {
                out.push(s);
                Ok(())
            },
        );
        match done {
            Ok(()) => out,
            Err(never) => match never {},
        }
    }

    /// The sensor frames of the UAVs `ids` (1-based, each at most once) for the current tick,
    /// each turned into a `T` by `prepare` on the thread that computed it (the hub encodes them
    /// there), then handed to `sink` on the calling thread, one UAV at a time in the order of
    /// `ids`. From [`PARALLEL_FROM_UAVS`] UAVs on, worker threads (one per core) compute chunks
    /// of [`CHUNK_UAVS`] while the calling thread sinks the chunks already done, so the sink's
    /// work (the hub's publication) overlaps the computation instead of waiting for all of it,
    /// and the first agents get their sensors early. Each UAV draws only from its own streams
    /// and the sink sees the order of `ids` whatever the threads do, so nothing depends on the
    /// split. The first error of `sink` stops the sinking and is returned (the workers finish
    /// their chunks).
    pub fn sensors_each<T: Send, E>(
        &mut self,
        ids: &[UavId],
        prepare: impl Fn(UavId, SenseFrame) -> T + Sync,
        sink: impl FnMut(UavId, T) -> Result<(), E>,
    ) -> Result<(), E> {
        let workers = std::thread::available_parallelism().map_or(1, |n| n.get());
        self.sensors_each_on(ids, workers, prepare, sink)
    }

    /// [`Sim::sensors_each`] with `workers` worker threads at most (below 2: none, one UAV after
    /// the other on the calling thread); the tests pick it so the pipeline runs on any machine.
    fn sensors_each_on<T: Send, E>(
        &mut self,
        ids: &[UavId],
        workers: usize,
        prepare: impl Fn(UavId, SenseFrame) -> T + Sync,
        mut sink: impl FnMut(UavId, T) -> Result<(), E>,
    ) -> Result<(), E> {
        let mut rngs = std::mem::take(&mut self.rngs);
        let mut jobs: Vec<(UavId, &mut UavRngs)> = Vec::with_capacity(ids.len());
        {
            let mut by_index: Vec<Option<&mut UavRngs>> = rngs.iter_mut().map(Some).collect();
            for &id in ids {
                if let Some(r) = id.try_index().and_then(|i| by_index.get_mut(i)).and_then(Option::take) {
                    jobs.push((id, r));
                }
            }
        }
        let this = &*self;
        let result = if jobs.len() < PARALLEL_FROM_UAVS || workers < 2 {
            jobs.into_iter().try_for_each(|(id, r)| sink(id, prepare(id, this.sensors_of(id, r))))
        } else {
            this.sensors_pipelined(&mut jobs, workers, &prepare, &mut sink)
        };
        self.rngs = rngs;
        result
    }

    /// [`Sim::sensors_each`] on `workers` threads: worker w computes chunks w, w + workers, …
    /// in that order and sends each whole; the calling thread sinks them in chunk order, holding
    /// any that arrive early.
    fn sensors_pipelined<T: Send, E>(
        &self,
        jobs: &mut [(UavId, &mut UavRngs)],
        workers: usize,
        prepare: &(impl Fn(UavId, SenseFrame) -> T + Sync),
        sink: &mut impl FnMut(UavId, T) -> Result<(), E>,
    ) -> Result<(), E> {
        let mut per_worker: Vec<Vec<Chunk<'_, '_>>> = (0..workers).map(|_| Vec::new()).collect();
        let chunks = jobs.len().div_ceil(CHUNK_UAVS);
        for (k, part) in jobs.chunks_mut(CHUNK_UAVS).enumerate() {
            per_worker[k % workers].push((k, part));
        }
        std::thread::scope(|scope| {
            let (tx, rx) = std::sync::mpsc::channel::<(usize, Vec<(UavId, T)>)>();
            for mine in per_worker {
                let tx = tx.clone();
                scope.spawn(move || {
                    for (k, part) in mine {
                        let done =
                            part.iter_mut().map(|(id, r)| (*id, prepare(*id, self.sensors_of(*id, r)))).collect();
                        if tx.send((k, done)).is_err() {
                            return;
                        }
                    }
                });
            }
            drop(tx);
            let mut early = std::collections::BTreeMap::new();
            let mut result = Ok(());
            for next in 0..chunks {
                let done = loop {
                    if let Some(d) = early.remove(&next) {
                        break d;
                    }
                    // A worker that panicked drops its sender; the scope re-raises the panic.
                    let Ok((k, d)) = rx.recv() else { return result };
                    early.insert(k, d);
                };
                if result.is_ok() {
                    result = done.into_iter().try_for_each(|(id, t)| sink(id, t));
                }
            }
            result
        })
    }

    /// The sensor frame of UAV `id`, drawing from its streams `r`.
    fn sensors_of(&self, id: UavId, r: &mut UavRngs) -> SenseFrame {
        let i = id.index();
        let (tick, t_s) = (self.tick, self.t_s());
        let b = self.bodies[i];
        let scan = self.scan(i, tick, t_s, &mut r.lidar);
        let s = self.starts[i];
        let start_from_world = Rotation2::new(-s.yaw);
        let to_start = |p: Vector2<f64>| start_from_world * (p - Vector2::new(s.x, s.y));
        let p = to_start(b.pos);
        let v = start_from_world * b.vel;
        let (goal, goal_vel) = if self.sc.is_informed(id) {
            let (g, gv) = self.sc.goal_motion_of(id, t_s);
            let g = to_start(Vector2::new(g[0], g[1]));
            let gv = start_from_world * Vector2::new(gv[0], gv[1]);
            (Some([g.x, g.y]), (gv.norm() > 0.0).then_some([gv.x, gv.y]))
        } else {
            (None, None)
        };
        let odom = Odom { tick, t_s, x: p.x, y: p.y, yaw: wrap_angle(b.yaw - s.yaw), vx: v.x, vy: v.y, goal, goal_vel };
        let gnss = (self.sc.localization.mode == LocalizationMode::Broadcast).then(|| {
            let [ex, ey] = gnss_error(&self.sc, id, t_s, &mut r.gnss);
            Gnss { tick, t_s, x: b.pos.x + ex, y: b.pos.y + ey, yaw: b.yaw, vx: b.vel.x, vy: b.vel.y }
        });
        let in_range = self.radio.in_range(i).into_iter().map(UavId::from_index).collect();
        let loss = self.radio.losses(i);
        let uvdar =
            (self.sc.localization.mode == LocalizationMode::Uvdar).then(|| self.uvdar(i, tick, t_s, &mut r.uvdar));
        SenseFrame { radio: RadioSet { tick, id, in_range, loss }, odom, gnss, uvdar, scan }
    }

    /// UAV index `i`'s LIDAR scan: the world and the other UAVs the beams can reach (found in the
    /// grid; a beam keeps its nearest hit whatever order the discs come in, so the scan equals
    /// one against every other UAV).
    fn scan(&self, i: usize, tick: u64, t_s: f64, rng: &mut ChaCha8Rng) -> Scan {
        let b = self.bodies[i];
        let r_uav = self.sc.body.radius_m;
        let mut others: Vec<[f64; 3]> = Vec::new();
        self.grid.for_each_near([b.pos.x, b.pos.y], self.sc.lidar.max_range_m + r_uav.max(0.0), |j| {
            if j != i {
                others.push([self.bodies[j].pos.x, self.bodies[j].pos.y, r_uav]);
            }
        });
        let mut ranges = Vec::with_capacity(self.sc.lidar.beams as usize);
        lidar::scan(&self.world, [b.pos.x, b.pos.y, b.yaw], &others, &self.sc.lidar, rng, &mut ranges);
        let (angle_min, angle_increment) = lidar::beam_angles(&self.sc.lidar);
        Scan { tick, t_s, angle_min, angle_increment, max_range_m: self.sc.lidar.max_range_m as f32, ranges_m: ranges }
    }

    /// What UAV index `i` sees of the others by UVDAR (seed 003) now.
    fn uvdar(&self, i: usize, tick: u64, t_s: f64, rng: &mut ChaCha8Rng) -> Uvdar {
        let poses: Vec<(UavId, [f64; 2], f64)> =
            self.bodies.iter().enumerate().map(|(j, b)| (UavId::from_index(j), [b.pos.x, b.pos.y], b.yaw)).collect();
        let seen = crate::uvdar::observe(&self.world, i, &poses, &self.sc.localization.uvdar, rng)
            .into_iter()
            .map(|o| UvdarSeen { id: o.id, range_m: o.range_m as f32, bearing_rad: o.bearing_rad as f32 })
            .collect();
        Uvdar { tick, t_s, seen }
    }
}

/// The artificial error of UAV `id`'s GNSS-like fix at `t` (seed 001 eq. 45–46): zero, or while
/// the scenario's `broadcast_error` is active for it, a vector of uniform direction whose length
/// is uniform in [0, δa], fresh every tick, drawn from the UAV's stream `r`.
fn gnss_error(sc: &Scenario, id: UavId, t: f64, r: &mut ChaCha8Rng) -> [f64; 2] {
    let Some(e) = sc.localization.broadcast_error.as_ref().filter(|e| e.active(id, t)) else {
        return [0.0, 0.0];
    };
    // seed 001 eq. 46: f(|δa|) = 1/δa on [0, δa]; the direction is uniform.
    let len = e.delta_a_m * r.gen::<f64>();
    let dir = std::f64::consts::TAU * r.gen::<f64>();
    [len * dir.cos(), len * dir.sin()]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::tests::{scenario, vel};

    /// A crowd large enough for the pipelined path (100 UAVs, chunks of [`CHUNK_UAVS`]).
    fn crowd() -> Scenario {
        Scenario::from_toml_str(
            r#"
name = "crowd"
seed = 7
[world]
trees = [{ x = 5.0, y = 0.0, r = 0.5 }, { x = -4.0, y = 6.0, r = 0.4 }]
[swarm]
count = 100
start_area = { center = [0.0, 0.0], radius_m = 24.0, min_spacing_m = 3.0 }
goal = [60.0, 0.0]
informed = "all"
[localization]
mode = "broadcast"
[end]
time_limit_s = 100.0
"#,
            "crowd.toml",
        )
        .expect("valid")
    }

    #[test]
    fn pipelined_sensors_equal_one_uav_at_a_time_in_the_order_asked() {
        let sc = crowd();
        let mut ids: Vec<UavId> = sc.uav_ids().collect();
        ids.reverse();
        ids.retain(|&id| id != UavId::new(50));
        assert!(ids.len() >= PARALLEL_FROM_UAVS, "large enough for the workers");
        let (mut pipelined, mut alone) = (Sim::new(&sc), Sim::new(&sc));
        for _ in 0..3 {
            let mut order = Vec::new();
            // Three workers whatever this machine has, so the pipeline itself is what is tested.
            let got = pipelined.sensors_each_on(
                &ids,
                3,
                |id, s| (id, format!("{s:?}")),
                |id, (prepared_for, text)| {
                    order.push(id);
                    assert_eq!(prepared_for, id, "prepared and sunk for the same UAV");
                    assert_eq!(text, format!("{:?}", alone.sensors(id)), "UAV {id}");
                    Ok::<(), ()>(())
                },
            );
            assert_eq!(got, Ok(()));
            assert_eq!(order, ids, "sunk in the order asked, UAV 50 left out");
            let cmds = vec![vel(0.4); 100];
            pipelined.step(&cmds, &[true; 100], 0.0);
            alone.step(&cmds, &[true; 100], 0.0);
        }
    }

    #[test]
    fn the_first_sink_error_stops_the_sinking() {
        let sc = crowd();
        let ids: Vec<UavId> = sc.uav_ids().collect();
        let mut sim = Sim::new(&sc);
        let mut sunk = 0;
        let got = sim.sensors_each_on(
            &ids,
            3,
            |_, s| s.scan.ranges_m.len(),
            |id, _| {
                sunk += 1;
                if id == UavId::new(40) {
                    Err(id)
                } else {
                    Ok(())
                }
            },
        );
        assert_eq!(got, Err(UavId::new(40)));
        assert_eq!(sunk, 40, "nothing after the error");
        assert_eq!(sim.sensors_all(&ids).len(), 100, "the streams are back for the next tick");
    }

    #[test]
    fn odometry_is_in_the_start_frame_and_goal_only_for_informed() {
        let mut sim = Sim::new(&scenario());
        let s1 = sim.sensors(UavId::new(1));
        // Start heading 90°: the world goal (10, 0) is 10 m to the right, i.e. at (0, -10).
        let g = s1.odom.goal.expect("UAV 1 is informed");
        assert!(g[0].abs() < 1e-9 && (g[1] + 10.0).abs() < 1e-9, "{g:?}");
        assert_eq!(sim.sensors(UavId::new(2)).odom.goal, None, "UAV 2 is not informed");
        assert_eq!(s1.radio.in_range, vec![UavId::new(2)]);
        // Fly body-forward (world +y) for a while: odometry x grows, y stays.
        for _ in 0..5 {
            sim.step(&[vel(0.2), vel(0.0)], &[true, true], 0.0);
        }
        let o = sim.sensors(UavId::new(1)).odom;
        assert!(o.x > 0.0 && o.y.abs() < 1e-9 && o.yaw.abs() < 1e-12, "{o:?}");
    }

    #[test]
    fn the_broadcast_error_is_uniform_in_length_up_to_delta_a_and_only_where_asked() {
        let mut sc = scenario();
        sc.localization.mode = LocalizationMode::Broadcast;
        sc.localization.broadcast_error = Some(swarm_config::BroadcastError {
            delta_a_m: 2.0,
            uavs: swarm_config::UavSet::Ids(vec![UavId::new(1)]),
            from_s: 1.0,
            until_s: Some(3.0),
        });
        let mut r = rng(sc.seed, stream::GNSS_ERROR + 1);
        let n = 20_000;
        let lengths: Vec<f64> =
            (0..n).map(|_| gnss_error(&sc, UavId::new(1), 2.0, &mut r)).map(|[x, y]| x.hypot(y)).collect();
        // seed 001 eq. 46: |δa| uniform on [0, 2]: mean 1, variance 4/12.
        let mean = lengths.iter().sum::<f64>() / f64::from(n);
        let var = lengths.iter().map(|l| (l - mean).powi(2)).sum::<f64>() / f64::from(n);
        assert!(lengths.iter().all(|&l| l <= 2.0));
        assert!((mean - 1.0).abs() < 0.02, "{mean}");
        assert!((var - 1.0 / 3.0).abs() < 0.02, "{var}");
        assert_eq!(gnss_error(&sc, UavId::new(2), 2.0, &mut r), [0.0, 0.0], "UAV 2 is not affected");
        assert_eq!(gnss_error(&sc, UavId::new(1), 0.5, &mut r), [0.0, 0.0], "before the window");
        assert_eq!(gnss_error(&sc, UavId::new(1), 3.0, &mut r), [0.0, 0.0], "after the window");
    }
}

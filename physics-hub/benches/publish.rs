//! The hub's sensor publication over real Zenoh: one tick of every UAV's sensors, put by a router
//! session as the hub puts them (`Writer::put_now`) and received by a client session holding a
//! subscription to each UAV's own keys, as an agent host does. Two layouts of the same payloads:
//! one message per sensor (the radio set on `radio/{id}`, odometry, GNSS and scan on
//! `uav/{id}/sense/{odom,gnss,scan}`: four keys in broadcast mode, the layout before
//! `Msg::Sense`) and one sensor frame per UAV on `uav/{id}/sense`. Each iteration is one tick:
//! it ends when the client has received the tick's last message. Throughput is UAVs per tick.
//!
//! The payloads are open-1000's crowd (`crowd`, shared with the `tick` bench), computed and
//! encoded once before the timing, so only the wire is measured: the puts, the router, the TCP
//! loopback and the subscriber's callbacks.
//!
//! Run: `cargo bench --workspace --bench publish -- --warm-up-time 1 --measurement-time 5`

use criterion::{criterion_main, BenchmarkId, Criterion, Throughput};
use physics_hub::sim::Sim;
use std::sync::mpsc;
use swarm_types::UavId;
use swarm_wire::plumbing::Subscription;
use swarm_wire::session::{self, Role, Writer};
use swarm_wire::{Msg, SenseFrame};
use tokio::runtime::Runtime;
use zenoh::qos::CongestionControl;

#[path = "common/crowd.rs"]
mod crowd;

/// How a UAV's sensors go on the wire: keys and encoded payloads, in put order.
type Layout = fn(prefix: &str, id: UavId, f: &SenseFrame) -> Vec<(String, Vec<u8>)>;

fn per_sensor(prefix: &str, id: UavId, f: &SenseFrame) -> Vec<(String, Vec<u8>)> {
    let g = f.gnss.expect("broadcast mode has a fix");
    [
        ("radio", Msg::Radio(f.radio.clone())),
        ("odom", Msg::Odom(f.odom)),
        ("gnss", Msg::Gnss(g)),
        ("scan", Msg::Scan(f.scan.clone())),
    ]
    .into_iter()
    .map(|(k, m)| {
        let key = if k == "radio" { format!("{prefix}/radio/{id}") } else { format!("{prefix}/uav/{id}/sense/{k}") };
        (key, m.encode().expect("encodes"))
    })
    .collect()
}

fn one_frame(prefix: &str, id: UavId, f: &SenseFrame) -> Vec<(String, Vec<u8>)> {
    vec![(format!("{prefix}/uav/{id}/sense"), Msg::Sense(Box::new(f.clone())).encode().expect("encodes"))]
}

/// A router and a client connected to it over loopback TCP.
struct Wire {
    rt: Runtime,
    hub: zenoh::Session,
    host: zenoh::Session,
}

impl Wire {
    fn new() -> Wire {
        let rt = tokio::runtime::Builder::new_multi_thread().worker_threads(2).enable_all().build().expect("runtime");
        let (hub, host) = rt.block_on(async {
            let hub = session::open(Role::Router, &["tcp/127.0.0.1:0".into()], &[], &[]).await.expect("router");
            let at = session::locators(&hub).await;
            let host = session::open(Role::Client, &[], &at, &[]).await.expect("client");
            (hub, host)
        });
        Wire { rt, hub, host }
    }

    /// The hub's writers and the host's subscriptions for `puts` (key, payload), with the
    /// channel the subscriptions signal each arrival on.
    fn declare(&self, puts: &[(String, Vec<u8>)]) -> (Vec<Writer>, Vec<Subscription>, mpsc::Receiver<()>) {
        let (tx, rx) = mpsc::channel();
        self.rt.block_on(async {
            let mut writers = Vec::with_capacity(puts.len());
            let mut subs = Vec::with_capacity(puts.len());
            for (key, _) in puts {
                let tx = tx.clone();
                let declared = self.host.declare_keyexpr(key.clone()).await.expect("key");
                let sub = self.host.declare_subscriber(declared).callback(move |_| {
                    let _ = tx.send(());
                });
                subs.push(sub.await.expect("subscriber"));
                writers.push(Writer::new(&self.hub, key.clone(), CongestionControl::Block).await.expect("writer"));
            }
            // Let the router learn every subscription before the first put.
            tokio::time::sleep(std::time::Duration::from_millis(500)).await;
            (writers, subs, rx)
        })
    }
}

fn bench_publish(c: &mut Criterion) {
    let wire = Wire::new();
    let mut group = c.benchmark_group("publish");
    for n in [100usize, 1000] {
        let sc = crowd::scenario(n, "publish-bench");
        let ids: Vec<UavId> = sc.uav_ids().collect();
        let frames = Sim::new(&sc).sensors_all(&ids);
        group.throughput(Throughput::Elements(n as u64));
        for (name, layout) in [("per_sensor", per_sensor as Layout), ("one_frame", one_frame as Layout)] {
            let prefix = format!("swarm/bench-{name}-{n}");
            let puts: Vec<(String, Vec<u8>)> =
                ids.iter().zip(&frames).flat_map(|(&id, f)| layout(&prefix, id, f)).collect();
            let (writers, _subs, rx) = wire.declare(&puts);
            group.bench_with_input(BenchmarkId::new(name, n), &n, |b, _| {
                b.iter(|| {
                    for (w, (_, bytes)) in writers.iter().zip(&puts) {
                        w.put_now(bytes.clone()).expect("put");
                    }
                    for _ in 0..puts.len() {
                        rx.recv().expect("every message arrives");
                    }
                })
            });
        }
    }
    group.finish();
}

/// The criterion group (in a private module: the macro's generated `pub fn` has no doc).
mod group {
    criterion::criterion_group!(benches, super::bench_publish);
}
criterion_main!(group::benches);

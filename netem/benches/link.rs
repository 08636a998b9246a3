#![allow(missing_docs)]
//! Cost per message of the netem layer: the seam must be free when no impairment is active
//! (target: under 2 µs of added CPU per message).
//!
//! Benches (one message per iteration, so the time per iteration is ns per message):
//! - `netem/identity_per_message`: [`netem::impair::LinkSim::decide`] under the identity rule,
//!   the fast path (no draw, no allocation);
//! - `netem/lossy_delay_per_message`: the same under 30 % random loss and 100 ± 50 ms normal
//!   jitter (one or two ChaCha8 draws and an inverse-normal evaluation per message);
//! - `netem/existing_link_on_receive`: what every share pays today, [`netem::Link::on_receive`]
//!   then an [`netem::Inbox`] push and the `take_due` of the next tick.
//!
//! Run: `cargo bench -p netem --bench link -- --warm-up-time 1 --measurement-time 3`.

use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use netem::impair::{Decision, Impairment, JitterDistribution, LinkSim, LossModel};
use netem::{Inbox, Link, Verdict};
use swarm_types::UavId;

const BYTES: usize = 120; // message size; only the rate limiter reads it

/// What a caller does with a decision: reads its instants. (Handing the whole enum to
/// `black_box` makes the compiler copy it byte by byte, ~10 ns that no real caller pays.)
#[inline(always)]
fn consume(d: Decision) -> f64 {
    black_box(match d {
        Decision::Lost(_) | Decision::Held => -1.0,
        Decision::Deliver(a) => a,
        Decision::Duplicate(a, b) => a + b,
    })
}

fn per_message(c: &mut Criterion) {
    let mut g = c.benchmark_group("netem");
    g.throughput(Throughput::Elements(1));

    let identity = Impairment::IDENTITY;
    let mut link = LinkSim::new(1, UavId::new(1), UavId::new(2));
    let mut now = 0.0;
    g.bench_function("identity_per_message", |b| {
        b.iter(|| {
            now += 0.1;
            consume(link.decide(black_box(&identity), now, black_box(BYTES)))
        })
    });

    let lossy = Impairment {
        delay_s: 0.1,
        jitter_s: 0.05,
        distribution: JitterDistribution::Normal,
        loss: LossModel::Random { p: 0.3 },
        ..Impairment::IDENTITY
    };
    let mut link = LinkSim::new(1, UavId::new(1), UavId::new(2));
    let mut now = 0.0;
    g.bench_function("lossy_delay_per_message", |b| {
        b.iter(|| {
            now += 0.1;
            consume(link.decide(black_box(&lossy), now, black_box(BYTES)))
        })
    });

    let dt = 0.1;
    let mut link = Link::new();
    let mut inbox: Inbox<u64> = Inbox::new();
    let mut tick = 0u64;
    // What an agent does per message with no rule in force: the link's decision and accounting
    // (class counts, the applied delay), the inbox, and taking the delays for the state message.
    g.bench_function("agent_link_no_rule_per_message", |b| {
        b.iter(|| {
            let now = tick as f64 * dt;
            if let Verdict::DeliverAt(at) =
                link.on_receive_with(None, 0.0, black_box(UavId::new(2)), now, now, dt, black_box(BYTES))
            {
                inbox.push(at, tick);
            }
            tick += 1;
            let due = inbox.take_due(tick as f64 * dt);
            link.on_delivered(due.len());
            black_box(link.take_delays());
            black_box(due)
        })
    });
    g.finish();
}

criterion_group!(benches, per_message);
criterion_main!(benches);

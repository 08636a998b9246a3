//! Property tests of [`Msg::decode`] over bad input: every payload a node takes off the wire goes
//! through it, on every key an outsider can reach (commands, shares, sensor keys, `netem/add`), so
//! whatever bytes arrive it must return a value or an error, never panic.
//!
//! Inputs, per property: arbitrary bytes; each variant's tag followed by arbitrary bytes (so the
//! decoder enters every variant's fields); valid encodings (the golden value of every variant and
//! arbitrary structured values) with bytes flipped, overwritten, cut short, spliced or extended.
//! Each property prints how many inputs it tried (`cargo test --release -p swarm-wire fuzz --
//! --nocapture`); `PROPTEST_CASES=N` sets the count (default [`DEFAULT_CASES`]).

use crate::msg::tests::golden;
use crate::*;
use proptest::prelude::*;
use proptest::test_runner::{Config, TestCaseError, TestRunner};
use std::sync::atomic::{AtomicU64, Ordering};

/// Inputs per property when `PROPTEST_CASES` is not set: decoding takes microseconds.
const DEFAULT_CASES: u32 = 4096;

/// Runs `check` on `cases` inputs drawn from `strategy`, fails the test on the first failure or
/// panic (after shrinking), and prints the number of inputs tried.
fn fuzz<S: Strategy>(name: &str, strategy: S, check: impl Fn(S::Value) -> Result<(), TestCaseError>) -> u64 {
    let cases = std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(DEFAULT_CASES);
    let mut runner = TestRunner::new(Config { cases, failure_persistence: None, ..Config::default() });
    let tried = AtomicU64::new(0);
    let result = runner.run(&strategy, |v| {
        tried.fetch_add(1, Ordering::Relaxed);
        check(v)
    });
    if let Err(e) = result {
        panic!("fuzz {name}: {e}");
    }
    let n = tried.load(Ordering::Relaxed);
    println!("fuzz {name}: {n} inputs, no panic");
    n
}

/// A decode error must be one of the malformed-payload variants and carry the payload's length.
fn is_decode_error(r: &Result<Msg, WireError>, len: usize) -> bool {
    matches!(r, Err(WireError::Decode { len: l, .. } | WireError::Trailing { len: l, .. }) if *l == len)
}

/// One edit of a byte string.
#[derive(Debug, Clone)]
enum Edit {
    /// XOR the byte at (index mod len) with a non-zero mask.
    Flip(usize, u8),
    /// Overwrite the byte at (index mod len).
    Set(usize, u8),
    /// Keep the first (n mod len) bytes.
    Truncate(usize),
    /// Insert bytes at (index mod (len + 1)).
    Splice(usize, Vec<u8>),
    /// Append bytes.
    Extend(Vec<u8>),
}

fn edit() -> impl Strategy<Value = Edit> {
    let bytes = || prop::collection::vec(any::<u8>(), 1..32);
    prop_oneof![
        (any::<usize>(), 1u8..=255).prop_map(|(i, m)| Edit::Flip(i, m)),
        (any::<usize>(), any::<u8>()).prop_map(|(i, b)| Edit::Set(i, b)),
        any::<usize>().prop_map(Edit::Truncate),
        (any::<usize>(), bytes()).prop_map(|(i, b)| Edit::Splice(i, b)),
        bytes().prop_map(Edit::Extend),
    ]
}

fn apply(mut bytes: Vec<u8>, edits: &[Edit]) -> Vec<u8> {
    for e in edits {
        let len = bytes.len();
        match e {
            Edit::Flip(i, m) if len > 0 => bytes[i % len] ^= m,
            Edit::Set(i, b) if len > 0 => bytes[i % len] = *b,
            Edit::Truncate(n) if len > 0 => bytes.truncate(n % len),
            Edit::Splice(i, b) => {
                let at = i % (len + 1);
                bytes.splice(at..at, b.iter().copied());
            }
            Edit::Extend(b) => bytes.extend_from_slice(b),
            _ => {}
        }
    }
    bytes
}

/// Arbitrary finite or not f32 / f64 (NaN, infinities and subnormals included).
fn f32s() -> impl Strategy<Value = f32> {
    any::<u32>().prop_map(f32::from_bits)
}
fn f64s() -> impl Strategy<Value = f64> {
    any::<u64>().prop_map(f64::from_bits)
}

/// Arbitrary structured values of the variants an outsider is most likely to forge (the ones
/// agents and the hub consume), and of the sensor variants.
fn structured() -> impl Strategy<Value = Msg> {
    let kind = prop_oneof![Just(CmdKind::Velocity), Just(CmdKind::Acceleration), Just(CmdKind::Hover)];
    prop_oneof![
        (any::<u64>(), f64s(), f64s()).prop_map(|(tick, t_s, dt_s)| Msg::Clock(Clock { tick, t_s, dt_s })),
        (any::<u64>(), kind, f32s(), f32s(), f32s()).prop_map(|(tick, kind, x, y, yaw_rate)| Msg::Cmd(Cmd {
            tick,
            kind,
            x,
            y,
            yaw_rate
        })),
        (any::<u32>(), any::<u64>(), prop::array::uniform6(f64s())).prop_map(|(from, tick, v)| Msg::Pose(PoseShare {
            from: UavId::new(from),
            tick,
            t_s: v[0],
            x: v[1],
            y: v[2],
            yaw: v[3],
            vx: v[4],
            vy: v[5],
            hops: (tick % 256) as u8,
            arrival: (tick / 256 % 256) as u8,
        })),
        (any::<u32>(), any::<u64>(), f64s(), prop::collection::vec(any::<[i16; 2]>(), 0..40), any::<[u8; 2]>())
            .prop_map(|(from, tick, t_s, centres_cm, [hops, arrival])| {
                Msg::Obstacles(ObstacleShare { from: UavId::new(from), tick, t_s, centres_cm, hops, arrival })
            }),
        radio_sets().prop_map(Msg::Radio),
        scans().prop_map(Msg::Scan),
        uvdars().prop_map(Msg::Uvdar),
        (radio_sets(), odoms(), prop::option::of(gnss_fixes()), prop::option::of(uvdars()), scans()).prop_map(
            |(radio, odom, gnss, uvdar, scan)| Msg::Sense(Box::new(SenseFrame { radio, odom, gnss, uvdar, scan }))
        ),
        ".{0,200}".prop_map(Msg::NetemRules),
    ]
}

fn radio_sets() -> impl Strategy<Value = RadioSet> {
    (any::<u64>(), any::<u32>(), prop::collection::vec(any::<u32>(), 0..20), prop::collection::vec(f32s(), 0..20))
        .prop_map(|(tick, id, in_range, loss)| RadioSet {
            tick,
            id: UavId::new(id),
            in_range: in_range.into_iter().map(UavId::new).collect(),
            loss,
        })
}

fn scans() -> impl Strategy<Value = Scan> {
    (any::<u64>(), prop::array::uniform4(f32s()), prop::collection::vec(f32s(), 0..100)).prop_map(|(tick, a, r)| Scan {
        tick,
        t_s: f64::from(a[0]),
        angle_min: a[1],
        angle_increment: a[2],
        max_range_m: a[3],
        ranges_m: r,
    })
}

fn uvdars() -> impl Strategy<Value = Uvdar> {
    (any::<u64>(), f64s(), prop::collection::vec((any::<u32>(), f32s(), f32s()), 0..10)).prop_map(|(tick, t_s, s)| {
        Uvdar {
            tick,
            t_s,
            seen: s
                .into_iter()
                .map(|(id, range_m, bearing_rad)| UvdarSeen { id: UavId::new(id), range_m, bearing_rad })
                .collect(),
        }
    })
}

fn odoms() -> impl Strategy<Value = Odom> {
    (any::<u64>(), prop::array::uniform6(f64s()), prop::option::of(any::<[i32; 2]>()), prop::option::of(f64s()))
        .prop_map(|(tick, v, goal, goal_vx)| Odom {
            tick,
            t_s: v[0],
            x: v[1],
            y: v[2],
            yaw: v[3],
            vx: v[4],
            vy: v[5],
            goal: goal.map(|g| g.map(f64::from)),
            goal_vel: goal_vx.map(|vx| [vx, 0.0]),
        })
}

fn gnss_fixes() -> impl Strategy<Value = Gnss> {
    (any::<u64>(), prop::array::uniform6(f64s())).prop_map(|(tick, v)| Gnss {
        tick,
        t_s: v[0],
        x: v[1],
        y: v[2],
        yaw: v[3],
        vx: v[4],
        vy: v[5],
    })
}

/// Equality that holds for NaN fields: the same bytes on the wire.
fn same_bytes(a: &Msg, b: &Msg) -> bool {
    a.encode().ok() == b.encode().ok()
}

#[test]
fn arbitrary_bytes_never_panic() {
    let n = fuzz("decode(arbitrary bytes)", prop::collection::vec(any::<u8>(), 0..512), |bytes| {
        let r = Msg::decode(&bytes);
        prop_assert!(r.is_ok() || is_decode_error(&r, bytes.len()), "{r:?}");
        Ok(())
    });
    assert!(n > 0);
}

/// Each variant's tag with an arbitrary body: what decodes is that variant, the rest is an error.
#[test]
fn every_variant_with_an_arbitrary_body() {
    let variants = golden().len() as u8;
    let strategy = (0..variants, prop::collection::vec(any::<u8>(), 0..300));
    fuzz("decode(variant tag + arbitrary body)", strategy, |(tag, body)| {
        let bytes: Vec<u8> = std::iter::once(tag).chain(body).collect();
        match Msg::decode(&bytes) {
            Ok(m) => {
                let want = golden()[usize::from(tag)].0.kind();
                prop_assert_eq!(m.kind(), want, "tag {} decoded as another variant", tag);
            }
            r => prop_assert!(is_decode_error(&r, bytes.len()), "{r:?}"),
        }
        Ok(())
    });
}

/// Golden values of every variant, edited: never a panic; a cut-short encoding is always an error.
#[test]
fn mutated_golden_encodings() {
    let count = golden().len();
    let strategy = (0..count, prop::collection::vec(edit(), 1..5));
    fuzz("decode(golden value of every variant, mutated)", strategy, |(i, edits)| {
        let valid = golden()[i].0.encode().expect("encodes");
        let bytes = apply(valid.clone(), &edits);
        let r = Msg::decode(&bytes);
        prop_assert!(r.is_ok() || is_decode_error(&r, bytes.len()), "{r:?}");
        if bytes.len() < valid.len() && valid.starts_with(&bytes) {
            prop_assert!(r.is_err(), "a strict prefix of a valid encoding decoded: {r:?}");
        }
        if let Ok(m) = r {
            prop_assert!(m.encode().is_ok(), "what decodes encodes again");
        }
        Ok(())
    });
}

/// A valid encoding with bytes after its end is malformed (no silent trailing garbage).
#[test]
fn trailing_bytes_are_malformed() {
    let count = golden().len();
    let strategy = (0..count, prop::collection::vec(any::<u8>(), 1..64));
    fuzz("decode(golden value + trailing bytes)", strategy, |(i, tail)| {
        let mut bytes = golden()[i].0.encode().expect("encodes");
        bytes.extend_from_slice(&tail);
        let r = Msg::decode(&bytes);
        prop_assert!(is_decode_error(&r, bytes.len()), "{r:?}");
        Ok(())
    });
}

/// Arbitrary structured values (NaN and infinities included) round-trip, and edited they never
/// make the decoder panic.
#[test]
fn structured_values_round_trip_and_survive_mutation() {
    fuzz("decode(arbitrary structured value)", structured(), |m| {
        let bytes = m.encode().expect("encodes");
        let back = Msg::decode(&bytes).expect("decodes");
        prop_assert!(same_bytes(&m, &back), "{m:?} came back as {back:?}");
        Ok(())
    });
    fuzz(
        "decode(arbitrary structured value, mutated)",
        (structured(), prop::collection::vec(edit(), 1..5)),
        |(m, edits)| {
            let bytes = apply(m.encode().expect("encodes"), &edits);
            let r = Msg::decode(&bytes);
            prop_assert!(r.is_ok() || is_decode_error(&r, bytes.len()), "{r:?}");
            Ok(())
        },
    );
}

//! How every process opens its Zenoh session (see `../shared/ZENOH.md` section 1).
//!
//! The hub is a router and everyone else a client of it: routing is deterministic, and the hub is
//! the one place where access control can be enforced. Multicast scouting is off in every
//! process (it is what makes parallel test runs cross-talk), and so is gossip autoconnect, so
//! traffic cannot route around the hub.
//!
//! Zenoh's QoS priorities stay on (its default): each link has a queue per priority, and its
//! sender always takes the highest-priority pending batch first, so a declaration (control
//! priority) leaves before any data put after it was queued. The lockstep protocol leans on that
//! with one tick to spare (`uav_agent` admission, ARCHITECTURE "Who receives which shares"). Not
//! one queue for all (QoS off): Zenoh 1.10 then never clears a congested link's flag for data
//! that may be dropped, and a realtime run's sensors stop reaching a link for good after its
//! first congestion (1000 UAVs in realtime: 5 280 commands of 150 000 arrived).
//!
//! Each link's data queue holds [`DATA_QUEUE_BATCHES`] batches, not Zenoh's 2, and a put that
//! may be dropped waits up to [`WAIT_BEFORE_DROP_US`] for room, not 1 ms. The hub puts every
//! UAV's sensor frame at once each tick: 25 agents' frames are about 85 kB for a host's link,
//! more than two 64 kB batches, and with Zenoh's defaults a realtime host lost the frames of its
//! last agents: at 100 UAVs over four hosts, those of 6 and 7 agents on 2 of 300 ticks with the
//! machine 12 % busy; at 200, 4 % of all frames (those agents then did not step, and their
//! neighbours missed their shares: issue 46, `swarm mesh --sizes`). Batches are
//! allocated when needed (Zenoh's lazy allocation), so an idle link costs nothing more.

use crate::WireError;
use zenoh::bytes::Encoding;
use zenoh::qos::{CongestionControl, Priority};

/// Role of a process in the run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// The physics hub: a Zenoh router.
    Router,
    /// Agents, recorder, tools: Zenoh clients of the hub.
    Client,
}

/// Batches in each link's data queue (Zenoh's maximum; its default is 2): room for a tick's
/// burst of sensor frames to a host of hundreds of agents.
pub const DATA_QUEUE_BATCHES: usize = 16;

/// How long a put that may be dropped (`CongestionControl::Drop`, realtime) waits for room in a
/// full queue before it is dropped [µs]: a fifth of a 10 Hz tick, long enough for a link to drain
/// a burst, short enough that the frame is still worth having (Zenoh's default: 1 ms).
pub const WAIT_BEFORE_DROP_US: u64 = 20_000;

/// Builds the Zenoh config of a process. `extra` are `KEY:JSON5` overrides (`--cfg`), applied last.
pub fn config(role: Role, listen: &[String], connect: &[String], extra: &[String]) -> Result<zenoh::Config, WireError> {
    let mut c = zenoh::Config::default();
    let set = |c: &mut zenoh::Config, k: &str, v: &str| {
        c.insert_json5(k, v).map_err(|e| WireError::zenoh(format!("{k}: {e}")))
    };
    let mode = match role {
        Role::Router => "\"router\"",
        Role::Client => "\"client\"",
    };
    set(&mut c, "mode", mode)?;
    set(&mut c, "scouting/multicast/enabled", "false")?;
    set(&mut c, "scouting/gossip/enabled", "false")?;
    set(&mut c, "scouting/delay", "0")?;
    set(&mut c, "transport/link/tx/queue/size/data", &DATA_QUEUE_BATCHES.to_string())?;
    set(&mut c, "transport/link/tx/queue/congestion_control/drop/wait_before_drop", &WAIT_BEFORE_DROP_US.to_string())?;
    let json = |v: &[String]| serde_json::to_string(v).map_err(|e| WireError::zenoh(e.to_string()));
    set(&mut c, "listen/endpoints", &json(listen)?)?;
    set(&mut c, "connect/endpoints", &json(connect)?)?;
    if role == Role::Router {
        // Zenoh's admin space, read-only: who subscribes to what, on every router (`swarm keys`);
        // the hub's access control lets only observers query it.
        set(&mut c, "adminspace", "{enabled: true, permissions: {read: true, write: false}}")?;
    }
    if role == Role::Client {
        // Wait for a hub that is not up yet, retrying, rather than failing at once.
        set(&mut c, "connect/timeout_ms", "30000")?;
        set(&mut c, "connect/retry", "{period_init_ms: 100, period_max_ms: 1000, period_increase_factor: 2}")?;
    }
    for kv in extra {
        let (k, v) =
            kv.split_once(':').ok_or_else(|| WireError::zenoh(format!("--cfg {kv:?}: expected KEY:JSON5_VALUE")))?;
        set(&mut c, k, v)?;
    }
    Ok(c)
}

/// Opens a session with [`config`].
pub async fn open(
    role: Role,
    listen: &[String],
    connect: &[String],
    extra: &[String],
) -> Result<zenoh::Session, WireError> {
    let c = config(role, listen, connect, extra)?;
    zenoh::open(c).await.map_err(WireError::zenoh)
}

/// The congestion control of the data a run's pieces publish in time mode `mode`: block in
/// lockstep (every message counts, and the barrier waits for it), drop in real time (a late
/// message is worth less than the next one).
pub fn congestion(mode: swarm_types::TimeMode) -> CongestionControl {
    if mode.blocks() {
        CongestionControl::Block
    } else {
        CongestionControl::Drop
    }
}

/// The Zenoh encoding of every payload: octet stream with our schema name.
pub fn encoding() -> Encoding {
    Encoding::APPLICATION_OCTET_STREAM.with_schema(crate::msg::SCHEMA)
}

/// The locators a router session listens on (with the real port when it was asked for port 0).
pub async fn locators(session: &zenoh::Session) -> Vec<String> {
    session.info().locators().await.iter().map(|l| l.to_string()).collect()
}

/// Writes our payloads on one key: what a Zenoh publisher does, without declaring one.
///
/// Why not a publisher: a declared publisher sends its router an interest in the subscribers of
/// its key (Zenoh's writer-side filtering), and a router matches every subscriber declared
/// anywhere against every such interest of every session. With the hub's five sensor publishers
/// per UAV and the agents' three, that was 79 % of the hub's CPU (`perf`, `Resource::matches`
/// under `propagate_subscriber`) while 1000 agents in 100 processes declared the share
/// subscriptions of their first radio sets, long enough to expire some sessions' leases. The
/// puts take the same path as a publisher's (`Session::put` and `Publisher::put` both end in
/// Zenoh's `resolve_put`).
///
/// What a publisher's interest also did, and a writer must still do: carry the key's declaration
/// to the router. A client session declares a key expression to itself only; its puts reach the
/// router with the key spelled out unless the router knows the key under an id, and the router
/// caches its access-control decision and route only for keys it knows under an id (without
/// them, deciding each agent host's puts against its per-UAV rules took more of the hub's time
/// than the simulation). So a writer also declares a querier on its key: a querier's interest is
/// in queryables, which are declared a few times per run, so no subscriber is ever matched
/// against it, and Zenoh forwards it to the router with the key's declaration. It never queries.
///
/// Every writer of a run uses one priority, so a session's data leaves in the order it was put
/// (the lockstep protocol relies on that); `cc` chooses back-pressure (`Block`) or dropping
/// (`Drop`) under congestion.
#[derive(Debug)]
pub struct Writer {
    session: zenoh::Session,
    key: zenoh::key_expr::KeyExpr<'static>,
    cc: CongestionControl,
    /// Declares the key to the router (see above); dropping it undeclares the interest.
    _declares_key: zenoh::query::Querier<'static>,
}

impl Writer {
    /// A writer on `key` (a key, or a key expression already declared on `s`).
    pub async fn new<K>(s: &zenoh::Session, key: K, cc: CongestionControl) -> Result<Writer, WireError>
    where
        K: TryInto<zenoh::key_expr::KeyExpr<'static>> + Send,
        K::Error: Into<zenoh::Error>,
    {
        let key = s.declare_keyexpr(key).await.map_err(WireError::zenoh)?;
        let declares_key = s.declare_querier(key.clone()).await.map_err(WireError::zenoh)?;
        Ok(Writer { session: s.clone(), key, cc, _declares_key: declares_key })
    }

    /// The key written on.
    pub fn key(&self) -> &str {
        self.key.as_str()
    }

    fn builder(&self, bytes: Vec<u8>) -> zenoh::session::SessionPutBuilder<'_, 'static> {
        self.session
            .put(self.key.clone(), bytes)
            .encoding(encoding())
            .congestion_control(self.cc)
            .priority(Priority::Data)
    }

    /// Puts `bytes`.
    pub async fn put(&self, bytes: Vec<u8>) -> Result<(), WireError> {
        self.builder(bytes).await.map_err(WireError::zenoh)
    }

    /// Puts `bytes`, blocking the calling thread (inside `block_in_place` or off the runtime).
    pub fn put_now(&self, bytes: Vec<u8>) -> Result<(), WireError> {
        use zenoh::Wait;
        self.builder(bytes).wait().map_err(WireError::zenoh)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_link_has_room_for_a_ticks_burst_of_frames() {
        for role in [Role::Router, Role::Client] {
            let c = config(role, &[], &[], &[]).expect("config");
            let get = |k: &str| c.get_json(k).expect(k);
            assert_eq!(get("transport/link/tx/queue/size/data"), DATA_QUEUE_BATCHES.to_string());
            assert_eq!(
                get("transport/link/tx/queue/congestion_control/drop/wait_before_drop"),
                WAIT_BEFORE_DROP_US.to_string()
            );
            assert_eq!(get("transport/link/tx/queue/allocation/mode"), "\"lazy\"", "batches only when needed");
        }
        let c = config(Role::Client, &[], &[], &["transport/link/tx/queue/size/data:4".into()]).expect("config");
        assert_eq!(c.get_json("transport/link/tx/queue/size/data").expect("set"), "4", "--cfg still overrides");
    }
}

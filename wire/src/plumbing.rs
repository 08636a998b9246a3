//! The Zenoh plumbing every process of a run needs, written once: subscribe a key into a
//! channel, watch liveliness tokens, fetch a reply (the scenario text) from a queryable.
//! Writers are made by [`crate::session::Writer`]; a tool that puts one message uses
//! [`put_once`] with the same encoding and priority.
//!
//! Why channels and callbacks: a callback runs in Zenoh's delivery order, and an unbounded
//! channel never pushes back on the session, so a process reads its messages in wire order at
//! its own pace (the lockstep protocol relies on that order). A receiver that went away is not an
//! error: the process is shutting down.

use crate::{Keys, WireError};
use std::time::Duration;
use tokio::sync::{mpsc, watch};
use zenoh::qos::{CongestionControl, Priority};
use zenoh::sample::{Sample, SampleKind};

/// A declared subscription (data or liveliness): it delivers until dropped.
pub type Subscription = zenoh::pubsub::Subscriber<()>;

/// How long one query waits for replies in [`fetch`].
const QUERY_TIMEOUT: Duration = Duration::from_secs(2);
/// The pause before [`fetch`] asks again after a round without a reply.
const RETRY_PAUSE: Duration = Duration::from_millis(200);

/// The payload of a sample, copied out.
pub fn payload(sample: &Sample) -> Vec<u8> {
    sample.payload().to_bytes().into_owned()
}

/// The message a sample carries, decoded from its payload in place (borrowed when the payload is
/// contiguous, as one message is: no copy).
pub fn decode(sample: &Sample) -> Result<crate::Msg, WireError> {
    crate::Msg::decode(&sample.payload().to_bytes())
}

/// Subscribes to `key` (a key, or a key expression declared on `s`) and sends `map(sample)`
/// into `tx` for every sample; `None` sends nothing (the mapping may count or log what it drops).
pub async fn subscribe<T: Send + 'static, K>(
    s: &zenoh::Session,
    key: K,
    tx: mpsc::UnboundedSender<T>,
    map: impl Fn(&Sample) -> Option<T> + Send + Sync + 'static,
) -> Result<Subscription, WireError>
where
    K: TryInto<zenoh::key_expr::KeyExpr<'static>> + Send,
    K::Error: Into<zenoh::Error>,
{
    s.declare_subscriber(key)
        .callback(move |sample| {
            if let Some(m) = map(&sample) {
                let _ = tx.send(m);
            }
        })
        .await
        .map_err(WireError::zenoh)
}

/// The sensor frames a sample carries: one on `uav/{id}/sense` (a [`Msg::Sense`](crate::Msg)),
/// each of an agent host's UAVs on `host/{ids}/sense` (a `Msg::Senses`; a frame for a UAV the
/// key does not name is left out). Nothing for a malformed payload or another key.
pub fn sense_frames(keys: &Keys, sample: &Sample) -> Vec<(swarm_types::UavId, Box<crate::SenseFrame>)> {
    split(
        keys,
        sample.key_expr().as_str(),
        || decode(sample).ok(),
        |m| match m {
            crate::Msg::Sense(f) => Some(vec![(None, f)]),
            crate::Msg::Senses(frames) => Some(frames.into_iter().map(|u| (Some(u.id), Box::new(u.frame))).collect()),
            _ => None,
        },
    )
}

/// The agent states a sample carries: one on `uav/{id}/state` (a [`Msg::State`](crate::Msg),
/// named by its key), each of an agent host's UAVs on `host/{ids}/state` (a `Msg::States`; a
/// state for a UAV the key does not name is left out). Nothing for a malformed payload or
/// another key.
pub fn agent_states(keys: &Keys, sample: &Sample) -> Vec<(swarm_types::UavId, Box<crate::AgentState>)> {
    states_of(keys, sample.key_expr().as_str(), || decode(sample).ok())
}

/// [`agent_states`] of a message `msg` on `key`.
fn states_of(
    keys: &Keys,
    key: &str,
    msg: impl FnOnce() -> Option<crate::Msg>,
) -> Vec<(swarm_types::UavId, Box<crate::AgentState>)> {
    split(keys, key, msg, |m| match m {
        crate::Msg::State(st) => Some(vec![(None, st)]),
        crate::Msg::States(states) => Some(states.into_iter().map(|st| (Some(st.id), Box::new(st))).collect()),
        _ => None,
    })
}

/// Whom a sample's key lets it speak for: one UAV (`uav/{id}/…`) or an agent host's UAVs
/// (`host/{ids}/…`). The access rules hold a login to its own UAVs' keys, so a reader that
/// takes a message's parts only for the UAVs its key names takes from each login only its own.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Speaker {
    /// A UAV's key: a message of one UAV, which its key names.
    Uav(swarm_types::UavId),
    /// An agent host's key: the parts of a host's message, for these UAVs (ascending).
    Host(Vec<swarm_types::UavId>),
}

impl Speaker {
    /// Whom `key` speaks for; `None` for a key of neither a UAV nor an agent host of this run.
    pub fn of(keys: &Keys, key: &str) -> Option<Speaker> {
        match keys.uav_id_of(key) {
            Some(id) => Some(Speaker::Uav(id)),
            None => keys.host_ids_of(key).map(Speaker::Host),
        }
    }

    /// The UAV a part of a message on this key is then: `part` is the UAV the part names
    /// (`None`: a message of one UAV, named by its key). A message of one UAV counts only on a
    /// UAV's key, a host's parts only on a host's key and only for the UAVs the key names.
    pub fn names(&self, part: Option<swarm_types::UavId>) -> Option<swarm_types::UavId> {
        match (self, part) {
            (Speaker::Uav(id), None) => Some(*id),
            (Speaker::Host(ids), Some(id)) => ids.binary_search(&id).is_ok().then_some(id),
            _ => None,
        }
    }
}

/// The UAVs' parts of the message `msg` (decoded only when `key` is one of a UAV or an agent
/// host of this run): `parts` takes it to its parts, each with the UAV it names (`None`: a
/// message of one UAV, named by its key), kept where [`Speaker::names`] says so.
fn split<U>(
    keys: &Keys,
    key: &str,
    msg: impl FnOnce() -> Option<crate::Msg>,
    parts: impl FnOnce(crate::Msg) -> Option<Vec<(Option<swarm_types::UavId>, Box<U>)>>,
) -> Vec<(swarm_types::UavId, Box<U>)> {
    let Some(speaker) = Speaker::of(keys, key) else { return Vec::new() };
    let Some(parts) = msg().and_then(parts) else { return Vec::new() };
    parts.into_iter().filter_map(|(id, part)| Some((speaker.names(id)?, part))).collect()
}

/// Subscribes to every UAV's sensor frames, sent alone (`uav/*/sense`) or to an agent host
/// (`host/*/sense`), and sends `map(id, frame, sample)` into `tx` for each frame, in the order
/// of the frames on the wire: what an observer of the sensors (the recorder's scene, the ROS 2
/// bridge) subscribes to, however the agents are spread over processes.
pub async fn subscribe_frames<T: Send + 'static>(
    s: &zenoh::Session,
    keys: &Keys,
    tx: mpsc::UnboundedSender<T>,
    map: impl Fn(swarm_types::UavId, Box<crate::SenseFrame>, &Sample) -> Option<T> + Clone + Send + Sync + 'static,
) -> Result<[Subscription; 2], WireError> {
    subscribe_split(s, keys, [keys.sense_any(), keys.host_sense_any()], sense_frames, tx, map).await
}

/// Subscribes to every UAV's state, sent alone (`uav/*/state`) or by an agent host
/// (`host/*/state`), and sends `map(id, state, sample)` into `tx` for each, in wire order.
pub async fn subscribe_states<T: Send + 'static>(
    s: &zenoh::Session,
    keys: &Keys,
    tx: mpsc::UnboundedSender<T>,
    map: impl Fn(swarm_types::UavId, Box<crate::AgentState>, &Sample) -> Option<T> + Clone + Send + Sync + 'static,
) -> Result<[Subscription; 2], WireError> {
    subscribe_split(s, keys, [keys.state_any(), keys.host_state_any()], agent_states, tx, map).await
}

/// Subscribes to the two wildcards `keys_any` (a UAV's key and an agent host's), splits each
/// sample into its UAVs' parts with `split`, and sends `map(id, part, sample)` into `tx`.
async fn subscribe_split<U: 'static, T: Send + 'static>(
    s: &zenoh::Session,
    keys: &Keys,
    keys_any: [String; 2],
    split: fn(&Keys, &Sample) -> Vec<(swarm_types::UavId, U)>,
    tx: mpsc::UnboundedSender<T>,
    map: impl Fn(swarm_types::UavId, U, &Sample) -> Option<T> + Clone + Send + Sync + 'static,
) -> Result<[Subscription; 2], WireError> {
    let [alone, host] = keys_any;
    let each = |key: String| {
        let (k, tx, map) = (keys.clone(), tx.clone(), map.clone());
        s.declare_subscriber(key).callback(move |sample| {
            for (id, part) in split(&k, &sample) {
                if let Some(m) = map(id, part, &sample) {
                    let _ = tx.send(m);
                }
            }
        })
    };
    let alone = each(alone).await.map_err(WireError::zenoh)?;
    let host = each(host).await.map_err(WireError::zenoh)?;
    Ok([alone, host])
}

/// Subscribes to `key` and sends every raw payload into `tx`.
pub async fn subscribe_payloads(
    s: &zenoh::Session,
    key: String,
    tx: mpsc::UnboundedSender<Vec<u8>>,
) -> Result<Subscription, WireError> {
    subscribe(s, key, tx, |sample| Some(payload(sample))).await
}

/// Calls `on_change(token key, alive)` whenever a liveliness token matching `key` appears
/// (`true`) or goes away (`false`), starting with the tokens already alive (history).
pub async fn on_tokens(
    s: &zenoh::Session,
    key: String,
    on_change: impl Fn(&str, bool) + Send + Sync + 'static,
) -> Result<Subscription, WireError> {
    s.liveliness()
        .declare_subscriber(key)
        .history(true)
        .callback(move |sample| on_change(sample.key_expr().as_str(), sample.kind() == SampleKind::Put))
        .await
        .map_err(WireError::zenoh)
}

/// Watches the one liveliness token `key`: the receiver holds whether it is alive now (`false`
/// until it is first seen) and wakes on every change.
pub async fn watch_token(s: &zenoh::Session, key: String) -> Result<(watch::Receiver<bool>, Subscription), WireError> {
    let (tx, alive) = watch::channel(false);
    let sub = on_tokens(s, key, move |_, up| {
        let _ = tx.send(up);
    })
    .await?;
    Ok((alive, sub))
}

/// Asks the queryable at `key` until one replies or `wait` has passed; returns the first good
/// reply's payload. A round with no reply (nobody serves the key yet) is retried after a pause.
pub async fn fetch(s: &zenoh::Session, key: &str, wait: Duration) -> Result<Vec<u8>, WireError> {
    let deadline = tokio::time::Instant::now() + wait;
    while tokio::time::Instant::now() < deadline {
        let replies = s.get(key).timeout(QUERY_TIMEOUT).await.map_err(WireError::zenoh)?;
        while let Ok(reply) = replies.recv_async().await {
            if let Ok(sample) = reply.result() {
                return Ok(payload(sample));
            }
        }
        tokio::time::sleep(RETRY_PAUSE).await;
    }
    Err(WireError::NoReply { key: key.to_string(), wait_s: wait.as_secs_f64() })
}

/// The scenario text the hub serves on `swarm/{run}/scenario`, fetched as [`fetch`] does (TOML;
/// the caller parses it).
pub async fn fetch_scenario_text(s: &zenoh::Session, keys: &Keys, wait: Duration) -> Result<String, WireError> {
    let bytes = fetch(s, &keys.scenario(), wait).await?;
    Ok(String::from_utf8_lossy(&bytes).into_owned())
}

/// Puts one payload on `key` without declaring a publisher (one-shot tools: `swarm put`,
/// `swarm netem`), with the encoding and priority of [`crate::session::Writer`].
pub async fn put_once(s: &zenoh::Session, key: &str, bytes: Vec<u8>, cc: CongestionControl) -> Result<(), WireError> {
    s.put(key, bytes)
        .encoding(crate::session::encoding())
        .congestion_control(cc)
        .priority(Priority::Data)
        .await
        .map_err(WireError::zenoh)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{AgentState, Msg};
    use swarm_types::UavId;

    fn state(id: u32) -> AgentState {
        AgentState { id: UavId::new(id), tick: 3, ..AgentState::default() }
    }

    fn ids(got: &[(UavId, Box<AgentState>)]) -> Vec<(u32, u32)> {
        got.iter().map(|(id, st)| (id.get(), st.id.get())).collect()
    }

    #[test]
    fn a_hosts_states_count_for_the_uavs_its_key_names_and_one_uavs_for_its_key() {
        let k = Keys::new("r").expect("valid");
        let host = k.host_state(&[1, 2, 3, 4].map(UavId::new));
        let many = || Some(Msg::States(vec![state(2), state(9), state(1)]));
        assert_eq!(ids(&states_of(&k, &host, many)), [(2, 2), (1, 1)], "UAV 9 is not the host's");
        // One UAV's state is named by its key, not by what it says.
        assert_eq!(ids(&states_of(&k, &k.state(UavId::new(5)), || Some(Msg::State(Box::new(state(6)))))), [(5, 6)]);
        assert!(states_of(&k, &k.state(UavId::new(5)), many).is_empty(), "a host's message on a UAV's key");
        assert!(states_of(&k, &host, || Some(Msg::State(Box::new(state(1))))).is_empty(), "one UAV's on a host's key");
        assert!(states_of(&k, &host, || None).is_empty(), "malformed");
        let mut decoded = false;
        assert!(states_of(&k, "swarm/r/truth/step", || {
            decoded = true;
            many()
        })
        .is_empty());
        assert!(!decoded, "another key's payload is not decoded");
    }

    #[test]
    fn a_key_speaks_for_the_uavs_it_names() {
        let k = Keys::new("r").expect("valid");
        let uav5 = Speaker::of(&k, &k.state(UavId::new(5))).expect("a UAV's key");
        assert_eq!(uav5, Speaker::Uav(UavId::new(5)));
        assert_eq!(uav5.names(None), Some(UavId::new(5)));
        assert_eq!(uav5.names(Some(UavId::new(5))), None, "a host's part on a UAV's key");
        let host = Speaker::of(&k, &k.host_state(&[1, 2, 4].map(UavId::new))).expect("a host's key");
        assert_eq!(host.names(Some(UavId::new(4))), Some(UavId::new(4)));
        assert_eq!(host.names(Some(UavId::new(3))), None, "not in the host's list");
        assert_eq!(host.names(None), None, "one UAV's message on a host's key");
        assert_eq!(Speaker::of(&k, "swarm/r/host/2-1/state"), None, "a list no host writes");
        assert_eq!(Speaker::of(&k, "swarm/other/uav/5/state"), None, "another run");
    }
}

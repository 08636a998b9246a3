//! ROS 2 on DDS, the middleware of a stock ROS 2 install (Fast DDS in Humble, Jazzy and Kilted):
//! one RTPS participant (RustDDS, pure Rust) whose writers and readers carry our CDR payloads
//! ([`crate::cdr`]) on ROS's DDS names (`rt/uav3/scan`, `sensor_msgs::msg::dds_::LaserScan_`),
//! and that tells the ROS graph which nodes it holds on `ros_discovery_info` (Jazzy's
//! `ParticipantEntitiesInfo`, [`crate::msgs::graph`]).
//!
//! Why RustDDS and not a ROS client library: the payloads are already encoded once for both
//! middlewares, so what is needed is RTPS itself (discovery, reliability, durability), not a
//! second set of message types; RustDDS's `DataWriter` takes a serializer adapter, and ours hands
//! it the bytes as they are. Its own ROS helpers write 24-byte GIDs (Humble's); Jazzy reads 16,
//! hence our own `ros_discovery_info`.
//!
//! `localhost_only` keeps every packet on the loopback interface (RustDDS's network filter:
//! multicast joins and advertised locators on 127.0.0.1 only; SPDP also goes to the well-known
//! localhost ports), the counterpart of ROS 2's `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`.
//! DDS has no access control: whatever the bridge writes, anyone on the network may read.

use crate::msgs::graph::{participant_entities_info, NodeEntities};
use crate::types::{RosType, PARTICIPANT_ENTITIES_INFO};
use crate::{Qos, Ros2Error};
use futures::StreamExt;
use rustdds::no_key::{Decode, DefaultDecoder, DeserializerAdapter, SerializerAdapter};
use rustdds::policy::{Durability, History, Reliability};
use rustdds::{
    DomainParticipant, DomainParticipantBuilder, QosPolicies, QosPolicyBuilder, RTPSEntity, RepresentationIdentifier,
    TopicKind,
};
use std::net::{IpAddr, Ipv4Addr};
use tokio::sync::mpsc;

/// A CDR body as it travels in an RTPS serialized payload (the encapsulation header is the
/// payload's representation identifier, which RustDDS writes and strips).
#[derive(Debug, Clone)]
pub struct Body(pub Vec<u8>);

impl serde::Serialize for Body {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_bytes(&self.0)
    }
}

impl<'de> serde::Deserialize<'de> for Body {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Body, D::Error> {
        Ok(Body(serde_bytes_vec(d)?))
    }
}

fn serde_bytes_vec<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<u8>, D::Error> {
    struct V;
    impl serde::de::Visitor<'_> for V {
        type Value = Vec<u8>;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("bytes")
        }
        fn visit_bytes<E>(self, v: &[u8]) -> Result<Vec<u8>, E> {
            Ok(v.to_vec())
        }
    }
    d.deserialize_bytes(V)
}

/// The adapter that hands RustDDS our bytes unchanged, both ways.
pub struct Raw;

/// No error: bytes are bytes.
#[derive(Debug, thiserror::Error)]
#[error("unreachable")]
pub struct Never;

impl SerializerAdapter<Body> for Raw {
    type Error = Never;
    fn output_encoding() -> RepresentationIdentifier {
        RepresentationIdentifier::CDR_LE
    }
    fn to_bytes(value: &Body) -> Result<bytes::Bytes, Never> {
        Ok(bytes::Bytes::copy_from_slice(&value.0))
    }
}

/// The decoder of [`Raw`]: the body copied out.
#[derive(Clone)]
pub struct RawDecoder;

impl<'de> Decode<'de, Body> for RawDecoder {
    type Error = Never;
    fn decode_bytes(self, input: &'de [u8], _: RepresentationIdentifier) -> Result<Body, Never> {
        Ok(Body(input.to_vec()))
    }
}

impl DeserializerAdapter<Body> for Raw {
    type Error = Never;
    type Decoded = Body;
    fn supported_encodings() -> &'static [RepresentationIdentifier] {
        &[RepresentationIdentifier::CDR_LE]
    }
    fn transform_decoded(decoded: Body) -> Body {
        decoded
    }
}

impl DefaultDecoder<Body> for Raw {
    type Decoder = RawDecoder;
    const DECODER: RawDecoder = RawDecoder;
}

/// Keeps a reader's thread going; dropping it ends the thread and the reader.
#[derive(Debug)]
pub struct ReaderGuard {
    _stop: futures::channel::oneshot::Sender<()>,
}

/// A data writer of ours.
pub type DdsWriter = rustdds::no_key::DataWriter<Body, Raw>;

/// One DDS participant of a process.
pub struct Participant {
    dp: DomainParticipant,
    publisher: rustdds::Publisher,
    subscriber: rustdds::Subscriber,
    discovery: DdsWriter,
}

impl std::fmt::Debug for Participant {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Participant").field("domain", &self.dp.domain_id()).finish()
    }
}

fn err(what: &str, e: impl std::fmt::Display) -> Ros2Error {
    Ros2Error::Dds(format!("{what}: {e}"))
}

/// RustDDS's QoS for ours.
fn policies(q: &Qos) -> QosPolicies {
    let reliability = if q.reliable {
        Reliability::Reliable { max_blocking_time: rustdds::Duration::from_millis(100) }
    } else {
        Reliability::BestEffort
    };
    let durability = if q.transient_local { Durability::TransientLocal } else { Durability::Volatile };
    QosPolicyBuilder::new()
        .reliability(reliability)
        .durability(durability)
        .history(History::KeepLast { depth: q.depth as i32 })
        .build()
}

/// A GUID as a Jazzy GID (its 16 bytes).
fn gid(g: rustdds::GUID) -> [u8; 16] {
    g.to_bytes()
}

/// ROS's DDS topic name of `topic` (`/uav3/scan` -> `rt/uav3/scan`).
pub fn dds_topic(topic: &str) -> String {
    format!("rt/{}", topic.trim_start_matches('/'))
}

impl Participant {
    /// Joins DDS domain `domain` (ROS's `ROS_DOMAIN_ID`), on loopback only if `localhost_only`.
    pub fn open(domain: u16, localhost_only: bool) -> Result<Participant, Ros2Error> {
        let mut b = DomainParticipantBuilder::new(domain);
        if localhost_only {
            b = b.with_only_networks([IpAddr::V4(Ipv4Addr::LOCALHOST)]);
        }
        let dp = b.build().map_err(|e| err("cannot join the DDS domain", e))?;
        let latched = policies(&Qos::LATCHED);
        let publisher = dp.create_publisher(&latched).map_err(|e| err("publisher", e))?;
        let subscriber = dp.create_subscriber(&latched).map_err(|e| err("subscriber", e))?;
        let topic = dp
            .create_topic("ros_discovery_info".into(), PARTICIPANT_ENTITIES_INFO.dds.into(), &latched, TopicKind::NoKey)
            .map_err(|e| err("ros_discovery_info", e))?;
        let discovery =
            publisher.create_datawriter_no_key::<Body, Raw>(&topic, None).map_err(|e| err("ros_discovery_info", e))?;
        Ok(Participant { dp, publisher, subscriber, discovery })
    }

    /// The participant's GID.
    pub fn gid(&self) -> [u8; 16] {
        gid(self.dp.guid())
    }

    fn topic(&self, topic: &str, t: &RosType, q: &Qos) -> Result<rustdds::Topic, Ros2Error> {
        self.dp
            .create_topic(dds_topic(topic), t.dds.to_string(), &policies(q), TopicKind::NoKey)
            .map_err(|e| err(&format!("topic {topic}"), e))
    }

    /// A writer of `topic` and its GID.
    pub fn writer(&self, topic: &str, t: &RosType, q: &Qos) -> Result<(DdsWriter, [u8; 16]), Ros2Error> {
        let tp = self.topic(topic, t, q)?;
        let w = self
            .publisher
            .create_datawriter_no_key::<Body, Raw>(&tp, Some(policies(q)))
            .map_err(|e| err(&format!("writer of {topic}"), e))?;
        let g = gid(w.guid());
        Ok((w, g))
    }

    /// A reader of `topic` that sends each payload (with its encapsulation header, as rmw_zenoh
    /// carries it) into `tx`, through `map`, from a thread of its own, until the returned guard is dropped or
    /// `tx`'s receiver goes away; and its GID.
    pub fn reader<T: Send + 'static>(
        this: &std::sync::Arc<Participant>,
        topic: &str,
        t: &RosType,
        q: &Qos,
        tx: mpsc::UnboundedSender<T>,
        map: impl Fn(Vec<u8>) -> T + Send + 'static,
    ) -> Result<(ReaderGuard, [u8; 16]), Ros2Error> {
        let tp = this.topic(topic, t, q)?;
        let r = this
            .subscriber
            .create_simple_datareader_no_key::<Body, Raw>(&tp, Some(policies(q)))
            .map_err(|e| err(&format!("reader of {topic}"), e))?;
        let g = gid(r.guid());
        let (stop, mut stopped) = futures::channel::oneshot::channel::<()>();
        // Dropped after the reader, which must tell its participant's event loop it goes.
        let participant = this.clone();
        std::thread::Builder::new()
            .name(format!("dds {topic}"))
            .spawn(move || {
                let _participant = participant;
                futures::executor::block_on(async move {
                    let mut stream = std::pin::pin!(r.as_async_stream());
                    while let futures::future::Either::Left((Some(next), _)) =
                        futures::future::select(stream.next(), &mut stopped).await
                    {
                        let Ok(change) = next else { continue };
                        let mut payload = crate::cdr::HEADER_LE.to_vec();
                        payload.extend_from_slice(&change.sample.0);
                        if tx.send(map(payload)).is_err() {
                            break;
                        }
                    }
                })
            })
            .map_err(|e| err("reader thread", e))?;
        Ok((ReaderGuard { _stop: stop }, g))
    }

    /// Tells the ROS graph which nodes this participant holds (replacing what it said before).
    pub fn announce(&self, nodes: &[NodeEntities]) -> Result<(), Ros2Error> {
        let payload = participant_entities_info(&self.gid(), nodes);
        self.discovery.write(Body(payload[4..].to_vec()), None).map_err(|e| err("ros_discovery_info", e))
    }
}

/// How many readers writer `w` is matched with: its status events since the last look, read into
/// `count`.
pub fn matched(w: &DdsWriter, count: &std::sync::atomic::AtomicI32) -> usize {
    use rustdds::StatusEvented;
    use std::sync::atomic::Ordering;
    while let Some(status) = w.try_recv_status() {
        if let rustdds::dds::statusevents::DataWriterStatus::PublicationMatched { current, .. } = status {
            count.store(current.count(), Ordering::Relaxed);
        }
    }
    usize::try_from(count.load(Ordering::Relaxed)).unwrap_or(0)
}

/// Writes a CDR payload (with its header) on a DDS writer, with source time `source_ns` (ns
/// since the Unix epoch).
pub fn write(w: &DdsWriter, payload: &[u8], source_ns: i64) -> Result<(), Ros2Error> {
    let body = payload.get(4..).unwrap_or_default();
    w.write(Body(body.to_vec()), Some(rtps_time(source_ns))).map_err(|e| err("write", e))
}

/// ns since the Unix epoch as an RTPS time: seconds, and the fraction of a second in 2^-32 s.
fn rtps_time(ns: i64) -> rustdds::Timestamp {
    let ns = u64::try_from(ns).unwrap_or(0);
    let (secs, sub) = (ns / 1_000_000_000, ns % 1_000_000_000);
    rustdds::Timestamp::from_ticks((secs << 32) + ((sub << 32) / 1_000_000_000))
}

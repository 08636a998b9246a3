//! One process's place in a ROS 2 graph, on either middleware: its nodes, their publishers and
//! subscriptions, with the same calls for both, so what a process publishes and reads is written
//! once.
//!
//! - rmw_zenoh: a node, publisher or subscription is a liveliness token on the process's Zenoh
//!   session (declared as the entity is made), a publication is a put on its data key with the
//!   sample attachment, a subscription a Zenoh subscriber on that key.
//! - DDS: every entity is a writer or reader of one RTPS participant; the nodes and which
//!   entities belong to which are told on `ros_discovery_info` by [`Graph::announce`], once the
//!   entities are made (and again after a change), so a graph of 1000 UAVs is told once, not
//!   once per entity.

use crate::dds::{self, DdsWriter, Participant, ReaderGuard};
use crate::msgs::graph::NodeEntities;
use crate::rmw_zenoh::{attachment, data_key, Entity, Kind};
use crate::types::RosType;
use crate::{Qos, Ros2Error};
use std::sync::atomic::{AtomicI64, Ordering};
use std::sync::Arc;
use std::time::{SystemTime, UNIX_EPOCH};
use tokio::sync::mpsc;
use zenoh::liveliness::LivelinessToken;
use zenoh::qos::CongestionControl;

/// Which middleware a graph speaks.
#[derive(Debug, Clone)]
pub enum Middleware {
    /// rmw_zenoh's keys on this Zenoh session.
    Zenoh(zenoh::Session),
    /// DDS (RTPS), on loopback only when `localhost_only`.
    Dds {
        /// Keep every packet on 127.0.0.1.
        localhost_only: bool,
    },
}

impl Middleware {
    /// `rmw_zenoh` or `dds`.
    pub fn name(&self) -> &'static str {
        match self {
            Middleware::Zenoh(_) => "rmw_zenoh",
            Middleware::Dds { .. } => "dds",
        }
    }
}

enum Inner {
    Zenoh { session: zenoh::Session, zid: String, tokens: Vec<LivelinessToken> },
    Dds { participant: Arc<Participant> },
}

/// A node of a [`Graph`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NodeRef(usize);

/// A process's nodes in one ROS domain.
pub struct Graph {
    domain: u32,
    inner: Inner,
    nodes: Vec<NodeEntities>,
    /// The next entity id (rmw_zenoh's tokens number every entity of a session).
    next_entity: u32,
}

impl std::fmt::Debug for Graph {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Graph").field("domain", &self.domain).field("nodes", &self.nodes.len()).finish()
    }
}

/// A publisher of one topic.
pub struct Publisher {
    inner: PubInner,
    gid: [u8; 16],
}

enum PubInner {
    Zenoh {
        session: zenoh::Session,
        key: zenoh::key_expr::KeyExpr<'static>,
        seq: AtomicI64,
        reliable: bool,
    },
    Dds {
        writer: Box<DdsWriter>,
        /// How many readers it is matched with, as its status events last said.
        matched: std::sync::atomic::AtomicI32,
        /// Kept until the writer is gone: a writer dropped after its participant cannot tell the
        /// participant's event loop.
        _participant: Arc<Participant>,
    },
}

/// Keeps a subscription (and its token or reader) alive; dropping it ends it.
pub enum SubscriptionGuard {
    /// A Zenoh subscriber and its liveliness token.
    Zenoh(zenoh::pubsub::Subscriber<()>, LivelinessToken),
    /// A DDS reader's thread.
    Dds(ReaderGuard),
}

/// A publisher's GID on rmw_zenoh: any 16 bytes unique to it in the session (rmw_zenoh only
/// reports them): the session id's bytes with the entity id.
fn zenoh_gid(zid: &str, entity: u32) -> [u8; 16] {
    let mut g = [0u8; 16];
    for (i, b) in zid.bytes().take(12).enumerate() {
        g[i] = b;
    }
    g[12..].copy_from_slice(&entity.to_le_bytes());
    g
}

impl Graph {
    /// Joins ROS domain `domain` on `middleware`.
    pub async fn open(middleware: Middleware, domain: u32) -> Result<Graph, Ros2Error> {
        let inner = match middleware {
            Middleware::Zenoh(session) => Inner::Zenoh { zid: session.zid().to_string(), session, tokens: Vec::new() },
            Middleware::Dds { localhost_only } => {
                let domain = u16::try_from(domain)
                    .map_err(|_| Ros2Error::Dds(format!("domain {domain} is not a DDS domain id")))?;
                Inner::Dds { participant: Arc::new(Participant::open(domain, localhost_only)?) }
            }
        };
        Ok(Graph { domain, inner, nodes: Vec::new(), next_entity: 1 })
    }

    /// The ROS domain.
    pub fn domain(&self) -> u32 {
        self.domain
    }

    fn entity(&mut self) -> u32 {
        let e = self.next_entity;
        self.next_entity += 1;
        e
    }

    fn token_entity<'a>(&'a self, node: NodeRef, entity_id: u32, zid: &'a str) -> Entity<'a> {
        let n = &self.nodes[node.0];
        Entity {
            domain: self.domain,
            zid,
            node_id: node.0 as u32,
            entity_id,
            kind: Kind::Node,
            namespace: &n.namespace,
            node: &n.name,
            topic: None,
        }
    }

    async fn declare(&mut self, key: String) -> Result<Option<LivelinessToken>, Ros2Error> {
        match &mut self.inner {
            Inner::Zenoh { session, .. } => {
                Ok(Some(session.liveliness().declare_token(key).await.map_err(Ros2Error::zenoh)?))
            }
            Inner::Dds { .. } => Ok(None),
        }
    }

    /// A node `name` in `namespace` (`/uav3`, or `/`).
    pub async fn node(&mut self, namespace: &str, name: &str) -> Result<NodeRef, Ros2Error> {
        let node = NodeRef(self.nodes.len());
        self.nodes.push(NodeEntities {
            namespace: namespace.into(),
            name: name.into(),
            readers: vec![],
            writers: vec![],
        });
        if let Inner::Zenoh { zid, .. } = &self.inner {
            let zid = zid.clone();
            let key = self.token_entity(node, node.0 as u32, &zid).token_key();
            if let Some(t) = self.declare(key).await? {
                self.push_token(t);
            }
        }
        Ok(node)
    }

    fn push_token(&mut self, t: LivelinessToken) {
        if let Inner::Zenoh { tokens, .. } = &mut self.inner {
            tokens.push(t);
        }
    }

    /// The liveliness token key of an entity of `node` on `topic`.
    fn topic_token(&mut self, node: NodeRef, kind: Kind, topic: &str, t: RosType, qos: Qos) -> Option<(String, u32)> {
        let Inner::Zenoh { zid, .. } = &self.inner else { return None };
        let zid = zid.clone();
        let entity_id = self.entity();
        let e = Entity { kind, topic: Some((topic, t, qos)), ..self.token_entity(node, entity_id, &zid) };
        Some((e.token_key(), entity_id))
    }

    /// A publisher of `topic` (`/uav3/scan`) of type `t` on `node`.
    pub async fn publisher(
        &mut self,
        node: NodeRef,
        topic: &str,
        t: RosType,
        qos: Qos,
    ) -> Result<Publisher, Ros2Error> {
        let p = match &self.inner {
            Inner::Zenoh { session, zid, .. } => {
                let session = session.clone();
                let zid = zid.clone();
                let key = session.declare_keyexpr(data_key(self.domain, topic, &t)).await.map_err(Ros2Error::zenoh)?;
                let (token, entity) = self.topic_token(node, Kind::Publisher, topic, t, qos).expect("zenoh");
                if let Some(tok) = self.declare(token).await? {
                    self.push_token(tok);
                }
                let inner = PubInner::Zenoh { session, key, seq: AtomicI64::new(0), reliable: qos.reliable };
                Publisher { inner, gid: zenoh_gid(&zid, entity) }
            }
            Inner::Dds { participant } => {
                let (w, gid) = participant.writer(topic, &t, &qos)?;
                let inner = PubInner::Dds {
                    writer: Box::new(w),
                    matched: std::sync::atomic::AtomicI32::new(0),
                    _participant: participant.clone(),
                };
                Publisher { inner, gid }
            }
        };
        self.nodes[node.0].writers.push(p.gid);
        Ok(p)
    }

    /// Subscribes `node` to `topic` of type `t`: every payload (CDR with its header) goes into
    /// `tx`, through `map`, as it comes.
    pub async fn subscribe<T: Send + 'static>(
        &mut self,
        node: NodeRef,
        topic: &str,
        t: RosType,
        qos: Qos,
        tx: mpsc::UnboundedSender<T>,
        map: impl Fn(Vec<u8>) -> T + Send + Sync + 'static,
    ) -> Result<SubscriptionGuard, Ros2Error> {
        match &self.inner {
            Inner::Zenoh { session, zid, .. } => {
                let session = session.clone();
                let zid = zid.clone();
                let sub = session
                    .declare_subscriber(data_key(self.domain, topic, &t))
                    .callback(move |sample| {
                        let _ = tx.send(map(sample.payload().to_bytes().into_owned()));
                    })
                    .await
                    .map_err(Ros2Error::zenoh)?;
                let (token, entity) = self.topic_token(node, Kind::Subscription, topic, t, qos).expect("zenoh");
                let tok = session.liveliness().declare_token(token).await.map_err(Ros2Error::zenoh)?;
                self.nodes[node.0].readers.push(zenoh_gid(&zid, entity));
                Ok(SubscriptionGuard::Zenoh(sub, tok))
            }
            Inner::Dds { participant } => {
                let (guard, gid) = Participant::reader(participant, topic, &t, &qos, tx, map)?;
                self.nodes[node.0].readers.push(gid);
                Ok(SubscriptionGuard::Dds(guard))
            }
        }
    }

    /// Tells the graph the nodes and their entities as they are now (DDS's
    /// `ros_discovery_info`; rmw_zenoh's tokens already told it).
    pub fn announce(&self) -> Result<(), Ros2Error> {
        match &self.inner {
            Inner::Zenoh { .. } => Ok(()),
            Inner::Dds { participant } => participant.announce(&self.nodes),
        }
    }
}

/// Now, in ns since the Unix epoch.
pub fn unix_ns() -> i64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.as_nanos() as i64)
}

impl Publisher {
    /// Publishes a CDR payload (with its encapsulation header), its source time now.
    pub async fn put(&self, payload: Vec<u8>) -> Result<(), Ros2Error> {
        self.put_at(payload, None).await
    }

    /// Publishes a CDR payload with source time `source_ns` (ns since the Unix epoch; now when
    /// `None`): what a subscriber reads as the sample's source timestamp (rclpy's
    /// `source_timestamp`, rmw_zenoh's attachment), so the time from where the data was made to
    /// its reader can be measured.
    pub async fn put_at(&self, payload: Vec<u8>, source_ns: Option<i64>) -> Result<(), Ros2Error> {
        let stamp = source_ns.unwrap_or_else(unix_ns);
        match &self.inner {
            PubInner::Zenoh { session, key, seq, reliable } => {
                let n = seq.fetch_add(1, Ordering::Relaxed) + 1;
                let cc = if *reliable { CongestionControl::Block } else { CongestionControl::Drop };
                let att = attachment(n, stamp, &self.gid);
                session
                    .put(key.clone(), payload)
                    .attachment(att.to_vec())
                    .congestion_control(cc)
                    .await
                    .map_err(Ros2Error::zenoh)
            }
            PubInner::Dds { writer, .. } => dds::write(writer, &payload, stamp),
        }
    }

    /// The publisher's GID.
    pub fn gid(&self) -> [u8; 16] {
        self.gid
    }

    /// How many subscriptions it is matched with (DDS), or `None` where the middleware does not
    /// tell (rmw_zenoh: Zenoh routes by the router's subscriptions, whoever holds them).
    pub fn matched(&self) -> Option<usize> {
        match &self.inner {
            PubInner::Zenoh { .. } => None,
            PubInner::Dds { writer, matched, .. } => Some(dds::matched(writer, matched)),
        }
    }

    /// Waits up to `timeout` until some subscription is matched (DDS discovery takes a moment,
    /// and a volatile sample written before a reader matched never reaches it); at once where
    /// the middleware does not tell. Whether one is.
    pub async fn wait_matched(&self, timeout: std::time::Duration) -> bool {
        let deadline = tokio::time::Instant::now() + timeout;
        loop {
            match self.matched() {
                None => return true,
                Some(n) if n > 0 => return true,
                Some(_) if tokio::time::Instant::now() >= deadline => return false,
                Some(_) => tokio::time::sleep(std::time::Duration::from_millis(5)).await,
            }
        }
    }
}

//! ROS 2 on Zenoh, the way rmw_zenoh (Jazzy 0.2.4 and later, Kilted) puts it on the wire, so that
//! a ROS 2 machine with rmw_zenoh sees our topics as topics of ROS nodes:
//!
//! - data keys `<domain>/<topic without its leading />/<DDS type name>/<RIHS01 hash>`;
//! - payloads in CDR, little endian, with its 4-byte encapsulation header ([`crate::cdr`]);
//! - a 33-byte attachment on every sample: sequence number and source timestamp (`i64` LE, ns),
//!   then the publisher's 16-byte GID behind its LEB128 length (`0x10`): rmw_zenoh drops a
//!   sample without one;
//! - liveliness tokens `@ros2_lv/<domain>/<zid>/<node id>/<entity id>/<kind>/<enclave>/
//!   <namespace>/<node>[/<topic>/<type>/<hash>/<qos>]` for each node, publisher and
//!   subscription, with every `/` inside a field written `%`, and QoS written as rmw_zenoh does
//!   (a field left empty where it is rmw_zenoh's default).
//!
//! The formats are rmw_zenoh's documented ones (its `docs/design.md` and source); the type hashes
//! are ROS 2 Jazzy's ([`crate::types`]). ROS 2's own serializer (rclpy) reads the payloads and
//! PyPI `zenoh-ros2-sdk` (an rmw_zenoh client no one here wrote) lists and echoes the topics in
//! `tests/tests/ros2.rs`; no rmw_zenoh_cpp node ran here (docs/ros2.md).

use crate::types::RosType;
use crate::Qos;

/// The data key of `topic` (`/uav3/scan`) of type `t` in ROS domain `domain`: inner slashes
/// stay, the leading one goes.
pub fn data_key(domain: u32, topic: &str, t: &RosType) -> String {
    format!("{domain}/{}/{}/{}", topic.trim_matches('/'), t.dds, t.hash)
}

/// The attachment of a sample: `seq`, the source time `stamp_ns`, the publisher's `gid`.
pub fn attachment(seq: i64, stamp_ns: i64, gid: &[u8; 16]) -> [u8; 33] {
    let mut a = [0u8; 33];
    a[..8].copy_from_slice(&seq.to_le_bytes());
    a[8..16].copy_from_slice(&stamp_ns.to_le_bytes());
    a[16] = 16;
    a[17..].copy_from_slice(gid);
    a
}

/// Reads an attachment: `(seq, stamp_ns, gid)`; `None` unless it has rmw_zenoh's layout.
pub fn parse_attachment(a: &[u8]) -> Option<(i64, i64, [u8; 16])> {
    if a.len() != 33 || a[16] != 16 {
        return None;
    }
    let seq = i64::from_le_bytes(a[..8].try_into().ok()?);
    let stamp = i64::from_le_bytes(a[8..16].try_into().ok()?);
    Some((seq, stamp, a[17..].try_into().ok()?))
}

/// A field of a liveliness token: every `/` written `%`.
fn mangle(s: &str) -> String {
    s.replace('/', "%")
}

/// What a liveliness token announces.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A node (`NN`).
    Node,
    /// A publisher (`MP`) of a topic.
    Publisher,
    /// A subscription (`MS`) to a topic.
    Subscription,
}

/// QoS as rmw_zenoh writes it in a token:
/// `<reliability>:<durability>:<history>,<depth>:<deadline>:<lifespan>:<liveliness>`, with
/// reliability 2 = best effort, durability 1 = transient local, and the rmw defaults (reliable,
/// volatile, no deadline, lifespan or liveliness lease) left empty.
pub fn qos_field(q: &Qos) -> String {
    let reliability = if q.reliable { "" } else { "2" };
    let durability = if q.transient_local { "1" } else { "" };
    format!("{reliability}:{durability}:,{}:,:,:,,", q.depth)
}

/// One entity of the ROS graph, as its liveliness token names it.
#[derive(Debug, Clone, Copy)]
pub struct Entity<'a> {
    /// ROS domain.
    pub domain: u32,
    /// The Zenoh session id of the process (lower-case hex).
    pub zid: &'a str,
    /// The node's id within the session.
    pub node_id: u32,
    /// The entity's id within the session (the node's own for a node).
    pub entity_id: u32,
    /// Node, publisher or subscription.
    pub kind: Kind,
    /// The node's namespace (`/uav3`).
    pub namespace: &'a str,
    /// The node's name.
    pub node: &'a str,
    /// The topic, its type and QoS (publishers and subscriptions).
    pub topic: Option<(&'a str, RosType, Qos)>,
}

impl Entity<'_> {
    /// The liveliness token's key.
    pub fn token_key(&self) -> String {
        let kind = match self.kind {
            Kind::Node => "NN",
            Kind::Publisher => "MP",
            Kind::Subscription => "MS",
        };
        let mut key = format!(
            "@ros2_lv/{}/{}/{}/{}/{kind}/%/{}/{}",
            self.domain,
            self.zid,
            self.node_id,
            self.entity_id,
            mangle(self.namespace),
            mangle(self.node)
        );
        if let Some((topic, t, qos)) = self.topic {
            key.push_str(&format!("/{}/{}/{}/{}", mangle(topic), t.dds, t.hash, qos_field(&qos)));
        }
        key
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::types::LASER_SCAN;

    #[test]
    fn keys_are_rmw_zenohs() {
        assert_eq!(
            data_key(0, "/uav3/scan", &LASER_SCAN),
            "0/uav3/scan/sensor_msgs::msg::dds_::LaserScan_/RIHS01_64c191398013af96509d518dac71d5164f9382553fce5c1f8cca5be7924bd828"
        );
        let node = Entity {
            domain: 0,
            zid: "aac3",
            node_id: 3,
            entity_id: 3,
            kind: Kind::Node,
            namespace: "/uav3",
            node: "swarm",
            topic: None,
        };
        assert_eq!(node.token_key(), "@ros2_lv/0/aac3/3/3/NN/%/%uav3/swarm");
        let publisher = Entity {
            entity_id: 7,
            kind: Kind::Publisher,
            topic: Some(("/uav3/scan", LASER_SCAN, Qos::SENSOR)),
            ..node
        };
        assert_eq!(
            publisher.token_key(),
            format!(
                "@ros2_lv/0/aac3/3/7/MP/%/%uav3/swarm/%uav3%scan/sensor_msgs::msg::dds_::LaserScan_/{}/2::,5:,:,:,,",
                LASER_SCAN.hash
            )
        );
        assert_eq!(qos_field(&Qos::DEFAULT), "::,10:,:,:,,");
        assert_eq!(qos_field(&Qos::LATCHED), ":1:,1:,:,:,,");
    }

    #[test]
    fn the_attachment_is_33_bytes_and_reads_back() {
        let gid: [u8; 16] = std::array::from_fn(|i| i as u8);
        let a = attachment(1, 1_700_000_000_123_456_789, &gid);
        assert_eq!(&a[..8], &[1, 0, 0, 0, 0, 0, 0, 0]);
        assert_eq!(&a[8..16], &[0x15, 0xcd, 0x85, 0x3d, 0xfe, 0x9c, 0x97, 0x17]);
        assert_eq!(a[16], 0x10);
        assert_eq!(parse_attachment(&a), Some((1, 1_700_000_000_123_456_789, gid)));
        assert_eq!(parse_attachment(&a[..32]), None);
    }
}

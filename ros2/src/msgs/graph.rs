//! `rmw_dds_common/msg/ParticipantEntitiesInfo`, Jazzy's layout (16-byte GIDs since Iron): the
//! nodes a DDS participant holds and the readers and writers of each, on `ros_discovery_info`.
//! Without it a DDS graph shows our topics but no nodes (`ros2 node list` is empty).

use crate::cdr::Writer;

/// One node's entry: its namespace and name, and the GIDs of its readers and writers.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NodeEntities {
    /// Namespace, e.g. `/uav3` (`/` for none).
    pub namespace: String,
    /// Node name, e.g. `swarm`.
    pub name: String,
    /// Its subscriptions' GIDs.
    pub readers: Vec<[u8; 16]>,
    /// Its publishers' GIDs.
    pub writers: Vec<[u8; 16]>,
}

/// The participant's message: its own GID and its nodes.
pub fn participant_entities_info(participant: &[u8; 16], nodes: &[NodeEntities]) -> Vec<u8> {
    let mut w = Writer::new();
    w.byte_array(participant).count(nodes.len());
    for n in nodes {
        w.string(&n.namespace).string(&n.name).count(n.readers.len());
        for g in &n.readers {
            w.byte_array(g);
        }
        w.count(n.writers.len());
        for g in &n.writers {
            w.byte_array(g);
        }
    }
    w.finish()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cdr::Reader;

    #[test]
    fn gids_are_sixteen_bytes_without_a_count() {
        let n =
            NodeEntities { namespace: "/uav1".into(), name: "swarm".into(), readers: vec![[1; 16]], writers: vec![] };
        let b = participant_entities_info(&[9; 16], &[n]);
        let mut r = Reader::new(&b).expect("header");
        assert_eq!(r.byte_array::<16>(), Ok([9; 16]));
        assert_eq!(r.count(1), Ok(1));
        assert_eq!(r.string().as_deref(), Ok("/uav1"));
        assert_eq!(r.string().as_deref(), Ok("swarm"));
        assert_eq!(r.count(16), Ok(1));
        assert_eq!(r.byte_array::<16>(), Ok([1; 16]));
        assert_eq!(r.count(16), Ok(0));
    }
}

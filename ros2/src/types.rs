//! The ROS 2 message types the project speaks, each with its ROS name, its DDS name on the wire
//! and its RIHS01 type hash (ROS 2 Jazzy's; rmw_zenoh puts the hash in every data key and
//! liveliness token). The hashes are checked against the `.json` type descriptions the installed
//! ROS 2 message packages ship and against PyPI `rosbags` in `tests/tests/ros2.rs`.

/// A ROS 2 message type: its ROS name, its DDS name on the wire, its RIHS01 type hash.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RosType {
    /// `sensor_msgs/msg/LaserScan`.
    pub ros: &'static str,
    /// `sensor_msgs::msg::dds_::LaserScan_`.
    pub dds: &'static str,
    /// `RIHS01_` and 64 lower-case hex digits.
    pub hash: &'static str,
}

/// `sensor_msgs/msg/LaserScan`.
pub const LASER_SCAN: RosType = RosType {
    ros: "sensor_msgs/msg/LaserScan",
    dds: "sensor_msgs::msg::dds_::LaserScan_",
    hash: "RIHS01_64c191398013af96509d518dac71d5164f9382553fce5c1f8cca5be7924bd828",
};

/// `nav_msgs/msg/Odometry`.
pub const ODOMETRY: RosType = RosType {
    ros: "nav_msgs/msg/Odometry",
    dds: "nav_msgs::msg::dds_::Odometry_",
    hash: "RIHS01_3cc97dc7fb7502f8714462c526d369e35b603cfc34d946e3f2eda2766dfec6e0",
};

/// `geometry_msgs/msg/Twist`.
pub const TWIST: RosType = RosType {
    ros: "geometry_msgs/msg/Twist",
    dds: "geometry_msgs::msg::dds_::Twist_",
    hash: "RIHS01_9c45bf16fe0983d80e3cfe750d6835843d265a9a6c46bd2e609fcddde6fb8d2a",
};

/// `geometry_msgs/msg/TwistStamped`.
pub const TWIST_STAMPED: RosType = RosType {
    ros: "geometry_msgs/msg/TwistStamped",
    dds: "geometry_msgs::msg::dds_::TwistStamped_",
    hash: "RIHS01_5f0fcd4f81d5d06ad9b4c4c63e3ea51b82d6ae4d0558f1d475229b1121db6f64",
};

/// `geometry_msgs/msg/AccelStamped`.
pub const ACCEL_STAMPED: RosType = RosType {
    ros: "geometry_msgs/msg/AccelStamped",
    dds: "geometry_msgs::msg::dds_::AccelStamped_",
    hash: "RIHS01_ef1df9eabae0a708cc049a061ebcddc4e2a5f745730100ba680e086a9698b165",
};

/// `geometry_msgs/msg/PoseStamped`.
pub const POSE_STAMPED: RosType = RosType {
    ros: "geometry_msgs/msg/PoseStamped",
    dds: "geometry_msgs::msg::dds_::PoseStamped_",
    hash: "RIHS01_10f3786d7d40fd2b54367835614bff85d4ad3b5dab62bf8bca0cc232d73b4cd8",
};

/// `geometry_msgs/msg/PoseArray`.
pub const POSE_ARRAY: RosType = RosType {
    ros: "geometry_msgs/msg/PoseArray",
    dds: "geometry_msgs::msg::dds_::PoseArray_",
    hash: "RIHS01_af0cc36d190e104d546d168d6b39df04fa4b4ccecf59cb4c9ed328d3d5004aa0",
};

/// `rosgraph_msgs/msg/Clock`.
pub const CLOCK: RosType = RosType {
    ros: "rosgraph_msgs/msg/Clock",
    dds: "rosgraph_msgs::msg::dds_::Clock_",
    hash: "RIHS01_692f7a66e93a3c83e71765d033b60349ba68023a8c689a79e48078bcb5c58564",
};

/// `tf2_msgs/msg/TFMessage` (no wheel of it here: its hash is rosbags').
pub const TF_MESSAGE: RosType = RosType {
    ros: "tf2_msgs/msg/TFMessage",
    dds: "tf2_msgs::msg::dds_::TFMessage_",
    hash: "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087",
};

/// `visualization_msgs/msg/MarkerArray`.
pub const MARKER_ARRAY: RosType = RosType {
    ros: "visualization_msgs/msg/MarkerArray",
    dds: "visualization_msgs::msg::dds_::MarkerArray_",
    hash: "RIHS01_86cb8800b6fb05b5eff1abd7a56f62a5641d3ae9a1c29e78e67e704f1d067dcf",
};

/// `rmw_dds_common/msg/ParticipantEntitiesInfo`: which ROS nodes a DDS participant holds, on
/// the `ros_discovery_info` topic (DDS only).
pub const PARTICIPANT_ENTITIES_INFO: RosType = RosType {
    ros: "rmw_dds_common/msg/ParticipantEntitiesInfo",
    dds: "rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_",
    hash: "RIHS01_91a0593bacdcc50ea9bdcf849a938b128412cc1ea821245c663bcd26f83c295e",
};

/// Every type above, for the tests that check the hashes.
pub const ALL: [RosType; 11] = [
    LASER_SCAN,
    ODOMETRY,
    TWIST,
    TWIST_STAMPED,
    ACCEL_STAMPED,
    POSE_STAMPED,
    POSE_ARRAY,
    CLOCK,
    TF_MESSAGE,
    MARKER_ARRAY,
    PARTICIPANT_ENTITIES_INFO,
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dds_names_follow_the_ros_names_and_hashes_have_their_shape() {
        for t in ALL {
            let mut parts = t.ros.split('/');
            let (pkg, kind, name) = (parts.next(), parts.next(), parts.next());
            assert_eq!(
                Some(t.dds.to_string()),
                pkg.zip(kind).zip(name).map(|((p, k), n)| format!("{p}::{k}::dds_::{n}_"))
            );
            let hex = t.hash.strip_prefix("RIHS01_").expect("prefix");
            assert!(hex.len() == 64 && hex.bytes().all(|b| b.is_ascii_hexdigit() && !b.is_ascii_uppercase()), "{t:?}");
        }
    }
}

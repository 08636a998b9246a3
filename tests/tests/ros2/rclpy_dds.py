"""A stock ROS 2 node (ROS 2 Jazzy's own rclpy on Fast DDS, no code of ours) in a run shown over
DDS: it subscribes to UAV 3's scan and odometry (sensor-data QoS), the clock, the world markers
(transient local) and UAV 3's neighbour estimates, follows sim time with `use_sim_time`, lists the
graph with rclpy's graph API, and drives UAV 3 (external) with a Twist of 0.8 m/s ahead on
/uav3/cmd_vel while the run lasts.

Usage: rclpy_dds.py
Prints one JSON line of what it saw. Exits once scans have stopped for 3 s (or after 120 s).
"""
import json
import statistics
import time

import rclpy
from geometry_msgs.msg import PoseArray, Twist
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import LaserScan
from visualization_msgs.msg import MarkerArray

rclpy.init()
node = Node("teleop", parameter_overrides=[Parameter("use_sim_time", Parameter.Type.BOOL, True)])
seen = {"scans": 0, "odoms": 0, "clocks": 0, "neighbour_msgs": 0, "scan_frame": None, "ranges": 0,
        "range_max": None, "odom_frame": None, "odom_child": None, "odom_x": [], "clock_s": [],
        "markers": {}, "marker_frame": None, "neighbours_max": 0, "neighbour_frame": None,
        "sim_time_s": None, "scan_stamp_s": []}
lat_ms = {"scan": [], "odom": [], "clock": []}
last_scan = [None]


def latency(kind, info):
    src, rcv = info.get("source_timestamp", 0), info.get("received_timestamp", 0)
    if src > 0 and rcv > 0:
        lat_ms[kind].append((rcv - src) / 1e6)


def on_scan(msg, info):
    seen["scans"] += 1
    last_scan[0] = time.monotonic()
    seen["scan_frame"], seen["ranges"], seen["range_max"] = msg.header.frame_id, len(msg.ranges), msg.range_max
    seen["scan_stamp_s"].append(msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9)
    latency("scan", info)


def on_odom(msg, info):
    seen["odoms"] += 1
    seen["odom_frame"], seen["odom_child"] = msg.header.frame_id, msg.child_frame_id
    seen["odom_x"].append(msg.pose.pose.position.x)
    latency("odom", info)


def on_clock(msg, info):
    seen["clocks"] += 1
    seen["clock_s"].append(msg.clock.sec + msg.clock.nanosec * 1e-9)
    latency("clock", info)


def on_markers(msg):
    seen["markers"] = {}
    for m in msg.markers:
        if m.action == 0:
            seen["markers"][m.ns] = seen["markers"].get(m.ns, 0) + 1
            seen["marker_frame"] = m.header.frame_id


def on_neighbours(msg):
    seen["neighbour_msgs"] += 1
    seen["neighbours_max"] = max(seen["neighbours_max"], len(msg.poses))
    seen["neighbour_frame"] = msg.header.frame_id


latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
node.create_subscription(LaserScan, "/uav3/scan", on_scan, qos_profile_sensor_data)
node.create_subscription(Odometry, "/uav3/odom", on_odom, qos_profile_sensor_data)
node.create_subscription(Clock, "/clock", on_clock, 10)
node.create_subscription(MarkerArray, "/world/markers", on_markers, latched)
node.create_subscription(PoseArray, "/uav3/neighbours", on_neighbours, 10)
cmd = node.create_publisher(Twist, "/uav3/cmd_vel", 10)
twist = Twist()
twist.linear.x = 0.8

graph = {}
start, sent = time.monotonic(), 0
while time.monotonic() - start < 120:
    rclpy.spin_once(node, timeout_sec=0.05)
    cmd.publish(twist)
    sent += 1
    if seen["scans"] > 0 and not graph:
        time.sleep(0.5)
        graph = {
            "nodes": sorted([f"{ns.rstrip('/')}/{n}" for n, ns in node.get_node_names_and_namespaces()]),
            "topics": {t: types for t, types in node.get_topic_names_and_types()},
            "uav3_publishers": {t: types for t, types in node.get_publisher_names_and_types_by_node("swarm", "/uav3")},
            "uav3_subscriptions": {t: types for t, types in node.get_subscriber_names_and_types_by_node("swarm", "/uav3")},
            "scan_publishers": [(i.node_name, i.node_namespace, i.qos_profile.reliability.name) for i in node.get_publishers_info_by_topic("/uav3/scan")],
        }
    if seen["clocks"]:
        # The node's own clock (use_sim_time) beside the newest /clock it received.
        seen["sim_time_s"] = [node.get_clock().now().nanoseconds * 1e-9, seen["clock_s"][-1]]
    if last_scan[0] is not None and time.monotonic() - last_scan[0] > 3.0:
        break

clocks = seen["clock_s"]
seen["clock_increasing"] = all(b > a for a, b in zip(clocks, clocks[1:]))
seen["clock_last_s"] = clocks[-1] if clocks else None
seen["clock_s"] = len(clocks)
seen["scan_stamp_s"] = seen["scan_stamp_s"][-1] if seen["scan_stamp_s"] else None
seen["latency_ms_p50"] = {k: (statistics.median(v) if v else None) for k, v in lat_ms.items()}
seen["latency_ms_p95"] = {k: (sorted(v)[int(0.95 * (len(v) - 1))] if v else None) for k, v in lat_ms.items()}
seen["graph"] = graph
seen["cmd_vel_sent"] = sent
print(json.dumps(seen))
node.destroy_node()
rclpy.shutdown()

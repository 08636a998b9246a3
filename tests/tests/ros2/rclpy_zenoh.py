"""A ROS 2 machine on rmw_zenoh, as far as the wire goes, with code no one here wrote: ROS 2
Jazzy's own serializer (rclpy.serialization) on the bytes our bridge puts under rmw_zenoh's keys
(eclipse-zenoh), and PyPI zenoh-ros2-sdk (an independent rmw_zenoh client, which computes its own
type hashes and keys) listing the topics and echoing UAV 3's odometry. Logged in as `ros`, it
drives UAV 3 (external) with a Twist made by rclpy's serializer, and cannot read the truth topics.

Usage: rclpy_zenoh.py LOCATOR PASSWORD_FILE SHARE_DIR
SHARE_DIR: the ROS venv's share/ (the message definitions zenoh-ros2-sdk reads, instead of
fetching them from the network). Prints one JSON line. Exits once scans have stopped for 3 s (or
after 120 s).
"""
import json
import os
import statistics
import sys
import threading
import time

loc, password_file, share = sys.argv[1:4]
host, port = loc.removeprefix("tcp/").rsplit(":", 1)
password = open(password_file).read().strip()
# zenoh-ros2-sdk's session: a client of the hub's router, logged in as `ros` (its defaults are a
# gossiping peer).
os.environ["ZENOH_CONFIG_OVERRIDE"] = ";".join([
    'mode="client"',
    "scouting/gossip/enabled=false",
    'transport/auth/usrpwd/user="ros"',
    f"transport/auth/usrpwd/password={json.dumps(password)}",
])

import zenoh  # noqa: E402
from geometry_msgs.msg import Twist  # noqa: E402
from nav_msgs.msg import Odometry  # noqa: E402
from rclpy.serialization import deserialize_message, serialize_message  # noqa: E402
from rosgraph_msgs.msg import Clock  # noqa: E402
from sensor_msgs.msg import LaserScan  # noqa: E402
from zenoh_ros2_sdk import ROS2Subscriber, get_registry, get_topic_names_and_types  # noqa: E402

get_registry(messages_dir=share)


def type_hash(ros_type):  # the installed message package's own description of its type
    pkg, kind, name = ros_type.split("/")
    with open(os.path.join(share, pkg, kind, f"{name}.json")) as f:
        return json.load(f)["type_hashes"][0]["hash_string"]


def key(topic, ros_type, domain=0):  # rmw_zenoh: <domain>/<topic>/<dds type>/<hash>
    pkg, kind, name = ros_type.split("/")
    return f"{domain}/{topic.strip('/')}/{pkg}::{kind}::dds_::{name}_/{type_hash(ros_type)}"


c = zenoh.Config()
for k, v in [("mode", '"client"'), ("connect/endpoints", json.dumps([loc])), ("scouting/multicast/enabled", "false"),
             ("transport/auth/usrpwd/user", '"ros"'), ("transport/auth/usrpwd/password", json.dumps(password))]:
    c.insert_json5(k, v)
s = zenoh.open(c)
lock = threading.Lock()
seen = {"scans": 0, "odoms": 0, "clocks": 0, "scan_frame": None, "ranges": 0, "odom_x": [], "clock_last_s": None,
        "truth_samples": 0, "sdk_odoms": 0, "sdk_odom_frame": None}
lat_ms = {"scan": [], "odom": [], "clock": []}
last_scan = [None]


def latency(kind, sample):
    att = sample.attachment.to_bytes() if sample.attachment is not None else b""
    if len(att) == 33:
        lat_ms[kind].append((time.time_ns() - int.from_bytes(att[8:16], "little", signed=True)) / 1e6)


def on_scan(sample):
    msg = deserialize_message(bytes(sample.payload.to_bytes()), LaserScan)
    with lock:
        seen["scans"] += 1
        last_scan[0] = time.monotonic()
        seen["scan_frame"], seen["ranges"] = msg.header.frame_id, len(msg.ranges)
        latency("scan", sample)


def on_odom(sample):
    msg = deserialize_message(bytes(sample.payload.to_bytes()), Odometry)
    with lock:
        seen["odoms"] += 1
        seen["odom_x"].append(msg.pose.pose.position.x)
        latency("odom", sample)


def on_clock(sample):
    msg = deserialize_message(bytes(sample.payload.to_bytes()), Clock)
    with lock:
        seen["clocks"] += 1
        seen["clock_last_s"] = msg.clock.sec + msg.clock.nanosec * 1e-9
        latency("clock", sample)


def on_truth(sample):
    with lock:
        seen["truth_samples"] += 1


def on_sdk_odom(msg):
    with lock:
        seen["sdk_odoms"] += 1
        seen["sdk_odom_frame"] = msg.header.frame_id


subs = [
    s.declare_subscriber(key("/uav3/scan", "sensor_msgs/msg/LaserScan"), on_scan),
    s.declare_subscriber(key("/uav3/odom", "nav_msgs/msg/Odometry"), on_odom),
    s.declare_subscriber(key("/clock", "rosgraph_msgs/msg/Clock"), on_clock),
    # Ground truth: the router must refuse a `ros` login these.
    s.declare_subscriber(key("/world/markers", "visualization_msgs/msg/MarkerArray"), on_truth),
]
sdk_sub = ROS2Subscriber("/uav3/odom", "nav_msgs/msg/Odometry", on_sdk_odom, router_ip=host, router_port=int(port))
twist = Twist()
twist.linear.x = 0.8
payload = serialize_message(twist)
gid = os.urandom(16)
cmd_key = key("/uav3/cmd_vel", "geometry_msgs/msg/Twist")
topics = []
start, seq = time.monotonic(), 0
while time.monotonic() - start < 120:
    seq += 1
    att = seq.to_bytes(8, "little", signed=True) + time.time_ns().to_bytes(8, "little", signed=True) + bytes([16]) + gid
    s.put(cmd_key, payload, attachment=att)
    time.sleep(0.05)
    with lock:
        scanning = seen["scans"] > 0
    if scanning and not topics:
        topics = get_topic_names_and_types(domain_id=0, router_ip=host, router_port=int(port), timeout=2.0)
    with lock:
        if last_scan[0] is not None and time.monotonic() - last_scan[0] > 3.0:
            break
with lock:
    seen["latency_ms_p50"] = {k: (statistics.median(v) if v else None) for k, v in lat_ms.items()}
    seen["sdk_topics"] = {t: types for t, types in topics}
    seen["cmd_vel_sent"] = seq
    print(json.dumps(seen))
sdk_sub.close()
s.close()

"""A ROS 2 machine on rmw_zenoh, as far as the wire goes, written from rmw_zenoh's documented
formats with eclipse-zenoh and rosbags (no code of ours): logged in as `ros`, it finds UAV 3's
node and topics in the liveliness graph, subscribes to /uav3/scan and /uav3/odom by ROS names,
and drives /uav3/cmd_vel with a Twist (0.8 m/s ahead) while the run lasts.

Usage: ros_client.py LOCATOR RUN PASSWORD_FILE
Prints one JSON line of what it saw. Exits once scans have stopped for 3 s (or after 120 s).
"""
import json
import os
import sys
import threading
import time

import zenoh
from rosbags.typesys import Stores, get_typestore

loc, run, password_file = sys.argv[1:4]
ts = get_typestore(Stores.ROS2_JAZZY)


def dds(ros_type):  # sensor_msgs/msg/LaserScan -> sensor_msgs::msg::dds_::LaserScan_
    pkg, kind, name = ros_type.split("/")
    return f"{pkg}::{kind}::dds_::{name}_"


def key(topic, ros_type, domain=0):  # rmw_zenoh: <domain>/<topic>/<type>/<hash>
    return f"{domain}/{topic.strip('/')}/{dds(ros_type)}/{ts.hash_rihs01(ros_type)}"


def attachment(seq, gid):  # i64 seq, i64 ns, LEB128 16, 16 bytes
    return seq.to_bytes(8, "little", signed=True) + time.time_ns().to_bytes(8, "little", signed=True) + bytes([16]) + gid


c = zenoh.Config()
c.insert_json5("mode", '"client"')
c.insert_json5("connect/endpoints", json.dumps([loc]))
c.insert_json5("scouting/multicast/enabled", "false")
c.insert_json5("transport/auth/usrpwd/user", '"ros"')
c.insert_json5("transport/auth/usrpwd/password", json.dumps(open(password_file).read().strip()))
s = zenoh.open(c)
zid = str(s.zid())
lock = threading.Lock()
seen = {"scans": 0, "scan_seqs": [], "bad_attachments": 0, "scan_frame": None, "ranges": 0, "odom_x": [], "run_keys": 0}
last_scan = [None]


def on_scan(sample):
    att = sample.attachment.to_bytes() if sample.attachment is not None else b""
    msg = ts.deserialize_cdr(bytes(sample.payload.to_bytes()), "sensor_msgs/msg/LaserScan")
    with lock:
        seen["scans"] += 1
        last_scan[0] = time.monotonic()
        if len(att) == 33 and att[16] == 16:
            seen["scan_seqs"].append(int.from_bytes(att[:8], "little", signed=True))
        else:
            seen["bad_attachments"] += 1
        seen["scan_frame"], seen["ranges"] = msg.header.frame_id, len(msg.ranges)


def on_odom(sample):
    msg = ts.deserialize_cdr(bytes(sample.payload.to_bytes()), "nav_msgs/msg/Odometry")
    with lock:
        seen["odom_x"].append(msg.pose.pose.position.x)


def on_run_key(sample):
    with lock:
        seen["run_keys"] += 1


graph = [str(r.ok.key_expr) for r in s.liveliness().get("@ros2_lv/0/**", timeout=5.0) if r.ok is not None]
subs = [
    s.declare_subscriber(key("/uav3/scan", "sensor_msgs/msg/LaserScan"), on_scan),
    s.declare_subscriber(key("/uav3/odom", "nav_msgs/msg/Odometry"), on_odom),
    s.declare_subscriber(f"swarm/{run}/**", on_run_key),  # refused by the access control: must stay silent
]
# Our own place in the ROS graph, as a node `teleop` with a cmd_vel publisher would hold it.
tokens = [
    s.liveliness().declare_token(f"@ros2_lv/0/{zid}/0/0/NN/%/%/teleop"),
    s.liveliness().declare_token(f"@ros2_lv/0/{zid}/0/1/MP/%/%/teleop/%uav3%cmd_vel/{dds('geometry_msgs/msg/Twist')}/{ts.hash_rihs01('geometry_msgs/msg/Twist')}/::,10:,:,:,,"),
]
Twist, Vector3 = ts.types["geometry_msgs/msg/Twist"], ts.types["geometry_msgs/msg/Vector3"]
twist = bytes(ts.serialize_cdr(Twist(linear=Vector3(x=0.8, y=0.0, z=0.0), angular=Vector3(x=0.0, y=0.0, z=0.0)), "geometry_msgs/msg/Twist"))
gid = os.urandom(16)
cmd_key = key("/uav3/cmd_vel", "geometry_msgs/msg/Twist")
start, seq = time.monotonic(), 0
while time.monotonic() - start < 120:
    seq += 1
    s.put(cmd_key, twist, attachment=attachment(seq, gid))
    time.sleep(0.05)
    with lock:
        if last_scan[0] is not None and time.monotonic() - last_scan[0] > 3.0:
            break
with lock:
    seqs = seen.pop("scan_seqs")
    seen["scan_seq_first"], seen["scan_seq_increasing"] = (seqs[0] if seqs else None), all(b > a for a, b in zip(seqs, seqs[1:]))
    seen["graph"] = graph
    seen["cmd_vel_sent"] = seq
    print(json.dumps(seen))
s.close()

"""Reads the ROS 2 messages our wire crate encoded with PyPI rosbags (a CDR implementation no
one here wrote), and writes one rosbags encoded for us to decode.

Usage: rosbags_check.py DIR
Reads DIR/scan.cdr (sensor_msgs/msg/LaserScan), DIR/odom.cdr (nav_msgs/msg/Odometry) and
DIR/twist.cdr (geometry_msgs/msg/Twist); writes DIR/twist_from_rosbags.cdr (linear 0.5, -0.25,
0; angular 0, 0, 0.1). Prints one JSON line: each message's fields as rosbags decoded them, and
each type's RIHS01 hash as rosbags computes it.
"""
import json
import pathlib
import sys

import numpy as np
from rosbags.typesys import Stores, get_typestore

d = pathlib.Path(sys.argv[1])
ts = get_typestore(Stores.ROS2_JAZZY)
types = {"scan": "sensor_msgs/msg/LaserScan", "odom": "nav_msgs/msg/Odometry", "twist": "geometry_msgs/msg/Twist"}


def number(x):
    """A float as JSON can carry it: a non-finite one by name ("inf", "-inf", "nan")."""
    return float(x) if np.isfinite(x) else str(float(x))


def plain(v):
    if isinstance(v, np.ndarray):
        return [number(x) for x in v.tolist()]
    if hasattr(v, "__dataclass_fields__"):
        return {k: plain(getattr(v, k)) for k in v.__dataclass_fields__ if k != "__msgtype__"}
    if isinstance(v, float):
        return number(v)
    return v


out = {"hashes": {t: ts.hash_rihs01(t) for t in types.values()}}
for name, t in types.items():
    out[name] = plain(ts.deserialize_cdr((d / f"{name}.cdr").read_bytes(), t))
Twist, Vector3 = ts.types["geometry_msgs/msg/Twist"], ts.types["geometry_msgs/msg/Vector3"]
mine = Twist(linear=Vector3(x=0.5, y=-0.25, z=0.0), angular=Vector3(x=0.0, y=0.0, z=0.1))
(d / "twist_from_rosbags.cdr").write_bytes(bytes(ts.serialize_cdr(mine, "geometry_msgs/msg/Twist")))
print(json.dumps(out))

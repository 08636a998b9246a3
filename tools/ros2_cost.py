"""The cost of the ROS 2 bridge, measured with ROS 2's own code: for each swarm size, middleware
and time mode, fly the scenario with the bridge (`swarm run --ros2`, `--dds`), listen to every
topic it publishes for a window of wall time (rclpy on Fast DDS, or eclipse-zenoh on rmw_zenoh's
keys logged in as `ros`), and print a table: messages per second the ROS side received, the rate
the run's sim speed calls for, and the latency from the hub's put (the source timestamp the
bridge carries over from the hub's Zenoh timestamp) to the ROS callback.

Usage (ROS 2 venv, as root for the network namespace DDS runs in):
    .venv-ros/bin/python tools/ros2_cost.py target/release/swarm [--sizes forest-5,forest-40-icp]
        [--window 10] [--modes realtime,lockstep]

DDS runs inside a network namespace of its own with loopback only (as the tests do), so nothing
else on the network takes part. A study, not a test: the numbers depend on the machine.
"""
import argparse
import json
import os
import pathlib
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent
TOPICS = ["scan", "odom", "goal", "neighbours"]


def uav_count(swarm, name):
    o = subprocess.run([swarm, "check", name, "--json"], capture_output=True, text=True, check=True)
    return int(json.loads(o.stdout)["swarm"]["count"])


def listen_dds(uavs, window):
    import rclpy
    from geometry_msgs.msg import PoseArray, PoseStamped
    from nav_msgs.msg import Odometry
    from rclpy.node import Node
    from rclpy.qos import qos_profile_sensor_data
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import LaserScan

    rclpy.init()
    node = Node("cost_probe")
    counts, lat = [0], []
    start = [None]

    def cb(_msg, info):
        if start[0] is None:
            return
        counts[0] += 1
        src, rcv = info.get("source_timestamp", 0), info.get("received_timestamp", 0)
        if src > 0 and rcv > 0:
            lat.append((rcv - src) / 1e6)

    types = {"scan": (LaserScan, qos_profile_sensor_data), "odom": (Odometry, qos_profile_sensor_data),
             "goal": (PoseStamped, 10), "neighbours": (PoseArray, 10)}
    # raw: the serialized bytes, not Python objects (deserializing 750 floats a scan in Python
    # would measure Python, not the bridge).
    for i in range(1, uavs + 1):
        for t in TOPICS:
            ty, qos = types[t]
            node.create_subscription(ty, f"/uav{i}/{t}", cb, qos, raw=True)
    node.create_subscription(Clock, "/clock", cb, 10, raw=True)
    warm = time.monotonic() + 3
    while time.monotonic() < warm:
        rclpy.spin_once(node, timeout_sec=0.05)
    start[0] = time.monotonic()
    while time.monotonic() - start[0] < window:
        rclpy.spin_once(node, timeout_sec=0.05)
    elapsed = time.monotonic() - start[0]
    node.destroy_node()
    rclpy.shutdown()
    return counts[0] / elapsed, lat


def listen_zenoh(loc, password_file, window):
    import zenoh

    c = zenoh.Config()
    for k, v in [("mode", '"client"'), ("connect/endpoints", json.dumps([loc])), ("scouting/multicast/enabled", "false"),
                 ("transport/auth/usrpwd/user", '"ros"'),
                 ("transport/auth/usrpwd/password", json.dumps(open(password_file).read().strip()))]:
        c.insert_json5(k, v)
    s = zenoh.open(c)
    lock = threading.Lock()
    counts, lat, on = [0], [], [False]

    def cb(sample):
        key = str(sample.key_expr)
        if not on[0] or not any(f"/{t}/" in key for t in TOPICS + ["clock"]):
            return
        att = sample.attachment.to_bytes() if sample.attachment is not None else b""
        with lock:
            counts[0] += 1
            if len(att) == 33:
                lat.append((time.time_ns() - int.from_bytes(att[8:16], "little", signed=True)) / 1e6)

    # The `ros` login may subscribe to its topics, not to everything.
    subs = [s.declare_subscriber(k, cb) for k in ["*/*/scan/**", "*/*/odom/**", "*/*/goal/**", "*/*/neighbours/**", "*/clock/**"]]
    time.sleep(3)
    on[0] = True
    t0 = time.monotonic()
    time.sleep(window)
    with lock:
        n, l = counts[0], list(lat)
    rate = n / (time.monotonic() - t0)
    for sub in subs:
        sub.undeclare()
    s.close()
    return rate, l


def one(swarm, scenario, uavs, middleware, mode, window, tmp):
    out = tmp / f"{scenario}-{middleware}-{mode}"
    ns = f"ros2cost-{os.getpid()}-{middleware}-{mode}-{uavs}"
    # A goal too far to end the flight before the window is over, and time enough for it.
    args = [swarm, "run", scenario, "--ros2", "--time-mode", mode, "--out", str(out), "--quiet", "--no-mcap",
            "--set", "swarm.goal=[1000.0, 0.0]", "--set", "end.time_limit_s=3000"]
    if middleware == "dds":
        args += ["--dds", "--ros2-localhost"]
        subprocess.run(["ip", "netns", "add", ns], check=True)
        subprocess.run(["ip", "-n", ns, "link", "set", "lo", "up"], check=True)
        args = ["ip", "netns", "exec", ns] + args
    run = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, start_new_session=True)
    try:
        deadline = time.monotonic() + 60
        while not (out / "hub.txt").exists() and time.monotonic() < deadline:
            if run.poll() is not None:
                raise SystemExit(f"swarm run failed: {run.stderr.read().decode(errors='replace')[-2000:]}")
            time.sleep(0.1)
        if middleware == "dds":
            env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
            probe = subprocess.run(["ip", "netns", "exec", ns, sys.executable, __file__, "--probe-dds", str(uavs), str(window)],
                                   env=env, capture_output=True, text=True, timeout=window + 120)
            rate, lat = json.loads(probe.stdout.strip().splitlines()[-1])
        else:
            loc = (out / "hub.txt").read_text().split()[0]
            rate, lat = listen_zenoh(loc, out / "credentials" / "ros.password", window)
    finally:
        os.killpg(run.pid, signal.SIGINT)
        try:
            run.wait(timeout=30)
        except subprocess.TimeoutExpired:
            os.killpg(run.pid, signal.SIGKILL)
        if middleware == "dds":
            subprocess.run(["ip", "netns", "del", ns])
    summary = json.loads((out / "summary.json").read_text()) if (out / "summary.json").exists() else {}
    speed = summary.get("sim_speed") or float("nan")
    expected = uavs * (len(TOPICS) - 0) * 10 * speed + 10 * speed
    lat.sort()
    p = lambda q: lat[int(q * (len(lat) - 1))] if lat else float("nan")
    return rate, expected, speed, p(0.5), p(0.95)


def main():
    if len(sys.argv) > 1 and sys.argv[1] == "--probe-dds":
        rate, lat = listen_dds(int(sys.argv[2]), float(sys.argv[3]))
        print(json.dumps([rate, lat]))
        return
    ap = argparse.ArgumentParser()
    ap.add_argument("swarm")
    ap.add_argument("--sizes", default="forest-5,forest-40-icp")
    ap.add_argument("--modes", default="realtime,lockstep")
    ap.add_argument("--window", type=float, default=10.0)
    a = ap.parse_args()
    tmp = pathlib.Path(tempfile.mkdtemp(prefix="ros2cost-"))
    print("| scenario | UAVs | middleware | time mode | x real time | ROS msgs/s received | msgs/s the run publishes | hub put -> ROS callback p50 / p95 ms |")
    print("|---|---|---|---|---|---|---|---|")
    for name in a.sizes.split(","):
        scenario, uavs = name, uav_count(a.swarm, name)
        for mode in a.modes.split(","):
            for mw in ["dds", "rmw_zenoh"]:
                rate, expected, speed, p50, p95 = one(a.swarm, scenario, uavs, mw, mode, a.window, tmp)
                print(f"| {name} | {uavs} | {mw} | {mode} | {speed:.2f} | {rate:.0f} | {expected:.0f} | {p50:.2f} / {p95:.2f} |", flush=True)


if __name__ == "__main__":
    main()

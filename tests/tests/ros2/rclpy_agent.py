"""A vehicle's drivers, played by ROS 2 Jazzy's own rclpy on Fast DDS (no code of ours): for one
UAV whose agent runs on ROS topics (`swarm agent --sensors ros2 --dds`), it publishes a LaserScan
(two trunks ahead-left and ahead-right), an Odometry and a goal 30 m ahead, each stamped with the
same sim time, tick after tick, and records the TwistStamped the agent sends back on
/uav{id}/cmd_vel.

Usage: rclpy_agent.py ID TICKS
Prints one JSON line: the warm-up ticks, the stamps sent after them, the commands received
(stamp, x, y, yaw rate), the agent's node as rclpy's graph lists it.
"""
import json
import math
import sys
import time

import rclpy
from geometry_msgs.msg import PoseStamped, TwistStamped
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import LaserScan

uav, ticks = int(sys.argv[1]), int(sys.argv[2])
ns = f"/uav{uav}"
rclpy.init()
node = Node("vehicle_driver")
scan_pub = node.create_publisher(LaserScan, f"{ns}/scan", qos_profile_sensor_data)
odom_pub = node.create_publisher(Odometry, f"{ns}/odom", qos_profile_sensor_data)
goal_pub = node.create_publisher(PoseStamped, f"{ns}/goal", 10)
commands = []
cmd_sub = node.create_subscription(
    TwistStamped,
    f"{ns}/cmd_vel",
    lambda m: commands.append((m.header.stamp.sec + m.header.stamp.nanosec * 1e-9, m.twist.linear.x, m.twist.linear.y, m.twist.angular.z, m.header.frame_id)),
    10,
)


def ranges(n=750):
    """Two trunks of radius 0.3 m at (6, 2) and (6, -2) in the body frame, hit by the beams."""
    out = []
    for i in range(n):
        a = -math.pi + i * 2 * math.pi / n
        best = math.inf
        for cx, cy in ((6.0, 2.0), (6.0, -2.0)):
            # ray (cos a, sin a) against the circle
            b = cx * math.cos(a) + cy * math.sin(a)
            c = cx * cx + cy * cy - 0.09
            d = b * b - c
            if d >= 0 and b - math.sqrt(d) > 0:
                best = min(best, b - math.sqrt(d))
        out.append(best)
    return out


def stamp(msg, t):
    msg.header.stamp.sec = int(t)
    msg.header.stamp.nanosec = int(round((t - int(t)) * 1e9))


# Wait until the agent's subscriptions and its command publisher are matched (DDS discovery), as a
# driver would.
deadline = time.monotonic() + 30
while time.monotonic() < deadline and min(
    scan_pub.get_subscription_count(),
    odom_pub.get_subscription_count(),
    goal_pub.get_subscription_count(),
    cmd_sub.get_publisher_count(),
) == 0:
    rclpy.spin_once(node, timeout_sec=0.1)
scan_ranges = ranges()


def publish_tick(t):
    goal = PoseStamped()
    stamp(goal, t)
    goal.header.frame_id = f"uav{uav}/odom"
    goal.pose.position.x = 30.0
    goal.pose.orientation.w = 1.0
    odom = Odometry()
    stamp(odom, t)
    odom.header.frame_id, odom.child_frame_id = f"uav{uav}/odom", f"uav{uav}/base_link"
    odom.pose.pose.orientation.w = 1.0
    scan = LaserScan()
    stamp(scan, t)
    scan.header.frame_id = f"uav{uav}/base_link"
    scan.angle_min, scan.angle_increment = -math.pi, 2 * math.pi / 750
    scan.angle_max = scan.angle_min + 749 * scan.angle_increment
    scan.scan_time, scan.range_min, scan.range_max = 0.1, 0.0, 12.0
    scan.ranges = scan_ranges
    goal_pub.publish(goal)
    odom_pub.publish(odom)
    scan_pub.publish(scan)


def after(t0):
    """The commands of the ticks stamped after t0."""
    return [c for c in commands if c[0] > t0 + 1e-6]


def wait_for_commands(t0, n, seconds):
    wait = time.monotonic() + seconds
    while time.monotonic() < wait and len(after(t0)) < n:
        rclpy.spin_once(node, timeout_sec=0.02)
    return len(after(t0)) >= n


# Matched on one side is not yet matched on the other: DDS discovery is asymmetric for a few
# milliseconds, and a sample sent into that gap is lost. Warm up with ticks of their own until the
# first command comes back; from then on every tick must get its command.
for warmup in range(1, 101):
    publish_tick(round(warmup * 0.1, 9))
    if wait_for_commands(-1.0, 1, 0.5):
        break
warmup_t = round(warmup * 0.1, 9)
sent = []
for k in range(warmup + 1, warmup + ticks + 1):
    t = round(k * 0.1, 9)
    publish_tick(t)
    sent.append(t)
    # The agent answers each tick; wait for it (bounded) before the next, as the hub would.
    wait_for_commands(warmup_t, len(sent), 5)
end = time.monotonic() + 1
while time.monotonic() < end:
    rclpy.spin_once(node, timeout_sec=0.05)
commands = after(warmup_t)
graph = {
    "nodes": sorted([f"{ns_.rstrip('/')}/{n}" for n, ns_ in node.get_node_names_and_namespaces()]),
    "agent_subscriptions": {t: ty for t, ty in node.get_subscriber_names_and_types_by_node("agent", ns)},
    "agent_publishers": {t: ty for t, ty in node.get_publisher_names_and_types_by_node("agent", ns)},
}
print(json.dumps({"warmup": warmup, "sent": sent, "commands": commands, "graph": graph}))
node.destroy_node()
rclpy.shutdown()

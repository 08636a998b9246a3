#!/usr/bin/env python3
"""Flies one UAV of a running swarm from outside: eclipse-zenoh and the standard library only.

Each tick the UAV's agent publishes its view as JSON on swarm/RUN/uav/N/ext/view; this answers
on swarm/RUN/uav/N/ext/cmd with a body-frame velocity for that tick: a flocking rule (to the
goal if informed, else to the neighbours' centre; away from neighbours closer than 2 m and from
trees closer than 1.5 m, sliding past them). The token alive/ext/N tells the agent it is here;
it exits when the hub's token goes or no view has come for 15 s.

  python3 external_uav.py --run R --id N --connect tcp/127.0.0.1:7447 --user extN --password-file F
"""
import argparse
import json
import math
import threading
import time

import zenoh

p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
for flag in ("--run", "--connect", "--user", "--password-file"):
    p.add_argument(flag, required=True)
p.add_argument("--id", type=int, required=True)
a = p.parse_args()

c = zenoh.Config()
c.insert_json5("mode", '"client"')
c.insert_json5("connect/endpoints", json.dumps([a.connect]))
c.insert_json5("scouting/multicast/enabled", "false")
c.insert_json5("transport/auth/usrpwd/user", json.dumps(a.user))
c.insert_json5("transport/auth/usrpwd/password", json.dumps(open(a.password_file).read().strip()))
session = zenoh.open(c)
prefix = f"swarm/{a.run}"
SPEED, APART, MARGIN = 1.0, 2.0, 1.5


def command(v):
    """The velocity for one view, body frame (x ahead, y left)."""
    o, ns = v["odom"], v["neighbours"]
    x = y = 0.0
    if v["goal"]:  # the goal, turned from the odometry frame into the body frame
        gx, gy, c_, s_ = v["goal"][0] - o["x"], v["goal"][1] - o["y"], math.cos(o["yaw"]), math.sin(o["yaw"])
        bx, by = c_ * gx + s_ * gy, -s_ * gx + c_ * gy
        d = math.hypot(bx, by) or 1.0
        x, y = SPEED * bx / d, SPEED * by / d
    if ns:  # cohesion
        x += 0.3 * sum(n["x"] for n in ns) / len(ns)
        y += 0.3 * sum(n["y"] for n in ns) / len(ns)
    for n in ns:  # separation
        d = max(math.hypot(n["x"], n["y"]), 0.1)
        if d < APART:
            x, y = x - n["x"] / d * (APART - d), y - n["y"] / d * (APART - d)
    for t in v["trees"]:  # avoidance, with a push to the side
        d = max(math.hypot(t["x"], t["y"]), 1e-3)
        clear = max(d - t["r"], 0.05)
        if clear < MARGIN:
            k = 1.0 / clear - 1.0 / MARGIN
            x, y = x - t["x"] / d * k + 0.5 * k * t["y"] / d, y - t["y"] / d * k - 0.5 * k * t["x"] / d
    n = math.hypot(x, y)
    return (x * SPEED / n, y * SPEED / n) if n > SPEED else (x, y)


last_view = [None]  # when the last view came (monotonic seconds)


def on_view(sample):
    last_view[0] = time.monotonic()
    v = json.loads(bytes(sample.payload.to_bytes()))
    vx, vy = command(v)
    session.put(f"{prefix}/uav/{a.id}/ext/cmd", json.dumps({"tick": v["tick"], "x": vx, "y": vy}))


sub = session.declare_subscriber(f"{prefix}/uav/{a.id}/ext/view", on_view)
token = session.liveliness().declare_token(f"{prefix}/alive/ext/{a.id}")
gone = threading.Event()  # the run is over when the hub's token goes, or no view came for 15 s
watch = session.liveliness().declare_subscriber(f"{prefix}/alive/hub", lambda s: s.kind == zenoh.SampleKind.DELETE and gone.set())
while not gone.wait(1.0) and (last_view[0] is None or time.monotonic() - last_view[0] < 15.0):
    pass
session.close()

"""The routers' own view of a live run, read by a client no one here wrote (eclipse-zenoh from
PyPI) logged in as the observer: which share keys each agent session subscribes to, beside the
radio sets the hub published around the same moment.

Usage: admin.py LOCATOR RUN OBSERVER_PASSWORD UAVS
Prints one JSON line:
  {"subscribed": {"<id>": [senders...]},       # from @/*/router/subscriber/..., per agent session
   "radio": {"<id>": [[tick, [ids...]], ...]},  # radio sets from 1 s (10 ticks) before the query to 0.5 s after
   "share_wildcards": [...],                    # share subscriptions with a wildcard, by anyone
   "sessions": n}                               # agent sessions named by their alive/uav token
Radio sets are decoded from the sensor frames' postcard bytes by hand: a varint tag (13, the
frame), then the frame's first field, the radio set: tick (varint), id (varint), in_range (varint
length, varints); the rest of the frame is not read.
"""
import json
import sys
import threading
import time

import zenoh

loc, run, password, uavs = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])


def varint(b, i):
    v, shift = 0, 0
    while True:
        x = b[i]
        i += 1
        v |= (x & 0x7F) << shift
        if x < 0x80:
            return v, i
        shift += 7


def radio_set(b):
    tag, i = varint(b, 0)
    if tag != 13:
        return None
    tick, i = varint(b, i)
    uav, i = varint(b, i)
    n, i = varint(b, i)
    in_range = []
    for _ in range(n):
        x, i = varint(b, i)
        in_range.append(x)
    return tick, uav, in_range


c = zenoh.Config()
c.insert_json5("mode", '"client"')
c.insert_json5("connect/endpoints", json.dumps([loc]))
c.insert_json5("scouting/multicast/enabled", "false")
c.insert_json5("transport/auth/usrpwd/user", '"observer"')
c.insert_json5("transport/auth/usrpwd/password", json.dumps(password))
s = zenoh.open(c)

lock = threading.Lock()
radio = {}  # id -> [(tick, [ids])], newest last


def on_radio(sample):
    r = radio_set(bytes(sample.payload.to_bytes()))
    if r is None:
        return
    tick, uav, in_range = r
    with lock:
        radio.setdefault(uav, []).append((tick, in_range))
        del radio[uav][:-50]


sub = s.declare_subscriber(f"swarm/{run}/uav/*/sense", on_radio)
deadline = time.time() + 60
while time.time() < deadline:
    with lock:
        if len(radio) == uavs and all(len(v) >= 20 for v in radio.values()):
            break
    time.sleep(0.1)

with lock:
    first = min(v[-1][0] for v in radio.values())
prefix = f"swarm/{run}/"
subscribed, holders, wildcards = {}, {}, []
for r in s.get(f"@/*/router/token/swarm/{run}/alive/uav/*", timeout=5.0):
    if r.ok:
        uav = int(str(r.ok.key_expr).rsplit("/", 1)[1])
        for zid in json.loads(r.ok.payload.to_string()).get("clients", []):
            holders[zid] = uav
for r in s.get(f"@/*/router/subscriber/swarm/{run}/uav/*/share/**", timeout=5.0):
    if not r.ok:
        continue
    key = str(r.ok.key_expr).split(prefix, 1)[1]
    sender = key.split("/")[1]
    if sender == "*":
        wildcards.append(key)
        continue
    for zid in json.loads(r.ok.payload.to_string()).get("clients", []):
        if zid in holders:
            subscribed.setdefault(str(holders[zid]), []).append(int(sender))
time.sleep(0.5)
with lock:
    window = {str(u): [[t, ids] for t, ids in v if t >= first - 10] for u, v in radio.items()}
sub.undeclare()
s.close()
print(json.dumps({"subscribed": subscribed, "radio": window, "share_wildcards": wildcards, "sessions": len(holders)}))

"""A client no one here wrote (eclipse-zenoh from PyPI) against a secured hub.

Usage: client.py LOCATOR RUN PASSWORD_OF_UAV3 SECONDS
Prints one JSON line: whether a session without credentials was refused, and what UAV 3's
credentials received in SECONDS (own sensor frames, truth samples, and every key seen by a
subscription to the whole run: the router refuses it, as broader than UAV 3's keys, so it sees
only what the session receives for its other subscriptions and its own puts).
It also puts garbage on uav/2/cmd (another UAV's: the router must drop it) and on uav/3/cmd (its
own: it reaches the hub, which counts it malformed), so the test can read the hub's counts, and
declares a liveliness token that is not its own (`alive/uav/9`), which the hub would log.
"""
import json
import sys
import time

import zenoh

loc, run, password, seconds = sys.argv[1], sys.argv[2], sys.argv[3], float(sys.argv[4])


def config(user=None, pwd=None):
    c = zenoh.Config()
    c.insert_json5("mode", '"client"')
    c.insert_json5("connect/endpoints", json.dumps([loc]))
    c.insert_json5("scouting/multicast/enabled", "false")
    if user is not None:
        c.insert_json5("transport/auth/usrpwd/user", json.dumps(user))
        c.insert_json5("transport/auth/usrpwd/password", json.dumps(pwd))
    return c


refused = False
try:
    s = zenoh.open(config())
    s.close()
except Exception as e:  # zenoh.ZError: the router refused the handshake
    refused = True
    refused_error = str(e)

wrong_password_refused = False
try:
    s = zenoh.open(config("uav3", "not-the-password"))
    s.close()
except Exception:
    wrong_password_refused = True

frames, truth, keys = 0, 0, set()


def on_frame(_sample):
    global frames
    frames += 1


def on_truth(_sample):
    global truth
    truth += 1


def on_any(sample):
    keys.add(str(sample.key_expr))


s = zenoh.open(config("uav3", password))
subs = [
    s.declare_subscriber(f"swarm/{run}/uav/3/sense", on_frame),
    s.declare_subscriber(f"swarm/{run}/truth/**", on_truth),
    s.declare_subscriber(f"swarm/{run}/**", on_any),
]
time.sleep(0.5)
s.put(f"swarm/{run}/uav/2/cmd", b"\x05\x02")
s.put(f"swarm/{run}/uav/3/cmd", b"\x05\x02")
# A liveliness token that is not its own (UAV 9's, outside the scenario: the hub would log it).
token = s.liveliness().declare_token(f"swarm/{run}/alive/uav/9")
time.sleep(seconds)
for sub in subs:
    sub.undeclare()
token.undeclare()
s.close()
print(json.dumps({
    "refused": refused,
    "wrong_password_refused": wrong_password_refused,
    "frames": frames,
    "truth": truth,
    "keys": sorted(keys),
}))

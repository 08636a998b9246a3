#!/usr/bin/env python3
"""Bytes each agent process receives per tick on its TCP link to the hub, read from the kernel
with `ss -tinp` (bytes_received of each agent's socket), over a window of a live run.

Starts `swarm run SCENARIO --agents-per-process 1` (one process, one session, one socket per
agent), waits until the run is `--warmup` ticks in, samples every agent socket's bytes_received
and the hub's tick, waits `--window` seconds, samples again, and prints the median, mean and
spread of (bytes received) / (ticks elapsed) over the agent processes, then stops the run.
Needs `ss` (iproute2) and a Linux machine; the run is local, on loopback.

    python3 tools/agent_wire_bytes.py --bin target/release/swarm SCENARIO [--window 10] [--warmup 30]

This is how issue 22's "each agent process received a median of about 13.4 kB per tick" was
measured, and how the scoped subscriptions are compared with it (docs/watching-and-recording.md, "What crosses the wire").
"""
import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time


def agent_pids():
    """Pids of `swarm agent` processes (one per agent with --agents-per-process 1)."""
    pids = set()
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        try:
            cmd = open(f"/proc/{pid}/cmdline", "rb").read().split(b"\0")
        except OSError:
            continue
        if len(cmd) > 1 and cmd[1] == b"agent":
            pids.add(int(pid))
    return pids


def bytes_received(port, pids):
    """bytes_received of every TCP socket to `port` owned by one of `pids`, by pid."""
    out = subprocess.run(["ss", "-tinpH", "dst", f":{port}"], capture_output=True, text=True, check=True).stdout
    got, owner = {}, None
    for line in out.splitlines():
        m = re.search(r'pid=(\d+)', line)
        if m:
            owner = int(m.group(1))
        b = re.search(r"bytes_received:(\d+)", line)
        if b and owner in pids:
            got[owner] = got.get(owner, 0) + int(b.group(1))
    return got


def hub_tick(swarm, run, endpoint, creds):
    out = subprocess.run(
        [swarm, "tap", f"swarm/{run}/clock", "--count", "1", "--duration", "10", "--connect", endpoint,
         "--user", "observer", "--password-file", os.path.join(creds, "observer.password")],
        capture_output=True, text=True).stdout
    return json.loads(out.splitlines()[0])["msg"]["Clock"]["tick"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenario")
    ap.add_argument("--bin", default="target/release/swarm")
    ap.add_argument("--window", type=float, default=10.0)
    ap.add_argument("--warmup", type=int, default=30)
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        run = f"wirebytes-{os.getpid()}"
        out = os.path.join(tmp, "run")
        p = subprocess.Popen([a.bin, "run", a.scenario, "--run", run, "--out", out, "--agents-per-process", "1", "--no-mcap", "--quiet"],
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        # The run folder's hub.txt holds the hub's locators, one a line, once the hub is up.
        endpoint, deadline = None, time.time() + 120
        while endpoint is None and time.time() < deadline and p.poll() is None:
            try:
                with open(os.path.join(out, "hub.txt")) as f:
                    m = next((re.fullmatch(r"(tcp/127\.0\.0\.1:(\d+))", l.strip()) for l in f if l.startswith("tcp/")), None)
                if m:
                    endpoint, port = m.group(1), m.group(2)
            except FileNotFoundError:
                pass
            if endpoint is None:
                time.sleep(0.2)
        if endpoint is None:
            sys.exit("the hub never wrote where it listens (hub.txt)")
        creds = os.path.join(out, "credentials")
        while hub_tick(a.bin, run, endpoint, creds) < a.warmup:
            time.sleep(0.5)
        pids = agent_pids()
        t0, b0 = hub_tick(a.bin, run, endpoint, creds), bytes_received(port, pids)
        time.sleep(a.window)
        t1, b1 = hub_tick(a.bin, run, endpoint, creds), bytes_received(port, pids)
        p.terminate()
        p.wait()
        per_tick = sorted((b1[pid] - b0[pid]) / (t1 - t0) for pid in b0 if pid in b1)
        print(json.dumps({
            "scenario": a.scenario, "agents": len(per_tick), "ticks": t1 - t0,
            "median_bytes_per_tick": statistics.median(per_tick),
            "mean_bytes_per_tick": statistics.fmean(per_tick),
            "min_bytes_per_tick": per_tick[0], "max_bytes_per_tick": per_tick[-1],
        }))


if __name__ == "__main__":
    main()

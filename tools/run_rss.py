#!/usr/bin/env python3
"""Resident memory and speed of one `swarm run`: the launcher, hub and agent processes.

Runs `swarm run ARGS... --run ID --out DIR --quiet`, samples /proc every 0.1 s for the processes
whose command line names the run id, and prints the peak of the summed resident memory (VmRSS),
the most processes seen at once, the wall time, and x real time (`sim_speed` of summary.json).
Linux only. Usage: python3 tools/run_rss.py [--bin PATH] -- forest-5 --agents-per-process 5
"""
import argparse
import json
import pathlib
import subprocess
import tempfile
import time


def swarm_pids(run_id):
    for p in pathlib.Path("/proc").iterdir():
        if not p.name.isdigit():
            continue
        try:
            if run_id.encode() in (p / "cmdline").read_bytes():
                yield p
        except OSError:
            continue


def rss_kib(proc_dir):
    try:
        for line in (proc_dir / "status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    except OSError:
        pass
    return 0


def main():
    root = pathlib.Path(__file__).resolve().parent.parent
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bin", default=str(root / "target" / "release" / "swarm"))
    ap.add_argument("args", nargs="+")
    a = ap.parse_args()
    run_id = f"rss-{int(time.time())}-{time.monotonic_ns() % 100000}"
    with tempfile.TemporaryDirectory() as tmp:
        out = pathlib.Path(tmp) / "run"
        start = time.monotonic()
        child = subprocess.Popen([a.bin, "run", *a.args, "--run", run_id, "--out", str(out), "--quiet"],
                                 stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        peak_kib, peak_procs = 0, 0
        while child.poll() is None:
            procs = list(swarm_pids(run_id))
            peak_kib = max(peak_kib, sum(rss_kib(p) for p in procs))
            peak_procs = max(peak_procs, len(procs))
            time.sleep(0.1)
        wall_s = time.monotonic() - start
        s = json.loads((out / "summary.json").read_text())
        n = s["uav_count"]
        print(f"{' '.join(a.args)}: {n} UAVs, {peak_procs} processes, peak RSS {peak_kib / 1024:.0f} MiB "
              f"({peak_kib / 1024 / n:.1f} MiB per UAV), wall {wall_s:.1f} s, "
              f"x real time {s['sim_speed']:.1f}, end {s['end_reason']}, collisions {s['collisions']}")


if __name__ == "__main__":
    main()

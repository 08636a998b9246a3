#!/usr/bin/env python3
"""x real time and CPU seconds per sim second by role, over a window of sim time of one run.

Usage: python3 tools/window_cpu.py FROM_S TO_S SWARM-BINARY scale --scenarios S [ARGS...]
(e.g. `20 120 target/release/swarm scale --scenarios forest-1000-icp --time-limit 120`). Runs
the command with `--out` a fresh folder, and every 0.5 s notes the wall clock, the last
sim time the recorder wrote to the run's `trajectories.csv`, and the CPU seconds (user + sys) of the
command's processes by role: `hub`, `agent` (agents and agent hosts) and `launcher` (the
recorder's process). Prints the window's x real time and CPU per sim second of each role, and
writes the samples as JSON beside the folder for other windows.

Why: `tools/proc_cpu.py` gives a whole command's CPU, so a window after the start had to be the
difference of two runs of different lengths, each with its own start: at forest-1000-icp that
difference swung by more than the changes measured. One run's own clock is steadier.
"""
import glob
import json
import os
import subprocess
import sys
import tempfile
import time

from proc_cpu import TICK, tree  # the same /proc walk, beside this file
from proc_cpu import role as proc_role


def role(pid):
    """`hub`, `agent` or `launcher` (`swarm scale` or `swarm run`) for a swarm process, else None:
    `proc_cpu.py`'s role without its scenario."""
    r = proc_role(pid)
    if r is None:
        return None
    kind = r.split()[0]
    return kind if kind in ('hub', 'agent') else 'launcher'


def last_time(folder):
    """The last sim time [s] written to the run's trajectories.csv, -1 before any."""
    files = glob.glob(f'{folder}/*/trajectories.csv')
    if not files:
        return -1
    try:
        with open(files[0], 'rb') as f:
            f.seek(0, 2)
            f.seek(max(0, f.tell() - 4096))
            lines = f.read().split(b'\n')
    except OSError:
        return -1
    for line in reversed(lines[:-1]):
        try:
            return float(line.split(b',')[1])
        except (ValueError, IndexError):
            continue
    return -1


def sample(cmd, folder):
    """Runs `cmd` into `folder`; returns [(wall s, last sim s, {role: CPU s})]."""
    proc = subprocess.Popen(cmd + ['--out', folder], stdout=subprocess.DEVNULL)
    cpu_of, samples, t0 = {}, [], time.time()
    while proc.poll() is None:
        for pid in tree(proc.pid):
            r = role(pid)
            if r is None:
                continue
            try:
                f = open(f'/proc/{pid}/stat').read().rsplit(')', 1)[1].split()
                cpu_of[pid] = (r, (int(f[11]) + int(f[12])) / TICK)
            except OSError:
                pass  # gone: it keeps its last sample
        by_role = {}
        for r, c in cpu_of.values():
            by_role[r] = by_role.get(r, 0.0) + c
        samples.append((time.time() - t0, last_time(folder), by_role))
        time.sleep(0.5)
    return samples


def window(samples, from_s, to_s):
    """x real time and {role: CPU s per sim s} between sim times from_s and to_s."""
    def at(t):
        return next((s for s in samples if s[1] >= t - 1e-6), None)
    a, b = at(from_s), at(to_s)
    if a is None or b is None or b[1] <= a[1]:
        return None
    sim = b[1] - a[1]
    return sim / (b[0] - a[0]), {r: (b[2].get(r, 0.0) - a[2].get(r, 0.0)) / sim for r in b[2]}


def main():
    if len(sys.argv) < 5:
        sys.exit(__doc__)
    from_s, to_s, cmd = float(sys.argv[1]), float(sys.argv[2]), sys.argv[3:]
    folder = tempfile.mkdtemp(prefix='window-', dir='runs' if os.path.isdir('runs') else None)
    samples = sample(cmd, folder)
    json.dump(samples, open(folder + '.json', 'w'))
    w = window(samples, from_s, to_s)
    if w is None:
        sys.exit(f'the run did not cover sim s {from_s}-{to_s} (samples in {folder}.json)')
    x, cpu = w
    by_role = ' / '.join(f'{cpu.get(r, 0.0):.3f}' for r in ('agent', 'hub', 'launcher'))
    print(f'sim s {from_s:g}-{to_s:g}: {x:.3f}x real time, {sum(cpu.values()):.3f} CPU-s per sim s '
          f'(agents / hub / launcher {by_role}); run folder {folder}')


if __name__ == '__main__':
    main()

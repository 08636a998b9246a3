#!/usr/bin/env python3
"""CPU seconds of every process of a command's tree, by role: a run's launcher, hub and agents.

Usage: python3 tools/proc_cpu.py SWARM-BINARY ARGS...  (e.g. `target/release/swarm scale
--scenarios forest-40-icp,forest-100 --time-limit 60`). Runs the command, samples /proc every
0.3 s for the swarm processes under it (user + sys time of each, kept at its last sample, so a
process that ends keeps what it had 0.3 s before), prints the command's last lines and then the
CPU seconds summed by role (`hub`, `agent`, `scale`, `run`) and scenario (from `--run`).
Why: `/usr/bin/time` gives one total; an agent-host change is judged by the hosts' share.
"""
import collections
import os
import re
import subprocess
import sys
import threading
import time

TICK = os.sysconf('SC_CLK_TCK')


def tree(root):
    """The pids under `root` (itself included)."""
    kids = collections.defaultdict(list)
    for d in os.listdir('/proc'):
        if not d.isdigit():
            continue
        try:
            st = open(f'/proc/{d}/stat').read()
            kids[int(st.rsplit(')', 1)[1].split()[1])].append(int(d))
        except OSError:
            pass
    out, todo = [], [root]
    while todo:
        x = todo.pop()
        out.append(x)
        todo += kids.get(x, [])
    return out


def role(pid):
    """`agent forest-40-icp`, `hub forest-100`, `scale`...; None for another process."""
    try:
        a = open(f'/proc/{pid}/cmdline').read().split('\0')
    except OSError:
        return None
    if len(a) < 2 or a[1] not in ('hub', 'agent', 'scale', 'run'):
        return None
    run = a[a.index('--run') + 1] if '--run' in a else ''
    # run ids: <scenario>-<unix secs>-<pid>; in a `swarm scale` study <scenario> is <name>-NN-<name>.
    scenario = re.sub(r'-\d+-\d+$', '', run)
    study = re.fullmatch(r'(.+)-\d+-\1', scenario)
    scenario = study.group(1) if study else scenario
    return f'{a[1]} {scenario}'.strip()


def main():
    p = subprocess.Popen(sys.argv[1:], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    lines, seen, t0 = [], {}, time.time()
    reader = threading.Thread(target=lambda: lines.extend(p.stdout))
    reader.start()
    while p.poll() is None:
        for pid in tree(p.pid):
            r = role(pid)
            try:
                f = open(f'/proc/{pid}/stat').read().rsplit(')', 1)[1].split()
            except OSError:
                continue
            if r is not None:
                seen[(pid, r)] = (int(f[11]) + int(f[12])) / TICK
        time.sleep(0.3)
    reader.join()
    sys.stdout.write(''.join(lines[-12:]))
    by = collections.defaultdict(float)
    for (_, r), cpu in seen.items():
        by[r] += cpu
    print('CPU s by role:', {k: round(v, 1) for k, v in sorted(by.items())},
          'total', round(sum(by.values()), 1), 'wall', round(time.time() - t0, 1))
    sys.exit(p.returncode)


if __name__ == '__main__':
    main()

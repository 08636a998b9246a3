"""How fast the environments step (a study, not a test): agent-steps per second of
`uavswarm.SwarmParallelEnv` (every UAV an agent, constant actions) for 5, 40 and 100 UAVs, one
environment and two side by side (`step_send` on both, then `step_receive` on both), each row
followed by VMAS's flocking at the same size on the CPU (the peer baseline
`vmas_flocking.py`: agents with LIDAR among obstacles, our forest's trees as its obstacles, our
LIDAR's beams as its rays, two torch threads), measured in the same session.

Usage: python examples/python/env_throughput.py --vmas-python /opt/vmas/bin/python \\
           --vmas-script ../shared/baselines/vmas_flocking.py [--scenarios forest-5,forest-40-icp,forest-100-icp]
Prints a Markdown table.
"""
import argparse
import json
import subprocess
import tempfile
import time

import numpy as np

import uavswarm

STEPS = {5: 200, 40: 60, 100: 30}


def ours(scenario, num_envs, steps, tmp):
    envs = [uavswarm.SwarmParallelEnv(scenario, time_limit_s=600.0, run_dir=tmp) for _ in range(num_envs)]
    for i, e in enumerate(envs):
        e.reset(seed=i + 1)
    act = np.array([0.5, 0.1, 0.0], np.float32)

    def tick():
        for e in envs:
            e.step_send({a: act for a in e.agents})
        for e in envs:
            e.step_receive()

    for _ in range(5):
        tick()
    t = time.perf_counter()
    for _ in range(steps):
        tick()
    wall = time.perf_counter() - t
    agents = sum(len(e.agents) for e in envs)
    trees = json.loads((envs[0]._run.out / "world.json").read_text())["trees"] if (envs[0]._run.out / "world.json").exists() else []
    for e in envs:
        e.close()
    return agents * steps / wall, steps * num_envs / wall, len(trees)


def vmas(py, script, agents, obstacles, steps):
    o = subprocess.run([py, script, "--agents", str(agents), "--obstacles", str(obstacles), "--rays", "750",
                        "--threads", "2", "--steps", str(steps)], capture_output=True, text=True, timeout=3600)
    if o.returncode != 0:
        return None
    r = json.loads(o.stdout.strip().splitlines()[-1])
    return r["steps_per_s"] * agents, r


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--scenarios", default="forest-5,forest-40-icp,forest-100-icp")
    ap.add_argument("--vmas-python", default="/opt/vmas/bin/python")
    ap.add_argument("--vmas-script", default="../shared/baselines/vmas_flocking.py")
    a = ap.parse_args()
    tmp = tempfile.mkdtemp(prefix="throughput-")
    print("| scenario | UAVs | ours, 1 env: agent-steps/s | ours, 2 envs: agent-steps/s | VMAS flocking, 1 env: agent-steps/s | ours (1 env) / VMAS |")
    print("|---|---|---|---|---|---|")
    for sc in a.scenarios.split(","):
        count = uavswarm.SwarmParallelEnv(sc).sc["swarm"]["count"]
        steps = STEPS.get(count, 30)
        one, _, trees = ours(sc, 1, steps, tmp)
        two, _, _ = ours(sc, 2, steps, tmp)
        peer = vmas(a.vmas_python, a.vmas_script, count, trees, max(10, steps // 2))
        p = f"{peer[0]:.0f}" if peer else "failed"
        ratio = f"{one / peer[0]:.1f}x" if peer else "-"
        print(f"| {sc} | {count} | {one:.0f} | {two:.0f} | {p} | {ratio} |", flush=True)


if __name__ == "__main__":
    main()

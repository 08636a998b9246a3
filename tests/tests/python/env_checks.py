"""The Python package `uavswarm` held to the RL community's own acceptance tests, on the real
swarm (the `swarm` binary of SWARM_BIN): PettingZoo's parallel_api_test and parallel_seed_test,
Gymnasium's check_env; the same seed and the same actions give the same episode; a bad action
raises naming the agent and leaves nothing running; load_run reads a finished run (run.mcap
through the `mcap` package).

Usage: env_checks.py RUN_DIR
Prints one JSON line of what it measured. Exits non-zero on a failed check.
"""
import json
import math
import os
import subprocess
import sys
import time

import gymnasium
import numpy as np
from gymnasium.utils.env_checker import check_env
from pettingzoo.test import parallel_api_test, parallel_seed_test

import uavswarm

run_dir = sys.argv[1]
out = {}
LIMIT_S = 3.0  # each episode: 30 ticks of forest-5


def swarm_processes(run_id):
    """The processes of run `run_id` still running (the launcher's children carry it in argv)."""
    o = subprocess.run(["pgrep", "-f", run_id], capture_output=True, text=True)
    return [int(p) for p in o.stdout.split()]


t = time.monotonic()
env = uavswarm.SwarmParallelEnv("forest-5", time_limit_s=LIMIT_S, run_dir=run_dir)
parallel_api_test(env, num_cycles=100)
env.close()
out["parallel_api_test_s"] = time.monotonic() - t

t = time.monotonic()
parallel_seed_test(lambda: uavswarm.SwarmParallelEnv("forest-5", time_limit_s=LIMIT_S, run_dir=run_dir), num_cycles=100)
out["parallel_seed_test_s"] = time.monotonic() - t

t = time.monotonic()
g = gymnasium.make("uavswarm/Forest5-v0", time_limit_s=LIMIT_S, run_dir=run_dir)
check_env(g.unwrapped)
g.close()
out["check_env_s"] = time.monotonic() - t


def episode(seed, env):
    """Observations and rewards of one episode flown with fixed actions (ahead, a little left)."""
    obs, _ = env.reset(seed=seed)
    trace = [np.concatenate([obs[a] for a in sorted(obs)])]
    rewards = []
    while env.agents:
        obs, r, _, _, _ = env.step({a: np.array([0.8, 0.1, 0.0], np.float32) for a in env.agents})
        trace.append(np.concatenate([obs[a] for a in sorted(obs)]))
        rewards.append([r[a] for a in sorted(r)])
    return np.stack(trace), np.array(rewards), env.run_folder


env = uavswarm.SwarmParallelEnv("forest-5", time_limit_s=LIMIT_S, run_dir=run_dir)
a_obs, a_rew, a_run = episode(11, env)
b_obs, b_rew, b_run = episode(11, env)
c_obs, _, _ = episode(12, env)
env.close()
assert a_obs.tobytes() == b_obs.tobytes() and a_rew.tobytes() == b_rew.tobytes(), "the same seed and actions differ"
assert a_obs.shape == c_obs.shape and a_obs.tobytes() != c_obs.tobytes(), "another seed is another forest"
out["episode_ticks"] = len(a_obs) - 1
out["episode_return_mean"] = float(a_rew.sum(axis=0).mean())
assert out["episode_return_mean"] > 0.5, f"flying ahead is progress towards the goal: {out}"

# Bad input: a NaN, and the wrong shape; each names the agent and the value, and stops the run.
for bad, want in [(np.array([math.nan, 0.0, 0.0]), "finite"), (np.zeros(2), "shape")]:
    env = uavswarm.SwarmParallelEnv("forest-5", time_limit_s=LIMIT_S, run_dir=run_dir)
    env.reset(seed=1)
    run_id = env._run.run_id
    acts = {a: np.zeros(3, np.float32) for a in env.agents}
    acts["uav2"] = bad
    try:
        env.step(acts)
        raise AssertionError(f"a {want} action was taken")
    except ValueError as e:
        assert "uav2" in str(e) and want in str(e), str(e)
        out.setdefault("bad_action_errors", []).append(str(e))
    deadline = time.monotonic() + 20
    while swarm_processes(run_id) and time.monotonic() < deadline:
        time.sleep(0.2)
    assert not swarm_processes(run_id), f"processes left after a bad action: {swarm_processes(run_id)}"

# A Python process killed outright takes its swarm with it.
child = subprocess.Popen([sys.executable, "-c", f"""
import os, signal, uavswarm
env = uavswarm.SwarmParallelEnv("forest-5", time_limit_s=60.0, run_dir={run_dir!r})
env.reset(seed=2)
print(env._run.run_id, flush=True)
os.kill(os.getpid(), signal.SIGKILL)
"""], stdout=subprocess.PIPE, text=True)
run_id = child.stdout.readline().strip()
child.wait(timeout=60)
deadline = time.monotonic() + 20
while swarm_processes(run_id) and time.monotonic() < deadline:
    time.sleep(0.2)
left = swarm_processes(run_id)
assert run_id and not left, f"a killed Python left its swarm running: {left}"
out["killed_python_left"] = len(left)

# The run folder of an episode as data.
run = uavswarm.load_run(a_run)
assert run.summary["schema"] == "swarm.summary.v1"
assert len(run.trajectories) == 5 * out["episode_ticks"], (len(run.trajectories), out["episode_ticks"])
assert set(run.trajectories["id"]) == {1, 2, 3, 4, 5}
assert {"mean_error_m", "id"} <= set(run.localization.columns)
assert len(run.agent_states) > 0 and len(run.connectivity) > 0
assert len(run.world["trees"]) == run.summary["trees"]
out["load_run_rows"] = {"trajectories": len(run.trajectories), "agent_states": len(run.agent_states),
                        "localization": len(run.localization), "connectivity": len(run.connectivity)}

# run.mcap, read by Foxglove's own `mcap` package (a run flown with it: the environments skip it).
folder = os.path.join(run_dir, "with-mcap")
subprocess.run([uavswarm.find_swarm(), "run", "forest-5", "--set", f"end.time_limit_s={LIMIT_S}", "--out", folder, "--quiet"],
               check=True, capture_output=True, timeout=300)
messages = list(uavswarm.load_run(folder).mcap_messages())
topics = sorted({m[0] for m in messages})
assert len(messages) > 30 and topics, topics
out["mcap"] = {"messages": len(messages), "topics": topics}
print(json.dumps(out))

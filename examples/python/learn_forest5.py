"""A learning study on the real swarm (not a test): PPO (Stable-Baselines3) learns to fly UAV 1
of forest-5 to the goal among four K21 UAVs, with 20 % burst loss on every inter-agent link
(burst-20.toml), and its learning curve is plotted against the built-in K21 flying the same UAV
on the same task, same seeds.

The task's return, the same for both: uavswarm's default reward of UAV 1 (metres covered towards
the goal, -1 per tick in contact, -(1 m - d) when another UAV is closer than 1 m) plus 10 once
UAV 1 is inside the goal disc, over 60 s of flight (an episode ends there, or when every UAV has
arrived). K21's is computed from its runs' trajectories.csv with the same formula.

Usage (a venv with `pip install -e python[train]`, and the swarm binary built):
    python examples/python/learn_forest5.py --steps 60000 --out docs/learning-forest5.png
Prints the curve's points and the wall time, and writes the plot (PNG) and a JSON beside it.
"""
import argparse
import json
import math
import pathlib
import subprocess
import tempfile
import time

import numpy as np

import uavswarm
from uavswarm.rewards import Weights, default_reward

HERE = pathlib.Path(__file__).resolve().parent
EXPERIMENT = str(HERE / "burst-20.toml")
LIMIT_S = 60.0
GOAL_BONUS = 10.0


class Task:
    """UAV 1's return on the task, from its truth bodies tick by tick."""

    def __init__(self, goal, radius):
        self.goal, self.radius, self.arrived = goal, radius, False

    def reward(self, before, after, ended):
        r = default_reward(Weights(goal=0.0), self.goal, before, after, {"ended": ended})
        if not self.arrived and math.hypot(after["x"] - self.goal[0], after["y"] - self.goal[1]) <= self.radius:
            self.arrived = True
            r += GOAL_BONUS
        return r


def k21_return(seed, sc, swarm, tmp):
    """UAV 1's return on the task when K21 flies it (a plain run of the same seed)."""
    out = pathlib.Path(tmp) / f"k21-{seed}"
    subprocess.run([swarm, "run", "forest-5", "--experiment", EXPERIMENT, "--seed", str(seed), "--set",
                    f"end.time_limit_s={LIMIT_S}", "--out", str(out), "--quiet", "--no-mcap"], check=True, capture_output=True)
    tr = uavswarm.load_run(out).trajectories
    rows = tr[tr["id"] == 1].sort_values("tick")
    task = Task(tuple(sc["swarm"]["goal"]), sc["end"]["goal_radius_m"])
    total, before = 0.0, None
    for row in rows.itertuples():
        after = {"x": row.x_m, "y": row.y_m, "colliding": bool(row.colliding), "agent_distance_m": row.agent_distance_m}
        total += task.reward(before, after, None)
        before = after
    return total


class TaskEnv(uavswarm.SwarmEnv):
    """SwarmEnv on the study's task, one seed per episode from a fixed list."""

    def __init__(self, seeds, **kw):
        super().__init__("forest-5", learner=1, experiment=EXPERIMENT, time_limit_s=LIMIT_S, **kw)
        sc = self.par.sc
        self.seeds, self.next = seeds, 0
        self.task = None
        self.par.reward_fn = lambda i, before, after, truth, default: self.task.reward(before, after, truth.get("ended"))
        self.goal, self.radius = tuple(sc["swarm"]["goal"]), sc["end"]["goal_radius_m"]

    def reset(self, *, seed=None, options=None):
        self.task = Task(self.goal, self.radius)
        seed = self.seeds[self.next % len(self.seeds)] if seed is None else seed
        self.next += 1
        return super().reset(seed=seed, options=options)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--steps", type=int, default=60000)
    ap.add_argument("--seeds", type=int, default=8, help="training seeds 1..N, cycled")
    ap.add_argument("--eval-every", type=int, default=10000)
    ap.add_argument("--out", default="docs/learning-forest5.png")
    ap.add_argument("--replot", help="draw the plot again from this JSON (what a run wrote) and stop")
    a = ap.parse_args()
    if a.replot:
        plot(json.loads(pathlib.Path(a.replot).read_text()), pathlib.Path(a.out))
        return

    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import BaseCallback

    tmp = tempfile.mkdtemp(prefix="learn-forest5-")
    seeds = list(range(1, a.seeds + 1))
    env = TaskEnv(seeds, run_dir=tmp)
    swarm = env.par.swarm
    started = time.monotonic()
    k21 = [k21_return(s, env.par.sc, swarm, tmp) for s in seeds]

    def evaluate(model):
        ev = TaskEnv(seeds, run_dir=tmp)
        returns = []
        for s in seeds:
            obs, _ = ev.reset(seed=s)
            total, done = 0.0, False
            while not done:
                act, _ = model.predict(obs, deterministic=True)
                obs, r, term, trunc, _ = ev.step(act)
                total, done = total + r, term or trunc
            returns.append(total)
        ev.close()
        return returns

    curve = []

    class Curve(BaseCallback):
        def __init__(self):
            super().__init__()
            self.next_eval = 0

        def _on_step(self):
            if self.num_timesteps >= self.next_eval:
                r = evaluate(self.model)
                curve.append({"steps": self.num_timesteps, "mean": float(np.mean(r)), "std": float(np.std(r)),
                              "wall_s": time.monotonic() - started})
                print(json.dumps(curve[-1]), flush=True)
                self.next_eval += a.eval_every
            return True

    model = PPO("MlpPolicy", env, n_steps=1024, batch_size=256, learning_rate=3e-4, gamma=0.99, seed=0, verbose=0)
    model.learn(total_timesteps=a.steps, callback=Curve())
    r = evaluate(model)
    # PPO collects whole rollouts, so the last model was trained on a little more than asked.
    curve.append({"steps": int(model.num_timesteps), "mean": float(np.mean(r)), "std": float(np.std(r)),
                  "wall_s": time.monotonic() - started})
    env.close()
    wall = time.monotonic() - started
    result = {"curve": curve, "k21": k21, "k21_mean": float(np.mean(k21)), "wall_s": wall, "steps": a.steps, "seeds": seeds}
    plot(result, pathlib.Path(a.out))
    print(json.dumps({"wall_s": wall, "k21_mean": result["k21_mean"], "final_mean": curve[-1]["mean"]}))


def plot(result, out):
    """The learning curve against K21, as PNG, and the numbers as JSON beside it."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    curve, k21, seeds = result["curve"], result["k21"], result["seeds"]
    out.parent.mkdir(parents=True, exist_ok=True)
    xs = [c["steps"] for c in curve]
    ms = np.array([c["mean"] for c in curve])
    sd = np.array([c["std"] for c in curve])
    fig, ax = plt.subplots(figsize=(7, 4), dpi=120)
    ax.plot(xs, ms, marker="o", label="PPO (Stable-Baselines3), UAV 1")
    ax.fill_between(xs, ms - sd, ms + sd, alpha=0.2)
    ax.axhline(np.mean(k21), color="tab:green", linestyle="--", label=f"K21 flying UAV 1 ({np.mean(k21):.1f})")
    ax.set_xlabel("training steps (ticks of the real swarm)")
    ax.set_ylabel(f"return over {len(seeds)} seeds (mean ± sd)")
    ax.set_title("forest-5, 20 % burst loss: UAV 1 learns among four K21 UAVs")
    ax.legend(loc="lower right")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out)
    out.with_suffix(".json").write_text(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()

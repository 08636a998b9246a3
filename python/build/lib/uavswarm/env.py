"""PettingZoo and Gymnasium environments over the real swarm.

`SwarmParallelEnv`: each agent a UAV of a scenario (a built-in name or a file); one `step` is one
lockstep tick of the real hub and agents over Zenoh, with the scenario's netem faults in force;
`reset(seed=N)` flies a new run with master seed N, so the same seed and the same actions give the
same episode, byte for byte. The UAVs that do not learn fly the scenario's own controller.

`SwarmEnv`: Gymnasium's single-agent form, one learning UAV among the others.

Observations: `uavswarm.observation` (what the UAV's onboard stack knows). Actions: a body-frame
velocity and a yaw rate, by default normalized, `Box(-1, 1, (3,))` times the scenario's speed and
yaw-rate limits (`normalized_actions=False`: `Box([-v, -v, -w], [v, v, w])` in m/s and rad/s). Rewards: `uavswarm.rewards`. Terminations and truncations: the hub's own end rules (the
goal rule met: terminated; the time limit or a stop: truncated; a UAV whose agent is gone:
terminated).
"""
from __future__ import annotations

import math
from typing import Any, Optional, Sequence

import gymnasium
import numpy as np
from pettingzoo import ParallelEnv

from ._run import Run, find_swarm, resolve_scenario
from .observation import Layout, encode
from .rewards import RewardFn, Weights, default_reward

#: How long a tick may wait for the learning loop's commands by default [ms]: a day, so a
#: policy update between rollouts never makes a UAV hover on its own.
STEP_WAIT_MS = 86_400_000


class SwarmParallelEnv(ParallelEnv):
    """A swarm whose UAVs `learners` (default: all) are the PettingZoo agents `uav{id}`."""

    metadata = {"name": "uavswarm_v0", "render_modes": []}

    def __init__(
        self,
        scenario: str = "forest-5",
        learners: Optional[Sequence[int]] = None,
        *,
        layout: Layout = Layout(),
        weights: Weights = Weights(),
        reward_fn: Optional[RewardFn] = None,
        time_limit_s: Optional[float] = None,
        set_fields: Sequence[str] = (),
        experiment: Optional[str] = None,
        swarm: Optional[str] = None,
        run_dir: Optional[str] = None,
        reply_timeout_s: float = 120.0,
        normalized_actions: bool = True,
    ) -> None:
        self.swarm = find_swarm(swarm)
        self.scenario = scenario
        self.sc = resolve_scenario(self.swarm, scenario)
        count = int(self.sc["swarm"]["count"])
        ids = sorted(set(learners)) if learners is not None else list(range(1, count + 1))
        bad = [i for i in ids if not 1 <= i <= count]
        if bad:
            raise ValueError(f"learners {bad} are not UAVs of {scenario!r} (ids 1..{count})")
        self.learner_ids = ids
        self.possible_agents = [f"uav{i}" for i in ids]
        self.agents: list[str] = []
        self.layout = layout
        self.weights = weights
        self.reward_fn = reward_fn
        self.goal = tuple(self.sc["swarm"]["goal"])
        body = self.sc["body"]
        self.max_speed = float(body["max_speed_mps"])
        self.max_yaw_rate = math.radians(float(body["max_yaw_rate_dps"]))
        self.sets = [f"time.tick_timeout_ms={STEP_WAIT_MS}"] + list(set_fields)
        if time_limit_s is not None:
            self.sets.append(f"end.time_limit_s={float(time_limit_s)}")
        self.run_dir = run_dir
        self.reply_timeout_s = reply_timeout_s
        self.extra_args = ["--experiment", str(experiment)] if experiment else []
        low, high = layout.bounds()
        self._obs_space = gymnasium.spaces.Box(low, high, dtype=np.float32)
        self._scale = np.array([self.max_speed, self.max_speed, self.max_yaw_rate], np.float64)
        a = np.ones(3, np.float32) if normalized_actions else self._scale.astype(np.float32)
        self._act_space = gymnasium.spaces.Box(-a, a, dtype=np.float32)
        self.normalized_actions = normalized_actions
        self._run: Optional[Run] = None
        self._tick = 0
        self._bodies: dict[int, dict[str, Any]] = {}
        self._last_obs: dict[str, np.ndarray] = {}

    def observation_space(self, agent: str) -> gymnasium.spaces.Box:
        return self._obs_space

    def action_space(self, agent: str) -> gymnasium.spaces.Box:
        return self._act_space

    # -- episodes ---------------------------------------------------------------------------

    def reset(self, seed: Optional[int] = None, options: Optional[dict] = None):
        self.close()
        self._run = Run(self.swarm, self.scenario, self.learner_ids, seed, out_dir=self.run_dir,
                        sets=self.sets, extra_args=self.extra_args, reply_timeout_s=self.reply_timeout_s)
        line = self._run.read()
        if "end" in line:
            raise RuntimeError(f"the run ended before its first tick: {line}")
        self.agents = list(self.possible_agents)
        self._bodies = {}
        obs = self._take(line)
        return obs, {a: {"tick": self._tick, "run": str(self._run.out)} for a in self.agents}

    def _take(self, line: dict[str, Any]) -> dict[str, np.ndarray]:
        """Observations of a tick's line (and the truth it carries, kept for the rewards)."""
        self._tick = int(line["tick"])
        views = line.get("views", {})
        obs = {}
        for a in self.agents:
            v = views.get(a[3:])
            if v is not None:
                obs[a] = encode(v, self.layout)
        self._last_obs.update(obs)
        return obs

    def _check(self, actions: dict[str, Any]) -> dict[int, dict[str, float]]:
        cmds = {}
        for a in self.agents:
            if a not in actions:
                raise ValueError(f"no action for agent {a!r} (every live agent needs one)")
            act = np.asarray(actions[a], dtype=np.float64)
            if act.shape != (3,):
                raise ValueError(f"agent {a!r}: an action is (vx, vy, yaw_rate), shape (3,); got shape {act.shape}: {actions[a]!r}")
            if not np.all(np.isfinite(act)):
                raise ValueError(f"agent {a!r}: an action must be finite; got {act.tolist()}")
            lo, hi = self._act_space.low, self._act_space.high
            x, y, w = np.clip(act, lo, hi) * (self._scale if self.normalized_actions else 1.0)
            cmds[int(a[3:])] = {"x": float(x), "y": float(y), "yaw_rate": float(w)}
        extra = [a for a in actions if a not in self.agents]
        if extra:
            raise ValueError(f"actions for {extra}, which are not live agents ({self.agents})")
        return cmds

    def step(self, actions: dict[str, Any]):
        self.step_send(actions)
        return self.step_receive()

    def step_send(self, actions: dict[str, Any]) -> None:
        """The first half of `step`: checks the actions and sends them (a bad one stops the run
        and raises `ValueError` naming the agent and the value). With `step_receive`, several
        swarms step side by side: send to each, then receive from each."""
        if self._run is None:
            raise RuntimeError("call reset() before step()")
        try:
            cmds = self._check(actions)
        except ValueError:
            self.close()
            raise
        self._run.send(self._tick, cmds)

    def step_receive(self):
        """The second half of `step`: the next tick's observations, rewards, terminations,
        truncations and infos."""
        if self._run is None:
            raise RuntimeError("call reset() and step_send() first")
        line = self._run.read()
        truth = line.get("truth") or {}
        bodies = {int(b["id"]): b for b in truth.get("bodies", [])}
        end = line.get("end")
        obs = {} if end else self._take(line)
        rewards, terms, truncs, infos = {}, {}, {}, {}
        for a in self.agents:
            i = int(a[3:])
            after = bodies.get(i)
            default = default_reward(self.weights, self.goal, self._bodies.get(i), after, truth) if after else 0.0
            rewards[a] = float(self.reward_fn(i, self._bodies.get(i), after, truth, default)) if (self.reward_fn and after) else default
            gone = end is None and a not in obs
            terms[a] = end == "Goal" or gone
            truncs[a] = end is not None and end != "Goal"
            infos[a] = {"tick": self._tick, "colliding": bool(after and after.get("colliding")), "end": end}
            if a not in obs:
                obs[a] = self._last_obs.get(a, np.zeros(self.layout.size, np.float32))
        self._bodies.update(bodies)
        self.agents = [a for a in self.agents if not (terms[a] or truncs[a])]
        return obs, rewards, terms, truncs, infos

    def close(self) -> None:
        if self._run is not None:
            self._run.close()
            self._run = None
        self.agents = []

    @property
    def run_folder(self) -> Optional[str]:
        """The current (or last) run's folder."""
        return str(self._run.out) if self._run else None

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # noqa: BLE001 - interpreter shutdown
            pass


class SwarmEnv(gymnasium.Env):
    """One learning UAV (`learner`, default 1) among the scenario's others, as a Gymnasium env."""

    metadata = {"render_modes": []}

    def __init__(self, scenario: str = "forest-5", learner: int = 1, **kwargs: Any) -> None:
        self.par = SwarmParallelEnv(scenario, learners=[learner], **kwargs)
        self.agent = self.par.possible_agents[0]
        self.observation_space = self.par.observation_space(self.agent)
        self.action_space = self.par.action_space(self.agent)

    def reset(self, *, seed: Optional[int] = None, options: Optional[dict] = None):
        super().reset(seed=seed)
        obs, infos = self.par.reset(seed=seed, options=options)
        return obs[self.agent], infos[self.agent]

    def step(self, action):
        obs, rewards, terms, truncs, infos = self.par.step({self.agent: action})
        return obs[self.agent], rewards[self.agent], terms[self.agent], truncs[self.agent], infos[self.agent]

    def close(self) -> None:
        self.par.close()

"""uavswarm: Python environments over the real swarm of this repository, and its run folders as
data.

- `SwarmParallelEnv`: a PettingZoo `ParallelEnv`, each agent a UAV; one step is one lockstep tick
  of the real hub and agents over Zenoh, network faults in force.
- `SwarmEnv`: a Gymnasium `Env` with one learning UAV among the scenario's own controller
  (registered as `uavswarm/Forest5-v0`, `uavswarm/Forest5Lossy-v0`, and the like).
- `observation`: the observation's documented layout; `rewards`: the default reward and the hook.
- `load_run(path)`: a run folder as dicts and pandas DataFrames.
- `find_swarm()`: where the `swarm` binary is (`SWARM_BIN`, `PATH`, the checkout).
"""
from __future__ import annotations

import gymnasium

from ._run import SwarmNotFound, SwarmRunError, find_swarm
from .env import SwarmEnv, SwarmParallelEnv
from .observation import Layout
from .rewards import Weights
from .runs import RunData, load_run

__all__ = [
    "SwarmEnv",
    "SwarmParallelEnv",
    "Layout",
    "Weights",
    "RunData",
    "load_run",
    "find_swarm",
    "SwarmNotFound",
    "SwarmRunError",
]
__version__ = "0.1.0"

#: The Gymnasium ids registered: one learning UAV (UAV 1) in a built-in scenario.
REGISTERED = {
    "uavswarm/Forest5-v0": "forest-5",
    "uavswarm/Forest5Lossy-v0": "forest-5-lossy",
    "uavswarm/Forest5BurstFrozen-v0": "forest-5-burst-frozen",
    "uavswarm/OpenField5-v0": "open-field-5",
}
for _id, _scenario in REGISTERED.items():
    if _id not in gymnasium.registry:
        gymnasium.register(id=_id, entry_point="uavswarm.env:SwarmEnv", kwargs={"scenario": _scenario})

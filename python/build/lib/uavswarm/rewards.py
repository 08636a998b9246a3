"""The default reward, from the hub's ground truth of each tick (a reward may use what the UAV
cannot know; the observation never does).

Per UAV and tick:

    progress * (d_before - d_after)            the distance to the goal it covered [m]
    - contact                                  while in contact with a tree, a wall or a UAV
    - separation * max(0, safe_m - d_uav)      too close to the nearest other UAV [m]
    + goal                                     on the tick the scenario's goal rule is met

with `Weights()` = progress 1, contact 1, separation 1, safe 1 m, goal 10. A user's reward is a
function `(uav_id, before, after, truth, default) -> float` of the UAV's truth bodies before and
after the tick (dicts with `x`, `y`, `vx`, `vy`, `colliding`, `agent_distance_m`,
`obstacle_distance_m`, …), the whole truth of the tick, and the default reward.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Optional

#: A user's reward: (uav_id, body before, body after, the tick's truth, the default) -> reward.
RewardFn = Callable[[int, Optional[dict[str, Any]], dict[str, Any], dict[str, Any], float], float]


@dataclass(frozen=True)
class Weights:
    """The default reward's weights."""

    progress: float = 1.0
    contact: float = 1.0
    separation: float = 1.0
    safe_m: float = 1.0
    goal: float = 10.0


def default_reward(
    w: Weights, goal: tuple[float, float], before: Optional[dict[str, Any]], after: dict[str, Any], truth: dict[str, Any]
) -> float:
    """The default reward of one UAV for one tick (see the module docs)."""
    r = 0.0
    if before is not None:
        d0 = math.hypot(before["x"] - goal[0], before["y"] - goal[1])
        d1 = math.hypot(after["x"] - goal[0], after["y"] - goal[1])
        r += w.progress * (d0 - d1)
    if after.get("colliding"):
        r -= w.contact
    d = after.get("agent_distance_m")
    if d is not None and math.isfinite(d):
        r -= w.separation * max(0.0, w.safe_m - d)
    if truth.get("ended") == "Goal":
        r += w.goal
    return r

"""What one UAV's observation holds: what its onboard stack knows, never ground truth, as a flat
float32 vector of a documented layout (`Layout.fields()`), body frame (x ahead, y left), metres,
seconds and radians.

| slice | what |
|---|---|
| 0-1 | own velocity, body frame [m/s] |
| 2-3 | own heading in its odometry frame (its start frame) as cos, sin |
| 4-7 | goal: 1 if informed (else all four 0), its direction in the body frame (unit x, y), its distance [m] |
| 8 … 8+6K | K neighbour estimates, nearest first: present (1/0), x, y [m], relative velocity x, y [m/s] (0 until known), age of the estimate [s] |
| … +4M | M nearest obstacles (trees as circles, walls as their nearest point): present, x, y [m], radius [m] (0 for a wall) |
| last 2 | hop counts to the nearest informed UAV and to the nearest one inside its goal disc, over 255 (1: no path) |
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

#: Bounds every entry is clipped to (the Box's own).
POS_M = 100.0
VEL_MPS = 20.0
AGE_S = 100.0


@dataclass(frozen=True)
class Layout:
    """How many neighbours and obstacles an observation keeps (padded with zeros, masked)."""

    neighbours: int = 8
    obstacles: int = 8

    @property
    def size(self) -> int:
        return 8 + 6 * self.neighbours + 4 * self.obstacles + 2

    def fields(self) -> list[str]:
        """The name of every entry, in order."""
        names = ["vx_body", "vy_body", "cos_heading", "sin_heading", "informed", "goal_dx", "goal_dy", "goal_dist_m"]
        for i in range(self.neighbours):
            names += [f"n{i}_{f}" for f in ("present", "x", "y", "vx", "vy", "age_s")]
        for i in range(self.obstacles):
            names += [f"o{i}_{f}" for f in ("present", "x", "y", "r")]
        return names + ["hops_informed", "hops_arrived"]

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The Box's low and high."""
        return _bounds(self)


_KINDS = {
    "present": (0.0, 1.0), "informed": (0.0, 1.0), "x": (-POS_M, POS_M), "y": (-POS_M, POS_M),
    "vx": (-VEL_MPS, VEL_MPS), "vy": (-VEL_MPS, VEL_MPS), "age_s": (0.0, AGE_S), "r": (0.0, POS_M),
    "vx_body": (-VEL_MPS, VEL_MPS), "vy_body": (-VEL_MPS, VEL_MPS), "cos_heading": (-1.0, 1.0),
    "sin_heading": (-1.0, 1.0), "goal_dx": (-1.0, 1.0), "goal_dy": (-1.0, 1.0), "goal_dist_m": (0.0, POS_M),
    "hops_informed": (0.0, 1.0), "hops_arrived": (0.0, 1.0),
}


@functools.lru_cache(maxsize=None)
def _bounds(layout: Layout) -> tuple[np.ndarray, np.ndarray]:
    def kind(name: str) -> str:  # n3_age_s -> age_s, o1_r -> r
        return name.split("_", 1)[1] if name[0] in "no" and name[1].isdigit() else name

    pairs = [_KINDS[kind(n)] for n in layout.fields()]
    return np.array([p[0] for p in pairs], np.float32), np.array([p[1] for p in pairs], np.float32)


def _wall_point(w: dict[str, float]) -> tuple[float, float]:
    """The point of a wall face nearest to the UAV (the body frame's origin)."""
    ax, ay, bx, by = w["ax"], w["ay"], w["bx"], w["by"]
    dx, dy = bx - ax, by - ay
    n = dx * dx + dy * dy
    t = 0.0 if n == 0 else max(0.0, min(1.0, -(ax * dx + ay * dy) / n))
    return ax + t * dx, ay + t * dy


def encode(view: dict[str, Any], layout: Layout) -> np.ndarray:
    """The observation of one view (the agent's JSON view of its tick)."""
    out = np.zeros(layout.size, np.float32)
    o = view["odom"]
    c, s = math.cos(o["yaw"]), math.sin(o["yaw"])
    out[0:4] = (c * o["vx"] + s * o["vy"], -s * o["vx"] + c * o["vy"], c, s)
    goal = view.get("goal")
    if goal:
        gx, gy = goal[0] - o["x"], goal[1] - o["y"]
        bx, by = c * gx + s * gy, -s * gx + c * gy
        d = math.hypot(bx, by)
        out[4:8] = (1.0, bx / d if d > 0 else 0.0, by / d if d > 0 else 0.0, d)
    at = 8
    near = sorted(view.get("neighbours", []), key=lambda n: math.hypot(n["x"], n["y"]))[: layout.neighbours]
    for n in near:
        vel = n.get("vel") or (0.0, 0.0)
        out[at : at + 6] = (1.0, n["x"], n["y"], vel[0], vel[1], n["age_s"])
        at += 6
    at = 8 + 6 * layout.neighbours
    obstacles = [(t["x"], t["y"], t["r"]) for t in view.get("trees", [])]
    obstacles += [(*_wall_point(w), 0.0) for w in view.get("walls", [])]
    obstacles.sort(key=lambda ob: math.hypot(ob[0], ob[1]) - ob[2])
    for x, y, r in obstacles[: layout.obstacles]:
        out[at : at + 4] = (1.0, x, y, r)
        at += 4
    out[-2] = min(view.get("hops_informed", 255), 255) / 255.0
    out[-1] = min(view.get("hops_arrived", 255), 255) / 255.0
    low, high = layout.bounds()
    return np.clip(out, low, high)

"""A run folder as data: `load_run(path)` reads what `swarm run` wrote (summary.json, the CSVs,
world.json, and run.mcap through Foxglove's `mcap` reader) into Python dicts and pandas
DataFrames, with the run folder's own column names and units (docs/watching-and-recording.md).
"""
from __future__ import annotations

import json
import pathlib
from dataclasses import dataclass, field
from typing import Any, Iterator, Optional

import pandas as pd


@dataclass
class RunData:
    """What one run left behind."""

    path: pathlib.Path
    #: summary.json (schema swarm.summary.v1).
    summary: dict[str, Any]
    #: The world: trees, walls, starts, goal (world.json).
    world: dict[str, Any]
    #: Every UAV's ground truth per tick (trajectories.csv).
    trajectories: pd.DataFrame
    #: Every agent's state per tick: step time, obstacles, neighbours, vectors, traffic (agent_states.csv).
    agent_states: pd.DataFrame
    #: Localization error per agent and tick (localization.csv).
    localization: pd.DataFrame
    #: Connected components of the estimate graph per tick (connectivity.csv).
    connectivity: pd.DataFrame
    #: The scenario the run flew (scenario.toml), as text.
    scenario_text: str = ""
    _mcap: Optional[pathlib.Path] = field(default=None, repr=False)

    def mcap_messages(self, topics: Optional[list[str]] = None) -> Iterator[tuple[str, str, int, bytes]]:
        """run.mcap's messages as (topic, schema name, log time in ns, data), read by the `mcap`
        package (`pip install uavswarm[mcap]`)."""
        if self._mcap is None:
            raise FileNotFoundError(f"{self.path} has no run.mcap (the run was flown with --no-mcap)")
        from mcap.reader import make_reader
        from mcap.decoder import DecoderFactory  # noqa: F401  (the reader's decoders)

        try:
            import zstandard  # noqa: F401  (run.mcap's chunks are zstd)
        except ImportError as e:  # pragma: no cover
            raise ImportError("run.mcap is zstd-compressed: pip install uavswarm[mcap]") from e
        with open(self._mcap, "rb") as f:
            for schema, channel, message in make_reader(f).iter_messages(topics=topics):
                yield channel.topic, schema.name if schema else "", message.log_time, message.data


def _csv(path: pathlib.Path) -> pd.DataFrame:
    return pd.read_csv(path) if path.exists() else pd.DataFrame()


def load_run(path: str | pathlib.Path) -> RunData:
    """Reads the run folder at `path`."""
    p = pathlib.Path(path)
    summary_path = p / "summary.json"
    if not summary_path.exists():
        raise FileNotFoundError(f"{p} is not a run folder (no summary.json; a killed run: `swarm recover {p}`)")
    world = p / "world.json"
    mcap = p / "run.mcap"
    scenario = p / "scenario.toml"
    return RunData(
        path=p,
        summary=json.loads(summary_path.read_text()),
        world=json.loads(world.read_text()) if world.exists() else {},
        trajectories=_csv(p / "trajectories.csv"),
        agent_states=_csv(p / "agent_states.csv"),
        localization=_csv(p / "localization.csv"),
        connectivity=_csv(p / "connectivity.csv"),
        scenario_text=scenario.read_text() if scenario.exists() else "",
        _mcap=mcap if mcap.exists() else None,
    )

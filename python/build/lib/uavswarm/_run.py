"""One swarm run driven tick by tick: `swarm run --external IDS --gym` as a child process, its
step protocol on the child's standard input and output (one JSON line each way per tick).

The child is the whole run: it starts the hub, the agents and the recorder as its own children,
which die with it. It dies with this process: with the parent-death signal set (Linux), a Python
killed outright takes it along; `close()` stops it cleanly (SIGINT to its process group, so the
hub ends the run as `stopped` and the run folder is whole) and kills it if it does not exit.
"""
from __future__ import annotations

import ctypes
import itertools
import json
import os
import pathlib
import select
import shutil
import signal
import subprocess
import tempfile
from typing import Any, Optional, Sequence

_PR_SET_PDEATHSIG = 1
_runs = itertools.count()


class SwarmNotFound(RuntimeError):
    """The `swarm` binary could not be found."""


class SwarmRunError(RuntimeError):
    """The run failed or stopped answering; the message names its log."""


def find_swarm(explicit: Optional[str] = None) -> str:
    """The `swarm` binary: `explicit`, else `SWARM_BIN`, else `swarm` on `PATH`, else the
    `target/release/swarm` of the checkout this package lives in (an editable install)."""
    candidates = [explicit, os.environ.get("SWARM_BIN"), shutil.which("swarm")]
    candidates.append(str(pathlib.Path(__file__).resolve().parents[2] / "target" / "release" / "swarm"))
    for c in candidates:
        if c and os.path.isfile(c) and os.access(c, os.X_OK):
            return c
    raise SwarmNotFound(
        "cannot find the `swarm` binary: build it with `cargo build --release` in the repository and "
        "set SWARM_BIN=<repo>/target/release/swarm (or put it on PATH, or install this package with "
        "`pip install -e python` from the checkout)"
    )


def _die_with_parent() -> None:  # pragma: no cover - runs in the child before exec
    try:
        libc = ctypes.CDLL("libc.so.6", use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL)
    except OSError:
        pass


def resolve_scenario(swarm: str, scenario: str) -> dict[str, Any]:
    """The scenario as `swarm check --json` resolves it (a built-in name or a file)."""
    o = subprocess.run([swarm, "check", scenario, "--json"], capture_output=True, text=True, timeout=60)
    if o.returncode != 0:
        raise ValueError(f"scenario {scenario!r}: {o.stderr.strip() or o.stdout.strip()}")
    return json.loads(o.stdout)


def ids_text(ids: Sequence[int]) -> str:
    """UAV ids in the command line's syntax (`1,2,5`)."""
    return ",".join(str(i) for i in sorted(ids))


class Run:
    """A running swarm with some UAVs handed to this process."""

    def __init__(
        self,
        swarm: str,
        scenario: str,
        external: Sequence[int],
        seed: Optional[int],
        *,
        out_dir: Optional[str] = None,
        sets: Sequence[str] = (),
        extra_args: Sequence[str] = (),
        reply_timeout_s: float = 120.0,
    ) -> None:
        self.dir = pathlib.Path(out_dir or tempfile.mkdtemp(prefix="uavswarm-"))
        self.dir.mkdir(parents=True, exist_ok=True)
        self.out = self.dir / f"run-{next(_runs)}"
        self.run_id = f"gym-{os.getpid()}-{os.urandom(3).hex()}"
        self.reply_timeout_s = reply_timeout_s
        args = [swarm, "run", scenario, "--external", ids_text(external), "--gym", "--quiet", "--no-mcap",
                "--out", str(self.out), "--run", self.run_id]
        if seed is not None:
            args += ["--seed", str(int(seed))]
        for s in sets:
            args += ["--set", s]
        args += list(extra_args)
        self.log_path = self.dir / f"{self.out.name}.log"
        self._log = open(self.log_path, "wb")
        self.proc = subprocess.Popen(
            args, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=self._log,
            start_new_session=True, preexec_fn=_die_with_parent,
        )
        self._buf = b""

    def _fail(self, what: str) -> SwarmRunError:
        tail = ""
        try:
            self._log.flush()
            tail = self.log_path.read_text(errors="replace")[-2000:]
        except OSError:
            pass
        return SwarmRunError(f"{what} (run log {self.log_path}):\n{tail}")

    def read(self) -> dict[str, Any]:
        """The next line of the run: a tick's views, or its end."""
        assert self.proc.stdout is not None
        fd = self.proc.stdout.fileno()
        while b"\n" not in self._buf:
            ready, _, _ = select.select([fd], [], [], self.reply_timeout_s)
            if not ready:
                raise self._fail(f"the swarm sent nothing for {self.reply_timeout_s:.0f} s")
            chunk = os.read(fd, 1 << 20)
            if not chunk:
                raise self._fail("the swarm run ended without its end line")
            self._buf += chunk
        line, self._buf = self._buf.split(b"\n", 1)
        return json.loads(line)

    def send(self, tick: int, cmds: dict[int, dict[str, Any]]) -> None:
        """The commands of `tick`, by UAV id."""
        assert self.proc.stdin is not None
        line = json.dumps({"tick": tick, "cmds": {str(i): c for i, c in cmds.items()}}) + "\n"
        try:
            self.proc.stdin.write(line.encode())
            self.proc.stdin.flush()
        except BrokenPipeError as e:
            raise self._fail("the swarm run is gone") from e

    def close(self, grace_s: float = 20.0) -> Optional[int]:
        """Stops the run (the hub ends it as `stopped`) and waits for it; kills what is left.
        Returns its exit status."""
        if self.proc.poll() is None:
            try:
                os.killpg(self.proc.pid, signal.SIGINT)
                self.proc.wait(timeout=grace_s)
            except (ProcessLookupError, subprocess.TimeoutExpired):
                pass
        if self.proc.poll() is None:
            try:
                os.killpg(self.proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            self.proc.wait(timeout=10)
        for f in (self.proc.stdin, self.proc.stdout):
            if f is not None:
                f.close()
        self._log.close()
        return self.proc.returncode

    def summary(self) -> Optional[dict[str, Any]]:
        """The run's summary.json, once it is written."""
        p = self.out / "summary.json"
        return json.loads(p.read_text()) if p.exists() else None

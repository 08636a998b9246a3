#!/usr/bin/env python3
"""Fingerprints of every shipped lockstep scenario: the oracle for changes meant to keep behaviour.

Flies each built-in lockstep scenario with a fixed run id and prints one line per scenario:
the SHA-256 of `trajectories.csv` and of `summary.json` with its wall-clock fields removed.
Run it before and after a refactoring and diff the two outputs:

    cargo build --release
    python3 tools/lockstep_hashes.py > before.txt
    ... change the code, rebuild ...
    python3 tools/lockstep_hashes.py > after.txt && diff before.txt after.txt

Options: --bin PATH (default target/release/swarm), --jobs N (default 2), --only NAME[,NAME],
--agents-per-process N (passed to `swarm run`: the hashes must not depend on it),
--drop-fields A,B (summary fields removed wherever they occur, like the wall-clock ones: to compare
with a baseline taken before those fields were added to summary.json).
"""
import argparse
import concurrent.futures
import hashlib
import json
import pathlib
import subprocess
import sys
import tempfile
import tomllib

# Fields of summary.json measured on the wall clock, which no refactoring is expected to keep, and
# `traffic`, which depends on how agents share sessions and on when an undeclaration reached the
# router (what arrives, not what counts).
WALL_FIELDS = {"run_id", "wall_time_s", "sim_speed", "mean_step_time_ms", "max_step_time_ms", "timing", "traffic"}

# Scenarios whose outcome depends on the wall clock although they run in lockstep: a restarted
# agent joins at whatever tick the hub has reached when its liveliness token appears.
WALL_CLOCK_SCENARIOS = {"open-field-5-restart"}

# Scale scenarios: lockstep and repeatable, but minutes each on the development machine, so left
# out of the default set; `--only open-1000` fingerprints it (forest-100-arrive: a 1100 s flight of
# 100 UAVs).
SCALE_SCENARIOS = {"open-1000", "forest-100-arrive", "forest-1000-icp"}


def strip_wall(value, drop=WALL_FIELDS):
    if isinstance(value, dict):
        return {k: strip_wall(v, drop) for k, v in value.items() if k not in drop}
    if isinstance(value, list):
        return [strip_wall(v, drop) for v in value]
    return value


def lockstep_scenarios(root):
    names = []
    for path in sorted((root / "scenarios").glob("*.toml")):
        if path.stem == "example" or path.stem in WALL_CLOCK_SCENARIOS or path.stem in SCALE_SCENARIOS:
            continue
        scenario = tomllib.loads(path.read_text())
        if scenario.get("time", {}).get("mode") == "realtime":
            continue
        names.append(path.stem)
    return names


def fingerprint(binary, name, extra, drop=WALL_FIELDS):
    with tempfile.TemporaryDirectory() as tmp:
        out = pathlib.Path(tmp) / "run"
        proc = subprocess.run(
            [binary, "run", name, "--run", f"oracle-{name}", "--out", str(out), "--quiet", *extra],
            capture_output=True, text=True)
        if not (out / "summary.json").exists():
            return f"{name} FAILED exit {proc.returncode}: {proc.stderr.strip()[-300:]}"
        summary = strip_wall(json.loads((out / "summary.json").read_text()), drop)
        s_hash = hashlib.sha256(json.dumps(summary, sort_keys=True).encode()).hexdigest()[:16]
        t_hash = hashlib.sha256((out / "trajectories.csv").read_bytes()).hexdigest()[:16]
        return f"{name} trajectories={t_hash} summary={s_hash}"


def main():
    root = pathlib.Path(__file__).resolve().parent.parent
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bin", default=str(root / "target" / "release" / "swarm"))
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--only", default="")
    ap.add_argument("--agents-per-process", default="")
    ap.add_argument("--drop-fields", default="")
    args = ap.parse_args()
    drop = WALL_FIELDS | set(filter(None, args.drop_fields.split(",")))
    extra = ["--agents-per-process", args.agents_per_process] if args.agents_per_process else []
    names = args.only.split(",") if args.only else lockstep_scenarios(root)
    with concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
        for line in pool.map(lambda n: fingerprint(args.bin, n, extra, drop), names):
            print(line, flush=True)
            print(line, file=sys.stderr, flush=True)


if __name__ == "__main__":
    main()

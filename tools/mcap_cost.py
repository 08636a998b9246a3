#!/usr/bin/env python3
"""What recording costs: x real time and MB per UAV-minute of `run.mcap` and of the journal.

Flies each scenario once per recording setting, the settings alternating in one session (so a
slower machine minute hits them alike), `--repeat` rounds, and prints a markdown table: the
median x real time, its ratio to the same scenario without `run.mcap`, the size of `run.mcap`
and the largest size the journal reached (it is removed at a clean end; the recorder logs it).

    cargo build --release
    python3 tools/mcap_cost.py --scenarios forest-5,forest-40 --time-limit 60 \\
        --settings "--no-mcap;;--mcap-every 5" --repeat 3

Settings are `swarm run` arguments separated by `;` (an empty one is the default recording).
"""
import argparse
import json
import pathlib
import re
import statistics
import subprocess
import tempfile


def scenario_file(name, limit, tmp):
    """The shipped scenario `name`, with its time limit set to `limit` sim seconds (if given)."""
    text = pathlib.Path(f"scenarios/{name}.toml").read_text()
    if limit:
        text = re.sub(r"(?m)^time_limit_s\s*=.*$", f"time_limit_s = {limit}", text)
    path = pathlib.Path(tmp) / f"{name}.toml"
    path.write_text(text)
    return str(path)


def fly(bin_, scenario, setting, out):
    args = [bin_, "run", scenario, "--quiet", "--out", str(out)] + setting.split()
    p = subprocess.run(args, capture_output=True, text=True)
    summary = json.loads((out / "summary.json").read_text())
    mcap = (out / "run.mcap").stat().st_size if (out / "run.mcap").exists() else 0
    m = re.findall(r"journal removed bytes=(\d+)", p.stderr)
    journal = int(m[-1]) if m else 0
    uav_min = summary["uav_count"] * summary["sim_time_s"] / 60.0
    return summary["sim_speed"], mcap, journal, uav_min


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", default="target/release/swarm")
    ap.add_argument("--scenarios", default="forest-5,forest-40")
    ap.add_argument("--settings", default="--no-mcap;;--mcap-every 5")
    ap.add_argument("--time-limit", type=float, default=0.0, help="override end.time_limit_s [sim s]")
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args()
    settings = a.settings.split(";")
    rows = {}
    with tempfile.TemporaryDirectory() as tmp:
        files = {sc: scenario_file(sc, a.time_limit, tmp) for sc in a.scenarios.split(",")}
        for r in range(a.repeat):
            for sc, file in files.items():
                for i, st in enumerate(settings):
                    out = pathlib.Path(tmp) / f"{sc}-{i}-{r}"
                    rows.setdefault((sc, st), []).append(fly(a.bin, file, st, out))
                    print(f"# {sc} [{st or 'default'}] round {r + 1}: {rows[(sc, st)][-1][0]:.1f}x", flush=True)
    print("| scenario | recording | x real time | vs the first | run.mcap MB per UAV-min | journal MB per UAV-min (peak, removed at the end) |")
    print("|---|---|---|---|---|---|")
    for sc in a.scenarios.split(","):
        base = statistics.median(x[0] for x in rows[(sc, settings[0])])
        for st in settings:
            xs = rows[(sc, st)]
            speed = statistics.median(x[0] for x in xs)
            mcap = statistics.median(x[1] / 1e6 / x[3] for x in xs)
            journal = statistics.median(x[2] / 1e6 / x[3] for x in xs)
            print(f"| {sc} | `{st or 'default'}` | {speed:.2f} | {speed / base:.2f} | {mcap:.2f} | {journal:.2f} |")


if __name__ == "__main__":
    main()

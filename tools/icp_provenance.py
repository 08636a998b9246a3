#!/usr/bin/env python3
"""Where a run's false ICP estimates come from (issue 14): joins the agents' `icp_provenance` TRACE
lines with the run's `trajectories.csv` and attributes every false estimate (> 1 m off) to the ICP
outcome that started its run of false estimates (`initial`: a full-grid placement, `long`: a
periodic lICP of a tracked entry, `short`: an sICP; `+sender`: the entry had just taken another
sender's set). Nothing here is used by the agents, which never see the truth.
    RUST_LOG=info,zenoh=warn,icp_provenance=trace swarm run forest-9-dense --out RUN
    python3 tools/icp_provenance.py RUN
"""
import collections
import csv
import glob
import math
import re
import sys

FALSE_M = 1.0
LINE = re.compile(r"uav_id=(\d+).*icp_provenance: accepted (.*)$")


def truth_of(run):
    truth = {}
    for r in csv.DictReader(open(f"{run}/trajectories.csv")):
        truth[(int(r["tick"]), int(r["id"]))] = (float(r["x_m"]), float(r["y_m"]), float(r["yaw_rad"]))
    return truth


def relative(me, other):
    """`other`'s position and heading in `me`'s body frame."""
    dx, dy = other[0] - me[0], other[1] - me[1]
    s, c = math.sin(me[2]), math.cos(me[2])
    return c * dx + s * dy, -s * dx + c * dy, math.remainder(other[2] - me[2], math.tau)


def outcomes(run, truth):
    """(me, entry, tick, sender, kind, error m, FRMSD, pairs) per accepted ICP outcome, sorted."""
    out = []
    for path in glob.glob(f"{run}/logs/agent*.log"):
        for line in open(path):
            m = LINE.search(line)
            if not m:
                continue
            d = dict(kv.split("=", 1) for kv in m.group(2).split())
            me_id = int(m.group(1))
            tick = round(float(d["now"]) * 10)
            me, other = truth.get((tick, me_id)), truth.get((tick, int(d["from"])))
            if not me or not other:
                continue
            tx, ty, _ = relative(me, other)
            err = math.hypot(float(d["x"]) - tx, float(d["y"]) - ty)
            out.append((me_id, int(d["entry"]), tick, int(d["from"]), d["kind"].strip('"'), err, float(d["frmsd"]), int(d["pairs"])))
    out.sort()
    return out


def main():
    run = sys.argv[1]
    out = outcomes(run, truth_of(run))
    false = [o for o in out if o[5] > FALSE_M]
    print(f"accepted ICP outcomes {len(out)}, false {len(false)} ({100 * len(false) / max(1, len(out)):.3f} %)")
    origin, by_origin, starts, prev = {}, collections.Counter(), collections.Counter(), {}
    for o in out:
        key, p = (o[0], o[1]), prev.get((o[0], o[1]))
        if o[5] > FALSE_M:
            if p is None or p[5] <= FALSE_M:
                why = o[4] + ("+sender" if p is not None and p[3] != o[3] else "")
                why += " FRMSD<=0.3" if o[6] <= 0.3 else " FRMSD>0.3"
                origin[key] = why
                starts[why] += 1
            by_origin[origin[key]] += 1
        prev[key] = o
    print("runs of false estimates, by the outcome that started them:", dict(starts))
    print("false estimates, by the outcome that started their run:", dict(by_origin))
    print("false estimates by agent:", dict(collections.Counter(o[0] for o in false)))


if __name__ == "__main__":
    main()

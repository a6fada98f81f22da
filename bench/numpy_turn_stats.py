#!/usr/bin/env python3
"""Per-manoeuvre statistics of a run CSV with plain numpy: the reader a user could have written.

It is the baseline of the host tool's throughput benchmark (`bench/throughput.sh`): same file,
same statistics (manoeuvres = maximal spans of constant commanded side speeds; per span: duration,
average and maximum electrical power per side and in total, energy per side by the trapezoid rule).

    python3 bench/numpy_turn_stats.py RUN.csv [--json OUT.json] [--repeat N]

Prints the best wall time of N repetitions (read + statistics) and the number of rows and spans.
"""
import argparse
import json
import sys
import time

import numpy as np

REQUIRED = ["t_s", "left_bus_v", "left_current_a", "right_bus_v", "right_current_a",
            "cmd_left_mps", "cmd_right_mps"]


def read(path):
    with open(path, encoding="utf-8-sig") as f:
        header = [c.strip() for c in f.readline().split(",")]
    cols = [header.index(name) for name in REQUIRED]
    data = np.loadtxt(path, delimiter=",", skiprows=1, usecols=cols, ndmin=2)
    return {name: data[:, i] for i, name in enumerate(REQUIRED)}


def spans(cmd_l, cmd_r, tol=1e-6):
    change = (np.abs(np.diff(cmd_l)) > tol) | (np.abs(np.diff(cmd_r)) > tol)
    starts = np.concatenate(([0], np.nonzero(change)[0] + 1))
    ends = np.concatenate((starts[1:], [len(cmd_l)]))
    return starts, ends


def stats(run):
    t = run["t_s"]
    p_l = run["left_bus_v"] * run["left_current_a"]
    p_r = run["right_bus_v"] * run["right_current_a"]
    p = p_l + p_r
    starts, ends = spans(run["cmd_left_mps"], run["cmd_right_mps"])
    out = []
    for s, e in zip(starts, ends):
        if e - s < 2:
            continue
        ts = t[s:e]
        out.append({
            "start_s": float(ts[0]),
            "duration_s": float(ts[-1] - ts[0]),
            "cmd_mps": [float(run["cmd_left_mps"][s]), float(run["cmd_right_mps"][s])],
            "avg_power_w": [float(p_l[s:e].mean()), float(p_r[s:e].mean()), float(p[s:e].mean())],
            "max_power_w": [float(p_l[s:e].max()), float(p_r[s:e].max()), float(p[s:e].max())],
            "energy_j": [float(np.trapezoid(p_l[s:e], ts)), float(np.trapezoid(p_r[s:e], ts))],
        })
    return out


def timed_main(read, label, doc, input_name):
    """The command line both baselines share: read + statistics N times, print the best time."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument(input_name)
    ap.add_argument("--json")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    best = float("inf")
    for _ in range(max(1, args.repeat)):
        t0 = time.perf_counter()
        run = read(getattr(args, input_name))
        result = stats(run)
        best = min(best, time.perf_counter() - t0)
    rows = len(run["t_s"])
    print(f"{label}: {rows} rows, {len(result)} spans, best {best * 1e3:.1f} ms "
          f"({rows / best / 1e6:.2f} M rows/s)")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"rows": rows, "seconds": best, "spans": result}, f)


def main():
    timed_main(read, "numpy", __doc__, "csv")


if __name__ == "__main__":
    sys.exit(main())

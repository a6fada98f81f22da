#!/usr/bin/env python3
"""Reading the one-hour run CSV from Python: rover_power.read_run against the host tool's
`validate` of the same file (the whole command, which reads it once and analyses it) and
against pandas.read_csv, best of --repeat each, in one run:

    cargo bench -p host-tool --bench turn_stats -- --generate-only   # the hour log, once
    pip install ./python
    python3 python/bench/read_speed.py [target/bench-data/large-run.csv] [--host-tool PATH]

Goals (issue 40): read_run ≤ 1.5× the CLI's validate, and ≥ 2× as fast as pandas.read_csv.
Both readers' frames must be equal (same columns, index and values) or the bench fails.
"""

import argparse
import os
import pathlib
import subprocess
import sys
import time

import numpy as np
import pandas as pd

import rover_power as rp

ROOT = pathlib.Path(__file__).resolve().parents[2]
TARGET = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))


def best_of(repeat, run):
    times = []
    result = None
    for _ in range(repeat):
        start = time.perf_counter()
        result = run()
        times.append(time.perf_counter() - start)
    return min(times), result


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("csv", nargs="?", default=TARGET / "bench-data" / "large-run.csv")
    parser.add_argument("--host-tool", default=TARGET / "release" / "host-tool")
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    csv = pathlib.Path(args.csv)
    if not csv.exists():
        sys.exit(
            f"{csv}: missing; generate it with "
            "`cargo bench -p host-tool --bench turn_stats -- --generate-only`"
        )
    megabytes = csv.stat().st_size / 1e6
    validate = [str(args.host_tool), "--quiet", "validate", "--runs", str(csv), "--json", os.devnull]

    t_ours, ours = best_of(args.repeat, lambda: rp.read_run(csv))
    t_cli, _ = best_of(args.repeat, lambda: subprocess.run(validate, check=True))
    t_pandas, theirs = best_of(max(1, args.repeat // 2), lambda: pd.read_csv(csv, index_col="t_s"))

    if list(ours.columns) != list(theirs.columns) or not (
        np.array_equal(ours.index.to_numpy(), theirs.index.to_numpy())
        and np.array_equal(ours.to_numpy(), theirs.to_numpy(), equal_nan=True)
    ):
        sys.exit("read_run and pandas.read_csv read different frames")

    rows = len(ours)
    print(f"{csv}: {rows} rows, {megabytes:.1f} MB; best of {args.repeat} (pandas: of {max(1, args.repeat // 2)})")
    for name, t in [
        ("rover_power.read_run", t_ours),
        ("host-tool validate (whole command)", t_cli),
        ("pandas.read_csv", t_pandas),
    ]:
        print(f"  {name:36} {t * 1e3:8.1f} ms  {rows / t / 1e6:6.2f} M rows/s  {megabytes / t:7.1f} MB/s")
    to_cli, to_pandas = t_ours / t_cli, t_pandas / t_ours
    print(f"  read_run / CLI validate: {to_cli:.2f}x (goal ≤ 1.5x: {'met' if to_cli <= 1.5 else 'MISSED'})")
    print(f"  pandas / read_run:       {to_pandas:.2f}x (goal ≥ 2x: {'met' if to_pandas >= 2 else 'MISSED'})")


if __name__ == "__main__":
    main()

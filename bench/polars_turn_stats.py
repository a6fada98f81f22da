#!/usr/bin/env python3
"""Per-manoeuvre statistics of a run CSV read with polars (multi-threaded, Rust underneath).

`polars.read_csv` of the required columns, as numpy arrays, then the same statistics as
`numpy_turn_stats.py`. A baseline of the host tool's throughput benchmark
(`bench/throughput.sh`).

    python3 bench/polars_turn_stats.py RUN.csv [--json OUT.json] [--repeat N]
"""
import os
import sys

import polars as pl

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from numpy_turn_stats import REQUIRED, timed_main  # noqa: E402


def read(path):
    frame = pl.read_csv(path, columns=REQUIRED,
                        schema_overrides={name: pl.Float64 for name in REQUIRED})
    return {name: frame[name].to_numpy() for name in REQUIRED}


def main():
    timed_main(read, "polars + numpy", __doc__, "csv")


if __name__ == "__main__":
    sys.exit(main())

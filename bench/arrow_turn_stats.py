#!/usr/bin/env python3
"""Per-manoeuvre statistics of a run CSV read with `pyarrow.csv` (multi-threaded, vectorised).

The fastest CSV reader a Python user would reach for: `pyarrow.csv.read_csv` (its default thread
pool), the columns as numpy arrays, then the same statistics as `numpy_turn_stats.py`. A
baseline of the host tool's throughput benchmark (`bench/throughput.sh`).

    python3 bench/arrow_turn_stats.py RUN.csv [--json OUT.json] [--repeat N]
"""
import os
import sys

import pyarrow as pa
import pyarrow.csv as pacsv

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from numpy_turn_stats import REQUIRED, timed_main  # noqa: E402


def read(path):
    options = pacsv.ConvertOptions(include_columns=REQUIRED,
                                   column_types={name: pa.float64() for name in REQUIRED})
    table = pacsv.read_csv(path, convert_options=options)
    return {name: table.column(name).to_numpy() for name in REQUIRED}


def main():
    timed_main(read, "pyarrow.csv + numpy", __doc__, "csv")


if __name__ == "__main__":
    sys.exit(main())

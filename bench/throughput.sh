#!/usr/bin/env bash
# Throughput of the host tool's decode → samples → per-manoeuvre statistics on a large recorded
# log, side by side with a plain numpy reader of the same file, in one run:
#
#     bench/throughput.sh
#
# 1. Makes sure python3 can import numpy (installs it with `python3 -m pip install --quiet numpy`
#    if not; without python3 the Rust figures are still printed).
# 2. Runs `cargo bench -p host-tool --bench turn_stats` (host-tool/benches/turn_stats.rs): the
#    first run generates an hour of the simulated Husky on sand, recorded by the tool's recorder
#    from the simulated board (target/bench-data/large-run.{bin,csv,commands.csv}; ~110 MB,
#    kept for later runs), then times, best of 5: the Rust path from the run CSV, the Rust path
#    from the raw capture, and bench/numpy_turn_stats.py on the same CSV; prints rows/s, MB/s,
#    the ratios Rust/numpy and how closely the per-span energies agree.
#
# Extra arguments go to cargo (e.g. `--offline`).
set -euo pipefail
cd "$(dirname "$0")/.."

if command -v python3 >/dev/null 2>&1; then
    if ! python3 -c "import numpy" >/dev/null 2>&1; then
        echo "numpy is missing: python3 -m pip install --quiet numpy" >&2
        python3 -m pip install --quiet numpy || echo "could not install numpy; the numpy baseline will be skipped" >&2
    fi
else
    echo "python3 not found: the numpy baseline will be skipped" >&2
fi

exec cargo bench -p host-tool --bench turn_stats "$@"

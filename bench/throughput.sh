#!/usr/bin/env bash
# Throughput of the host tool's decode → samples → per-manoeuvre statistics on a large recorded
# log, side by side with a plain numpy reader of the same file, in one run:
#
#     bench/throughput.sh
#
# 1. Makes sure python3 can import numpy, mcap, mcap_protobuf, pyarrow and polars (installs
#    them with `python3 -m pip install --quiet numpy mcap mcap-protobuf-support pyarrow polars`
#    if not; without python3 the Rust figures are still printed).
# 2. Runs `cargo bench -p host-tool --bench turn_stats` (host-tool/benches/turn_stats.rs): the
#    first run generates an hour of the simulated Husky on sand, recorded by the tool's recorder
#    from the simulated board (target/bench-data/large-run.{bin,csv,commands.csv,mcap}; kept for
#    later runs), then times, best of 5: the Rust path from the run CSV, from the raw capture and
#    from the MCAP log, the page-cache read floor (the CSV's bytes read again), the Python peers
#    on the same CSV (bench/numpy_turn_stats.py: numpy.loadtxt; bench/arrow_turn_stats.py:
#    pyarrow.csv; bench/polars_turn_stats.py: polars) and bench/mcap_turn_stats.py (mcap reader +
#    mcap-protobuf-support + numpy) on the same MCAP log; prints rows/s, MB/s, every ratio from
#    that one run and
#    how closely the per-span energies agree.
#
# Extra arguments go to cargo (e.g. `--offline`).
set -euo pipefail
cd "$(dirname "$0")/.."

if command -v python3 >/dev/null 2>&1; then
    if ! python3 -c "import numpy, mcap, mcap_protobuf, pyarrow, polars" >/dev/null 2>&1; then
        echo "a Python peer's package is missing: python3 -m pip install --quiet numpy mcap mcap-protobuf-support pyarrow polars" >&2
        python3 -m pip install --quiet numpy mcap mcap-protobuf-support pyarrow polars \
            || echo "could not install them; the Python baselines that need them will be skipped" >&2
    fi
else
    echo "python3 not found: the Python baselines will be skipped" >&2
fi

exec cargo bench -p host-tool --bench turn_stats "$@"

#!/usr/bin/env python3
"""Rerun opens our MCAP logs: `rerun mcap convert` (the PyPI `rerun-sdk`'s own CLI) decodes
every sample, model and status message of a demo log into typed columns.

    python3 .ci/check-rerun.py DEMO_OUT

Converts DEMO_OUT/run-1.mcap to a temporary .rrd, lists its chunks with `rerun rrd print` (and
their column types with `-vv`, no data) and checks, per channel, that the rows of its decoded
protobuf column add up to the channel's message count in the MCAP summary (read with the
`mcap` package), and that the column's type holds the fields a plot needs (power per side,
energy, tau). Exit 0 when all hold.
"""
import re
import subprocess
import sys
import tempfile
from pathlib import Path

from mcap.reader import make_reader

# Channel → the fields its decoded column must hold (as Rerun names them in the Arrow type).
EXPECTED = {
    "/rover_power/sample": ["t_s", "left", "right", "bus_v", "current_a", "power_w", "cmd_mps"],
    "/rover_power/model": ["energy_j", "power_w", "tau_w_per_rad_s", "total_energy_j"],
    "/rover_power/status": ["i2c_errors", "reinits", "skipped_results", "queue_drops"],
}
CHUNK = re.compile(r"Chunk\(\S+\) with (\d+) rows .* - (/\S+) - data columns: \[(.*)\]")


def main() -> int:
    log = Path(sys.argv[1]) / "run-1.mcap"
    with open(log, "rb") as f:
        summary = make_reader(f).get_summary()
    topic_of = {c.id: c.topic for c in summary.channels.values()}
    counts = {topic_of[i]: n for i, n in summary.statistics.channel_message_counts.items()}

    with tempfile.TemporaryDirectory() as tmp:
        rrd = Path(tmp) / "run-1.rrd"
        subprocess.run(["rerun", "mcap", "convert", str(log), "-o", str(rrd)], check=True,
                       capture_output=True)
        def listing(*verbosity):
            return subprocess.run(["rerun", "rrd", "print", *verbosity, str(rrd)], check=True,
                                  capture_output=True, text=True).stdout

        chunks = listing()  # one line per chunk: its rows, entity and data columns
        headers = listing("-vv")  # column types

    failures = []
    for topic, fields in EXPECTED.items():
        message = topic.rsplit("/", 1)[1].capitalize()
        column = f"rover_power.{message}:message"
        rows = sum(int(m[1]) for m in CHUNK.finditer(chunks)
                   if m[2] == topic and column in m[3])
        types = [line for line in headers.splitlines()
                 if "type: List(Struct(" in line and '"t_s"' in line]
        typed = any(all(f'"{f}"' in line for f in fields) for line in types)
        print(f"{topic}: {rows} rows decoded as {column} of {counts.get(topic, 0)} messages; "
              f"fields {'present' if typed else 'MISSING'}")
        if rows != counts.get(topic, 0) or rows == 0:
            failures.append(f"{topic}: {rows} decoded rows, {counts.get(topic, 0)} messages")
        if not typed:
            failures.append(f"{topic}: no decoded column type holds {fields}")
    for failure in failures:
        print("FAIL", failure)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())

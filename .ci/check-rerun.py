#!/usr/bin/env python3
"""Rerun opens our MCAP logs: `rerun mcap convert` (the PyPI `rerun-sdk`'s own CLI) decodes
every sample batch, model and status message of a demo log into typed columns.

    python3 .ci/check-rerun.py DEMO_OUT

Converts DEMO_OUT/run-1.mcap to a temporary .rrd, lists its chunks with `rerun rrd print` (and
their column types with `-vv`) and checks, per channel, that the rows of its decoded protobuf
column (named after the channel's schema, `rover_power.SampleBatch:message` on
`/rover_power/sample_batch`) add up to the channel's message count in the MCAP summary (read
with the `mcap` package), and that the column's type in that channel's chunks holds the fields
a plot needs (the batch's sample times and per side power, bus and current registers and
commanded speed; energy, tau; the health counters). Exit 0 when all hold.
"""
import re
import subprocess
import sys
import tempfile
from pathlib import Path

from mcap.reader import make_reader

# Channel → the fields its decoded column must hold (as Rerun names them in the Arrow type).
# The samples come ~20 to a message: columns per side, the readings as the chips' registers.
EXPECTED = {
    "/rover_power/sample_batch": ["t_s", "left", "right", "power_w", "bus_raw", "current_raw",
                                  "cmd_mps"],
    "/rover_power/model": ["energy_j", "power_w", "tau_w_per_rad_s", "total_energy_j"],
    "/rover_power/status": ["i2c_errors", "reinits", "skipped_results", "queue_drops"],
}
CHUNK = re.compile(r"Chunk\(\S+\) with (\d+) rows .* - (/\S+) - data columns: \[(.*)\]")
SECTION = re.compile(r"Chunk\(\S+\) with \d+ rows .* - (/\S+) - ")  # a chunk's line with -vv


def main() -> int:
    log = Path(sys.argv[1]) / "run-1.mcap"
    with open(log, "rb") as f:
        summary = make_reader(f).get_summary()
    topic_of = {c.id: c.topic for c in summary.channels.values()}
    counts = {topic_of[i]: n for i, n in summary.statistics.channel_message_counts.items()}
    # Rerun names a decoded column after the message, i.e. the channel's schema.
    schema_of = {c.topic: summary.schemas[c.schema_id].name
                 for c in summary.channels.values() if c.schema_id in summary.schemas}

    with tempfile.TemporaryDirectory() as tmp:
        rrd = Path(tmp) / "run-1.rrd"
        subprocess.run(["rerun", "mcap", "convert", str(log), "-o", str(rrd)], check=True,
                       capture_output=True)
        def listing(*verbosity):
            return subprocess.run(["rerun", "rrd", "print", *verbosity, str(rrd)], check=True,
                                  capture_output=True, text=True).stdout

        chunks = listing()  # one line per chunk: its rows, entity and data columns
        headers = listing("-vv")  # each chunk's line, then its columns' types

    failures = []
    # The -vv listing cut at each chunk's line: (its entity, its table of columns and types).
    sections = [(m[1], section) for section in re.split(r"(?m)^(?=Chunk\()", headers)
                if (m := SECTION.match(section))]
    for topic, fields in EXPECTED.items():
        column = f"{schema_of.get(topic, '?')}:message"
        rows = sum(int(m[1]) for m in CHUNK.finditer(chunks)
                   if m[2] == topic and column in m[3].split())
        types = [line for entity, section in sections if entity == topic and column in section
                 for line in section.splitlines() if "type: List(Struct(" in line]
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

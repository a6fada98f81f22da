#!/usr/bin/env python3
"""Per-manoeuvre statistics of an MCAP run log with the official `mcap` reader and numpy.

The reader a user would write for the host tool's own log format (`host-tool record --out
run.mcap`, `host-tool demo`): the `mcap` package's `make_reader` with `mcap-protobuf-support`'s
decoder (the `rover_power.Sample` schema is in the file; a log written before the protobuf
channels is decoded with `json.loads`), every message on `/rover_power/sample`, the columns as
numpy arrays, then the same statistics as `numpy_turn_stats.py` (its `stats` function). It is a
baseline of the host tool's throughput benchmark (`bench/throughput.sh`).

    python3 bench/mcap_turn_stats.py RUN.mcap [--json OUT.json] [--repeat N]

Prints the best wall time of N repetitions (read + statistics) and the number of rows and spans.
"""
import json
import os
import sys

import numpy as np
from mcap.decoder import DecoderFactory as JsonFactoryBase
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from numpy_turn_stats import timed_main  # noqa: E402  (same statistics and command line)

TOPIC = "/rover_power/sample"
COLUMNS = ["t_s", "left_bus_v", "left_current_a", "right_bus_v", "right_current_a",
           "cmd_left_mps", "cmd_right_mps"]


class JsonFactory(JsonFactoryBase):
    """Logs written before the protobuf channels: JSON samples."""

    def decoder_for(self, message_encoding, schema):
        return json.loads if message_encoding == "json" else None


def read(path):
    rows = []
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory(), JsonFactory()])
        for _schema, _channel, _message, m in reader.iter_decoded_messages(topics=[TOPIC]):
            if isinstance(m, dict):
                left, right = m["left"], m["right"]
                rows.append((m["t_s"], left["bus_v"], left["current_a"], right["bus_v"],
                             right["current_a"], left["cmd_mps"], right["cmd_mps"]))
            else:
                left, right = m.left, m.right
                rows.append((m.t_s, left.bus_v, left.current_a, right.bus_v,
                             right.current_a, left.cmd_mps, right.cmd_mps))
    data = np.array(rows, dtype=np.float64).reshape(-1, len(COLUMNS))
    return {name: data[:, i] for i, name in enumerate(COLUMNS)}


def main():
    timed_main(read, "mcap + json + numpy", __doc__, "mcap")


if __name__ == "__main__":
    sys.exit(main())

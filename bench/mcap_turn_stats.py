#!/usr/bin/env python3
"""Per-manoeuvre statistics of an MCAP run log with the official `mcap` reader and numpy.

The reader a user would write for the host tool's own log format (`host-tool record --out
run.mcap`, `host-tool demo`): the `mcap` package's `make_reader` with `mcap-protobuf-support`'s
decoder (the schemas are in the file), every message on `/rover_power/sample_batch` (about 20
samples a `rover_power.SampleBatch`, one packed column per value) with its columns straight
into numpy, the chips' bus and current registers turned into volts and amps as the host tool
does, then the same statistics as `numpy_turn_stats.py` (its `stats` function). Logs written
before the batches still read: one `rover_power.Sample` a message on `/rover_power/sample`,
or in logs older still JSON samples (decoded with `json.loads`). It is a baseline of the host
tool's throughput benchmark (`bench/throughput.sh`).

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

BATCH_TOPIC = "/rover_power/sample_batch"
SAMPLE_TOPIC = "/rover_power/sample"  # logs written before the batches: one sample a message
COLUMNS = ["t_s", "left_bus_v", "left_current_a", "right_bus_v", "right_current_a",
           "cmd_left_mps", "cmd_right_mps"]
BUS_LSB_UV = 1250.0  # INA226 bus register step [µV]


class JsonFactory(JsonFactoryBase):
    """Logs written before the protobuf channels: JSON samples."""

    def decoder_for(self, message_encoding, schema):
        return json.loads if message_encoding == "json" else None


def electrical(side, current_lsb_na):
    """A side's bus voltages [V] and currents [A] of a batch: from the registers as the host
    tool rebuilds them (bit for bit), or the doubles of a batch whose readings are no
    register's (a foreign rig's converted CSV)."""
    if current_lsb_na is None:
        return np.asarray(side.bus_v, dtype=np.float64), np.asarray(side.current_a, np.float64)
    bus = np.asarray(side.bus_raw, dtype=np.float64) * BUS_LSB_UV / 1e6
    current = np.asarray(side.current_raw, dtype=np.float64) * float(current_lsb_na) / 1e9
    return bus, current


def read(path):
    parts = {name: [] for name in COLUMNS}  # each column's pieces, in the file's order
    rows = []  # per-sample messages not yet added to `parts`

    def flush_rows():
        if rows:
            data = np.array(rows, dtype=np.float64)
            for i, name in enumerate(COLUMNS):
                parts[name].append(data[:, i])
            rows.clear()

    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory(), JsonFactory()])
        for _schema, channel, message, m in reader.iter_decoded_messages(
                topics=[BATCH_TOPIC, SAMPLE_TOPIC]):
            if channel.topic == BATCH_TOPIC:
                flush_rows()
                lsb = m.current_lsb_na if m.HasField("current_lsb_na") else None
                left_bus, left_current = electrical(m.left, lsb)
                right_bus, right_current = electrical(m.right, lsb)
                batch = [np.asarray(m.t_s, dtype=np.float64), left_bus, left_current,
                         right_bus, right_current, np.asarray(m.left.cmd_mps, np.float64),
                         np.asarray(m.right.cmd_mps, np.float64)]
                if any(len(column) != len(batch[0]) for column in batch):
                    raise ValueError(f"{path}: a batch at sequence {message.sequence} has "
                                     f"columns of different lengths")
                for name, column in zip(COLUMNS, batch):
                    parts[name].append(column)
            elif isinstance(m, dict):
                left, right = m["left"], m["right"]
                rows.append((m["t_s"], left["bus_v"], left["current_a"], right["bus_v"],
                             right["current_a"], left["cmd_mps"], right["cmd_mps"]))
            else:
                left, right = m.left, m.right
                rows.append((m.t_s, left.bus_v, left.current_a, right.bus_v,
                             right.current_a, left.cmd_mps, right.cmd_mps))
    flush_rows()
    return {name: np.concatenate(parts[name]) if parts[name] else np.empty(0)
            for name in COLUMNS}


def main():
    timed_main(read, "mcap + protobuf + numpy", __doc__, "mcap")


if __name__ == "__main__":
    sys.exit(main())

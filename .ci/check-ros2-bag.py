#!/usr/bin/env python3
"""Checks `host-tool convert --to ros2-bag` with a third-party reader (rosbags).

Usage: check-ros2-bag.py HOST_TOOL DEMO_OUT

Converts DEMO_OUT/run-1.mcap into a bag in a temporary directory, opens it with
rosbags.highlevel.AnyReader using only the definitions the bag carries, deserialises every
message of every topic, and checks the samples against the run CSV of the same log: the count,
the first sample's currents and run time exactly, and the yaw (on /rover_power/sample and
/imu/data) to 1e-12; and every standard type's stored definition against the text rosbags
itself generates for it (rosbag2's form, which Foxglove parses). Prints one line per topic. Installs rosbags==0.11.9 with pip when it is not
importable. Writes nothing outside the temporary directory.
"""

import csv
import math
import subprocess
import sys
import tempfile
from pathlib import Path

ROSBAGS = "rosbags==0.11.9"


def import_rosbags():
    try:
        from rosbags.highlevel import AnyReader
    except ImportError:
        print(f"check-ros2-bag: installing {ROSBAGS}", file=sys.stderr)
        subprocess.run(
            [sys.executable, "-m", "pip", "install", "--quiet", ROSBAGS], check=True
        )
        from rosbags.highlevel import AnyReader
    return AnyReader


def check_definitions(connections):
    """Each standard type's definition in the bag is, byte for byte, the one rosbags generates
    (`MSG: std_msgs/Header`, not `MSG: std_msgs/msg/Header`); our own type is checked by
    Foxglove's parser (foxglove/check/ros2msg-schemas.mjs)."""
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    checked = 0
    for c in connections:
        if c.msgtype not in store.types:
            continue
        want, _ = store.generate_msgdef(c.msgtype, ros_version=2)
        if c.msgdef.data != want:
            fail(f"{c.topic}: {c.msgtype}'s stored definition differs from rosbags':\n"
                 f"{c.msgdef.data}\n---- rosbags:\n{want}")
        checked += 1
    if checked == 0:
        fail("no standard type in the bag to check")
    return checked


def fail(message):
    sys.exit(f"check-ros2-bag: {message}")


def run(*args):
    done = subprocess.run([str(a) for a in args], capture_output=True, text=True)
    if done.returncode != 0:
        fail(f"{' '.join(map(str, args))} failed ({done.returncode}):\n{done.stderr}")
    return done


def read_run_csv(path):
    """The run CSV's rows as dicts of floats (None for an empty cell)."""
    with open(path, newline="") as f:
        return [
            {k: float(v) if v != "" else None for k, v in row.items()}
            for row in csv.DictReader(f)
        ]


def yaw_of(q):
    """Yaw [rad] of a geometry_msgs/Quaternion (as host-tool's msgs::yaw_pitch_of)."""
    return math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))


def same(a, b, tolerance=0.0):
    if b is None:
        return math.isnan(a)
    return abs(a - b) <= tolerance


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    host_tool, demo_out = Path(sys.argv[1]), Path(sys.argv[2])
    log = demo_out / "run-1.mcap"
    AnyReader = import_rosbags()

    with tempfile.TemporaryDirectory(prefix="check-ros2-bag-") as tmp:
        tmp = Path(tmp)
        bag = tmp / "bag"
        run(host_tool, "convert", log, bag, "--to", "ros2-bag")
        run(host_tool, "convert", log, tmp / "run.csv")
        rows = read_run_csv(tmp / "run.csv")
        if not rows:
            fail(f"{log} has no samples")

        counts = {}
        samples = []
        imu_yaws = []
        with AnyReader([bag]) as reader:
            types = {c.topic: c.msgtype for c in reader.connections}
            declared = {c.topic: c.msgcount for c in reader.connections}
            definitions = check_definitions(reader.connections)
            for connection, log_time, raw in reader.messages():
                # Raises on any message that does not decode as its stored definition.
                msg = reader.deserialize(raw, connection.msgtype)
                counts[connection.topic] = counts.get(connection.topic, 0) + 1
                if connection.topic == "/rover_power/sample":
                    stamp = msg.stamp.sec * 1_000_000_000 + msg.stamp.nanosec
                    if stamp != log_time:
                        fail(f"sample stamp {stamp} is not its log time {log_time}")
                    samples.append(msg)
                elif connection.topic == "/imu/data":
                    imu_yaws.append(yaw_of(msg.orientation))

        if counts != declared:
            fail(f"messages read {counts} differ from metadata.yaml's {declared}")
        if len(samples) != len(rows):
            fail(f"{len(samples)} samples in the bag, {len(rows)} in the log")
        first, row = samples[0], rows[0]
        for field, column in [
            ("left_current_a", "left_current_a"),
            ("right_current_a", "right_current_a"),
            ("t_s", "t_s"),
        ]:
            if getattr(first, field) != row[column]:
                fail(f"first sample {field} = {getattr(first, field)!r}, log {row[column]!r}")
        want_yaws = [r["yaw_rad"] for r in rows if r["yaw_rad"] is not None]
        if not want_yaws:
            fail(f"{log} has no yaw to check")
        for i, (msg, r) in enumerate(zip(samples, rows)):
            if not same(msg.yaw_rad, r["yaw_rad"], 1e-12):
                fail(f"sample {i}: yaw_rad {msg.yaw_rad!r}, log {r['yaw_rad']!r}")
        if len(imu_yaws) != len(want_yaws):
            fail(f"{len(imu_yaws)} IMU messages, {len(want_yaws)} samples with yaw")
        for i, (got, want) in enumerate(zip(imu_yaws, want_yaws)):
            # The quaternion keeps yaw modulo 2π; the log's yaw is unwrapped.
            if abs(math.remainder(got - want, math.tau)) > 1e-12:
                fail(f"IMU message {i}: yaw {got!r}, log {want!r}")

        for topic in sorted(counts):
            print(f"check-ros2-bag: {topic} ({types[topic]}): {counts[topic]} messages decoded")
        print(
            f"check-ros2-bag: ok, {len(samples)} samples as in {log.name}, "
            f"{len(want_yaws)} yaws within 1e-12, {definitions} standard definitions as rosbags "
            "writes them"
        )


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Checks `host-tool merge` on robot bags written by a third-party writer (rosbags).

Usage: check-robot-bags.py HOST_TOOL

Runs `host-tool demo --runs 1 --robot-bag` into a temporary directory, reads its robot bag with
rosbags, and writes with rosbags' own Writer the bags robots write:

- plain: the same messages (MCAP storage);
- raw-imu: the IMU as raw drivers publish it (REP 145: no orientation, orientation_covariance[0]
  = -1, a zero quaternion; angular_velocity.z the yaw rate between messages);
- sqlite3: the plain bag in `.db3` storage, split into two files as rosbag2 splits;
- partial: the middle 20 s of the 48 s drive;
- mirrored: every twist's angular.z negated (left and right swapped).

Each is merged with the board log and validated. The plain, raw-imu and sqlite3 merges must give
the plain merge's turns and angular slips (raw-imu's to 0.5 % of the slip: its yaw is
integrated); the partial merge the plain's on the turns it covers; the mirrored bag must be
refused saying it turns the other way. Installs rosbags==0.11.9 with pip when it is not
importable. Writes nothing outside the temporary directory.
"""

import json
import math
import subprocess
import sys
import tempfile
from pathlib import Path

ROSBAGS = "rosbags==0.11.9"


def fail(message):
    sys.exit(f"check-robot-bags: {message}")


def rosbags():
    try:
        import rosbags.rosbag2  # noqa: F401
    except ImportError:
        print(f"check-robot-bags: installing {ROSBAGS}", file=sys.stderr)
        subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", ROSBAGS], check=True)
    from rosbags.highlevel import AnyReader
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    return AnyReader, Writer, StoragePlugin, get_typestore(Stores.ROS2_HUMBLE)


def read_bag(any_reader, path):
    """[(topic, msgtype, log time ns, message)] in log-time order."""
    out = []
    with any_reader([path]) as reader:
        for conn, t, raw in reader.messages():
            out.append((conn.topic, conn.msgtype, t, reader.deserialize(raw, conn.msgtype)))
    return out


def write_bag(writer_cls, storage, store, path, messages, split_at=None):
    """Writes `messages` with rosbags' Writer. With `split_at` (a log time) it writes two bags
    and moves their files into one directory whose metadata.yaml lists both, as rosbag2 does for
    --max-bag-duration (rosbags cannot split by itself)."""
    parts = [messages] if split_at is None else [
        [m for m in messages if m[2] < split_at], [m for m in messages if m[2] >= split_at]]
    dirs = []
    for i, part in enumerate(parts):
        d = path if split_at is None else path.parent / f"{path.name}-part{i}"
        with writer_cls(d, version=8, storage_plugin=storage) as w:
            conns = {}
            for topic, msgtype, t, msg in part:
                if topic not in conns:
                    conns[topic] = w.add_connection(topic, msgtype, typestore=store)
                w.write(conns[topic], t, store.serialize_cdr(msg, msgtype))
        dirs.append(d)
    if split_at is None:
        return path
    path.mkdir()
    names = []
    for i, d in enumerate(dirs):
        (f,) = [p for p in d.iterdir() if p.name != "metadata.yaml"]
        names.append(f"{path.name}_{i}{''.join(f.suffixes)}")
        f.rename(path / names[-1])
    meta, out, skipping = (dirs[0] / "metadata.yaml").read_text().splitlines(), [], False
    for line in meta:
        if skipping and line.strip().startswith("- "):
            continue
        skipping = False
        out.append(line.replace(f"{dirs[0].name}", f"{path.name}_0"))
        if line.strip() == "relative_file_paths:":
            indent = line[: len(line) - len(line.lstrip())]
            out += [f"{indent}- {n}" for n in names]
            skipping = True
    (path / "metadata.yaml").write_text("\n".join(out) + "\n")
    return path


def merge(tool, board, bag, out):
    return subprocess.run([tool, "merge", "--board", str(board), "--bag", str(bag), "--out",
                           str(out)], capture_output=True, text=True)


def turns(tool, run):
    """(t_start_s, r/r', angular slip, t_end_s) of each turn of `run`."""
    p = subprocess.run([tool, "validate", "--quiet", "--runs", str(run), "--json", "-"],
                       capture_output=True, text=True)
    if p.returncode not in (0, 3):
        fail(f"validate {run}: exit {p.returncode}: {p.stderr.strip()[-400:]}")
    return [(m["t_start_s"], m["r_over_r_prime"], m["angular_slip"], m["t_end_s"])
            for m in json.loads(p.stdout)["manoeuvres"] if m.get("angular_slip") is not None]


def same_turns(name, got, want, slip_tol, span=None):
    if span is not None:
        want = [w for w in want if span[0] <= w[0] and w[3] <= span[1]]
        got = [g for g in got if any(abs(g[0] - w[0]) < 0.05 for w in want)]
    if len(got) != len(want) or not want:
        fail(f"{name}: {len(got)} turns with slip, the plain merge {len(want)}")
    worst = 0.0
    for g, w in zip(got, want):
        if abs(g[0] - w[0]) > 0.05 or g[1] != w[1]:
            fail(f"{name}: turn at {g[0]:.2f} s (R/R' {g[1]}) against {w[0]:.2f} s ({w[1]})")
        worst = max(worst, abs(g[2] - w[2]))
        if abs(g[2] - w[2]) > slip_tol:
            fail(f"{name}: angular slip {g[2]:.4f} at {g[0]:.2f} s, the plain merge {w[2]:.4f}")
    print(f"check-robot-bags: {name}: {len(got)} turns as the plain merge's "
          f"(largest slip difference {worst:.2e})")


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    tool = sys.argv[1]
    AnyReader, Writer, StoragePlugin, store = rosbags()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        demo = tmp / "demo"
        subprocess.run([tool, "demo", "--runs", "1", "--robot-bag", "--out", str(demo)],
                       check=True, capture_output=True)
        board = demo / "run-1.mcap"
        messages = read_bag(AnyReader, demo / "run-1-robot")
        if not any(m[0] == "/imu/data" for m in messages):
            fail("the demo's robot bag has no /imu/data")
        t0, t1 = messages[0][2], messages[-1][2]

        def merged_turns(name, msgs, storage=StoragePlugin.MCAP, split_at=None):
            bag = write_bag(Writer, storage, store, tmp / name, msgs, split_at)
            out = tmp / f"{name}.mcap"
            p = merge(tool, board, bag, out)
            if p.returncode != 0:
                fail(f"merge of the {name} bag: exit {p.returncode}: {p.stderr.strip()[-400:]}")
            return turns(tool, out), p.stdout + p.stderr

        plain, _ = merged_turns("plain", messages)
        same_turns("plain", plain, plain, 0.0)

        # A raw IMU: no orientation, its rate (the yaw's central difference) only.
        imu = [(t, msg) for topic, _, t, msg in messages if topic == "/imu/data"]
        yaw = [math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))
               for q in (m.orientation for _, m in imu)]
        wrap = lambda d: (d + math.pi) % (2 * math.pi) - math.pi  # noqa: E731
        rates = {}
        for i, (t, _) in enumerate(imu):
            a, b = max(i - 1, 0), min(i + 1, len(imu) - 1)
            rates[t] = wrap(yaw[b] - yaw[a]) / ((imu[b][0] - imu[a][0]) * 1e-9)
        raw = []
        for topic, msgtype, t, msg in messages:
            if topic == "/imu/data":
                msg.orientation.x = msg.orientation.y = msg.orientation.z = msg.orientation.w = 0.0
                msg.orientation_covariance = msg.orientation_covariance.copy()
                msg.orientation_covariance[0] = -1.0
                msg.angular_velocity.z = rates[t]
                msg.angular_velocity_covariance = msg.angular_velocity_covariance.copy()
                msg.angular_velocity_covariance[0] = 0.0
            raw.append((topic, msgtype, t, msg))
        got, said = merged_turns("raw-imu", raw)
        if "integrated from angular_velocity.z" not in said:
            fail(f"raw-imu: merge did not say the yaw is integrated: {said.strip()[-300:]}")
        same_turns("raw-imu", got, plain, 0.005)

        messages = read_bag(AnyReader, demo / "run-1-robot")
        got, _ = merged_turns("sqlite3-split", messages, StoragePlugin.SQLITE3, (t0 + t1) // 2)
        same_turns("sqlite3-split", got, plain, 0.0)

        mid = (t0 + t1) // 2
        got, _ = merged_turns("partial", [m for m in messages if abs(m[2] - mid) <= 10_000_000_000])
        # The demo's robot clock is the board's: the run starts with the bag's first message.
        at = (mid - t0) * 1e-9
        same_turns("partial", got, plain, 0.002, span=(at - 10.0, at + 10.0))

        mirrored = []
        for topic, msgtype, t, msg in read_bag(AnyReader, demo / "run-1-robot"):
            if topic == "/cmd_vel":
                msg.angular.z = -msg.angular.z
            mirrored.append((topic, msgtype, t, msg))
        bag = write_bag(Writer, StoragePlugin.MCAP, store, tmp / "mirrored", mirrored)
        p = merge(tool, board, bag, tmp / "mirrored.mcap")
        if p.returncode == 0 or "turns the other way" not in p.stderr:
            fail(f"the mirrored bag: exit {p.returncode}, {p.stderr.strip()[-300:]!r}")
        print("check-robot-bags: mirrored: refused (" + p.stderr.strip().splitlines()[-1][:120] + ")")


if __name__ == "__main__":
    main()

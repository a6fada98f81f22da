#!/usr/bin/env python3
"""Runs every command the README and the guide show, as a user would type it.

    .ci/doc-commands.py HOST_TOOL DEMO_OUT

Commands come from the `sh` blocks and the inline `host-tool ...` spans of README.md and docs/*.md,
and from the examples of every `--help` (docs/cli.md). Each page runs in order in its own scratch
directory, as a user follows a page; each `--help` example runs alone. The inputs a command names
are the demo's outputs (DEMO_OUT, made by CI's demo step), put in place just before it runs:
`run-1.mcap` is the demo's first run, `my-run-2.csv` its second as a run CSV, and so on. A file a
command writes (`--out`, `--json`, convert's OUT, ...) is never put in place beforehand.

The board is a replay: a port (`/dev/ttyACM0`, `/dev/rover-power`) becomes the pty of
`host-tool replay --to-pty` on the demo's first run. `replay --serve` and `demo --serve` wait for a
viewer: a minimal Foxglove WebSocket client subscribes to every channel and must receive data.

A `python` block runs as a script with python3 in the page's directory (the `rover_power` package
installed by CI's Python step), the demo's outputs at `demo-out/`; a `text` block after it is its
output.

A command that cannot run without hardware is listed in NOT_HERE with the reason; a listed command
that no page shows any more fails the check, so the list cannot go stale. Nothing is written into
the tree.
"""

import base64
import json
import os
import re
import shlex
import shutil
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time
from fnmatch import fnmatch
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md"] + sorted(p for p in (ROOT / "docs").glob("*.md") if p.name != "cli.md")
CLI_REFERENCE = ROOT / "docs" / "cli.md"
TIMEOUT_S = 300

# Commands that need hardware, or that CI runs as its own step, with the reason.
NOT_HERE = {
    "cargo test --workspace": "the README's test command: CI's test step runs it as written",
    "cargo fw-run": "flashes a board through a debug probe; CI builds the same image (firmware step)",
    "./firmware/build-image.sh": "CI's firmware step runs it",
    "dfu-util -a 0 -s 0x08000000:leave -D target/thumbv7em-none-eabihf/firmware/firmware.bin":
        "needs a board in DFU mode",
    "host-tool check": "needs a board that answers Configure (a replay does not); "
        "`check --simulated` runs the same steps on the simulated board",
    "host-tool check --port /dev/ttyACM0 --json check.json": "needs a board that answers Configure",
    "sudo cp firmware/99-rover-power.rules /etc/udev/rules.d/": "installs a udev rule (root)",
    "sudo udevadm control --reload-rules && sudo udevadm trigger": "reloads udev (root)",
    "pip install ./python": "installs into the machine's Python from the repository's root; "
        "CI's Python step runs it as written",
    "pip install matplotlib": "CI's Python step installs it",
    "pip install rerun-sdk": "CI's Rerun step installs it (pinned)",
    "rerun run-1.mcap": "opens the Rerun viewer's window; CI converts the same log instead",
    "rerun run-1.rrd rover-power.rbl": "opens the Rerun viewer's window",
    "cargo install --locked --path host-tool": "installs into ~/.cargo/bin; CI puts its release "
        "build on PATH as `host-tool` instead",
}

# Exit codes other than 0 that a command is documented to give.
EXPECTED_EXIT = {
    "host-tool check --simulated --fault missing-chip": 1,  # a FAIL line: the check's point
    # `cat` ends with EIO when the replay hangs up its pty (on a board's port, `timeout` ends it: 124)
    "stty -F /dev/ttyACM0 raw -echo && timeout 10 cat /dev/ttyACM0 > capture.bin": 1,
}

# Options whose value a command writes; convert's second argument too.
OUTPUT_OPTIONS = {"--out", "--json", "--to", "--next-runs", "--figure", "--commands-out"}
PORTS = ("/dev/ttyACM0", "/dev/rover-power")
SYNOPSIS = re.compile(r"[\[<…]|\b[A-Z]{3,}\b|\bR\.toml\b")
# A `python` block's code, as a command: this prefix, then the code.
PYTHON = "python3 <<block>>\n"


def commands_of_page(path):
    """The page's commands in order, as (line, command, shown output): sh blocks (continuations
    joined, comments cut) and inline `host-tool ...` spans outside blocks. The `text` blocks after
    an sh block, up to the next one or the next heading, are the output of its last command."""
    found, block, in_block, lang, last = [], [], False, "", None
    for number, line in enumerate(path.read_text().splitlines(), 1):
        fence = re.match(r"^\s*```(\w*)", line)
        if fence:
            if in_block and lang == "sh":
                found += [(number, c, []) for c in logical_lines(block)]
                last = found[-1] if found else None
            elif in_block and lang == "python":
                found.append((number, PYTHON + "\n".join(block) + "\n", []))
                last = found[-1]
            elif in_block and lang == "text" and last is not None:
                last[2].append(block)
            in_block, lang, block = not in_block, fence.group(1), []
            continue
        if in_block:
            block.append(line)
        elif line.startswith("#"):
            last = None  # output shown under another heading is not this command's
        else:
            found += [(number, m, []) for m in re.findall(r"`(host-tool [^`]*)`", line)]
    return found


def missing_output(shown, out):
    """The first line of a shown output block that the command's output lacks, else None. The
    lines must come in order; `…` in a line stands for any text, a line of `…` alone for any
    lines."""
    at = 0
    lines = out.splitlines()
    for want in shown:
        if want.strip() == "…":
            continue
        pattern = re.compile(".*?".join(re.escape(part) for part in want.split("…")) + "$")
        while at < len(lines) and not pattern.match(lines[at]):
            at += 1
        if at == len(lines):
            return want
        at += 1
    return None


def logical_lines(lines):
    out, pending = [], ""
    for line in lines:
        line = pending + line.strip()
        if line.endswith("\\"):
            pending = line[:-1]
            continue
        pending = ""
        line = re.sub(r"\s+#.*$", "", line).strip()
        if line:
            out.append(line)
    return out


def examples_of_cli_reference():
    """Every `--help`'s examples. A line in an Examples section that is not a whole command (a
    wrapped one) is an error: the user could not copy it."""
    found, in_examples = [], False
    for number, line in enumerate(CLI_REFERENCE.read_text().splitlines(), 1):
        if line == "Examples:":
            in_examples = True
        elif in_examples and not line.strip():
            in_examples = False
        elif in_examples:
            if not line.startswith("  host-tool "):
                sys.exit(f"docs/cli.md:{number}: an example wrapped onto a second line: {line!r}")
            found.append((number, re.sub(r"\s+#.*$", "", line).strip(), []))
    return found


def normalised(command):
    if command.startswith(PYTHON):
        return command
    return re.sub(r"^cargo run (--release )?-p host-tool -- ", "host-tool ", command)


class Fixture:
    """The inputs commands may name, made from the demo's outputs."""

    def __init__(self, host_tool, demo_out, scratch):
        self.dir = scratch / "fixture"
        self.dir.mkdir()
        self.files = {}
        demo_out = Path(demo_out)
        runs = sorted(demo_out.glob("run-*.mcap"))
        if len(runs) < 2:
            sys.exit(f"{demo_out}: the demo's outputs need two runs or more")
        for n, mcap in enumerate(runs, 1):
            csv = mcap.with_suffix(".csv")
            self.files[f"runs/run-{n}.mcap"] = mcap
            self.files[f"run-{n}.mcap"] = mcap
            self.files[f"run-{n}.csv"] = csv
            self.files[f"my-run-{n}.csv"] = csv
        self.files["runs/first.mcap"] = runs[0]
        # A log of the earlier version (JSON samples, model and status), as `convert` rewrites.
        self.files["old.mcap"] = ROOT / "host-tool/tests/fixtures/mcap/json-channels-v3.mcap"
        self.files["sand-1.csv"] = runs[0].with_suffix(".csv")
        self.files["turns.commands.csv"] = runs[0].with_suffix(".commands.csv")
        self.files["demo-out"] = demo_out
        self.files["rovers"] = ROOT / "rovers"
        self.files["examples"] = ROOT / "examples"
        self.files["rerun"] = ROOT / "rerun"
        capture = self.dir / "capture.bin"
        run([host_tool, "replay", "--quiet", "--to", capture, runs[0]])
        self.files["capture.bin"] = capture
        # A calibration drive on hard ground, by the same simulated board.
        hard = self.dir / "hard"
        run([host_tool, "demo", "--quiet", "--world", ROOT / "worlds/husky-hard-ground.toml",
             "--runs", "1", "--out", hard])
        self.files["hard-1.csv"] = hard / "run-1.csv"
        # A drive with the robot's own bag (`demo --robot-bag`), for the ROS 2 page.
        robot = self.dir / "robot"
        run([host_tool, "demo", "--quiet", "--robot-bag", "--robot-clock-offset-s", "7.3",
             "--runs", "1", "--out", robot])
        self.files["drive-1.mcap"] = robot / "run-1.mcap"
        self.files["rosbag2_drive"] = robot / "run-1-robot"
        self.run_1 = runs[0]

    def put_inputs(self, tokens, workdir):
        """Copies into workdir each fixture file the command reads and workdir lacks."""
        writes = {tokens[i + 1] for i, t in enumerate(tokens[:-1]) if t in OUTPUT_OPTIONS}
        positional = [t for t in tokens[2:] if not t.startswith("-")]
        if tokens[1:2] == ["convert"] and len(positional) >= 2:
            writes.add(positional[1])
        for token in tokens:
            if token in writes:
                continue
            for name, source in self.files.items():
                whole = name == token or ("*" in token and fnmatch(name, token))
                if whole or (source.is_dir() and token.startswith(name + "/")):
                    target = workdir / name
                    if target.exists() or target.is_symlink():
                        continue
                    target.parent.mkdir(parents=True, exist_ok=True)
                    if source.is_dir():
                        target.symlink_to(source)
                    else:
                        shutil.copyfile(source, target)


def run(argv, **kw):
    done = subprocess.run([str(a) for a in argv], capture_output=True, text=True, **kw)
    if done.returncode != 0:
        sys.exit(f"fixture: {' '.join(map(str, argv))} failed:\n{done.stderr}")
    return done


class Replay:
    """`host-tool replay --to-pty` on the demo's first run: the board a port command reads."""

    def __init__(self, host_tool, log):
        self.proc = subprocess.Popen(
            [host_tool, "replay", "--quiet", "--to-pty", "--as-fast-as-possible", str(log)],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        self.pty = self.proc.stdout.readline().strip()
        if not self.pty.startswith("/dev/"):
            sys.exit(f"replay --to-pty printed no pty: {self.pty!r} {self.proc.stderr.read()}")

    def close(self):
        try:
            self.proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()


class Viewer(threading.Thread):
    """A minimal Foxglove WebSocket client (foxglove.websocket.v1): subscribes to every channel
    advertised and counts the messages until the server closes."""

    def __init__(self, url):
        super().__init__(daemon=True)
        self.url, self.messages, self.close_code, self.error = url, 0, None, None

    def run(self):
        try:
            self.talk()
        except Exception as e:  # reported by the caller
            self.error = repr(e)

    def talk(self):
        host, port = re.match(r"ws://([^:/]+):(\d+)", self.url).groups()
        sock = socket.create_connection((host, int(port)), timeout=60)
        key = base64.b64encode(os.urandom(16)).decode()
        sock.sendall((f"GET / HTTP/1.1\r\nHost: {host}:{port}\r\nUpgrade: websocket\r\n"
                      f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
                      "Sec-WebSocket-Version: 13\r\n"
                      "Sec-WebSocket-Protocol: foxglove.websocket.v1\r\n\r\n").encode())
        head = b""
        while b"\r\n\r\n" not in head:
            head += sock.recv(1)
        if b" 101 " not in head.split(b"\r\n")[0]:
            raise RuntimeError(f"no WebSocket upgrade: {head[:80]!r}")
        subscription = 0
        while True:
            opcode, payload = read_frame(sock)
            if opcode == 1:
                op = json.loads(payload)
                if op.get("op") == "advertise":
                    subs = []
                    for channel in op["channels"]:
                        subscription += 1
                        subs.append({"id": subscription, "channelId": channel["id"]})
                    send_text(sock, json.dumps({"op": "subscribe", "subscriptions": subs}))
            elif opcode == 2 and payload[:1] == b"\x01":
                self.messages += 1
            elif opcode == 8:
                self.close_code = struct.unpack(">H", payload[:2])[0] if len(payload) >= 2 else None
                return


def read_exact(sock, n):
    data = b""
    while len(data) < n:
        chunk = sock.recv(n - len(data))
        if not chunk:
            raise RuntimeError("connection closed without a close frame")
        data += chunk
    return data


def read_frame(sock):
    first, second = read_exact(sock, 2)
    length = second & 0x7F
    if length == 126:
        length = struct.unpack(">H", read_exact(sock, 2))[0]
    elif length == 127:
        length = struct.unpack(">Q", read_exact(sock, 8))[0]
    return first & 0x0F, read_exact(sock, length)


def send_text(sock, text):
    data, mask = text.encode(), os.urandom(4)
    head = bytes([0x81])
    head += bytes([0x80 | len(data)]) if len(data) < 126 else bytes([0x80 | 126]) + struct.pack(">H", len(data))
    sock.sendall(head + mask + bytes(b ^ mask[i % 4] for i, b in enumerate(data)))


def run_command(command, shown, workdir, fixture, bin_dir, host_tool):
    """Runs one command in workdir; returns None when it did what the page says, else why not."""
    if command.startswith(PYTHON):
        script = workdir / f"block-{len(list(workdir.glob('block-*.py')))}.py"
        script.write_text(command.removeprefix(PYTHON))
        if not (workdir / "demo-out").exists():
            (workdir / "demo-out").symlink_to(fixture.files["demo-out"])
        command = f"python3 {script.name}"
    tokens = shlex.split(command)
    shell = command
    if tokens[0] in ("host-tool", "python3", "rerun"):
        fixture.put_inputs(tokens, workdir)
    replay = None
    if any(p in command for p in PORTS):
        replay = Replay(host_tool, fixture.run_1)
        for p in PORTS:
            shell = shell.replace(p, replay.pty)
    shell = shell.replace("/tmp/demo", str(workdir / "tmp-demo"))
    env = dict(os.environ, PATH=f"{bin_dir}{os.pathsep}{os.environ['PATH']}")
    serve = tokens[:2] in (["host-tool", "demo"], ["host-tool", "replay"]) and "--serve" in tokens
    to_pty = tokens[:2] == ["host-tool", "replay"] and "--to-pty" in tokens
    started = time.monotonic()
    proc = subprocess.Popen(["sh", "-c", shell], cwd=workdir, env=env, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            start_new_session=True)
    viewer = None
    try:
        if serve:
            viewer = watch(proc, tokens[1] == "demo")
        if to_pty:
            read_pty(proc, host_tool, workdir)
        out, err = proc.communicate(timeout=TIMEOUT_S)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        return f"no end within {TIMEOUT_S} s"
    finally:
        if replay:
            replay.close()
    expected = EXPECTED_EXIT.get(command, 0)
    seconds = time.monotonic() - started
    interrupted = viewer is not None and tokens[1] == "demo" and proc.returncode in (130, -2)
    # A demo stopped by Ctrl-C drops its viewers without a close frame (Studio: "connection lost").
    dropped = interrupted and viewer.error and "without a close frame" in viewer.error
    if viewer is not None and ((viewer.error and not dropped) or viewer.messages == 0):
        return f"the viewer got {viewer.messages} messages ({viewer.error or 'no error'})"
    if proc.returncode != expected and not interrupted:
        return (f"exit {proc.returncode}, expected {expected}\n--- stdout\n{out[-3000:]}"
                f"\n--- stderr\n{err[-3000:]}")
    for block in shown:
        missing = missing_output(block, out)
        if missing is not None:
            return f"the page shows a line its output lacks:\n{missing}\n--- stdout\n{out[-3000:]}"
    note = f" (viewer: {viewer.messages} messages)" if viewer else ""
    note += f" (output as shown: {sum(map(len, shown))} lines)" if shown else ""
    print(f"  ok {seconds:6.1f} s  {command}{note}")
    return None


def read_pty(proc, host_tool, workdir):
    """`replay --to-pty` streams once a reader opens the pty it prints: `record` on it, as its
    example says. The recording must hold samples."""
    pty = proc.stdout.readline().strip()
    out = workdir / "from-pty.mcap"
    done = subprocess.run([str(host_tool), "record", "--quiet", "--port", pty, "--out", str(out)],
                          capture_output=True, text=True, timeout=TIMEOUT_S)
    if done.returncode != 0 or out.stat().st_size == 0:
        raise RuntimeError(f"record on the replay's pty {pty!r} failed: {done.stderr}")


def watch(proc, interrupt):
    """Connects a viewer to the address the command prints. `demo --serve` plays its runs at real
    time: once the viewer has data, Ctrl-C ends it, as a user watching would."""
    err_lines = []
    url = None
    for line in proc.stderr:
        err_lines.append(line)
        m = re.search(r"ws://[\w.]+:\d+", line)
        if m:
            url = m.group(0)
            break
    if url is None:
        raise RuntimeError("no live-view address printed: " + "".join(err_lines))
    # Keep draining stderr so the command never blocks on a full pipe.
    threading.Thread(target=lambda: err_lines.extend(proc.stderr), daemon=True).start()
    viewer = Viewer(url)
    viewer.start()
    if interrupt:
        deadline = time.monotonic() + 60
        while viewer.messages < 200 and time.monotonic() < deadline and viewer.is_alive():
            time.sleep(0.1)
        os.killpg(proc.pid, signal.SIGINT)
    viewer.join(timeout=TIMEOUT_S)
    proc.stderr = None
    return viewer


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    host_tool, demo_out = Path(sys.argv[1]).resolve(), Path(sys.argv[2]).resolve()
    scratch = Path(tempfile.mkdtemp(prefix="doc-commands-"))
    bin_dir = scratch / "bin"
    bin_dir.mkdir()
    (bin_dir / "host-tool").symlink_to(host_tool)
    fixture = Fixture(host_tool, demo_out, scratch)

    sessions = [(p.relative_to(ROOT), commands_of_page(p)) for p in PAGES]
    sessions += [(f"{CLI_REFERENCE.relative_to(ROOT)}:{n}", [(n, c, [])])
                 for n, c, _ in examples_of_cli_reference()]
    # DOC_ONLY=README.md,docs/ros2.md: those pages alone (to try a page; CI runs them all).
    only = [p for p in os.environ.get("DOC_ONLY", "").split(",") if p]
    if only:
        sessions = [(w, c) for w, c in sessions if any(str(w).startswith(p) for p in only)]
    failures, seen, ran, skipped = [], set(), 0, 0
    for index, (where, commands) in enumerate(sessions):
        if not commands:
            continue
        print(f"{where}")
        workdir = scratch / f"session-{index}"
        workdir.mkdir()
        for number, command, shown in commands:
            command = normalised(command)
            seen.add(command)
            if command in NOT_HERE:
                print(f"  not here: {command}  ({NOT_HERE[command]})")
                skipped += 1
                continue
            if command.startswith("host-tool ") and SYNOPSIS.search(command):
                print(f"  synopsis: {command}")
                skipped += 1
                continue
            ran += 1
            why = run_command(command, shown, workdir, fixture, bin_dir, host_tool)
            if why:
                failures.append(f"{where}:{number}: {command}\n{why}")
                print(f"  FAILED {command}")
    stale = [] if only else sorted(set(NOT_HERE) - seen)
    for command in stale:
        failures.append(f"NOT_HERE lists a command no page shows any more: {command}")
    shutil.rmtree(scratch, ignore_errors=True)
    print(f"\n{ran} documented commands ran, {skipped} not (synopses, or listed above with the reason)")
    if failures:
        print("\n\n".join(failures))
        sys.exit(1)


if __name__ == "__main__":
    main()

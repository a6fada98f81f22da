"""The Python package against the host tool's command line and pandas: every result is compared
with what the CLI writes (`--json`, `convert`) or what pandas reads from the same file, never
with values written down here."""

import gc
import json
import os
import pathlib
import random
import subprocess
import sys
import warnings

import numpy as np
import pandas as pd
import pytest

import rover_power as rp
from conftest import ROOT, cli


def cli_json(host_tool, *args):
    return json.loads(cli(host_tool, *args, "--json", "-").stdout)


def cli_error(host_tool, *args) -> str:
    done = cli(host_tool, *args, ok=False)
    assert done.returncode == 1, (done.returncode, done.stderr)
    lines = [l for l in done.stderr.splitlines() if l.startswith("Error: ")]
    assert len(lines) == 1, done.stderr
    return lines[0].removeprefix("Error: ")


def same_frame(ours: pd.DataFrame, theirs: pd.DataFrame):
    """Same columns in the same order, same index, same values bit for bit (NaN where NaN)."""
    assert list(ours.columns) == list(theirs.columns)
    assert ours.index.name == theirs.index.name
    np.testing.assert_array_equal(ours.index.to_numpy(), theirs.index.to_numpy())
    np.testing.assert_array_equal(ours.to_numpy(), theirs.to_numpy())


# --- read_run -------------------------------------------------------------------------------


def test_run_csv_reads_as_pandas_reads_it(demo_out):
    path = demo_out / "run-1.csv"
    df = rp.read_run(path)
    same_frame(df, pd.read_csv(path, index_col="t_s"))
    assert (df.dtypes == np.float64).all()
    assert rp.COLUMNS == ["t_s", *df.columns]


def test_a_frame_owns_its_memory_and_can_be_written(demo_out):
    """The columns are vectors the reader hands numpy: they outlive every other reference to
    the call's result, a frame can be changed in place like any other, and what one frame
    changes no other read sees."""
    path = demo_out / "run-1.csv"
    df = rp.read_run(path)
    expected = pd.read_csv(path, index_col="t_s")
    for _ in range(3):
        rp.read_run(path)  # other reads come and go
    gc.collect()
    same_frame(df, expected)
    column = df["left_current_a"].to_numpy()
    assert column.dtype == np.float64 and column.flags["C_CONTIGUOUS"]
    df.iloc[0, 0] = -1.0
    df.loc[df.index[1], "right_current_a"] += 1.0
    df.loc[df.index < df.index[10], "left_current_a"] = np.nan
    assert df.iloc[0, 0] == -1.0
    assert df["right_current_a"].iloc[1] == expected["right_current_a"].iloc[1] + 1.0
    assert df["left_current_a"].iloc[:10].isna().all()
    same_frame(rp.read_run(path), expected)
    df["power_w"] = df["left_bus_v"] * df["left_current_a"]  # a new column, as on any frame
    view = np.asarray(df["left_bus_v"])
    del df
    gc.collect()
    assert view[0] == -1.0
    np.testing.assert_array_equal(view[1:], expected["left_bus_v"].to_numpy()[1:])


def test_the_native_columns_are_numpys_to_write(demo_out):
    """What `_native.read_run` hands numpy is writable and each array its own memory."""
    columns, _ = rp._native.read_run(str(demo_out / "run-1.csv"), False, "physical")
    assert len(columns) == len(rp.COLUMNS)
    arrays = [np.asarray(column) for column in columns]
    for array in arrays:
        assert array.dtype == np.float64 and array.flags.writeable
    arrays[1][:] = 7.0
    assert not any(np.shares_memory(arrays[1], a) for a in arrays[2:])
    del columns
    gc.collect()
    assert (arrays[1] == 7.0).all()


def test_mcap_log_reads_as_its_run_csv(host_tool, demo_runs, tmp_path):
    """An MCAP log holds the samples `convert` writes to a run CSV: the same frame."""
    csv = tmp_path / "run.csv"
    cli(host_tool, "convert", demo_runs[0], str(csv))
    df = rp.read_run(demo_runs[0])
    same_frame(df, pd.read_csv(csv, index_col="t_s"))
    assert len(df) > 1000


def test_every_message_of_a_log_decodes_with_the_official_mcap_decoders(demo_runs):
    """A reader with only the `mcap` package and `mcap-protobuf-support` (plus `json` for the
    command and event channels) decodes every message of a demo log from the schemas in the
    file; the sample batches' columns (the chips' registers turned into volts and amps as the
    host tool does) are `read_run`'s samples, to the bit."""
    from mcap.decoder import DecoderFactory as JsonFactoryBase
    from mcap.reader import make_reader
    from mcap_protobuf.decoder import DecoderFactory

    class JsonFactory(JsonFactoryBase):
        def decoder_for(self, message_encoding, schema):
            return json.loads if message_encoding == "json" else None

    counts, batches, models = {}, [], []
    samples = 0  # written before the batch at hand
    with open(demo_runs[0], "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory(), JsonFactory()])
        for _schema, channel, message, decoded in reader.iter_decoded_messages():
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            if channel.topic == "/rover_power/sample_batch":
                t_s = np.asarray(decoded.t_s)
                n = len(t_s)
                assert message.sequence == samples  # a batch's sequence counts samples
                samples += n
                # A demo's readings are the chips' registers.
                assert decoded.HasField("current_lsb_na")
                columns = [t_s]
                for side in [decoded.left, decoded.right]:
                    bus_v = np.asarray(side.bus_raw, dtype=np.float64) * 1250.0 / 1e6
                    current_a = (np.asarray(side.current_raw, dtype=np.float64)
                                 * float(decoded.current_lsb_na) / 1e9)
                    assert len(side.bus_v) == len(side.current_a) == 0
                    # The power is a float, for viewers: bus × current rounded.
                    np.testing.assert_array_equal(np.asarray(side.power_w, dtype=np.float32),
                                                  (bus_v * current_a).astype(np.float32))
                    columns += [bus_v, current_a]
                columns += [np.asarray(decoded.left.cmd_mps), np.asarray(decoded.right.cmd_mps)]
                for name in ["yaw_rad", "pitch_deg", "x_m", "y_m"]:  # NaN where not measured
                    column = np.asarray(getattr(decoded, name))
                    columns.append(column if len(column) else np.full(n, np.nan))
                assert all(len(column) == n for column in columns)
                batches.append(np.column_stack(columns))
            elif channel.topic == "/rover_power/model":
                models.append(decoded.total_energy_j)
    assert set(counts) == {"/rover_power/" + t for t in
                           ["sample_batch", "model", "status", "command", "event", "frame"]}, counts
    df = rp.read_run(demo_runs[0])
    ours = np.concatenate(batches)
    assert len(ours) == len(df) == samples
    assert len(batches) < len(df) / 10  # batched, not one sample a message
    np.testing.assert_array_equal(ours[:, 0], df.index.to_numpy())
    for i, column in enumerate(rp.COLUMNS[1:], start=1):
        np.testing.assert_array_equal(ours[:, i], df[column].to_numpy(), err_msg=column)
    # The board's energy only grows over a run that never resets.
    assert models == sorted(models) and models[-1] > 0


def test_a_ros2_bag_reads_as_its_log(host_tool, demo_runs, tmp_path):
    """A user who keeps only the bag `convert --to ros2-bag` wrote reads the same samples from
    the bag directory and from its MCAP file as from the log."""
    bag = tmp_path / "drive"
    cli(host_tool, "convert", demo_runs[0], str(bag), "--to", "ros2-bag")
    expected = rp.read_run(demo_runs[0])
    for run in [bag, bag / "drive_0.mcap"]:
        same_frame(rp.read_run(str(run)), expected)


def test_mcap_events_are_the_logs(demo_runs):
    events = rp.read_run(demo_runs[0]).attrs["events"]
    kinds = [e["kind"] for e in events]
    assert kinds[0] == "started" and kinds[-1] == "stopped", kinds
    assert "wall-clock" in kinds
    clock = next(e for e in events if e["kind"] == "wall-clock")
    assert isinstance(clock["unix_ns"], int) and clock["unix_ns"] > 1_600_000_000 * 10**9
    times = [e["t_s"] for e in events]
    assert times == sorted(times)


def test_a_foreign_csv_in_its_own_column_order(demo_out, tmp_path):
    """A run CSV written by pandas, columns shuffled, an extra column, CRLF line ends and
    fewer digits: read by the general reader, in the run CSV's column order."""
    theirs = pd.read_csv(demo_out / "run-2.csv", index_col="t_s")
    shuffled = theirs.reset_index()
    order = list(shuffled.columns)
    random.Random(7).shuffle(order)
    shuffled = shuffled[order]
    shuffled["operator_note"] = "ok"
    path = tmp_path / "foreign.csv"
    shuffled.to_csv(path, index=False, lineterminator="\r\n", float_format="%.9g")
    same_frame(rp.read_run(path), pd.read_csv(path, index_col="t_s")[theirs.columns])


def test_a_run_csvs_events_file_is_read(demo_out, tmp_path):
    path = tmp_path / "run.csv"
    path.write_bytes((demo_out / "run-1.csv").read_bytes())
    assert rp.read_run(path).attrs["events"] == []
    lines = [
        {"t_s": 1.5, "kind": "device-vanished", "port": "/dev/ttyACM0"},
        {"t_s": 2.25, "kind": "reconnected", "port": "/dev/ttyACM0", "offline_s": 0.75},
    ]
    (tmp_path / "run.events.jsonl").write_text("".join(json.dumps(l) + "\n" for l in lines))
    assert rp.read_run(path).attrs["events"] == lines


# --- validate, diagnose, plan: the CLI's --json ----------------------------------------------


def test_validate_is_the_clis_json(host_tool, demo_runs):
    assert rp.validate(None, demo_runs) == cli_json(host_tool, "validate", "--runs", *demo_runs)


def test_diagnose_is_the_clis_json(host_tool, demo_runs):
    ours = rp.diagnose(None, demo_runs)
    assert ours == cli_json(host_tool, "diagnose", "--runs", *demo_runs)
    assert ours["effect"]  # a verdict, whichever it is


def test_diagnose_with_calibration_runs_and_a_rover_file(host_tool, demo_runs):
    rover = ROOT / "rovers" / "husky-a200.toml"
    ours = rp.diagnose(rover, demo_runs[1:], calibration=demo_runs[0])
    theirs = cli_json(
        host_tool,
        "diagnose",
        "--rover",
        str(rover),
        "--calibration",
        demo_runs[0],
        "--runs",
        *demo_runs[1:],
    )
    assert ours == theirs


def test_diagnose_a_published_table(host_tool):
    """The thesis' Table 6.1 as a path table: its own judgement, as on the command line."""
    table = ROOT / "examples" / "husky-sand-table-6.1.csv"
    assert rp.diagnose(None, table) == cli_json(host_tool, "diagnose", "--runs", str(table))


def test_plan_is_the_clis_json(host_tool, demo_out):
    args = ["--start-deg", "90", "--end-deg", "45", "--distance-m", "7.5"]
    assert rp.plan(90, 45, 7.5) == cli_json(host_tool, "plan", *args)
    model = demo_out / "diagnosis" / "model.toml"
    assert rp.plan(90, 45, 7.5, model=model) == cli_json(
        host_tool, "plan", *args, "--model", str(model)
    )


# --- errors and damage ------------------------------------------------------------------------


def test_a_malformed_csv_is_the_clis_error(host_tool, demo_out, tmp_path):
    lines = (demo_out / "run-1.csv").read_text().splitlines(keepends=True)
    cells = lines[5].split(",")
    cells[2] = "abc"
    lines[5] = ",".join(cells)
    path = tmp_path / "bad.csv"
    path.write_text("".join(lines))
    with pytest.raises(rp.RoverPowerError) as caught:
        rp.read_run(path)
    message = str(caught.value)
    assert "line 6, column 3 (left_current_a)" in message, message
    assert message == cli_error(host_tool, "validate", "--runs", str(path))
    with pytest.raises(rp.RoverPowerError) as again:
        rp.validate(None, path)
    assert str(again.value) == message


def test_missing_files_are_named(host_tool, tmp_path):
    missing = str(tmp_path / "nosuch.mcap")
    with pytest.raises(rp.RoverPowerError, match="nosuch.mcap") as caught:
        rp.read_run(missing)
    assert str(caught.value) == cli_error(host_tool, "validate", "--runs", missing)
    with pytest.raises(rp.RoverPowerError, match="nosuch.toml"):
        rp.diagnose(tmp_path / "nosuch.toml", missing)
    with pytest.raises(rp.RoverPowerError, match="nosuch-model.toml"):
        rp.plan(0, 0, 5, model=tmp_path / "nosuch-model.toml")


def test_bad_arguments_are_value_errors(demo_runs):
    with pytest.raises(ValueError, match="rig_range"):
        rp.read_run(demo_runs[0], rig_range="huge")
    with pytest.raises(rp.RoverPowerError, match="distance"):
        rp.plan(45, 45, -5)


def test_no_runs_is_a_value_error_that_says_so(demo_runs):
    """An empty list of runs (the command line requires --runs) is named as such, not as a
    run set without manoeuvres."""
    with pytest.raises(ValueError, match=r"^no runs given: diagnose needs at least one run log"):
        rp.diagnose(None, [])
    with pytest.raises(ValueError, match=r"^no runs given: diagnose needs"):
        rp.diagnose(None, [], calibration=demo_runs[0])
    with pytest.raises(ValueError, match=r"^no runs given: validate needs at least one run log"):
        rp.validate(None, [])


# Runs one call in a fresh Python (a call that hangs, as reading a FIFO without a writer did,
# is killed there rather than hanging the suite) and prints how long it took and how it ended.
CALL_IN_A_CHILD = """
import sys, time
import rover_power as rp
start = time.monotonic()
try:
    eval(sys.argv[1], {"rp": rp})
    outcome = "returned"
except rp.RoverPowerError as e:
    outcome = "RoverPowerError: " + str(e)
print(time.monotonic() - start)
print(outcome)
"""


# Each Python entry point with a path, that path a FIFO without a writer (made by the test),
# a device or a directory: the call, the path's name, and what the error must say it is.
NOT_A_FILE = [
    pytest.param("rp.read_run({path!r})", "run.csv", "is a named pipe (FIFO)", id="read_run"),
    pytest.param("rp.read_run({path!r})", "run.mcap", "is a named pipe (FIFO)", id="read_run-mcap"),
    pytest.param("rp.read_run({csv!r})", "copy.events.jsonl", "is a named pipe", id="events"),
    pytest.param("rp.read_run({path!r})", "dir.csv", "is a directory, not a file", id="dir"),
    pytest.param("rp.validate(None, [{run!r}, {path!r}])", "run.csv", "is a named", id="validate"),
    pytest.param("rp.validate({path!r}, {run!r})", "rover.toml", "is a named", id="validate-rover"),
    pytest.param("rp.diagnose(None, [{run!r}, {path!r}])", "run.mcap", "is a named", id="diagnose"),
    pytest.param("rp.diagnose({path!r}, {run!r})", "rover.toml", "is a named", id="diagnose-rover"),
    pytest.param(
        "rp.diagnose(None, {run!r}, calibration={path!r})",
        "run.csv",
        "is a named",
        id="calibration",
    ),
    pytest.param("rp.plan(90, 90, 10, model={path!r})", "model.toml", "is a named", id="plan"),
    pytest.param(
        "rp.plan(90, 90, 10, model={path!r})",
        "/dev/urandom",
        "is a character device",
        id="plan-urandom",
    ),
]


@pytest.mark.parametrize("call,name,kind", NOT_A_FILE)
def test_what_is_not_a_regular_file_is_refused_at_once(demo_runs, tmp_path, call, name, kind):
    """A FIFO without a writer once hung the call (opened twice, and Ctrl-C could not stop it),
    /dev/urandom as a model file was read forever: each is refused within 5 s, naming the
    path and what it is."""
    path = name if name.startswith("/") else str(tmp_path / name)
    if name == "dir.csv":
        os.mkdir(path)
    elif not name.startswith("/"):
        os.mkfifo(path)
    csv = tmp_path / "copy.csv"  # a regular run CSV with a FIFO for its events file
    csv.write_bytes(pathlib.Path(demo_runs[0]).with_suffix(".csv").read_bytes())
    code = call.format(path=path, csv=str(csv), run=demo_runs[0])
    try:
        done = subprocess.run(
            [sys.executable, "-c", CALL_IN_A_CHILD, code],
            capture_output=True,
            text=True,
            timeout=30,  # the import too, on a busy machine; the call itself must take < 5 s
        )
    except subprocess.TimeoutExpired:
        pytest.fail(f"{code} still running after 30 s")
    assert done.returncode == 0, done.stderr
    seconds, outcome = done.stdout.splitlines()
    assert float(seconds) < 5, (code, seconds)
    assert outcome.startswith(f"RoverPowerError: {path}: {kind}"), (code, outcome)


def test_an_mcap_log_cut_short_reads_to_the_cut_with_a_warning(demo_runs, tmp_path):
    data = pathlib.Path(demo_runs[0]).read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) // 2])
    with pytest.warns(rp.RoverPowerWarning, match="ends before its footer"):
        df = rp.read_run(cut)
    whole = rp.read_run(demo_runs[0])
    assert 0 < len(df) < len(whole)
    same_frame(df, whole.iloc[: len(df)])


def test_damage_is_an_error_unless_salvaged(host_tool, demo_runs, tmp_path):
    """As the CLI's exit code 4 unless --salvage."""
    data = bytearray(pathlib.Path(demo_runs[0]).read_bytes())
    at = len(data) * 3 // 10
    # 64 KiB: longer than the message indexes after a chunk, so it reaches a chunk's samples.
    data[at : at + 65536] = bytes(65536)
    damaged = tmp_path / "damaged.mcap"
    damaged.write_bytes(bytes(data))
    assert cli(host_tool, "validate", "--runs", str(damaged), ok=False).returncode == 4
    with warnings.catch_warnings(record=True):
        warnings.simplefilter("always")
        with pytest.raises(rp.RoverPowerError, match="salvage=True"):
            rp.read_run(damaged)
    with pytest.warns(rp.RoverPowerWarning, match="damaged, skipped"):
        df = rp.read_run(damaged, salvage=True)
    assert 0 < len(df) < len(rp.read_run(demo_runs[0]))


def test_damaged_logs_never_panic(demo_runs, tmp_path):
    """Seeded truncations and overwrites: a frame or a RoverPowerError, never a panic."""
    seed = 40
    rng = random.Random(seed)
    data = pathlib.Path(demo_runs[0]).read_bytes()
    path = tmp_path / "fuzzed.mcap"
    for case in range(60):
        damaged = bytearray(data[: rng.randrange(len(data) + 1)])
        for _ in range(rng.randrange(4)):
            if damaged:
                at = rng.randrange(len(damaged))
                damaged[at : at + rng.randrange(1, 200)] = rng.randbytes(rng.randrange(1, 200))
        path.write_bytes(bytes(damaged))
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                rp.read_run(path, salvage=True)
        except rp.RoverPowerError:
            pass
        except BaseException as e:  # a PanicException derives from BaseException
            pytest.fail(f"seed {seed}, case {case}: {type(e).__name__}: {e}")

"""Fixtures: the host tool's binary (the reference every result is compared with) and the
demo's runs. CI passes both (HOST_TOOL, ROVER_POWER_DEMO_OUT); alone, the binary is built and
a demo is run into a temporary directory."""

import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def host_tool() -> str:
    given = os.environ.get("HOST_TOOL")
    if given:
        return given
    subprocess.run(
        ["cargo", "build", "--release", "--quiet", "-p", "host-tool"], cwd=ROOT, check=True
    )
    target = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    return str(target / "release" / "host-tool")


@pytest.fixture(scope="session")
def demo_out(host_tool, tmp_path_factory) -> pathlib.Path:
    given = os.environ.get("ROVER_POWER_DEMO_OUT")
    if given:
        return pathlib.Path(given)
    out = tmp_path_factory.mktemp("demo") / "demo-out"
    subprocess.run([host_tool, "demo", "--out", str(out)], check=True, capture_output=True)
    return out


@pytest.fixture(scope="session")
def demo_runs(demo_out) -> list:
    runs = sorted(demo_out.glob("run-?.mcap"))
    assert len(runs) == 3, runs
    return [str(r) for r in runs]


def cli(host_tool, *args, ok=True) -> subprocess.CompletedProcess:
    """Runs the host tool; with ok, requires exit 0."""
    done = subprocess.run([host_tool, "--quiet", *args], capture_output=True, text=True)
    if ok:
        assert done.returncode == 0, done.stderr
    return done

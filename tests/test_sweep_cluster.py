"""Sweeps on a real Dask cluster: a `dask scheduler` and two `dask worker` processes on 127.0.0.1."""

import os
import shutil
import signal
import socket
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pandas as pd
import pytest

from mckibben.sweep import load_sweep, read_results, run_sweep

SWEEP = """
[sweep]
seed = 11
samples = 8
chunk_size = 1

[scenario]
kind = "step"
duration = "0.2s"

[plant]
supply_pressure = { uniform = ["0.6MPa", "1.0MPa"] }
load_force = { uniform = ["0N", "3N"] }

[controller]
kind = "smc"
beta = { grid = [120, 150, 180] }

[metrics]
keep = ["time_constant_s", "overshoot_pct", "valve_effort_counts"]
"""

DASK = shutil.which("dask") or str(Path(sys.executable).with_name("dask"))


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _wait_port(port: int, timeout: float = 30.0) -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        with socket.socket() as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return
        time.sleep(0.2)
    raise RuntimeError(f"scheduler on port {port} did not start")


@pytest.fixture
def cluster(tmp_path):
    """A scheduler and two single-threaded workers, each in its own process group."""
    if not os.path.exists(DASK):
        pytest.skip("the dask command line (dask[distributed]) is not installed")
    port = _free_port()
    addr = f"tcp://127.0.0.1:{port}"
    logs = tmp_path / "logs"
    logs.mkdir()
    procs = []

    def start(name, *args):
        log = open(logs / f"{name}.log", "wb")
        p = subprocess.Popen([DASK, *args], stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        procs.append(p)
        return p

    start("scheduler", "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard")
    _wait_port(port)
    workers = [start(f"worker{i}", "worker", addr, "--nworkers", "1", "--nthreads", "1", "--no-dashboard",
                     "--host", "127.0.0.1", "--death-timeout", "60") for i in range(2)]
    from distributed import Client

    with Client(addr, timeout="30s") as c:
        c.wait_for_workers(2, timeout=60)
    yield addr, workers
    for p in procs:
        try:
            os.killpg(p.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        p.wait(timeout=30)


@pytest.mark.slow
def test_cluster_equals_in_process_and_survives_a_killed_worker(cluster, tmp_path):
    addr, workers = cluster
    toml = tmp_path / "sweep.toml"
    toml.write_text(textwrap.dedent(SWEEP))
    sweep = load_sweep(toml)
    # 24 one-run chunks: enough that a worker killed after the first one lands mid-sweep
    assert sweep.n_chunks == 24

    local = tmp_path / "local"
    run_sweep(sweep, local)

    # through the command line, against the real scheduler
    remote = tmp_path / "remote"
    r = subprocess.run([sys.executable, "-m", "mckibben.cli", "sweep", "run", str(toml), "--out", str(remote),
                        "--scheduler", addr, "--json"], capture_output=True, text=True, timeout=240)
    assert r.returncode == 0, r.stderr
    pd.testing.assert_frame_equal(read_results(remote), read_results(local))  # identical numbers

    # again, killing one worker (and its nanny) once the first chunks are written
    killed = tmp_path / "killed"
    run = subprocess.Popen([sys.executable, "-m", "mckibben.cli", "sweep", "run", str(toml), "--out", str(killed),
                            "--scheduler", addr, "--json"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    end = time.monotonic() + 120
    while time.monotonic() < end and len(list(killed.glob("chunk-*.parquet"))) < 1:
        time.sleep(0.005)
    written_before = len(list(killed.glob("chunk-*.parquet")))
    os.killpg(workers[0].pid, signal.SIGKILL)
    out, err = run.communicate(timeout=240)
    assert run.returncode == 0, err
    assert written_before < sweep.n_chunks  # the kill really came mid-sweep
    result = read_results(killed)
    assert result["run_id"].is_unique and len(result) == sweep.n_runs  # nothing lost or duplicated
    pd.testing.assert_frame_equal(result, read_results(local))

"""The first compilation says so in a real Jupyter kernel too: once, with progress.

A notebook's first simulating cell on an empty kernel cache compiles for many seconds; the
command line has said so since the compile cache came, a notebook said nothing. These tests start
a real IPython kernel (jupyter_client) on an empty cache folder of their own.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

jupyter_client = pytest.importorskip("jupyter_client")
pytest.importorskip("ipykernel")

SRC = Path(__file__).resolve().parents[1] / "src"


def _run_cells(cells: list[str], cache: Path) -> list[str]:
    """Run each cell in one fresh kernel; return the stderr text each printed."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_", "MCKIBBEN_"))}
    env.update(PYTHONPATH=str(SRC), MCKIBBEN_CACHE_DIR=str(cache), MCKIBBEN_BACKGROUND_WARM="0")
    km, kc = jupyter_client.manager.start_new_kernel(kernel_name="python3", env=env)
    try:
        out = []
        for code in cells:
            err: list[str] = []

            def collect(msg, err=err):
                if msg["msg_type"] == "stream" and msg["content"]["name"] == "stderr":
                    err.append(msg["content"]["text"])
                if msg["msg_type"] == "error":
                    err.append("ERROR " + msg["content"]["ename"] + ": " + msg["content"]["evalue"])

            reply = kc.execute_interactive(code, timeout=600, output_hook=collect)
            assert reply["content"]["status"] == "ok", "".join(err)
            out.append("".join(err))
        return out
    finally:
        kc.stop_channels()
        km.shutdown_kernel(now=True)


@pytest.mark.slow
@pytest.mark.timeout(1200)  # two real kernels, the first compiling on an empty cache
def test_a_notebooks_first_simulating_cell_says_it_compiles_once_with_progress(tmp_path):
    first, second = _run_cells(["from mckibben import experiments\nr = experiments.open_loop()",
                                "r2 = experiments.step_response('pid')"], tmp_path / "cache")
    notice = "mckibben: compiling kernels once for this machine (up to a minute; later runs and kernels load them from "
    assert first.startswith(notice) and first.count("mckibben: compiling") == 1, first
    assert first.rstrip().endswith(".") and first.count(".") >= 2  # one dot per kernel compiled: progress
    assert "mckibben: compiling" not in second  # once per kernel process (its later compilations are dots)
    # a new kernel on the now warm cache loads what the first compiled: no notice
    (again,) = _run_cells(["from mckibben import experiments\nr = experiments.open_loop()"], tmp_path / "cache")
    assert "compiling" not in again, again

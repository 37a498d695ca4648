"""The public namespace and the API reference agree: every name of ``mckibben.__all__`` is in
docs/api.md and documented; nothing private leaks into ``dir(mckibben)``; ``.plot()`` shows once
in a real Jupyter kernel."""

from __future__ import annotations

import inspect
import pathlib
import queue

import pytest

import mckibben as mk

DOCS = pathlib.Path(__file__).resolve().parents[1] / "docs"
#: Entry points whose reference names the function where it lives, under another name.
ALIASES = {"track_pressure": "mckibben.experiments.track_pressure", "track_tip": "mckibben.experiments.track_tip"}


@pytest.mark.parametrize("name", sorted(set(mk.__all__) - {"__version__"}))
def test_every_public_name_is_in_the_reference_and_documented(name):
    api = (DOCS / "api.md").read_text(encoding="utf-8")
    obj = getattr(mk, name)
    target = ALIASES.get(name, name)
    assert target in api or f"mckibben.{name}" in api, f"{name} is missing from docs/api.md"
    assert inspect.getdoc(obj), f"mckibben.{name} has no docstring"


@pytest.mark.parametrize("name", ["read_muscle", "fit_table", "compare_table", "run_sweep", "get_muscle", "track_tip",
                                  "read_table", "PlantParams.from_muscle_file"])
def test_the_first_entry_points_are_in_the_reference(name):
    api = (DOCS / "api.md").read_text(encoding="utf-8")
    assert name in api or ALIASES.get(name, "-") in api


def test_nothing_private_is_exported():
    import mckibben.plant  # noqa: F401 - loads most of the package
    import mckibben.sweep  # noqa: F401

    public = [n for n in dir(mk) if not n.startswith("_")]
    for leak in ("Path", "PackageNotFoundError", "drop_stale", "version", "importlib"):
        assert leak not in public
    assert set(mk.__all__) <= set(dir(mk))


def test_getting_started_is_in_the_toctree():
    assert (DOCS / "getting-started.md").is_file()
    assert "getting-started" in (DOCS / "index.md").read_text(encoding="utf-8")


def test_plot_shows_once_in_a_jupyter_kernel():
    jupyter_client = pytest.importorskip("jupyter_client")
    pytest.importorskip("ipykernel")
    km, kc = jupyter_client.manager.start_new_kernel(kernel_name="python3")
    try:
        code = ("%matplotlib inline\n"
                "import mckibben as mk\n"
                "from mckibben.tool import map_workspace\n"
                "map_workspace(grid=3).plot()\n")
        msg_id = kc.execute(code)
        images, error = 0, None
        while True:
            try:
                msg = kc.get_iopub_msg(timeout=240)
            except queue.Empty:
                pytest.fail("the kernel did not answer")
            if msg["parent_header"].get("msg_id") != msg_id:
                continue
            kind, content = msg["msg_type"], msg["content"]
            if kind in ("display_data", "execute_result") and "image/png" in content.get("data", {}):
                images += 1
            elif kind == "error":
                error = content.get("ename"), content.get("evalue")
            elif kind == "status" and content.get("execution_state") == "idle":
                break
        assert error is None, error
        assert images == 1
    finally:
        kc.stop_channels()
        km.shutdown_kernel(now=True)

"""Steering the three-muscle tool through the link: `tool track --port` against `rig emulate`.

Both are real processes on a real pty; the device (either engine: the Python emulator, or the
firmware image in simavr) runs the tool's three muscles. The tip error
through the link depends on how evenly the host's references reach the device (a loaded host
sends late): the assertions bound it loosely and check that the circle was followed; the
measured ratio to the simulation is recorded in benchmarks/RESULTS.md.
"""

import os
import signal
import subprocess
import sys
import time

import pytest

from mckibben.rig.device import PACED_PERIODS

from conftest import _avr_engine_missing

PATH = "circle:radius=10mm,period=1s"


@pytest.fixture
def tool_emulator(tmp_path, engine):
    link = tmp_path / "tty"
    p = subprocess.Popen([sys.executable, "-m", "mckibben.cli", "rig", "emulate", "--engine", engine, "--tool-path",
                          PATH, "--link", str(link), "--json"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True)
    end = time.monotonic() + 120
    while time.monotonic() < end and not link.is_symlink():
        time.sleep(0.05)
    assert link.is_symlink(), p.stderr.read() if p.poll() is not None else "no link"
    yield str(link)
    p.send_signal(signal.SIGTERM)
    p.wait(timeout=30)
    assert not link.exists()


@pytest.mark.slow  # ~40 s: two processes, the identification and the simulation of the same path
@pytest.mark.parametrize("engine", [
    "python",
    pytest.param("avr", marks=pytest.mark.skipif(_avr_engine_missing() is not None, reason="no avr engine")),
])
def test_tool_track_through_the_link_follows_the_circle(cli, tool_emulator, engine):
    r = cli("tool", "track", "--port", tool_emulator, "--path", PATH, "--json")
    assert r.code == 0, r.err
    out = r.json()
    link, sim = out["link"], out["runs"][0]
    assert link["corrupt"] == 0 and link["controller_faults"] == 0 and "warning" not in r.err
    # the host paces its SET_POINTS at the image's measured ceiling (one every PACED_PERIODS periods,
    # telemetry at that decimation, docs/firmware.md "Command rate"): the references reached the
    # device and were applied, and on the image the telemetry arrives whole
    assert link["references_applied"] >= 0.3 * link["path_periods"] / PACED_PERIODS
    if engine == "avr":
        assert link["missing"] <= 0.01 * link["frames"]
    # it followed the 10 mm circle: loose bounds (a loaded host sends its references late)
    assert link["rms_error_m"] < 2e-3 and link["rms_error_ratio_to_simulation"] < 10
    assert sim["rms_error_m"] < 1e-3


@pytest.mark.parametrize("args, message", [
    (["--periods", "1s,2s"], "error: --port: runs one path on the device; it takes neither --periods nor --reference-only"),
    (["--reference-only"], "error: --port: runs one path on the device"),
])
def test_tool_track_port_bad_input(cli, args, message):
    master, slave = os.openpty()
    try:
        r = cli("tool", "track", "--port", os.ttyname(slave), "--path", PATH, *args)
    finally:
        os.close(master)
        os.close(slave)
    assert r.code == 2 and r.err.startswith(message) and r.err.count("\n") == 1


def test_tool_track_port_that_is_not_a_device(cli):
    r = cli("tool", "track", "--port", "/dev/nonexistent-tty", "--path", PATH)
    assert r.code == 2 and r.err.startswith("error: --port: cannot open '/dev/nonexistent-tty'")

"""The bad-input catalogue: every command, fed what a user can get wrong.

Each case asserts the command line's contract (DESIGN.md, "bad input gets a clear error"): exit
status 2, exactly one line on stderr, no traceback, the argument or file named, and nothing left
in the folder. Cases run in-process through :func:`conftest.run_cli`; a real process is used only
where one is needed (signals, ``kill -9``).

Read-only destinations: the tests run as root on CI, and root ignores permission bits, so the
"cannot write" cases use what blocks root too: a path under ``/proc`` (a pseudo-file system that
takes no new files), a regular file where a folder is wanted, and ``chattr +i`` where the file
system supports it (skipped with the reason otherwise).
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from conftest import run_cli
from mckibben.atomic import TMP_TAG

SRC = str(Path(__file__).resolve().parents[1] / "src")


def _env():
    return {**os.environ, "PYTHONPATH": SRC + os.pathsep + os.environ.get("PYTHONPATH", "")}


def listing(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def assert_refused(r, *named: str, code: int = 2) -> None:
    """Exit ``code``, one stderr line naming each of ``named``, no traceback, nothing on stdout."""
    assert r.code == code, (r.code, r.err)
    assert r.err.count("\n") == 1 and r.err.endswith("\n"), r.err
    assert "Traceback" not in r.err
    for n in named:
        assert n in r.err, (n, r.err)
    assert r.out == ""


# ---------------------------------------------------------------------------------------------
# Fixtures: special files


@pytest.fixture
def special(tmp_path):
    """A folder holding a directory named like a file, a FIFO, an empty file and a regular file."""
    (tmp_path / "d.png").mkdir()
    (tmp_path / "d.csv").mkdir()
    (tmp_path / "d.parquet").mkdir()
    (tmp_path / "d.toml").mkdir()
    os.mkfifo(tmp_path / "f.csv")
    os.mkfifo(tmp_path / "f.toml")
    os.mkfifo(tmp_path / "f.png")
    (tmp_path / "file").write_text("x")
    return tmp_path


# ---------------------------------------------------------------------------------------------
# Output paths: a folder given as a file, a FIFO, /proc, a file where a folder is wanted

PLOT_COMMANDS = [
    ["simulate", "open-loop"],
    ["control", "step"],
    ["control", "track", "--reference", "sine:0.4MPa,0.1MPa,2Hz"],
    ["control", "robustness", "--n", "2"],
    ["control", "fig13"],
    ["control", "hysteresis"],
    ["tool", "workspace", "--grid", "2"],
    ["tool", "track", "--path", "circle:radius=2mm,period=2s"],
]


@pytest.mark.parametrize("cmd", PLOT_COMMANDS, ids=lambda c: "-".join(c[:2]))
@pytest.mark.parametrize("target, says", [("d.png", "is a folder"), ("f.png", "FIFO"),
                                          ("/proc/mckibben.png", "cannot write in folder '/proc'"),
                                          ("file/x.png", "not a folder"),
                                          ("nodir/x.png", "does not exist")])
def test_plot_destination_refused_before_work(special, cmd, target, says):
    path = target if target.startswith("/") else str(special / target)
    before = listing(special)
    r = run_cli(*cmd, "--plot", path)
    assert_refused(r, "--plot", says)
    assert listing(special) == before


def test_identify_plot_into_a_folder(special):
    log = special / "step.csv"
    log.write_text("time_s,pressure_MPa\n" + "".join(f"{i * 1e-3},{0.5 * (i > 20)}\n" for i in range(200)))
    before = listing(special)
    assert_refused(run_cli("identify", str(log), "--plot", str(special / "d.png")), "--plot", "is a folder")
    assert listing(special) == before


@pytest.mark.parametrize("cmd", [["reproduce"], ["datasets", "generate"]], ids=lambda c: c[0])
@pytest.mark.parametrize("target, says", [("/proc/mckibben-out", "cannot write in folder '/proc'"),
                                          ("file", "is a file, not a folder"),
                                          ("f.csv", "FIFO"),
                                          ("file/sub", "not a folder")])
def test_output_folder_refused(special, cmd, target, says):
    path = target if target.startswith("/") else str(special / target)
    before = listing(special)
    assert_refused(run_cli(*cmd, "--out", path), "--out", says)
    assert listing(special) == before


def test_immutable_folder_blocks_root_too(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    if shutil.which("chattr") is None:
        pytest.skip("chattr is not installed: no way to make a folder read-only for root here")
    done = subprocess.run(["chattr", "+i", str(ro)], capture_output=True)
    if done.returncode != 0:
        pytest.skip(f"this file system does not take the immutable flag ({done.stderr.decode().strip()})")
    try:
        assert_refused(run_cli("simulate", "open-loop", "--plot", str(ro / "a.png")), "--plot", "cannot write")
        assert_refused(run_cli("datasets", "generate", "--out", str(ro / "c")), "--out", "cannot write")
        assert_refused(run_cli("reproduce", "--out", str(ro / "r")), "--out", "cannot write")
    finally:
        subprocess.run(["chattr", "-i", str(ro)])
    assert listing(ro) == []


# ---------------------------------------------------------------------------------------------
# Input files: a folder or FIFO is named for what it is, and a FIFO is never opened (no hang)

INPUT_COMMANDS = [
    (["fit", "{f}", "--model", "cubic"], "csv"),
    (["compare", "{f}"], "csv"),
    (["identify", "{f}"], "csv"),
    (["control", "track", "--reference", "{f}"], "csv"),
    (["sweep", "run", "{f}", "--out", "{f}-results"], "toml"),
    (["fit", "{f}", "--model", "cubic"], "parquet"),
]


@pytest.mark.parametrize("args, ext", INPUT_COMMANDS, ids=lambda a: "-".join(a) if isinstance(a, list) else a)
@pytest.mark.parametrize("kind, says", [("d", "is a folder"), ("f", "FIFO"), ("missing", "no such")])
def test_input_file_is_named_for_what_it_is(special, args, ext, kind, says):
    if kind == "f" and ext == "parquet":
        os.mkfifo(special / "f.parquet")
    f = special / f"{kind}.{ext}"
    if args[0] == "compare" and kind == "d":
        says = "holds no isotonic.csv"  # compare takes a muscle folder too
    r = run_cli(*[a.format(f=f) for a in args])
    assert_refused(r, str(f), says)


# ---------------------------------------------------------------------------------------------
# Internal errors: one line asking for a report, exit 1; the traceback with --debug


def test_internal_error_is_one_line_and_asks_for_a_report(monkeypatch):
    import mckibben.plant as plant

    def broken():
        return 1 / 0

    monkeypatch.setattr(plant, "calibration", broken)
    r = run_cli("simulate", "calibrate")
    assert r.code == 1 and r.err.count("\n") == 1 and "Traceback" not in r.err
    assert "please report" in r.err and "ZeroDivisionError" in r.err and "--debug" in r.err
    r = run_cli("simulate", "calibrate", "--debug")
    assert r.code == 1 and "Traceback" in r.err and "please report" in r.err.splitlines()[-1]


def test_memory_error_is_a_user_error(monkeypatch):
    import mckibben.plant as plant

    def huge():
        raise MemoryError("Unable to allocate 7.28 TiB for an array")

    monkeypatch.setattr(plant, "calibration", huge)
    assert_refused(run_cli("simulate", "calibrate"), "not enough memory", "7.28 TiB")


# ---------------------------------------------------------------------------------------------
# Signals: SIGTERM unwinds and removes the temporary; kill -9's temporary is cleaned next time


def test_sigterm_during_a_write_leaves_nothing(tmp_path):
    code = textwrap.dedent(f"""
        import os, signal, sys
        from mckibben.cli import _signals_unwind
        from mckibben.atomic import atomic_file
        try:
            with _signals_unwind(), atomic_file({str(tmp_path / 'a.png')!r}, "--plot") as tmp:
                tmp.write_bytes(b"half")
                os.kill(os.getpid(), signal.SIGTERM)
                signal.pause()
        except KeyboardInterrupt:
            sys.exit(143)
    """)
    done = subprocess.run([sys.executable, "-c", code], env=_env(), capture_output=True, timeout=60)
    assert done.returncode == 143, done.stderr
    assert listing(tmp_path) == []


def test_kill_9_leaves_a_temporary_that_the_next_run_removes(tmp_path):
    code = textwrap.dedent(f"""
        import os, signal
        from mckibben.atomic import atomic_dir
        with atomic_dir({str(tmp_path / 'report')!r}) as tmp:
            (tmp / "index.html").write_text("half")
            os.kill(os.getpid(), signal.SIGKILL)
    """)
    done = subprocess.run([sys.executable, "-c", code], env=_env(), capture_output=True, timeout=60)
    assert done.returncode == -signal.SIGKILL
    left = listing(tmp_path)
    assert len(left) == 2 and TMP_TAG in left[0]  # the stranded folder and its file
    r = run_cli("datasets", "generate", "--out", str(tmp_path / "campaign"))
    assert r.code == 0, r.err
    assert [p.name for p in tmp_path.iterdir()] == ["campaign"]


def test_reproduce_killed_with_sigkill_then_rerun_leaves_only_the_report(tmp_path):
    out = tmp_path / "report"
    proc = subprocess.Popen([sys.executable, "-m", "mckibben.cli", "reproduce", "--out", str(out), "--json"],
                            env=_env(), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        import time

        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and not any(TMP_TAG in p.name for p in tmp_path.iterdir()):
            time.sleep(0.05)
        assert any(TMP_TAG in p.name for p in tmp_path.iterdir()), "reproduce never started its report"
    finally:
        proc.kill()
        proc.wait()
    # the next run into the same folder removes what the killed one left
    r = run_cli("reproduce", "--out", str(out), "--json")
    assert r.code == 0, r.err
    assert [p.name for p in tmp_path.iterdir()] == ["report"]


# ---------------------------------------------------------------------------------------------
# A failed sweep leaves its folder reusable

SWEEP = """
[sweep]
seed = 1
samples = 2
chunk_size = 2

[scenario]
kind = "step"
target = "0.55MPa"
duration = "0.03s"

[plant]
supply_pressure = "{supply}"

[controller]
kind = "smc"
"""


def test_failed_sweep_leaves_the_folder_reusable(tmp_path):
    spec, out = tmp_path / "s.toml", tmp_path / "results"
    spec.write_text(SWEEP.format(supply="2MPa"))  # above the compressor: refused while running
    r = run_cli("sweep", "run", str(spec), "--out", str(out))
    assert_refused(r, "supply_pressure")
    spec.write_text(SWEEP.format(supply="0.8MPa"))
    r = run_cli("sweep", "run", str(spec), "--out", str(out), "--json")
    assert r.code == 0, r.err
    assert r.json()["computed"] == 1
    assert not [p for p in out.iterdir() if TMP_TAG in p.name]

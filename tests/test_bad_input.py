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
    (["rig", "gains", "--port", "/nonexistent/tty", "--from", "{f}"], "json"),
    (["predict", "force", "--pressure", "0.5MPa", "--muscle-file", "{f}"], "toml"),
    (["tool", "ik", "--tip", "0mm,0mm,250mm", "--muscle-file", "{f}"], "toml"),
    (["control", "compare", "--muscle-file", "{f}"], "toml"),
]


@pytest.mark.parametrize("args, ext", INPUT_COMMANDS, ids=lambda a: "-".join(a) if isinstance(a, list) else a)
@pytest.mark.parametrize("kind, says", [("d", "is a folder"), ("f", "FIFO"), ("missing", "no such")])
def test_input_file_is_named_for_what_it_is(special, args, ext, kind, says):
    if kind == "f" and not (special / f"f.{ext}").exists():
        os.mkfifo(special / f"f.{ext}")
    if kind == "d":
        (special / f"d.{ext}").mkdir(exist_ok=True)
    f = special / f"{kind}.{ext}"
    if args[0] == "rig" and kind == "missing":
        says = "does not exist"
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


@pytest.mark.slow  # a reproduce started, killed, and run again in full (~10 s)
def test_reproduce_killed_with_sigkill_then_rerun_leaves_only_the_report(tmp_path):
    out = tmp_path / "report"
    proc = subprocess.Popen([sys.executable, "-m", "mckibben.cli", "reproduce", "--out", str(out), "--json"],
                            env=_env(), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    seen = False
    try:
        import time

        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and proc.poll() is None:
            if any(TMP_TAG in p.name for p in tmp_path.iterdir()):
                proc.send_signal(signal.SIGKILL)  # while it writes its report
                seen = True
                break
            time.sleep(0.01)
    finally:
        proc.kill()
        proc.wait()
    assert seen, "reproduce was never caught writing its report"
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


# ---------------------------------------------------------------------------------------------
# Values: huge, tiny, NaN/inf, negative, wrong dimension, garbage — every command, the option named

VALUE_CASES = [
    # predict
    (["predict", "length", "--pressure", "nan MPa"], "--pressure"),
    (["predict", "length", "--pressure", "inf"], "--pressure"),
    (["predict", "length", "--pressure", "0.5mm"], "--pressure"),
    (["predict", "length", "--pressure", "0:0.8MPa:100000000"], "--pressure"),
    (["predict", "length", "--pressure", "0.5MPa", "--load", "1e6N"], "--load"),
    (["predict", "length", "--pressure", "0.5MPa", "--load", "5MPa"], "--load"),
    (["predict", "length", "--pressure", "0.5MPa", "--muscle", "mpam98"], "mpam98"),
    (["predict", "pressure", "--length", "0mm"], "--length"),
    (["predict", "pressure", "--length", "90mm", "--p-max", "5MPa"], "--p-max"),
    (["predict", "pressure", "--length", "90mm", "--p-max", "-1MPa"], "--p-max"),
    (["predict", "pressure", "--length", "1e300m,"], "--length"),
    (["predict", "force", "--pressure", "0.8MPa", "--length", "1000m"], "--length"),
    (["predict", "force", "--pressure", "0.8MPa", "--model", "tondu-lopez", "--k", "-5"], "--k"),
    (["predict", "force", "--pressure", "0.8MPa", "--model", "tondu-lopez", "--k", "nan"], "--k"),
    (["predict", "force", "--pressure", "0.8MPa", "--model", "wall-corrected", "--diameter", "1e-300mm"], "--diameter"),
    (["predict", "force", "--pressure", "0.8MPa", "--braid-angle", "90deg"], "--braid-angle"),
    (["predict", "force", "--pressure", "0.8MPa", "--braid-angle", "20mm"], "--braid-angle"),
    (["predict", "force", "--pressure", "0.8MPa", "--rest-length", "0mm"], "--rest-length"),
    (["predict", "force", "--pressure", "0.8MPa", "--diameter", "200mm"], "--diameter"),
    (["predict", "force", "--pressure", "0.8MPa", "--model", "hooke"], "hooke"),
    # simulate
    (["simulate", "open-loop", "--load", "1e6N"], "--load"),
    (["simulate", "open-loop", "--load", "nanN"], "--load"),
    (["simulate", "open-loop", "--duration", "1e9s"], "--duration"),
    (["simulate", "open-loop", "--duration", "0.0001s"], "--duration"),
    (["simulate", "open-loop", "--duration", "1Hz"], "--duration"),
    (["simulate", "open-loop", "--supply", "5MPa"], "--supply"),
    (["simulate", "open-loop", "--valve", "-1"], "--valve"),
    (["simulate", "open-loop", "--valve", "1e9"], "--valve"),
    # control
    (["control", "step", "--duration", "1e6s"], "--duration"),
    (["control", "step", "--duration", "0.0001s"], "--duration"),
    (["control", "step", "--duration", "0.5005s"], "--duration"),
    (["control", "step", "--duration", "-1s"], "--duration"),
    (["control", "step", "--p-max", "5MPa"], "--p-max"),
    (["control", "step", "--p-max", "inf MPa"], "--p-max"),
    (["control", "step", "--target", "-0.1MPa"], "--target"),
    (["control", "step", "--target", "nanMPa"], "--target"),
    (["control", "step", "--target", "0.5N"], "--target"),
    (["control", "step", "--load", "1e6N"], "--load"),
    (["control", "step", "--beta", "nan"], "--beta"),
    (["control", "step", "--beta", "1e300"], "--beta"),
    (["control", "step", "--ki", "-1"], "--ki"),
    (["control", "step", "--eps", "0kPa"], "--eps"),
    (["control", "step", "--lambda", "0ms", "--controller", "pid"], "--lambda"),
    (["control", "step", "--controller", "lqr"], "lqr"),
    (["control", "step", "--law", "magic"], "--law"),
    (["control", "track", "--reference", "sine:0.4MPa,0.2MPa,2Hz", "--duration", "1e9s"], "--duration"),
    (["control", "track", "--reference", "sine:0.4MPa,0.2MPa"], "--reference"),
    (["control", "track", "--reference", "sine:0.4MPa,0.2MPa,0Hz"], "--reference"),
    (["control", "track", "--reference", "sine:0.4MPa,0.2MPa,1e9Hz"], "--reference"),
    (["control", "track", "--reference", "sine:nanMPa,0.2MPa,2Hz"], "--reference"),
    (["control", "track", "--reference", "sine:0.4MPa,0.2MPa,2Hz", "--p-max", "5MPa"], "--p-max"),
    (["control", "robustness", "--n", "100000000"], "--n"),
    (["control", "robustness", "--n", "0"], "--n"),
    (["control", "robustness", "--n", "1e3"], "--n"),
    (["control", "robustness", "--seed", "-1", "--n", "2"], "--seed"),
    (["control", "robustness", "--seed", str(2**70), "--n", "2"], "--seed"),
    (["control", "compare", "--beta", "-3"], "--beta"),
    (["control", "fig13", "--ki", "inf"], "--ki"),
    (["control", "fig13", "--eps", "1e300Pa"], "--eps"),
    (["control", "hysteresis", "--period", "1e9s"], "--period"),
    (["control", "hysteresis", "--period", "0.001s"], "--period"),
    (["control", "hysteresis", "--sweep-period", "1e9s"], "--sweep-period"),
    # --muscle-file and --direction (the file plant's own cases: tests/test_muscle_file_cli.py)
    (["predict", "force", "--pressure", "0.5MPa", "--muscle-file", "{tmp}/none.toml", "--direction", "up"],
     "--direction"),
    (["simulate", "open-loop", "--direction", "up"], "--direction"),
    (["simulate", "open-loop", "--direction", "deflate"], "--direction"),
    (["control", "step", "--direction", "sideways"], "--direction"),
    (["control", "step", "--direction", "deflate"], "--direction"),
    (["control", "track", "--reference", "sine:0.4MPa,0.2MPa,2Hz", "--direction", "in"], "--direction"),
    (["control", "compare", "--direction", "out"], "--direction"),
    (["control", "compare", "--muscle-file", "{tmp}/none.toml"], "none.toml"),
    (["control", "robustness", "--n", "2", "--direction", "INFLATE"], "--direction"),
    (["control", "robustness", "--n", "2", "--muscle-file", "{tmp}/none.toml"], "none.toml"),
    (["control", "fig13", "--muscle-file", "{tmp}/none.toml"], "--muscle-file"),
    (["control", "hysteresis", "--muscle-file", "{tmp}/none.toml"], "--muscle-file"),
    # tool
    (["tool", "fk", "--discs", "1000000", "--lengths", "117mm,112mm,115mm"], "--discs"),
    (["tool", "fk", "--discs", "-3", "--lengths", "117mm,112mm,115mm"], "--discs"),
    (["tool", "fk", "--discs", "many", "--lengths", "117mm,112mm,115mm"], "--discs"),
    (["tool", "fk", "--p-max", "5MPa", "--lengths", "117mm,112mm,115mm"], "--p-max"),
    (["tool", "fk", "--lengths", "117mm,112mm"], "--lengths"),
    (["tool", "fk", "--lengths", "nanmm,112mm,115mm"], "--lengths"),
    (["tool", "fk", "--pressures", "5MPa,0MPa,0MPa"], "--pressures"),
    (["tool", "fk", "--lengths", "117mm,112mm,115mm", "--pressures", "0,0,0MPa"], "--lengths"),
    (["tool", "fk", "--lengths", "117mm,112mm,115mm", "--pitch-radius", "1e300mm"], "pitch radius"),
    (["tool", "fk", "--lengths", "117mm,112mm,115mm", "--bending-stiffness", "-1Nm2"], "--bending-stiffness"),
    (["tool", "fk", "--lengths", "117mm,112mm,115mm", "--bending-stiffness", "lots"], "--bending-stiffness"),
    (["tool", "fk", "--lengths", "117mm,112mm,115mm", "--preload", "nanN"], "--preload"),
    (["tool", "ik", "--tip", "1e300mm,0mm,110mm"], "--tip"),
    (["tool", "ik", "--tip", "0mm,0mm"], "--tip"),
    (["tool", "ik", "--tip", "nanmm,0mm,110mm"], "--tip"),
    (["tool", "ik", "--tip", "3mm,0mm,110mm", "--p-max", "5MPa"], "--p-max"),
    (["tool", "workspace", "--grid", "1000000"], "--grid"),
    (["tool", "workspace", "--grid", "1"], "--grid"),
    (["tool", "workspace", "--p-max", "5MPa"], "--p-max"),
    (["tool", "track", "--path", "circle:radius=2mm,period=2s,cycles=1000000000"], "--path"),
    (["tool", "track", "--path", "circle:radius=2mm,period=2s", "--periods", "1e9s"], "--periods"),
    (["tool", "track", "--path", "circle:radius=2mm,period=1e12s"], "--path"),
    (["tool", "track", "--path", "circle:radius=1e300mm,period=2s"], "--path"),
    (["tool", "track", "--path", "square:side=2mm,period=2s"], "--path"),
    (["tool", "track", "--path", "circle:radius=2mm,period=2s", "--beta", "nan"], "--beta"),
    (["tool", "track", "--path", "circle:radius=2mm,period=2s", "--p-max", "5MPa"], "--p-max"),
    # datasets, params, rig, sweep, identify
    (["datasets", "generate", "--seed", "-1"], "--seed"),
    (["params", "show", "mpam1000"], "mpam1000"),
    (["rig", "step", "--port", "/nonexistent/tty", "--target", "5MPa"], "--target"),
    (["rig", "step", "--port", "/nonexistent/tty"], "--port"),
    (["rig", "step", "--port", "/nonexistent/tty", "--duration", "1e9s"], "--duration"),
    (["rig", "record", "--port", "/nonexistent/tty", "--out", "x.parquet", "--duration", "1e9s"], "--duration"),
    (["rig", "record", "--port", "/nonexistent/tty", "--out", "x.csv"], "--out"),
    (["rig", "record", "--port", "/nonexistent/tty", "--out", "x.parquet", "--decimation", "0"], "--decimation"),
    (["rig", "emulate", "--duration", "1e9s"], "--duration"),
    (["rig", "emulate", "--duration", "0s"], "--duration"),
    (["identify", "{step}", "--order", "3"], "--order"),
    (["identify", "{step}", "--t-step", "1e9s"], "--t-step"),
    (["identify", "{step}", "--t-step", "nans"], "--t-step"),
    (["sweep", "run", "{sweep}", "--out", "r", "--workers", "100000"], "--workers"),
    (["sweep", "run", "{sweep}", "--out", "r", "--scheduler", "localhost"], "--scheduler"),
    (["sweep", "summarize", "{tmp}", "--quantile", "2"], "{tmp}"),
    (["fit", "{iso}", "--model", "spring", "--split-pressure", "5MPa"], "--split-pressure"),
    (["fit", "{fl}", "--model", "spring", "--split-pressure", "5MPa"], "--split-pressure"),
    (["fit", "{fl}", "--model", "spring", "--split-pressure", "5mm"], "--split-pressure"),
    (["fit", "{iso}", "--model", "quintic"], "quintic"),
    (["fit", "{iso}", "--model", "cubic", "--kind", "nonsense"], "nonsense"),
    (["fit", "{iso}", "--model", "kinematic", "--muscle-file", "{tmp}/none.toml"], "none.toml"),
    (["unknown-command"], "unknown-command"),
    (["rig", "emulate", "--duration", ""], "--duration"),
    (["control", "step", "--eps="], "--eps"),
    (["predict", "force", "--pressure", "0.8MPa", "--wall", ""], "--wall"),
    (["control", "step", "--no-such-option"], "--no-such-option"),
]


@pytest.fixture
def places(tmp_path):
    from mckibben.datasets.campaign import BUNDLED

    step = tmp_path / "step.csv"
    step.write_text("time_s,pressure_MPa,command_pwm\n" + "".join(
        f"{i * 1e-3:.3f},{0.0 if i < 50 else 0.5 * (1 - 2.718281828 ** (-(i - 50) / 60.0)):.5f},{0 if i < 50 else 150}\n"
        for i in range(400)))
    sweep = tmp_path / "s.toml"
    sweep.write_text("[sweep]\nsamples = 2\nchunk_size = 2\n[scenario]\nduration = \"0.02s\"\n")
    return {"tmp": str(tmp_path), "step": str(step), "sweep": str(sweep),
            "iso": str(BUNDLED / "mpam97" / "isotonic.csv"), "fl": str(BUNDLED / "mpam97" / "force_length.csv")}


@pytest.mark.parametrize("args, named", VALUE_CASES, ids=[" ".join(a) for a, _ in VALUE_CASES])
def test_bad_value_names_the_option(places, tmp_path, monkeypatch, args, named):
    monkeypatch.chdir(tmp_path)
    before = listing(tmp_path)
    r = run_cli(*[a.format(**places) for a in args])
    assert_refused(r, named.format(**places))
    assert listing(tmp_path) == before


# ---------------------------------------------------------------------------------------------
# Files: empty, garbage, BOM, ragged, header only, implausible, too short — named with the file

FILE_CASES = {
    "empty.csv": "",
    "garbage.csv": None,  # random bytes
    "ragged.csv": "pressure_kPa,load_N,length_mm\n0,0.6\n100,0.6,95,4,5\n",
    "header.csv": "pressure_kPa,load_N,length_mm\n",
    "text.csv": "pressure_kPa,load_N,length_mm\n0,0.6,ninety\n",
    "nan.csv": "pressure_kPa,load_N,length_mm\n0,0.6,nan\n",
    "huge.csv": "pressure_kPa,load_N,length_mm\n1e300,0.6,97\n",
    "units.csv": "pressure_mm,load_N,length_mm\n0,0.6,97\n",
    "bom.csv": "\ufeffpressure_kPa,load_N,length_mm\n0,0.6,97\n",
    "metres.csv": "pressure_kPa,load_N,length_mm\n0,0.6,0.097\n100,0.6,0.094\n",
    "latin1.csv": None,
}


def _write(path: Path, text):
    if path.name == "garbage.csv":
        path.write_bytes(bytes(range(256)) * 3)
    elif path.name == "latin1.csv":
        path.write_bytes("pressure_kPa,load_N,length_mm\n0,0.6,97\xb0\n".encode("latin-1"))
    else:
        path.write_text(text, encoding="utf-8")


@pytest.mark.parametrize("name", list(FILE_CASES))
@pytest.mark.parametrize("cmd", [["fit", "{f}", "--model", "cubic"], ["compare", "{f}"],
                                 ["control", "track", "--reference", "{f}"], ["identify", "{f}"]],
                         ids=lambda c: c[0] if c[0] != "control" else "track")
def test_bad_file_names_the_file(tmp_path, monkeypatch, name, cmd):
    monkeypatch.chdir(tmp_path)
    f = tmp_path / name
    _write(f, FILE_CASES[name])
    before = listing(tmp_path)
    r = run_cli(*[a.format(f=f) for a in cmd])
    assert_refused(r, str(f))
    assert listing(tmp_path) == before


@pytest.mark.parametrize("content, says", [
    ("time_s,pressure_MPa\n0,0.1\n1000000,0.2\n", "control periods"),
    ("time_s,pressure_MPa\n0,0\n0.1,1e300\n0.2,0.5\n", "not a plausible"),
    ("time_s,pressure_MPa\n0,0\n0.001,0.5\n", "shorter than 10 ms"),
    ("time_s,pressure_MPa\n0,0\n0.02,0.5\n0.01,0.4\n", "time goes back"),
])
def test_reference_file_sizes_and_values(tmp_path, content, says):
    f = tmp_path / "ref.csv"
    f.write_text(content)
    assert_refused(run_cli("control", "track", "--reference", str(f)), str(f), says)


def test_sweep_with_a_target_above_p_max_is_refused(tmp_path):
    f = tmp_path / "high.toml"
    f.write_text("[scenario]\ntarget = \"5MPa\"\n")
    assert_refused(run_cli("sweep", "run", str(f), "--out", str(tmp_path / "r")), str(f), "target")
    assert listing(tmp_path) == ["high.toml"]


def test_sweep_too_big_is_refused_with_the_estimate(tmp_path):
    f = tmp_path / "big.toml"
    f.write_text("[sweep]\nsamples = 1000000\nchunk_size = 1000000\n[scenario]\nduration = \"10s\"\n")
    assert_refused(run_cli("sweep", "run", str(f), "--out", str(tmp_path / "r")), str(f), "GiB")
    assert listing(tmp_path) == ["big.toml"]


# ---------------------------------------------------------------------------------------------
# Random strings at every option of every command (discovered from the app, not hand-listed)

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "fuzz"))
import fuzz_cli  # noqa: E402

from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

COMMANDS = fuzz_cli.discover()
OPTIONS = [(path, p) for path, params in COMMANDS for p in params if not getattr(p, "is_flag", False)]


def test_every_command_and_option_is_fuzzed():
    names = {" ".join(path) for path, _ in COMMANDS}
    assert {"predict force", "control step", "tool track", "sweep run", "reproduce", "rig record"} <= names
    assert len(OPTIONS) > 100


#: For the commands that run long when every value is accepted, an option that fails cheaply and is
#: checked after the others: the fuzzed option is still validated, the long run is not made.
CHEAP_FAILURE = {
    ("reproduce",): [("--data", "/nonexistent-campaign")],
    ("tool", "track"): [("--path", "circle:radius=1e300mm,period=2s")],
    ("control", "robustness"): [("--beta", "-1")],
    ("control", "fig13"): [("--ki", "-1")],
}

RANDOM_TEXT = st.one_of(
    st.text(alphabet=st.characters(blacklist_characters="\x00", blacklist_categories=("Cs",)), max_size=40),
    st.text(alphabet="0123456789.,:-+eE naifMPamNsgdrHz%/", max_size=24),
    st.builds(lambda n, u: n + u, st.sampled_from(fuzz_cli.NUMBERS), st.sampled_from(fuzz_cli.UNITS)),
    st.sampled_from(fuzz_cli.GARBAGE),
)


@pytest.mark.parametrize("option", range(len(OPTIONS)),
                         ids=[" ".join(path) + " " + (p.opts[0] if p.param_type_name == "option" else p.name)
                              for path, p in OPTIONS])
@settings(max_examples=3, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(data=st.data())
def test_random_strings_at_every_option(tmp_path_factory, option, data):
    path, param = OPTIONS[option]
    value = data.draw(RANDOM_TEXT, label="value")
    work = tmp_path_factory.mktemp("fuzz")
    files = {"isotonic": str(Path(fuzz_cli.__file__).parents[1] / "src/mckibben/datasets/campaign/mpam97/isotonic.csv")}
    args = list(path)
    for p in dict(COMMANDS)[path]:
        if p is param or getattr(p, "is_flag", False) or not p.required:
            continue
        key = p.opts[0] if p.param_type_name == "option" else p.name
        plausible = fuzz_cli.PLAUSIBLE.get(key, ["x"])[0]
        plausible = files.get(plausible.strip("{}"), str(work / "missing") if plausible.startswith("{") else plausible)
        args += [p.opts[0], plausible] if p.param_type_name == "option" else [plausible]
    key = param.opts[0] if param.param_type_name == "option" else param.name
    for opt, bad in CHEAP_FAILURE.get(path, ()):
        if opt != key:  # checked after the fuzzed option, so a long run stops there instead
            args = [a for i, a in enumerate(args) if not (a == opt or (i and args[i - 1] == opt))] + [opt, bad]
    args += [param.opts[0], value] if param.param_type_name == "option" else [value]
    if path == ("rig", "emulate") and "--duration" not in args:
        args += ["--duration", "0.2s"]  # a server: without a duration it runs until Ctrl-C, by design
    cwd = os.getcwd()
    os.chdir(work)
    try:
        r = fuzz_cli.run_line(args, timeout=60.0)
    finally:
        os.chdir(cwd)
    assert r["code"] in (0, 2), (args, r)
    assert "Traceback" not in r["err"], (args, r["err"])
    if r["code"] == 2:
        assert r["err"].count("\n") == 1, (args, r["err"])
    assert not [p for p in work.rglob("*") if TMP_TAG in p.name]


@pytest.mark.parametrize("content, says", [
    ("", "the sweep file is empty"),
    ("# only a comment\n", "the sweep file is empty"),
    ("[sweep]\nseed = 3\n[scenario]\nduration = \"0.05s\"\n", "nothing varies"),
])
def test_a_sweep_that_varies_nothing_is_refused(tmp_path, content, says):
    f = tmp_path / "s.toml"
    f.write_text(content)
    out = tmp_path / "out"
    assert_refused(run_cli("sweep", "run", str(f), "--out", str(out)), str(f), says)
    assert not out.exists()


def test_lengths_in_metres_under_a_millimetre_heading_are_refused(tmp_path):
    f = tmp_path / "metres.csv"
    f.write_text("pressure_kPa,load_N,length_mm\n0,0.6,0.0972\n100,0.6,0.0941\n")
    r = run_cli("fit", str(f), "--model", "spring")
    assert_refused(r, str(f), "holds metres")

"""Random-option fuzz of the ``mckibben`` command line: no traceback, exit status 0 or 2 only.

The commands and their options are discovered from the Typer/Click app (nothing is hand-listed),
so a new command or option is fuzzed the day it is added. Each command line sets a few options
(and every required one) to values drawn from a mix of garbage text, undecodable bytes, extreme
and non-finite numbers with right, wrong and no units, lists and ranges, special paths (a folder,
a FIFO, /proc, /dev/zero, empty, garbage, BOM and ragged files) and plausible values, then runs
in-process and checks the contract:

- exit status 0 or 2 (1 would be an internal error, anything else a crash);
- no ``Traceback`` on stderr; on exit 2 exactly one stderr line;
- nothing left behind but what a successful command wrote (no ``.mckibben-tmp-`` temporaries).

Usage (from the repository root)::

    PYTHONPATH=src python fuzz/fuzz_cli.py --lines 2000 --seed 1

Each line runs under a time limit (``--timeout``, default 120 s); a line that hits it is reported
as ``slow`` with its command line (a size guard that let too much through).
"""

from __future__ import annotations

import argparse
import io
import json
import os
import random
import signal
import sys
import tempfile
import time
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

HERE = Path(__file__).resolve().parent


def discover():
    """Every leaf command of the app: ``[(path tuple, [click parameters])]``."""
    import typer

    from mckibben.cli import app

    root = typer.main.get_command(app)
    out = []

    def walk(cmd, path):
        if hasattr(cmd, "commands"):
            for name, sub in sorted(cmd.commands.items()):
                walk(sub, path + (name,))
        else:
            out.append((path, list(cmd.params)))

    walk(root, ())
    return out


# ---------------------------------------------------------------------------------------------
# Values

NUMBERS = ["0", "-0", "1", "-1", "2", "255", "256", "1e300", "-1e300", "1e-300", "1e9", "1e6", "100000000",
           "0.0001", "0.5", "nan", "inf", "-inf", "NaN", "1e400", "3.7", "13", "99999999999999999999999", "0x10",
           "1_000", "١٢", "+5", ".", "1e", "--1"]
UNITS = ["", "MPa", "kPa", "Pa", "bar", "psi", "mm", "m", "cm", "um", "in", "N", "mN", "kN", "gf", "kgf", "g", "kg",
         "deg", "rad", "s", "ms", "us", "Hz", "kHz", "%", "Nm2", "Nmm2", "MPA", "furlong", " MPa", "µm"]
GARBAGE = ["", " ", "\t", "-", "--", "--json", "-h", "x", "é", "日本", "\u202e", "\udcff\udcfe", "a,b,c", ",,", ":", "::",
           "0:1:0", "0:1e300MPa:1000000000", "1:2:3:4", "1,2", "1,2,3", "1mm,2mm,3mm", "1MPa,,2MPa", "sine:", "sine:1,2",
           "sine:0.4MPa,0.2MPa,1e9Hz", "sine:0.4MPa,0.2MPa,0Hz", "sine:nan,1MPa,2Hz", "circle:", "circle:radius=1e300mm",
           "circle:radius=5mm,period=2s,cycles=1e12", "figure8:size=0mm,period=2s", "circle:radius=5mm,period=1e-9s",
           "tcp://", "tcp://256.1.1.1:99999", "tcp://127.0.0.1:1", "continuous", "inf", "none", "smc", "pid", "paper",
           "model", "both", "cubic", "spring", "empirical", "tondu-lopez", "mpam97", "mpam143", "spring-small",
           "overshoot_pct<=10", "overshoot_pct<=nan", "nope<=1", "time_constant_s", "1" * 5000, "../" * 50,
           "%s%n%x", "$(reboot)", "'; DROP TABLE", "\x1b[31mred", "\r\n"]


def fixtures(root: Path) -> dict:
    """Files of every kind under ``root``: special, broken and good. Returns name -> path."""
    from mckibben.datasets.campaign import BUNDLED

    f = {}
    root.mkdir(parents=True, exist_ok=True)
    (root / "a_folder").mkdir()
    f["folder"] = root / "a_folder"
    (root / "d.png").mkdir()
    f["folder.png"] = root / "d.png"
    (root / "d.csv").mkdir()
    f["folder.csv"] = root / "d.csv"
    for ext in ("csv", "toml", "png", "parquet"):
        os.mkfifo(root / f"fifo.{ext}")
        f[f"fifo.{ext}"] = root / f"fifo.{ext}"
    (root / "empty.csv").write_text("")
    f["empty.csv"] = root / "empty.csv"
    (root / "garbage.csv").write_bytes(os.urandom(300))
    f["garbage.csv"] = root / "garbage.csv"
    (root / "garbage.parquet").write_bytes(b"PAR1" + os.urandom(100))
    f["garbage.parquet"] = root / "garbage.parquet"
    (root / "bom.csv").write_bytes("\ufeffpressure_kPa,load_N,length_mm\n0,0.6,97\n100,0.6,95\n".encode())
    f["bom.csv"] = root / "bom.csv"
    (root / "ragged.csv").write_text("pressure_kPa,load_N,length_mm\n0,0.6\n100,0.6,95,4,5\n")
    f["ragged.csv"] = root / "ragged.csv"
    (root / "header_only.csv").write_text("time_s,pressure_MPa\n")
    f["header_only.csv"] = root / "header_only.csv"
    (root / "huge.csv").write_text("time_s,pressure_MPa\n0,0\n0.1,1e300\n0.2,0.5\n")
    f["huge.csv"] = root / "huge.csv"
    (root / "long.csv").write_text("time_s,pressure_MPa\n0,0.1\n1000000,0.2\n")
    f["long.csv"] = root / "long.csv"
    (root / "negative.csv").write_text("time_s,pressure_MPa\n" + "".join(f"{i * 1e-3},{-0.5 if i > 20 else 0}\n"
                                                                       for i in range(100)))
    f["negative.csv"] = root / "negative.csv"
    step = "time_s,pressure_MPa,command_pwm\n" + "".join(
        f"{i * 1e-3:.3f},{0.0 if i < 50 else 0.5 * (1 - 2.718281828 ** (-(i - 50) / 60.0)):.5f},{0 if i < 50 else 150}\n"
        for i in range(400))
    (root / "step.csv").write_text(step)
    f["step.csv"] = root / "step.csv"
    (root / "bad.toml").write_text("[sweep\nseed = ")
    f["bad.toml"] = root / "bad.toml"
    (root / "big.toml").write_text("[sweep]\nsamples = 1000000\nchunk_size = 1000000\n[scenario]\nduration = \"10s\"\n")
    f["big.toml"] = root / "big.toml"
    (root / "high.toml").write_text("[scenario]\ntarget = \"5MPa\"\n")
    f["high.toml"] = root / "high.toml"
    (root / "small.toml").write_text("[sweep]\nsamples = 2\nchunk_size = 2\n[scenario]\nduration = \"0.02s\"\n")
    f["small.toml"] = root / "small.toml"
    f["campaign"] = BUNDLED
    f["isotonic"] = BUNDLED / "mpam97" / "isotonic.csv"
    f["force_length"] = BUNDLED / "mpam97" / "force_length.csv"
    f["muscle.toml"] = BUNDLED / "mpam97" / "muscle.toml"
    f["step_parquet"] = BUNDLED / "mpam97" / "step_response.parquet"
    f["proc"] = Path("/proc/mckibben-fuzz")
    f["proc.png"] = Path("/proc/mckibben-fuzz.png")
    f["dev_zero"] = Path("/dev/zero")
    f["dev_null"] = Path("/dev/null")
    f["missing.csv"] = root / "missing" / "x.csv"
    f["under_file"] = root / "empty.csv" / "x.png"
    f["out.png"] = root / "out.png"
    f["out.svg"] = root / "out.svg"
    f["out.parquet"] = root / "out.parquet"
    f["out_folder"] = root / "out_folder"
    return f


def random_value(rng: random.Random, files: dict) -> str:
    """One value of any kind."""
    kind = rng.random()
    if kind < 0.25:
        return rng.choice(NUMBERS) + rng.choice(UNITS)
    if kind < 0.45:
        return rng.choice(GARBAGE)
    if kind < 0.65:
        return str(rng.choice(list(files.values())))
    if kind < 0.8:
        n = rng.randrange(1, 4)
        return ",".join(rng.choice(NUMBERS[:12]) + rng.choice(["", "mm", "MPa"]) for _ in range(n)) + rng.choice(UNITS)
    if kind < 0.9:
        alphabet = "".join(chr(c) for c in range(32, 127)) + "é°µ²·\udcff"
        return "".join(rng.choice(alphabet) for _ in range(rng.randrange(0, 30)))
    return f"{rng.choice(NUMBERS[:14])}{rng.choice(UNITS)}:{rng.choice(NUMBERS[:14])}{rng.choice(UNITS)}:" \
           f"{rng.choice(['1', '9', '0', '1000001', '-3', 'x'])}"


#: Plausible values for required parameters, so that a line gets past them to the fuzzed ones.
PLAUSIBLE = {
    "--reference": ["sine:0.4MPa,0.1MPa,2Hz"], "--path": ["circle:radius=2mm,period=0.5s,cycles=1"],
    "--tip": ["3mm,0mm,110mm"], "--pressure": ["0.5MPa", "0:0.8MPa:5"], "--length": ["90mm"],
    "--lengths": ["117mm,112mm,115mm"], "--model": ["cubic", "chou-hannaford", "spring"],
    "--port": ["{missing.csv}"], "--out": ["{out_folder}"], "data": ["{isotonic}", "{force_length}"],
    "logs": ["{step.csv}"], "file": ["{small.toml}"], "results": ["{folder}"], "journal": ["{folder}"],
    "name": ["mpam97", "spring-small"],
}


def command_line(rng: random.Random, commands, files: dict) -> list[str]:
    """One random command line."""
    path, params = rng.choice(commands)
    args = list(path)
    chosen = [p for p in params if rng.random() < 0.35]
    for p in params:
        key = p.opts[0] if p.param_type_name == "option" else p.name
        fuzzed = p in chosen
        if getattr(p, "is_flag", False):
            if fuzzed or rng.random() < 0.2:
                args.append(p.opts[0])
            continue
        if not fuzzed and not p.required:
            continue
        if fuzzed or key not in PLAUSIBLE:
            value = random_value(rng, files)
        else:
            value = rng.choice(PLAUSIBLE[key])
            if value.startswith("{") and value.endswith("}"):
                value = str(files[value[1:-1]])
        if p.param_type_name == "option":
            args += [p.opts[0], value]
        else:
            args.append(value)
    if path == ("rig", "emulate") and "--duration" not in args:
        args += ["--duration", "0.3s"]  # a server: without a duration it runs until Ctrl-C, by design
    return args


class Slow(BaseException):
    """The time limit of one line (not an Exception: the command line's boundary lets it through)."""


def _alarm(signum, frame):
    raise Slow()


def run_line(args: list[str], timeout: float) -> dict:
    """Run one line in-process; return its status, stderr and wall time."""
    from mckibben.cli import main

    out, err = io.StringIO(), io.StringIO()
    t0 = time.perf_counter()
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, timeout)
    try:
        with redirect_stdout(out), redirect_stderr(err):
            code = main(list(args))
    except Slow:
        code = "slow"
    except SystemExit as exc:  # a command must return, not exit the interpreter
        code = f"SystemExit({exc.code})"
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)
    return {"code": code, "err": err.getvalue(), "seconds": time.perf_counter() - t0}


def problems(res: dict) -> list[str]:
    """What breaks the contract in one result (empty: fine)."""
    bad = []
    if res["code"] not in (0, 2):
        bad.append(f"exit {res['code']}")
    if "Traceback" in res["err"]:
        bad.append("traceback")
    if res["code"] == 2 and res["err"].count("\n") != 1:
        bad.append(f"{res['err'].count(chr(10))} stderr lines")
    return bad


def leftovers(folder: Path) -> list[str]:
    """Temporaries left in ``folder`` (recursively)."""
    from mckibben.atomic import TMP_TAG

    return [str(p) for p in folder.rglob("*") if TMP_TAG in p.name]


def fuzz(lines: int, seed: int, timeout: float = 120.0, log=None) -> dict:
    """Run ``lines`` random command lines; return the tally and every failure."""
    import matplotlib

    matplotlib.use("Agg")
    rng = random.Random(seed)
    commands = discover()
    tally: dict = {"lines": 0, "exit_0": 0, "exit_2": 0, "failures": [], "slow": [], "seconds": 0.0}
    cwd = os.getcwd()
    with tempfile.TemporaryDirectory(prefix="mckibben-fuzz-") as tmp:
        root = Path(tmp)
        files = fixtures(root / "fx")
        work = root / "work"
        work.mkdir()
        os.chdir(work)
        try:
            for i in range(lines):
                args = command_line(rng, commands, files)
                res = run_line(args, timeout)
                tally["lines"] += 1
                tally["seconds"] += res["seconds"]
                if res["code"] == "slow":
                    tally["slow"].append({"args": args, "seconds": res["seconds"]})
                elif res["code"] in (0, 2):
                    tally[f"exit_{res['code']}"] += 1
                bad = problems(res) if res["code"] != "slow" else []
                left = leftovers(root)
                if left:
                    bad.append(f"left {left}")
                    for p in left:
                        Path(p).unlink(missing_ok=True) if Path(p).is_file() else None
                if bad:
                    tally["failures"].append({"args": args, "problems": bad, "stderr": res["err"][-2000:]})
                if log is not None:
                    log.write(json.dumps({"i": i, "args": args, "code": res["code"], "seconds": round(res["seconds"], 3),
                                          "problems": bad}) + "\n")
                    log.flush()
        finally:
            os.chdir(cwd)
    return tally


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lines", type=int, default=2000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--timeout", type=float, default=120.0)
    ap.add_argument("--log", default=None, help="Write one JSON line per command line here.")
    a = ap.parse_args()
    log = open(a.log, "w", encoding="utf-8") if a.log else None
    t0 = time.perf_counter()
    tally = fuzz(a.lines, a.seed, a.timeout, log)
    wall = time.perf_counter() - t0
    print(f"{tally['lines']} command lines (seed {a.seed}) in {wall:.0f} s: exit 0: {tally['exit_0']}, "
          f"exit 2: {tally['exit_2']}, slow (> {a.timeout:g} s): {len(tally['slow'])}, "
          f"failures: {len(tally['failures'])}")
    for f in tally["failures"][:50]:
        print("FAIL", f["problems"], " ".join(repr(x) if (" " in x or not x) else x for x in f["args"]))
        print("    ", f["stderr"].strip().splitlines()[-1] if f["stderr"].strip() else "(no stderr)")
    for s in tally["slow"]:
        print("SLOW", " ".join(s["args"]))
    sys.exit(1 if tally["failures"] else 0)


if __name__ == "__main__":
    main()

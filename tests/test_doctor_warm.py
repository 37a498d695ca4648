"""``mckibben doctor --warm`` compiles every kernel any command uses: nothing compiles after it.

Tried the way users run commands, each in its own process, on an empty cache folder of the test's
own: ``doctor --warm``, then the README's quick start (the Python and the commands) and a lab's
own muscle (a muscle file's fitted law through ``fit --save``, ``predict force``, ``simulate`` and
``control step --muscle-file``); none may print the compile notice. Compilation is seen by the
notice the command line prints at a process's first compilation, and by Numba's own statistics.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from mckibben.datasets.isometric import BUNDLED_ISOMETRIC

SRC = Path(__file__).resolve().parents[1] / "src"
NOTICE = "compiling kernels once"
#: The console script, then what Numba compiled in this process (as tests/test_compile_cache.py).
WRAPPER = ("import json, sys\n"
           "from mckibben.cli import run, main\n"
           "from mckibben import compile_notice, _jit\n"
           "compile_notice.enabled = True\n"
           "code = main(sys.argv[1:])\n"
           "sys.stderr.write('COMPILE-STATS ' + json.dumps(_jit.compile_stats()) + '\\n')\n"
           "sys.exit(code)\n")
QUICK_START = """
import mckibben as mk
muscle = mk.get_muscle("mpam97")
mk.predict_length(muscle, 0.8e6, 0.6).length
step = mk.step_response("smc", target=0.55e6, law="paper", beta=150)
step.metrics["time_constant_s"]
step.to_pandas().head()
mk.track_tip(mk.tool.parse_path("circle:radius=5mm,period=2s"))
from mckibben import _jit
print("COMPILE-STATS " + __import__("json").dumps(_jit.compile_stats()))
"""


def _run(args: list[str], cache: Path, cwd: Path, script: str = WRAPPER) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_", "MCKIBBEN_"))}
    env.update(PYTHONPATH=str(SRC), MCKIBBEN_CACHE_DIR=str(cache), MCKIBBEN_BACKGROUND_WARM="0", COLUMNS="100")
    return subprocess.run([sys.executable, "-c", script, *args], capture_output=True, text=True, env=env, cwd=cwd,
                          timeout=900)


def _compiled(stream: str) -> int:
    line = next(x for x in stream.splitlines() if x.startswith("COMPILE-STATS "))
    return json.loads(line.split(" ", 1)[1])["compiled"]


@pytest.mark.slow
@pytest.mark.timeout(2400)  # doctor --warm on an empty cache, then 11 fresh processes: minutes on a shared 2-core machine
def test_after_doctor_warm_no_command_compiles(tmp_path):
    cache = tmp_path / "cache"
    warm = _run(["doctor", "--warm", "--json"], cache, tmp_path)
    assert warm.returncode in (0, 1), warm.stderr  # 1: an optional tool is missing, which is not the point here
    assert NOTICE in warm.stderr and json.loads(warm.stdout)["warm"]["steps"]  # it compiled, on an empty cache

    folder = BUNDLED_ISOMETRIC / "commercial10"
    commands = [
        ["fit", str(folder / "isometric.csv"), "--model", "spring", "--muscle-file", str(folder / "muscle.toml"),
         "--save", "mine.toml", "--json"],
        ["predict", "length", "--muscle", "mpam97", "--pressure", "0.8MPa", "--load", "0.6N", "--json"],
        ["simulate", "open-loop", "--valve", "117", "--json"],
        ["control", "step", "--controller", "smc", "--law", "paper", "--beta", "150", "--target", "0.55MPa", "--json"],
        ["control", "step", "--json"],
        ["control", "fig13", "--json"],
        ["tool", "track", "--path", "circle:radius=10mm,period=1s", "--json"],
        ["predict", "force", "--muscle-file", "mine.toml", "--pressure", "0:0.6MPa:7", "--length", "280mm", "--json"],
        ["simulate", "open-loop", "--muscle-file", "mine.toml", "--load", "100N", "--json"],
        ["control", "step", "--muscle-file", "mine.toml", "--load", "100N", "--target", "0.4MPa", "--json"],
    ]
    for args in commands:
        r = _run(args, cache, tmp_path)
        assert r.returncode == 0, (args, r.stderr)
        assert NOTICE not in r.stderr and _compiled(r.stderr) == 0, (args, r.stderr)
    r = _run([], cache, tmp_path, QUICK_START)  # the README's Python quick start
    assert r.returncode == 0, r.stderr
    assert _compiled(r.stdout) == 0, r.stdout

"""The compiled kernels' cache, tried the way users run commands: many short processes.

Every test here starts fresh processes (the suite's own process cannot see a cache problem: it
compiles once and keeps the result in memory). Compilation is observed through Numba's own
dispatcher statistics (:func:`mckibben._jit.compile_stats`), never through a timer.
"""

from __future__ import annotations

import json
import os
import shutil
import stat
import subprocess
import sys
import sysconfig
import tempfile
import textwrap
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]

#: Runs the command line like the console script, then reports what Numba compiled in this process.
WRAPPER = (
    "import json, sys\n"
    "from mckibben import compile_notice\n"
    "from mckibben.cli import main\n"
    "compile_notice.enabled = True\n"
    "code = main(sys.argv[1:])\n"
    "from mckibben import _jit\n"
    "sys.stderr.write('COMPILE-STATS ' + json.dumps(_jit.compile_stats()) + '\\n')\n"
    "sys.exit(code)\n"
)

#: The sequence after which, on the landed main of 2026-11-25, every `control step` failed with
#: "ReferenceError: underlying object has vanished" (issue #21), each command with --json.
SEQUENCE = [
    ["control", "step"],
    ["control", "step"],
    ["control", "step"],
    ["control", "step", "--controller", "smc", "--law", "paper", "--beta", "150", "--target", "0.55MPa"],
    ["simulate", "open-loop", "--valve", "117"],
    ["control", "fig13"],
    ["tool", "track", "--path", "circle:radius=5mm,period=2s"],
    ["control", "track", "--reference", "sine:0.4MPa,0.1MPa,2Hz"],
    ["control", "robustness", "--n", "50"],
    ["control", "compare"],
    ["sweep", "run", "sweep.toml", "--out", "sweep-out"],
    ["control", "step", "--controller", "pid"],
    ["simulate", "open-loop"],
    ["control", "step", "--controller", "pid"],
    ["control", "hysteresis"],
]


def _env(**extra: str) -> dict:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_", "MCKIBBEN_"))}
    env.update(extra)
    return env


def _run(args, cwd, env, timeout=600):
    r = subprocess.run([sys.executable, "-c", WRAPPER, *args, "--json"], cwd=cwd, env=env, capture_output=True,
                       text=True, timeout=timeout)
    lines = r.stderr.splitlines()
    stats = [json.loads(x.split(" ", 1)[1]) for x in lines if x.startswith("COMPILE-STATS ")]
    return r, (stats[0] if stats else None), [x for x in lines if not x.startswith("COMPILE-STATS ")]


def _snapshot(folder: Path) -> dict:
    return {str(p.relative_to(folder)): p.stat().st_size for p in folder.rglob("*") if p.is_file()}


@pytest.mark.slow
@pytest.mark.timeout(2400)  # 30 fresh processes, the first ones compiling: minutes on a shared 2-core machine
def test_the_command_sequence_from_a_clean_cache_then_again_compiles_nothing(tmp_path):
    cache = tmp_path / "cache"
    work = tmp_path / "work"
    work.mkdir()
    shutil.copy(ROOT / "src" / "mckibben" / "examples" / "sweep.toml", work / "sweep.toml")
    env = _env(MCKIBBEN_CACHE_DIR=str(cache))
    first_compiled = 0
    for args in SEQUENCE:
        shutil.rmtree(work / "sweep-out", ignore_errors=True)
        r, stats, err = _run(args, work, env)
        assert r.returncode == 0, (args, r.stderr[-3000:])
        assert not [x for x in err if x.startswith("warning")], (args, err)
        first_compiled += stats["compiled"]
    assert first_compiled > 0  # the cache was clean: the first pass compiled
    before = _snapshot(cache)
    for args in SEQUENCE:
        shutil.rmtree(work / "sweep-out", ignore_errors=True)
        r, stats, err = _run(args, work, env)
        assert r.returncode == 0, (args, r.stderr[-3000:])
        assert stats["compiled"] == 0, (args, stats)
        assert stats["cache_hits"] > 0, (args, stats)
        assert err == [], (args, err)  # no compile notice, no warning
    assert _snapshot(cache) == before  # nothing saved again: the cache does not grow


@pytest.mark.slow
def test_a_first_compilation_says_so_once_on_stderr(tmp_path):
    env = _env(MCKIBBEN_CACHE_DIR=str(tmp_path / "cache"))
    r, stats, err = _run(["simulate", "open-loop", "--duration", "0.05s"], tmp_path, env)
    assert r.returncode == 0, r.stderr
    assert stats["compiled"] > 0
    assert len(err) == 1 and err[0].startswith("mckibben: compiling kernels once for this machine"), err
    assert str(tmp_path / "cache") in err[0]


def test_an_unwritable_cache_folder_runs_uncached_with_one_warning(tmp_path):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    env = _env(MCKIBBEN_CACHE_DIR=str(blocker / "cache"))
    # 100 pressures: past what the NumPy face runs as Python, so the force law compiles
    r, stats, err = _run(["predict", "force", "--model", "tondu-lopez", "--pressure", "0:0.8MPa:100"], tmp_path, env)
    assert r.returncode == 0, r.stderr
    assert stats["compiled"] > 0
    assert len(err) == 1 and err[0].startswith("warning: cannot write the kernel cache folder"), err
    assert not blocker.with_name("cache").exists()


@pytest.mark.slow
def test_a_corrupt_cache_entry_is_compiled_again_not_fatal(tmp_path):
    cache = tmp_path / "cache"
    env = _env(MCKIBBEN_CACHE_DIR=str(cache))
    args = ["simulate", "open-loop", "--duration", "0.05s"]
    r, _, _ = _run(args, tmp_path, env)
    assert r.returncode == 0, r.stderr
    damaged = 0
    for f in cache.rglob("*.nb[ic]"):
        f.write_bytes(b"\x80\x04garbage, not a pickle")
        damaged += 1
    assert damaged > 0
    r, stats, err = _run(args, tmp_path, env)
    assert r.returncode == 0, r.stderr
    assert stats["compiled"] > 0
    assert len([x for x in err if x.startswith("warning")]) <= 1, err


def test_no_cached_function_takes_a_compiled_function_as_an_argument():
    """A dispatcher-typed argument cannot be cached (numba-cache.md): check every kernel's compiled signatures."""
    import numba

    from mckibben import _jit, experiments

    experiments.step_response("smc", law="paper", beta=150)
    experiments.open_loop()
    seen = set()
    for disp in _jit.DISPATCHERS:  # entry points loaded from the cache list their signatures; callees are inside
        for sig in disp.signatures:
            seen.add(disp.__name__)
            assert not any(isinstance(t, numba.core.types.Dispatcher) for t in sig), (disp, sig)
    assert {"run_blocks", "eval_loop"} <= seen, seen


def test_a_cache_never_lands_inside_the_package():
    pkg = ROOT / "src" / "mckibben"
    from mckibben import _jit

    assert _jit.cache_dir() is None or not _jit.cache_dir().is_relative_to(pkg)
    # whatever older versions left beside the sources is not written by this one
    for disp in _jit.DISPATCHERS:
        cache = getattr(disp, "_cache", None)
        path = getattr(cache, "cache_path", None)
        if path:
            assert not Path(path).resolve().is_relative_to(pkg.resolve()), (disp, path)


def test_the_open_loop_metrics_equal_python_controls_step_info():
    import control

    from mckibben.plant.calibration import step_info

    rng = np.random.default_rng(7)
    t = np.arange(400) * 1e-3
    for k in range(50):
        tau, over = rng.uniform(0.005, 0.1), rng.uniform(0.0, 0.4)
        y = 1.0 - np.exp(-t / tau) * np.cos(over * 40 * t) + rng.normal(0, 0.003 * (k % 3), t.size)
        final = float(np.mean(y[-20:]))
        info = control.step_info(y, T=t, yfinal=final)
        assert step_info(y, t, final) == (float(info["RiseTime"]), float(info["Overshoot"]),
                                          float(info["SettlingTime"]))


# --- a system-wide install, run by an account that can write neither it nor a home folder ---------


def _other_user_python() -> str | None:
    """A Python 3.11 that uid 65534 may run (this one may live in a private home), or None."""
    for exe in (sys.executable, "/usr/bin/python3.11", "/usr/local/bin/python3.11"):
        if not os.path.exists(exe):
            continue
        r = subprocess.run(["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups", "--", exe, "-c",
                            "import sys; print(sys.version_info[:2])"], capture_output=True, text=True)
        if r.returncode == 0 and r.stdout.strip() == "(3, 11)":
            return exe
    return None


@pytest.fixture(scope="module")
def system_install():
    if os.geteuid() != 0 or shutil.which("setpriv") is None:
        pytest.skip("needs root and setpriv to run a command as another user")
    if sys.version_info[:2] != (3, 11):
        pytest.skip("the other user's interpreter is the system's Python 3.11")
    python = _other_user_python()
    if python is None:
        pytest.skip("no Python 3.11 that another user may run")
    root = Path(tempfile.mkdtemp(prefix="mckibben-system-"))
    try:
        root.chmod(0o755)
        site = root / "site-packages"
        # the installed dependencies, hard-linked (their folders may sit in a home others cannot enter)
        purelib = Path(sysconfig.get_paths()["purelib"])
        shutil.copytree(purelib, site, copy_function=os.link, symlinks=True,
                        ignore=shutil.ignore_patterns("mckibben*", "__editable__*", "*mckibben*.pth", "__pycache__"))
        r = subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--no-compile", "--target",
                            str(site), str(ROOT)], capture_output=True, text=True, timeout=600)
        assert r.returncode == 0, r.stderr[-3000:]
        for p in [root, *root.rglob("*")]:  # root-owned, read-only for everyone else
            mode = p.lstat().st_mode
            if not stat.S_ISLNK(mode):
                p.chmod((mode | stat.S_IRGRP | stat.S_IROTH | (stat.S_IXGRP | stat.S_IXOTH if mode & stat.S_IXUSR
                                                                 else 0)) & ~(stat.S_IWGRP | stat.S_IWOTH))
        yield python, site
    finally:
        shutil.rmtree(root, ignore_errors=True)


@pytest.mark.slow
@pytest.mark.timeout(1200)  # uncached: control step compiles its kernels in memory
@pytest.mark.parametrize("args", [
    ["--version"],
    ["predict", "force", "--model", "tondu-lopez", "--pressure", "0.5MPa"],
    ["control", "step", "--json"],
])
def test_a_system_wide_install_runs_for_a_user_without_a_home(system_install, args):
    python, site = system_install
    env = {"PATH": "/usr/bin:/bin", "HOME": "/nonexistent", "PYTHONPATH": str(site), "LANG": "C.UTF-8"}
    r = subprocess.run(["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups", "--", python, "-m",
                        "mckibben.cli", *args], env=env, capture_output=True, text=True, timeout=900, cwd="/")
    assert r.returncode == 0, r.stderr[-3000:]
    assert "Traceback" not in r.stderr
    warnings = [x for x in r.stderr.splitlines() if x.strip()]
    assert len(warnings) <= 1, warnings
    assert not list(site.rglob("*.nb[ic]"))  # nothing cached inside the install


# --- kernels that run as plain Python until Numba is loaded (mckibben._kernels) --------------------

_LAW_CASES = (
    "import numpy as np\n"
    "from mckibben.models import laws as LW\n"
    "from mckibben.datasets import get_muscle\n"
    "rng = np.random.default_rng(11)\n"
    "n = 60\n"
    "sp = np.zeros(LW.NTH)\n"
    "sp[LW.SP_H2], sp[LW.SP_H1], sp[LW.SP_H0], sp[LW.SP_SPLIT] = -1e-14, 1e-9, 0.1, 0.3e6\n"
    "sp[LW.SP_LOW:LW.SP_LOW + 4] = rng.normal(0, 1e-3, 4)\n"
    "sp[LW.SP_HIGH:LW.SP_HIGH + 4] = rng.normal(0, 1e-3, 4)\n"
    "CASES = {\n"
    "  'tondu-lopez': LW.tondu_lopez_theta(6e-4, 0.35, 1.2, 2e4, 0.097),\n"
    "  'chou-hannaford': LW.chou_hannaford_theta(0.1, 2.0),\n"
    "  'wall-corrected': LW.chou_hannaford_theta(0.1, 2.0, 2e-4),\n"
    "  'braid-map': LW.braid_map_theta(get_muscle('mpam97')),\n"
    "  'spring': sp,\n"
    "}\n"
    "P = rng.uniform(-1e5, 1.0e6, n)\n"
    "L = rng.uniform(0.06, 0.11, n)\n"
)


def test_kernels_give_the_same_bits_as_plain_python_and_compiled(tmp_path):
    """``predict`` runs the force laws and the sensor model as plain Python (no Numba); the plant compiles them."""
    script = _LAW_CASES + (
        "import sys\n"
        "from mckibben import hardware as HW\n"
        "out = {k: LW.evaluate(k, P, L, th) for k, th in CASES.items()}\n"
        "out['adc'] = HW.adc_from_pressure(P)\n"
        "out['enc'] = HW.encoder_from_length(L, 0.097)\n"
        "assert 'numba' not in sys.modules\n"
        f"np.savez(r'{tmp_path / 'py.npz'}', **{{k.replace('-', '_'): v for k, v in out.items()}})\n"
    )
    subprocess.run([sys.executable, "-c", script], check=True, env=_env(), timeout=300)
    python = np.load(tmp_path / "py.npz")
    import mckibben._jit  # noqa: F401  (compiled from here on)

    ns: dict = {}
    exec(_LAW_CASES, ns)
    LW, P, L = ns["LW"], ns["P"], ns["L"]
    from mckibben import hardware as HW

    from numba.core.registry import CPUDispatcher

    assert isinstance(LW.tondu_lopez, CPUDispatcher) and isinstance(HW.adc_count, CPUDispatcher)
    for name, th in ns["CASES"].items():
        compiled = LW.evaluate(name, np.repeat(P, 2), np.repeat(L, 2), th)  # 120 elements: the compiled path
        np.testing.assert_array_equal(compiled[::2], python[name.replace("-", "_")], err_msg=name)
    np.testing.assert_array_equal(HW.adc_from_pressure(np.repeat(P, 2))[::2], python["adc"])
    np.testing.assert_array_equal(HW.encoder_from_length(np.repeat(L, 2), 0.097)[::2], python["enc"])


@pytest.mark.parametrize("args", [["--version"], ["--help"],
                                  ["predict", "length", "--muscle", "mpam97", "--pressure", "0.8MPa", "--load", "0.6N"],
                                  ["predict", "force", "--model", "tondu-lopez", "--pressure", "0.5MPa"],
                                  ["predict", "pressure", "--muscle", "mpam97", "--length", "90mm", "--load", "0.6N"]])
def test_quick_commands_import_no_heavy_package(args):
    script = ("import sys, io, contextlib\n"
              "from mckibben.cli import main\n"
              "with contextlib.redirect_stdout(io.StringIO()):\n"
              f"    code = main({args!r})\n"
              "heavy = [m for m in ('numba', 'control', 'matplotlib', 'dask') if m in sys.modules]\n"
              "print(code, heavy)\n")
    r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=_env(), timeout=120)
    assert r.stdout.strip() == "0 []", (r.stdout, r.stderr[-2000:])


@pytest.mark.slow
@pytest.mark.timeout(600)
@pytest.mark.parametrize("args", [["simulate", "open-loop", "--valve", "117", "--json"],
                                  ["control", "step", "--controller", "smc", "--law", "paper", "--beta", "150",
                                   "--target", "0.55MPa", "--json"],
                                  ["tool", "track", "--path", "circle:radius=5mm,period=2s", "--json"]])
def test_simulation_commands_import_no_lti_plotting_table_or_cluster_package(args):
    """A simulation that builds no LTI object, draws nothing and writes no table loads neither
    python-control, Matplotlib, Dask nor pandas (0.25-0.8 s each of every run's wall time)."""
    script = ("import sys, io, contextlib\n"
              "from mckibben.cli import main\n"
              "with contextlib.redirect_stdout(io.StringIO()):\n"
              f"    code = main({args!r})\n"
              "heavy = [m for m in ('control', 'matplotlib', 'dask', 'pandas') if m in sys.modules]\n"
              "print(code, heavy)\n")
    r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=_env(), timeout=580)
    assert r.stdout.strip() == "0 []", (r.stdout, r.stderr[-2000:])


@pytest.mark.slow
def test_a_runner_compiled_in_memory_gives_the_cached_runners_bits(monkeypatch):
    """The path of an uncached process or a kernel defined in a notebook cell: same numbers, to the bit."""
    from mckibben import _jit
    from mckibben.control import core as C
    from mckibben.plant import PlantParams, _runner, simulate
    from mckibben.plant import simulator as S

    spec = C.core_spec(C.CoreParams(), 3)
    ref = np.where(np.arange(300) >= 20, 0.45e6, 0.0)
    cached = simulate(PlantParams(), 0.3, controller=spec, reference=ref, n=3)
    in_memory = _jit._in_memory(_runner, "controller_kernel", spec[0])
    assert in_memory.controller_kernel is spec[0]
    monkeypatch.setattr(S, "_runner_of", lambda kernel: in_memory)
    again = simulate(PlantParams(), 0.3, controller=spec, reference=ref, n=3)
    assert cached.pressure.max() > 0.4e6
    np.testing.assert_array_equal(again.pressure, cached.pressure)
    np.testing.assert_array_equal(again.inlet, cached.inlet)
    np.testing.assert_array_equal(again.istate, cached.istate)


def test_a_cache_save_failure_never_reaches_the_run(monkeypatch):
    """Numba's save of a new overload may fail (a foreign index: 'underlying object has vanished',
    a full disk): the compiled code is used all the same, with one warning. (It replaces the
    simulator's old retry of a whole run after such a failure.)"""
    import uuid
    import warnings

    from numba.core import caching

    from mckibben import _jit

    if _jit.cache_dir() is None:
        pytest.skip("this process has no kernel cache folder")

    def fails(self, sig, data):
        raise ReferenceError("underlying object has vanished")

    monkeypatch.setattr(caching.FunctionCache, "save_overload", fails)
    monkeypatch.setitem(_jit._STATE, "warned", False)
    # a kernel no process has cached before: generated source, written to the cache folder like the plant's
    tag = uuid.uuid4().hex
    mod = _jit.generated_module(f"test_save_{tag}", "from mckibben._jit import kernel  # kernel-decorator\n\n\n"
                                f"@kernel\ndef twice(x):\n    return 2.0 * x  # {tag}\n")
    assert str(_jit.cache_dir()) in mod.twice.stats.cache_path  # cached on disk, not in memory
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert mod.twice(21.0) == 42.0
        assert mod.twice(4.0) == 8.0
    assert [str(w.message) for w in caught] == [
        "a compiled kernel could not be cached (ReferenceError: underlying object has vanished)"]
    assert sum(mod.twice.stats.cache_misses.values()) == 1


# --- only Numba's public API -------------------------------------------------------------------


def _numba_private_names() -> set[str]:
    """Private (``_x``, not dunder) members of the Numba objects the package handles: dispatchers,
    their caches and compile events, read from the installed Numba itself."""
    import numba
    from numba.core import caching, event
    from numba.core.registry import CPUDispatcher

    def twice(x):
        return 2.0 * x

    previous = numba.config.CACHE_DIR
    with tempfile.TemporaryDirectory() as where:
        numba.config.CACHE_DIR = where
        try:
            disp = numba.njit(cache=True)(twice)
        finally:
            numba.config.CACHE_DIR = previous
    objects = [CPUDispatcher, disp, caching.FunctionCache, caching.IndexDataCacheFile, event.Event, event.Listener,
               disp._cache, disp._cache._cache_file, disp._cache._impl, disp._cache._impl.locator,
               caching, event, numba.core.config,
               event.Event("numba:compile", event.EventStatus.START)]
    impl = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl", None)
    objects += [impl] if impl is not None else []
    names = set()
    for obj in objects:
        names.update(dir(obj))
        names.update(getattr(obj, "__dict__", {}))
    return {n for n in names if n.startswith("_") and not (n.startswith("__") and n.endswith("__"))}


def _private_numba_uses(tree, private: set[str]) -> list[str]:
    import ast

    numba_names: set[str] = set()  # names bound to Numba modules or objects by an import
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] == "numba":
                    numba_names.add((alias.asname or alias.name).split(".")[0])
                    if any(part.startswith("_") for part in alias.name.split(".")):
                        found.append(f"line {node.lineno}: import {alias.name}")
        elif isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[0] == "numba":
            for part in (node.module or "").split("."):
                if part.startswith("_"):
                    found.append(f"line {node.lineno}: from {node.module}")
            for alias in node.names:
                numba_names.add(alias.asname or alias.name)
                if alias.name.startswith("_"):
                    found.append(f"line {node.lineno}: from {node.module} import {alias.name}")
    numba_classes = set()
    for node in ast.walk(tree):  # classes of the module built on a Numba class: their `self` is a Numba object
        if isinstance(node, ast.ClassDef) and any(
                isinstance(b, (ast.Name, ast.Attribute)) and ast.unparse(b).split(".")[0] in numba_names
                for b in node.bases):
            numba_classes.add(node.name)
            for inner in ast.walk(node):
                if (isinstance(inner, ast.Attribute) and isinstance(inner.value, ast.Name)
                        and inner.value.id in ("self", "cls") and inner.attr.startswith("_")
                        and not inner.attr.startswith("__")):
                    found.append(f"line {inner.lineno}: {ast.unparse(inner)} on a subclass of a Numba class")
    for node in ast.walk(tree):
        if not isinstance(node, ast.Attribute) or not node.attr.startswith("_") or node.attr.startswith("__"):
            continue
        root = node.value
        while isinstance(root, ast.Attribute):
            root = root.value
        on_numba = isinstance(root, ast.Name) and root.id in numba_names
        if on_numba or node.attr in private:
            found.append(f"line {node.lineno}: {ast.unparse(node)}")
    for node in ast.walk(tree):  # getattr(x, "_private") is the same access
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in ("getattr", "setattr")
                and len(node.args) >= 2 and isinstance(node.args[1], ast.Constant)
                and isinstance(node.args[1].value, str) and node.args[1].value in private):
            found.append(f"line {node.lineno}: {ast.unparse(node)}")
    return found


def test_the_package_uses_no_private_numba_attribute():
    """No ``caching._X``, ``disp._cache``, ``event._exc_details``: the next Numba release may drop them."""
    import ast

    private = _numba_private_names()
    assert {"_cache", "_exc_details", "_CacheLocator"} <= private  # the check knows what it looks for
    problems = []
    for path in sorted((ROOT / "src" / "mckibben").rglob("*.py")):
        for where in _private_numba_uses(ast.parse(path.read_text(), str(path)), private):
            problems.append(f"{path.relative_to(ROOT)}: {where}")
    assert problems == []


@pytest.mark.parametrize("source", [
    "from numba.core import caching\nclass L(caching._CacheLocator):\n    pass\n",
    "from numba.core import caching\nimpl = caching.CacheImpl\nimpl._locator_classes.insert(0, 1)\n",
    "def f(disp, cls):\n    disp._cache.__class__ = cls\n",
    "def f(cache):\n    return getattr(getattr(cache, '_cache_file', None), '_index_path', None)\n",
    "def on_end(event):\n    return getattr(event, '_exc_details', None)\n",
    "import numba\nx = numba.core.config._readenv\n",
    "from numba.core.registry import CPUDispatcher\nclass K(CPUDispatcher):\n"
    "    def f(self):\n        return self._can_compile\n",
    "from numba.core.caching import _CacheLocator\n",
])
def test_the_private_numba_check_finds_each_use_it_replaced(source):
    import ast

    assert _private_numba_uses(ast.parse(source), _numba_private_names()) != []


def test_the_cache_folder_is_named_by_the_package_sources(tmp_path):
    """An edit anywhere in the package moves its kernels to another folder: a stale entry is never read."""
    copy = tmp_path / "src"
    shutil.copytree(ROOT / "src" / "mckibben", copy / "mckibben", ignore=shutil.ignore_patterns("__pycache__"))
    code = "from mckibben import _jit; print(_jit.cache_dir())"
    env = _env(MCKIBBEN_CACHE_DIR=str(tmp_path / "cache"), PYTHONPATH=str(copy))

    def folder() -> Path:
        r = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
        assert r.returncode == 0, r.stderr[-2000:]
        return Path(r.stdout.strip())

    first = folder()
    assert first == folder() and first.is_relative_to(tmp_path / "cache")
    units = copy / "mckibben" / "units.py"
    units.write_text(units.read_text() + "\n# an edit\n")
    second = folder()
    assert second != first and second.parent == first.parent


def test_a_new_cache_folder_removes_only_its_long_unused_siblings(tmp_path):
    from mckibben import _jit

    version = tmp_path / "0.1.0"
    old, recent, foreign, new = (version / n for n in ("old", "recent", "not-ours", "new"))
    for folder in (old, recent, foreign, new):
        folder.mkdir(parents=True)
    (old / ".last-used").touch()
    (recent / ".last-used").touch()
    long_ago = (old / ".last-used").stat().st_mtime - _jit.PRUNE_AFTER_S - 60
    os.utime(old / ".last-used", (long_ago, long_ago))
    _jit._mark_used(new)
    assert sorted(p.name for p in version.iterdir()) == ["new", "not-ours", "recent"]
    assert (new / ".last-used").exists()


# --- mckibben doctor ----------------------------------------------------------------------------


@pytest.mark.parametrize("address", ["notanaddress", "http://127.0.0.1:8786", "tcp://127.0.0.1", "tcp://host:port",
                                     "tcp://:8786"])
def test_doctor_refuses_a_bad_scheduler_address_before_the_warm_up(cli, address):
    r = cli("doctor", "--scheduler", address)  # with the warm-up on: refused before any compiling
    assert r.code == 2, (r.code, r.err)
    assert r.err.count("\n") == 1 and r.err.startswith("error: --scheduler:") and address in r.err, r.err


def test_doctor_reports_the_cache_the_tools_and_an_unanswering_scheduler(cli):
    import socket

    with socket.socket() as s:  # a port nothing listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    r = cli("doctor", "--no-warm", "--scheduler", f"tcp://127.0.0.1:{port}", "--json")
    assert r.code == 1, r.err  # not ok: the scheduler does not answer
    out = r.json()
    assert out["warm"] is None and out["ok"] is False and out["scheduler"]["reachable"] is False
    assert out["cache_dir"] and set(out["tools"]) == {"avr-gcc", "simavr", "libsimavr", "avrdude", "arduino-cli"}
    assert "dask scheduler --port" in out["scheduler"]["detail"]


# ---------------------------------------------------------------------------------------------
# one compiler per kernel across processes, and the background warm-up of a first command


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_the_background_warm_up_compiles_what_the_runner_calls(tmp_path):
    """The warm-up compiles the integrator, its outputs and the firmware core with the very
    signatures the generated runner calls them with; a mismatch would compile them twice."""
    # a fresh process and an empty cache: the runner is compiled here, not loaded (a loaded runner
    # leaves its callees' dispatchers without signatures, and the check would see nothing)
    code = textwrap.dedent("""
        from mckibben import doctor
        from mckibben.control import core as C
        from mckibben.plant import PlantParams, simulate

        simulate(PlantParams(), 0.003, controller=C.core_spec(C.CoreParams()), reference=4e5)
        for name, dispatcher, signature in doctor.background_kernels():
            assert tuple(signature) in [tuple(s) for s in dispatcher.signatures], (name, dispatcher.signatures)
        print("same signatures")
    """)
    env = {**os.environ, "MCKIBBEN_CACHE_DIR": str(tmp_path / "cache"), "MCKIBBEN_BACKGROUND_WARM": "0"}
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300)
    assert run.returncode == 0 and "same signatures" in run.stdout, run.stderr[-2000:]


_HOLD = """
import sys, time
from mckibben import doctor
name, dispatcher, sig = doctor.background_kernels()[0]
dispatcher.compile(sig)
print("COMPILED", sum(dispatcher.stats.cache_misses.values()), flush=True)
"""

_WAIT = """
import sys
from mckibben import doctor
name, dispatcher, sig = doctor.background_kernels()[0]
dispatcher.compile(sig)
print("STATS", sum(dispatcher.stats.cache_hits.values()), sum(dispatcher.stats.cache_misses.values()), flush=True)
"""


@pytest.mark.slow
@pytest.mark.timeout(600)
def test_a_process_waits_for_a_kernel_another_one_compiles_and_loads_it(tmp_path):
    """Two processes that need the integrator at once from a cold cache: the first compiles it
    under its lock, the second waits and loads it (a cache hit, no compilation of its own)."""
    import fcntl
    import time

    env = _env(MCKIBBEN_CACHE_DIR=str(tmp_path), MCKIBBEN_BACKGROUND_WARM="0")
    first = subprocess.Popen([sys.executable, "-c", _HOLD], env=env, stdout=subprocess.PIPE, text=True)
    try:
        lock = None
        deadline = time.monotonic() + 300
        while lock is None and time.monotonic() < deadline and first.poll() is None:
            for p in tmp_path.rglob("*.lock"):
                with open(p) as fh:
                    try:
                        fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
                        fcntl.flock(fh, fcntl.LOCK_UN)
                    except BlockingIOError:
                        lock = p  # held: the first process is compiling under it
            time.sleep(0.02)
        assert lock is not None, "the first process never held a compile lock"
        second = subprocess.run([sys.executable, "-c", _WAIT], env=env, capture_output=True, text=True, timeout=580)
        assert second.returncode == 0, second.stderr[-2000:]
        out, _ = first.communicate(timeout=580)
    finally:
        first.kill()
    assert "COMPILED 1" in out
    stats = next(x for x in second.stdout.splitlines() if x.startswith("STATS"))
    assert stats == "STATS 1 0", stats  # loaded what the first compiled, compiled nothing


@pytest.mark.timeout(120)
def test_the_background_warm_up_ends_with_its_command(tmp_path):
    import time

    env = _env(MCKIBBEN_CACHE_DIR=str(tmp_path), MCKIBBEN_BACKGROUND_WARM="1")
    r = subprocess.run([sys.executable, "-c", "from mckibben import _jit\np = _jit.start_background_warm()\n"
                        "print(p.pid if p is not None else None)"], env=env, capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    pid = int(r.stdout.strip())  # started: a cache folder, more than one core

    def alive() -> bool:
        try:
            state = Path(f"/proc/{pid}/status").read_text()
        except OSError:
            return False
        return "\nState:\tZ" not in state  # a zombie has ended (whoever reaps it)

    deadline = time.monotonic() + 30
    while alive() and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not alive(), "the warm-up outlived the command that started it"


def test_no_background_warm_up_where_it_cannot_help(tmp_path, monkeypatch):
    from mckibben import _jit

    monkeypatch.setenv("MCKIBBEN_BACKGROUND_WARM", "0")
    assert _jit.start_background_warm() is None
    monkeypatch.setenv("MCKIBBEN_BACKGROUND_WARM", "warming")  # the warm-up itself starts none
    assert _jit.start_background_warm() is None


def test_doctor_finds_the_optional_python_packages_without_importing_them(monkeypatch):
    import importlib.util
    import sys

    from mckibben import doctor

    loaded = "mujoco" in sys.modules  # (another test of this process may have loaded it)
    rep = doctor.check()
    assert set(rep.packages) == set(doctor.OPTIONAL_PACKAGES)
    for name, p in rep.packages.items():  # the test extras install both
        assert p["found"] and name in p["found"] and "pip install" in p["install"]
    assert ("mujoco" in sys.modules) == loaded  # found, not loaded
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "mujoco" else real(name, *a))
    gone = doctor.check().packages["mujoco"]
    assert gone["found"] is None and gone["install"] == "pip install 'mckibben[mujoco]'"


def test_every_kernel_states_its_fast_math_flags():
    # Numba compiles a callee that leaves fastmath unset with the flags of whichever caller compiles
    # it first, so a kernel reached from the integrator (which contracts to FMA) and from the output
    # stage gave last bits that depended on what had filled the cache; every kernel states its own
    from mckibben import _kernels
    from mckibben.plant import simulate  # noqa: F401 (loads the plant's kernels)

    jit = _kernels.jit()
    assert len(jit.DISPATCHERS) > 50
    unset = [d.py_func.__qualname__ for d in jit.DISPATCHERS if "fastmath" not in d.targetoptions]
    assert unset == []


# --- one decorator ------------------------------------------------------------------------------


def test_every_compiled_function_of_the_package_is_made_by_the_one_decorator():
    """``mckibben._kernels.kernel`` (re-exported by ``mckibben._jit``) is the only way the package
    makes a Numba function: no ``numba.njit``/``jit``/``vectorize`` anywhere else, no second
    decorator in ``_jit``, and every dispatcher of a simulation is the package's ``Kernel``."""
    import ast

    from mckibben import _jit, _kernels
    from mckibben.plant import simulate  # noqa: F401 (loads the plant's kernels)

    assert _jit.kernel is _kernels.kernel
    assert not hasattr(_jit, "njit")
    numba_makers = {"njit", "jit", "vectorize", "guvectorize", "cfunc", "generated_jit", "stencil"}
    found = []
    for path in sorted((ROOT / "src" / "mckibben").rglob("*.py")):
        tree = ast.parse(path.read_text(), str(path))
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[0] == "numba":
                found += [f"{path.name}:{node.lineno} from {node.module} import {a.name}"
                          for a in node.names if a.name in numba_makers]
            elif (isinstance(node, ast.Attribute) and node.attr in numba_makers and isinstance(node.value, ast.Name)
                  and node.value.id == "numba"):
                found.append(f"{path.name}:{node.lineno} numba.{node.attr}")
    assert found == []
    assert len(_jit.DISPATCHERS) > 50
    assert {type(d) for d in _jit.DISPATCHERS} == {_jit.Kernel}


def test_the_decorator_compiles_at_once_once_numba_is_loaded_and_refuses_a_cache_choice():
    from mckibben import _jit, _kernels

    def twice(x):
        return 2.0 * x

    made = _kernels.kernel(error_model="numpy")(twice)
    assert isinstance(made, _jit.Kernel) and made.targetoptions["fastmath"] is False
    assert made(4.0) == 8.0 and made.py_func is twice
    with pytest.raises(TypeError, match="cache"):
        _kernels.kernel(cache=True)
    with pytest.raises(TypeError, match="func must be a function"):
        _kernels.kernel(np.sin)


def test_before_numba_is_loaded_the_decorator_marks_and_numba_compiles_the_marked_later(tmp_path):
    """In a fresh process: a cheap module's kernel is its plain function until ``_kernels.jit()``,
    then the same name in that module is the compiled dispatcher, with the same result."""
    code = textwrap.dedent("""
        import sys
        from mckibben import hardware as HW, _kernels
        plain = HW.adc_count
        assert "numba" not in sys.modules and type(plain).__name__ == "function", type(plain)
        assert plain.__mckibben_kernel__ is not None
        before = plain(0.3e6, 500.0, 100)
        jit = _kernels.jit()
        assert isinstance(HW.adc_count, jit.Kernel) and HW.adc_count.py_func is plain
        assert HW.adc_count(0.3e6, 500.0, 100) == before
        print("ok")
    """)
    env = _env(MCKIBBEN_BACKGROUND_WARM="0", MCKIBBEN_CACHE_DIR=str(tmp_path / "cache"))
    r = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0 and r.stdout.strip() == "ok", r.stderr[-2000:]


#: Compiles one chain from an empty cache (argv[1]: ``control`` = the controller core, its laws and
#: the firmware clamp; ``plant`` = the integrator, its stages and the law dispatch), then prints
#: every kernel's signatures. A constant passed from one kernel to another is typed as a literal,
#: one compilation per constant: ``clamp`` was compiled 7 times in a cold ``control step`` (issue #34).
_ONCE = (
    "import json, sys\n"
    "from mckibben import _kernels\n"
    "jit = _kernels.jit()\n"
    "from numba import types as T\n"
    "from mckibben.control import step\n"
    "from mckibben.plant import physics as ph\n"
    "i64, f64 = T.Array(T.int64, 1, 'C'), T.Array(T.float64, 1, 'C')\n"
    "if sys.argv[1] == 'control':\n"
    "    step.core_step.compile((i64, i64, T.int64, T.boolean, T.float64, i64))\n"
    "else:\n"
    "    ph.rk4_step.compile((T.int64, f64, T.int64, T.float64))\n"
    "print(json.dumps({f'{d.py_func.__module__}.{d.py_func.__qualname__}': [str(s) for s in d.overloads]\n"
    "                  for d in jit.DISPATCHERS if d.overloads}))\n"
)


@pytest.mark.parametrize("chain", ["control", pytest.param("plant", marks=pytest.mark.slow)])
def test_a_cold_chain_compiles_each_kernel_once(tmp_path, chain):
    """Each kernel of a chain compiled from an empty cache has one signature: constants reach callees typed, not as literals."""
    env = _env(MCKIBBEN_CACHE_DIR=str(tmp_path / "cache"), MCKIBBEN_BACKGROUND_WARM="0")
    r = subprocess.run([sys.executable, "-c", _ONCE, chain], env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    signatures = json.loads(r.stdout.strip().splitlines()[-1])
    callee = {"control": "mckibben.control.fixed.clamp", "plant": "mckibben.plant.physics.rhs"}[chain]
    assert callee in signatures  # the callee that was compiled several times is in the chain
    # rhs alone is compiled once per Runge-Kutta stage on purpose: with the stage's row offsets as
    # constants its lane loop vectorizes (typed, the integrator ran 3.7x slower; see rhs's comment)
    stages = signatures.pop("mckibben.plant.physics.rhs", [])
    assert len(stages) == (4 if chain == "plant" else 0)
    assert all("Literal[int]" in s for s in stages)
    assert {name: sigs for name, sigs in signatures.items() if len(sigs) > 1} == {}

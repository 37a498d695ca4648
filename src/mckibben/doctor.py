"""What this machine has for mckibben, and a warm-up that compiles every kernel once.

:func:`warm` runs each experiment a command reaches once, at its defaults (small enough to take
a fraction of a second each once compiled), so that every compiled kernel is in the per-user
cache (:mod:`mckibben._jit`) before a user's first real command. :func:`check` reports the cache
folder, the compiler's versions, the cores used and the optional parts (the AVR toolchain, the
simulator, the programmer, a Dask scheduler), with what to install when one is missing.
"""

from __future__ import annotations

import importlib.util
import os
import shutil
import socket
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from urllib.parse import urlparse

import numpy as np

from mckibben import __version__, _kernels, control, experiments, models, plant, tool
from mckibben.datasets import get_muscle
from mckibben.errors import InputError
from mckibben.models.laws import LAWS
from mckibben.models.laws._base import NTH, evaluate_points
from mckibben.rig import firmware as FW

#: The optional tools: name -> (what it is for, how to install it on Debian/Ubuntu).
TOOLS = {
    "avr-gcc": ("builds the firmware (mckibben firmware build)", "apt-get install gcc-avr avr-libc"),
    "simavr": ("counts the firmware's cycles (make -C firmware cycles)", "apt-get install simavr"),
    "libsimavr": ("runs the firmware image as the device (the avr engine of mckibben rig emulate)",
                  "apt-get install libsimavr-dev libelf-dev"),
    "avrdude": ("flashes the Arduino Mega (mckibben firmware flash)", "apt-get install avrdude"),
    "arduino-cli": ("an alternative way to build and flash the firmware", "see arduino.github.io/arduino-cli"),
}
#: The optional Python packages (the extras of pyproject.toml): name -> (what for, how to install).
PACKAGES = {
    "mujoco": ("the MuJoCo bridge (mckibben.export.mujoco; the tool's MuJoCo engine)", "pip install 'mckibben[mujoco]'"),
    "fmpy": ("exports and checks FMUs (mckibben export fmu)", "pip install 'mckibben[fmu]'"),
}


def _warm_steps() -> list[tuple[str, Callable[[], object]]]:
    """The experiments the commands run, each at a size that compiles every kernel it reaches."""
    muscle = get_muscle("mpam97")
    return [
        ("static models", lambda: (models.predict_length(muscle, 0.8e6, 0.6),  # every law of a catalogue muscle
                                   [models.force(0.5e6, 0.09, muscle, model=n) for n in models.force_laws()])),
        ("open loop", lambda: experiments.open_loop()),
        ("sliding-mode step", lambda: experiments.step_response("smc", law="paper", beta=150)),
        ("PID step", lambda: experiments.step_response("pid")),
        ("tracking", lambda: experiments.track_pressure(control.SineReference(0.4e6, 0.1e6, 2.0))),
        ("Fig. 13", lambda: experiments.fig13()),
        ("compare", lambda: experiments.compare()),
        ("robustness", lambda: experiments.robustness(4)),
        ("hysteresis", lambda: experiments.hysteresis_compensation()),
        ("the tool", lambda: experiments.track_tip(tool.parse_path("circle:radius=5mm,period=2s"))),
        ("live stepper", lambda: plant.PlantStepper().advance(100, 0)),
        ("a sweep's static start", lambda: plant.static_length(  # batches above SMALL_BATCH: the compiled bisection
            plant.PlantParams(load_force=np.full(plant.simulator.SMALL_BATCH + 1, 0.6)))),
        ("linear model", lambda: plant.linearize(pressure=0.4e6)),
        ("every force law", _every_law),
    ]


def _every_law() -> None:
    """Compile the per-law evaluation loop of every registered force law, not only the bundled sets'.

    A muscle file's law (``simulate --muscle-file``, ``control step --muscle-file``, ``predict
    force --muscle-file``, a tool of fitted muscles) runs through :func:`~mckibben.models.laws._base.evaluate_points`,
    whose loop is generated and compiled once per law; the bundled sets reach only their own.
    """
    p, ell, col = np.array([0.3e6]), np.array([0.09]), np.zeros(1, dtype=np.int64)
    for law in LAWS.values():
        try:
            evaluate_points(law.kernel, p, ell, np.ones(NTH), col, 1)
        except (ArithmeticError, IndexError, ValueError):  # placeholder parameters: the loop is compiled before it runs
            pass


def background_kernels() -> list[tuple[str, object, tuple]]:
    """The kernels a background warm-up compiles, in order, with the signatures the simulator's
    runner calls them with: the integrator (the longest, 6 s), its output stage and the firmware
    core's mirror. A test holds the signatures to the runner's (``tests/test_compile_cache.py``).

    Returns
    -------
    list of (str, dispatcher, tuple)
        Name, Numba dispatcher and argument types. [-]
    """
    from numba import types as T  # deferred on purpose: Numba

    C, ph = control.core, plant.physics

    f64, i64 = T.Array(T.float64, 1, "C"), T.Array(T.int64, 1, "C")
    return [
        ("integrator", ph.advance, (T.int64, f64, T.int64, T.float64, T.int64)),
        ("outputs", ph.outputs, (T.int64, f64, T.int64)),
        ("firmware core", C.core_kernel, (i64, i64, f64, f64, T.int64, T.int64, T.literal(True), T.float64)),
    ]


def background_warm(parent: int) -> None:
    """Compile the longest shared kernels into the cache while the process ``parent`` runs; stop when it ends.

    Started by :func:`mckibben._jit.start_background_warm` at a process's first compilation; compiles
    :func:`background_kernels`. Each
    kernel is compiled under its compile lock, so the parent, reaching it, waits and loads it
    instead of compiling it again.

    Parameters
    ----------
    parent : int
        The process id of the command that started it. [-]
    """
    import threading

    def watch():
        while True:
            try:
                os.kill(parent, 0)
            except OSError:
                os._exit(0)  # the command ended: so does its warm-up (a lock dies with the process)
            if os.getppid() != parent:
                os._exit(0)
            time.sleep(0.2)

    threading.Thread(target=watch, daemon=True).start()
    for _, dispatcher, signature in background_kernels():
        dispatcher.compile(signature)


@dataclass
class WarmResult:
    """What :func:`warm` did.

    Attributes
    ----------
    steps : list of dict
        Per experiment: ``name``, ``seconds`` (wall time), ``compiled`` (kernels compiled, not
        loaded from the cache) and ``loaded`` (kernels loaded from the cache).
    cache_dir : str or None
        The cache folder (None: kernels compiled in memory, not kept).
    """

    steps: list = field(default_factory=list)
    cache_dir: str | None = None

    @property
    def compiled(self) -> int:
        """Kernels compiled in all (0 on a warm cache). [-]"""
        return sum(s["compiled"] for s in self.steps)

    def to_dict(self) -> dict:
        return {"cache_dir": self.cache_dir, "compiled": self.compiled, "steps": self.steps}


def warm(progress: Callable[[int, int, str], None] | None = None) -> WarmResult:
    """Compile (or load) every kernel the commands reach, once.

    Parameters
    ----------
    progress : callable, optional
        ``progress(done, total, name)`` before each step and once at the end. [-]

    Returns
    -------
    WarmResult
        Per step: wall time and how many kernels were compiled or loaded.
    """
    if progress is not None and not callable(progress):
        raise InputError(f"progress: a callable progress(done, total, name), not a {type(progress).__name__}")
    steps = _warm_steps()
    _jit = _kernels.jit()  # loads Numba
    result = WarmResult(cache_dir=None if _jit.cache_dir() is None else str(_jit.cache_dir()))
    for i, (name, run) in enumerate(steps):
        if progress is not None:
            progress(i, len(steps), name)
        before = _jit.compile_stats()
        t0 = time.perf_counter()
        run()
        after = _jit.compile_stats()
        result.steps.append({"name": name, "seconds": time.perf_counter() - t0,
                             "compiled": after["compiled"] - before["compiled"],
                             "loaded": after["cache_hits"] - before["cache_hits"]})
    if progress is not None:
        progress(len(steps), len(steps), "done")
    return result


@dataclass
class Report:
    """The machine as mckibben sees it (:func:`check`).

    Attributes
    ----------
    version : str
        mckibben's version.
    cache_dir : str or None
        Where compiled kernels are cached (None: they cannot be; see ``cache_problem``).
    cache_problem : str or None
        Why they are not cached.
    cache_bytes : int
        Size of the cache folder. [bytes]
    numba, llvmlite : str
        Compiler versions.
    threads : int
        Threads a batch simulation uses (``numba.get_num_threads()``; ``NUMBA_NUM_THREADS``). [-]
    cores : int
        Cores of the machine. [-]
    tools : dict
        Optional tool (:data:`TOOLS`) -> ``{"found": path or None, "for": ..., "install": ...}``.
    scheduler : dict or None
        The Dask scheduler asked about: ``{"address": ..., "reachable": bool, "detail": ...}``.
    packages : dict
        Optional Python package (:data:`PACKAGES`) -> ``{"found": its file or None, "for": ...,
        "install": ...}``.
    """

    version: str
    cache_dir: str | None
    cache_problem: str | None
    cache_bytes: int
    numba: str
    llvmlite: str
    threads: int
    cores: int
    tools: dict
    scheduler: dict | None = None
    packages: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return dict(self.__dict__)

    @property
    def ok(self) -> bool:
        """True when the kernels are cached and a scheduler asked about answers."""
        return self.cache_dir is not None and (self.scheduler is None or self.scheduler["reachable"])


def _folder_bytes(path) -> int:
    total = 0
    for root, _dirs, files in os.walk(path):
        for f in files:
            try:
                total += os.path.getsize(os.path.join(root, f))
            except OSError:
                pass
    return total


def _scheduler_address(address) -> tuple[str, int] | None:
    """``(host, port)`` of a Dask scheduler address (None for None); else an InputError naming ``scheduler``."""
    if address is None:
        return None
    if not isinstance(address, str):
        raise InputError(f"scheduler: an address like tcp://127.0.0.1:8786, not a {type(address).__name__}")
    try:
        url = urlparse(address if "://" in address else f"tcp://{address}")
        port = url.port
    except ValueError:  # a port that is not a number, or out of range
        port = None
    if url.scheme not in ("tcp", "tls") or not url.hostname or port is None:
        raise InputError(f"scheduler: {address!r} is not a Dask scheduler address like tcp://127.0.0.1:8786")
    return url.hostname, port


def _probe_scheduler(address: str, timeout: float = 3.0) -> dict:
    host, port = _scheduler_address(address)
    try:
        with socket.create_connection((host, port), timeout=timeout):
            return {"address": address, "reachable": True, "detail": "accepts connections"}
    except OSError as exc:
        return {"address": address, "reachable": False,
                "detail": f"{exc.strerror or exc}; start one with: dask scheduler --port {port}"}


def _tool(name: str) -> str | None:
    """Where a tool is: an executable on the PATH, or libsimavr's headers (it is a library)."""
    if name == "libsimavr":
        try:
            return str(FW.simavr_include())
        except InputError:
            return None
    return shutil.which(name)


def check(scheduler: str | None = None) -> Report:
    """Report the kernel cache, the compiler, the cores used and the optional tools.

    Parameters
    ----------
    scheduler : str, optional
        A Dask scheduler address (``tcp://host:port``) to check for a connection. [-]

    Returns
    -------
    Report
    """
    _scheduler_address(scheduler)
    import llvmlite  # deferred on purpose: Numba's compiler (loaded with Numba just below)

    _jit = _kernels.jit()  # loads Numba
    numba = _jit.numba
    where = _jit.cache_dir()
    tools = {name: {"found": _tool(name), "for": what, "install": how} for name, (what, how) in TOOLS.items()}
    packages = {}
    for name, (what, how) in PACKAGES.items():  # found, not imported: MuJoCo alone takes a second to load
        spec = importlib.util.find_spec(name)
        packages[name] = {"found": None if spec is None else spec.origin, "for": what, "install": how}
    return Report(
        version=__version__, cache_dir=None if where is None else str(where), cache_problem=_jit.cache_problem(),
        cache_bytes=0 if where is None else _folder_bytes(where), numba=numba.__version__,
        llvmlite=llvmlite.__version__, threads=numba.get_num_threads(), cores=os.cpu_count() or 1, tools=tools,
        scheduler=None if scheduler is None else _probe_scheduler(scheduler), packages=packages)


def run(scheduler: str | None = None, *, warm_up: bool = True,
        progress: Callable[[int, int, str], None] | None = None) -> tuple[Report, WarmResult | None]:
    """What ``mckibben doctor`` does: check the arguments, warm the cache (optional), then report once.

    Parameters
    ----------
    scheduler : str, optional
        A Dask scheduler address (``tcp://host:port``) to check for a connection. [-]
    warm_up : bool, default True
        Compile (or load) every kernel first (:func:`warm`). [-]
    progress : callable, optional
        ``progress(done, total, name)`` of the warm-up. [-]

    Returns
    -------
    (Report, WarmResult or None)
        The machine after the warm-up (the cache's size included), and the warm-up's steps.
    """
    _scheduler_address(scheduler)  # a bad address is refused before a minute of compiling
    warmed = warm(progress) if warm_up else None
    return check(scheduler), warmed

"""Compiled kernels, compiled once per machine: where they are cached, and why a cache never breaks a command.

Every Numba function of the package is decorated with the one decorator
:func:`mckibben._kernels.kernel` (re-exported here: ``from mckibben._jit import kernel`` in a module
that loads Numba at import), which compiles through :func:`dispatcher`; never with ``numba.njit``
directly. Only Numba's public API is used (a test scans the package for private Numba attributes):

- **Where.** Each kernel caches on disk with Numba's own ``cache=True`` under Numba's
  ``config.CACHE_DIR`` set to :func:`cache_dir` while the dispatcher is made (:func:`_make`; put
  back after, so a user's own Numba functions are not moved): ``$MCKIBBEN_CACHE_DIR`` if set, else
  ``$NUMBA_CACHE_DIR/mckibben``, else the platform's user cache folder (``$XDG_CACHE_HOME`` or
  ``~/.cache`` on Linux, ``~/Library/Caches`` on macOS, ``%LOCALAPPDATA%`` on Windows)
  ``/mckibben``; below it ``<package version>/<fingerprint>``. Never inside the installed package.
- **Fresh.** The fingerprint (:func:`fingerprint`) is a hash of every source file of the package
  and of the Python, Numba and llvmlite versions. Numba stamps an entry with its own file only,
  but kernels inline functions and constants from other modules and Numba does not see those
  change (numba#1833): a folder per package content means a stale entry can never be read. A
  reinstall of the same sources finds its folder again; folders not used for
  :data:`PRUNE_AFTER_S` are removed when a new one is made.
- **No folder.** When no folder can be written (a system-wide install run by an account without a
  writable home), kernels compile in memory: one warning line, the command runs.
- **Never fatal.** A failure to read a cache entry (a truncated or damaged file) removes that
  kernel's entries and compiles it again; a failure to save one keeps the compiled code in memory;
  one warning either way (:meth:`Kernel.compile`).
- **Once across processes.** A process takes a lock on a kernel (``flock`` on a file beside its
  entries) from before it looks the kernel up in the cache to after it saved it; another process
  that needs the same kernel waits, then loads it (Dask workers, a second terminal, the background
  warm-up), instead of compiling it too.
- No cached function takes another compiled function as an argument: such a function cannot be
  cached (its argument type names a dispatcher of one process only), so the simulator's runner is
  generated once per controller kernel, with the kernel as a true global (:func:`module_for`).
- The first compilation of a process starts a background warm-up on the machine's other core
  (:func:`start_background_warm`): it compiles the integrator and the firmware core's mirror,
  the longest kernels every simulation needs, while the command compiles its own start, so a
  first command waits for about the longest of the two, not their sum.

See ``../shared/notes/numba-cache.md`` for the facts of Numba's cache this design rests on.
"""

from __future__ import annotations

import hashlib
import importlib.util
import inspect
import os
import shutil
import sys
import threading
import time
import types
import warnings
from pathlib import Path

import llvmlite
import numba
from numba.core import event as _event
from numba.core import sigutils
from numba.core.registry import CPUDispatcher

try:
    import fcntl as _fcntl
except ImportError:  # Windows: no compile lock
    _fcntl = None  # type: ignore[assignment]

from mckibben import _kernels
# the package's one decorator, re-exported for a module whose kernels compile as it is imported
from mckibben._kernels import kernel as kernel
from mckibben import compile_notice as _notice_module

PACKAGE_DIR = Path(__file__).resolve().parent
_ENV_DIR = "MCKIBBEN_CACHE_DIR"
#: A fingerprint folder unused for this long is removed when a new one is made. [s]
PRUNE_AFTER_S = 14 * 24 * 3600.0
_USED = ".last-used"

#: Every dispatcher made by :func:`dispatcher` in this process (the warm-up and the tests read them).
DISPATCHERS: list = []
_LOCK = threading.RLock()
_STATE: dict = {}


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("mckibben")
    except PackageNotFoundError:  # a source tree without installation
        return "0+unknown"


def _user_cache_base() -> Path:
    """The platform's per-user cache folder (not created here)."""
    if sys.platform == "win32":
        return Path(os.environ.get("LOCALAPPDATA") or Path.home() / "AppData" / "Local")
    if sys.platform == "darwin":
        return Path.home() / "Library" / "Caches"
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")


def _base() -> Path:
    """The folder holding one folder per version (what ``MCKIBBEN_CACHE_DIR`` names)."""
    if os.environ.get(_ENV_DIR):
        return Path(os.environ[_ENV_DIR]).expanduser()
    if os.environ.get("NUMBA_CACHE_DIR"):
        return Path(os.environ["NUMBA_CACHE_DIR"]).expanduser() / "mckibben"
    return _user_cache_base() / "mckibben"


def _candidate() -> Path:
    return _base() / _version() / fingerprint()[:16]


def _usable(path: Path) -> bool:
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe = path / f".probe-{os.getpid()}-{threading.get_ident()}"
        probe.write_bytes(b"")
        probe.unlink()
        return True
    except (OSError, RuntimeError):  # RuntimeError: Path.home() with no home at all
        return False


def _mark_used(path: Path) -> None:
    """Record that ``path`` is in use; when it is new, remove its sibling folders unused for :data:`PRUNE_AFTER_S`."""
    stamp = path / _USED
    new = not stamp.exists()
    try:
        stamp.touch()
    except OSError:
        return
    if not new:
        return
    now = time.time()
    for sibling in path.parent.iterdir():
        used = sibling / _USED
        try:
            old = sibling != path and used.exists() and now - used.stat().st_mtime > PRUNE_AFTER_S
        except OSError:
            continue
        if old:
            shutil.rmtree(sibling, ignore_errors=True)


def cache_dir() -> Path | None:
    """The folder the kernels are cached in, or None when none can be written (kernels compile in memory).

    Decided once per process; the reason for None is in :func:`cache_problem`.
    """
    with _LOCK:
        if "dir" not in _STATE:
            try:
                path = _candidate().resolve()
            except (OSError, RuntimeError) as exc:
                _STATE["dir"], _STATE["problem"] = None, f"no cache folder can be named ({exc})"
            else:
                ok = _usable(path)
                _STATE["dir"] = path if ok else None
                _STATE["problem"] = None if ok else (
                    f"cannot write the kernel cache folder {path}; kernels are compiled in memory for this "
                    f"process only (set {_ENV_DIR} to a writable folder to cache them)")
                if ok:
                    _mark_used(path)
        return _STATE["dir"]


def cache_problem() -> str | None:
    """Why kernels are not cached in this process (None when they are)."""
    cache_dir()
    return _STATE["problem"]


def fingerprint() -> str:
    """SHA-256 of every source file of the package (in path order) and of the Python, Numba and llvmlite versions.

    Names the cache folder: a kernel cached by other sources or another compiler is never read.
    """
    with _LOCK:
        if "fingerprint" not in _STATE:
            h = hashlib.sha256(f"{sys.version}|{numba.__version__}|{llvmlite.__version__}".encode())
            for f in sorted(PACKAGE_DIR.rglob("*.py")):
                h.update(str(f.relative_to(PACKAGE_DIR)).encode())
                h.update(f.read_bytes())
            _STATE["fingerprint"] = h.hexdigest()
        return _STATE["fingerprint"]


def _runner_dir() -> Path | None:
    base = cache_dir()
    return None if base is None else base / "runners"


def _ours(py_file: str) -> bool:
    path = Path(py_file).resolve()
    runners = _runner_dir()
    return path.is_relative_to(PACKAGE_DIR) or (runners is not None and path.is_relative_to(runners))


class _CompileLock:
    """An exclusive ``flock`` on a kernel's ``.lock`` file, held while this process loads or compiles it.

    The operating system drops it if the process dies. A process that finds it held waits (at
    most :data:`WAIT_S`), then looks the kernel up in the cache, where the holder saved it. Not on
    Windows (no ``fcntl``): there every process compiles for itself.
    """

    WAIT_S = 600.0
    _held: dict = {}  # lock path -> _CompileLock held by this process

    def __init__(self, path: str):
        self.path = path
        self.fd: int | None = None

    def acquire(self) -> bool:
        """Take the lock, waiting while another process holds it; True if it is held now."""
        if _fcntl is None or self.path in _CompileLock._held:  # none, or ours already (a recursive kernel)
            return False
        try:
            os.makedirs(os.path.dirname(self.path), exist_ok=True)
            self.fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError:
            return False  # a read-only cache folder: no lock, compile as before
        deadline = time.monotonic() + self.WAIT_S
        while True:
            try:
                _fcntl.flock(self.fd, _fcntl.LOCK_EX | _fcntl.LOCK_NB)
            except BlockingIOError:
                if time.monotonic() < deadline:
                    time.sleep(0.05)
                    continue
            except OSError:
                pass
            else:
                _CompileLock._held[self.path] = self
                return True
            os.close(self.fd)  # a stuck holder or a folder without locks: compile without it
            self.fd = None
            return False

    def release(self) -> None:
        if self.fd is not None:
            _CompileLock._held.pop(self.path, None)
            try:
                _fcntl.flock(self.fd, _fcntl.LOCK_UN)
            finally:
                os.close(self.fd)
                self.fd = None


def _cache_warning(message: str) -> None:
    with _LOCK:
        if _STATE.get("warned"):
            return
        _STATE["warned"] = True
    warnings.warn(message, RuntimeWarning, stacklevel=3)


class Kernel(CPUDispatcher):
    """Numba's CPU dispatcher, whose :meth:`compile` makes the disk cache safe to share and never fatal.

    Numba calls ``compile`` for every new signature: a call from Python, and a call from another
    compiled function while that one is typed. Only public members of the dispatcher are used:
    ``overloads``, ``stats`` and ``py_func``.
    """

    def compile(self, sig):
        """Load the overload for ``sig`` from the cache, or compile and save it, under the kernel's lock.

        Parameters
        ----------
        sig : numba signature or tuple of numba types
            The argument types. [-]

        Returns
        -------
        callable
            The compiled entry point (Numba's).
        """
        # Lookup, load or compilation run in a fresh stretch of Python's frame stack (_fresh_stack):
        # see _FRESH_STACK_SLOTS. The failure paths live in _after_failure.
        args = tuple(sigutils.normalize_signature(sig)[0])
        if args in self.overloads:  # compiled or loaded already in this process
            return super().compile(sig)
        entries = _entry_files(self)
        if entries is None:  # not cached on disk: compiled in memory
            return _fresh_stack(CPUDispatcher.compile, self, sig)
        lock = _CompileLock(str(entries[0] / f"{entries[1]}.lock"))
        held = lock.acquire()
        misses = sum(self.stats.cache_misses.values())
        try:
            return _fresh_stack(CPUDispatcher.compile, self, sig)
        except Exception as exc:  # noqa: BLE001 - a cache problem must not reach the run
            return _after_failure(self, sig, args, entries, misses, exc)
        finally:
            if held:
                lock.release()


#: Local variables of :func:`_fresh_stack`'s frame: 4200 slots of 8 bytes, just over 32 KiB. [-]
#:
#: CPython (3.11 on) keeps frames on a stack of chunks, 16 KiB each, and frees a chunk as soon as
#: its first frame returns. A loop whose calls cross a chunk's edge maps and unmaps a chunk on
#: every call. Numba compiles a kernel's callees from inside the kernel's own compilation, so
#: where its typing and lowering loops fall against those edges depends on every frame below
#: them: one frame more per nesting level (:meth:`Kernel.compile`) put the integrator's chain
#: (``rhs`` ×4, ``rk4_step``, ``advance``) on an edge, 85,000 mmap/munmap pairs and 1.5–3 s of
#: CPU in a cold ``control step`` where main's layer made 6,500 (benchmarks/RESULTS.md). A frame
#: this large does not fit in a 16 KiB chunk: Python gives it a 64 KiB one of its own, so each
#: compilation starts with about 30 KiB of stack before any edge (1,500 pairs for that chain),
#: whatever the depth it was called at. One 64 KiB chunk per kernel compiled or loaded.
_FRESH_STACK_SLOTS = 4200


def _fresh_stack_function(slots: int):
    """``run(f, a, b)`` = ``f(a, b)``, from a frame of ``slots`` local variables (generated: Python has no other way)."""
    names = " = ".join(f"_{i}" for i in range(slots))
    namespace: dict = {}
    exec(compile(f"def run(f, a, b, never=False):\n    if never:\n        {names} = None\n    return f(a, b)\n",  # noqa: S102 - ours
                 "<mckibben._jit._fresh_stack>", "exec"), namespace)
    return namespace["run"]


_fresh_stack = _fresh_stack_function(_FRESH_STACK_SLOTS)


def _entry_files(disp: Kernel) -> tuple[Path, str] | None:
    """The folder of a kernel's cache entries and the start of their names (as Numba names them), or None."""
    where = getattr(disp.stats, "cache_path", None)
    base = cache_dir()
    if not isinstance(where, str) or base is None or not Path(where).is_relative_to(base):
        return None
    func = disp.py_func
    name = f"{Path(inspect.getfile(func)).stem}.{func.__qualname__}".replace("<", "").replace(">", "")
    return Path(where), f"{name}-{func.__code__.co_firstlineno}.py"


def _after_failure(disp: Kernel, sig, args: tuple, entries: tuple[Path, str], misses: int, exc: Exception):
    """After Numba's compile (load, or compile and save) raised: neither a damaged entry nor a failed save is fatal.

    A failed save keeps the compiled code; an entry that could not be read is removed and the
    kernel compiled again; a failed compilation is the caller's error and is raised again.
    """
    done = disp.overloads.get(args)
    if done is not None:  # compiled and in memory: only the save failed
        _cache_warning(f"a compiled kernel could not be cached ({type(exc).__name__}: {exc})")
        return done.entry_point
    if sum(disp.stats.cache_misses.values()) != misses:
        raise exc  # the compilation itself failed: the caller's error, not the cache's
    _cache_warning(f"a cached kernel could not be read ({type(exc).__name__}: {exc}); compiling it")
    folder, stem = entries
    for f in folder.glob(f"{stem}*.nb[ic]"):
        f.unlink(missing_ok=True)
    return CPUDispatcher.compile(disp, sig)


def _make(func, cached: bool, options: dict):
    """A :class:`Kernel` for ``func`` with Numba's ``njit`` options; caching under :func:`cache_dir` when ``cached``.

    Numba has no public way to give one dispatcher its own cache folder: its cache reads
    ``numba.config.CACHE_DIR`` (``NUMBA_CACHE_DIR``) once, when ``enable_caching`` builds the
    dispatcher's cache, and keeps the path. So the folder is set there for that call and put back
    at once, under this module's lock (:data:`_LOCK`, re-entrant): no two of the package's
    dispatchers are made at the same time. A user's own ``numba.njit(cache=True)`` made by another
    thread during that instant would cache in the package's folder (harmless: it is a cache).
    Setting ``NUMBA_CACHE_DIR`` before Numba is imported is not an option: it would move every
    user function's cache for the whole process, and a user may have imported Numba first.
    """
    options = dict(options)
    locals_ = options.pop("locals", {})
    options["nopython"] = True
    options.setdefault("boundscheck", None)
    disp = Kernel(py_func=func, locals=locals_, targetoptions=options)
    if cached:
        with _LOCK:
            previous = numba.config.CACHE_DIR
            numba.config.CACHE_DIR = str(cache_dir() / "numba")  # type: ignore[operator]
            try:
                disp.enable_caching()
            finally:
                numba.config.CACHE_DIR = previous
    return disp


def dispatcher(func, options: dict):
    """The compiled kernel of ``func``: cached in :func:`cache_dir`, or compiled in memory when it cannot be.

    What :func:`mckibben._kernels.kernel`, the package's one decorator, calls once Numba is loaded.

    Parameters
    ----------
    func : function
        The plain Python function. [-]
    options : dict
        Numba's ``njit`` options (``cache`` is decided here and may not be given; ``fastmath``
        is ``False`` unless given). [-]

    Returns
    -------
    Kernel or function
        The dispatcher (the function itself with ``NUMBA_DISABLE_JIT=1``).
    """
    if "cache" in options:
        raise TypeError("mckibben._kernels.kernel decides caching itself; do not pass cache=")
    # Explicit, never inherited: Numba compiles a callee that leaves ``fastmath`` unset with the
    # flags of the caller that compiles it first. ``law_force`` compiled from the integrator (whose
    # stages contract a·b + c into one FMA) then differed from ``law_force`` compiled from the
    # output stage, so the plant's last bits depended on which command had filled the cache.
    options = {"fastmath": False, **options}
    if numba.config.DISABLE_JIT:
        return func
    if not inspect.isfunction(func):
        raise TypeError(f"kernel: func must be a function, got {type(func).__name__}")
    with _LOCK:
        try:
            source = inspect.getsourcefile(func)
        except TypeError:
            source = None
        cached = cache_dir() is not None and source is not None and os.path.exists(source) and _ours(source)
        disp = _make(func, cached, options)
        DISPATCHERS.append(disp)
    return disp


# --- generated modules: one compiled runner per controller kernel ---------------------------------


def kernel_reference(kernel) -> tuple[str, str] | None:
    """``(module, qualname)`` by which a compiled kernel can be imported again, or None.

    None for a kernel defined in ``__main__``, in a notebook cell or inside a function: such a
    kernel cannot be named by a cached module, and its runner is compiled in memory.
    """
    py_func = getattr(kernel, "py_func", None)
    if py_func is None:
        return None
    module, qualname = py_func.__module__, py_func.__qualname__
    if module in (None, "__main__") or "<" in qualname or "." in qualname:
        return None
    mod = sys.modules.get(module)
    if mod is None or getattr(mod, qualname, None) is not kernel or getattr(mod, "__file__", None) is None:
        return None
    return module, qualname


def module_for(template, kernel_name: str, kernel) -> object:
    """The module of ``template``'s source with the global ``kernel_name`` bound to ``kernel``.

    ``template`` is a module whose functions refer to a compiled kernel by a global name, bound
    to a placeholder by a line that ends with ``# kernel-import``. For an importable kernel, that
    line is replaced by an import of the kernel, the source is written once to the cache folder
    and imported from there, so its functions are cached like any other (their stamp includes the
    kernel module's source, written into the generated file). Otherwise (a kernel defined in
    ``__main__``, or no writable cache) the template's functions are compiled in memory, with the
    kernel set as their global.

    Parameters
    ----------
    template : module
        The template module (its file is read; it is not modified).
    kernel_name : str
        The global name the template's functions call. [-]
    kernel : numba dispatcher
        The kernel to bind. [-]

    Returns
    -------
    module
        A module object whose compiled functions call ``kernel``.
    """
    with _LOCK:
        key = (template.__name__, kernel_name, id(kernel))
        found = _STATE.setdefault("modules", {}).get(key)
        if found is not None and found[0] is kernel:
            return found[1]
        ref = kernel_reference(kernel)
        runners = _runner_dir()
        module = None
        if ref is not None and runners is not None and not numba.config.DISABLE_JIT:
            module = _generated(template, kernel_name, ref, runners)
        if module is None:
            module = _in_memory(template, kernel_name, kernel)
        _STATE["modules"][key] = (kernel, module)
        return module


def _generated(template, kernel_name: str, ref: tuple[str, str], runners: Path):
    source = Path(template.__file__).read_text()
    lines = source.splitlines(keepends=True)
    marked = [i for i, line in enumerate(lines) if line.rstrip().endswith("# kernel-import")]
    if len(marked) != 1:
        raise RuntimeError(f"{template.__name__}: want one line ending with '# kernel-import', found {len(marked)}")
    module_name, qualname = ref
    kernel_file = Path(sys.modules[module_name].__file__)
    kernel_hash = hashlib.sha256(kernel_file.read_bytes()).hexdigest()
    lines[marked[0]] = f"from {module_name} import {qualname} as {kernel_name}  # generated\n"
    header = (f"# Generated by mckibben._jit from {template.__name__} for the kernel {module_name}.{qualname}.\n"
              f"# Kernel source sha256 {kernel_hash}. Do not edit: it is rewritten when either changes.\n")
    text = header + "".join(lines)
    stem = f"{template.__name__.rsplit('.', 1)[-1]}__{module_name.replace('.', '_')}__{qualname}"
    return _import_written(stem, text, runners)


def _import_written(stem: str, text: str, runners: Path):
    """Write ``text`` as ``<runners>/<stem>.py`` (unless it is there already) and import it; None if it cannot be written."""
    digest = hashlib.sha256(text.encode()).hexdigest()[:16]
    path = runners / f"{stem}.py"
    try:
        runners.mkdir(parents=True, exist_ok=True)
        if not path.exists() or path.read_text() != text:
            tmp = path.with_name(f"{path.name}.{os.getpid()}.{threading.get_ident()}.tmp")
            tmp.write_text(text)
            os.replace(tmp, path)
    except OSError as exc:
        _cache_warning(f"cannot write a generated runner in {runners} ({exc}); compiling it in memory")
        return None
    name = f"mckibben._generated.{stem}_{digest}"
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[name]
        raise
    return module


def generated_module(stem: str, text: str) -> object:
    """A module of generated source, cached like every kernel: written once into the cache folder.

    For code generated from data of the package (the plant's law dispatch, one branch per
    registered law): its functions are made with :func:`kernel`, so, written to the per-user folder
    (``runners/<stem>.py``) and imported from there, they are cached and stamped like any other.
    Without a writable cache (or with ``NUMBA_DISABLE_JIT``), the source is executed in memory and
    its functions compile for this process only.

    Parameters
    ----------
    stem : str
        The generated file's name, without ``.py`` (one per kind of generated code). [-]
    text : str
        Python source; it makes its compiled functions with ``mckibben._jit.kernel``, imported by
        a line ending with ``# kernel-decorator`` (in memory, that line binds an uncached
        ``kernel``). [-]

    Returns
    -------
    module
        The imported (or executed) module.
    """
    with _LOCK:
        key = ("generated", stem, hashlib.sha256(text.encode()).hexdigest())
        found = _STATE.setdefault("modules", {}).get(key)
        if found is not None:
            return found[1]
        runners = _runner_dir()
        module = None
        if runners is not None and not numba.config.DISABLE_JIT:
            # the digest in the name: another source tree sharing the folder (other laws) writes
            # another file, never this one under a compiling process
            module = _import_written(f"{stem}_{key[2][:16]}", text, runners)
        if module is None:
            module = types.ModuleType(f"mckibben._generated.{stem}")
            module.__dict__["_memory_kernel"] = _memory_kernel
            lines = [("kernel = _memory_kernel\n" if line.rstrip().endswith("# kernel-decorator") else line)
                     for line in text.splitlines(keepends=True)]
            exec(compile("".join(lines), f"<generated {stem}>", "exec"), module.__dict__)  # noqa: S102 - ours
        _STATE["modules"][key] = (None, module)
        return module


def _memory_kernel(func=None, /, **options):
    """:func:`kernel` without a disk cache (generated source executed in memory has no file)."""
    options = {"fastmath": False, **options}

    def wrap(f):
        if numba.config.DISABLE_JIT:
            return f
        with _LOCK:
            disp = _make(f, False, options)
            DISPATCHERS.append(disp)
        return disp

    return wrap if func is None else wrap(func)


def _in_memory(template, kernel_name: str, kernel):
    """The template's functions compiled in memory (no disk cache) with ``kernel_name`` bound to ``kernel``."""
    module = types.ModuleType(f"{template.__name__}[{getattr(kernel, '__name__', 'kernel')}]")
    namespace = dict(vars(template))
    namespace[kernel_name] = kernel
    module.__dict__.update(namespace)
    for name, value in vars(template).items():
        if name == kernel_name:  # bound above (the template binds it to a placeholder kernel)
            continue
        py_func = getattr(value, "py_func", value)  # a plain function with NUMBA_DISABLE_JIT=1
        if not isinstance(py_func, types.FunctionType) or py_func.__module__ != template.__name__:
            continue
        clone = types.FunctionType(py_func.__code__, module.__dict__, name, py_func.__defaults__, py_func.__closure__)
        clone.__qualname__ = py_func.__qualname__
        options = getattr(value, "targetoptions", None)
        if options is not None:
            options = {k: v for k, v in options.items() if k not in ("nopython", "cache", "boundscheck")}
        module.__dict__[name] = clone if options is None else _make(clone, False, options)
        if options is not None:
            DISPATCHERS.append(module.__dict__[name])
    return module


# --- telling a user that compilation is happening -------------------------------------------------


class _FirstCompile(_event.Listener):
    def __init__(self, callback):
        self.callback = callback
        self.done = False

    def on_start(self, event):
        if self.done:
            return
        disp = event.data.get("dispatcher") if isinstance(event.data, dict) else None
        py_func = getattr(disp, "py_func", None)
        path = inspect.getsourcefile(py_func) if py_func is not None else None
        if path is not None and _ours(path):
            self.done = True
            self.callback()

    def on_end(self, event):
        pass


def on_first_compile(callback) -> None:
    """Call ``callback()`` once, when this process first compiles one of the package's kernels.

    Parameters
    ----------
    callback : callable
        Called with no argument, before the compilation. [-]
    """
    _event.register("numba:compile", _FirstCompile(callback))


def _notice() -> None:
    """At the first compilation: warn that nothing will be kept (no cache), or say once that it is being kept."""
    where = cache_dir()
    if where is None:
        _cache_warning(cache_problem() or "kernels are compiled in memory")
        return
    if not _notice_module.shown():
        return
    if _notice_module.in_notebook():  # progress follows on the same line: one dot per kernel (_Progress)
        sys.stderr.write(f"mckibben: compiling kernels once for this machine (up to a minute; later runs and kernels "
                         f"load them from {where}) ")
        _event.register("numba:compile", _Progress())
    else:
        sys.stderr.write(f"mckibben: compiling kernels once for this machine (up to a minute); later runs load them "
                         f"from {where}\n")
    sys.stderr.flush()


class _Progress(_event.Listener):
    """In a notebook: a dot on stderr as each of the package's kernels is compiled, after the notice."""

    def on_start(self, event):
        disp = event.data.get("dispatcher") if isinstance(event.data, dict) else None
        py_func = getattr(disp, "py_func", None)
        path = inspect.getsourcefile(py_func) if py_func is not None else None
        if path is not None and _ours(path):
            sys.stderr.write(".")
            sys.stderr.flush()

    def on_end(self, event):
        pass


on_first_compile(_notice)

#: Environment switch of the background warm-up: ``0`` turns it off (the test suite does, but for
#: its own test); the warm-up process itself runs with ``warming``.
BACKGROUND_ENV = "MCKIBBEN_BACKGROUND_WARM"


def start_background_warm() -> object | None:
    """Compile the longest shared kernels in a second process, beside this one's own compilation.

    Started at the first compilation of a process whose kernels are cached on disk, on a machine
    with more than one core, unless ``MCKIBBEN_BACKGROUND_WARM=0``. The process
    (:func:`mckibben.doctor.background_warm`) takes each kernel's compile lock before compiling
    it; this process, reaching that kernel, waits and loads it. It ends with this process.

    Returns
    -------
    subprocess.Popen or None
        The process, or None when none was started.
    """
    import subprocess

    if (os.environ.get(BACKGROUND_ENV, "1") in ("0", "warming") or cache_dir() is None or _fcntl is None
            or (os.cpu_count() or 1) < 2 or numba.config.DISABLE_JIT):
        return None
    env = {**os.environ, BACKGROUND_ENV: "warming", _ENV_DIR: str(cache_dir().parent.parent)}  # type: ignore[union-attr]
    try:
        return subprocess.Popen([sys.executable, "-c", "from mckibben.doctor import background_warm; "
                                 f"background_warm({os.getpid()})"],
                                stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                env=env, start_new_session=True)
    except OSError:
        return None


on_first_compile(lambda: _STATE.setdefault("background", start_background_warm()))


def compile_stats() -> dict[str, int]:
    """Cache hits and compilations of the package's kernels in this process (Numba's dispatcher stats)."""
    hits = misses = 0
    for disp in DISPATCHERS:
        stats = disp.stats
        hits += sum(stats.cache_hits.values())
        misses += sum(stats.cache_misses.values())
    return {"cache_hits": hits, "compiled": misses}


# --- kernels written as plain Python until Numba is loaded (mckibben._kernels) --------------------


_COMPILED: dict = {}  # id(plain function) -> (plain function, dispatcher)


def _is_plain(value) -> bool:
    return isinstance(value, types.FunctionType)  # a dispatcher forwards attributes to its py_func


def compile_marked() -> None:
    """Compile every function marked by :func:`mckibben._kernels.kernel`, in place.

    Each registered module's own marked functions get their dispatchers; then every name of a
    registered module bound to a marked function, its own or another's (``from m import f``), is
    bound to that dispatcher.
    """
    with _LOCK:
        for mod in _kernels.modules():
            for value in list(vars(mod).values()):
                options = getattr(value, "__mckibben_kernel__", None) if _is_plain(value) else None
                if options is not None and value.__module__ == mod.__name__ and id(value) not in _COMPILED:
                    _COMPILED[id(value)] = (value, dispatcher(value, options))
        for mod in _kernels.modules():
            for name, value in list(vars(mod).items()):
                if _is_plain(value) and id(value) in _COMPILED:
                    setattr(mod, name, _COMPILED[id(value)][1])


_kernels.use_compiler(dispatcher)  # from now on the decorator compiles at once
compile_marked()

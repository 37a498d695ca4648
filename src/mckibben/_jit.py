"""Compiled kernels, compiled once per machine: where they are cached, and why a cache never breaks a command.

Every Numba function of the package is made with :func:`njit` from here, never with
``numba.njit`` directly. It caches on disk in a per-user folder (:func:`cache_dir`), never inside
the installed package:

- ``$MCKIBBEN_CACHE_DIR`` if set, else ``$NUMBA_CACHE_DIR/mckibben``, else the platform's user
  cache folder (``$XDG_CACHE_HOME`` or ``~/.cache`` on Linux, ``~/Library/Caches`` on macOS,
  ``%LOCALAPPDATA%`` on Windows) ``/mckibben``; below it one folder per package version.
- A cached kernel is fresh while the *package's* sources are unchanged: the stamp Numba keeps in
  each index is a hash of every source file of the package (:func:`fingerprint`), not of the
  kernel's own file only, because kernels inline functions and constants from other modules and
  Numba does not see those change (numba#1833). Content hashes, not times: a reinstall of the same
  version keeps its cache; an edit anywhere invalidates it, and the next compilation overwrites the
  stale entries in place (the folder does not grow).
- When no folder can be written (a system-wide install run by an account without a writable
  home), kernels compile in memory: one warning line, the command runs.
- A failure to read or write a cache entry (a foreign, truncated or concurrently replaced file) is
  never fatal: the entry is compiled in memory instead, with one warning.
- No cached function takes another compiled function as an argument: such a function cannot be
  cached (its argument type names a dispatcher of one process only), so the simulator's runner is
  generated once per controller kernel, with the kernel as a true global (:func:`module_for`).
- One process compiles a kernel at a time: a process that finds a kernel missing takes a lock on
  its index (``flock``) while it compiles; another process that needs the same kernel waits and
  loads it (Dask workers, a second terminal, the background warm-up), instead of compiling it too.
- The first compilation of a process starts a background warm-up on the machine's other core
  (:func:`start_background_warm`): it compiles the integrator and the firmware core's mirror,
  the longest kernels every simulation needs, while the command compiles its own start, so a
  first command waits for about the longest of the two, not their sum.

See ``../shared/notes/numba-cache.md`` for the facts of Numba's cache this design rests on.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.util
import inspect
import os
import sys
import threading
import types
import warnings
from pathlib import Path

import numba
from numba.core import caching

try:
    import fcntl as _fcntl
except ImportError:  # Windows: no compile lock
    _fcntl = None  # type: ignore[assignment]
from numba.core import event as _event

from mckibben import _kernels
from mckibben import compile_notice as _notice_module

PACKAGE_DIR = Path(__file__).resolve().parent
_ENV_DIR = "MCKIBBEN_CACHE_DIR"

#: Every dispatcher made by :func:`njit` in this process (the warm-up and the tests read them).
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


def _candidate() -> Path:
    if os.environ.get(_ENV_DIR):
        return Path(os.environ[_ENV_DIR]).expanduser() / _version()
    if os.environ.get("NUMBA_CACHE_DIR"):
        return Path(os.environ["NUMBA_CACHE_DIR"]).expanduser() / "mckibben" / _version()
    return _user_cache_base() / "mckibben" / _version()


def _usable(path: Path) -> bool:
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe = path / f".probe-{os.getpid()}-{threading.get_ident()}"
        probe.write_bytes(b"")
        probe.unlink()
        return True
    except (OSError, RuntimeError):  # RuntimeError: Path.home() with no home at all
        return False


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
        return _STATE["dir"]


def cache_problem() -> str | None:
    """Why kernels are not cached in this process (None when they are)."""
    cache_dir()
    return _STATE["problem"]


def fingerprint() -> str:
    """SHA-256 of every source file of the package, in path order: the stamp of every cached kernel."""
    with _LOCK:
        if "fingerprint" not in _STATE:
            h = hashlib.sha256()
            for f in sorted(PACKAGE_DIR.rglob("*.py")):
                h.update(str(f.relative_to(PACKAGE_DIR)).encode())
                h.update(f.read_bytes())
            _STATE["fingerprint"] = h.hexdigest()
        return _STATE["fingerprint"]


@functools.lru_cache(maxsize=None)
def _file_hash(path: str, mtime_ns: int, size: int) -> str:
    """SHA-256 of a source file, read once per version of it (one stamp per function of the file)."""
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def _runner_dir() -> Path | None:
    base = cache_dir()
    return None if base is None else base / "runners"


def _ours(py_file: str) -> bool:
    path = Path(py_file).resolve()
    runners = _runner_dir()
    return path.is_relative_to(PACKAGE_DIR) or (runners is not None and path.is_relative_to(runners))


class _Locator(caching._CacheLocator):
    """Numba cache locator for the package's functions: the per-user folder, the package's stamp."""

    def __init__(self, py_func, py_file):
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno
        base = cache_dir()
        assert base is not None  # from_function checked it
        self._cache_path = str(base / "numba" / self.get_suitable_cache_subpath(py_file))

    def ensure_cache_path(self):
        os.makedirs(self._cache_path, exist_ok=True)

    def get_cache_path(self):
        return self._cache_path

    def get_source_stamp(self):
        # the package's sources and the function's own file (a generated runner is not in the package)
        st = os.stat(self._py_file)
        return (fingerprint(), _file_hash(self._py_file, st.st_mtime_ns, st.st_size))

    def get_disambiguator(self):
        return str(self._lineno)

    @classmethod
    def from_function(cls, py_func, py_file):
        if cache_dir() is None or not os.path.exists(py_file) or not _ours(py_file):
            return None
        self = cls(py_func, py_file)
        try:
            self.ensure_cache_path()
        except OSError:
            return None
        return self


def _install_locator() -> None:
    impl = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl")
    if _Locator not in impl._locator_classes:
        impl._locator_classes.insert(0, _Locator)


class _SafeCache(caching.FunctionCache):
    """Numba's function cache, where a failure to load or save an entry compiles in memory instead,
    and where a kernel another process is compiling is waited for and loaded (:class:`_CompileLock`)."""

    def _load(self, sig, target_context):
        try:
            return super().load_overload(sig, target_context)
        except Exception as exc:  # noqa: BLE001 - a foreign/truncated entry: compile instead
            _cache_warning(f"a cached kernel could not be read ({type(exc).__name__}: {exc}); compiling it")
            return None

    def load_overload(self, sig, target_context):
        found = self._load(sig, target_context)
        if found is not None:
            return found
        lock = _CompileLock.of(self)
        if lock is not None and lock.acquire():  # another process held it: it may have saved the kernel
            found = self._load(sig, target_context)
            if found is not None:
                lock.release()
        return found  # None: this process compiles, holding the lock until save_overload

    def save_overload(self, sig, data):
        try:
            super().save_overload(sig, data)
        except Exception as exc:  # noqa: BLE001 - the compiled code is in memory; only the save failed
            _cache_warning(f"a compiled kernel could not be cached ({type(exc).__name__}: {exc})")
        finally:
            lock = _CompileLock.held(self)
            if lock is not None:
                lock.release()


class _CompileLock:
    """An exclusive ``flock`` on ``<kernel index>.lock`` while this process compiles that kernel.

    Held from the cache miss to the save (or to a failed compilation, see :class:`_LockRelease`);
    the operating system drops it if the process dies. A process that finds it held waits (at most
    :data:`WAIT_S`), then loads what the holder saved. Not on Windows (no ``fcntl``): there every
    process compiles for itself, as before.
    """

    WAIT_S = 600.0
    _held: dict = {}  # lock path -> _CompileLock held by this process

    def __init__(self, path: str):
        self.path = path
        self.fd: int | None = None

    @classmethod
    def of(cls, cache) -> "_CompileLock | None":
        if _fcntl is None:
            return None
        path = cls._path(cache)
        if path is None or path in cls._held:  # already ours (a nested compile of the same kernel)
            return None
        return cls(path)

    @classmethod
    def held(cls, cache) -> "_CompileLock | None":
        path = cls._path(cache)
        return cls._held.get(path) if path is not None else None

    @staticmethod
    def _path(cache) -> str | None:
        index = getattr(getattr(cache, "_cache_file", None), "_index_path", None)
        return f"{index}.lock" if index else None

    def acquire(self) -> bool:
        """Take the lock, waiting while another process holds it; True if it had to wait."""
        try:
            self.fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError:
            return False  # a read-only cache folder: no lock, compile as before
        waited = False
        deadline = None
        while True:
            try:
                _fcntl.flock(self.fd, _fcntl.LOCK_EX | _fcntl.LOCK_NB)
                break
            except BlockingIOError:
                import time

                deadline = deadline or time.monotonic() + self.WAIT_S
                if time.monotonic() > deadline:  # a stuck holder: compile anyway
                    os.close(self.fd)
                    self.fd = None
                    return waited
                waited = True
                time.sleep(0.05)
            except OSError:
                os.close(self.fd)
                self.fd = None
                return False
        _CompileLock._held[self.path] = self
        return waited

    def release(self) -> None:
        if self.fd is not None:
            _CompileLock._held.pop(self.path, None)
            try:
                _fcntl.flock(self.fd, _fcntl.LOCK_UN)
            finally:
                os.close(self.fd)
                self.fd = None


class _LockRelease(_event.Listener):
    """Drop a kernel's compile lock when its compilation fails (no save follows then)."""

    def on_start(self, event):
        pass

    def on_end(self, event):
        # numba's Event.is_failed reads the wrong way round (True when no exception): read the details
        if getattr(event, "_exc_details", None) is None:
            return
        disp = event.data.get("dispatcher") if isinstance(event.data, dict) else None
        lock = _CompileLock.held(getattr(disp, "_cache", None)) if disp is not None else None
        if lock is not None:
            lock.release()


_event.register("numba:compile", _LockRelease())


def _cache_warning(message: str) -> None:
    with _LOCK:
        if _STATE.get("warned"):
            return
        _STATE["warned"] = True
    warnings.warn(message, RuntimeWarning, stacklevel=3)


def njit(*args, **options):
    """``numba.njit`` for the package: cached in :func:`cache_dir`, or compiled in memory when it cannot be.

    Takes Numba's options (``cache`` is decided here and may not be given). Use as ``@njit`` or
    ``@njit(error_model="numpy", ...)``.
    """
    if "cache" in options:
        raise TypeError("mckibben._jit.njit decides caching itself; do not pass cache=")
    # Explicit, never inherited: Numba compiles a callee that leaves ``fastmath`` unset with the
    # flags of the caller that compiles it first. ``law_force`` compiled from the integrator (whose
    # stages contract a·b + c into one FMA) then differed from ``law_force`` compiled from the
    # output stage, so the plant's last bits depended on which command had filled the cache.
    options.setdefault("fastmath", False)

    def wrap(func):
        with _LOCK:
            cached = cache_dir() is not None
            if cached:
                _install_locator()
            disp = numba.njit(cache=cached, **options)(func)
            if cached and hasattr(disp, "_cache"):  # not with NUMBA_DISABLE_JIT=1 (a plain function)
                disp._cache.__class__ = _SafeCache
            DISPATCHERS.append(disp)
        return disp

    if args and callable(args[0]):
        return wrap(args[0])
    return wrap


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
    registered law): its functions are made with :func:`njit`, so, written to the per-user folder
    (``runners/<stem>.py``) and imported from there, they are cached and stamped like any other.
    Without a writable cache (or with ``NUMBA_DISABLE_JIT``), the source is executed in memory and
    its functions compile for this process only.

    Parameters
    ----------
    stem : str
        The generated file's name, without ``.py`` (one per kind of generated code). [-]
    text : str
        Python source; it makes its compiled functions with ``mckibben._jit.njit``, imported by a
        line ending with ``# njit-import`` (in memory, that line binds an uncached ``njit``). [-]

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
            module.__dict__["_memory_njit"] = _memory_njit
            lines = [("njit = _memory_njit\n" if line.rstrip().endswith("# njit-import") else line)
                     for line in text.splitlines(keepends=True)]
            exec(compile("".join(lines), f"<generated {stem}>", "exec"), module.__dict__)  # noqa: S102 - ours
        _STATE["modules"][key] = (None, module)
        return module


def _memory_njit(*args, **options):
    """:func:`njit` without a disk cache (generated source executed in memory has no file)."""
    options.setdefault("fastmath", False)

    def wrap(func):
        with _LOCK:
            disp = numba.njit(cache=False, **options)(func)
            DISPATCHERS.append(disp)
        return disp

    if args and callable(args[0]):
        return wrap(args[0])
    return wrap


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
        module.__dict__[name] = clone if options is None else numba.njit(cache=False, **options)(clone)
        if options is not None:
            DISPATCHERS.append(module.__dict__[name])
    return module


# --- telling a user that compilation is happening -------------------------------------------------


class _FirstCompile(_event.Listener):
    def __init__(self, callback):
        self._callback = callback
        self._done = False

    def on_start(self, event):
        if self._done:
            return
        disp = event.data.get("dispatcher") if isinstance(event.data, dict) else None
        py_func = getattr(disp, "py_func", None)
        path = inspect.getsourcefile(py_func) if py_func is not None else None
        if path is not None and _ours(path):
            self._done = True
            self._callback()

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
    if not _notice_module.enabled:
        return
    sys.stderr.write(f"mckibben: compiling kernels once for this machine (up to a minute); later runs load them "
                     f"from {where}\n")
    sys.stderr.flush()


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
    env = {**os.environ, BACKGROUND_ENV: "warming", _ENV_DIR: str(cache_dir().parent)}
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
                    _COMPILED[id(value)] = (value, njit(**options)(value))
        for mod in _kernels.modules():
            for name, value in list(vars(mod).items()):
                if _is_plain(value) and id(value) in _COMPILED:
                    setattr(mod, name, _COMPILED[id(value)][1])


compile_marked()

"""Drop Numba's on-disk caches when the sources they were compiled from have changed.

Numba keys a cached function by its own file's modification time only. The hot loops inline
functions and constants from other modules (the plant's parameter columns, the controller
core), so an edit there leaves a stale cache that silently runs the old code — wrong numbers, no
error. This module keeps a fingerprint of every source the cached functions are built from and
removes the package's ``*.nbi``/``*.nbc`` files when it changes. An installed (non-editable)
package is rewritten whole on upgrade and is not affected; a source checkout is.

Only the caches beside the sources (``__pycache__``, Numba's default) are handled: with
``NUMBA_CACHE_DIR`` set the check stands aside and writes no stamp. A process that imported the
package before an edit and compiles after it (a long-lived Jupyter kernel) can still write a
stale cache; restart such processes after editing the plant or the controller core.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

#: Subpackages whose modules hold or feed ``@njit(cache=True)`` functions.
CACHED_SUBPACKAGES = ("plant", "control", "models")
#: Top-level modules that hold or feed them.
CACHED_MODULES = ("hardware.py",)
STAMP = "numba-sources.sha256"


def fingerprint(package_dir: Path) -> str:
    """SHA-256 of the sources of :data:`CACHED_SUBPACKAGES`, in path order.

    Parameters
    ----------
    package_dir : pathlib.Path
        The ``mckibben`` package folder. [-]
    """
    h = hashlib.sha256()
    for sub in CACHED_SUBPACKAGES:
        for f in sorted((package_dir / sub).rglob("*.py")):  # subpackages too (models/laws/)
            h.update(str(f.relative_to(package_dir)).encode())
            h.update(f.read_bytes())
    for name in CACHED_MODULES:
        f = package_dir / name
        h.update(name.encode())
        h.update(f.read_bytes() if f.exists() else b"")
    return h.hexdigest()


def drop_stale(package_dir: Path) -> bool:
    """Remove the cached compilations under ``package_dir`` if the sources changed since they were made.

    Never raises: a read-only installation simply keeps its caches (it cannot have been edited
    in place either).

    Parameters
    ----------
    package_dir : pathlib.Path
        The ``mckibben`` package folder. [-]

    Returns
    -------
    bool
        True when caches were dropped.
    """
    if os.environ.get("NUMBA_CACHE_DIR"):
        return False
    try:
        stamp = package_dir / "__pycache__" / STAMP
        now = fingerprint(package_dir)
        if stamp.exists() and stamp.read_text() == now:
            return False
        dropped = False
        for sub in CACHED_SUBPACKAGES:
            for f in (package_dir / sub).rglob("__pycache__/*.nb[ic]"):
                f.unlink(missing_ok=True)
                dropped = True
        for name in CACHED_MODULES:
            for f in (package_dir / "__pycache__").glob(f"{Path(name).stem}.*.nb[ic]"):
                f.unlink(missing_ok=True)
                dropped = True
        stamp.parent.mkdir(exist_ok=True)
        tmp = stamp.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(now)
        tmp.replace(stamp)
        return dropped
    except (OSError, ValueError):  # unwritable, missing, or a garbled stamp (UnicodeDecodeError)
        return False

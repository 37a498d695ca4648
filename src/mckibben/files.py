"""Files and folders the library writes: created with the user's umask, replaced atomically.

Temporary files from :func:`tempfile.mkstemp` are mode 0600 and folders from
:func:`tempfile.mkdtemp` 0700, whatever the umask; a result renamed into place from them would
keep those modes. :func:`apply_umask` gives them the mode a plain ``open(path, "w")`` or
``mkdir`` would have (0644 and 0755 under umask 022).
"""

from __future__ import annotations

import os
import threading

__all__ = ["current_umask", "apply_umask"]

_LOCK = threading.Lock()


def current_umask() -> int:
    """The process's umask (read by setting and restoring it, under a lock). [-]"""
    with _LOCK:
        mask = os.umask(0o022)
        os.umask(mask)
    return mask


def apply_umask(path, directory: bool | None = None) -> None:
    """Give ``path`` (and, for a folder, everything below it) the mode the umask allows.

    Parameters
    ----------
    path : str or os.PathLike
        A file or folder the library created. [-]
    directory : bool, optional
        Whether ``path`` is a folder; default: look. [-]
    """
    mask = current_umask()
    path = os.fspath(path)
    if directory is None:
        directory = os.path.isdir(path)
    if not directory:
        os.chmod(path, 0o666 & ~mask)
        return
    os.chmod(path, 0o777 & ~mask)
    for root, dirs, files in os.walk(path):
        for d in dirs:
            os.chmod(os.path.join(root, d), 0o777 & ~mask)
        for f in files:
            os.chmod(os.path.join(root, f), 0o666 & ~mask)

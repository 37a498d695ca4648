"""Files and folders that appear whole or not at all.

Every output of the toolkit (a figure, a report folder, a generated campaign, a table) is written
into a temporary sibling of its destination and renamed into place when complete. On an exception,
Ctrl-C or SIGTERM the temporary is removed (the command line turns SIGTERM into an exception, so
``finally`` blocks run). A ``kill -9`` cannot be intercepted: the temporary it strands carries the
writer's process id in its name (``.NAME.mckibben-tmp-PID-XXXX``) and the next write into the
same folder removes the ones whose process is gone.

Destinations are checked before any work starts (:func:`check_output_file`,
:func:`check_output_dir`): an existing folder where a file is wanted, a FIFO or device, a missing
or read-only parent folder, a pseudo-file system such as ``/proc`` — each is one
:class:`~mckibben.errors.InputError` naming the option and the path.
"""

from __future__ import annotations

import errno
import os
import re
import secrets
import shutil
import stat
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from mckibben.errors import ArgumentTypeError, InputError
from mckibben.files import apply_umask

#: Marker in the name of every temporary this module creates.
TMP_TAG = ".mckibben-tmp-"
_STALE = re.compile(r"^\..*" + re.escape(TMP_TAG) + r"(?P<pid>\d+)-[0-9a-f]+")


def _kind(mode: int) -> str:
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    if stat.S_ISREG(mode):
        return "a file"
    return "a special file"


def _why(exc: OSError) -> str:
    return exc.strerror or errno.errorcode.get(exc.errno or 0, str(exc))


def as_path(path, name: str | None = None, what: str = "file") -> Path:
    """``path`` as a :class:`~pathlib.Path` if it is text or path-like; else an :class:`ArgumentTypeError`.

    Parameters
    ----------
    path : str or os.PathLike
        The argument. [-]
    name : str, optional
        The argument's name, for the message (default ``path``). [-]
    what : str
        What the path names, for the message. [-]
    """
    if isinstance(path, (str, os.PathLike)) and not isinstance(path, bytes):
        return Path(os.fspath(path))
    raise ArgumentTypeError(f"{name or 'path'} = {path!r}: not a {what} path ({type(path).__name__}); "
                            "give a str or a pathlib.Path")


def check_input_file(path, name: str | None = None, what: str = "file") -> Path:
    """Check that ``path`` is an existing regular file that can be read; return it as a Path.

    A folder, FIFO, device or socket is refused *without opening it* (reading a FIFO would wait
    forever).

    Parameters
    ----------
    path : str or os.PathLike
        The file. [-]
    name : str, optional
        The option that gave it, for the message (default: the message starts with the path). [-]
    what : str
        What the file is, for the message ("file", "muscle file", "sweep file"). [-]
    """
    p = as_path(path, name, what)
    where = f"{name}: {str(p)!r}" if name else str(p)
    try:
        st = p.stat()
    except FileNotFoundError:
        raise InputError(f"{where}: no such {what}") from None
    except NotADirectoryError:
        raise InputError(f"{where}: no such {what} (a part of the path is a file, not a folder)") from None
    except OSError as exc:
        raise InputError(f"{where}: cannot read the {what} ({_why(exc)})") from None
    if not stat.S_ISREG(st.st_mode):
        raise InputError(f"{where}: is {_kind(st.st_mode)}, not a {what}")
    if not os.access(p, os.R_OK):
        raise InputError(f"{where}: cannot read the {what} (permission denied)")
    return p


def _check_parent(p: Path, name: str) -> Path:
    parent = p.absolute().parent
    try:
        st = parent.stat()
    except FileNotFoundError:
        raise InputError(f"{name}: folder {str(parent)!r} does not exist") from None
    except OSError as exc:
        raise InputError(f"{name}: folder {str(parent)!r}: {_why(exc)}") from None
    if not stat.S_ISDIR(st.st_mode):
        raise InputError(f"{name}: {str(parent)!r} is {_kind(st.st_mode)}, not a folder")
    _probe(parent, name)
    return parent


def _probe(folder: Path, name: str) -> None:
    """Create and remove a temporary in ``folder``: the only test that also holds for root,
    immutable folders, read-only mounts and pseudo-file systems."""
    probe = folder / f".probe{TMP_TAG}{os.getpid()}-{secrets.token_hex(4)}"
    try:
        fd = os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    except OSError as exc:
        raise InputError(f"{name}: cannot write in folder {str(folder)!r} ({_why(exc)})") from None
    os.close(fd)
    try:
        os.unlink(probe)
    except OSError:
        pass


def _stat_destination(p: Path, name: str) -> os.stat_result | None:
    """What stands at an output path now (None: nothing); a path that cannot be one is refused."""
    try:
        return p.stat()
    except FileNotFoundError:
        return None
    except NotADirectoryError:
        raise InputError(f"{name}: {str(p)!r}: a part of the path is a file, not a folder") from None
    except OSError as exc:
        raise InputError(f"{name}: {str(p)!r}: {_why(exc)}") from None


def check_output_file(path, name: str = "out", suffixes: tuple[str, ...] | None = None) -> Path:
    """Check, before any work, that a file can be written at ``path``; return it as a Path.

    Parameters
    ----------
    path : str or os.PathLike
        The destination file. An existing regular file is replaced. [-]
    name : str
        The option that gave it, for the message. [-]
    suffixes : tuple of str, optional
        Accepted suffixes (lower case, with the dot), e.g. ``(".png", ".pdf", ".svg")``.
    """
    p = as_path(path, name)
    if str(path) == "" or p.name in ("", ".", ".."):
        raise InputError(f"{name}: {str(path)!r} is not a file name")
    if suffixes is not None and p.suffix.lower() not in suffixes:
        listed = suffixes[0] if len(suffixes) == 1 else f"{', '.join(suffixes[:-1])} or {suffixes[-1]}"
        raise InputError(f"{name}: {str(path)!r} must end in {listed}")
    st = _stat_destination(p, name)
    if st is not None and not stat.S_ISREG(st.st_mode):
        raise InputError(f"{name}: {str(p)!r} is {_kind(st.st_mode)}; give a file name")
    _check_parent(p, name)
    return p


def check_output_dir(path, name: str = "out") -> Path:
    """Check, before any work, that a folder can be created (or replaced) at ``path``.

    Whether an existing folder may be replaced is the caller's rule; this checks that ``path``
    is not a file or special file and that its parent folder exists and takes new entries.

    Parameters
    ----------
    path : str or os.PathLike
        The destination folder. [-]
    name : str
        The option that gave it. [-]
    """
    p = as_path(path, name, "folder")
    if str(path) == "":
        raise InputError(f"{name}: an empty folder name")
    st = _stat_destination(p, name)
    if st is not None and not stat.S_ISDIR(st.st_mode):
        raise InputError(f"{name}: {str(p)!r} is {_kind(st.st_mode)}, not a folder")
    if p.resolve().parent == p.resolve():
        raise InputError(f"{name}: {str(p)!r} is the root folder")
    parent = p.resolve().parent
    if not parent.exists():
        try:
            parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise InputError(f"{name}: cannot create folder {str(parent)!r} ({_why(exc)})") from None
    _check_parent(p.resolve(), name)
    return p


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def clean_stale(folder) -> list[str]:
    """Remove the temporaries in ``folder`` left by writers that no longer run (``kill -9``).

    Parameters
    ----------
    folder : str or os.PathLike
        The folder. [-]

    Returns
    -------
    list of str
        The names removed.
    """
    removed = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for e in entries:
        m = _STALE.match(e.name)
        if m is None or _alive(int(m.group("pid"))):
            continue
        try:
            if e.is_dir(follow_symlinks=False):
                shutil.rmtree(e.path, ignore_errors=True)
            else:
                os.unlink(e.path)
            removed.append(e.name)
        except OSError:
            pass
    return removed


def _tmp_name(p: Path) -> Path:
    return p.with_name(f".{p.name}{TMP_TAG}{os.getpid()}-{secrets.token_hex(4)}{p.suffix}")


@contextmanager
def atomic_file(path, name: str = "out") -> Iterator[Path]:
    """Write a file atomically: yield a temporary sibling path; rename it onto ``path`` on success.

    On any exception (and on SIGTERM under the command line) the temporary is removed and the
    destination is untouched. The file gets the mode the user's umask gives a new file.

    Parameters
    ----------
    path : str or os.PathLike
        The destination. [-]
    name : str
        The option that gave it, for messages. [-]

    Examples
    --------
    >>> with atomic_file("fig.png", "plot") as tmp:  # doctest: +SKIP
    ...     fig.savefig(tmp, format="png")
    """
    p = check_output_file(path, name)
    clean_stale(p.absolute().parent)
    tmp = _tmp_name(p)
    try:
        yield tmp
        if not tmp.exists():
            raise InputError(f"{name}: nothing was written to {str(p)!r}")
        apply_umask(tmp, directory=False)
        os.replace(tmp, p)
    except OSError as exc:
        _remove(tmp)
        raise InputError(f"{name}: cannot write {str(p)!r} ({_why(exc)})") from None
    except BaseException:
        _remove(tmp)
        raise


@contextmanager
def atomic_dir(path, name: str = "out") -> Iterator[Path]:
    """Write a folder atomically: yield a fresh temporary sibling folder; on success replace
    ``path`` with it (an existing ``path`` is removed just before the rename).

    The caller decides beforehand whether an existing folder may be replaced.

    Parameters
    ----------
    path : str or os.PathLike
        The destination folder. [-]
    name : str
        The option that gave it, for messages. [-]
    """
    p = check_output_dir(path, name).resolve()
    clean_stale(p.parent)
    tmp = p.with_name(f".{p.name}{TMP_TAG}{os.getpid()}-{secrets.token_hex(4)}")
    try:
        tmp.mkdir(mode=0o777)
    except OSError as exc:
        raise InputError(f"{name}: cannot write in folder {str(p.parent)!r} ({_why(exc)})") from None
    try:
        yield tmp
        apply_umask(tmp, directory=True)
        if p.exists():
            shutil.rmtree(p)
        os.replace(tmp, p)
    except OSError as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        raise InputError(f"{name}: cannot write {str(p)!r} ({_why(exc)})") from None
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def _remove(tmp: Path) -> None:
    try:
        os.unlink(tmp)
    except FileNotFoundError:
        pass
    except IsADirectoryError:
        shutil.rmtree(tmp, ignore_errors=True)

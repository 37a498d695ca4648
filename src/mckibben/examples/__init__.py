"""Example files shipped with the package (a sweep description), to list and copy.

``mckibben examples list`` and ``mckibben examples copy NAME [DEST]`` are one call each of
:func:`list_examples` and :func:`copy_example`; nothing is ever written into the package.
"""

from __future__ import annotations

import shutil
from importlib import resources
from pathlib import Path

from mckibben.errors import InputError, unknown_name
from mckibben.atomic import atomic_file

__all__ = ["copy_example", "example_path", "list_examples"]


def list_examples() -> dict[str, str]:
    """The bundled examples: file name → its first comment line (what it is).

    Returns
    -------
    dict of str to str
    """
    out = {}
    for entry in sorted(resources.files(__name__).iterdir(), key=lambda e: e.name):
        if entry.name.startswith(("_", ".")) or not entry.is_file():
            continue
        first = entry.read_text(encoding="utf-8").splitlines()[0] if entry.name.endswith(".toml") else ""
        out[entry.name] = first.lstrip("# ").strip()
    return out


def example_path(name: str) -> Path:
    """Where a bundled example is (read-only: copy it before editing).

    Parameters
    ----------
    name : str
        A name from :func:`list_examples`, e.g. ``"sweep.toml"``. [-]
    """
    names = list_examples()
    if name not in names:
        raise unknown_name("example", name, names)
    return Path(str(resources.files(__name__) / name))


def copy_example(name: str, dest=".") -> Path:
    """Copy a bundled example to ``dest`` (a folder, or a file name); never overwrite a file.

    Parameters
    ----------
    name : str
        A name from :func:`list_examples`. [-]
    dest : str or os.PathLike, default "."
        Existing folder, or the path of the copy. [-]

    Returns
    -------
    pathlib.Path
        The copy.
    """

    src = example_path(name)
    dest = Path(dest)
    target = dest / name if dest.is_dir() else dest
    if target.exists():
        raise InputError(f"DEST: {str(target)!r} exists; remove it or give another name")
    with atomic_file(target, "DEST") as tmp:
        shutil.copyfile(src, tmp)
    return target

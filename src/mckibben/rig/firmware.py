"""The firmware from an installed package: build the Mega image, flash it, write the Arduino sketch.

The firmware's sources (``firmware/``: the program ``src/main.c``, the controller core ``core/``,
the processor-in-the-loop harness ``pil/``, the sketch's ``.ino`` and the ``Makefile``) ship in
the package (``mckibben/firmware``, copied by ``setup.py``); a source checkout uses its own
``firmware/``. Every build goes through that ``Makefile``, the one place that holds the flags,
the programmer and its baud rate: :func:`build` runs its image target, :func:`flash` its
``upload`` target (avrdude), :func:`sketch` its ``sketch`` target. A missing tool is one
:class:`~mckibben.errors.InputError` line naming the Debian package that installs it.
"""

from __future__ import annotations

import hashlib
import os
import shlex
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

from mckibben import _kernels
from mckibben import hardware as HW
from mckibben.errors import InputError

#: The Debian packages that install each tool the firmware needs.
PACKAGES = {"avr-gcc": "gcc-avr avr-libc", "make": "make", "cc": "gcc", "libsimavr": "libsimavr-dev libelf-dev",
            "avrdude": "avrdude", "simavr": "simavr"}


#: Where libsimavr's headers are looked for (``$SIMAVR_INCLUDE`` first).
SIMAVR_INCLUDES = ("/usr/include/simavr", "/usr/local/include/simavr", "/opt/homebrew/include/simavr")


def simavr_include() -> Path:
    """The folder of libsimavr's headers (``sim_avr.h``); refused naming its package when missing."""
    for d in ([os.environ["SIMAVR_INCLUDE"]] if os.environ.get("SIMAVR_INCLUDE") else []) + list(SIMAVR_INCLUDES):
        if (Path(d) / "sim_avr.h").is_file():
            return Path(d)
    raise missing("libsimavr")


def missing(tool: str) -> InputError:
    """The one-line refusal for a missing tool, naming the Debian package that installs it."""
    return InputError(f"{tool} not found: install it (Debian/Ubuntu: sudo apt-get install {PACKAGES[tool]})")


def firmware_dir() -> Path:
    """The firmware's sources: the copy a built package carries (``mckibben/firmware``, made by
    ``setup.py``), else ``firmware/`` of the source tree this runs from."""
    here = Path(__file__).resolve()
    for fw in (here.parents[1] / "firmware", here.parents[3] / "firmware"):
        if (fw / "Makefile").is_file() and (fw / "src" / "main.c").is_file():
            return fw
    raise InputError("firmware: its sources are not in this installation (a package built without firmware/)")


def sources(fw: Path | None = None) -> list[Path]:
    """The files an image is built from (the Makefile, the program, the core). [-]"""
    fw = firmware_dir() if fw is None else fw
    return [fw / "Makefile", *sorted((fw / "src").glob("*.[ch]")), *sorted((fw / "core").glob("*.[ch]"))]


def _channels(n_channels) -> int:
    if isinstance(n_channels, bool) or int(n_channels) != n_channels or not 1 <= int(n_channels) <= HW.N_CHANNELS:
        raise InputError(f"n_channels: {n_channels!r} must be 1, 2 or 3")
    return int(n_channels)


def load_cell_mn(load_cell, name: str = "load_cell") -> int:
    """The Makefile's ``LOAD_CELL_MN`` for a load cell's full scale (0: none fitted). [mN]

    Parameters
    ----------
    load_cell : float or None
        Full scale of the load cell, above 0 and at most
        :data:`mckibben.hardware.LOAD_CELL_FULL_SCALE_MAX`; None: no load cell. [N]
    name : str, default "load_cell"
        The argument's name in the error. [-]
    """
    if load_cell is None:
        return 0
    try:
        f = float(load_cell)
    except (TypeError, ValueError):
        raise InputError(f"{name}: {load_cell!r} is not a force") from None
    if not 0 < f <= HW.LOAD_CELL_FULL_SCALE_MAX or int(round(f * 1e3)) < 1:
        raise InputError(f"{name}: {load_cell!r} is not a full scale above 0 and at most "
                         f"{HW.LOAD_CELL_FULL_SCALE_MAX:g} N")
    return int(round(f * 1e3))


def _make(args: list[str], what: str) -> subprocess.CompletedProcess:
    if shutil.which("make") is None:
        raise missing("make")
    done = subprocess.run(["make", "-s", "-C", str(firmware_dir()), *args], capture_output=True, text=True)
    if done.returncode != 0:
        last = (done.stderr.strip().splitlines() or ["(no message)"])[-1]
        raise InputError(f"{what}: make {' '.join(args)} failed: {last}")
    return done


@dataclass(frozen=True)
class Image:
    """A built firmware image. ``elf`` and ``hex`` are its files; ``n_channels`` its ``MCK_N_CHANNELS``."""

    elf: Path
    hex: Path
    n_channels: int
    load_cell: float | None = None

    def to_dict(self) -> dict:
        return {"elf": str(self.elf), "hex": str(self.hex), "channels": self.n_channels,
                "load_cell_N": self.load_cell, "bytes": self.elf.stat().st_size}


def build(n_channels: int = HW.N_CHANNELS, out: str | os.PathLike = "firmware-build",
          load_cell: float | None = None) -> Image:
    """Build the ATmega2560 image (``make -C firmware``) into a folder: ``mckibben.elf`` and ``mckibben.hex``.

    Parameters
    ----------
    n_channels : int, default 3
        Pressure channels, the firmware's ``MCK_N_CHANNELS``, 1..3. [-]
    out : path, default "firmware-build"
        Folder to write the two files into (made if missing; its parent must exist). They are
        written whole or not at all. [-]
    load_cell : float, optional
        Full scale of a load cell on A3 (``MCK_LOAD_CELL_MN``; docs/firmware.md, "Load cell"); None:
        no load cell. [N]

    Returns
    -------
    Image

    Raises
    ------
    InputError
        ``n_channels`` out of range; ``out`` not a folder or its parent missing; avr-gcc or make
        missing (named with the package that installs it).
    """
    n = _channels(n_channels)
    mn = load_cell_mn(load_cell)
    dest = Path(out).expanduser().resolve()
    if dest.exists() and not dest.is_dir():
        raise InputError(f"out: {str(out)!r} is not a folder")
    if not dest.parent.is_dir():
        raise InputError(f"out: folder {str(dest.parent)!r} does not exist")
    if shutil.which("avr-gcc") is None:
        raise missing("avr-gcc")
    dest.mkdir(exist_ok=True)
    with tempfile.TemporaryDirectory(prefix=".mckibben-fw-", dir=dest) as tmp:
        _make([f"BUILD={tmp}", f"N_CHANNELS={n}", f"LOAD_CELL_MN={mn}", f"{tmp}/mckibben.hex"], "firmware build")
        for name in ("mckibben.elf", "mckibben.hex"):
            os.replace(Path(tmp) / name, dest / name)
    return Image(dest / "mckibben.elf", dest / "mckibben.hex", n, mn / 1e3 if mn else None)


def cache_folder(kind: str) -> Path:
    """A folder of the per-user cache for built firmware parts (:func:`mckibben._jit.cache_dir`,
    ``pil/KIND``); a temporary folder of this user when there is no writable cache. [-]"""
    base = _kernels.jit().cache_dir()  # loads Numba's cache machinery: only when something is built
    if base is None:
        base = Path(tempfile.gettempdir()) / f"mckibben-{os.getuid()}"
    return base / "pil" / kind


def cached_build(n_channels: int = HW.N_CHANNELS, load_cell: float | None = None) -> Image:
    """:func:`build` into the per-user cache, once per source, channel count and load cell. [-]"""
    n = _channels(n_channels)
    mn = load_cell_mn(load_cell)
    h = hashlib.sha256()
    for p in sources():
        h.update(p.name.encode() + p.read_bytes())
    folder = cache_folder("image") / (f"{h.hexdigest()[:16]}-{n}" + (f"-lc{mn}" if mn else ""))
    image = Image(folder / "mckibben.elf", folder / "mckibben.hex", n, mn / 1e3 if mn else None)
    if image.elf.is_file() and image.hex.is_file():
        return image
    folder.parent.mkdir(parents=True, exist_ok=True)
    return build(n, folder, load_cell)


@dataclass(frozen=True)
class Flash:
    """A flash (or its dry run): the avrdude ``command`` run (or to run) and the image."""

    command: list[str]
    image: Image
    port: str
    dry_run: bool

    def to_dict(self) -> dict:
        return {"command": shlex.join(self.command), "port": self.port, "dry_run": self.dry_run,
                "hex": str(self.image.hex), "channels": self.image.n_channels, "load_cell_N": self.image.load_cell}


def flash(port: str, n_channels: int = HW.N_CHANNELS, dry_run: bool = False, load_cell: float | None = None) -> Flash:
    """Build the image and flash it onto a Mega through its bootloader (``make upload``: avrdude, STK500v2).

    Parameters
    ----------
    port : str
        The Mega's serial port (``/dev/ttyACM0``). [-]
    n_channels : int, default 3
        Pressure channels of the image, 1..3. [-]
    dry_run : bool, default False
        Build (into the per-user cache, :func:`cached_build`), then return the avrdude command
        without running it. [-]
    load_cell : float, optional
        Full scale of a load cell on A3; None: no load cell. [N]

    Raises
    ------
    InputError
        An empty port, or (not a dry run) a port that does not exist; avr-gcc, make or (not a dry
        run) avrdude missing; avrdude failed.
    """
    if not port or not str(port).strip():
        raise InputError("port: give the Mega's serial port, e.g. /dev/ttyACM0")
    if not dry_run and not os.path.exists(port):
        raise InputError(f"port: {port!r} does not exist (is the Mega plugged in?)")
    if not dry_run and shutil.which("avrdude") is None:
        raise missing("avrdude")
    image = cached_build(n_channels, load_cell)
    args = [f"BUILD={image.elf.parent}", f"N_CHANNELS={image.n_channels}",
            f"LOAD_CELL_MN={load_cell_mn(image.load_cell)}", f"PORT={port}", "upload"]
    plan = _make(["-n", *args], "firmware flash")
    lines = [ln for ln in plan.stdout.splitlines() if ln.startswith("avrdude") or "/avrdude" in ln]
    command = shlex.split(lines[-1]) if lines else []
    if not dry_run:
        _make(args, "firmware flash")
    return Flash(command, image, str(port), bool(dry_run))


def sketch(out: str | os.PathLike) -> Path:
    """Write the Arduino IDE sketch folder ``OUT/mckibben`` (``make sketch``: the same sources as the image).

    Parameters
    ----------
    out : path
        An existing folder; ``mckibben/`` is written into it whole, replacing one that is there. [-]

    Returns
    -------
    pathlib.Path
        The sketch folder (open ``mckibben.ino`` in the Arduino IDE, board Arduino Mega 2560).

    Raises
    ------
    InputError
        ``out`` not an existing folder; make missing.
    """
    dest = Path(out).expanduser()
    if not dest.is_dir():
        raise InputError(f"out: {str(out)!r} is not an existing folder")
    folder = dest / "mckibben"
    with tempfile.TemporaryDirectory(prefix=".mckibben-sketch-", dir=dest) as tmp:
        _make([f"BUILD={tmp}", "sketch"], "firmware sketch")
        if folder.exists():
            shutil.rmtree(folder)
        os.replace(Path(tmp) / "sketch" / "mckibben", folder)
    return folder

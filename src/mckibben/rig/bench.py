"""The bench side channel: change the hanging load, or hold the muscle at a length, on a simulated bench.

On a real bench the operator hangs the weights; an emulated device (both engines: the Python
emulator and the firmware image in simavr) has no operator, so beside its serial link it serves a
small line-based Unix socket through which a script changes the bench of channel 0. One request per
line, SI numbers, one reply line each:

=============  ======================================================  =======================
request        what the bench does                                     reply
=============  ======================================================  =======================
``load F``     hangs a weight of F newtons (``F >= 0``)                ``ok``
``hold L``     clamps the muscle's end at length L metres (isometric)  ``ok``
``release``    lets the end go again (the weight hangs)                ``ok``
``state``      reports the bench of channel 0                          ``ok load F length L``
                                                                       ``pressure P held 0|1``
anything else  nothing                                                 ``error: <reason>``
=============  ======================================================  =======================

The socket of a device whose serial port is ``PORT`` is :func:`bench_path` ``(PORT)`` (a symbolic
link to the port leads to the same socket), so a script that knows the port finds its bench:
``Bench.of_port("/tmp/mega").load(0.6)``; on the command line ``mckibben rig bench --port /tmp/mega
load 61g``. ``mckibben rig characterize --unattended`` changes the loads this way.
"""

from __future__ import annotations

import math
import os
import socket
import tempfile
from dataclasses import dataclass
from pathlib import Path

from mckibben.errors import InputError

__all__ = ["Bench", "BenchState", "bench_dir", "bench_path", "parse_request"]

#: Longest request or reply line. [bytes]
MAX_LINE = 256


def bench_dir() -> Path:
    """The folder of the bench sockets: ``$MCKIBBEN_BENCH_DIR``, else a per-user folder in the temporary one."""
    env = os.environ.get("MCKIBBEN_BENCH_DIR")
    return Path(env) if env else Path(tempfile.gettempdir()) / f"mckibben-bench-{os.getuid()}"


def bench_path(port: str) -> Path:
    """The bench socket of the emulated device on ``port`` (a link to the port is followed).

    Parameters
    ----------
    port : str
        The device's serial port (a pseudo-terminal such as ``/dev/pts/3``, or a link to it). [-]
    """
    real = os.path.realpath(port)
    return bench_dir() / (real.strip("/").replace("/", "_") + ".sock")


def parse_request(line: str) -> tuple[str, float | None]:
    """One request line → ``(verb, value)``; a bad line raises :class:`InputError` with the reason.

    Parameters
    ----------
    line : str
        ``load F`` [N], ``hold L`` [m], ``release`` or ``state``. [-]
    """
    words = line.split()
    if not words:
        raise InputError("empty request")
    verb, args = words[0], words[1:]
    if verb in ("release", "state"):
        if args:
            raise InputError(f"{verb} takes no value")
        return verb, None
    if verb not in ("load", "hold"):
        raise InputError(f"unknown request {verb!r} (load F, hold L, release, state)")
    if len(args) != 1:
        raise InputError(f"{verb} takes one number ({'newtons' if verb == 'load' else 'metres'})")
    try:
        v = float(args[0])
    except ValueError:
        raise InputError(f"{verb}: {args[0]!r} is not a number") from None
    if not math.isfinite(v) or v < 0 or (verb == "hold" and v == 0):
        raise InputError(f"{verb}: {args[0]} must be a finite number {'>= 0' if verb == 'load' else '> 0'}")
    return verb, v


@dataclass(frozen=True)
class BenchState:
    """What ``state`` reports.

    Attributes
    ----------
    load : float
        The hanging weight. [N]
    length : float
        The muscle's true length. [m]
    pressure : float
        The muscle's true gauge pressure. [Pa]
    held : bool
        The end is clamped (isometric). [-]
    """

    load: float
    length: float
    pressure: float
    held: bool


class Bench:
    """A client of a bench socket.

    Parameters
    ----------
    path : str or os.PathLike
        The socket (:func:`bench_path`). [-]
    timeout : float, default 5.0
        How long to wait for a reply. [s]
    """

    def __init__(self, path, timeout: float = 5.0):
        self.path = Path(path)
        self.timeout = float(timeout)

    @classmethod
    def of_port(cls, port: str, timeout: float = 5.0) -> "Bench":
        """The bench of the emulated device on ``port``.

        Parameters
        ----------
        port : str
            The device's serial port. [-]
        timeout : float, default 5.0
            How long to wait for a reply. [s]
        """
        return cls(bench_path(port), timeout)

    def request(self, line: str) -> str:
        """Send one request line; return the reply line (``ok ...``); an ``error:`` reply raises.

        Parameters
        ----------
        line : str
            The request. [-]

        Raises
        ------
        InputError
            No bench at the path (not an emulated device), or the bench refused the request.
        """
        try:
            with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as s:
                s.settimeout(self.timeout)
                s.connect(str(self.path))
                s.sendall(line.strip().encode() + b"\n")
                buf = b""
                while not buf.endswith(b"\n") and len(buf) < MAX_LINE:
                    chunk = s.recv(MAX_LINE)
                    if not chunk:
                        break
                    buf += chunk
        except (FileNotFoundError, ConnectionRefusedError, NotADirectoryError):
            raise InputError(f"bench: no bench socket at {str(self.path)!r}; is the port an emulated device "
                             "(mckibben rig emulate)?") from None
        except OSError as exc:
            raise InputError(f"bench: {str(self.path)!r}: {exc.strerror or exc}") from None
        reply = buf.decode(errors="replace").strip()
        if not reply.startswith("ok"):
            raise InputError(f"bench: {line.strip()!r} refused: {reply.removeprefix('error:').strip() or 'no reply'}")
        return reply

    def load(self, force: float) -> None:
        """Hang a weight.

        Parameters
        ----------
        force : float
            Its weight (a mass times standard gravity). [N]
        """
        self.request(f"load {float(force)!r}")

    def hold(self, length: float) -> None:
        """Clamp the muscle's end at a length (an isometric run).

        Parameters
        ----------
        length : float
            The held length. [m]
        """
        self.request(f"hold {float(length)!r}")

    def release(self) -> None:
        """Let the end go: the weight hangs again."""
        self.request("release")

    def state(self) -> BenchState:
        """The bench of channel 0 now (load, true length and pressure, held)."""
        w = self.request("state").split()
        try:
            kv = dict(zip(w[1::2], w[2::2]))
            return BenchState(float(kv["load"]), float(kv["length"]), float(kv["pressure"]), kv["held"] == "1")
        except (KeyError, ValueError):
            raise InputError(f"bench: unreadable state reply {' '.join(w)!r}") from None

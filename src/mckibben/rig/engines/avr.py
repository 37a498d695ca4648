"""The firmware image as the device: ``firmware/src/main.c`` in simavr, in the loop with the C plant.

:class:`AvrDevice` runs the processor-in-the-loop harness (``firmware/pil/pil.c``, linked against
libsimavr): it loads the very ELF that ``make -C firmware`` builds and ``make upload`` flashes,
clocks it at 16 MHz, feeds ADC0..2 from each channel's pressure through the sensor model, turns
the six PWM compare outputs into valve commands, feeds the encoder pins from channel 0's length
and bridges USART0 to a pseudo-terminal, with the Mega's reset on open, the bootloader's delay
and HELLO; with a load cell, ADC3 reads channel 0's tension through :class:`mckibben.hardware.LoadCell`
(the image built with ``LOAD_CELL_MN``). The plant is ``export/c/mk_plant.c``, the C port of :mod:`mckibben.plant.physics` the
FMU compiles (its layout from :func:`mckibben.plant.c_layout.plant_header`).

Both binaries are built on first use with the system tools and cached per user
(:func:`mckibben.rig.firmware.cache_folder`), keyed by a hash of their sources: the image with
``make`` and avr-gcc (Debian: ``gcc-avr avr-libc make``), the harness with ``cc`` and libsimavr
(Debian: ``libsimavr-dev libelf-dev``). A missing tool is one :class:`~mckibben.errors.InputError`
line naming the package to install.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import signal
import subprocess
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from mckibben import hardware as HW
from mckibben.errors import InputError
from mckibben.plant import c_layout as CL
from mckibben.plant import params as PP
from mckibben.plant import packing as PK
from mckibben.rig import firmware as FW
from mckibben.rig.bench import bench_dir

#: The plant's C sources (package data of mckibben.export, ``c/``) the harness compiles.
PLANT_SOURCES = ("mk_plant.h", "mk_plant.c")
#: The folder of the C plant's sources: package data beside mckibben.export (``export/c``), read as files.
PLANT_C = Path(__file__).resolve().parents[2] / "export" / "c"

#: The firmware's ring indices the harness watches for their high-water marks (``--rings``).
RING_SYMBOLS = ("tx_head", "tx_tail", "rx_head", "rx_tail")


def ring_symbols(elf: str | os.PathLike) -> str | None:
    """The harness's ``--rings`` argument for ``elf``: the data addresses of USART0's ring indices
    (:data:`RING_SYMBOLS`) and the receive ring's size, read from the image's symbols with avr-nm.

    Parameters
    ----------
    elf : path
        The firmware image. [-]

    Returns
    -------
    str or None
        ``"TXH,TXT,RXH,RXT,RXSIZE"`` (SRAM addresses [byte], size [byte]); None when avr-nm is
        missing or the image lacks a symbol.
    """
    nm = shutil.which("avr-nm")
    if nm is None:
        return None
    out = subprocess.run([nm, "-S", str(elf)], capture_output=True, text=True).stdout
    sym = {}
    for line in out.splitlines():
        f = line.split()
        if len(f) == 4:
            sym[f[3]] = (int(f[0], 16) & 0xFFFF, int(f[1], 16))
    if not all(name in sym for name in (*RING_SYMBOLS, "rx_buf")):
        return None
    return ",".join([*(str(sym[name][0]) for name in RING_SYMBOLS), str(sym["rx_buf"][1])])


def build_image(n_channels: int = HW.N_CHANNELS, load_cell: float | None = None) -> Path:
    """The firmware image (:func:`mckibben.rig.firmware.build`), built once per source, channel count and
    load cell into the per-user cache.

    Parameters
    ----------
    n_channels : int, default 3
        Pressure channels, ``MCK_N_CHANNELS``, 1..3. [-]
    load_cell : float, optional
        Full scale of the load cell on A3 (``LOAD_CELL_MN``); None: none. [N]

    Returns
    -------
    pathlib.Path
        The ELF image.
    """
    return FW.cached_build(n_channels, load_cell).elf


simavr_include = FW.simavr_include


def build_harness(plant: PP.PlantParams | None = None) -> Path:
    """The processor-in-the-loop harness (``firmware/pil/pil.c`` + ``export/c/mk_plant.c`` + the laws' generated
    ``mk_laws.c``), built once per source.

    Parameters
    ----------
    plant : PlantParams, optional
        A rig whose layout and thermal model the binary is built for (values are read at run
        time); default the calibrated rig. [-]

    Raises
    ------
    InputError
        No C compiler or no libsimavr (named with the package that installs it); a build failure.
    """
    plant = PP.PlantParams() if plant is None else plant
    cc = shutil.which(os.environ.get("CC", "cc"))
    if cc is None:
        raise FW.missing("cc")
    include = simavr_include()
    prm, law, theta, _ = plant.prepare(1)
    header = "\n".join(CL.plant_header(prm[0], theta[:, 0], law, plant.thermal)) + "\n\n#endif\n"
    fw = FW.firmware_dir()
    pkg = PLANT_C  # data files (C sources), not a Python import of the export layer
    sources = {"pil.c": (fw / "pil" / "pil.c").read_bytes(),
               **{f: (pkg / f).read_bytes() for f in PLANT_SOURCES}, "mk_model.h": header.encode(),
               "mk_laws.c": CL.laws_c().encode()}
    h = hashlib.sha256(b"".join(k.encode() + v for k, v in sorted(sources.items())) + str(include).encode())
    binary = FW.cache_folder("harness") / h.hexdigest()[:16] / "pil"
    if binary.is_file():
        return binary
    binary.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="mckibben-pil-", dir=binary.parent) as tmp:
        for name, data in sources.items():
            (Path(tmp) / name).write_bytes(data)
        cmd = [cc, "-std=gnu99", "-O2", "-Wall", "-Wextra", f"-I{tmp}", f"-I{include.parent}", "-o", f"{tmp}/pil",
               f"{tmp}/pil.c", f"{tmp}/mk_plant.c", f"{tmp}/mk_laws.c", "-lsimavr", "-lelf", "-lutil", "-lm"]
        done = subprocess.run(cmd, capture_output=True, text=True)
        if done.returncode != 0:
            if "-lsimavr" in done.stderr or "-lelf" in done.stderr:
                raise FW.missing("libsimavr")
            raise RuntimeError(f"building the PIL harness failed ({' '.join(cmd)}):\n{done.stderr}")
        os.replace(Path(tmp) / "pil", binary)
    return binary


def require() -> None:
    """Raise the one-line :class:`~mckibben.errors.InputError` naming the first tool the engine lacks
    (avr-gcc, make, libsimavr, a C compiler) and its Debian package; return when all are here."""
    for tool in ("avr-gcc", "make"):
        if shutil.which(tool) is None:
            raise FW.missing(tool)
    simavr_include()
    if shutil.which(os.environ.get("CC", "cc")) is None:
        raise FW.missing("cc")


def available() -> str | None:
    """None when the avr engine can run here, else the reason (one line naming what to install)."""
    try:
        require()
    except InputError as exc:
        return str(exc)
    return None


def write_params(plants, path: Path) -> None:
    """The channels' plants as the harness reads them: the packed fields and the law, as the FMU packs them.

    Parameters
    ----------
    plants : sequence of PlantParams
        One rig per channel (scalar fields). [-]
    path : pathlib.Path
        The text file to write. [-]
    """
    nf = len(PK.field_names())
    have = CL.c_laws()
    lines = []
    for i, p in enumerate(plants):
        prm, law, theta, name = p.prepare(1)
        if name not in have:
            raise InputError(f"plant: channel {i}'s force law {name} has no C face (models/laws/<law>.c), so "
                             f"the C plant cannot run it (those that have one: {', '.join(have)})")
        if p.pressure_noise != 0:
            raise InputError(f"plant: channel {i} has pressure_noise; the avr engine's sensors are noiseless")
        lines.append(" ".join([str(int(law)), *(CL.c_double(v) for v in prm[0, :nf]),
                               *(CL.c_double(v) for v in np.asarray(theta)[:, 0])]))
    text = f"{len(plants)} {nf} {len(np.asarray(theta)[:, 0])}\n" + "\n".join(lines) + "\n"
    path.write_text(text)


class AvrDevice:
    """The firmware image in simavr against the C plant, behind a pseudo-terminal (a child process).

    Parameters
    ----------
    plants : sequence of PlantParams
        One rig per channel (:func:`mckibben.rig.engines.with_supply`). [-]
    n_channels : int, default 3
        Channels: the image is built with ``MCK_N_CHANNELS = n_channels``. [-]
    boot_time : float, default 0.3
        Bootloader time after each reset (a Mega: 1-2 s). [s]
    unthrottled : bool, default False
        Run the simulation as fast as it goes instead of following wall time. [-]
    elf : path, optional
        An image to run instead of building one. [-]
    hold_adc : int, optional
        Channel 0's ADC reads this count whatever the pressure: a stuck sensor. [count]
    stall_at : float, optional
        Simulated time at which the control tick stalls (Timer1's interrupts masked), to show the
        watchdog path. [s]
    load_cell : LoadCell, optional
        A load cell on channel 0's muscle (:class:`mckibben.hardware.LoadCell`): the image is built
        with its full scale, the harness drives ADC3 from the plant's tension. [-]
    adc_miss_at : float, optional
        Simulated time from which the ADC's conversions miss the control tick (its completion
        interrupt masked) for ``adc_miss_n`` periods. [s]
    adc_miss_n : int, default 1
        Control periods the conversions miss. [-]
    profile : path, optional
        File the harness writes at the end: CPU cycles per program address. [-]

    Attributes
    ----------
    port : str
        The pseudo-terminal to open. [-]
    resets, wdt_resets : int
        Resets by a host opening the port, and by the watchdog (or a stopped image). [-]
    host_present : bool
        A process has the port open. [-]
    device_time : float
        The firmware's clock: simulated time since it last started after a reset. [s]
    steps, dropped : int
        Control periods simulated; packets dropped whole because the host did not read. [-]
    stats : dict
        The harness's last counters line. [-]
    instruments : dict
        What the harness reads off the CPU (:attr:`instruments`). [-]
    """

    def __init__(self, plants, n_channels: int = 3, boot_time: float = 0.3, unthrottled: bool = False,
                 elf: str | os.PathLike | None = None, stall_at: float | None = None, hold_adc: int | None = None,
                 load_cell: HW.LoadCell | None = None, adc_miss_at: float | None = None, adc_miss_n: int = 1,
                 profile: str | os.PathLike | None = None):
        if not 0 <= float(boot_time) <= 10:
            raise InputError(f"boot_time: {boot_time!r} must be within 0..10 s")
        self.n = int(n_channels)
        if load_cell is not None and not isinstance(load_cell, HW.LoadCell):
            raise InputError(f"load_cell: {load_cell!r} must be a mckibben.hardware.LoadCell or None")
        self.load_cell = load_cell
        require()
        self.elf = Path(elf) if elf is not None else build_image(
            self.n, None if load_cell is None else load_cell.full_scale)
        self.harness = build_harness(plants[0])
        self._dir = tempfile.TemporaryDirectory(prefix="mckibben-avr-")
        params = Path(self._dir.name) / "plants.txt"
        write_params(plants, params)
        self.boot_time, self.unthrottled = float(boot_time), bool(unthrottled)
        cmd = [str(self.harness), str(self.elf), str(params), "--boot-time", repr(self.boot_time)]
        if unthrottled:
            cmd.append("--unthrottled")
        if hold_adc is not None:
            cmd += ["--hold-adc", str(int(hold_adc))]
        if stall_at is not None:
            cmd += ["--stall-at", repr(float(stall_at))]
        if load_cell is not None:
            cmd += ["--load-cell", repr(float(load_cell.full_scale)), "--load-cell-offset", repr(float(load_cell.offset)),
                    "--load-cell-noise", repr(float(load_cell.noise)),
                    "--load-cell-seed", str(int(getattr(plants[0], "seed", 0) or 0) & 0xFFFFFFFFFFFFFFFF)]
        try:
            bench_dir().mkdir(mode=0o700, parents=True, exist_ok=True)
            cmd += ["--bench-dir", str(bench_dir())]  # the bench side channel (mckibben.rig.bench)
        except OSError:
            pass  # no place for the socket: the device runs, without a bench to script
        if adc_miss_at is not None:
            if not 1 <= int(adc_miss_n) <= 1000:
                raise InputError(f"adc_miss_n: {adc_miss_n!r} must be within 1..1000 periods")
            cmd += ["--adc-miss-at", repr(float(adc_miss_at)), "--adc-miss-n", str(int(adc_miss_n))]
        if profile is not None:
            cmd += ["--profile", str(profile)]
        rings = ring_symbols(self.elf)
        if rings is not None:
            cmd += ["--rings", rings]
        self._cmd = cmd
        self._proc: subprocess.Popen | None = None
        self.stats: dict = {}
        self._lock = threading.Lock()
        self._reader: threading.Thread | None = None
        self._launch()

    def _launch(self) -> None:
        self._proc = subprocess.Popen(self._cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                      start_new_session=True)
        info = None
        while info is None:  # simavr's ELF loader prints its own lines first
            line = self._proc.stdout.readline()
            if not line:
                err = self._proc.stderr.read().strip()
                self._proc.wait()
                raise InputError(err.removeprefix("error: ") or "the PIL harness exited at start")
            if line.startswith('{"port"'):
                info = json.loads(line)
        self.port: str = info["port"]
        #: The bench side channel's socket (:mod:`mckibben.rig.bench`).
        self.bench = Path(info["bench"]) if info.get("bench") else None
        self._reader = threading.Thread(target=self._read, name="mckibben-avr-stats", daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self._proc is not None and self._proc.stdout is not None
        for line in self._proc.stdout:
            try:
                s = json.loads(line)
            except ValueError:
                continue
            with self._lock:
                self.stats = s

    def _stat(self, key: str, default=0):
        with self._lock:
            return self.stats.get(key, default)

    @property
    def resets(self) -> int:
        return int(self._stat("resets"))

    @property
    def wdt_resets(self) -> int:
        return int(self._stat("wdt_resets"))

    @property
    def wdt_reset_at(self) -> float | None:
        """Simulated time of the last watchdog reset, None before any. [s]"""
        t = float(self._stat("wdt_reset_at", -1.0))
        return None if t < 0 else t

    @property
    def instruments(self) -> dict:
        """What the harness reads off the CPU since the image last started: ``ticks`` (Timer1
        compare-A interrupts entered), ``tick_min_cycles``/``tick_max_cycles`` (the shortest and
        longest period between two entries, 16,000 nominal), ``masked_max_cycles`` (the longest
        stretch with interrupts masked: an ISR's run or an atomic block), ``tx_hwm``/``rx_hwm``
        (the USART rings' high-water marks [byte]; -1 when not watched). [cycle, byte]"""
        keys = ("ticks", "tick_min_cycles", "tick_max_cycles", "masked_max_cycles", "tx_hwm", "rx_hwm")
        return {k: int(self._stat(k, -1)) for k in keys}

    @property
    def host_present(self) -> bool:
        return bool(self._stat("host"))

    @property
    def device_time(self) -> float:
        """The firmware's clock: simulated time since it last started after a reset. [s]"""
        return float(self._stat("t_dev", 0.0))

    @property
    def late(self) -> float:
        """Wall time the simulation fell behind and did not make up (a host starved of CPU): the
        device's clock slipped by this much rather than race to catch up. [s]"""
        return float(self._stat("late_ms", 0)) / 1e3

    @property
    def steps(self) -> int:
        """Control periods simulated since the harness started. [-]"""
        return int(float(self._stat("t_sim", 0.0)) / HW.CONTROL_PERIOD)

    @property
    def dropped(self) -> int:
        """Packets dropped whole because the host did not read (the USB bridge's 4 KB buffer was full). [-]"""
        return int(self._stat("dropped_packets"))

    def pressures(self) -> list[float]:
        """The channels' true gauge pressures at the last counters line. [Pa]"""
        return list(self._stat("pressure_pa", []))

    def tensions(self) -> list[float]:
        """The channels' true muscle tensions (the C plant's ``mk_outputs`` force) at the last counters
        line: what a load cell on the muscle carries. [N]"""
        return list(self._stat("tension_n", []))

    def start(self) -> "AvrDevice":
        """The harness runs from construction: nothing to start (as ``Emulator.start``)."""
        return self

    def run(self, duration: float | None = None) -> None:
        """Wait in the calling thread until the harness ends, or for ``duration`` seconds, then stop it.

        Parameters
        ----------
        duration : float, optional
            Wall-clock time to run. [s]
        """
        assert self._proc is not None
        try:
            self._proc.wait(timeout=duration)
        except subprocess.TimeoutExpired:
            pass
        finally:
            self.stop()

    def stop(self) -> None:
        """Stop the harness (SIGTERM; it closes the pty) and remove its files."""
        p = self._proc
        if p is not None and p.poll() is None:
            p.send_signal(signal.SIGTERM)
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
        if self._reader is not None:
            self._reader.join(timeout=5)
        for f in (p.stdout, p.stderr) if p is not None else ():
            if f is not None:
                f.close()
        self._dir.cleanup()

    def wait_until(self, cond, timeout: float = 30.0) -> bool:
        """Poll ``cond()`` until true or ``timeout`` seconds. [s]"""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if cond():
                return True
            time.sleep(0.02)
        return bool(cond())

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.stop()

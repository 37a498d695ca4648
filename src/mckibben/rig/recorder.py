"""The telemetry recorder: crash-safe by construction.

Frames are parsed as they arrive and written, at least every ``flush_interval`` (default
0.2 s), as a new Parquet part in a journal folder ``OUT.journal/``: each part is written to a
temporary name, fsynced, renamed, and the folder fsynced, so a part is complete or absent. A
``kill -9`` at any moment therefore loses at most the frames of the last interval (and what the
serial driver still buffered). A normal end joins the parts into ``OUT`` (atomically) and removes
the journal; after a crash, ``mckibben rig recover OUT.journal --out OUT`` does the join.

Columns (SI, unit-suffixed): ``seq``, ``time_s`` (device clock, wrap-corrected), ``pressure_Pa``,
``pressure_adc``, ``encoder_count``, ``length_m``, ``inlet_pwm``, ``bleed_pwm``, ``mode``,
``faults``, ``reference_Pa``, ``surface_Pa`` (channel 0), then the same per further channel with
``ch1_``, ``ch2_`` in front (:func:`channel_columns`), and ``force_N`` (the load cell's force,
untared, :func:`mckibben.hardware.force_from_count` with the device's full scale) when the device
streams one; a one-channel recording of protocol version 1 reads the same way. The file's metadata holds the port, baud rate,
protocol version, conversion constants and the parser's counters.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import json
import os
import re
import time
from dataclasses import dataclass, field
from pathlib import Path


from mckibben import hardware as HW
from mckibben.errors import InputError
from mckibben.rig import protocol as P
from mckibben.atomic import check_input_file

if TYPE_CHECKING:  # annotations only; the modules are imported where used (deferred)
    import pyarrow as pa
    import pandas as pd

COLUMNS = ["seq", "time_s", "pressure_Pa", "pressure_adc", "encoder_count", "length_m", "inlet_pwm", "bleed_pwm",
           "mode", "faults", "reference_Pa", "surface_Pa"]
#: Per-channel columns; channel 0's are the plain names of :data:`COLUMNS` (as in one-channel
#: recordings of protocol version 1), channel i > 0 adds ``ch{i}_`` in front.
CHANNEL_COLUMNS = ["pressure_Pa", "pressure_adc", "inlet_pwm", "bleed_pwm", "mode", "faults", "reference_Pa",
                   "surface_Pa"]


#: The load cell's column, last, when the telemetry carries a force. [N]
FORCE_COLUMN = "force_N"


def channel_columns(n_channels: int, force: bool = False) -> list[str]:
    """The columns of a recording of ``n_channels`` channels (:data:`COLUMNS` first).

    Parameters
    ----------
    n_channels : int
        Channels in the telemetry (1..3). [-]
    force : bool, default False
        The telemetry carries a load cell's force: :data:`FORCE_COLUMN` comes last. [-]
    """
    return COLUMNS + [f"ch{i}_{c}" for i in range(1, n_channels) for c in CHANNEL_COLUMNS] + (
        [FORCE_COLUMN] if force else [])


def _fsync_dir(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _atomic_parquet(table: pa.Table, path: Path) -> None:
    import pyarrow.parquet as pq  # deferred on purpose: pyarrow
    tmp = path.with_name(f".{path.name}.tmp")
    with open(tmp, "wb") as fh:
        pq.write_table(table, fh)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)
    _fsync_dir(path.parent)



def _write_part(journal: Path, stem: str, index: int, trial: int, columns: list, rows: list, meta: dict) -> None:
    """One completed run of a characterization, atomically (:func:`_atomic_parquet`): complete or absent.

    Written as ``part-<stem><index>-trial<trial>.parquet`` in ``journal``, ``meta`` in the file's metadata; the
    stem tells the runs apart (``load``: an isotonic load step, ``length``: an isometric held length).
    """
    import pandas as pd  # deferred on purpose: pandas (0.25 s)
    import pyarrow as pa  # deferred on purpose: pyarrow

    table = pa.Table.from_pandas(pd.DataFrame(rows, columns=columns), preserve_index=False)
    table = table.replace_schema_metadata({b"mckibben": json.dumps(meta).encode()})
    _atomic_parquet(table, Path(journal) / f"part-{stem}{index:03d}-trial{trial:02d}.parquet")


def _done_parts(journal: Path, stem: str) -> dict:
    """(index, trial) → path of the completed runs of one stem (:func:`_write_part`) in a journal."""
    pat = re.compile(rf"part-{re.escape(stem)}(\d+)-trial(\d+)\.parquet")
    out = {}
    for f in sorted(Path(journal).glob(f"part-{stem}*-trial*.parquet")):
        m = pat.fullmatch(f.name)
        if m:
            out[(int(m.group(1)), int(m.group(2)))] = f
    return out


def _read_parts(journal: Path, stem: str, columns: list, index_column: str):
    """Every completed run of one stem in a journal, in protocol order (index, trial, step): one DataFrame."""
    import pandas as pd  # deferred on purpose: pandas (0.25 s)

    parts = _done_parts(journal, stem)
    if not parts:
        return pd.DataFrame(columns=columns)
    df = pd.concat([pd.read_parquet(parts[k]) for k in sorted(parts)], ignore_index=True)
    return df.sort_values([index_column, "trial", "step"], kind="stable").reset_index(drop=True)


@dataclass
class Recorder:
    """Parse telemetry bytes and journal them to disk.

    Parameters
    ----------
    out : Path
        The final Parquet file; the journal is ``out`` + ``.journal``.
    meta : dict
        Provenance stored with the data (port, baud, ...).
    pa_per_count : float
        Transducer scale. [Pa/count]
    nominal_length : float
        Muscle rest length, for ``length_m``. [m]
    encoder_resolution : float
        Belt travel per encoder count. [m]
    flush_interval : float
        Longest time between journal parts. [s]
    """

    out: Path
    meta: dict = field(default_factory=dict)
    pa_per_count: float = HW.PA_PER_COUNT
    nominal_length: float = 0.097
    encoder_resolution: float = HW.ENCODER_RESOLUTION
    flush_interval: float = 0.2
    n_channels: int | None = None
    has_force: bool | None = None
    parser: P.Parser = field(default_factory=P.Parser)
    rows: list = field(default_factory=list)
    part: int = 0
    written: int = 0
    last: P.Telemetry | None = None
    _t_wrap: int = 0
    _t_prev: int | None = None
    _flushed_at: float = field(default_factory=time.monotonic)

    def __post_init__(self):
        self.out = Path(self.out)
        self.journal = Path(str(self.out) + ".journal")
        if self.out.suffix.lower() != ".parquet":
            raise InputError(f"out: {str(self.out)!r} must end in .parquet")
        if not self.out.parent.is_dir():
            raise InputError(f"out: folder {str(self.out.parent)!r} does not exist")
        if self.journal.exists():
            raise InputError(f"out: a journal {str(self.journal)!r} is already there; recover it or remove it")
        try:
            self.journal.mkdir()
        except OSError as exc:
            raise InputError(f"out: cannot write in {str(self.out.parent)!r} ({exc.strerror})") from None
        info = {**self.meta, "protocol_version": P.VERSION, "pa_per_count": self.pa_per_count,
                "nominal_length_m": self.nominal_length, "encoder_resolution_m": self.encoder_resolution}
        tmp = self.journal / ".meta.json.tmp"
        tmp.write_text(json.dumps(info))
        os.replace(tmp, self.journal / "meta.json")
        _fsync_dir(self.journal)

    def feed(self, data: bytes) -> list:
        """Parse bytes; journal when the interval has passed. Returns the frames parsed.

        Parameters
        ----------
        data : bytes
            Bytes from the link. [-]
        """
        frames = self.parser.feed(data)
        for f in frames:
            if isinstance(f, P.Telemetry):
                if self._t_prev is not None and f.t_us < self._t_prev and self._t_prev - f.t_us > 2**31:
                    self._t_wrap += 2**32
                self._t_prev = f.t_us
                self.last = f
                row = [f.seq, (f.t_us + self._t_wrap) * 1e-6, HW.adc_pressure(f.pressure_adc, self.pa_per_count, 0.0),
                       f.pressure_adc, f.encoder,
                       HW.encoder_length(f.encoder, self.nominal_length, self.encoder_resolution),
                       f.inlet_pwm, f.bleed_pwm, f.mode, f.faults, float(f.reference_pa), float(f.surface_pa)]
                if self.n_channels is None:
                    self.n_channels = len(f.channels)
                    self.has_force = f.force is not None
                for c in f.channels[1:self.n_channels]:
                    row += [HW.adc_pressure(c.pressure_adc, self.pa_per_count, 0.0), c.pressure_adc, c.inlet_pwm,
                            c.bleed_pwm, c.mode, c.faults, float(c.reference_pa), float(c.surface_pa)]
                if self.has_force:
                    row.append(f.force)
                if len(row) != len(channel_columns(self.n_channels, bool(self.has_force))) or None in row:
                    self.parser.corrupt += 1  # a frame with fewer channels than the recording's
                    continue
                self.rows.append(tuple(row))
        if time.monotonic() - self._flushed_at >= self.flush_interval:
            self.flush()
        return frames

    def flush(self) -> None:
        """Write the rows received since the last part as a new journal part."""
        import pyarrow as pa  # deferred on purpose: pyarrow
        import pandas as pd  # deferred on purpose: pandas (0.25 s)
        self._flushed_at = time.monotonic()
        if not self.rows:
            return
        df = pd.DataFrame(self.rows, columns=channel_columns(self.n_channels or 1, bool(self.has_force)))
        self.rows = []
        self.part += 1
        table = pa.Table.from_pandas(df, preserve_index=False)
        table = table.replace_schema_metadata({b"counters": json.dumps(self.parser.counters()).encode()})
        _atomic_parquet(table, self.journal / f"part-{self.part:06d}.parquet")
        self.written += len(df)

    def close(self) -> pd.DataFrame:
        """Flush, join the journal into ``out`` and remove the journal; returns the data."""
        self.flush()
        return recover(self.journal, self.out, counters=self.parser.counters())


def recover(journal: str | Path, out: str | Path, counters: dict | None = None) -> pd.DataFrame:
    """Join a journal's parts into one Parquet file (atomically), then remove the journal.

    Parameters
    ----------
    journal : str or Path
        The ``*.journal`` folder.
    out : str or Path
        The Parquet file to write.
    counters : dict, optional
        Parser counters to store (default: those of the last part).
    """
    import pyarrow as pa  # deferred on purpose: pyarrow
    import pandas as pd  # deferred on purpose: pandas (0.25 s)
    import pyarrow.parquet as pq  # deferred on purpose: pyarrow
    journal, out = Path(journal), Path(out)
    meta_file = journal / "meta.json"
    if not journal.is_dir() or not meta_file.exists():
        raise InputError(f"{str(journal)!r} is not a recorder journal (no meta.json)")
    if out.suffix.lower() != ".parquet":
        raise InputError(f"out: {str(out)!r} must end in .parquet")
    if not out.parent.is_dir():
        raise InputError(f"out: folder {str(out.parent)!r} does not exist")
    try:
        meta = json.loads(check_input_file(meta_file, None, "journal metadata file").read_text())
    except (OSError, ValueError):
        raise InputError(f"{str(meta_file)!r}: unreadable journal metadata") from None
    parts = sorted(p for p in journal.glob("part-*.parquet") if p.is_file())  # never open a FIFO
    tables = []
    for p in parts:
        try:
            tables.append(pq.read_table(p))
        except Exception:
            raise InputError(f"{str(p)!r}: unreadable journal part") from None
    if counters is None and tables:
        counters = json.loads((tables[-1].schema.metadata or {}).get(b"counters", b"{}"))
    df = pd.concat([t.to_pandas() for t in tables], ignore_index=True) if tables else pd.DataFrame(columns=COLUMNS)
    table = pa.Table.from_pandas(df, preserve_index=False)
    table = table.replace_schema_metadata({b"mckibben": json.dumps({**meta, "counters": counters or {}}).encode()})
    try:
        _atomic_parquet(table, out)
    except OSError as exc:
        raise InputError(f"out: cannot write {str(out)!r} ({exc.strerror})") from None
    for p in parts:
        p.unlink()
    meta_file.unlink()
    try:
        journal.rmdir()
    except OSError:
        pass
    return df


def read_recording(path: str | Path) -> tuple[pd.DataFrame, dict]:
    """A recording and its metadata (``read_*`` returns ``(data, metadata)``).

    Parameters
    ----------
    path : str or Path
        A Parquet file written by the recorder.
    """
    import pyarrow.parquet as pq  # deferred on purpose: pyarrow
    try:
        table = pq.read_table(path)
    except Exception as exc:
        raise InputError(f"{str(path)!r}: not a readable recording ({exc})") from None
    meta = json.loads((table.schema.metadata or {}).get(b"mckibben", b"{}"))
    return table.to_pandas(), meta

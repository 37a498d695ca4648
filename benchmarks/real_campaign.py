"""Which real isometric campaign the real-data benchmarks read: the one home of that choice.

``bench_real_models.py``, ``bench_hysteresis.py`` and ``bench_hysteresis_gap.py`` read a lab's isometric
campaign in the format of ``../shared/data/real/festo10_isometric.csv`` (:data:`DEFAULT`; columns
cut_length_cm, rest_length_mm, free_length_620kPa_mm, held_length_mm, trial, phase, pressure_kPa,
force_N, n_samples; PROVENANCE.md there). :func:`parse` takes ``--data PATH`` and
``--outer-diameter-mm D`` off a command line; :func:`rail_floor` and :func:`trials` read from the data
what the scripts once wrote as constants: the load cell's floor and the fitted / held-out trials.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from mckibben.data import read_table
from mckibben.data.preprocessing import find_rails

#: The campaign read when ``--data`` is not given (beside the repository, not bundled: absent on CI).
DEFAULT = Path(__file__).resolve().parents[2] / "shared/data/real/festo10_isometric.csv"

_SUFFIX = "_isometric"


@dataclass(frozen=True)
class Campaign:
    """One campaign: its file, its muscles' outer diameter and its name.

    ``name`` is the file's stem without a trailing ``_isometric`` (``festo10``): the family's id and
    the prefix of the muscles' ids (``f"{name}-{cut}cm"``).
    """

    path: Path
    outer_diameter_mm: float
    name: str


def _take(argv: list[str], flag: str) -> tuple[list[str], str | None]:
    """``argv`` without ``flag VALUE`` / ``flag=VALUE``, and VALUE (the last one given; None: absent)."""
    rest: list[str] = []
    value = None
    i = 0
    while i < len(argv):
        a = argv[i]
        if a == flag:
            if i + 1 >= len(argv):
                raise SystemExit(f"{flag}: a value is needed after it")
            value, i = argv[i + 1], i + 2
            continue
        if a.startswith(flag + "="):
            value = a[len(flag) + 1:]
        else:
            rest.append(a)
        i += 1
    return rest, value


def parse(argv: list[str]) -> tuple[list[str], Campaign]:
    """Consume ``--data PATH`` and ``--outer-diameter-mm D`` (either as ``--flag=value``) from ``argv``.

    Without ``--data``, :data:`DEFAULT` (which may be absent: the scripts then skip). A ``--data``
    file that does not exist is an error. The outer diameter [mm] is the flag's, else the number
    before ``_isometric`` in the file's name (``festo20_isometric.csv``: 20), else an error.

    Returns
    -------
    remaining : list of str
        ``argv`` without those flags and their values.
    campaign : Campaign
    """
    rest, data = _take(list(argv), "--data")
    rest, od = _take(rest, "--outer-diameter-mm")
    path = DEFAULT if data is None else Path(data)
    if data is not None and not path.is_file():
        raise SystemExit(f"--data: {path} does not exist (or is not a file)")
    stem = path.stem
    name = stem[: -len(_SUFFIX)] if stem.endswith(_SUFFIX) and len(stem) > len(_SUFFIX) else stem
    if od is None:
        m = re.search(r"(\d+)" + _SUFFIX, path.name)
        if m is None:
            raise SystemExit(f"--outer-diameter-mm: give the muscles' outer diameter in mm; the file name {path.name!r} "
                             f"does not say it (only a name like festo20{_SUFFIX}.csv does)")
        od = m.group(1)
    try:
        diameter = float(od)
    except ValueError:
        diameter = float("nan")
    if not (math.isfinite(diameter) and diameter > 0):
        raise SystemExit(f"--outer-diameter-mm: {od!r} is not a positive number of millimetres")
    return rest, Campaign(path=path, outer_diameter_mm=diameter, name=name)


def rail_floor(path: Path) -> float | None:
    """The load cell's floor [N]: the campaign's lowest force if it is a rail, else None (no rail).

    The library's rule (:func:`mckibben.data.preprocessing.find_rails`: the lowest value repeated on
    ``RAIL_MIN_ROWS`` rows or more), on the whole campaign read as a family. Festo 10 mm: −8.735 N.
    """
    table = read_table(path, "isometric", None, {"phase": "direction", "cut_length_cm": "muscle"})
    _, report = find_rails(table, ("force",))
    low = [r["value"] for r in report["rails"] if r["side"] == "low"]
    return low[0] if low else None


def trials(d: pd.DataFrame) -> tuple[tuple[int, ...], int]:
    """The fitted trials and the held-out one: every trial but the last, and the last (8, 9 and 10)."""
    ts = sorted(int(t) for t in d["trial"].unique())
    if len(ts) < 2:
        raise SystemExit(f"the campaign holds {len(ts)} trial(s): at least two are needed (fit and held out)")
    return tuple(ts[:-1]), ts[-1]

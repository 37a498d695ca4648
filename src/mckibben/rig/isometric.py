"""The isometric runs of a characterization protocol: the muscle held at a length, pressure up and down.

A protocol's ``[isometric]`` section (:func:`mckibben.rig.characterize.read_protocol`) lists held
lengths; on a rig with a load cell (its HELLO announces one) each length and trial is one run, after
the isotonic runs: the load cell tared (the weight off, the end free, the muscle vented), the end
clamped at the length (the operator is asked; unattended, the bench side channel's ``hold``), the
pressure set-point stepped up the protocol's pressures and back down with the isotonic sweep's rules
(its ``ramp``, its safety checks), each step held until the *force* settles, one sample kept (the
mean pressure and the tared force over the settling window), the end released at the end. Every
completed run is written to the run's journal at once, atomically, as
``part-length<i>-trial<t>.parquet`` (the isotonic parts are ``part-load<i>-trial<t>.parquet``: the
two never collide, and a journal from before the isometric runs resumes as it did); ``resume`` goes
on with the runs not in it. :func:`write_isometric_table` writes ``OUT/isometric.csv``, the project's
``isometric`` table kind (:func:`mckibben.data.read_table`, ``mckibben fit``), and
:func:`compare_run` scores every force law on it held out (:func:`mckibben.fit.registry.compare_table`);
:func:`fit_isometric_only` writes the muscle file from its best law when the protocol has no
isotonic runs. See ``docs/rig.md``.

This module sits below :mod:`mckibben.rig.characterize`, which runs it: the isotonic runner's own
safety steps (vent, tare, ramp, the leak and stuck-sensor check) come in as :class:`Tools`, so each
lives in one place.
"""

from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from mckibben import hardware as HW
from mckibben.atomic import atomic_file
from mckibben.data.muscle_file import read_muscle
from mckibben.data.tables import read_table
from mckibben.errors import InputError
from mckibben.fit.isometric import fit_isometric
from mckibben.fit.muscle_file import muscle_file_text
from mckibben.fit.registry import compare_table
from mckibben.results import write_table
from mckibben.rig import recorder as REC

__all__ = ["ISO_COLUMNS", "Tools", "check_isometric", "collect_isometric", "compare_run", "fit_isometric_only",
           "held_steps", "held_sweep", "run_isometric", "write_isometric_table"]

#: The columns of an isometric journal part (one row per settled step). ``force_N`` is the load cell's mean over
#: the settling window less the run's tare ``force_offset_N``; ``length_m`` the held length.
ISO_COLUMNS = ["length_index", "trial", "step", "length_m", "set_point_Pa", "pressure_Pa", "force_N", "direction",
               "settled", "time_s", "pressure_max_Pa", "force_offset_N"]


@dataclass(frozen=True)
class Tools:
    """The isotonic runner's steps an isometric run shares (:mod:`mckibben.rig.characterize`).

    Attributes
    ----------
    tare : callable
        ``tare(session, protocol)``: the load cell's zero, vented (:func:`~mckibben.rig.characterize._tare`). [N]
    check_reached : callable
        ``check_reached(session, target, p_before, window_rows, start)``: stop on a leak or a stuck sensor. [-]
    ramp : callable
        ``ramp(session, start, target, rate)``: the rate-limited set-point ramp. [-]
    """

    tare: Callable
    check_reached: Callable
    ramp: Callable


def held_sweep(proto) -> list[tuple[float, str]]:
    """One isometric sweep's steps: ``(pressure [Pa], "inflate"|"deflate")``, up the protocol's isometric
    pressures and back down.

    Parameters
    ----------
    proto : Protocol
        The protocol (:func:`mckibben.rig.characterize.read_protocol`). [-]
    """
    ps = tuple(proto.iso_pressures)
    return [(p, "inflate") for p in ps] + [(p, "deflate") for p in reversed(ps[:-1])]


def held_steps(proto) -> list[tuple[int, int, float]]:
    """Every isometric run in order: ``(length index, trial (1-based), held length [m])``.

    Parameters
    ----------
    proto : Protocol
        The protocol. [-]
    """
    return [(i, t, ell) for i, ell in enumerate(proto.lengths) for t in range(1, proto.trials + 1)]


def done_parts(journal: Path) -> dict:
    """(length index, trial) → path of the completed isometric runs in a journal.

    Parameters
    ----------
    journal : pathlib.Path
        The run's ``steps.journal`` folder. [-]
    """
    return REC._done_parts(journal, "length")


def _line(proto, key: str) -> str:
    """``FILE:LINE: [isometric] key`` of a protocol (the line of the key in its text)."""
    lines = proto.text.splitlines()
    start = next((i for i, s in enumerate(lines) if re.match(r"^\s*\[\s*isometric\s*\]", s)), 0)
    at = next((i for i in range(start, len(lines)) if re.match(rf"^\s*{key}\s*=", lines[i])), start)
    return f"{proto.source}:{at + 1}: [isometric] {key}"


def check_isometric(proto, port: str, has_force: bool, bench=None, muscle_file=None) -> None:
    """Refuse an isometric protocol the rig cannot run, before anything moves.

    A device without a load cell; a held length longer than the muscle file's strand length
    ([mpam-characterization] eq. (1): l = Ls·cos θ ≤ Ls) or outside the muscle's travel on an
    emulated bench (each length clamped once and released, the muscle vented: the bench refuses a
    length past its end stops).

    Parameters
    ----------
    proto : Protocol
        The protocol. [-]
    port : str
        The device's port (for the message). [-]
    has_force : bool
        The device streams a load cell's force. [-]
    bench : Bench, optional
        The bench side channel (unattended). [-]
    muscle_file : str or os.PathLike, optional
        The muscle under test. [-]

    Raises
    ------
    InputError
        One line naming the protocol's line and the reason.
    """
    if not proto.lengths:
        return
    if not has_force:
        raise InputError(f"{_line(proto, 'lengths')}: the device on {port} streams no force (no load cell): "
                         "isometric runs need one (a firmware built for a load cell, docs/rig.md), or remove "
                         "the [isometric] section")
    if muscle_file is not None:
        ls = read_muscle(muscle_file).strand_length
        long = [ell for ell in proto.lengths if ls is not None and ell > ls]
        if long:
            raise InputError(f"{_line(proto, 'lengths')}: {long[0] * 1e3:g} mm is longer than the muscle's strand "
                             f"length {ls * 1e3:g} mm (muscle file {muscle_file})")
    if bench is not None:
        for ell in proto.lengths:
            try:
                bench.hold(ell)
            except InputError as exc:
                raise InputError(f"{_line(proto, 'lengths')}: {ell * 1e3:g} mm: {exc}") from None
            finally:
                bench.release()


def _settle_force(s, proto, start: int) -> tuple[bool, np.ndarray]:
    """Hold ``iso_hold``, then until the force's means over the two halves of the last window differ by less than
    ``iso_tolerance`` (or the timeout); ``(settled, the window's rows)``."""
    s.wait(proto.iso_hold)

    def window() -> np.ndarray:
        t_now = s.rows[-1][0]
        return np.array([r for r in s.rows[start:] if r[0] >= t_now - proto.window], dtype=float)

    def settled() -> bool:
        if s.rows[-1][0] - s.rows[start][0] < proto.iso_hold + proto.window:
            return False
        f = window()[:, 7]
        half = len(f) // 2
        return half >= 1 and abs(float(f[half:].mean()) - float(f[:half].mean())) <= proto.iso_tolerance

    t_start = s.rows[start][0]
    ok = settled()
    while not ok and s.rows[-1][0] - t_start < proto.timeout:
        s.wait(proto.window / 2)
        ok = settled()
    return ok, window()


def _run_held_sweep(s, proto, tools: Tools, index: int, trial: int, length: float, tare: float, progress) -> list:
    """One held length's sweep, up then down; the rows of its steps (:data:`ISO_COLUMNS`).

    The end must stay where it was clamped: an encoder that moves by more than the settling rule's
    length ``tolerance`` during a step (the clamp let go) stops the run, vented."""
    rows = []
    clamped = s.rows[-1][2]  # the encoder's count at the clamp
    p_before = float(np.mean([r[1] for r in s.rows[-10:]]))
    previous = 0.0  # the sweep starts vented
    for k, (target, direction) in enumerate(held_sweep(proto)):
        start = len(s.rows)
        if proto.ramp:
            tools.ramp(s, previous, target, proto.ramp)
        s.set_point(target)
        s.wait(0.0)
        previous = target
        ok, win = _settle_force(s, proto, start)
        moved = float(np.max(np.abs(np.array([r[2] for r in s.rows[start:]], dtype=float) - clamped)))
        if moved * HW.ENCODER_RESOLUTION > proto.tolerance:
            raise s.stop(f"the held end moved {moved * HW.ENCODER_RESOLUTION * 1e3:.2f} mm from its clamp at "
                         f"{length * 1e3:.2f} mm (the clamp let go)")
        tools.check_reached(s, target, p_before, win, start)
        p_mean = float(win[:, 1].mean())
        rows.append((index, trial, k, length, target, p_mean, float(win[:, 7].mean()) - tare, direction, bool(ok),
                     float(win[-1, 0]), float(np.array(s.rows[start:], dtype=float)[:, 1].max()), tare))
        p_before = p_mean
        progress()
    return rows


def _write_part(journal: Path, index: int, trial: int, rows: list, meta: dict) -> None:
    """One completed isometric run, atomically: complete or absent (the recorder's journal discipline)."""
    REC._write_part(journal, "length", index, trial, ISO_COLUMNS, rows, meta)


def run_isometric(s, proto, journal, tools: Tools, bench=None, ask=None, tell=None) -> list[dict]:
    """Run the protocol's isometric runs not yet in the journal; journal each; return the tares.

    For each held length and trial: the weight off and the end free (the operator is asked, or the
    bench's ``load 0``/``release``), the load cell tared vented (``tools.tare``), the end clamped at
    the length (asked, or the bench's ``hold``), the set-point stepped up the isometric pressures and
    back down (the protocol's ``ramp`` between steps), each step held ``iso_hold`` and then until the
    force settles (:func:`_settle_force`), the leak / stuck-sensor check of every isotonic step; the
    set-point back to 0 and the run's part written. The end is released after the last run
    (unattended; the operator unclamps it).

    Parameters
    ----------
    s : mckibben.rig.characterize._Session
        The run's connection (its set-point gate holds the maximum; every frame is checked). [-]
    proto : Protocol
        The protocol. [-]
    journal : pathlib.Path
        The run's ``steps.journal`` folder. [-]
    tools : Tools
        The isotonic runner's shared steps. [-]
    bench : Bench, optional
        The bench side channel (unattended); without it the operator is asked. [-]
    ask : callable, optional
        ``ask(text)``: the operator's prompt (default ``input``). [-]
    tell : callable, optional
        The progress callback of :func:`mckibben.rig.characterize.run_protocol` (``("length", length=,
        trial=)``, ``("step",)``). [-]

    Returns
    -------
    list of dict
        One per run made: ``length_index``, ``trial``, ``force_offset_N`` (the tare). [-]
    """
    ask = ask if ask is not None else input
    tell = tell if tell is not None else (lambda *a, **k: None)
    done = done_parts(journal)
    todo = [(i, t, ell) for i, t, ell in held_steps(proto) if (i, t) not in done]
    tares = []
    for index, trial, length in todo:
        tell("length", length=length, trial=trial)
        if bench is not None:
            bench.release()
            bench.load(0.0)
        else:
            ask("take the weight off channel 0 and free its end (the load cell is tared at zero force), then Enter "
                "(Ctrl-C stops safely) ")
        tare = tools.tare(s, proto)
        tares.append({"length_index": index, "trial": trial, "force_offset_N": tare})
        if bench is not None:
            bench.hold(length)
        else:
            ask(f"clamp channel 0's end at {length * 1e3:.2f} mm for trial {trial}, then Enter (Ctrl-C stops safely) ")
        s.wait(proto.window)
        rows = _run_held_sweep(s, proto, tools, index, trial, length, tare, lambda: tell("step"))
        s.set_point(0.0)
        _write_part(journal, index, trial, rows, {"max_pressure_Pa": s.max_pressure, "force_offset_N": tare})
    if bench is not None and todo:
        bench.release()
    return tares


def collect_isometric(out):
    """Every completed isometric run of a run's journal, in protocol order (one row per settled step).

    Parameters
    ----------
    out : str or os.PathLike
        The run's folder. [-]

    Returns
    -------
    pandas.DataFrame
        :data:`ISO_COLUMNS`. [-]
    """
    return REC._read_parts(Path(out) / "steps.journal", "length", ISO_COLUMNS, "length_index")


def write_isometric_table(out, steps, meta: dict) -> str | None:
    """``OUT/isometric.csv``: the project's ``isometric`` kind (held length, pressure, tared force, direction,
    trial), with the run's provenance beside it; None without isometric steps.

    Parameters
    ----------
    out : str or os.PathLike
        The run's folder. [-]
    steps : pandas.DataFrame
        :func:`collect_isometric`. [-]
    meta : dict
        The run's provenance (:func:`mckibben.rig.characterize.run_protocol`). [-]
    """
    import pandas as pd  # deferred on purpose: pandas (0.25 s)

    if not len(steps):
        return None
    df = pd.DataFrame({"held_length_mm": steps["length_m"].to_numpy(float) * 1e3,
                       "pressure_MPa": steps["pressure_Pa"].to_numpy(float) / 1e6,
                       "force_N": steps["force_N"].to_numpy(float),
                       "direction": steps["direction"].astype(str).to_numpy(),
                       "trial": steps["trial"].to_numpy(int)})
    prov = {k: v for k, v in meta.items() if k != "protocol_text"}
    return write_table(df, Path(out) / "isometric.csv", {**prov, "kind": "isometric", "force": "tared at the start "
                                                         "of each run (load_cell_tares)"})


def compare_run(out, muscle_file) -> dict:
    """Every force law fitted to ``OUT/isometric.csv`` and scored held out, one held length out at a time
    (:func:`mckibben.fit.registry.compare_table`, the table's force already tared).

    Parameters
    ----------
    out : str or os.PathLike
        The run's folder. [-]
    muscle_file : str or os.PathLike
        The muscle under test. [-]

    Returns
    -------
    dict
        The comparison's summary (``best``, ``cv``, ``models`` with each one's held-out RMSE [N]...). [-]
    """
    return compare_table(str(Path(out) / "isometric.csv"), muscle=str(muscle_file)).to_dict()


def fit_isometric_only(out, muscle_file) -> dict:
    """A protocol with isometric runs only: its comparison's best law fitted to ``OUT/isometric.csv``
    (:func:`mckibben.fit.isometric.fit_isometric`) and written to ``OUT/muscle.toml``.

    Parameters
    ----------
    out : str or os.PathLike
        The run's folder. [-]
    muscle_file : str or os.PathLike
        The muscle under test (its geometry). [-]

    Returns
    -------
    dict
        ``source`` ("isometric"), ``best``, ``best_cv_rmse_N``, ``muscle_file``, ``parameters``, ``stderr``,
        ``valid_range`` (SI), ``isometric`` (:func:`compare_run`). [-]
    """
    out = Path(out)
    spec = read_muscle(muscle_file)
    cmp = compare_run(out, muscle_file)
    best = cmp.get("best")
    if not best:
        raise InputError(f"out: {out}: no force law could be fitted to the isometric runs")
    fit = fit_isometric(read_table(out / "isometric.csv", "isometric"), spec, best)
    target = out / "muscle.toml"
    text = muscle_file_text(dataclasses.replace(spec, path=str(target)), fit)
    with atomic_file(target, "out") as tmp:
        Path(tmp).write_text(text, encoding="utf-8")
    r = fit.result
    score = next((m for m in cmp.get("models", []) if m.get("model") == best), {})
    return {"source": "isometric", "best": best, "best_cv_rmse_N": score.get("cv_rmse_N"),
            "muscle_file": str(target), "parameters": dict(zip(r.names, (float(v) for v in r.values))),
            "stderr": {n: float(v) for n, v in zip(r.names, r.stderr)},
            "valid_range": {k: [float(a), float(b)] for k, (a, b) in r.valid_range.items()}, "isometric": cmp}


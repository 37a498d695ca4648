"""A SYNTHETIC isometric campaign of a commercial-size muscle (10 mm class, 300 mm long).

No measured commercial-muscle data ship with mckibben; this campaign exercises the isometric
path (``fit``, ``compare --cv``, ``reproduce``) the way a lab's file would: it is generated from a
physical "truth" that none of the fitted models is, with the flaws of real recordings
(``/work/shared/notes/lab-data.md``). **It is not a measurement.**

Truth (:func:`true_force`)
--------------------------
The Tsagarakis–Caldwell/Davis wall-corrected braid force (:func:`mckibben.models.physical.wall_corrected_force`)
of a braid with θ0 = 22°, braid diameter 11 mm at rest (D0 = 29.4 mm), wall 1.5 mm, with three
things a real muscle adds and no fitted model has:

- an opening pressure: the braid takes load only above P_open = 15 kPa (the tube must first
  touch the braid), P_eff = P − P_open·(1 − exp(−P/P_open));
- rubber elasticity resisting contraction: − E·ε with E = 800 N per unit contraction ε = 1 − L/L0,
  which brings the free contraction at 620 kPa near 25 % (a Festo muscle's specification);
- friction hysteresis: the deflate branch pulls more, ± 3 % of the blocked force at 620 kPa,
  shaped 4x(1 − x), x = P/620 kPa;

and a slack muscle pulls nothing (F = max(F, 0)).

Recording
---------
Held lengths at 0, 25, 50, 75 % of the way from L0 to the free length at 620 kPa; pressure set
points 0 → 620 kPa in 16 steps and back; 3 trials per held length (12 runs). Each run has its
own load-cell zero (common 2 N + N(0, 1.5 N) per run: offsets not removed), force noise
σ = 0.4 N read to 0.1 N, pressure read with σ = 1 kPa to 1 kPa.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from pathlib import Path

import numpy as np

from mckibben.models.physical import BraidGeometry, wall_corrected_force

if TYPE_CHECKING:  # annotations only; the modules are imported where used (deferred)
    import pandas as pd

#: Where the bundled campaign lives (package data).
BUNDLED_ISOMETRIC = Path(__file__).with_name("isometric")

MUSCLE_ID = "commercial10"
L0 = 0.300  #: nominal length [m]
OUTER_DIAMETER = 0.012  #: measured outer diameter [m]
THETA0 = float(np.deg2rad(22.0))  #: braid angle at rest [rad]
BRAID_DIAMETER = 0.011  #: braid diameter at rest [m]
WALL = 1.5e-3  #: tube wall [m]
P_OPEN = 15e3  #: opening pressure [Pa]
ELASTIC = 800.0  #: rubber force per unit contraction [N]
HYSTERESIS = 0.03  #: deflate − inflate half-width, fraction of the blocked force at P_TOP [-]
P_TOP = 620e3  #: highest pressure [Pa]
N_STEPS = 16  #: pressure set points up (and back down) [-]
N_TRIALS = 3
ZERO_COMMON = 2.0  #: load-cell zero common to all runs [N]
ZERO_SD = 1.5  #: run-to-run load-cell zero scatter [N]
FORCE_NOISE_SD = 0.4  #: force noise [N]
FORCE_STEP = 0.1  #: load-cell resolution [N]
PRESSURE_NOISE_SD = 1e3  #: pressure noise [Pa]
PRESSURE_RESOLUTION = 1e3  #: transducer resolution [Pa]
HELD_FRACTIONS = (0.0, 0.25, 0.5, 0.75)


def _geometry() -> BraidGeometry:
    return BraidGeometry.from_initial(L0, BRAID_DIAMETER, THETA0, WALL)


def true_force(pressure, length, direction="inflate"):
    """The truth's force (before the load cell): see the module notes.

    Parameters
    ----------
    pressure : array_like
        Gauge pressure. [Pa]
    length : array_like
        Held length. [m]
    direction : str or array_like, default "inflate"
        ``"inflate"`` or ``"deflate"``. [-]

    Returns
    -------
    numpy.ndarray
        Force, 0 where slack. [N]
    """
    p = np.asarray(pressure, dtype=float)
    ell = np.asarray(length, dtype=float)
    p_eff = p - P_OPEN * (1.0 - np.exp(-p / P_OPEN))
    eps = 1.0 - ell / L0
    f = wall_corrected_force(p_eff, ell, _geometry()) - ELASTIC * eps
    x = np.clip(p / P_TOP, 0.0, 1.0)
    blocked = float(wall_corrected_force(P_TOP - P_OPEN, L0, _geometry()))
    sign = np.where(np.asarray(direction) == "deflate", 1.0, -1.0)
    f = f + sign * HYSTERESIS * blocked * 4.0 * x * (1.0 - x)
    return np.maximum(f, 0.0)


def free_length(pressure=P_TOP) -> float:
    """Length where the truth's inflate force is zero at a pressure (bisection). [m]

    Parameters
    ----------
    pressure : float, default 620 kPa
        Gauge pressure. [Pa]
    """
    lo, hi = 0.55 * L0, L0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if true_force(pressure, mid) > 0:
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


def held_lengths() -> np.ndarray:
    """The held lengths: 0, 25, 50, 75 % of the way from L0 to the free length at 620 kPa. [m]"""
    lf = free_length()
    return np.array([L0 - f * (L0 - lf) for f in HELD_FRACTIONS])


def isometric_campaign(seed: int = 0, n_trials: int = N_TRIALS, lengths=None, n_steps: int = N_STEPS) -> pd.DataFrame:
    """One synthetic isometric table in file units (``held_length_mm``, ``pressure_kPa``, ``force_N``).

    Parameters
    ----------
    seed : int, default 0
        Random seed. [-]
    n_trials : int, default 3
        Trials per held length. [-]
    lengths : array_like, optional
        Held lengths (default :func:`held_lengths`). [m]
    n_steps : int, default 16
        Pressure set points from 0 to 620 kPa. [-]

    Returns
    -------
    pandas.DataFrame
        Columns ``held_length_mm``, ``pressure_kPa``, ``force_N``, ``direction``, ``trial``,
        ``muscle``.
    """
    import pandas as pd  # deferred on purpose: pandas (0.25 s)
    rng = np.random.default_rng(seed)
    lengths = held_lengths() if lengths is None else np.asarray(lengths, dtype=float)
    up = np.linspace(0.0, P_TOP, n_steps)
    frames = []
    for ell in lengths:
        for trial in range(1, n_trials + 1):
            zero = ZERO_COMMON + rng.normal(0.0, ZERO_SD)
            for direction, sets in (("inflate", up), ("deflate", up[::-1][1:])):
                p = np.maximum(sets + rng.normal(0.0, PRESSURE_NOISE_SD, sets.size), 0.0)
                f = true_force(p, ell, direction) + zero + rng.normal(0.0, FORCE_NOISE_SD, sets.size)
                frames.append(pd.DataFrame({
                    "held_length_mm": np.round(ell * 1e3, 2),
                    "pressure_kPa": np.round(p / PRESSURE_RESOLUTION) * PRESSURE_RESOLUTION / 1e3,
                    "force_N": np.round(f / FORCE_STEP) * FORCE_STEP,
                    "direction": direction, "trial": trial, "muscle": MUSCLE_ID}))
    return pd.concat(frames, ignore_index=True)


MUSCLE_TOML = (f'id = "{MUSCLE_ID}"\nnominal_length_mm = {L0 * 1e3:g}\nouter_diameter_mm = {OUTER_DIAMETER * 1e3:g}\n'
               'synthetic = true\nnotes = "SYNTHETIC commercial-size muscle (10 mm class): generated by '
               'mckibben.datasets.isometric (seed 0), not a measurement. Braid angle and strand length are not '
               'given, as for a commercial muscle."\n')

ISOMETRIC_README = """# SYNTHETIC isometric campaign of a commercial-size muscle

**Generated, not measured.** `isometric.csv` is `mckibben.datasets.isometric.isometric_campaign(seed=0)`:
a 300 mm, 10 mm-class braided muscle held at four lengths (0, 25, 50, 75 % of the way to its free
length at 620 kPa), pressure stepped 0 → 620 kPa and back, three trials per length, load-cell
offsets NOT removed, quantized readings, friction hysteresis. The truth is a wall-corrected braid
force with an opening pressure and rubber elasticity (see the module's notes): none of the fitted
models. `muscle.toml` gives only what a commercial muscle's datasheet gives (id, nominal length,
outer diameter).

    mckibben fit isometric.csv --model spring --json
    mckibben compare isometric.csv --cv leave-one-length-out
"""


def write_isometric_campaign(folder, seed: int = 0) -> Path:
    """Write ``isometric.csv``, ``muscle.toml`` and ``README.md`` (SYNTHETIC) into a folder.

    Parameters
    ----------
    folder : str or pathlib.Path
        Target folder (created). [-]
    seed : int, default 0
        Random seed; the bundled copy is seed 0. [-]
    """
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    isometric_campaign(seed).to_csv(out / "isometric.csv", index=False)
    (out / "muscle.toml").write_text(MUSCLE_TOML, encoding="utf-8")
    (out / "README.md").write_text(ISOMETRIC_README, encoding="utf-8")
    return out

"""Static force models fitted to isometric tests: force(P, L) at held lengths, inflate and deflate.

Every model predicts the load-cell force at a held length L and gauge pressure P. Geometry the
muscle file does not give is fitted within physical bounds; geometry it gives is held fixed.

==========================  ===========================================================  ==========
model                       force                                                        fitted
==========================  ===========================================================  ==========
``chou-hannaford``          π·D0²·P/4·(3cos²θ − 1), cos θ = L·cos θ0/L0                 θ0, D0
``wall-corrected``          the same + π·P·[D0·t·(2 sin θ − 1/sin θ) − t²]              θ0, D0, t
``tondu-lopez``             π·r0²·(P − P_th)·[a(1 − kε)² − b], ε = 1 − L/L0              α0, r0, k, P_th
``spring``                  K(P, Ls)·Ls, Ls = L − Lu(P), K per direction ([wickramatunge2010], eq. 1–2)  h, c
``surface``                 Σ a_ij·P^i·ε^j (i ≤ 3, j ≤ 1) + deflate·(b0 + b1·P)         a, b
==========================  ===========================================================  ==========

Each law's fit spec (names, bounds, starts) lives in its file of :mod:`mckibben.models.laws`
and is read from there; ``wall-chou-hannaford`` is still read as the old name of ``wall-corrected``.

Every model but ``spring`` (whose stretch term already gives a force at zero pressure) also
fits ``offset_N``, the load cell's zero: a lab's force column is seldom tared
(``docs/data.md``). ``inflate`` rows are the spring model's ``elongation`` branch (the force rises
at a fixed length), ``deflate`` its ``contraction`` branch.

Physical bounds (``BOUNDS_NOTE``):

- braid angle at rest θ0 (α0 for Tondu–Lopez) in [1°, 54.7°): at 54.7° (cos²θ = 1/3) the ideal
  braid pulls nothing, beyond it it pushes; the strand length b = L0/cos θ0 ≥ L0 follows;
- D0 (the braid's diameter at 90°) within [0.5, 4] × the measured outer diameter: D0·sin θ0 is
  the braid diameter at rest, which is about the outer diameter, and θ0 ≥ 15° keeps D0 below
  4 × that;
- r0 (the braid radius at rest, an effective value) within [0.25, 1] × the outer diameter;
- wall thickness t within [0.01, 0.25] × the outer diameter; Tondu–Lopez k within [0.5, 5] and
  its pressure threshold P_th within [0, 0.5] × the highest measured pressure;
- offset within ± 10 % of the largest measured force for the physical laws (a load cell's
  plausible zero error; ± all of it for the others), flagged ``large_offset`` beyond 5 % of it;
- log-normal priors from the muscle file's outer diameter on θ0, D0, t and r0 (the laws' files);
- spring stiffness: K ≥ 0 is checked at every data point (``negative_stiffness`` flag), not
  forced by bounds, since single coefficients of K may be negative while K stays positive.

A fit at a bound, with R² < 0.5, an ill-conditioned covariance or a non-physical result carries
flags (:func:`mckibben.fit.core.fit_flags`); it is never silently wrong. Intervals are
cluster-robust by run (held length and trial): see :func:`fit_isometric`.

References
----------
Chou & Hannaford (1996); Tondu & Lopez (2000); Tsagarakis & Caldwell (2000), Davis et al. (2003):
:mod:`mckibben.models.physical`. Wickramatunge & Leephakpreeda (2010) [wickramatunge2010], eq. (1)–(2): :mod:`mckibben.models.spring`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from mckibben.data.preprocessing import RAIL_POLICIES, apply_pressure_zero, apply_tare, find_rails
from mckibben.data.muscle_file import MuscleSpec
from mckibben.data.tables import Table
from mckibben.data.schema import SCHEMAS
from mckibben.errors import InputError, check_instance, unknown_name
from mckibben.fit.core import (FitResult, bounded_fit, censor_hinge, data_range, heldout_flags, interpolated_rms,
                               linear_fit)
from mckibben.models import laws
from mckibben.models.flags import flag_names
from mckibben.models.law_statics import rising_root
from mckibben.models.threshold import (THRESHOLD_FRACTION, THRESHOLD_NAME, THRESHOLD_SUFFIX, split_threshold,
                                      with_threshold)
from mckibben.models.tube import TUBE_MAX_STRAIN, TUBE_NAME, with_tube
from mckibben.models.laws._base import OFFSET_FLAG, THETA_MAX, THETA_MIN, THETA_STARTS_DEG, FitSpec
from mckibben.models.laws.chou_hannaford import D0_FACTOR, WALL_FACTOR
from mckibben.models.laws.spring import NOMINAL_TOL, SPRING_NAMES, spring_model_of
from mckibben.models.laws.tondu_lopez import K_BOUNDS, R0_FACTOR
from mckibben.results import FitBase, Result, provenance
from mckibben.data.setpoints import set_point_groups
from dataclasses import replace

if TYPE_CHECKING:  # annotations only; the modules are imported where used (deferred)
    import pandas as pd

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["ALL_MODELS", "FAMILY_MODELS", "BOUNDS_NOTE", "CV_METHODS", "D0_FACTOR", "MUSCLE_MODELS", "IsometricFit",
           "K_BOUNDS", "ModelComparison",
           "NOMINAL_TOL", "OFFSET_FLAG", "R0_FACTOR", "SPRING_NAMES", "THETA_MAX", "THETA_MIN", "THETA_STARTS_DEG",
           "SAMPLES_COLUMN", "WALL_FACTOR", "ZEROS", "best_of", "compare_isometric", "fit_isometric", "fit_points", "fit_isotonic_law", "force_law", "law_length",
           "max_error", "parameter_names", "run_zeros", "zero_runs"]

BOUNDS_NOTE = ("theta0 in [1, 54.7) deg; D0 in [0.5, 4] x outer diameter; r0 in [0.25, 1] x outer diameter; "
               "wall in [0.01, 0.25] x outer diameter; k in [0.5, 5]; tondu-lopez p_th in [0, 0.5] x top pressure; "
               "|offset| <= 10 % of peak force (physical laws), peak force (others); spring K >= 0 checked")

#: The data-driven model: no physical law, not in the law registry (the plant cannot run it).
SURFACE = "surface"
#: The models of one muscle and one line each: every law of the registry with a fit spec
#: (:func:`mckibben.models.laws.fit_laws`) that describes one muscle, and the data-driven surface.
MUSCLE_MODELS = {**{n: law.description for n, law in laws.fit_laws(family=False).items()},
                SURFACE: "data-driven: cubic in pressure, linear in contraction, a deflate shift"}
#: The family laws (fitted across muscles of one type; on one muscle too, with ``fit --model``).
FAMILY_MODELS = {n: law.description for n, law in laws.fit_laws(family=True).items()}
#: Every model an isometric table is fitted with.
ALL_MODELS = {**MUSCLE_MODELS, **FAMILY_MODELS}


def model_name(model: str) -> str:
    """The registry name of a force model (old names read, with a deprecation warning).

    Parameters
    ----------
    model : str
        A key of :data:`ALL_MODELS` or an old alias (``wall-chou-hannaford``). [-]
    """
    if model == SURFACE or model in ALL_MODELS:
        return model
    if model in laws.ALIASES and laws.ALIASES[model] in ALL_MODELS:
        return laws.resolve(model)
    raise unknown_name("force model", model, ALL_MODELS)


def threshold_law(model: str, muscle: MuscleSpec) -> bool:
    """Whether a model may carry the threshold pressure (:mod:`mckibben.models.threshold`): a registered
    law without a threshold of its own (Tondu–Lopez's ``p_threshold_Pa``).

    Parameters
    ----------
    model : str
        A key of :data:`ALL_MODELS`. [-]
    muscle : MuscleSpec
        The muscle (the law's parameters for its geometry). [-]
    """
    return model_name(model) in laws.LAWS and not any(n.startswith("p_threshold") for n in parameter_names(model, muscle))


def _direction_flag(direction) -> np.ndarray:
    return (np.asarray(direction) == "deflate").astype(float)


#: The fitted vector as a SpringModel (the law file's :func:`~mckibben.models.laws.spring.spring_model_of`).
_spring_model = spring_model_of

#: No data: a spec built only for its names and force function (a saved law). [-]
_NO_DATA = (np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0, dtype=object))


def _spec(model: str, muscle: MuscleSpec, fmax: float, p, ell, f, direction, rest=None) -> FitSpec:
    """The law's own fit spec (:attr:`mckibben.models.laws.Law.fit_spec`), read, never copied."""
    data = {"pressure": p, "held_length": ell, "force": f, "direction": direction,
            "rest_length": np.full(np.size(p), muscle.nominal_length) if rest is None else rest}
    return laws.LAWS[model].fit_spec(muscle, fmax, data)


def _surface_terms(pressure, length, direction, l0):
    x = np.asarray(pressure, dtype=float) / 1e6
    e = 1.0 - np.asarray(length, dtype=float) / l0
    dfl = _direction_flag(direction) if direction is not None else np.zeros(np.shape(x))
    x, e, dfl = np.broadcast_arrays(x, e, dfl)
    return [x**3, x**2, x, np.ones_like(x), x**3 * e, x**2 * e, x * e, e, dfl, dfl * x]


SURFACE_NAMES = ("a30_N_per_MPa3", "a20_N_per_MPa2", "a10_N_per_MPa", "a00_N", "a31_N_per_MPa3", "a21_N_per_MPa2",
                 "a11_N_per_MPa", "a01_N", "b0_deflate_N", "b1_deflate_N_per_MPa")


@dataclass(repr=False)
class IsometricFit(FitBase):
    """A force model fitted to an isometric table; a fit-family member speaking its :attr:`result`'s
    words (:class:`~mckibben.results.FitBase`: ``to_pandas()`` is the parameter table, :meth:`points`
    the fitted points).

    Attributes
    ----------
    model : str
        The model's name (a key of :data:`ALL_MODELS`).
    result : FitResult
        Parameters (SI), standard errors, flags; ``result.predict(pressure=, length=, direction=)``.
    muscle : MuscleSpec
        The muscle file the fit used.
    tare : dict
        The tare applied (:func:`mckibben.data.preprocessing.apply_tare`).
    data : pandas.DataFrame
        The fitted points: ``held_length`` [m], ``pressure`` [Pa], ``force`` [N] (after the tare),
        ``direction``, ``trial``.
    """

    model: str
    result: FitResult
    muscle: MuscleSpec
    tare: dict
    data: pd.DataFrame = field(repr=False)

    RECORD = "result"
    call = "mckibben.fit.isometric.fit_isometric"
    _repr_keys = ("rmse_N", "r2", "flags")

    @property
    def arguments(self) -> dict:  # type: ignore[override]
        """What was fitted: model, data file, muscle and tare."""
        return {"model": self.model, "source": self.result.source, "muscle": self.muscle.id,
                "tare": self.tare.get("method", "none")}

    @property
    def metrics(self) -> dict:
        """``rmse_N``, ``r2``, ``n_points``, ``flags`` and the covariance used."""
        return {"rmse_N": self.result.residual_rms, "r2": self.result.r2, "n_points": self.result.n_points,
                "flags": list(self.flags), "covariance": self.result.covariance_method}

    def predict(self, pressure, length, direction="inflate"):
        """Force at pressures and lengths, with out-of-range flags.

        Parameters
        ----------
        pressure : array_like
            Gauge pressure. [Pa]
        length : array_like
            Held length. [m]
        direction : str or array_like, default "inflate"
            ``"inflate"`` or ``"deflate"`` branch. [-]

        Returns
        -------
        force : numpy.ndarray
            [N]
        flags : numpy.ndarray
            :class:`~mckibben.models.flags.Flag` masks.
        """
        return self.result.predict(pressure=pressure, length=length, direction=direction)

    @property
    def max_error(self) -> tuple[float, float]:
        """In-sample maximum absolute error [N] and it as a percentage of the peak |force| of the data [%].

        The figure the literature reports beside the RMS (e.g. Sárosi 2015; Hunt et al. 2017).
        """
        return max_error(self.result.residuals, self.data["force"].to_numpy(dtype=float))

    def to_dict(self) -> dict:
        """JSON-ready: the fit's parameters, errors, flags and tare, and its in-sample maximum error."""
        err, pct = self.max_error
        return {**self.result.to_dict(), "max_error_N": err, "max_error_pct_of_peak": pct, "tare": self.tare,
                "bounds": BOUNDS_NOTE}

    def points(self) -> pd.DataFrame:
        """The fitted points with the model's force and the residual (``quantity_unit`` columns).

        Returns
        -------
        pandas.DataFrame
            ``held_length_m``, ``pressure_Pa``, ``force_N``, ``direction``, ``trial``,
            ``force_fit_N``, ``residual_N``; provenance in ``attrs``.
        """
        import pandas as pd  # deferred on purpose: pandas (0.25 s)
        d = self.data.reset_index(drop=True)
        df = pd.DataFrame({"held_length_m": d["held_length"], "pressure_Pa": d["pressure"], "force_N": d["force"],
                           "direction": d["direction"], "trial": d["trial"],
                           "force_fit_N": d["force"].to_numpy() - self.result.residuals,
                           "residual_N": self.result.residuals})
        df.attrs["provenance"] = provenance(self.call, self.arguments)
        return df

    def plot(self, ax=None, kind: str = "fit"):
        """The fit over the data, its residuals, or measured against fitted force.

        ``kind="fit"``: force against pressure per held length (each at its own length, and for a
        family at its own muscle's rest length, coloured by muscle), inflate and deflate, the fitted
        curve and its 95 % band. The band is clipped to the data's force range (±10 % of it); when
        it reaches beyond (a parameter the data barely constrain), the figure says so.
        ``"residuals"``: measured − fitted force against pressure, per held length.
        ``"parity"``: measured against fitted force with the 1:1 line.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on (default: a new figure).
        kind : {"fit", "residuals", "parity"}, default "fit"
            Which figure. [-]

        Returns
        -------
        matplotlib.figure.Figure
        """
        import matplotlib.pyplot as plt  # deferred on purpose: Matplotlib

        if kind not in PLOT_KINDS:
            raise unknown_name("fit plot kind", kind, PLOT_KINDS)
        if ax is None:
            _, ax = plt.subplots(figsize=(6.5, 4.5), layout="constrained")
        fig = ax.figure
        d = self.data.reset_index(drop=True)
        f = d["force"].to_numpy(dtype=float)
        fitted = f - self.result.residuals
        rest = d["rest_length"].to_numpy(dtype=float) if "rest_length" in d else np.zeros(len(d))
        ell_all = d["held_length"].to_numpy(dtype=float)
        runs = np.unique(np.column_stack([np.round(rest, 9), held_length_groups(ell_all)]), axis=0, return_inverse=True)[1]
        runs = np.asarray(runs).ravel()
        family = "rest_length" in d
        shades = np.unique(np.round(rest, 9)) if family else np.unique(held_length_groups(ell_all))
        colors = plt.get_cmap("viridis")(np.linspace(0, 0.85, max(shades.size, 1)))
        if kind == "parity":
            ax.plot(fitted, f, "o", ms=2.5, alpha=0.5)
            lim = [min(f.min(), fitted.min()), max(f.max(), fitted.max())]
            ax.plot(lim, lim, "k-", lw=1, label="measured = fitted")
            ax.set_xlabel("fitted force [N]")
            ax.set_ylabel("measured force [N]")
            ax.set_title(f"{self.model}: measured against fitted, RMS {self.result.residual_rms:.3g} N")
            ax.legend(fontsize="small", loc="upper left")
            return fig
        pg = np.linspace(0.0, float(d["pressure"].max()), 60)
        span = float(np.ptp(f)) or 1.0
        ylo, yhi = float(f.min()) - 0.1 * span, float(f.max()) + 0.1 * span
        wide, labelled = False, set()
        for k in np.unique(runs):
            sel = runs == k
            ell = float(np.median(ell_all[sel]))
            shade = np.round(rest[sel][0], 9) if family else held_length_groups(ell_all)[sel][0]
            col = colors[int(np.searchsorted(shades, shade))]
            if family:
                who = str(d["muscle"][sel].iloc[0])
                label = None if who in labelled else f"{who} ({rest[sel][0] * 1e3:g} mm)"
                labelled.add(who)
            else:
                label = f"{ell * 1e3:g} mm"
            extra = {"rest_length": np.full_like(pg, rest[sel][0])} if family else {}
            for dn, mk, ls in (("inflate", "o", "-"), ("deflate", "v", "--")):
                sd = sel & (d["direction"] == dn).to_numpy()
                if not sd.any():
                    continue
                x = d["pressure"][sd].to_numpy() / 1e3
                if kind == "residuals":
                    ax.plot(x, self.result.residuals[sd], mk, ms=2.5, color=col, alpha=0.6, label=label)
                    label = None
                    continue
                ax.plot(x, f[sd], mk, ms=3, color=col, alpha=0.6)
                fc = self.result.func(self.result.values, pressure=pg, length=np.full_like(pg, ell), direction=dn, **extra)
                band = self.result.band(pressure=pg, length=np.full_like(pg, ell), direction=dn, **extra)
                wide |= bool(np.any(~np.isfinite(band)) or np.any(fc - band < ylo) or np.any(fc + band > yhi))
                ax.plot(pg / 1e3, fc, ls, color=col, lw=1, label=label if dn == "inflate" else None)
                ax.fill_between(pg / 1e3, np.clip(fc - band, ylo, yhi), np.clip(fc + band, ylo, yhi), color=col,
                                alpha=0.15, lw=0)
        ax.set_xlabel("pressure [kPa]")
        if kind == "residuals":
            ax.axhline(0.0, color="k", lw=0.8)
            ax.set_ylabel("measured − fitted force [N]")
            ax.set_title(f"{self.model}: residuals, o inflate, v deflate")
        else:
            ax.set_ylim(ylo, yhi)
            ax.set_ylabel("force [N]")
            ax.set_title(f"{self.model}: o inflate, v deflate, 95 % band")
            if wide:
                ax.text(0.01, 0.99, "band clipped to the data's range: it is wider (a parameter the data barely "
                        "constrain)", transform=ax.transAxes, va="top", fontsize="x-small", wrap=True)
        ax.legend(title="muscle (rest length)" if family else "held length", fontsize="x-small", ncol=2 if family else 1,
                  loc="upper left")
        return fig


#: The column of a binned table that counts the readings behind each point (an optional column of the
#: isometric kind, :data:`mckibben.data.schema.SCHEMAS`). [-]
SAMPLES_COLUMN = "n_samples"


def transition_rows(table: Table, min_samples: int) -> np.ndarray:
    """Which points of a binned table are a pressure step passing through, not a hold: fewer than ``min_samples`` readings.

    A table binned from a stepped protocol (a lab's readings grouped into pressure bins, each point
    their median) counts the readings of each bin in a column :data:`SAMPLES_COLUMN`. A hold fills
    its bin with every reading taken while it lasts (hundreds); a step crosses the bins on its
    way in a few readings, while the force is still moving (rate dependent, not repeatable:
    ``docs/data.md``). The threshold is a count of readings, unit free.

    Parameters
    ----------
    table : Table
        A table read by :func:`mckibben.data.read_table`. [-]
    min_samples : int
        Points with fewer readings than this are transitions; 0 marks none (and needs no column). [-]

    Returns
    -------
    numpy.ndarray
        True where a point is a transition, aligned with ``table.data``. [-]
    """
    if isinstance(min_samples, bool) or not isinstance(min_samples, (int, np.integer)) or min_samples < 0:
        raise InputError(f"min_samples: {min_samples!r} must be a whole number of readings >= 0 (0: keep every point)")
    if min_samples == 0:
        return np.zeros(len(table.data), dtype=bool)
    if SAMPLES_COLUMN not in table.data:
        raise InputError(f"min_samples: {min_samples} needs a column {SAMPLES_COLUMN} (readings per binned point); "
                         f"{table.path} has none")
    raw = table.data[SAMPLES_COLUMN]  # numbers >= 0 (the reader refuses text and negatives): whole ones here
    n = raw.to_numpy(dtype=float)
    bad = ~(np.isfinite(n) & (n == np.round(n)))
    if bad.any():
        r = int(table.data.index[np.flatnonzero(bad)[0]])
        raise InputError(f"{table.path}: row {r}, column {SAMPLES_COLUMN}: {float(raw.loc[r]):g} is not a count of readings "
                         "(a whole number >= 0)")
    if not np.any(n >= min_samples):
        raise InputError(f"min_samples: {min_samples} leaves no point of {table.path} (most readings in a point: "
                         f"{int(np.max(n)) if n.size else 0})")
    return n < min_samples


def isometric_points(table: Table, tare: str = "none", rails: str = "keep",
                     pressure_zero: str = "none", min_samples: int = 0) -> tuple[pd.DataFrame, dict]:
    """The tared points of an isometric table (SI), and the sensor report.

    In order: the pressure transducer's zero is removed (:func:`mckibben.data.preprocessing.apply_pressure_zero`),
    rows at a sensor's rail are found on the raw readings (:func:`mckibben.data.preprocessing.find_rails`),
    the load cell is tared (:func:`mckibben.data.preprocessing.apply_tare`), and the rows at a rail are kept,
    excluded or censored (``rails="censor"``: a column ``censored``, −1 for a force at the load
    cell's floor, "at most this", +1 at its ceiling, "at least this", 0 for a reading; the fit's
    likelihood treats them so, :func:`mckibben.fit.core.bounded_fit`). A run whose tare was read at the load cell's floor has an unknown zero: it is
    marked ``at_rail`` and the report's ``flags`` say ``tare_at_rail``.

    Parameters
    ----------
    table : Table
        An ``isometric`` table.
    tare : {"none", "lowest", "column", "fitted"}, default "none"
        See :func:`mckibben.data.preprocessing.apply_tare`. [-]
    rails : {"keep", "exclude", "censor"}, default "keep"
        Rows at a rail: kept (counted, flagged), excluded from the fit, or censored (a force at
        the rail is a bound on the force, not its value). [-]
    pressure_zero : {"none", "lowest", "column"}, default "none"
        See :func:`mckibben.data.preprocessing.apply_pressure_zero`. [-]
    min_samples : int, default 0
        Points binned from fewer readings than this (the column :data:`SAMPLES_COLUMN`) are a
        pressure step passing through, not a hold, and are left out (:func:`transition_rows`);
        0 keeps every point. [-]

    Returns
    -------
    points : pandas.DataFrame
        ``held_length`` [m], ``pressure`` [Pa], ``force`` [N], ``direction``, ``trial`` (and
        ``rest_length``, ``muscle`` of a family; ``censored`` with ``rails="censor"``).
    report : dict
        The tare's report (``method``, ``per_run_N``) with ``pressure_zero``, ``rails`` (each rail,
        ``rows_at_rail``, ``excluded``), ``transitions`` (``min_samples``, ``rows_excluded``) and ``flags``.
    """
    if table.kind != "isometric":
        raise InputError(f"fit: needs an isometric table ({', '.join(SCHEMAS['isometric'].required)}, ...);"
                         f" {table.path} is a {table.kind} table")
    if rails not in RAIL_POLICIES:
        raise unknown_name("rails policy", rails, RAIL_POLICIES)
    transit = transition_rows(table, min_samples)
    zeroed, pz = apply_pressure_zero(table, pressure_zero)
    at_rail, rail_report = find_rails(zeroed, ("force",))
    tared, report = apply_tare(zeroed, tare)
    report = dict(report)
    flags = []
    lows = [r["value"] for r in rail_report["rails"] if r["side"] == "low"]
    for run in report.get("per_run_N", []):
        if lows and abs(run["tare_N"] - lows[0]) < 1e-9:
            run["at_rail"] = True
    if any(r.get("at_rail") for r in report.get("per_run_N", [])):
        flags.append("tare_at_rail")
    report.update(pressure_zero=pz, rails={**rail_report, "excluded": rails == "exclude",
                                           "censored": rails == "censor"}, flags=flags)
    if min_samples:
        report["transitions"] = {"min_samples": int(min_samples), "rows_excluded": int(transit.sum())}
    keep = ~(at_rail if rails == "exclude" else np.zeros_like(at_rail)) & ~transit
    if not keep.all():
        tared = Table(tared.kind, tared.path, tared.data[keep], tared.columns)
    cols = ["held_length", "pressure", "force", "direction", "trial"]
    cols += [c for c in ("rest_length", "muscle") if c in tared.data]  # a family table's muscles
    d = tared.data[cols].copy()
    if rails == "censor":
        raw = zeroed.data["force"].to_numpy(dtype=float)[keep]
        side = np.zeros(len(d), dtype=int)
        for r in rail_report["rails"]:
            if r["column"] == "force":
                side[raw == r["value"]] = -1 if r["side"] == "low" else 1
        d["censored"] = side
    return d, report


def fit_isotonic_law(table: Table, muscle: MuscleSpec, model: str, tube: bool = False) -> FitResult:
    """A registered law fitted to an isotonic table through its force: each point (P, load, L) is F(P, L) = load.

    The law's own fit spec (:attr:`mckibben.models.laws.Law.fit_spec`), as on an isometric table: a
    muscle hanging a load at rest is a muscle held at that length pulling that load (friction
    aside). The residuals are in force [N]; :func:`law_length` solves the fitted law for the length.
    The spec's load-cell zero is fitted too (it absorbs a bias in the loads' calibration). A
    ``direction`` column (a hysteresis table's ``inflate``/``deflate``) labels each point's branch,
    so a two-branch law (:attr:`~mckibben.models.laws.Law.branches`) fits both; without one every
    point is ``inflate``.

    Parameters
    ----------
    table : Table
        An ``isotonic`` or ``hysteresis`` table (pressure, load, length). [-]
    muscle : MuscleSpec
        The muscle file (its nominal length and what the law's fit needs). [-]
    model : str
        A law of :func:`mckibben.models.laws.fit_laws` (or an old name). [-]
    tube : bool, default False
        Fit the tube's passive stretch with the law (:func:`fit_points`, :mod:`mckibben.models.tube`). [-]

    Returns
    -------
    FitResult
    """
    import pandas as pd  # deferred on purpose: pandas (0.25 s)

    model = model_name(model)
    if model not in laws.LAWS:
        raise InputError(f"fit {model}: not a registered force law")
    if table.kind not in ("isotonic", "hysteresis"):
        raise InputError(f"fit {model}: needs an isotonic or hysteresis table; {table.path} is a {table.kind} table")
    d = table.data
    # a loop's rows keep their branch (a two-branch law fits both); a table without one is inflate
    direction = d["direction"].to_numpy(dtype=object) if "direction" in d else "inflate"
    pts = pd.DataFrame({"held_length": d["length"].to_numpy(dtype=float), "pressure": d["pressure"].to_numpy(dtype=float),
                        "force": d["load"].to_numpy(dtype=float), "direction": direction,
                        "trial": d["trial"].to_numpy() if "trial" in d else np.ones(len(d))})
    return fit_points(pts, muscle, model, source=str(table.path), tube=tube)


def law_length(res: FitResult, pressure, load, lo: float, hi: float) -> np.ndarray:
    """Length at which a fitted law pulls a load (:func:`mckibben.models.law_statics.rising_root`); NaN where it does not cross. [m]

    Parameters
    ----------
    res : FitResult
        A force law's fit (:func:`fit_isotonic_law`, :func:`fit_points`). [-]
    pressure : array_like
        Gauge pressure. [Pa]
    load : array_like
        The load to pull. [N]
    lo, hi : float
        The lengths bracketing the answer (the law's force rises with length between them). [m]

    Returns
    -------
    numpy.ndarray
        Length, broadcast over ``pressure`` and ``load``: the shortest in ``[lo, hi]`` where the law
        passes the load, NaN where it pulls more at ``lo`` or never reaches it. [m]
    """
    length, state = rising_root(lambda p, ell: res.func(res.values, p, ell, "inflate"), pressure, load, lo, hi)
    return np.where(state == 0, length, np.nan)


def max_error(residuals, force) -> tuple[float, float]:
    """Largest absolute error [N], and it as a percentage of the peak |force| [%] (NaN residuals skipped).

    Parameters
    ----------
    residuals : array_like
        Model minus measurement (or the reverse), per point. [N]
    force : array_like
        The measured forces whose peak |force| is the scale. [N]

    Returns
    -------
    (float, float)
        ``max |residual|`` [N] and ``100 · max |residual| / max |force|`` [%]; NaN when no residual is finite.
    """
    r = np.abs(np.asarray(residuals, dtype=float))
    r = r[np.isfinite(r)]
    if r.size == 0:
        return float("nan"), float("nan")
    peak = float(np.max(np.abs(np.asarray(force, dtype=float)))) or 1.0
    return float(r.max()), float(r.max()) / peak * 100.0


def is_family(d: pd.DataFrame) -> bool:
    """Whether isometric points hold several muscles (a ``muscle`` and a ``rest_length`` column, ≥ 2 muscles)."""
    return "rest_length" in d and "muscle" in d and d["muscle"].astype(str).nunique() > 1


def held_length_groups(held_length) -> np.ndarray:
    """Group label per row: the held length's set point (an LVDT's reading scatters around it).

    Parameters
    ----------
    held_length : array_like
        Held lengths. [m]
    """

    return set_point_groups(np.asarray(held_length, dtype=float), decimals=6)[0]


def _runs(d: pd.DataFrame) -> np.ndarray:
    """Cluster label per row: one run = one held length and one trial (of one muscle, in a family)."""
    keys = np.column_stack([held_length_groups(d["held_length"]), d["trial"].to_numpy(dtype=float)]
                           + ([np.unique(d["muscle"].astype(str), return_inverse=True)[1].ravel()] if "muscle" in d else []))
    return np.unique(keys, axis=0, return_inverse=True)[1].ravel()


def zero_runs(d: pd.DataFrame) -> tuple[np.ndarray, list]:
    """Run label per row and each run's keys, a run being what has one zero of the load cell.

    A run is one held length × trial, of one muscle in a family (the clusters of the covariance and
    the runs of ``tare="lowest"``): one clamping, its pressure swept up and back down. Its inflate
    and deflate phases share the zero: nothing re-zeroes the cell between them, and a zero per
    phase would take the up/down gap (the hysteresis loop, a force the law misses) for a zero; on
    the real Festo 10 mm muscles per-phase zeros spread with a standard deviation of 20–32 N
    (benchmarks/RESULTS.md).

    Parameters
    ----------
    d : pandas.DataFrame
        Isometric points: ``held_length`` [m], ``trial`` (``muscle`` of a family).

    Returns
    -------
    label : numpy.ndarray
        Run index per row (0 … R−1). [-]
    keys : list of dict
        Per run: ``held_length_m``, ``trial`` (and ``muscle``). [-]
    """
    groups, lengths = set_point_groups(d["held_length"].to_numpy(dtype=float), decimals=6)
    who = d["muscle"].astype(str).to_numpy() if "muscle" in d else np.full(len(d), "")
    keys_rows = list(zip(who, groups, d["trial"].to_numpy()))
    uniq = sorted(set(keys_rows), key=lambda t: (t[0], int(t[1]), t[2]))
    index = {t: i for i, t in enumerate(uniq)}
    label = np.array([index[t] for t in keys_rows], dtype=int)
    keys = [{**({"muscle": m} if m else {}), "held_length_m": float(lengths[g]), "trial": int(tr)}
            for m, g, tr in uniq]
    return label, keys


#: How each run's load-cell zero enters a fit: as the law's one zero, or fitted per run (``tare="fitted"``).
ZEROS = ("shared", "per-run")


def _zero_contrasts(d: pd.DataFrame) -> np.ndarray:
    """Sum-to-zero contrasts of the runs (:func:`zero_runs`): column i is 1 on run i, −1 on the last run. [-]"""
    label, keys = zero_runs(d)
    r = len(keys)
    c = np.zeros((label.size, max(r - 1, 0)))
    for i in range(r - 1):
        c[label == i, i] = 1.0
    c[label == r - 1, :] = -1.0
    return c


def run_zeros(res: FitResult, d: pd.DataFrame) -> list:
    """Each run's fitted load-cell zero and its 95 % interval, from a fit with ``zeros="per-run"``.

    A run's zero is the law's ``offset_N`` (0 for a law without one) plus its deviation (the last
    run's, minus the sum of the others'); its variance is cᵀ·Σ·c over the covariance Σ of the fit.

    Parameters
    ----------
    res : FitResult
        A fit by :func:`fit_points` with ``zeros="per-run"``. [-]
    d : pandas.DataFrame
        The points it was fitted on. [-]

    Returns
    -------
    list of dict
        Per run (:func:`zero_runs`'s keys): ``zero_N`` and ``ci95_N`` ([lo, hi], NaN-free only when
        the zero's deviation is off its bounds). [N]
    """
    _, keys = zero_runs(d)
    names = list(res.names)
    dev = [names.index(f"zero_dev_{i}_N") for i in range(len(keys) - 1)]
    base = names.index("offset_N") if "offset_N" in names else None
    cov = np.asarray(res.covariance, dtype=float)
    tq = res.t_quantile
    out = []
    for r, key in enumerate(keys):
        c = np.zeros(len(names))
        if base is not None:
            c[base] = 1.0
        if r < len(dev):
            c[dev[r]] = 1.0
        else:
            c[dev] = -1.0
        z = float(c @ np.asarray(res.values, dtype=float))
        used = c != 0
        var = float(c[used] @ cov[np.ix_(used, used)] @ c[used])
        half = tq * np.sqrt(var) if np.isfinite(var) and var >= 0 else float("nan")
        out.append({**key, "zero_N": z, "ci95_N": [z - half, z + half]})
    return out


#: How a family's rest lengths enter a fit: as recorded, or each muscle's fitted as a nuisance parameter.
REST_LENGTHS = ("nominal", "fitted")
#: Largest fitted rest-length shift, as a fraction of the muscle's recorded rest length. [-]
REST_SHIFT_MAX = 0.05


def fit_points(d: pd.DataFrame, muscle: MuscleSpec, model: str, *, source: str = "",
               rest_lengths: str = "nominal", zeros: str = "shared", tube: bool = False,
               threshold: bool = False) -> FitResult:
    """Fit one force model to isometric points (already tared). See :func:`fit_isometric`.

    Parameters
    ----------
    d : pandas.DataFrame
        ``held_length`` [m], ``pressure`` [Pa], ``force`` [N], ``direction``, ``trial``.
    muscle : MuscleSpec
        Nominal length, outer diameter and whatever geometry is known.
    model : str
        A key of :data:`ALL_MODELS`. [-]
    source : str
        The data file, for messages.
    rest_lengths : {"nominal", "fitted"}, default "nominal"
        A family's rest lengths as recorded, or each muscle's own fitted as a nuisance parameter
        ``rest_shift_<muscle>_m`` (its true rest length less the recorded one, within ±
        :data:`REST_SHIFT_MAX` of it; a family law on a family table only). A cut muscle's rest
        length is measured to a millimetre or so, and a family law's end length absorbs the
        errors otherwise. A muscle the fit did not see (a held-out one) is predicted at its
        recorded rest length plus the family's mean shift (the recording's bias). [-]
    zeros : {"shared", "per-run"}, default "shared"
        The load cell's zero: the law's one ``offset_N`` (or none, for a law without one), or a zero
        per run (:func:`zero_runs`: held length × trial) as the law's zero plus a
        deviation ``zero_dev_<i>_N`` per run, the deviations summing to 0 (R − 1 of them fitted; so
        ``offset_N`` stays the runs' mean zero, which predicts a run the fit did not see). Each
        run's zero and its interval: :func:`run_zeros`. With a zero per run the runs' offsets are in
        the model, and a cluster-robust covariance by run would see no scatter in them (a run's own
        zero absorbs its residuals' mean): the covariance is s²·(JᵀJ)⁻¹, the rows of a run taken as
        independent about its zero. [-]
    tube : bool, default False
        Fit the tube's passive stretch with the law (:mod:`mckibben.models.tube`): a stiffness
        ``tube_stiffness_N_per_m`` k_t in [0, peak force / (:data:`~mckibben.models.tube.TUBE_MAX_STRAIN`
        × the rest length)] pulling k_t·max(L − L0, 0) beside the law, L0 each row's rest length (the
        fitted one with ``rest_lengths="fitted"``). The last parameter; flagged
        ``tube_stiffness_N_per_m_unconstrained`` when no point stretches the muscle past its rest
        length (the data then say nothing of it). A registered law only. [-]
    threshold : bool, default False
        Fit a threshold pressure with the law (:mod:`mckibben.models.threshold`): the law pulls at
        max(P − P_th, 0), ``threshold_pressure_Pa`` P_th in [0, :data:`~mckibben.models.threshold.THRESHOLD_FRACTION`
        × the highest measured pressure]. Before the tube's stiffness when both are fitted (the
        tube's stays last). Flagged ``threshold_pressure_Pa_at_lower_bound`` at 0 (the data show no
        threshold: the plain law is the same fit) and ``_unconstrained`` when no point tells it. A
        registered law without a threshold of its own only. [-]

    Returns
    -------
    FitResult
    """
    if rest_lengths not in REST_LENGTHS:
        raise unknown_name("rest_lengths", rest_lengths, REST_LENGTHS)
    if zeros not in ZEROS:
        raise unknown_name("zeros", zeros, ZEROS)
    model, suffixed = split_threshold(model)  # ``<law>+threshold``: the law with its threshold
    threshold = threshold or suffixed
    model = model_name(model)
    what = f"fit {model} on {source}"
    p = d["pressure"].to_numpy(dtype=float)
    ell = d["held_length"].to_numpy(dtype=float)
    f = d["force"].to_numpy(dtype=float)
    direction = d["direction"].to_numpy()
    clusters = _runs(d)
    fmax = float(np.max(np.abs(f))) or 1.0
    vr = data_range(pressure=p, length=ell)
    law = laws.LAWS.get(model)
    family = law is not None and law.family
    if is_family(d) and not family:
        raise InputError(f"{what}: the table holds {d['muscle'].astype(str).nunique()} muscles; {model} is fitted on one "
                         f"muscle (fit a family law: {', '.join(laws.fit_laws(family=True)) or 'none registered'})")
    rest = d["rest_length"].to_numpy(dtype=float) if "rest_length" in d else np.full(p.size, muscle.nominal_length)
    if family:
        vr["rest_length"] = (float(rest.min()), float(rest.max()))
    if tube and law is None:
        raise InputError(f"{what}: tube: the tube's stretch is a term of a registered force law; {model} is not one")
    if threshold and law is None:
        raise InputError(f"{what}: threshold: the threshold pressure is a term of a registered force law; {model} is "
                         "not one")
    if model == "surface":
        l0 = muscle.nominal_length
        x = np.column_stack(_surface_terms(p, ell, direction, l0))
        if np.unique(direction).size < 2:
            x = x[:, :8]

        def sfunc(values, pressure, length, direction="inflate", rest_length=None):
            terms = _surface_terms(pressure, length, direction, l0)[: len(values)]
            return sum(v * t for v, t in zip(values, terms))

        names = SURFACE_NAMES[: x.shape[1]]
        if zeros == "per-run":
            dev = _zero_contrasts(d)
            x, names = np.column_stack([x, dev]), names + tuple(f"zero_dev_{i}_N" for i in range(dev.shape[1]))
        res = linear_fit(x, f, names, model=model, response="force_N", what=what, valid_range=vr, func=sfunc,
                         source=source, clusters=None if zeros == "per-run" else clusters, cluster_unit="runs")
        if zeros == "per-run":
            res = _with_zero_spread_flag(res, d, fmax)
        return _with_monotone_flag(res, d)
    spec = _spec(model, muscle, fmax, p, ell, f, direction, rest)
    k = len(spec.names)
    names, lo, hi, starts = spec.names, spec.lo, spec.hi, spec.starts
    recorded = np.zeros(0)
    m_shift = 0
    if rest_lengths == "fitted":
        if not (family and is_family(d)):
            raise InputError(f"{what}: rest_lengths 'fitted' needs a family law on a family table (a muscle and a "
                             "rest_length column, two muscles or more)")
        who = d["muscle"].astype(str).to_numpy()
        musc, idx = np.unique(who, return_inverse=True)
        recorded = np.array([rest[who == m][0] for m in musc])
        m_shift = musc.size
        names = names + tuple(f"rest_shift_{m}_m" for m in musc)
        lo = np.concatenate([lo, -REST_SHIFT_MAX * recorded])
        hi = np.concatenate([hi, REST_SHIFT_MAX * recorded])
        starts = [np.concatenate([x0, np.zeros(musc.size)]) for x0 in starts]
        rest_fit = lambda v: rest + v[k:k + m_shift][idx]  # noqa: E731 - each row's muscle's fitted rest length
    else:
        rest_fit = lambda v: rest  # noqa: E731
    dev = np.zeros((p.size, 0))
    if zeros == "per-run":
        dev = _zero_contrasts(d)
        names = names + tuple(f"zero_dev_{i}_N" for i in range(dev.shape[1]))
        lo = np.concatenate([lo, np.full(dev.shape[1], -fmax)])
        hi = np.concatenate([hi, np.full(dev.shape[1], fmax)])
        starts = [np.concatenate([x0, np.zeros(dev.shape[1])]) for x0 in starts]
    kz = k + m_shift  # the run zeros' deviations start here
    kt = kz + dev.shape[1]  # the extra terms' values start here: P_th (threshold=True), then k_t (tube=True)
    extra_fn = spec.force
    if threshold:
        if not threshold_law(model, muscle):
            raise InputError(f"{what}: threshold: {model} has a threshold pressure of its own")
        names = names + (THRESHOLD_NAME,)
        p_top = THRESHOLD_FRACTION * max(float(np.max(p)), 0.0)
        lo, hi = np.concatenate([lo, [0.0]]), np.concatenate([hi, [p_top]])
        starts = [np.concatenate([x0, [0.1 * p_top]]) for x0 in starts]
        extra_fn = with_threshold(extra_fn)
    if tube:
        names = names + (TUBE_NAME,)
        k_max = fmax / (TUBE_MAX_STRAIN * float(np.min(rest)))
        lo, hi = np.concatenate([lo, [0.0]]), np.concatenate([hi, [k_max]])
        starts = [np.concatenate([x0, [0.05 * k_max]]) for x0 in starts]
        extra_fn = with_tube(extra_fn, float(muscle.nominal_length))

    def law_force(v, pressure, length, direction=None, rest_length=None):
        """The law's force (its values first) with its extra terms (their values last: P_th, then k_t)."""
        v = np.asarray(v, dtype=float)
        if not (tube or threshold):
            return spec.force(v[:k], pressure, length, direction, rest_length)
        return extra_fn(np.concatenate([v[:k], v[kt:]]), pressure, length, direction, rest_length)

    def func(values, pressure, length, direction="inflate", rest_length=None):
        values = np.asarray(values, dtype=float)
        if rest_length is not None and m_shift and values.size >= kz:  # the law's values alone: as recorded
            # the muscles the fit saw at their fitted rest length, any other at the family's mean shift
            # (the recording's bias: a muscle's own scatter about it is what the fit cannot know)
            rl = np.asarray(rest_length, dtype=float)
            shifts = values[k:kz]
            seen = [np.isclose(rl, r0, rtol=0, atol=1e-9) for r0 in recorded]
            rest_length = rl + sum(np.where(m, dv, 0.0) for m, dv in zip(seen, shifts)) + np.where(
                np.any(seen, axis=0), 0.0, float(np.mean(shifts)))
        return law_force(values, pressure, length, direction, rest_length)  # a run's zero: the runs' mean

    res = bounded_fit(lambda v: law_force(v, p, ell, direction, rest_fit(v)) + dev @ v[kz:kt], f, starts, names,
                      lo, hi, model=model, response="force_N", what=what, valid_range=vr, func=func,
                      clusters=None if zeros == "per-run" else clusters,
                      source=source, physical_flags=lambda v: spec.physical(v[:k]) if spec.physical else [],
                      cluster_unit="runs", priors=spec.priors,
                      censored=d["censored"].to_numpy(dtype=int) if "censored" in d else None)
    if zeros == "per-run":
        res = _with_zero_spread_flag(res, d, fmax)
    if threshold:  # the profile at P_th = 0 is the law without it, fitted on the same points
        res = _with_threshold_profile(res, fit_points(d, muscle, model, source=source, rest_lengths=rest_lengths,
                                                      zeros=zeros, tube=tube))
    return _with_monotone_flag(res, d)


def _with_threshold_profile(res: FitResult, plain: FitResult) -> FitResult:
    """Flag ``threshold_pressure_Pa_unconstrained`` when the threshold's profile likelihood reaches 0.

    The threshold is told from none when fitting it lowers the sum of squares by more than t²·s²
    (s² the threshold fit's residual variance, t its 95 % quantile): a likelihood-ratio test on the
    profile at P_th = 0, which is the law fitted without the term. A law whose other parameters
    absorb a shift of pressure (one polynomial in P: the spring model, Hunt–Quinn) gains nothing from
    it, and the conditional interval of :func:`~mckibben.fit.core.fit_flags` (the others held) would
    not see that. A threshold already at its bound is flagged there.
    """
    if any(f.startswith(THRESHOLD_NAME) for f in res.flags):
        return res
    ssr, ssr0 = float(np.sum(res.residuals**2)), float(np.sum(plain.residuals**2))
    s2 = ssr / max(res.dof, 1)
    if ssr0 - ssr <= res.t_quantile**2 * s2:
        return replace(res, flags=res.flags + (f"{THRESHOLD_NAME}_unconstrained",))
    return res


#: Runs' fitted zeros (``zeros="per-run"``) whose standard deviation exceeds
#: :data:`~mckibben.models.laws._base.OFFSET_FLAG` × the peak force are flagged ``run_zeros_spread``:
#: a zero per run can absorb any force that changes from one held length to the next, so zeros that
#: spread past a load cell's plausible zero error carry force the law misses, and a run the fit did
#: not see (predicted at the runs' mean zero) is off by that spread.
ZERO_SPREAD_FLAG = OFFSET_FLAG


def _with_zero_spread_flag(res: FitResult, d: pd.DataFrame, fmax: float) -> FitResult:
    z = np.array([r["zero_N"] for r in run_zeros(res, d)])
    if z.size > 1 and float(np.std(z)) > ZERO_SPREAD_FLAG * fmax:
        return replace(res, flags=res.flags + ("run_zeros_spread",))
    return res


#: The figures :meth:`IsometricFit.plot` draws.
PLOT_KINDS = ("fit", "residuals", "parity")

#: A fitted force that falls with rising pressure at a held length by more than this fraction of the
#: peak force, inside the fitted range, is flagged ``force_falls_with_pressure``: a muscle pulls
#: harder the more it is inflated (PyBaMM-style physics check; notes/lab-data.md). [-]
MONOTONE_TOL = 0.02


def _with_monotone_flag(res: FitResult, d: pd.DataFrame) -> FitResult:

    pg = np.linspace(float(d["pressure"].min()), float(d["pressure"].max()), 41)
    peak = float(np.max(np.abs(d["force"]))) or 1.0

    rests = d["rest_length"].to_numpy(dtype=float) if "rest_length" in d else np.full(len(d), np.nan)
    pairs = np.unique(np.column_stack([np.round(rests, 9), np.round(d["held_length"].to_numpy(dtype=float), 6)]), axis=0)
    if "rest_length" not in d:
        pairs = [(None, ell) for ell in set_point_groups(d["held_length"].to_numpy(dtype=float), decimals=6)[1]]
    for rest, ell in pairs:
        extra = {} if rest is None else {"rest_length": np.full_like(pg, rest)}
        for dn in np.unique(d["direction"]):
            fg = np.asarray(res.func(res.values, pressure=pg, length=np.full_like(pg, ell), direction=dn, **extra),
                            dtype=float)
            if np.any(np.maximum.accumulate(fg) - fg > MONOTONE_TOL * peak):
                return replace(res, flags=res.flags + ("force_falls_with_pressure",))
    return res


def fit_isometric(table: Table, muscle: MuscleSpec, model: str = "spring", tare: str = "none", rails: str = "keep",
                  pressure_zero: str = "none", rest_lengths: str = "nominal", min_samples: int = 0) -> IsometricFit:
    """Fit a static force model F(P, L) to an isometric table.

    Geometry missing from the muscle file (braid angle, wall) is fitted within the bounds of
    :data:`BOUNDS_NOTE`; the physical fits start from several braid angles and keep the best.

    **Uncertainty.** The intervals are cluster-robust by run (one held length, one trial):
    :func:`mckibben.fit.core.cluster_covariance`, with t on (runs − 1) degrees of freedom. We
    chose a cluster-robust covariance over a random per-trial offset because a run differs from
    the next by more than an offset (re-clamping changes the pre-tension, the load cell's zero and
    the hysteresis loop), the robust covariance assumes no form for that, and it needs no extra
    parameter per trial that a held-out trial could not use anyway. It needs enough runs: with
    fewer than about 6 the t quantile grows large (wide, honest intervals).

    Parameters
    ----------
    table : Table
        An ``isometric`` table.
    muscle : MuscleSpec
        The muscle file (nominal length and outer diameter are required).
    model : str, default "spring"
        A key of :data:`ALL_MODELS`. [-]
    tare : {"none", "lowest", "column", "fitted"}, default "none"
        See :func:`mckibben.data.preprocessing.apply_tare`; ``"fitted"``: the force is left as read (pre-tension
        kept) and each run's zero is fitted (:func:`fit_points` with ``zeros="per-run"``), reported
        with its interval in ``tare["per_run_N"]`` (:func:`run_zeros`). [-]
    rails : {"keep", "exclude", "censor"}, default "keep"
        Rows at a sensor's rail (:func:`isometric_points`). [-]
    pressure_zero : {"none", "lowest", "column"}, default "none"
        The pressure transducer's zero (:func:`isometric_points`). [-]
    rest_lengths : {"nominal", "fitted"}, default "nominal"
        A family's rest lengths as recorded or fitted per muscle (:func:`fit_points`). [-]
    min_samples : int, default 0
        Points binned from fewer readings than this are left out (a pressure step passing
        through, not a hold: :func:`isometric_points`). [-]

    Returns
    -------
    IsometricFit

    References
    ----------
    Module notes; Cameron & Miller (2015) for the cluster-robust covariance.
    """
    check_instance(table, "table", Table, "a Table (mckibben.read_table)")
    check_instance(muscle, "muscle", MuscleSpec, "a MuscleSpec (mckibben.read_muscle)")
    d, report = isometric_points(table, tare, rails, pressure_zero, min_samples)
    zeros = "per-run" if tare == "fitted" else "shared"
    res = fit_points(d, muscle, model, source=table.path, rest_lengths=rest_lengths, zeros=zeros)
    if zeros == "per-run":
        report["per_run_N"] = run_zeros(res, d)
    return IsometricFit(model, res, muscle, report, d)


def force_law(model: str, muscle: MuscleSpec, values) -> Callable:
    """The force function F(P, L, direction) of a fitted model, from its parameter values.

    Used to evaluate a force law saved in a muscle file (``mckibben fit … --save``): the muscle
    file's known geometry is held fixed exactly as in the fit.

    Parameters
    ----------
    model : str
        A key of :data:`ALL_MODELS`. [-]
    muscle : MuscleSpec
        The muscle the law was fitted for.
    values : array_like
        Parameter values in the order of :func:`parameter_names`. [SI]

    Returns
    -------
    callable
        ``f(pressure [Pa], length [m], direction="inflate") -> force [N]``.
    """
    v = np.asarray(values, dtype=float)
    model = model_name(model)
    if model == SURFACE:
        l0 = muscle.nominal_length

        def sfunc(pressure, length, direction="inflate"):
            terms = _surface_terms(pressure, length, direction, l0)[: len(v)]
            return sum(a * t for a, t in zip(v, terms))

        return sfunc
    spec = _spec(model, muscle, 1.0, *_NO_DATA)
    return lambda pressure, length, direction="inflate": spec.force(v, pressure, length, direction)


def parameter_names(model: str, muscle: MuscleSpec) -> tuple:
    """The parameter names a model fits for a muscle (geometry the file gives is not fitted).

    Parameters
    ----------
    model : str
        A key of :data:`ALL_MODELS`. [-]
    muscle : MuscleSpec
        The muscle file.
    """
    model = model_name(model)
    if model == SURFACE:
        return SURFACE_NAMES
    return _spec(model, muscle, 1.0, *_NO_DATA).names


#: Cross-validation schemes of :func:`compare_isometric`.
CV_METHODS = ("leave-one-length-out", "leave-one-trial-out", "leave-one-muscle-out")


@dataclass(repr=False)
class ModelComparison(Result):
    """Every force model on the same isometric data and the same folds.

    Attributes
    ----------
    cv : str
        The cross-validation scheme (a key of :data:`CV_METHODS`).
    scores : list of dict
        Per model: ``model``, ``n_parameters``, ``rmse_N``, ``r2``, ``max_error_N`` and
        ``max_error_pct_of_peak`` (in-sample, all data: the largest |error| and it / peak |force| ×
        100, the figure the literature reports), ``cv_rmse_N`` (held-out), ``cv_rmse_pct_of_peak``
        (held-out RMSE / peak |force| × 100), ``cv_max_error_N`` and ``cv_max_error_pct_of_peak``
        (the largest held-out |error|), ``folds`` (per fold: ``held_out``, ``rmse_N``,
        ``rmse_pct_of_peak`` of the held-out muscle's peak |force|, ``max_error_N`` and
        ``max_error_pct_of_peak`` of the held-out points, ``peak_force_N``, ``n_points``, ``extrapolated``: the range flags of
        its points, e.g. ``rest_length_out_of_range``), ``median_fold_pct_of_peak`` and
        ``worst_fold_pct_of_peak`` over the folds, ``extrapolated_folds`` (folds whose held-out
        points lie outside the training range), ``flags`` (of the fit on all data) and ``note``.
    best : str or None
        The model with the smallest held-out RMSE among the unflagged ones (all, when every one is
        flagged).
    peak_force : float
        Largest |force| in the data. [N]
    fits : dict
        Model -> :class:`IsometricFit` on all the data (models that could be fitted).
    tare : dict
        The tare applied.
    source : str
        The data file.
    best_flagged : bool
        Whether every model's fit is flagged, the best one's too. [-]
    """

    cv: str
    scores: list
    best: str | None
    peak_force: float
    fits: dict = field(repr=False)
    tare: dict = field(default_factory=dict)
    source: str = ""
    best_flagged: bool = False

    call = "mckibben.fit.isometric.compare_isometric"

    @property
    def arguments(self) -> dict:
        """What was compared: data file, scheme and tare."""
        return {"source": self.source, "cv": self.cv, "tare": self.tare.get("method", "none")}

    @property
    def metrics(self) -> dict:
        """``best``, its ``cv_rmse_N`` and ``cv_rmse_pct_of_peak``, and the peak force."""
        b = next((s for s in self.scores if s["model"] == self.best), {})
        return {"best": self.best, "cv": self.cv, "cv_rmse_N": b.get("cv_rmse_N"),
                "cv_rmse_pct_of_peak": b.get("cv_rmse_pct_of_peak"), "peak_force_N": self.peak_force}

    def _series(self) -> pd.DataFrame:
        """One row per model (the scores), sorted by held-out error."""
        import pandas as pd  # deferred on purpose: pandas (0.25 s)
        return pd.DataFrame(self.scores).sort_values("cv_rmse_N", na_position="last").reset_index(drop=True)

    def to_dict(self) -> dict:
        """JSON-ready."""
        return {"cv": self.cv, "best": self.best, "best_flagged": self.best_flagged, "peak_force_N": self.peak_force,
                "tare": self.tare, "models": self.scores}

    def plot(self, ax=None):
        """Held-out and in-sample RMSE per model, as % of the peak force, with each fold's error.

        One row per model (names on the vertical axis, never clipped), sorted by held-out error:
        the in-sample and the pooled held-out RMSE as bars, each held-out fold's RMSE (as % of its
        muscle's peak) as a dot, so the spread across folds shows. A flagged model's bars are
        hatched and its label says ``(flagged)``, the recommended one (``best``) is in bold, the
        legend beside the axes; a model that could not be fitted is listed without bars.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Axes to draw on (default: a new figure).

        Returns
        -------
        matplotlib.figure.Figure
        """
        import matplotlib.pyplot as plt  # deferred on purpose: Matplotlib

        df = self.to_pandas().iloc[::-1].reset_index(drop=True)  # the best at the top
        if ax is None:
            _, ax = plt.subplots(figsize=(9.0, 1.6 + 0.45 * max(len(df), 3)), layout="constrained")
        y = np.arange(len(df))
        flagged = np.array([bool(f) for f in df["flags"]])
        ins = np.where(df["rmse_N"].notna(), df["rmse_N"].astype(float) / self.peak_force * 100, np.nan)
        held = df["cv_rmse_pct_of_peak"].astype(float).to_numpy()
        for rows, hatch, suffix in ((~flagged, None, ""), (flagged, "//", ", flagged")):
            ax.barh(y[rows] + 0.2, ins[rows], 0.38, color="C0", hatch=hatch, edgecolor="white" if hatch else None,
                    label=f"in-sample{suffix}" if rows.any() else None)
            ax.barh(y[rows] - 0.2, held[rows], 0.38, color="C1", hatch=hatch, edgecolor="white" if hatch else None,
                    label=f"held out, pooled{suffix}" if rows.any() else None)
        dots = "held out, one fold"
        for k, folds in enumerate(df["folds"]):
            pct = [f["rmse_pct_of_peak"] for f in folds if np.isfinite(f["rmse_pct_of_peak"])]
            if pct:
                ax.plot(pct, np.full(len(pct), y[k] - 0.2), "o", color="k", ms=3, alpha=0.7, label=dots)
                dots = None  # one legend entry
        labels = [f"{m} (flagged)" if fl else m for m, fl in zip(df["model"], flagged)]
        ax.set_yticks(y, labels)
        for tick, m in zip(ax.get_yticklabels(), df["model"]):
            if m == self.best:
                tick.set_fontweight("bold")
        ax.set_xlabel("RMSE [% of peak force]")
        ax.set_title(f"{self.cv}: held out and in-sample error (best: {self.best})", fontsize="medium")
        ax.set_xlim(left=0)
        ax.legend(fontsize="small", loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)  # beside: never over the data
        return ax.figure


def _fold_keys(d: pd.DataFrame, cv: str) -> tuple[np.ndarray, list]:
    """Fold label per row and a readable name per fold."""
    who = d["muscle"].astype(str).to_numpy() if "muscle" in d else np.full(len(d), "")
    if cv == "leave-one-muscle-out":
        names = sorted(set(who))
        return np.searchsorted(names, who), names
    if cv == "leave-one-trial-out":
        t = d["trial"].to_numpy()
        names = list(np.unique(t))
        return np.searchsorted(names, t), [f"trial {x}" for x in names]
    g = held_length_groups(d["held_length"])
    pairs = sorted(set(zip(who, g)))
    index = {pq: k for k, pq in enumerate(pairs)}
    ell = d["held_length"].to_numpy(dtype=float)
    label = []
    for m, k in pairs:
        sel = (who == m) & (g == k)
        mm = f"{m} " if m else ""
        label.append(f"{mm}{float(np.median(ell[sel])) * 1e3:.4g} mm")
    return np.array([index[pq] for pq in zip(who, g)]), label


def compare_isometric(table: Table, muscle: MuscleSpec, cv: str = "leave-one-length-out", tare: str = "none",
                      models=None, rails: str = "keep", pressure_zero: str = "none",
                      rest_lengths: str = "nominal", min_samples: int = 0, threshold: bool = False) -> ModelComparison:
    """Fit every force model to an isometric table and score it on held-out lengths, trials or muscles.

    Every model is fitted on the same folds: ``leave-one-length-out`` leaves each held length out
    in turn and predicts it from the others (the extreme lengths are extrapolations, counted in
    ``extrapolated_folds``; on a family table a fold is one muscle's held length, and the other
    muscles stay in the training data); ``leave-one-trial-out`` leaves each trial number out;
    ``leave-one-muscle-out`` (a family table: ``muscle`` and ``rest_length`` columns) leaves each
    whole muscle out and predicts it from its rest length alone. The best model is the one with
    the smallest held-out RMSE, never the in-sample one (notes/lab-data.md).

    On a family table only the family laws (:func:`mckibben.models.laws.fit_laws`) are fitted:
    the others describe one muscle. On one muscle's table every law is fitted, the family laws
    too: on one rest length a family law has no end length to find and is a force law of that
    muscle's contraction (its own file says which parameters it drops).

    **Best.** The model with the smallest held-out RMSE among those whose predictions carry no
    doubt: no flag on its fit on all the data (a bound that binds, a parameter the data do not
    constrain, a non-physical value) and a held-out error at most :data:`~mckibben.fit.core.HELDOUT_RATIO`
    times its in-sample error on the same points, those of the folds that predict within the fitted
    range (else ``heldout_far_above_insample``; :func:`~mckibben.fit.core.interpolated_rms`: the
    extrapolated folds are counted apart and still scored in the held-out error). Notes (parameters that only
    trade off) do not discard a model. A flagged model is reported, not recommended;
    when every model is flagged, the smallest held-out RMSE of all, and ``best_flagged`` says so.

    Per fold, ``folds`` gives the held-out RMSE and that RMSE as a percentage of the held-out
    muscle's peak measured |force| (the peak of the whole table for one muscle).

    Parameters
    ----------
    table : Table
        An ``isometric`` table.
    muscle : MuscleSpec
        The muscle file (for a family: the type's outer diameter and geometry). [-]
    cv : {"leave-one-length-out", "leave-one-trial-out", "leave-one-muscle-out"}
        Cross-validation scheme. [-]
    tare : {"none", "lowest", "column", "fitted"}, default "none"
        See :func:`mckibben.data.preprocessing.apply_tare`. [-]
    models : sequence of str, optional
        Models to compare (default: :data:`FAMILY_MODELS` on a family table, else :data:`MUSCLE_MODELS`). [-]
    rails : {"keep", "exclude", "censor"}, default "keep"
        Rows at a sensor's rail (:func:`isometric_points`). [-]
    pressure_zero : {"none", "lowest", "column"}, default "none"
        The pressure transducer's zero (:func:`isometric_points`). [-]
    rest_lengths : {"nominal", "fitted"}, default "nominal"
        A family's rest lengths as recorded or fitted per muscle (:func:`fit_points`). [-]
    min_samples : int, default 0
        Points binned from fewer readings than this are left out (a pressure step passing
        through, not a hold: :func:`isometric_points`). [-]
    threshold : bool, default False
        Also score every registered law without a threshold of its own with a threshold pressure
        fitted with it (:func:`fit_points`, :mod:`mckibben.models.threshold`), named
        ``<law>+threshold`` beside ``<law>``: the held-out error and the flags say whether the term
        earns its place (a threshold at 0 is flagged at its bound: the plain law is the same fit).
        ``models`` may name ``<law>+threshold`` itself. [-]

    Returns
    -------
    ModelComparison
    """
    check_instance(table, "table", Table, "a Table (mckibben.read_table)")
    check_instance(muscle, "muscle", MuscleSpec, "a MuscleSpec (mckibben.read_muscle)")
    if cv not in CV_METHODS:
        raise unknown_name("`cv` scheme", cv, CV_METHODS)
    d, report = isometric_points(table, tare, rails, pressure_zero, min_samples)
    zeros = "per-run" if tare == "fitted" else "shared"
    family = is_family(d)
    if rest_lengths not in REST_LENGTHS:
        raise unknown_name("rest_lengths", rest_lengths, REST_LENGTHS)
    if rest_lengths == "fitted" and not family:
        raise InputError(f"compare on {table.path}: rest_lengths 'fitted' needs a family table (a muscle and a "
                         "rest_length column, two muscles or more)")
    if cv == "leave-one-muscle-out" and not family:
        raise InputError(f"compare on {table.path}: leave-one-muscle-out needs a family table (a muscle and a "
                         "rest_length column, two muscles or more)")
    f = d["force"].to_numpy(dtype=float)
    peak = float(np.max(np.abs(f)))
    who = d["muscle"].astype(str).to_numpy() if family else np.full(len(d), "")
    muscle_peak = {m: float(np.max(np.abs(f[who == m]))) or 1.0 for m in set(who)}
    key, fold_names = _fold_keys(d, cv) if family or cv != "leave-one-length-out" else (
        held_length_groups(d["held_length"]), None)
    groups = np.unique(key)
    if groups.size < 2:
        what = {"leave-one-length-out": "held lengths", "leave-one-trial-out": "trials"}.get(cv, "muscles")
        raise InputError(f"compare on {table.path}: {cv} needs two {what} or more")
    if fold_names is None:
        fold_names = _fold_keys(d, cv)[1]
    if models is None:  # a family's laws on a family table, every law on one muscle
        models = list(FAMILY_MODELS if family else ALL_MODELS)
    if threshold:  # each law with its threshold beside it (not a law with a threshold of its own)
        models = [x for m in models for x in ((m, m + THRESHOLD_SUFFIX) if threshold_law(m, muscle) else (m,))]
    scores, fits = [], {}
    for model in models:
        try:
            full = fit_points(d, muscle, model, source=table.path, rest_lengths=rest_lengths, zeros=zeros)
        except InputError as exc:
            scores.append({"model": model, "n_parameters": 0, "rmse_N": None, "r2": None, "max_error_N": None,
                           "max_error_pct_of_peak": None, "cv_rmse_N": None, "cv_rmse_pct_of_peak": None,
                           "cv_max_error_N": None, "cv_max_error_pct_of_peak": None,
                           "extrapolated_folds": 0, "flags": [], "folds": [],
                           "note": f"not fitted: {exc}"})
            continue
        # each model's own run zeros (tare "fitted") in its fit's report
        fits[model] = IsometricFit(model, full, muscle, {**report, "per_run_N": run_zeros(full, d)}
                                   if zeros == "per-run" else report, d)
        pred = np.full(f.size, np.nan)
        inside = np.zeros(f.size, dtype=bool)  # points of the folds that predict within the fitted range
        extrapolated, notes, folds = 0, [], []
        for g in groups:
            test = key == g
            try:
                r = fit_points(d[~test], muscle, model, source=table.path,
                               rest_lengths=rest_lengths if is_family(d[~test]) else "nominal", zeros=zeros)
            except InputError as exc:
                notes.append(f"fold {fold_names[int(g)]} not fitted: {exc}")
                continue
            sub = d[test]
            extra = {"rest_length": sub["rest_length"].to_numpy(dtype=float)} if "rest_length" in sub else {}
            value, fl = r.predict(pressure=sub["pressure"].to_numpy(), length=sub["held_length"].to_numpy(),
                                  direction=sub["direction"].to_numpy(), **extra)
            if "censored" in sub:  # a prediction that keeps to a rail's bound is no error (``rails="censor"``)
                value = f[test] + censor_hinge(value - f[test], sub["censored"].to_numpy(dtype=int))
            pred[test] = value
            extrapolated += int(np.any(fl))
            inside[test] = not np.any(fl)
            ok = np.isfinite(value)
            rm = float(np.sqrt(np.mean((value[ok] - f[test][ok]) ** 2))) if ok.any() else float("nan")
            pk = max(muscle_peak[m] for m in set(who[test]))
            mx = max_error(value - f[test], [pk])
            folds.append({"held_out": fold_names[int(g)], "rmse_N": rm, "rmse_pct_of_peak": rm / pk * 100.0,
                          "max_error_N": mx[0], "max_error_pct_of_peak": mx[1], "peak_force_N": pk, "n_points": int(test.sum()), "extrapolated": flag_names(int(np.bitwise_or.reduce(fl.ravel())))})
        ok = np.isfinite(pred)
        cv_rmse = float(np.sqrt(np.mean((pred[ok] - f[ok]) ** 2))) if ok.any() else float("nan")
        if not ok.all():
            notes.append(f"{int((~ok).sum())} points not predicted")
        pct = [x["rmse_pct_of_peak"] for x in folds if np.isfinite(x["rmse_pct_of_peak"])]
        cv_within, fit_within = interpolated_rms(pred - f, full.residuals, inside)
        heldout = list(heldout_flags(cv_within, fit_within))
        ins, held = max_error(full.residuals, f), max_error(pred - f, f)
        scores.append({"model": model, "n_parameters": len(full.values), "rmse_N": full.residual_rms,
                       "r2": full.r2, "max_error_N": ins[0], "max_error_pct_of_peak": ins[1],
                       "cv_rmse_N": cv_rmse, "cv_rmse_pct_of_peak": cv_rmse / peak * 100.0,
                       "cv_max_error_N": held[0], "cv_max_error_pct_of_peak": held[1],
                       "median_fold_pct_of_peak": float(np.median(pct)) if pct else None,
                       "worst_fold_pct_of_peak": float(np.max(pct)) if pct else None,
                       "cv_rmse_interpolated_N": cv_within, "rmse_interpolated_N": fit_within,
                       "extrapolated_folds": extrapolated, "flags": list(full.flags) + heldout, "notes": list(full.notes), "note": "; ".join(notes),
                       "folds": folds})
    chosen, every_flagged = best_of(scores)
    return ModelComparison(cv, scores, chosen["model"] if chosen else None, peak, fits, report, table.path,
                           best_flagged=every_flagged)


def best_of(scores: list) -> tuple[dict | None, bool]:
    """Compare's rule for ``best``: the smallest held-out RMSE among the scores that carry no flag.

    The one place the rule is written: :func:`compare_isometric` and the nested cross-validation
    (:func:`mckibben.fit.nested.compare_nested`, whose candidates are scores of several comparisons)
    both call it.

    Parameters
    ----------
    scores : list of dict
        :attr:`ModelComparison.scores` entries (``cv_rmse_N`` [N], ``flags``). [-]

    Returns
    -------
    (dict or None, bool)
        The chosen score (None when no score has a finite held-out error), and whether every
        ranked score is flagged (then the chosen one is the smallest held-out RMSE of all). [-]
    """
    ranked = [s for s in scores if s["cv_rmse_N"] is not None and np.isfinite(s["cv_rmse_N"])]
    clean = [s for s in ranked if not s["flags"]]
    if not ranked:
        return None, False
    return min(clean or ranked, key=lambda s: s["cv_rmse_N"]), not clean

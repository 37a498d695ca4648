"""Fits of the static models to experiment tables, each with standard errors and a valid range.

========================  =================  ===================================================
function                  data kind          model
========================  =================  ===================================================
fit_kinematic             braid_angle        l = k1·Ls·cos θ + k2 ([mpam-characterization], eq. 2, Table I)
fit_cubics                isotonic,          one cubic in pressure per load (and direction):
                          hysteresis,        length (Fig. 5/6), cos θ (eq. 3, Table II, Fig. 10),
                          braid_angle,       blocked force (Fig. 3)
                          blocked_force
fit_force_contraction     isotonic           one cubic of load vs contraction per pressure (Fig. 5)
fit_surface               isotonic           l = Σ a_ij·P^i·F^j, i ≤ 3, j ≤ 1: one smooth surface
fit_spring                force_length,      Lu(P) and K(P, Ls) per direction and pressure range
                          isotonic           ([wickramatunge2010], eq. 1–2, Tables 1–2)
fit_chou_hannaford        isotonic           length under load, effective strand length and D0
fit_tondu_lopez           isotonic           length under load, fitted k and r0 (α0 from the file)
fit_first_order           step_response      p = p0 + (p∞ − p0)(1 − e^{−(t − t0)/τ}) (§IV.A)
========================  =================  ===================================================

Pressure inside the cubics and the surface is in MPa, as the paper prints them (parameter names
say so: ``c3_per_MPa3``); everything else is SI.

**Why three laws keep an isotonic fit of their own.** Every registered law with a fit spec is fitted
to an isotonic table through its force (:func:`mckibben.fit.isometric.fit_isotonic_law`: each
point is F(P, L) = load, residuals in newtons, with the load cell's zero). ``fit_spring``,
``fit_chou_hannaford`` and ``fit_tondu_lopez`` are different estimators, not copies of those laws:
their residuals are in *length* (what an isotonic rig measures: the error is in the length, the
load is a known hanging mass, so there is no load-cell zero to fit), the braid laws solve the law
for the length (:func:`mckibben.models.physical.length_under_load`, the law's own kernel through
the one solver :func:`mckibben.models.law_statics.rising_root`; Tondu–Lopez its closed-form
contraction), and the spring model fits its unstretched length Lu(P) and stiffness per pressure
range ([wickramatunge2010], eq. 1–2), a structure the isometric fit spec does not have. The laws'
formulas are not written here: each fit calls the law's own functions. The names under which
``fit`` and ``compare`` offer them are still listed in :mod:`mckibben.fit.registry`,
:mod:`mckibben.fit.compare` and :mod:`mckibben.fit.names` (the remaining hand lists of issue 32).
"""

from __future__ import annotations

import warnings

from typing import TYPE_CHECKING

from dataclasses import dataclass

import numpy as np

from mckibben.data.setpoints import GROUP_GAP, set_point_groups  # noqa: F401 (re-exported)
from mckibben.data.muscle_file import MuscleSpec  # noqa: F401 (re-exported)
from mckibben.data.tables import Table  # noqa: F401 (re-exported)
from mckibben.errors import InputError
from mckibben.fit.core import (FitResult, bounded_fit, data_range, linear_fit, nonlinear_fit, require_distinct,
                               require_points)
from mckibben.models.geometry import MiniatureGeometry
from mckibben.models.kinematic import length_from_braid
from mckibben.models.mpam import BraidAngleMap, MiniatureMuscle
from mckibben.models.physical import BraidGeometry, length_under_load, tondu_lopez_contraction
if TYPE_CHECKING:
    import pandas as pd

from mckibben.models.laws.chou_hannaford import LAW as _CH_LAW
from mckibben.models.laws.spring import LAW as _SPRING_LAW
from mckibben.models.laws.tondu_lopez import LAW as _TL_LAW
from mckibben.models.spring import DEFAULT_TERMS, DIRECTIONS, ELONGATION, HIGH, LOW, SpringModel, spring_force
from mckibben.fit.isometric import D0_FACTOR, THETA_MAX, THETA_STARTS_DEG
from mckibben.fit.isometric import K_BOUNDS, R0_FACTOR

if TYPE_CHECKING:  # annotations only; the modules are imported where used (deferred)
    import pandas as pd

MPA = 1e6


def _need(table: Table, kinds: tuple[str, ...], model: str) -> None:
    if table.kind not in kinds:
        raise InputError(f"fit {model}: needs a {' or '.join(kinds)} table; {table.path} is a {table.kind} table")


def _what(model: str, table: Table, condition: dict | None = None) -> str:
    cond = ""
    if condition:
        cond = " (" + ", ".join(_fmt_condition(k, v) for k, v in condition.items()) + ")"
    return f"fit {model} on {table.path}{cond}"


def _fmt_condition(key: str, value) -> str:
    if key == "load_N":
        return f"load {value:.4g} N"
    if key == "pressure_Pa":
        return f"pressure {value / MPA:.4g} MPa"
    return f"{key.split('_')[0]} {value}"


def _pkey(pressure):
    """Pressures binned to 1 kPa (a transducer's resolution), so repeated set points group."""
    return np.round(np.asarray(pressure, dtype=float) / 1e3) * 1e3


def _groups(values, decimals=9):
    """Sorted distinct values (rounded, so 0.6 from grams and from newtons group together)."""
    return np.unique(np.round(np.asarray(values, dtype=float), decimals))


# --------------------------------------------------------------------------------------------
# eq. 2: kinematics


def _kinematic_func(values, cos_theta, strand_length):
    return length_from_braid(cos_theta, strand_length, values[0], values[1])


def fit_kinematic(table: Table, muscle: MuscleSpec) -> FitResult:
    """Fit eq. (2), l = k1·Ls·cos θ + k2, to braid-angle photographs.

    Parameters
    ----------
    table : Table
        A ``braid_angle`` table (braid angle and length per photograph).
    muscle : MuscleSpec
        Gives the strand length Ls. [m]

    Returns
    -------
    FitResult
        ``k1`` [-] and ``k2_m`` [m]; ``predict(cos_theta=..., strand_length=...)`` gives the length.

    References
    ----------
    [mpam-characterization], eq. (2), Table I, Fig. 9.
    """
    _need(table, ("braid_angle",), "kinematic")
    d = table.data
    what = _what("kinematic", table)
    cos_t = np.cos(d["braid_angle"].to_numpy())
    require_distinct(d["braid_angle"], 3, "braid angles", what, "a straight line with a check of its fit")
    x = np.column_stack([muscle.need("strand_length", "fit kinematic (eq. 2)") * cos_t, np.ones_like(cos_t)])
    return linear_fit(x, d["length"].to_numpy(), ("k1", "k2_m"), model="kinematic", response="length_m", what=what,
                      clusters=_clusters(d),
                      valid_range=data_range(cos_theta=cos_t, length=d["length"]), func=_kinematic_func,
                      source=table.path)


# --------------------------------------------------------------------------------------------
# the paper's cubics


def _cubic_func(values, pressure):
    p = np.asarray(pressure, dtype=float) / MPA
    return ((values[0] * p + values[1]) * p + values[2]) * p + values[3]


CUBIC_RESPONSES = {
    "isotonic": ("length", "length_m", "m"),
    "hysteresis": ("length", "length_m", "m"),
    "braid_angle": ("cos_theta", "cos_theta", ""),
    "blocked_force": ("force", "force_N", "N"),
}


def _cubic_names(base: str) -> tuple[str, ...]:
    sep = "_" if base else ""
    return (f"c3{sep}{base}_per_MPa3", f"c2{sep}{base}_per_MPa2", f"c1{sep}{base}_per_MPa", f"c0{sep}{base}".rstrip("_"))


def fit_cubic(pressure, response, *, what: str, response_name: str, unit: str, condition=None, source="",
              extra_range=None, trials=None) -> FitResult:
    """One cubic in pressure, y = c3·P³ + c2·P² + c1·P + c0 with P in MPa (the paper's fits).

    Parameters
    ----------
    pressure : array_like
        Gauge pressure. [Pa]
    response : array_like
        The fitted quantity (length [m], cos θ [-], force [N]).
    what : str
        The fit's name for messages.
    response_name : str
        Response with unit, e.g. ``"length_m"``.
    unit : str
        Unit of the response, e.g. ``"m"`` (names become ``c3_m_per_MPa3`` ... ``c0_m``).
    condition : dict, optional
        The condition (load, direction) the data were restricted to.
    source : str
        Data file.
    extra_range : dict, optional
        More entries of the valid range (e.g. the load). [SI]
    trials : array_like, optional
        Trial per point: with five trials or more the covariance is cluster-robust by trial
        (a per-trial offset shifts every point of a trial alike; :func:`~mckibben.fit.core.cluster_covariance`).
        [-]

    Returns
    -------
    FitResult
        Coefficients of P³, P², P, 1 (P in MPa); ``predict(pressure=...)``.

    References
    ----------
    [mpam-characterization], eq. (3), Table II, Figs. 3, 5, 6, 10 (cubic fits).
    """
    p = np.asarray(pressure, dtype=float)
    require_distinct(p, 5, "pressures", what, "a cubic in pressure (4 coefficients and a check of its fit)")
    x = np.column_stack([(p / MPA) ** 3, (p / MPA) ** 2, p / MPA, np.ones_like(p)])
    vr = data_range(pressure=p) | dict(extra_range or {})
    return linear_fit(x, response, _cubic_names(unit), model="cubic", response=response_name, what=what,
                      valid_range=vr, func=_cubic_func, condition=condition, source=source, clusters=trials)


def fit_cubics(table: Table) -> dict[tuple, FitResult]:
    """The paper's way: one cubic in pressure per load (and per direction for hysteresis).

    Isotonic and hysteresis tables fit the length, braid-angle tables (with pressure and load)
    fit cos θ (Table II), blocked-force tables fit the force.

    Parameters
    ----------
    table : Table
        An ``isotonic``, ``hysteresis``, ``braid_angle`` (with pressure and load) or
        ``blocked_force`` table.

    Returns
    -------
    dict
        ``(load [N] or None, direction or None) -> FitResult``, sorted by load.
    """
    _need(table, tuple(CUBIC_RESPONSES), "cubic")
    col, response_name, unit = CUBIC_RESPONSES[table.kind]
    d = table.data.copy()
    if table.kind == "braid_angle":
        for q in ("pressure", "load"):
            if q not in d:
                raise InputError(f"fit cubic on {table.path}: a braid_angle table needs a {q} column for cos θ(P) per load (Table II)")
        d["cos_theta"] = np.cos(d["braid_angle"])
    out = {}
    if "load" in d:
        labels, loads = set_point_groups(d["load"])
    else:
        labels, loads = np.zeros(len(d), int), [None]
    directions = sorted(d["direction"].unique()) if "direction" in d else [None]
    for k, load in enumerate(loads):
        for direction in directions:
            sel = labels == k
            cond: dict = {}
            if load is not None:
                cond["load_N"] = float(load)
            if direction is not None:
                sel &= (d["direction"] == direction).to_numpy()
                cond["direction"] = direction
            sub = d[sel]
            if len(sub) == 0:
                continue
            extra = {"load": (float(sub["load"].min()), float(sub["load"].max()))} if load is not None else {}
            out[(float(load) if load is not None else None, direction)] = fit_cubic(sub["pressure"], sub[col], what=_what("cubic", table, cond),
                                               response_name=response_name, unit=unit, condition=cond,
                                               source=table.path, extra_range=extra,
                                               trials=sub["trial"].to_numpy() if sub["trial"].nunique() >= 2 else None)
    return out


def braid_map_from_fits(fits: dict[tuple, FitResult]) -> BraidAngleMap:
    """A :class:`~mckibben.models.mpam.BraidAngleMap` from fitted cos θ cubics (one per load).

    Parameters
    ----------
    fits : dict
        ``(load, None) -> FitResult`` from :func:`fit_cubics` on a braid_angle table.
    """
    keys = sorted(k for k in fits if k[0] is not None)
    lo = min(fits[k].valid_range["pressure"][0] for k in keys)
    hi = max(fits[k].valid_range["pressure"][1] for k in keys)
    return BraidAngleMap(tuple(float(k[0]) for k in keys), tuple(tuple(float(v) for v in fits[k].values) for k in keys),
                         (lo, hi), citation=f"fitted to {fits[keys[0]].source}")


def fitted_muscle(spec: MuscleSpec, kinematic: FitResult, braid_fits: dict[tuple, FitResult]) -> MiniatureMuscle:
    """The paper's model (eq. 2 + eq. 3) with fitted k1, k2 and cos θ cubics.

    Parameters
    ----------
    spec : MuscleSpec
        The muscle file (nominal and strand length, geometry).
    kinematic : FitResult
        From :func:`fit_kinematic`.
    braid_fits : dict
        From :func:`fit_cubics` on a braid_angle table.
    """
    return MiniatureMuscle(
        name=spec.id, nominal_length=spec.nominal_length, strand_length=spec.need("strand_length", "the paper's map"),
        k1=kinematic["k1"], k2=kinematic["k2_m"], braid_map=braid_map_from_fits(braid_fits),
        geometry=MiniatureGeometry.from_spec(spec), citation=f"fitted to {kinematic.source}", synthetic=spec.synthetic,
    )


# --------------------------------------------------------------------------------------------
# Fig. 5: load vs contraction per pressure


def _fc_func(values, contraction):
    e = np.asarray(contraction, dtype=float)
    return ((values[0] * e + values[1]) * e + values[2]) * e + values[3]


def fit_force_contraction(table: Table, muscle: MuscleSpec) -> dict[float, FitResult]:
    """One cubic of the hanging load in the contraction ε = 1 − l/L0 per pressure (Fig. 5).

    Parameters
    ----------
    table : Table
        An ``isotonic`` table.
    muscle : MuscleSpec
        Gives the nominal length L0. [m]

    Returns
    -------
    dict
        pressure [Pa] -> FitResult of ``c3_N`` … ``c0_N`` (force in N, ε dimensionless).

    References
    ----------
    [mpam-characterization], §III.B, Fig. 5.
    """
    _need(table, ("isotonic",), "force-contraction")
    d = table.data
    eps = 1.0 - d["length"].to_numpy() / muscle.nominal_length
    out = {}
    labels, centres = set_point_groups(_pkey(d["pressure"]))
    for k, p in enumerate(centres):
        sel = labels == k
        cond = {"pressure_Pa": float(p)}
        what = _what("force-contraction", table, cond)
        require_distinct(d["load"][sel], 5, "loads", what, "a cubic in contraction (4 coefficients and a check of its fit)")
        e = eps[sel]
        x = np.column_stack([e**3, e**2, e, np.ones_like(e)])
        out[float(p)] = linear_fit(x, d["load"].to_numpy()[sel], ("c3_N", "c2_N", "c1_N", "c0_N"), model="force-contraction",
                                   clusters=_clusters(d[sel]),
                                   response="force_N", what=what, valid_range=data_range(contraction=e),
                                   func=_fc_func, condition=cond, source=table.path)
    return out


# --------------------------------------------------------------------------------------------
# one smooth surface over (pressure, load)


def _surface_terms(pressure, load, load_degree):
    p = np.asarray(pressure, dtype=float) / MPA
    f = np.asarray(load, dtype=float)
    return [p**i * f**j for j in range(load_degree + 1) for i in range(3, -1, -1)]


def _surface_names(load_degree):
    names = []
    for j in range(load_degree + 1):
        for i in range(3, -1, -1):
            unit = "m" + (f"_per_MPa{i if i > 1 else ''}" if i else "") + (("_per_N" if i == 0 else "_N") + (str(j) if j > 1 else "") if j else "")
            names.append(f"a{i}{j}_{unit}")
    return tuple(names)


def fit_surface(table: Table, load_degree: int = 1) -> FitResult:
    """One smooth surface l(P, F) = Σ a_ij·P^i·F^j (i ≤ 3, j ≤ load_degree) over all loads.

    Cubic in pressure like the paper's per-load fits, polynomial in load (linear by default,
    the least-assuming shape between characterized loads, as in :mod:`mckibben.models.mpam`), so
    it evaluates between the characterized loads; outside the data's pressure and load range the
    prediction is flagged.

    Parameters
    ----------
    table : Table
        An ``isotonic`` (or ``hysteresis``) table.
    load_degree : int, default 1
        Degree in load. [-]

    Returns
    -------
    FitResult
        ``a{i}{j}`` with P in MPa and F in N; ``predict(pressure=..., load=...)`` gives the length.
    """
    _need(table, ("isotonic", "hysteresis"), "surface")
    d = table.data
    what = _what("surface", table)
    require_distinct(d["pressure"], 5, "pressures", what, "a cubic in pressure")
    require_distinct(d["load"], load_degree + 1, "loads", what, f"degree {load_degree} in load")
    x = np.column_stack(_surface_terms(d["pressure"], d["load"], load_degree))

    def func(values, pressure, load):
        terms = np.broadcast_arrays(*_surface_terms(pressure, load, load_degree))
        return sum(v * t for v, t in zip(values, terms))

    return linear_fit(x, d["length"].to_numpy(), _surface_names(load_degree), model="surface", response="length_m",
                      clusters=_clusters(d),
                      what=what, valid_range=data_range(pressure=d["pressure"], load=d["load"]), func=func,
                      source=table.path)


# --------------------------------------------------------------------------------------------
# the spring model of [wickramatunge2010]


@dataclass(frozen=True)
class SpringFit:
    """A fitted spring model and its statistics.

    Attributes
    ----------
    model : SpringModel
        The fitted parameters (usable with :mod:`mckibben.models.spring`).
    result : FitResult
        Standard errors and statistics; names ``h2_m_per_Pa2``, ``h1_m_per_Pa``, ``h0_m`` then
        ``c{k}_{direction}_{range}`` in SI (N/(m·Pa^i·m^j) for the term P^i·Ls^j).
    blocks : tuple
        The (direction, range) coefficient sets fitted, in order.
    """

    model: SpringModel
    result: FitResult
    blocks: tuple


def _spring_model_from(values, blocks, terms, split, l0, prange, srange, citation):
    h = tuple(float(v) for v in values[:3])
    coeffs = {}
    k = 3
    for b in blocks:
        coeffs[b] = tuple(float(v) for v in values[k:k + len(terms)])
        k += len(terms)
    return SpringModel(l0, h, coeffs, tuple(terms), split, prange, srange, citation)


def fit_spring(table: Table, terms=DEFAULT_TERMS, split_pressure: float | None = None,
               nominal_length: float | None = None) -> SpringFit:
    """Fit the spring model F = K(P, Ls)·Ls, Ls = L − Lu(P), to force–length data.

    Lu(P) = h2·P² + h1·P + h0 and one stiffness polynomial per (direction, pressure range) are
    fitted jointly by nonlinear least squares on the force. Force–length loops give the direction
    (elongation/contraction); an isotonic table (hanging loads) is taken as one direction
    (elongation: the loads are hung on) with the load as the force.

    Parameters
    ----------
    table : Table
        A ``force_length`` or ``isotonic`` table.
    terms : sequence of (int, int)
        Exponents (i, j) of the stiffness terms P^i·Ls^j (default eq. 2 as read). [-]
    split_pressure : float, optional
        Pressure between the low (≤) and high range. Default: the median of the distinct
        pressures, so each range gets half of them; ``numpy.inf`` fits one range. [Pa]
    nominal_length : float, optional
        L0 stored in the model (default: the longest length in the data). [m]

    Returns
    -------
    SpringFit

    References
    ----------
    Wickramatunge & Leephakpreeda (2010) [wickramatunge2010], eq. (1)–(2), Tables 1–2, §5.
    """
    law = _SPRING_LAW
    _need(table, law.own_fit.tables, law.name)
    d = table.data
    what = _what(law.name, table)
    p = d["pressure"].to_numpy()
    ell = d["length"].to_numpy()
    force = (d["force"] if "force" in d else d["load"]).to_numpy()
    direction = d["direction"].to_numpy() if "direction" in d else np.full(len(d), ELONGATION)
    pk = _pkey(p)
    pressures = np.unique(pk)
    require_distinct(p, 3, "pressures", what, "Lu(P), a quadratic in pressure,")
    split = float(np.median(pressures)) if split_pressure is None else float(split_pressure)
    rng = np.where(p <= split, LOW, HIGH)
    blocks = tuple((dn, r) for dn in DIRECTIONS for r in (LOW, HIGH) if np.any((direction == dn) & (rng == r)))
    n_p_terms = sum(1 for i, _ in terms if i > 0)
    for dn, r in blocks:
        sel = (direction == dn) & (rng == r)
        w = f"{what} ({dn}, {r} range)"
        require_points(int(sel.sum()), len(terms), w)
        if n_p_terms:
            require_distinct(p[sel], 2, "pressures", w, "K's pressure terms")
    npar = 3 + len(blocks) * len(terms)
    require_points(len(d), npar, what)

    # scales: each scaled parameter is of order one
    ps = float(np.max(p)) or 1.0
    lspan = float(np.ptp(ell)) or float(np.max(ell)) * 0.1
    fs = float(np.max(np.abs(force))) or 1.0
    scale = [lspan / ps**2, lspan / ps, lspan]
    for _ in blocks:
        scale += [fs / (lspan * ps**i * lspan**j) for i, j in terms]
    scale = np.asarray(scale)

    # start: Lu per pressure from the least-loaded point, a quadratic through those; then K linear
    lu_pts = []
    for pv in pressures:
        sel = pk == pv
        if np.unique(force[sel]).size >= 2:  # zero-force length of a straight line through L(F)
            intercept = np.polyfit(force[sel], ell[sel], 1)[1]
        else:
            intercept = ell[sel][0]
        lu_pts.append(min(intercept, float(np.min(ell[sel]))))
    h_start = np.polyfit(pressures, lu_pts, 2)
    stretch0 = np.maximum(ell - np.polyval(h_start, p), 1e-6 * lspan)
    c_start = []
    for dn, r in blocks:
        sel = (direction == dn) & (rng == r)
        x = np.column_stack([p[sel] ** i * stretch0[sel] ** j * stretch0[sel] for i, j in terms])
        c, *_ = np.linalg.lstsq(x, force[sel], rcond=None)
        c_start += list(c)
    theta0 = np.concatenate([h_start, c_start]) / scale
    l0 = float(nominal_length) if nominal_length is not None else float(np.max(ell))
    prange = (float(np.min(p)), float(np.max(p)))

    def model_of(values):
        return _spring_model_from(values, blocks, terms, split, l0, prange, (0.0, np.inf), f"fitted to {table.path}")

    def residual(theta):
        f_hat, _ = spring_force(ell, p, model_of(theta * scale), direction)
        return (f_hat - force)

    names = ["h2_m_per_Pa2", "h1_m_per_Pa", "h0_m"]
    for dn, r in blocks:
        names += [f"c{k}_{dn}_{r}" for k in range(len(terms) - 1, -1, -1)] if tuple(terms) == DEFAULT_TERMS else \
            [f"c_P{i}_Ls{j}_{dn}_{r}" for i, j in terms]

    def func(values, length, pressure, direction=ELONGATION):
        return spring_force(length, pressure, model_of(values), direction)[0]

    res = nonlinear_fit(residual, theta0, names, model=law.name, response="force_N", what=what, clusters=_clusters(d),
                        valid_range=data_range(pressure=p, length=ell), scale=scale, func=func,
                        source=table.path, y=force)
    stretch = ell - np.polyval(res.values[:3], p)
    srange = (0.0, float(np.max(stretch)))
    model = _spring_model_from(res.values, blocks, terms, split, l0, prange, srange, f"fitted to {table.path}")
    return SpringFit(model, res, blocks)


def _fit_spring_table(table: Table, spec: MuscleSpec | None, split_pressure: float | None) -> tuple[list, dict]:
    """``fit --model spring`` on its own tables: the fit and what ``--json`` adds (split, blocks, terms)."""
    sf = fit_spring(table, split_pressure=split_pressure, nominal_length=spec.nominal_length if spec else None)
    return [sf.result], {"split_pressure_Pa": sf.model.split_pressure, "blocks": [list(b) for b in sf.blocks],
                         "terms_P_Ls_exponents": [list(t) for t in sf.model.terms]}


#: Each law's own fit procedure on the non-isometric tables of its :attr:`Law.own_fit
#: <mckibben.models.laws.Law.own_fit>`, by the law's registry name:
#: ``procedure(table, muscle or None, split_pressure [Pa] or None) -> (fits, extra --json fields)``.
#: The law conformance suite holds this to :func:`mckibben.models.laws.own_fit_laws`.
OWN_FITS = {_SPRING_LAW.name: _fit_spring_table}


def spring_names_for_terms(terms=DEFAULT_TERMS) -> list[str]:
    """Coefficient names of one (direction, range) set for the default terms: c3, c2, c1, c0.

    Parameters
    ----------
    terms : sequence of (int, int)
        Stiffness terms. [-]
    """
    return [f"c{k}" for k in range(len(terms) - 1, -1, -1)]


# --------------------------------------------------------------------------------------------
# physical models, fitted


def _positive(d: pd.DataFrame) -> np.ndarray:
    return d["pressure"].to_numpy() > 0


def _clusters(d: pd.DataFrame):
    return d["trial"].to_numpy() if "trial" in d and d["trial"].nunique() >= 2 else None


def fit_chou_hannaford(table: Table, muscle: MuscleSpec) -> FitResult:
    """Chou–Hannaford length under a hanging load with a fitted effective strand length and D0.

    .. deprecated::
        ``fit chou-hannaford`` and ``compare`` fit every registered law to an isotonic table through its
        force, F(P, L) = load (:func:`mckibben.fit.isometric.fit_isotonic_law`, the law's own fit
        spec); this length-residual fit of the old parameters is kept for scripts that call it.

    l = b·sqrt((4F/(π·D0²·P) + 1)/3); b and D0 are fitted within physical bounds: b in
    [L0, L0/cos 54.7°] (a strand at least as long as the muscle, a braid angle at rest below
    54.7°), D0 within :data:`~mckibben.fit.isometric.D0_FACTOR` × the outer diameter. The fit starts
    from several braid angles (it is non-convex) and is flagged at a bound, with R² < 0.5 or an
    ill-conditioned covariance. Rows at zero pressure are left out: the model has no stiffness
    there.

    Parameters
    ----------
    table : Table
        An ``isotonic`` table.
    muscle : MuscleSpec
        Nominal length L0 and outer diameter.

    Returns
    -------
    FitResult
        ``b_m`` and ``d0_m``; ``predict(pressure=..., load=...)`` gives the length.

    References
    ----------
    Chou & Hannaford (1996); :func:`mckibben.models.physical.length_under_load`.
    """
    warnings.warn("fit_chou_hannaford is deprecated: fit every law through its force, "
                  "mckibben.fit.isometric.fit_isotonic_law(table, muscle, 'chou-hannaford')", DeprecationWarning, stacklevel=2)

    _need(table, ("isotonic", "hysteresis"), _CH_LAW.name)
    d = table.data[_positive(table.data)]
    what = _what(_CH_LAW.name, table)
    require_distinct(d["pressure"], 3, "pressures above zero", what, "Chou–Hannaford (2 parameters and a check)")
    od = muscle.need("outer_diameter", _CH_LAW.name)
    l0 = muscle.nominal_length
    p, f, ell = d["pressure"].to_numpy(), d["load"].to_numpy(), d["length"].to_numpy()

    def func(values, pressure, load):
        geom = BraidGeometry(float(values[0]), float(values[0] / (np.pi * values[1])))
        return length_under_load(pressure, load, geom, _CH_LAW.name)[0]

    lo = np.array([l0, D0_FACTOR[0] * od])
    hi = np.array([l0 / np.cos(THETA_MAX), D0_FACTOR[1] * od])
    starts = [np.array([l0 / np.cos(np.deg2rad(t)), fac * od]) for t in THETA_STARTS_DEG for fac in (1.5, 3.0)]
    return bounded_fit(lambda v: func(v, p, f), ell, starts, ("b_m", "d0_m"), lo, hi, model=_CH_LAW.name,
                       response="length_m", what=what, valid_range=data_range(pressure=p, load=f), func=func,
                       clusters=_clusters(d), source=table.path)


def fit_tondu_lopez(table: Table, muscle: MuscleSpec) -> FitResult:
    """Tondu–Lopez length under a hanging load with fitted contraction correction k and radius r0.

    .. deprecated::
        ``fit tondu-lopez`` and ``compare`` fit every registered law to an isotonic table through its
        force, F(P, L) = load (:func:`mckibben.fit.isometric.fit_isotonic_law`, the law's own fit
        spec); this length-residual fit of the old parameters is kept for scripts that call it.

    l = L0·(1 − ε), ε from F = π·r0²·P·[a(1 − kε)² − b] (α0 from the muscle file). k within
    :data:`~mckibben.fit.isometric.K_BOUNDS`, r0 within :data:`~mckibben.fit.isometric.R0_FACTOR` ×
    the outer diameter; flagged as :func:`fit_chou_hannaford`. Rows at zero pressure are left out.

    Parameters
    ----------
    table : Table
        An ``isotonic`` table.
    muscle : MuscleSpec
        Nominal length L0, outer diameter and braid angle α0.

    Returns
    -------
    FitResult
        ``k`` [-] and ``r0_m``; ``predict(pressure=..., load=...)`` gives the length.

    References
    ----------
    Tondu & Lopez (2000); :func:`mckibben.models.physical.tondu_lopez_contraction`.
    """
    warnings.warn("fit_tondu_lopez is deprecated: fit every law through its force, "
                  "mckibben.fit.isometric.fit_isotonic_law(table, muscle, 'tondu-lopez')", DeprecationWarning, stacklevel=2)

    _need(table, ("isotonic", "hysteresis"), _TL_LAW.name)
    d = table.data[_positive(table.data)]
    what = _what(_TL_LAW.name, table)
    require_distinct(d["pressure"], 3, "pressures above zero", what, "Tondu–Lopez (2 parameters and a check)")
    od = muscle.need("outer_diameter", _TL_LAW.name)
    p, f, ell = d["pressure"].to_numpy(), d["load"].to_numpy(), d["length"].to_numpy()
    l0, a0 = muscle.nominal_length, muscle.need("braid_angle", f"{_TL_LAW.name} on isotonic data")

    def func(values, pressure, load):
        eps, _ = tondu_lopez_contraction(pressure, load, values[1], a0, values[0])
        return l0 * (1.0 - eps)

    lo = np.array([K_BOUNDS[0], R0_FACTOR[0] * od])
    hi = np.array([K_BOUNDS[1], R0_FACTOR[1] * od])
    starts = [np.array([k, fac * od]) for k in (1.0, 2.0) for fac in (0.4, 0.7)]
    return bounded_fit(lambda v: func(v, p, f), ell, starts, ("k", "r0_m"), lo, hi, model=_TL_LAW.name,
                       response="length_m", what=what, valid_range=data_range(pressure=p, load=f), func=func,
                       clusters=_clusters(d), source=table.path)


# --------------------------------------------------------------------------------------------
# pressure step responses


def first_order_step(t, p0, p_final, tau, t0):
    """First-order step response p(t) = p0 + (p∞ − p0)(1 − exp(−(t − t0)/τ)) for t ≥ t0.

    Parameters
    ----------
    t : array_like
        Time. [s]
    p0 : float
        Pressure before the step. [Pa]
    p_final : float
        Final pressure p∞. [Pa]
    tau : float
        Time constant. [s]
    t0 : float
        Time of the command step. [s]

    Returns
    -------
    numpy.ndarray
        Pressure. [Pa]

    References
    ----------
    [mpam-characterization], §IV.A: first order, τ ≈ 0.09 s, no overshoot.
    """
    t = np.asarray(t, dtype=float)
    return p0 + (p_final - p0) * np.where(t >= t0, -np.expm1(-(t - t0) / tau), 0.0)


def fit_first_order(table: Table) -> dict[float, FitResult]:
    """First-order fit (p0, p∞, τ) of pressure step responses, one per command step size.

    The step time t0 of each trial is the first sample whose command differs from the first
    sample's; trials with the same command step are fitted together.

    Parameters
    ----------
    table : Table
        A ``step_response`` table.

    Returns
    -------
    dict
        command after the step [-] -> FitResult with ``p0_Pa``, ``p_final_Pa``, ``tau_s``.
    """
    _need(table, ("step_response",), "first-order")
    d = table.data
    rows = []
    for trial, grp in d.groupby("trial", sort=True):
        cmd = grp["command"].to_numpy()
        changed = np.flatnonzero(cmd != cmd[0])
        if changed.size == 0:
            raise InputError(f"{table.where(int(grp.index[0]), 'command')}: trial {trial} has no command step")
        i = changed[0]
        rows.append((round(float(cmd[i]), 9), grp["time"].to_numpy() - grp["time"].to_numpy()[i], grp["pressure"].to_numpy(),
                     np.full(len(grp), trial)))
    out = {}
    for cmd in sorted({r[0] for r in rows}):
        t = np.concatenate([r[1] for r in rows if r[0] == cmd])
        pr = np.concatenate([r[2] for r in rows if r[0] == cmd])
        trials = np.concatenate([r[3] for r in rows if r[0] == cmd])
        cond = {"command": cmd}
        what = _what("first-order", table, cond)
        after = t > 0
        require_points(int(after.sum()), 3, what)
        p0 = float(np.mean(pr[~after])) if np.any(~after) else float(pr[0])
        pf = float(np.mean(pr[t >= 0.8 * t.max()]))
        span = max(abs(pf - p0), 1e3)
        tau0 = max(float(t[after][np.argmax(np.abs(pr[after] - p0) >= 0.632 * abs(pf - p0))]), 1e-3)
        scale = np.array([span, span, tau0])

        def func(values, time):
            return first_order_step(time, values[0], values[1], values[2], 0.0)

        out[cmd] = nonlinear_fit(lambda th: func(th * scale, t) - pr, [p0 / span, pf / span, 1.0],
                                 ("p0_Pa", "p_final_Pa", "tau_s"), model="first-order", response="pressure_Pa",
                                 what=what, valid_range=data_range(time=t), scale=scale, func=func,
                                 condition=cond, source=table.path, y=pr,
                                 clusters=trials if np.unique(trials).size >= 2 else None,
                                 bounds=([-np.inf, -np.inf, 1e-6], [np.inf, np.inf, np.inf]))
    return out


# --------------------------------------------------------------------------------------------
# repeated trials


def trial_stats(table: Table, x: str, y: str, by: tuple[str, ...] = ()) -> pd.DataFrame:
    """Mean ± standard deviation of ``y`` per condition over repeated trials (the error bars).

    Parameters
    ----------
    table : Table
        Any validated table.
    x : str
        The swept quantity, e.g. ``"pressure"``. [-]
    y : str
        The measured quantity, e.g. ``"length"``. [-]
    by : tuple of str
        Further condition columns, e.g. ``("load",)``. [-]

    Returns
    -------
    pandas.DataFrame
        Columns ``by + (x, "mean", "std", "n")``; ``std`` is the sample standard deviation
        (ddof=1; NaN for a single trial). [SI]
    """
    d = table.data.copy()
    keys = list(by) + [x]
    for k in keys:
        if d[k].dtype.kind == "f":
            d[k] = d[k].round(9)
    g = d.groupby(keys, sort=True)[y]
    out = g.agg(["mean", "std", "count"]).reset_index().rename(columns={"count": "n"})
    return out

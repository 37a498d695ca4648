"""One fit-result family: every fitted model is a :class:`~mckibben.results.FitBase` and speaks its vocabulary.

The family is found by scanning the source (every class named ``*Fit`` or ``FitResult`` in
``src/mckibben``), so a new fit class that is not a member fails here; then a real fit of each
kind, on small synthetic data with known parameters or on the bundled data sets, is held to the
vocabulary: names, values, standard errors and 95 % intervals that agree with each other,
``to_pandas()``'s parameter table, a JSON-able ``to_dict()``, a file and a Figure.
"""

from __future__ import annotations

import ast
import importlib
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from mckibben.data import read_muscle, read_table
from mckibben.datasets.campaign import BUNDLED
from mckibben.datasets.isometric import BUNDLED_ISOMETRIC
from mckibben.fit.core import FitResult, linear_fit
from mckibben.fit.direction import fit_direction_aware
from mckibben.fit.hysteresis import fit_prandtl_ishlinskii
from mckibben.fit.isometric import fit_isometric
from mckibben.fit.registry import fit_table
from mckibben.fit.static import fit_spring
from mckibben.fit.step import fill_response, fit_fill, fit_step_response, fopdt_response
from mckibben.models.hysteresis import PrandtlIshlinskii, apply, thresholds_uniform
from mckibben.results import FitBase, Result, to_jsonable, unit_of_name

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "mckibben"
COMMERCIAL = BUNDLED_ISOMETRIC / "commercial10"
PARAMETER_COLUMNS = ["name", "value", "stderr", "ci95_low", "ci95_high", "unit"]


def _fit_classes() -> list[tuple[str, str]]:
    """(module, class name) of every class in src/mckibben named ``*Fit`` or ``FitResult``, from the source."""
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ClassDef) and (node.name.endswith("Fit") or node.name == "FitResult"):
                found.append((".".join(parts), node.name))
    return found


FIT_CLASSES = _fit_classes()


def test_the_scan_finds_the_fits():
    """The scan sees the fit classes (a broken path would make the next test pass vacuously)."""
    names = {c for _, c in FIT_CLASSES}
    assert {"FitResult", "StepFit", "FillFit", "SpringFit", "PIFit", "IsometricFit", "TableFit",
            "DirectionAwareFit"} <= names


@pytest.mark.parametrize("module, name", FIT_CLASSES, ids=[f"{m}.{c}" for m, c in FIT_CLASSES])
def test_every_fit_class_is_in_the_family(module, name):
    cls = getattr(importlib.import_module(module), name)
    assert issubclass(cls, FitBase) and issubclass(cls, Result), f"{module}.{name} is not a FitBase"
    if not cls.__subclasses__():  # a shared base (ResponseFit) is no function's result; its members are
        assert cls.call.startswith("mckibben."), f"{module}.{name}: its provenance names no call"


def test_step_and_fill_share_their_fields_through_one_base():
    """FillFit does not repeat StepFit's fields: both take them from one base (ResponseFit)."""
    import dataclasses

    from mckibben.fit.step import FillFit, ResponseFit, StepFit

    shared = {f.name for f in dataclasses.fields(ResponseFit)}
    assert {"names", "values", "stderr", "t_step", "t", "residuals", "rmse", "r2", "aic", "flags"} <= shared
    for cls in (StepFit, FillFit):
        own = set(cls.__dataclass_fields__) - shared
        assert own <= {"order", "input_step", "supply", "shape"}, (cls.__name__, own)
        assert not shared & set(vars(cls).get("__annotations__", {})), cls.__name__


# --------------------------------------------------------------------------------------------
# real fits of each kind


def _linear():
    """FitResult: y = 2·x + 1 with 0.01 white noise (known parameters)."""
    rng = np.random.default_rng(3)
    x = np.linspace(0.0, 1.0, 40)
    y = 2.0 * x + 1.0 + rng.normal(0.0, 0.01, x.size)
    fit = linear_fit(np.column_stack([x, np.ones_like(x)]), y, ["slope_m", "offset_m"], model="line",
                     response="length_m", what="fit line", valid_range={"pressure": (0.0, 1.0)})
    return fit, {"slope_m": 2.0, "offset_m": 1.0}


def _step():
    """StepFit: a first-order step, 2 kPa noise (as test_identify)."""
    rng = np.random.default_rng(0)
    t = np.arange(0.0, 1.0, 1e-3)
    u = np.where(t >= 0.1, 160.0, 0.0)
    y = fopdt_response(t, 2500.0, 0.09, 0.01, y0=60e3, t_step=0.1, input_step=160) + rng.normal(0, 2e3, t.size)
    return fit_step_response(t, y, u), {"gain": 2500.0, "tau_s": 0.09, "dead_time_s": 0.01}


def _fill():
    """FillFit: a fill of a growing volume, 1 kPa noise (test_fit_fill's truth)."""
    rng = np.random.default_rng(5)
    t = np.linspace(0.0, 3.0, 1500)
    y = fill_response(t, 15e3, 640e3, 0.25, 0.45, 0.008, t_step=0.0, volume_growth=2.5) + rng.normal(0, 1e3, t.size)
    return fit_fill(t, y, t_step=0.0), {"tau_fill_s": 0.25, "b": 0.45}


def _pi():
    """PIFit: a known Prandtl–Ishlinskii operator, 5 µm noise (as test_hysteresis_pi)."""
    r = thresholds_uniform(6, 0.6e6)
    w = np.array([20e-9, 8e-9, 6e-9, 4e-9, 3e-9, 2e-9])
    rng = np.random.default_rng(1)
    turns = np.r_[0.0, 0.7e6, rng.uniform(0.05e6, 0.65e6, 30)]
    u = np.concatenate([np.linspace(a, b, 4000 // turns.size) for a, b in zip(turns[:-1], turns[1:])])
    y, _ = apply(PrandtlIshlinskii(r, w, output_offset=1e-3, input_unit="Pa", output_unit="m"), u)
    fit = fit_prandtl_ishlinskii(u, y + rng.normal(0.0, 5e-6, u.size), r, input_unit="Pa", output_unit="m")
    return fit, {"offset_m": 1e-3, **{f"w{i}_m_per_Pa": float(v) for i, v in enumerate(w)}}


def _spring():
    """SpringFit: the spring law on the bundled campaign's force–length loops."""
    return fit_spring(read_table(BUNDLED / "mpam97" / "force_length.csv")), {}


def _isometric():
    """IsometricFit: the spring law on the bundled commercial muscle's isometric table."""
    return fit_isometric(read_table(COMMERCIAL / "isometric.csv"), read_muscle(COMMERCIAL / "muscle.toml"), "spring"), {}


def _direction_aware():
    """DirectionAwareFit: relative-strain with a play, on the bundled isometric table."""
    table, muscle = read_table(COMMERCIAL / "isometric.csv"), read_muscle(COMMERCIAL / "muscle.toml")
    return fit_direction_aware(table, muscle, "relative-strain", "play"), {}


def _table_one():
    """TableFit of one fit (an isometric table)."""
    return fit_table(COMMERCIAL / "isometric.csv", "relative-strain"), {}


def _table_per_load():
    """TableFit of several fits: one cubic per load of the bundled campaign's isotonic table."""
    return fit_table(BUNDLED / "mpam97" / "isotonic.csv", "cubic"), {}


KINDS = {"FitResult": _linear, "StepFit": _step, "FillFit": _fill, "PIFit": _pi, "SpringFit": _spring,
         "IsometricFit": _isometric, "DirectionAwareFit": _direction_aware, "TableFit": _table_one,
         "TableFit-per-load": _table_per_load}


@pytest.fixture(scope="module", params=list(KINDS))
def fitted(request):
    fit, truth = KINDS[request.param]()
    return request.param, fit, truth


def test_every_fit_class_has_a_real_fit_here():
    assert {c for _, c in FIT_CLASSES} - {"ResponseFit"} <= {k.split("-")[0] for k in KINDS}


def test_names_values_stderr_and_intervals_agree(fitted):
    kind, fit, truth = fitted
    assert type(fit).__name__ == kind.split("-")[0]
    p = len(fit.names)
    assert p >= 2 and all(isinstance(n, str) for n in fit.names) and len(set(fit.names)) == p
    values, se, ci = np.asarray(fit.values), np.asarray(fit.stderr), np.asarray(fit.ci95)
    assert values.shape == (p,) and se.shape == (p,) and ci.shape == (p, 2) and len(fit.units) == p
    assert fit.params == {n: float(v) for n, v in zip(fit.names, values)}
    for k, n in enumerate(fit.names):
        assert fit[n] == values[k] and (fit.se(n) == se[k] or np.isnan(se[k]))
    free = np.isfinite(se)  # a parameter held at a bound has no standard error
    assert free.sum() >= 2
    assert np.all(se[free] >= 0)
    # each interval is centred on its value, t·stderr wide on each side: t of a 95 % interval lies
    # between the normal's 1.96 and t(1 dof)'s 12.71
    np.testing.assert_allclose(ci[free].mean(axis=1), values[free], rtol=1e-9, atol=1e-12 * np.abs(values).max())
    half = (ci[free, 1] - ci[free, 0]) / 2
    ratio = half[se[free] > 0] / se[free][se[free] > 0]
    assert np.all((ratio > 1.959) & (ratio < 12.71)), ratio
    # the known parameters of the synthetic fits lie in their intervals
    for n, true in truth.items():
        k = list(fit.names).index(n)
        assert ci[k, 0] <= true <= ci[k, 1], (n, true, ci[k])
    r = np.asarray(fit.residuals)
    assert fit.n_points == r.size > p and fit.dof == fit.n_points - p
    assert fit.residual_rms == pytest.approx(float(np.sqrt(np.mean(r**2))), rel=1e-12)
    assert np.isfinite(fit.aic) or getattr(fit, "priors", None)
    assert isinstance(fit.flags, tuple) and isinstance(fit.notes, tuple) and isinstance(fit.source, str)


def test_parameter_table_file_dict_and_figure(fitted, tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.figure import Figure

    kind, fit, _ = fitted
    df = fit.to_pandas()
    cols = (["condition"] if isinstance(fit.fits if hasattr(fit, "fits") else None, list) else []) + PARAMETER_COLUMNS
    assert list(df.columns) == cols and len(df) == len(fit.names)
    np.testing.assert_array_equal(df["value"].to_numpy(), np.asarray(fit.values))
    np.testing.assert_array_equal(df[["ci95_low", "ci95_high"]].to_numpy(), np.asarray(fit.ci95))
    assert list(df["unit"]) == list(fit.units)
    assert df.attrs["provenance"]["call"] == fit.call
    # the dict is JSON as Python writes it, and strict JSON once NaN is None (what --json prints)
    json.loads(json.dumps(fit.to_dict()))
    json.dumps(to_jsonable(fit.to_dict()), allow_nan=False)
    out = fit.to_file(tmp_path / "params.csv")
    back = pd.read_csv(out)
    assert list(back["value"]) == pytest.approx(list(df["value"]), rel=1e-12)
    fig = fit.plot()
    assert isinstance(fig, Figure) and fig.axes
    plt.close(fig)
    assert "\n" not in repr(fit) and repr(fit).startswith(type(fit).__name__ + "(")


def test_a_record_wrapper_speaks_its_records_words():
    """IsometricFit, DirectionAwareFit, SpringFit and PIFit give their least-squares record's words."""
    for make, attr in ((_isometric, "result"), (_pi, "fit")):
        fit, _ = make()
        inner = getattr(fit, attr)
        assert isinstance(inner, FitResult)
        assert fit.names == inner.names and fit.flags == tuple(inner.flags) and fit.source == inner.source
        np.testing.assert_array_equal(fit.ci95, inner.ci95)
        assert fit.aic == inner.aic and fit.n_points == inner.n_points


def test_aic_is_nan_where_the_fit_is_no_plain_least_squares():
    fit, _ = _linear()
    import dataclasses

    assert np.isfinite(fit.aic)
    assert np.isnan(dataclasses.replace(fit, priors={"slope_m": (2.0, 1.5)}).aic)
    assert np.isnan(dataclasses.replace(fit, censored=True).aic)


def test_a_step_fit_keeps_its_words_and_its_own():
    """The family's words beside what callers read: params, se(name), confidence_intervals, to_dict."""
    fit, _ = _step()
    assert fit.gain == fit["gain"] and fit.tau == fit["tau_s"] and fit.rmse == fit.residual_rms
    lo, hi = fit.confidence_intervals(0.95)["tau_s"]
    np.testing.assert_allclose([lo, hi], fit.ci95[list(fit.names).index("tau_s")], rtol=1e-12)
    d = fit.to_dict("Pa", "count")
    assert d["gain_Pa_per_count_stderr"] == fit.se("gain") and d["n_samples"] == fit.n_points


def test_unknown_parameter_names_the_choices():
    fit, _ = _linear()
    with pytest.raises(ValueError, match="slope_m"):
        fit["slope"]


@pytest.mark.parametrize("name, unit", [("a30_N_per_MPa3", "N_per_MPa3"), ("dead_time_s", "s"), ("zeta", ""),
                                        ("wn_rad_s", "rad_s"), ("c3_per_MPa3", "per_MPa3"), ("p0_Pa", "Pa"),
                                        ("friction_area_m2", "m2"), ("volume_growth", "")])
def test_unit_of_a_parameter_name(name, unit):
    assert unit_of_name(name) == unit

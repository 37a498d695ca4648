"""A muscle k times larger in every length gets the same verdicts: no constant in N or mm hides in a fit.

Geometric similarity: scale every length of a campaign (held lengths, rest lengths, the muscle
file's nominal length and outer diameter) by k and every force by k² (force is pressure times an
area), keep the pressures. Every law's force is pressure × area × a function of contraction, so a
fit whose bounds, priors, starts and flags are all read from the data and the muscle file gives
the same held-out error in % of peak, the same flags and the same best model, with lengths in its
parameters k times larger. A bound, a prior, a start or a flag threshold written as an absolute
force or length (a 5 N scale, a 1 mm floor) breaks this, on the 1.2 mm miniature muscle (k ≈ 0.1
of a 12 mm one) or on a 20 mm commercial one (k = 2). The same check on the real Festo 10 mm
campaign scaled to 20 mm (``benchmarks/bench_real_models.py --data``) is in benchmarks/RESULTS.md.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import mckibben
from mckibben.data import read_muscle, read_table
from mckibben.fit.direction import fit_direction_aware, heldout_gap
from mckibben.fit.isometric import compare_isometric, fit_isometric
from mckibben.models.laws.virtual_work import VirtualWork

BUNDLED = Path(mckibben.__file__).parent / "datasets" / "isometric" / "commercial10"
#: The scales: the seed paper's 1.2 mm muscle against this 12 mm one, and a 24 mm one.
SCALES = (0.1, 2.0)
#: Held-out error agreement, percentage points of peak (the optimiser's tolerance, not the law's).
PCT_TOL = 0.05


def _scaled_commercial(k: float, folder: Path):
    d = pd.read_csv(BUNDLED / "isometric.csv")
    spec = read_muscle(BUNDLED / "muscle.toml")
    d["held_length_mm"] *= k
    d["force_N"] *= k * k
    folder.mkdir(parents=True, exist_ok=True)
    d.to_csv(folder / "isometric.csv", index=False)
    (folder / "muscle.toml").write_text(f'id = "scaled"\nnominal_length_mm = {spec.nominal_length * 1e3 * k!r}\n'
                                        f"outer_diameter_mm = {spec.outer_diameter * 1e3 * k!r}\n")
    return read_table(folder / "isometric.csv"), read_muscle(folder / "muscle.toml")


@pytest.fixture(scope="module")
def commercial(tmp_path_factory):
    root = tmp_path_factory.mktemp("scaled")
    return {k: _scaled_commercial(k, root / f"k{k}") for k in (1.0,) + SCALES}


@pytest.fixture(scope="module")
def comparisons(commercial):
    return {k: compare_isometric(t, m, "leave-one-length-out", tare="lowest") for k, (t, m) in commercial.items()}


@pytest.mark.parametrize("k", SCALES)
def test_every_law_scores_and_is_flagged_the_same_on_a_similar_muscle(comparisons, k):
    base, scaled = comparisons[1.0].to_dict(), comparisons[k].to_dict()
    assert scaled["best"] == base["best"]
    by_model = {s["model"]: s for s in base["models"]}
    assert {s["model"] for s in scaled["models"]} == set(by_model)
    for s in scaled["models"]:
        b = by_model[s["model"]]
        assert s["flags"] == b["flags"], (s["model"], k, s["flags"], b["flags"])
        assert s["cv_rmse_pct_of_peak"] == pytest.approx(b["cv_rmse_pct_of_peak"], abs=PCT_TOL), (s["model"], k)
        assert s["cv_rmse_N"] == pytest.approx(b["cv_rmse_N"] * k * k, rel=PCT_TOL / 2)


@pytest.mark.parametrize("k", SCALES)
def test_every_fitted_law_predicts_k_squared_the_force_at_similar_points(comparisons, commercial, k):
    """Each law fitted on the scaled table, at k times the held lengths: k² times the force, every law."""
    table = commercial[1.0][0]
    ell = np.unique(table.data["held_length"].to_numpy())[[0, -1]]
    p, ell = np.meshgrid([0.1e6, 0.3e6, 0.5e6], ell)
    for model, fit in comparisons[k].fits.items():
        base = comparisons[1.0].fits[model].result
        scaled = fit.result
        assert scaled.func(scaled.values, pressure=p.ravel(), length=ell.ravel() * k) == pytest.approx(
            base.func(base.values, pressure=p.ravel(), length=ell.ravel()) * k * k, rel=1e-3, abs=1e-3 * k * k), model


@pytest.mark.parametrize("k", SCALES)
def test_the_direction_aware_form_keeps_its_play_and_its_gap_ratio(commercial, k):
    """The play acts on pressure, which similarity keeps: the same threshold, the same held-out gap ratio."""
    base = fit_direction_aware(*commercial[1.0], "spring", "play", tare="lowest").result
    scaled = fit_direction_aware(*commercial[k], "spring", "play", tare="lowest").result
    assert scaled["play_threshold_Pa"] == pytest.approx(base["play_threshold_Pa"], rel=1e-3)
    assert scaled.flags == base.flags
    g0 = heldout_gap(*commercial[1.0], "spring", "play", tare="lowest").metrics
    g1 = heldout_gap(*commercial[k], "spring", "play", tare="lowest").metrics
    assert g1["direction_aware_gap_error_ratio"] == pytest.approx(g0["direction_aware_gap_error_ratio"], abs=1e-3)


def _family(k: float, folder: Path):
    rng = np.random.default_rng(41)
    rows = []
    for m, (rec, shift) in {"a": (0.12, 1.5e-3), "b": (0.20, 0.5e-3), "c": (0.32, 1.0e-3)}.items():
        law = VirtualWork(530.0 * k * k, -2400.0 * k * k, 400.0 * k * k, 130.0 * k * k, 0.025, 720.0 * k * k,
                          0.02 * k, (rec + shift) * k)
        noise = rng.normal(0, 1.0, (4, 2, 13)) * k * k
        for i, eps in enumerate((0.0, 0.04, 0.08, 0.12)):
            ell = rec * k * (1 - eps)
            for j, trial in enumerate((1, 2)):
                p = np.linspace(0.0, 0.6e6, 13)
                f = law.force(p, ell) + noise[i, j]
                rows += [dict(held_length_mm=ell * 1e3, pressure_kPa=a / 1e3, force_N=b, direction="inflate",
                              trial=trial, muscle=m, rest_length_mm=rec * k * 1e3) for a, b in zip(p, f)]
    folder.mkdir(parents=True, exist_ok=True)
    pd.DataFrame(rows).to_csv(folder / "fam.csv", index=False)
    (folder / "t.toml").write_text(f'id = "t"\nnominal_length_mm = {200 * k!r}\nouter_diameter_mm = {10 * k!r}\n')
    return read_table(folder / "fam.csv"), read_muscle(folder / "t.toml")


def test_a_family_with_fitted_rest_lengths_is_scored_the_same_at_twice_the_size(tmp_path):
    """Leave-one-muscle-out with each rest length fitted: the same % of peak; the shifts scale by k."""
    out = {}
    for k in (1.0, 2.0):
        table, muscle = _family(k, tmp_path / f"k{k}")
        c = compare_isometric(table, muscle, "leave-one-muscle-out", models=["virtual-work"],
                              rest_lengths="fitted").to_dict()
        fit = fit_isometric(table, muscle, "virtual-work", rest_lengths="fitted").result
        out[k] = (c["models"][0], fit)
    (s1, f1), (s2, f2) = out[1.0], out[2.0]
    assert s2["flags"] == s1["flags"]
    assert s2["cv_rmse_pct_of_peak"] == pytest.approx(s1["cv_rmse_pct_of_peak"], abs=PCT_TOL)
    for name in ("rest_shift_a_m", "rest_shift_b_m", "rest_shift_c_m", "end_zone_m"):
        assert f2[name] == pytest.approx(2.0 * f1[name], rel=1e-3, abs=1e-6), name

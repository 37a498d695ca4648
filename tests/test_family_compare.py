"""Held-out results per fold, and family tables (several muscles of one type) in fit and compare."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from mckibben.data import read_muscle, read_table
from mckibben.datasets.isometric import BUNDLED_ISOMETRIC
from mckibben.errors import InputError
from mckibben.fit.isometric import compare_isometric, fit_points, isometric_points

FOLDER = BUNDLED_ISOMETRIC / "commercial10"
ISO, MUSCLE = FOLDER / "isometric.csv", FOLDER / "muscle.toml"


def _family_csv(tmp_path, scale=0.8):
    """The synthetic campaign twice: as itself and as a shorter muscle (lengths scaled) of the same type."""
    d = pd.read_csv(ISO)
    short = d.assign(held_length_mm=d["held_length_mm"] * scale, muscle="short")
    d = d.assign(muscle="long", rest_length_mm=float(d["held_length_mm"].max()))
    short["rest_length_mm"] = float(d["held_length_mm"].max()) * scale
    path = tmp_path / "family.csv"
    pd.concat([d, short]).to_csv(path, index=False)
    return path


def test_compare_reports_every_fold_against_the_held_out_peak():
    c = compare_isometric(read_table(ISO), read_muscle(MUSCLE), "leave-one-length-out", models=["spring", "surface"])
    for s in c.scores:
        assert len(s["folds"]) == 4 and {"held_out", "rmse_N", "rmse_pct_of_peak"} <= set(s["folds"][0])
        # one muscle: each fold's percentage is of the table's peak, so the pooled figure sits among them
        pct = [f["rmse_pct_of_peak"] for f in s["folds"]]
        assert min(pct) <= s["cv_rmse_pct_of_peak"] <= max(pct)
        assert s["worst_fold_pct_of_peak"] == max(pct)
    assert c.to_dict()["models"][0]["folds"]


def test_a_family_table_is_read_and_refused_by_one_muscle_laws(tmp_path):
    t = read_table(_family_csv(tmp_path))
    d, report = isometric_points(t, "lowest")
    assert {"rest_length", "muscle"} <= set(d) and {r["muscle"] for r in report["per_run_N"]} == {"long", "short"}
    with pytest.raises(InputError, match="fit a family law"):
        fit_points(d, read_muscle(MUSCLE), "spring")


def test_leave_one_muscle_out_needs_a_family(tmp_path, cli):
    with pytest.raises(InputError, match="needs a family table"):
        compare_isometric(read_table(ISO), read_muscle(MUSCLE), "leave-one-muscle-out")
    r = cli("compare", str(ISO), "--cv", "leave-one-muscle-out")
    assert r.code == 2 and "needs a family table" in r.err and len(r.err.strip().splitlines()) == 1
    bad = tmp_path / "bad.csv"
    d = pd.read_csv(ISO).drop(columns="muscle")
    d.assign(rest_length_mm=np.where(np.arange(len(d)) < len(d) // 2, 300.0, 310.0)).to_csv(bad, index=False)
    r = cli("compare", str(bad), "--muscle-file", str(MUSCLE))
    assert r.code == 2 and r.err == (f"error: {bad}: column rest_length_mm holds 2 muscles (300, 310), each with its "
                                     "own rest length; pick one with --select rest_length_mm=300, or fit them as a "
                                     "family with a muscle column\n")
    # one rest length and no muscle column: one muscle, read as it is
    d.assign(rest_length_mm=300.0).to_csv(bad, index=False)
    assert cli("compare", str(bad), "--muscle-file", str(MUSCLE)).code == 0


def test_rest_length_needs_a_family_law_and_save(tmp_path, cli):
    r = cli("fit", str(ISO), "--model", "spring", "--rest-length", "200mm")
    assert r.code == 2 and "--rest-length" in r.err
    r = cli("fit", str(ISO), "--model", "spring", "--rest-length", "200mm", "--save", str(tmp_path / "x.toml"))
    assert r.code == 2 and "--rest-length" in r.err and not (tmp_path / "x.toml").exists()

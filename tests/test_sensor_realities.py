"""Sensor realities of isometric tables: a load cell's floor (rows at a rail), the pressure transducer's zero, the tare."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from mckibben.data import read_muscle, read_table
from mckibben.data.preprocessing import RAIL_MIN_ROWS, apply_pressure_zero, find_rails
from mckibben.datasets.isometric import BUNDLED_ISOMETRIC
from mckibben.errors import InputError
from mckibben.fit.isometric import fit_isometric, isometric_points

FOLDER = BUNDLED_ISOMETRIC / "commercial10"
ISO, MUSCLE = FOLDER / "isometric.csv", FOLDER / "muscle.toml"
FLOOR = -8.735  # the real Festo rig's load cell reads no lower (PROVENANCE.md of the real data)


def _floored(tmp_path, offset_kpa=0.0):
    """The synthetic campaign read by a load cell with a floor, and a transducer reading offset_kpa at atmosphere."""
    d = pd.read_csv(ISO)
    d["force_N"] = np.maximum(d["force_N"] - 12.0, FLOOR)  # an unzeroed cell: low readings hit the floor
    d["pressure_kPa"] = d["pressure_kPa"] + offset_kpa
    d["pressure_zero_kPa"] = offset_kpa
    path = tmp_path / "floored.csv"
    d.to_csv(path, index=False)
    return path


def test_rows_at_a_load_cell_floor_are_found_counted_and_can_be_excluded(tmp_path):
    t = read_table(_floored(tmp_path))
    at, report = find_rails(t, ("force",))
    n = int((t.data["force"] == FLOOR).sum())
    assert n >= RAIL_MIN_ROWS and at.sum() == n == report["rows_at_rail"]
    assert report["rails"] == [{"column": "force", "side": "low", "value": FLOOR, "rows": n}]
    kept, rk = isometric_points(t, "lowest")
    dropped, rx = isometric_points(t, "lowest", rails="exclude")
    assert len(kept) - len(dropped) == n and rx["rails"]["excluded"] and not rk["rails"]["excluded"]
    # a run whose lowest-pressure rows sit on the floor has an unknown zero: said, per run and as a flag
    assert "tare_at_rail" in rk["flags"] and any(r.get("at_rail") for r in rk["per_run_N"])
    # no rail on the clean campaign
    assert find_rails(read_table(ISO))[1]["rows_at_rail"] == 0


def test_the_pressure_zero_is_taken_from_a_column_or_estimated(tmp_path):
    t = read_table(_floored(tmp_path, offset_kpa=4.0))
    clean = read_table(ISO).data["pressure"].to_numpy()
    col, rep = apply_pressure_zero(t, "column")
    np.testing.assert_allclose(col.data["pressure"].to_numpy(), clean, atol=1e-6)  # 4 kPa off, to round-off
    assert rep["pressure_zero_Pa"] == pytest.approx([4e3, 4e3])
    low, rep = apply_pressure_zero(t, "lowest")  # the campaign's runs start vented: the estimate is exact
    assert rep["pressure_zero_Pa"] == pytest.approx(4e3) and low.data["pressure"].min() == 0.0
    with pytest.raises(InputError, match="pressure_zero_<unit>"):
        apply_pressure_zero(read_table(ISO), "column")
    with pytest.raises(InputError, match="unknown pressure zero"):
        apply_pressure_zero(t, "guess")


def test_every_fit_reports_its_tare_rails_and_pressure_zero(tmp_path, cli):
    path = _floored(tmp_path, offset_kpa=4.0)
    fit = fit_isometric(read_table(path), read_muscle(MUSCLE), "spring", "lowest", "exclude", "column")
    d = fit.to_dict()["tare"]
    assert d["method"] == "lowest" and len(d["per_run_N"]) == 12
    assert d["rails"]["rows_at_rail"] > 0 and d["pressure_zero"]["method"] == "column"
    r = cli("fit", str(path), "--model", "spring", "--muscle-file", str(MUSCLE), "--tare", "lowest", "--json")
    assert r.code == 0 and "rows at a sensor's rail" in r.err and r.json()["tare"]["rails"]["rows_at_rail"] > 0
    r = cli("compare", str(path), "--muscle-file", str(MUSCLE), "--rails", "drop")
    assert r.code == 2 and "rails" in r.err and len(r.err.strip().splitlines()) == 1
    r = cli("fit", str(path), "--model", "spring", "--muscle-file", str(MUSCLE), "--pressure-zero", "guess")
    assert r.code == 2 and "pressure zero" in r.err

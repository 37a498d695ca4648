"""The tool from Python: make_tool, forward, inverse, map_workspace, and the experiment track_tip; tool track --out."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from matplotlib.figure import Figure

import mckibben.experiments as mx
import mckibben.tool as mt
from mckibben.errors import InputError
from mckibben.results import read_provenance
from mckibben.units import parse_quantity, parse_values


def test_quantities_as_numbers_or_text():
    a = mt.make_tool("mpam117", preload=parse_quantity("1.2N", "force"),
                     bending_stiffness=parse_quantity("2e-4Nm2", "bending_stiffness"),
                     pitch_radius=parse_quantity("4.5mm", "length"))
    b = mt.make_tool("mpam117", preload=1.2, bending_stiffness=2e-4, pitch_radius=4.5 * 1e-3)  # "4.5mm" is 4.5·1e-3
    assert a == b
    s1 = mt.inverse(parse_values("20mm,0mm,110mm", "length"), a)
    s2 = mt.inverse([0.02, 0.0, 0.11], b)
    np.testing.assert_array_equal(s1.pressures, s2.pressures)  # same call, same numbers
    back = mt.forward(a, pressures=s1.pressures)
    np.testing.assert_allclose(back.tip, [0.02, 0.0, 0.11], atol=1e-9)  # the static inverse's tolerance
    with pytest.raises(InputError, match="tip"):
        mt.inverse([0.02, 0.0], a)
    with pytest.raises(InputError, match="discs"):
        mt.make_tool(discs="many")


@pytest.mark.slow
def test_track_result_and_its_series(cli, tmp_path):
    res = mx.track_tip(mt.parse_path("circle:radius=3mm,period=1s"), periods=[1.0])
    assert res.metrics["runs"] == 1 and 0 < res.metrics["rms_error_m"] < 3e-3
    df = res.to_pandas()
    assert {"time_s", "target_x_m", "achieved_x_m", "reference_1_Pa", "pressure_3_Pa"} <= set(df.columns)
    assert isinstance(res.plot(), Figure)
    out = tmp_path / "track.parquet"
    r = cli("tool", "track", "--path", "circle:radius=3mm,period=1s", "--out", str(out), "--json")
    assert r.code == 0, r.err
    back = pd.read_parquet(out)
    np.testing.assert_array_equal(back["achieved_x_m"], df["achieved_x_m"])
    assert read_provenance(out)["call"] == "mckibben.experiments.track_tip"
    assert r.json()["runs"][0]["rms_error_m"] == pytest.approx(res.metrics["rms_error_m"], rel=1e-12)


def test_reference_only_has_no_plot():
    res = mx.track_tip(mt.parse_path("circle:radius=3mm,period=1s"), reference_only=True)
    assert np.isnan(res.metrics["rms_error_m"])
    with pytest.raises(InputError, match="nothing simulated"):
        res.plot()


def test_workspace_result():
    ws = mt.map_workspace(grid=3)
    assert ws.metrics["samples"] == 27 and len(ws.to_pandas()) == 27
    assert repr(ws).startswith("WorkspaceResult(grid=3; lateral_reach_m=")

"""Result objects share one shape: .metrics, .to_pandas() (unit-suffixed columns), .plot(ax), repr, files."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from matplotlib.figure import Figure

from mckibben.errors import InputError
from mckibben.results import read_provenance
from mckibben.rig import Device
from mckibben.units import quantity

from conftest import start_device


def test_quantities_are_si_numbers_or_text_with_a_unit():
    assert quantity("0.55MPa", "pressure") == quantity(0.55e6, "pressure") == 0.55e6
    assert quantity("200Nmm2", "bending_stiffness") == pytest.approx(2e-4)  # same as 2e-4 N·m²
    with pytest.raises(InputError, match="target"):
        quantity("fast", "pressure", "target")
    with pytest.raises(InputError, match="load"):
        quantity(-1.0, "force", "load")
    with pytest.raises(InputError, match="neither a number"):
        quantity([1, 2], "force", "load")


def test_device_step_returns_a_result(tmp_path, engine):
    with start_device(engine) as em:
        res = Device(em.port).step(0.4e6, duration=0.5)
    m = res.metrics
    assert 0 < m["rise_time_s"] < 0.3 and res.counters["missing"] <= (0 if engine == "python" else 5)
    df = res.to_pandas()
    assert list(df.columns) == ["time_s", "reference_Pa", "pressure_Pa", "command_pwm"]
    assert df.attrs["provenance"]["call"] == "mckibben.rig.Device.step"
    assert isinstance(res.plot(), Figure)
    assert repr(res).startswith("RigStepResult(port=") and "rise_time_s=" in repr(res)
    out = res.to_file(tmp_path / "step.parquet")
    back = pd.read_parquet(out)
    np.testing.assert_array_equal(back["pressure_Pa"], df["pressure_Pa"])
    assert read_provenance(out)["arguments"]["target_Pa"] == 0.4e6
    with pytest.raises(InputError, match="out"):
        res.to_file(tmp_path / "step.xlsx")

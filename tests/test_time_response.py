"""One time-response type under every time-series result (python-control's ``TimeResponseData`` in spirit).

Each record of sampled signals the library returns — the batch simulator's, the closed loop's, the
device's, the open-loop step's, the tool's and the MuJoCo runs' — is a
:class:`~mckibben.results.TimeResponse`: ``time`` in seconds, ``n_samples``, ``n_instances``,
``signal(name, i)`` and ``frame(i)``, whose columns follow one naming (``time_s`` first, then
``quantity_unit`` from :data:`~mckibben.results.SIGNAL_COLUMNS`). The results' ``to_pandas`` are
built from those frames, so a column means the same everywhere.
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import pkgutil
import re

import numpy as np
import pytest

import mckibben as mk
from mckibben.errors import InputError
from mckibben.results import SIGNAL_COLUMNS, TimeResponse

COLUMN = re.compile(r"^[a-z0-9]+(_[a-z0-9]+)*_(s|Pa|m|N|pwm|flags|K|kg)$")


def _check(rec: TimeResponse, n_instances: int = 1):
    assert isinstance(rec, TimeResponse)
    t = rec.time
    assert t.dtype == float and t.ndim == 1 and t.size == rec.n_samples > 1
    assert np.all(np.diff(t) > 0)
    assert rec.n_instances == n_instances
    df = rec.frame(n_instances - 1)
    assert list(df.columns)[0] == "time_s" and len(df) == rec.n_samples
    for c in df.columns:
        assert COLUMN.match(c) or c.split("_")[0] in {"muscle", "muscle2", "muscle3"}, c
    for name in rec.recorded_signals():
        a = rec.signal(name, n_instances - 1)
        assert a.shape[0] == rec.n_samples, name
    with pytest.raises(InputError, match="signal"):
        rec.signal("no_such_signal")
    return df


def test_closed_loop_step_and_track_records():
    step = mk.step_response(duration=0.15)
    df = _check(step.record)
    assert list(step.to_pandas().columns) == list(df.columns)
    assert step.record.time[1] - step.record.time[0] == pytest.approx(1e-3)
    track = mk.track_pressure(mk.control.SineReference(0.4e6, 0.1e6, 2.0) if hasattr(mk.control, "SineReference")
                              else np.full(200, 0.4e6), duration=0.2)
    _check(track.record)


def test_simulator_records_one_row_per_instance():
    from mckibben import plant

    sim = plant.simulate(plant.PlantParams(load_force=np.array([0.2, 0.4, 0.6])), duration=0.05)
    df = _check(sim, n_instances=3)
    assert set(df.columns) >= {"pressure_Pa", "reference_Pa", "fault_flags", "inlet_pwm"}
    assert list(sim.to_pandas(2).columns) == list(df.columns)
    with pytest.raises(InputError, match="instance 5 of 3"):
        sim.signal("pressure", 5)
    only = plant.simulate(duration=0.05, record=("pressure",))
    assert list(_check(only).columns) == ["time_s", "pressure_Pa", "reference_Pa"]


def test_open_loop_and_hysteresis_are_results_with_tables():
    ol = mk.open_loop(duration=0.1)
    _check(ol)
    assert list(ol.to_pandas().columns) == ["time_s", "pressure_Pa", "length_m"]
    from mckibben.control.hysteresis import HysteresisBenefit
    from mckibben.results import Result

    assert issubclass(HysteresisBenefit, Result)


def test_tool_tracking_is_a_time_response_with_channels():
    res = mk.track_tip(mk.tool.parse_path("circle:radius=5mm,period=1s"))
    rec = res.results[0]
    df = _check(rec)
    assert {"target_x_m", "achieved_z_m", "pressure_3_Pa", "reference_1_Pa"} <= set(df.columns)
    assert set(df.columns) <= set(res.to_pandas().columns)


def test_device_and_mujoco_results_share_the_type():
    from mckibben.experiments.mujoco import HangingMassResult, MuscleRunResult
    from mckibben.rig.device import RigStepResult

    t = np.linspace(0.0, 0.1, 101)
    rig = RigStepResult(t, np.full(101, 4e5), np.full(101, 4e5), np.zeros(101), 0.01)
    assert list(_check(rig).columns) == ["time_s", "reference_Pa", "pressure_Pa", "command_pwm"]
    hang = HangingMassResult(t, np.full(101, 4e5), np.full(101, 0.09), np.full(101, 1.0), "mpam97", 0.6, 4e5,
                             0.09, 0.09)
    _check(hang)
    run = MuscleRunResult(t, np.full((101, 2), 4e5), np.full((101, 2), 0.09), np.ones((101, 2)), ("muscle", "muscle2"),
                          np.zeros(2, bool), np.zeros(2, int))
    df = _check(run)
    assert {"muscle2_pressure_Pa", "muscle_length_m", "muscle2_tension_N"} <= set(df.columns)


def _dataclasses_with_a_time_vector():
    found = []
    for info in pkgutil.walk_packages(mk.__path__, "mckibben."):
        if info.name.split(".")[-1].startswith("_") or ".cli" in info.name:
            continue
        try:
            mod = importlib.import_module(info.name)
        except Exception:  # optional extras (MuJoCo, FMU tools) absent here
            continue
        for _, cls in inspect.getmembers(mod, inspect.isclass):
            if cls.__module__ != mod.__name__ or not dataclasses.is_dataclass(cls):
                continue
            names = {f.name for f in dataclasses.fields(cls)}
            signals = names & set(SIGNAL_COLUMNS)
            if names & {"t", "time"} and signals:
                found.append(cls)
    return found


#: Records of time that are inputs or fits, not responses: a tip path's reference (what the tool is
#: asked to follow) and a step fit's samples (residuals), and a hysteresis study that holds several
#: runs (a Result whose table is its tracking runs).
NOT_RESPONSES = {"TipReference", "HysteresisBenefit"}


def test_every_sampled_record_in_the_package_is_a_time_response():
    classes = _dataclasses_with_a_time_vector()
    assert len(classes) >= 6
    missing = [c.__qualname__ for c in classes if not issubclass(c, TimeResponse) and c.__name__ not in NOT_RESPONSES]
    assert missing == []

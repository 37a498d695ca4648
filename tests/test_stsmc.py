"""The super-twisting law (mckibben.control.laws.stsmc): fixed point against float64, and on the plant.

The C-against-Python equivalence and the AVR cycle budget come from being registered
(tests/test_controller_conformance.py).
"""

from __future__ import annotations

import numpy as np

from mckibben.control import core
from mckibben.control.laws import stsmc
from mckibben.control import registry as R
from mckibben.control.runs import identify_plant, run_closed_loop, step_reference


def test_sqrt_table_and_interpolation():
    t = stsmc.sqrt_table()
    assert t[0] == 0 and t[-1] == stsmc.SQRT8_Q14 == round(np.sqrt(8) * 2**14)
    x = np.arange(0, 8 * 4096)
    got = np.array([stsmc.sqrt_q14(int(v)) for v in x[::7]]) / 2**14
    # linear interpolation of sqrt on a 1/16 grid: worst in the first cell, where sqrt(x) - 4x
    # peaks at x = 1/64 (0.0625); elsewhere below h^2/8 max|sqrt''| + rounding
    err = np.abs(got - np.sqrt(x[::7] / 4096))
    assert err.max() <= 0.0626
    assert err[x[::7] >= 4096].max() <= 2e-4


def test_fixed_point_command_follows_the_float_law():
    """One step from rest (v = 0): the command before rounding within a count of the float law."""
    rng = np.random.default_rng(3)
    params = core.CoreParams(mode=stsmc.MODE, st_g=3000.0, st_u0=100.0)
    _, ip, _, _ = core.pack_params(params)
    so, io = R.LAYOUT["stsmc"]
    for pref, p in zip(rng.integers(0, 800_000, 2000), rng.integers(0, 800_000, 2000), strict=True):
        e = int(pref - p)
        if abs(e) < params.st_phi:  # the interpolated root's linear zone is tested above
            continue
        st = np.zeros(core.N_ISTATE, dtype=np.int64)
        u, s = stsmc.law(st, ip, so, io, int(p), int(pref), e)
        assert s == e
        assert abs(u / 256 - float(stsmc.float_law(params, pref, e, 0.0))) <= 1.0


def test_steps_to_target_on_the_calibrated_plant_without_overshoot_beyond_the_bar():
    model = identify_plant()[1]
    params = R.get("stsmc").design(model, core.CoreParams())
    ref = step_reference(1100, 100, 0.0, 0.55e6)
    rec = run_closed_loop(core.core_spec(params), ref, 1.1, None)
    m = rec.metrics(0, 0.1)
    assert abs(m["steady_state_error_Pa"]) < 5e3  # the integral v removes the model's error
    assert m["overshoot_pct"] < 10.0
    assert rec.pressure.max() <= 0.8e6 + 90e3  # the supervisor stays below every law

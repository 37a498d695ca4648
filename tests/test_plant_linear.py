"""The plant linearized at an operating point, against a small-step simulation; ``mckibben plant``."""

import control
import numpy as np
import pytest

from mckibben.plant import PlantParams, linearize

from mckibben.plant import PlantStepper
from mckibben.plant import physics as ph

U0 = 119  # inlet counts: above the lift-off (112), holding ≈ 0.63 MPa against the leak
PLANT = PlantParams(friction_force=0.0, friction_per_pa=0.0)  # the linear model leaves the friction out


def _settled(u):
    st = PlantStepper(PLANT)
    for _ in range(3000):  # 3 s: valve, gas temperature and length settle
        st.advance(u, 0)
    return st


def test_linear_model_matches_a_small_disturbance_of_the_simulation():
    st = _settled(U0)
    p0, l0 = st.pressure, st.length
    lin = linearize(PLANT, p0)
    # the operating point is the simulation's: the command that holds p0 is the one that got there
    assert lin.command_counts == pytest.approx(U0, abs=1e-3)
    assert lin.length_m == pytest.approx(l0, abs=1e-7)
    # a 1 kPa disturbance of the chamber pressure, then the same command: the simulated decay
    # against the linear model's initial response (second-order terms are ~Δp/p = 0.2 %)
    st.bk[ph.Z_P] += 1e3
    n = 300
    p_sim, l_sim = np.empty(n), np.empty(n)
    for k in range(n):
        p_sim[k], l_sim[k] = st.pressure - p0, st.length - l0
        st.advance(U0, 0)
    t = np.arange(n) * 1e-3
    x0 = np.zeros(lin.ss.nstates)
    x0[0] = 1e3
    resp = control.initial_response(lin.ss, t, X0=x0).outputs
    assert np.max(np.abs(p_sim - resp[0])) < 20.0  # 2 % of the disturbance
    assert np.max(np.abs(l_sim - resp[1])) < 0.02 * np.max(np.abs(l_sim))
    # the input path: one count moves the pressure by the secant of the curve whose tangents the
    # model gives at both ends (the valve is strongly curved just above its lift-off)
    up = _settled(U0 + 1).pressure - p0
    g0 = lin.metrics["dc_gain_Pa_per_count"]
    g1 = linearize(PLANT, p0 + up).metrics["dc_gain_Pa_per_count"]
    assert min(g0, g1) <= up <= max(g0, g1)
    # the pressure -> length path is the muscle and its load: second order, stable
    length = lin.length
    assert len(control.poles(length)) == 2 and np.all(control.poles(length).real < 0)
    # the two paths multiply back to the whole. The product of the two transfer functions is exact to
    # a few ulps; the one inexact step is minreal in .length, which takes a zero z and a pole p for the
    # same when |z - p| < 1000 sqrt(eps) |z| and cancels them, so each cancelled pair may move the DC
    # gain by the factor p/z: by up to 1000 sqrt(eps) = 1.5e-5 relative. Cancelled here: the quotient's
    # order minus the result's (8: the six common poles and the two zeros both paths have) -> 1.2e-4,
    # still far below a 1 % error in either path.
    whole = control.ss2tf(lin.ss[1, 0])
    cancelled = (len(lin.ss.A) + len(lin.pressure.num[0][0]) - 1) - (len(length.den[0][0]) - 1)
    tol = cancelled * 1000 * np.sqrt(np.finfo(float).eps)
    assert 0 < tol < 0.01
    assert control.dcgain(lin.pressure * length) == pytest.approx(control.dcgain(whole), rel=tol)


def test_plant_bode_and_margins_from_the_cli(cli):
    r = cli("plant", "bode", "--pressure", "0.5MPa", "--points", "5", "--json")
    assert r.code == 0, r.err
    d = r.json()
    gains = [row["gain_Pa_per_count"] for row in d["response"]]
    assert len(gains) == 5 and gains[0] > gains[-1]  # a low-pass path
    assert 112 < d["operating_point"]["command_counts"] < 160
    r = cli("plant", "margins", "--kp", "1e-3", "--ki", "0.011", "--json")
    assert r.code == 0, r.err
    d = r.json()
    assert d["phase_margin_deg"] > 0 and d["gain_crossover_Hz"] > 0
    r = cli("plant", "margins", "--kp", "1e-3")
    assert r.code == 0 and "phase margin" in r.out


@pytest.mark.parametrize(
    "args, message",
    [
        (["bode", "--pressure", "0.9MPa"], "error: --pressure: pressure = 0.9 MPa: the operating point must be above 0 and below the supply (0.8 MPa)"),
        (["bode", "--pressure", "5"], "error: --pressure: '5' has no unit"),
        (["bode", "--points", "1"], "error: --points: 1 must be in 2..200"),
        (["margins", "--kp", "-1"], "error: --kp: -1.0 must be a finite gain >= 0"),
        (["margins", "--kp", "nan"], "error: --kp: nan must be a finite gain >= 0"),
        (["margins", "--kp", "0"], "error: --kp: all gains are zero; there is no loop"),
        (["margins", "--kp", "1e-3", "--tf", "0"], "error: --tf: 0.0 must be a time constant > 0 s"),
    ],
)
def test_bad_input(cli, args, message):
    r = cli("plant", *args)
    assert r.code == 2 and r.out == ""
    assert r.err.startswith(message)

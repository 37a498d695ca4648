"""The plant linearized at an operating point: a python-control ``StateSpace`` for control design.

:func:`linearize` holds the chamber at a gauge pressure with the inlet valve open just enough to
balance the leak (the muscle at its static length under the load, the gas at the wall
temperature), and differentiates the integrator's own right-hand side there (central
differences): states p, T, x_in, x_bl, l, v (the friction element, non-smooth at rest, is left
out), input the inlet's PWM command above the lift-off [counts], outputs the gauge pressure [Pa]
and the length [m]. ``.pressure`` (command → pressure) and ``.length`` (pressure → length) are
the two paths as transfer functions. ``docs/plant.md``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mckibben._jit import kernel
from mckibben.errors import InputError, check_real
from mckibben.plant import params as PP
from mckibben.plant import packing as PK
from mckibben.plant import physics as ph
from mckibben.plant.simulator import _check_plant, _prepared, initial_states, static_equilibrium

#: The states kept in the linear model (the friction and play rows are left out).
STATES = ("pressure_Pa", "temperature_K", "inlet_opening", "bleed_opening", "length_m", "velocity_m_per_s")
_K1 = ph.st_row(ph.ST_K1, 0)


@kernel(error_model="numpy")
def _f(bk, law, x, xin_t, out):
    for r in range(6):
        bk[ph.Z_P + r * ph.W] = x[r]
    bk[ph.Z_FRIC] = 0.0
    bk[ph.Z_PLAY] = x[0] - ph.P_ATM  # the play at rest at the operating point: the law sees the pressure
    bk[ph.Y_XIN] = xin_t
    bk[ph.Y_XBL] = 0.0
    ph.rhs(1, bk, ph.ST_S, ph.ST_K1, law)
    for r in range(6):
        out[r] = bk[_K1 + r * ph.W]


def _tf(path):
    """One SISO path of the state space (no feedthrough) as a transfer function, without round-off terms.

    ``ss2tf`` forms the numerator as det(sI - A + BC) - det(sI - A). The leading coefficients that
    should cancel to zero (the path's relative degree: 4 from the command to the length) come out as
    a few ulps of those determinants' coefficients instead, and put spurious zeros far above the
    model's frequencies (1e5 to 1e21 rad/s here, some in the right half plane). Left in, they ruin
    ``minreal`` on a quotient of paths: its roots lose their accuracy, nothing cancels, and the
    pressure → length path came out of order 11 with a pole at +1e21 rad/s instead of order 2.
    """
    import control  # deferred on purpose: python-control (0.8 s)

    a, b, c = (np.asarray(m, dtype=float) for m in (path.A, path.B, path.C))
    tf = control.ss2tf(path)
    num, den = tf.num[0][0], tf.den[0][0]
    # round-off of that difference, coefficient by coefficient (a true term of this model lies > 1e6 above)
    floor = 1e3 * np.finfo(float).eps * (np.abs(np.poly(a)) + np.abs(np.poly(a - b @ c)))[-num.size:]
    k = 0
    while k < num.size - 1 and abs(num[k]) <= floor[k]:
        k += 1
    return control.tf(num[k:], den)


@dataclass(frozen=True)
class LinearPlant:
    """A plant linearized at an operating point (result of :func:`linearize`).

    Attributes
    ----------
    ss : control.StateSpace
        Input: inlet PWM command [counts]; outputs: gauge pressure [Pa], length [m].
    pressure_Pa : float
        Operating gauge pressure. [Pa]
    length_m : float
        Static length there. [m]
    command_counts : float
        The inlet command that holds the pressure against the leak. [counts]
    lift_off_counts : float
        The command below which the inlet stays shut (the model holds above it). [counts]
    """

    ss: object
    pressure_Pa: float
    length_m: float
    command_counts: float
    lift_off_counts: float

    @property
    def pressure(self):
        """Command → gauge pressure transfer function. [Pa/count]"""
        return _tf(self.ss[0, 0])

    @property
    def length(self):
        """Gauge pressure → length transfer function (the muscle and its load). [m/Pa]"""
        import control  # deferred on purpose: python-control (0.8 s)

        quotient = _tf(self.ss[1, 0]) / _tf(self.ss[0, 0])
        # The two paths share the valve's and the sensor's equal lags: a pole of multiplicity 3 near
        # -1/tau, which floating point splits by about eps^(1/3)·|s| (2e-3 rad/s at 333 rad/s), in
        # the numerator and the denominator differently. minreal's default tolerance (1000·sqrt(eps)·|z|,
        # 5e-3 rad/s there) then cancels two of the three on some BLAS builds and leaves an order-3
        # path; a tolerance of 10·eps^(1/3) of the largest zero cancels the cluster whole and is still
        # far below the distance between the model's distinct roots (> 1 rad/s).
        zeros = np.roots(np.asarray(quotient.num[0][0], dtype=float))
        scale = max(float(np.max(np.abs(zeros))) if zeros.size else 0.0, 1.0)
        return control.minreal(quotient, tol=10.0 * np.finfo(float).eps ** (1.0 / 3.0) * scale, verbose=False)

    @property
    def metrics(self) -> dict:
        """The operating point and the command → pressure path's DC gain and slowest time constant."""
        import control  # deferred on purpose: python-control (0.8 s)

        poles = np.asarray(control.poles(self.ss[0, 0]))
        slow = float(-1.0 / np.max(poles.real)) if np.all(poles.real < 0) else math.inf
        return {"pressure_Pa": self.pressure_Pa, "length_m": self.length_m, "command_counts": self.command_counts,
                "lift_off_counts": self.lift_off_counts,
                "dc_gain_Pa_per_count": float(control.dcgain(self.ss[0, 0])),
                "slowest_time_constant_s": slow}


def linearize(plant: PP.PlantParams | None = None, pressure: float = 0.55e6) -> LinearPlant:
    """Linearize one rig at a held gauge pressure.

    Parameters
    ----------
    plant : PlantParams, optional
        One rig (scalar parameters); default the calibrated one.
    pressure : float, default 0.55e6
        Operating gauge pressure, above 0 and below the supply. [Pa]

    Returns
    -------
    LinearPlant
        The ``StateSpace`` and the operating point.
    """
    plant = _check_plant(plant)
    if plant.size() != 1:
        raise InputError("plant: linearize takes one rig (scalar parameters) only")
    pressure = check_real(pressure, "pressure", unit="Pa")
    prm, law, th = _prepared(plant, 1)
    c = PK.Col
    supply = float(prm[0, c.supply_pressure])
    if not (math.isfinite(pressure) and 0 < pressure < supply):
        raise InputError(f"pressure = {pressure / 1e6:g} MPa: the operating point must be above 0 and below the supply "
                         f"({supply / 1e6:g} MPa)")
    length = float(static_equilibrium(prm, law, th, pressure)[0][0])
    s0 = initial_states(prm, law, th, pressure, length, "energy" if plant.thermal == "energy" else "polytropic")
    bk = np.zeros(ph.BLOCK)
    ph.load_block(0, 1, prm, th, s0, bk)
    x0 = s0[0, :6].copy()
    d = np.empty(6)

    def dp(xin):
        x = x0.copy()
        x[ph.S_XIN] = xin
        _f(bk, law, x, xin, d)
        return d[ph.S_P]

    if dp(1.0) <= 0:
        raise InputError(f"pressure = {pressure:g} Pa: the open inlet cannot hold it against the leak")
    lo, hi = 0.0, 1.0
    if dp(0.0) < 0:
        for _ in range(80):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if dp(mid) < 0 else (lo, mid)
    xin = 0.5 * (lo + hi) if dp(0.0) < 0 else 0.0
    x0[ph.S_XIN] = xin
    drv, db = float(prm[0, c.driver_gain]), float(prm[0, c.dead_band])
    lift_off = 255.0 * db / drv
    command = 255.0 * (db + xin * (1.0 - db)) / drv
    dxdu = drv / (255.0 * (1.0 - db))  # valve opening per count above the lift-off
    scale = np.array([max(abs(v), 1.0) for v in x0]) * 1e-6
    scale[ph.S_XIN] = scale[ph.S_XBL] = 1e-6
    a = np.empty((6, 6))
    for k in range(6):
        xp, xm = x0.copy(), x0.copy()
        xp[k] += scale[k]
        xm[k] -= scale[k]
        fp, fm = np.empty(6), np.empty(6)
        _f(bk, law, xp, xin, fp)
        _f(bk, law, xm, xin, fm)
        a[:, k] = (fp - fm) / (2 * scale[k])
    fp, fm = np.empty(6), np.empty(6)
    _f(bk, law, x0, xin + 1e-6, fp)
    _f(bk, law, x0, xin - 1e-6, fm)
    b = ((fp - fm) / 2e-6 * dxdu)[:, None]
    cmat = np.zeros((2, 6))
    cmat[0, ph.S_P] = 1.0
    cmat[1, ph.S_LEN] = 1.0
    import control  # deferred on purpose: python-control (0.8 s)

    ss = control.ss(a, b, cmat, np.zeros((2, 1)), inputs=["command_counts"], outputs=["pressure_Pa", "length_m"],
                    states=list(STATES))
    return LinearPlant(ss, float(pressure), length, float(command), float(lift_off))

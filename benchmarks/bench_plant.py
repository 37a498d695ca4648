"""Benchmark of the batch plant simulator on the reference closed loop (issue 5).

The loop: a pressure step to 0.55 MPa under a saturated proportional-integral law on the
default rig, 1 s, control at 1 kHz (zero-order hold), plant RK4 at 10 kHz. Timed, in one run, for
N = 1, 100 and 10,000 instances:

- ``mckibben``: :func:`mckibben.plant.simulate` with the PI law as a Numba kernel;
- ``C -O2``: ``plant_loop.c``, the same loop as a plain C program (the yardstick);
- ``SciPy``: the same model with ``scipy.integrate.solve_ivp`` (RK45, rtol 1e-8) restarted every
  control period, two ways: one rig at a time (the usual script), and the whole batch as one
  state vector with the right-hand side compiled by Numba (the fastest SciPy arrangement we know);
- ``python-control``: ``control.input_output_response`` on the plant as a ``NonlinearIOSystem``,
  called once per control period with the held command (one instance).

Slow methods are timed at small N and extrapolated linearly in N (marked ``*``).

Run: ``python benchmarks/bench_plant.py`` (about two minutes on 2 cores).
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from numba import njit

from mckibben.plant import PlantParams, simulate
from mckibben.plant import params as PP
from mckibben.plant import physics as ph
from mckibben.plant.simulator import _initial_states

HERE = Path(__file__).resolve().parent
TS, SUB, STEPS, TARGET = 1e-3, 10, 1000, 0.55e6
KP, KI = 1e-3, 5e-3  # counts/Pa, counts/(Pa·s)


@njit(cache=True)
def pi_kernel(istate, iparams, fstate, fparams, adc, enc, sample_ok, p_ref_pa):
    """Saturated PI on the ADC reading; fstate[0] is the error integral [Pa·s]."""
    meas = adc * (1e6 / 1023.0)
    e = p_ref_pa - meas
    fstate[0] += e * 1e-3
    u = 1e-3 * e + 5e-3 * fstate[0]
    if u > 255.0:
        u = 255.0
    if u < -255.0:
        u = -255.0
    ui = int(round(u))
    if ui >= 0:
        return ui, 0, 0
    return 0, -ui, 0


def run_ours(n: int) -> tuple[float, float]:
    spec = (pi_kernel, np.zeros((n, 1), np.int64), np.zeros((n, 1), np.int64), np.zeros((n, 1)), np.zeros((n, 1)))
    t = time.perf_counter()
    r = simulate(PlantParams(), STEPS * TS, controller=spec, reference=TARGET, n=n, ts=TS, substeps=SUB)
    return time.perf_counter() - t, float(r.pressure[0, -1])


def build_c(tmp: Path) -> Path:
    names = PP._FIELDS + PP._DERIVED
    header = "".join(f"#define I_{name.upper()} {i}\n" for i, name in enumerate(names)) + f"#define NP_TOTAL {len(names)}\n"
    (tmp / "plant_index.h").write_text(header)
    exe = tmp / "plant_loop"
    subprocess.run(["gcc", "-O2", "-o", str(exe), str(HERE / "plant_loop.c"), f"-I{tmp}", "-lm"], check=True)
    prm = PlantParams().pack(1)
    s0 = _initial_states(prm, np.zeros(1))
    (tmp / "params.bin").write_bytes(prm[0].astype("<f8").tobytes() + s0[0].astype("<f8").tobytes())
    return exe


def run_c(exe: Path, n: int) -> tuple[float, float]:
    out = subprocess.run([str(exe), str(exe.parent / "params.bin"), str(n), str(STEPS), str(SUB)],
                         check=True, capture_output=True, text=True).stdout.split()
    return float(out[0]), float(out[1])


@njit(cache=True)
def _rhs_batch(y, prm, xin, xbl, dy):
    n = prm.shape[0]
    for i in range(n):
        ph.derivatives(y[i * ph.NS:(i + 1) * ph.NS], prm[i], xin[i], xbl[i], dy[i * ph.NS:(i + 1) * ph.NS])


def run_scipy(n: int, steps: int) -> float:
    from scipy.integrate import solve_ivp

    prm = PlantParams().pack(n)
    y = _initial_states(prm, np.zeros(n)).ravel()
    integ = np.zeros(n)
    dy = np.empty_like(y)
    t0 = time.perf_counter()
    for k in range(steps):
        m = y.reshape(n, ph.NS)
        pg = np.array([ph.gauge_pressure(m[i, 0], m[i, 3], prm[i]) for i in range(n)])
        adc = np.clip(np.round(pg / (1e6 / 1023)), 0, 1023)
        e = TARGET - adc * (1e6 / 1023)
        integ += e * TS
        u = np.round(np.clip(KP * e + KI * integ, -255, 255))
        xin = np.array([ph.valve_target(max(v, 0.0), prm[i]) for i, v in enumerate(u)])
        xbl = np.array([ph.valve_target(max(-v, 0.0), prm[i]) for i, v in enumerate(u)])

        def f(t, yy):
            _rhs_batch(yy, prm, xin, xbl, dy)
            return dy.copy()

        y = solve_ivp(f, (k * TS, (k + 1) * TS), y, method="RK45", rtol=1e-8, atol=1e-12).y[:, -1]
    return time.perf_counter() - t0


def run_python_control(steps: int) -> float:
    import control

    prm = PlantParams().pack(1)[0]
    x = _initial_states(prm[None, :], np.zeros(1))[0]
    dx = np.empty(ph.NS)

    def upd(t, xx, u, params):
        ph.derivatives(np.ascontiguousarray(xx, dtype=float), prm, float(u[0]), float(u[1]), dx)
        return dx.copy()

    def out(t, xx, u, params):
        return np.array([ph.gauge_pressure(float(xx[0]), float(xx[3]), prm)])

    sys_ = control.nlsys(upd, out, inputs=2, outputs=1, states=ph.NS)
    integ = 0.0
    t0 = time.perf_counter()
    for k in range(steps):
        pg = ph.gauge_pressure(x[0], x[3], prm)
        e = TARGET - round(pg / (1e6 / 1023)) * (1e6 / 1023)
        integ += e * TS
        u = round(min(max(KP * e + KI * integ, -255), 255))
        uu = np.array([[ph.valve_target(max(u, 0), prm)] * 2, [ph.valve_target(max(-u, 0), prm)] * 2])
        resp = control.input_output_response(sys_, [k * TS, (k + 1) * TS], uu, X0=x, solve_ivp_method="RK45",
                                             solve_ivp_kwargs={"rtol": 1e-8, "atol": 1e-12})
        x = resp.states[:, -1]
    return time.perf_counter() - t0


def main() -> None:
    ns = (1, 100, 10_000)
    rows = []
    run_ours(2)  # compile (cached after the first run)
    ours = {n: run_ours(n) for n in ns}
    with tempfile.TemporaryDirectory() as d:
        exe = build_c(Path(d))
        c = {n: run_c(exe, n) for n in ns}
    agree = abs(c[1][1] - ours[1][1]) / abs(ours[1][1])
    # SciPy: N = 1 for the full second; N = 100 for 100 periods, scaled to 1000
    sci1 = run_scipy(1, STEPS)
    sci100 = run_scipy(100, 100) * STEPS / 100
    sci = {1: (sci1, False), 100: (sci100, True), 10_000: (sci100 * 100, True)}
    sci_one = {n: (sci1 * n, n > 1) for n in ns}
    pc1 = run_python_control(200) * STEPS / 200
    pc = {1: (pc1, True), 100: (pc1 * 100, True), 10_000: (pc1 * 10_000, True)}
    for n in ns:
        work = n * STEPS * SUB
        base = ours[n][0]
        for name, (sec, extra) in (("mckibben (Numba)", (base, False)), ("C -O2 yardstick", (c[n][0], False)),
                                   ("SciPy, one rig at a time", sci_one[n]),
                                   ("SciPy, batch + Numba RHS", sci[n]), ("python-control per period", pc[n])):
            rows.append((n, name, sec, extra, sec / work * 1e9, sec / base))
    print(f"reference loop: PI step to 0.55 MPa, 1 s, 1 kHz control, {SUB} RK4 substeps; C vs ours final pressure "
          f"differ by {agree:.1e} (relative)")
    print(f"{'N':>6} | {'method':<28} | {'seconds':>10} | {'ns/instance-substep':>19} | {'× ours':>8}")
    for n, name, sec, extra, ns_, ratio in rows:
        star = "*" if extra else " "
        print(f"{n:>6} | {name:<28} | {sec:>9.3f}{star} | {ns_:>19.1f} | {ratio:>8.2f}")
    print("* extrapolated linearly in N or in time from a shorter run")


if __name__ == "__main__":
    sys.exit(main())

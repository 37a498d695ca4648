"""The simulator's compiled runner, a template bound to one controller kernel at a time.

The functions here call the controller kernel by the global name ``controller_kernel``. A compiled function
that took the kernel as an *argument* could not be cached (its argument type names a dispatcher
that lives in one process only: Numba would save a new copy in every process, and its index could
not be pickled again once it held another process's kernel). So :func:`mckibben._jit.module_for`
makes one copy of this module per kernel, with the ``# kernel-import`` line replaced by an import
of that kernel: each copy is an ordinary cached module. This module itself, bound to
:func:`no_kernel`, runs the open-loop schedules.

The block loop is :func:`mckibben.plant.simulator.simulate`'s; its docstring says what it
computes.
"""

from __future__ import annotations

import math

import numpy as np

from mckibben import hardware as HW
from mckibben._jit import kernel as compiled  # the one decorator (`kernel` here names a controller kernel)
from mckibben.plant import packing as PK
from mckibben.plant import physics as ph
from mckibben.plant.physics import NS, W

FLAG_NONFINITE = 1  #: the state became NaN or infinite (simulation of that instance stopped)
FLAG_ABOVE_SUPPLY = 2  #: the chamber rose above the supply pressure by more than 1 kPa
FLAG_END_STOP = 4  #: the length reached an end stop of the braid (locking or straight) during the run

_C = PK.Col


@compiled(error_model="numpy")
def no_kernel(istate, iparams, fstate, fparams, adc, enc, sample_ok, p_ref_pa):
    """The placeholder controller of open-loop runs (never called: ``use_kernel`` is False)."""
    return 0, 0, 0


controller_kernel = no_kernel  # kernel-import


@compiled(error_model="numpy")
def splitmix(state):
    z = (state + np.uint64(0x9E3779B97F4A7C15)) & np.uint64(0xFFFFFFFFFFFFFFFF)
    out = z
    out = ((out ^ (out >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)) & np.uint64(0xFFFFFFFFFFFFFFFF)
    out = ((out ^ (out >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)) & np.uint64(0xFFFFFFFFFFFFFFFF)
    out = out ^ (out >> np.uint64(31))
    return z, out


@compiled(error_model="numpy")
def gauss(rng, j):
    """Standard normal deviate from lane j's splitmix64 stream (Box–Muller)."""
    rng[j], a = splitmix(rng[j])
    rng[j], b = splitmix(rng[j])
    u1 = ((a >> np.uint64(11)) + np.uint64(1)) * (1.0 / 9007199254740993.0)
    u2 = (b >> np.uint64(11)) * (1.0 / 9007199254740992.0)
    return math.sqrt(-2.0 * math.log(u1)) * math.cos(2.0 * math.pi * u2)


def _x(col) -> int:
    return ph.OFF_P + int(col) * W


X_PPC, X_ADCZ, X_ENC, X_NOISE, X_SEED = (_x(c) for c in (_C.pa_per_count, _C.adc_zero, _C.encoder_resolution,
                                                        _C.pressure_noise, _C.seed))


@compiled(error_model="numpy")
def run_block(use_kernel, b0, nl, istate, iparams, fstate, fparams, schedule, prm, theta, law, s0, ref,
               n_steps, substeps, ts, out_p, out_pm, out_l, out_f, out_m, out_t, out_in, out_bl, out_fault, out_adc,
               out_enc, flags, rec):
    """Simulate instances b0..b0+nl-1 (one block) over every control period.

    ``rec`` holds one mask per output series (:data:`SERIES` order): −1 records period k in column k,
    0 overwrites column 0 of a one-column placeholder (the series was not asked for).
    """
    bk = np.zeros(ph.BLOCK)
    ph.load_block(b0, nl, prm, theta, s0, bk)
    alive = np.ones(W, dtype=np.bool_)
    rng = np.zeros(W, dtype=np.uint64)
    for j in range(nl):
        seed = np.uint64(int(bk[X_SEED + j]) & 0x7FFFFFFFFFFFFFFF)
        rng[j] = seed * np.uint64(2654435761) + np.uint64(b0 + j + 1)
    per_instance_ref = ref.shape[0] > 1
    per_instance_sched = schedule.shape[0] > 1
    dt = ts / substeps
    need_outputs = (rec[3] | rec[4]) != 0  # force or air mass recorded
    for k in range(n_steps):
        k0, k1, k2, k3, k4, k5 = k & rec[0], k & rec[1], k & rec[2], k & rec[3], k & rec[4], k & rec[5]
        k6, k7, k8, k9, k10 = k & rec[6], k & rec[7], k & rec[8], k & rec[9], k & rec[10]
        if need_outputs:
            ph.outputs(nl, bk, law)
        for j in range(nl):
            i = b0 + j
            if not alive[j]:
                out_p[i, k0] = np.nan
                out_pm[i, k1] = np.nan
                out_l[i, k2] = np.nan
                out_f[i, k3] = np.nan
                out_m[i, k4] = np.nan
                out_t[i, k5] = np.nan
                out_in[i, k6] = 0
                out_bl[i, k7] = 0
                out_fault[i, k8] = 0
                out_adc[i, k9] = 0
                out_enc[i, k10] = 0
                bk[ph.Y_XIN + j] = 0.0
                bk[ph.Y_XBL + j] = 0.0
                continue
            pg = bk[ph.Z_P + j] - ph.P_ATM
            length = bk[ph.Z_LEN + j]
            meas = pg
            if bk[X_NOISE + j] > 0.0:
                meas += bk[X_NOISE + j] * gauss(rng, j)
            adc = HW.adc_count(meas, bk[X_PPC + j], bk[X_ADCZ + j])
            enc = HW.encoder_count(length, bk[ph.X_L0 + j], bk[X_ENC + j])
            r = ref[i if per_instance_ref else 0, k]
            if use_kernel:
                u_in, u_bl, fault = controller_kernel(istate[i], iparams[i], fstate[i], fparams[i], adc, enc, True, r)
            else:
                row = i if per_instance_sched else 0
                u_in = schedule[row, k, 0]
                u_bl = schedule[row, k, 1]
                fault = 0
            out_p[i, k0] = pg
            out_pm[i, k1] = HW.adc_pressure(adc, bk[X_PPC + j], bk[X_ADCZ + j])
            out_l[i, k2] = length
            out_f[i, k3] = bk[ph.Y_FORCE + j]
            out_m[i, k4] = bk[ph.Y_MASS + j]
            out_t[i, k5] = bk[ph.Z_T + j]
            out_in[i, k6] = u_in
            out_bl[i, k7] = u_bl
            out_fault[i, k8] = fault
            out_adc[i, k9] = adc
            out_enc[i, k10] = enc
            bk[ph.Y_XIN + j] = ph.valve_target(u_in, bk[ph.X_DRV + j], bk[ph.X_DB + j])
            bk[ph.Y_XBL + j] = ph.valve_target(u_bl, bk[ph.X_DRV + j], bk[ph.X_DB + j])
        ph.advance(nl, bk, law, dt, substeps)
        for j in range(nl):
            if not alive[j]:
                continue
            i = b0 + j
            pa = bk[ph.Z_P + j]
            ta = bk[ph.Z_T + j]
            la = bk[ph.Z_LEN + j]
            if not (math.isfinite(pa) and math.isfinite(ta) and math.isfinite(la) and pa > 0.0 and ta > 0.0):
                flags[i] |= FLAG_NONFINITE
                alive[j] = False
                for r in range(NS):  # a finite lane again, so the block's arithmetic stays ordinary
                    bk[ph.Z_P + r * W + j] = s0[i, r]
                continue
            if pa - ph.P_ATM > bk[ph.X_SUPPLY + j] + 1e3:
                flags[i] |= FLAG_ABOVE_SUPPLY
            if la >= bk[ph.X_LMAX + j] or la <= bk[ph.X_LMIN + j]:
                flags[i] |= FLAG_END_STOP


@compiled(nogil=True, error_model="numpy")
def run_blocks(use_kernel, blk0, blk1, istate, iparams, fstate, fparams, schedule, prm, theta, law, s0, ref,
                n_steps, substeps, ts, out_p, out_pm, out_l, out_f, out_m, out_t, out_in, out_bl, out_fault, out_adc,
                out_enc, flags, rec):
    """Blocks blk0..blk1-1, one after the other (one thread's share); the GIL is released."""
    n = prm.shape[0]
    for b in range(blk0, blk1):
        b0 = b * W
        run_block(use_kernel, b0, min(W, n - b0), istate, iparams, fstate, fparams, schedule, prm, theta, law,
                   s0, ref, n_steps, substeps, ts, out_p, out_pm, out_l, out_f, out_m, out_t, out_in, out_bl, out_fault,
                   out_adc, out_enc, flags, rec)

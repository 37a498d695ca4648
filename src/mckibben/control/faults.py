"""Sensor faults between the plant and the controller, and a recorder of the sliding surface.

:func:`instrumented_kernel` wraps the core kernel with the controller-kernel interface of the
plant simulator. It can corrupt what the controller sees from a chosen control step on — the
plant's true pressure keeps evolving — and records the core's sliding surface S of every step
into the instance's float state, so a batch run yields S(t) for the Lyapunov check. The fault
kinds are the ones the supervisor must catch (``docs/controller.md``):

========  ============================================================================
``0``     none
``1``     stuck: the ADC repeats the reading it had at the onset
``2``     missing: no sample arrives (``sample_ok`` false)
``3``     out of range: the ADC reads a fixed count (e.g. 1023 for a shorted wire)
========  ============================================================================
"""

from __future__ import annotations

import numpy as np

from mckibben._jit import kernel
from mckibben.control.core_params import N_ISTATE, pack_params
from mckibben.control.layout import IS_SURFACE
from mckibben.control.step import core_kernel
from mckibben.errors import InputError

FAULT_NONE, FAULT_STUCK_SENSOR, FAULT_MISSING_SAMPLES, FAULT_FIXED_READING = 0, 1, 2, 3
#: istate after the core's: the step index and the reading held by a stuck sensor.
IS_K, IS_HELD = N_ISTATE, N_ISTATE + 1
#: fparams: fault kind, onset step, fixed reading.
FP_KIND, FP_ONSET, FP_VALUE = 0, 1, 2


@kernel
def instrumented_kernel(istate, iparams, fstate, fparams, adc, enc, sample_ok, p_ref_pa):
    """The core kernel behind an optional sensor fault, recording S of every step.

    Parameters
    ----------
    istate : numpy.ndarray of int64
        The core's state, then the step index and the held reading. [-]
    iparams : numpy.ndarray of int64
        The core's parameters. [-]
    fstate : numpy.ndarray of float64
        S of step k is written to ``fstate[k]`` (while k < len). [Pa]
    fparams : numpy.ndarray of float64
        Fault kind, onset step, fixed reading. [-]
    adc : int
        True ADC reading of the plant's sensor. [count]
    enc : int
        Encoder count. [count]
    sample_ok : bool
        Whether the plant delivered a sample. [-]
    p_ref_pa : float
        Pressure reference. [Pa]

    Returns
    -------
    tuple of int
        Inlet, bleed and fault flags from the core. [-]
    """
    k = istate[IS_K]
    kind = int(fparams[FP_KIND])
    a = adc
    ok = sample_ok
    if k == int(fparams[FP_ONSET]):
        istate[IS_HELD] = adc
    if kind != 0 and k >= int(fparams[FP_ONSET]):
        if kind == 1:
            a = istate[IS_HELD]
        elif kind == 2:
            ok = False
        elif kind == 3:
            a = int(fparams[FP_VALUE])
    inlet, bleed, faults = core_kernel(istate, iparams, fstate, fparams, a, enc, ok, p_ref_pa)
    if k < fstate.shape[0]:
        fstate[k] = istate[IS_SURFACE]
    istate[IS_K] = k + 1
    return inlet, bleed, faults


def instrumented_spec(params, n_steps: int, kinds=None, onsets=None, values=None):
    """Spec of :func:`instrumented_kernel` for a batch: one core parameter set per instance.

    Parameters
    ----------
    params : sequence of CoreParams
        Core parameters per instance. [-]
    n_steps : int
        Control steps to record S for. [-]
    kinds : array_like of int, optional
        Fault kind per instance (default none). [-]
    onsets : array_like of int, optional
        Onset step per instance. [-]
    values : array_like of int, optional
        Fixed reading of kind 3. [count]

    Returns
    -------
    tuple
        ``(instrumented_kernel, istate0, iparams, fstate0, fparams)``. [-]
    """
    plist = list(params)
    n = len(plist)
    if n == 0 or n_steps < 1:
        raise InputError("instrumented_spec needs at least one instance and one step")
    kinds = np.zeros(n) if kinds is None else np.asarray(kinds, dtype=float)
    onsets = np.zeros(n) if onsets is None else np.asarray(onsets, dtype=float)
    values = np.zeros(n) if values is None else np.asarray(values, dtype=float)
    if np.any((kinds < 0) | (kinds > 3)):
        raise InputError("instrumented_spec: fault kinds are 0..3")
    packs = [pack_params(p) for p in plist]
    ist = np.zeros((n, N_ISTATE + 2), dtype=np.int64)
    ist[:, :N_ISTATE] = np.stack([p[0] for p in packs])
    ist[:, IS_K] = 0
    ip = np.stack([p[1] for p in packs])
    fst = np.full((n, int(n_steps)), np.nan)
    fp = np.stack([kinds, onsets, values], axis=1)
    return (instrumented_kernel, ist, ip, fst, fp)

"""The controller core's step, bit-exact with ``firmware/core/controller.c``: the compiled kernels.

:func:`core_step` is one step of one channel (``mck_ctrl_step``): ADC scaling, the supervisor
(reference clamp, overpressure vent, the inlet's lead cut and headroom cap, latched sensor faults
and the response rule), the dispatch to the controller of the mode (the sliding mode's and the PID's law,
:mod:`mckibben.control.laws`, and the extension laws' slots, :func:`mckibben.control.registry.extension_law`)
and the split of the command into inlet and bleed PWM counts. :func:`core_kernel` is it with the
controller-kernel interface of the plant simulator. The modes, fault flags and status codes of
the protocol are here too. The arrays it reads are laid out by :mod:`mckibben.control.layout`
and packed by :mod:`mckibben.control.core_params`.

References
----------
[mpam-characterization], section IV, eq. (5)-(12) (sliding mode; signs corrected as in
``docs/controller.md``).
"""

from __future__ import annotations

import math

import numpy as np

from mckibben._jit import kernel
from mckibben.control import registry as R
from mckibben.control.fixed import clamp as _clamp
from mckibben.control.laws import pid, smc
from mckibben.control.layout import (
    IP_ADC_MAX, IP_ADC_MIN, IP_ADC_ZERO, IP_GS_PA, IP_ISUM_MAX, IP_N_MISSING, IP_N_STUCK, IP_OL_BLEED,
    IP_OL_INLET, IP_P_MAX, IP_P_OVER, IP_PPC_Q8, IP_RESP_U, IS_E_PREV, IS_FIRST,
    IS_HELD_ADC, IS_ISUM, IS_LAST_BLEED, IS_LAST_INLET, IS_LATCHED, IS_MISSING_N, IS_MODE, IS_OVER,
    IS_P_PREV, IS_P_SEEN, IS_PREF_PREV, IS_REFERENCE, IS_STUCK_N, IS_SURFACE)
from mckibben.control.registry import MODE_OPEN_LOOP
from mckibben.hardware import ADC_MAX


# --- modes and fault flags (firmware/core/controller.h, docs/protocol.md) ---------------------

MODE_SMC = R.SMC.mode
MODE_PID = R.PID.mode

FAULT_OVERPRESSURE = 0x01
FAULT_ADC_RANGE = 0x02
FAULT_STUCK = 0x04
FAULT_MISSING = 0x08
FAULT_VENT = 0x10

STATUS_OK = 0
STATUS_RANGE = 3
STATUS_GAIN_ID = 4



#: Supervisor 2b: the inlet is shut and the bleed opened wide while p + LEAD_SAMPLES·(p − p_prev)
#: > p_max (``firmware/core/controller.h``, ``MCK_LEAD_SAMPLES``).
LEAD_SAMPLES = 4
#: Supervisor 2b's headroom: the inlet is capped at (p_max − p) >> HEADROOM_SHIFT counts (255 from
#: 65.3 kPa below p_max down, 0 at p_max), so a valve opening near the maximum cannot carry the
#: pressure past it through its lag (``MCK_HEADROOM_SHIFT``).
HEADROOM_SHIFT = 8
P_NONE = 2_000_000  #: IS_P_PREV before the first step: a falling 'rate', so no cut on the first sample
#: Supervisor 3, the response rule (``docs/controller.md``): a valve counts as open from the
#: supervisor model's lift-off u0_s plus RESP_DU counts; the inlet must raise the pressure while
#: the model's equilibrium for its command (above that margin) is at least 2 p + RESP_P_MIN, the
#: bleed lower it from RESP_P_MIN up.
RESP_DU = 24
RESP_P_MIN = 20_000


@kernel(_nrt=False)  # no reference counting: integer code that allocates nothing (halves its cost per step)
def _response_expected(st, ip, seen):
    # controller.c response_expected(): must the reading have moved under the last command?
    if ip[IP_GS_PA] == 0:
        return False
    p = st[IS_P_PREV]
    if st[IS_LAST_BLEED] != 0:  # a fall, if the inlet is shut
        return st[IS_LAST_INLET] == 0 and st[IS_LAST_BLEED] >= ip[IP_RESP_U] and p >= RESP_P_MIN
    if st[IS_LAST_INLET] < ip[IP_RESP_U] or p > seen - RESP_P_MIN:
        return False
    # the model's equilibrium above the margin at least twice what holds p
    return (st[IS_LAST_INLET] - ip[IP_RESP_U]) * ip[IP_GS_PA] >= 2 * p + RESP_P_MIN


@kernel(_nrt=False)  # no reference counting: integer code that allocates nothing (halves its cost per step)
def core_step(st, ip, adc, sample_ok, p_ref_pa, shared):
    """One step of one channel; ``shared`` is the istate that holds the supply estimate.

    ``shared`` is ``st`` itself for a lone controller and channel 0's istate in a bank
    (``mck_bank_step``). See :func:`core_kernel` for the other arguments.
    """
    a_raw = _clamp(adc, np.int64(0), np.int64(65535))
    p_max = ip[IP_P_MAX]
    if not (p_ref_pa > 0.0):
        pref = 0
    elif p_ref_pa >= p_max:
        pref = p_max
    else:
        pref = int(math.floor(p_ref_pa + 0.5))
    # supervisor 3: sensor faults
    if sample_ok:
        st[IS_MISSING_N] = 0
        if a_raw < ip[IP_ADC_MIN] or a_raw > ip[IP_ADC_MAX]:
            st[IS_LATCHED] |= FAULT_ADC_RANGE
        if a_raw == st[IS_HELD_ADC] and _response_expected(st, ip, shared[IS_P_SEEN]):
            if st[IS_STUCK_N] < 65535:
                st[IS_STUCK_N] += 1
        else:
            st[IS_STUCK_N] = 0
        if ip[IP_N_STUCK] != 0 and st[IS_STUCK_N] >= ip[IP_N_STUCK]:
            st[IS_LATCHED] |= FAULT_STUCK
        st[IS_HELD_ADC] = a_raw
    else:
        if st[IS_MISSING_N] < 65535:
            st[IS_MISSING_N] += 1
        if ip[IP_N_MISSING] != 0 and st[IS_MISSING_N] >= ip[IP_N_MISSING]:
            st[IS_LATCHED] |= FAULT_MISSING
    # ADC scaling
    a = st[IS_HELD_ADC]
    if a > ADC_MAX:
        a = ADC_MAX
    p = ((a - ip[IP_ADC_ZERO]) * ip[IP_PPC_Q8] + 128) >> 8
    if p > shared[IS_P_SEEN]:
        shared[IS_P_SEEN] = p
    # supervisor 1 and 2
    pref = _clamp(pref, np.int64(0), p_max)
    if st[IS_OVER] != 0:
        if p < p_max:
            st[IS_OVER] = 0
    elif p > ip[IP_P_OVER]:
        st[IS_OVER] = 1
    cut = p + (p - st[IS_P_PREV]) * LEAD_SAMPLES > p_max
    room = p_max - p
    if cut or room <= 0:
        cap = 0
    else:
        cap = 255 if room >= 255 << HEADROOM_SHIFT else room >> HEADROOM_SHIFT
    st[IS_P_PREV] = p
    e = pref - p
    surface = e
    inlet = 0
    bleed = 0
    mode = st[IS_MODE]
    if st[IS_LATCHED] != 0 or st[IS_OVER] != 0:
        bleed = 255
        st[IS_FIRST] = 1
    elif mode == MODE_SMC or mode == MODE_PID or mode > MODE_OPEN_LOOP:
        if st[IS_FIRST] != 0:
            st[IS_FIRST] = 0
            st[IS_PREF_PREV] = pref
            st[IS_E_PREV] = e
        if mode == MODE_SMC:
            st[IS_ISUM] = _clamp(st[IS_ISUM] + e, -ip[IP_ISUM_MAX], ip[IP_ISUM_MAX])
            u, surface = smc.law(ip, p, pref - st[IS_PREF_PREV], e, st[IS_ISUM])
            st[IS_PREF_PREV] = pref
        elif mode == MODE_PID:
            u = pid.law(st, ip, e)
        else:  # the registry's extension laws (modes 4, 5, ...)
            u, surface = R.extension_law(mode, st, ip, p, pref, e)
        u = (u + 128) >> 8
        if u >= 0:
            inlet = 255 if u > 255 else u
        else:
            bleed = 255 if u < -255 else -u
    else:
        st[IS_FIRST] = 1
        if mode == MODE_OPEN_LOOP:
            inlet = ip[IP_OL_INLET]
            bleed = ip[IP_OL_BLEED]
    # supervisor 2b: the inlet within the headroom cap, shut and the bleed wide open while the
    # predicted pressure is past p_max
    if inlet > cap:
        inlet = cap
    if cut:
        bleed = 255
    faults = st[IS_LATCHED] | (FAULT_OVERPRESSURE if st[IS_OVER] != 0 else 0)
    st[IS_LAST_INLET] = inlet
    st[IS_LAST_BLEED] = bleed
    st[IS_SURFACE] = surface
    st[IS_REFERENCE] = pref
    return inlet, bleed, faults


@kernel(_nrt=False)  # no reference counting: integer code that allocates nothing (halves its cost per step)
def core_kernel(istate, iparams, fstate, fparams, adc, enc, sample_ok, p_ref_pa):
    """One control step of the firmware core (``mck_ctrl_step``), bit-exact.

    Parameters
    ----------
    istate : numpy.ndarray of int64
        This instance's integer state, mutated in place (layout ``IS_*``). [-]
    iparams : numpy.ndarray of int64
        This instance's parameters (:func:`pack_params`). [-]
    fstate : numpy.ndarray of float64
        Unused (the core is integer only); kept for the kernel interface. [-]
    fparams : numpy.ndarray of float64
        Unused; kept for the kernel interface. [-]
    adc : int
        Raw pressure ADC count; saturated to 0..65535 (the C core takes uint16). [count]
    enc : int
        Encoder count; the pressure law does not use it. [count]
    sample_ok : bool
        False when no sample arrived this period. [-]
    p_ref_pa : float
        Pressure reference; rounded to whole Pa as the protocol's i32 (NaN counts as 0). [Pa]

    Returns
    -------
    tuple of int
        Inlet PWM count 0..255, bleed PWM count 0..255, fault flags (``FAULT_*``). [-]
    """
    return core_step(istate, iparams, adc, sample_ok, p_ref_pa, istate)

"""The controller core's integer arrays: the slot of every field of ``istate`` and ``iparams``.

One instance of the core (``firmware/core/controller.c``: ``mck_ctrl_t``) is two ``int64`` arrays
in Python: ``iparams`` (settings, the coefficients ``derive()`` computes, the supervisor's
settings, then the raw SET_GAIN values at ``IP_GAIN0 + id``) and ``istate`` (mode, supervisor
and law state, the last telemetry values). The core's own slots are fixed here; the extension
laws' slots follow them (:data:`mckibben.control.registry.LAYOUT`). The laws
(:mod:`mckibben.control.laws`), the step (:mod:`mckibben.control.core`) and the packing read
these names; nothing else numbers a slot.
"""

from __future__ import annotations

# iparams (int64): settings, derived coefficients and the supervisor's settings by name (the
# fields of mck_coef_t), then the raw gain values (IP_GAIN0 + id) that the setters keep.
IP_P_MAX, IP_TS_US, IP_OL_INLET, IP_OL_BLEED = 0, 1, 2, 3
IP_PPC_Q8, IP_BETA_Q8, IP_C_P, IP_C_DREF, IP_C_E, IP_C_KI = 4, 5, 6, 7, 8, 9
IP_C_EPS, IP_S_SAT, IP_ISUM_MAX, IP_C_KP, IP_C_KIP, IP_C_KD, IP_ALPHA = 10, 11, 12, 13, 14, 15, 16
IP_C_U0 = 17
IP_P_OVER, IP_ADC_ZERO, IP_ADC_MIN, IP_ADC_MAX, IP_N_STUCK, IP_N_MISSING = 18, 19, 20, 21, 22, 23
IP_GS_PA, IP_RESP_U = 24, 25
#: First raw SET_GAIN value; then the extension laws' coefficients.
IP_GAIN0 = 26

# istate (int64): mode, supervisor and law state, last telemetry values.
IS_MODE, IS_LATCHED, IS_OVER, IS_FIRST, IS_LAST_INLET, IS_LAST_BLEED = 0, 1, 2, 3, 4, 5
IS_HELD_ADC, IS_STUCK_N, IS_MISSING_N = 6, 7, 8
IS_ISUM, IS_IU, IS_DQ, IS_E_PREV, IS_PREF_PREV = 9, 10, 11, 12, 13
IS_SURFACE, IS_REFERENCE, IS_P_PREV = 14, 15, 16
IS_P_SEEN = 17  #: supply estimate: highest pressure shown since SET_MODE (a bank's channel 0 holds the shared one)
#: Slots of the core's own state; then the extension laws' state.
CORE_N_ISTATE = IS_P_SEEN + 1

"""The pressure-controller core, the firmware's fixed-point law bit-exact in Python: an index of its modules.

The core mirrors ``firmware/core/controller.c`` operation for operation; the tests feed identical
sequences to the C core (built for the host, loaded with ctypes) and to the Python one and
require identical outputs at every step, so a simulation runs the controller that runs on the
Arduino Mega. It lives in modules that say what they hold; this module defines nothing and keeps
``mckibben.control.core.<name>`` importable for the rig, the sweeps, the exports and the tool:

- :mod:`mckibben.control.layout`: the slots of the core's integer arrays (``IP_*``, ``IS_*``);
- :mod:`mckibben.control.step`: the compiled step (:func:`core_step`, :func:`core_kernel`, the
  plant simulator's controller-kernel interface), the modes, fault flags and status codes;
- :mod:`mckibben.control.core_params`: :class:`CoreParams`, the SET_GAIN values (:data:`GAINS`),
  the coefficients ``derive()`` computes, the packing (:func:`pack_params`, :func:`pack_batch`,
  :func:`core_spec`), the law in float64 (:func:`float_command`);
- :mod:`mckibben.control.bank`: :class:`CoreController` and :class:`CoreBank`, the core run step
  by step with the C core's setters;
- :mod:`mckibben.control.design_file`: :func:`save_design`, :func:`load_design`;
- the laws themselves: :mod:`mckibben.control.laws` (one file per controller).

References
----------
[mpam-characterization], section IV, eq. (5)-(12) (sliding mode; signs corrected as in
``docs/controller.md``).
"""

from __future__ import annotations

from mckibben import hardware as HW  # noqa: F401  (``core.HW``: the tests' sensor scale)
from mckibben.control import registry as R  # noqa: F401  (``core.R``)
from mckibben.control.bank import (  # noqa: F401  (re-exported)
    CoreBank, CoreController
)
from mckibben.control.core_params import (  # noqa: F401  (re-exported)
    GAINS, GAIN_IDS, N_GAINS, N_IPARAMS, N_ISTATE, CoreParams, Gain, core_spec, counts_from_command, derive,
    derive_arrays, fill_coefficients, float_command, gain_values, pack_batch, pack_params
)
from mckibben.control.design_file import (  # noqa: F401  (re-exported)
    DESIGN_FORMAT, load_design, save_design
)
from mckibben.control.fixed import _TANH, mulq16, tanh_q15, tanh_table  # noqa: F401  (re-exported)
from mckibben.control.layout import (  # noqa: F401  (re-exported)
    CORE_N_ISTATE, IP_ADC_MAX, IP_ADC_MIN, IP_ADC_ZERO, IP_ALPHA, IP_BETA_Q8, IP_C_DREF, IP_C_E, IP_C_EPS,
    IP_C_KD, IP_C_KI, IP_C_KIP, IP_C_KP, IP_C_P, IP_C_U0, IP_GAIN0, IP_GS_PA, IP_ISUM_MAX, IP_N_MISSING,
    IP_N_STUCK, IP_OL_BLEED, IP_OL_INLET, IP_PPC_Q8, IP_P_MAX, IP_P_OVER, IP_RESP_U, IP_S_SAT, IP_TS_US, IS_DQ,
    IS_E_PREV, IS_FIRST, IS_HELD_ADC, IS_ISUM, IS_IU, IS_LAST_BLEED, IS_LAST_INLET, IS_LATCHED, IS_MISSING_N,
    IS_MODE, IS_OVER, IS_PREF_PREV, IS_P_PREV, IS_P_SEEN, IS_REFERENCE, IS_STUCK_N, IS_SURFACE
)
from mckibben.control.step import (  # noqa: F401  (re-exported)
    FAULT_ADC_RANGE, FAULT_MISSING, FAULT_OVERPRESSURE, FAULT_STUCK, FAULT_VENT, HEADROOM_SHIFT, LEAD_SAMPLES,
    MODE_OFF, MODE_OPEN_LOOP, MODE_PID, MODE_SMC, P_MAX_LIMIT, P_NONE, RESP_DU, RESP_P_MIN, STATUS_GAIN_ID, STATUS_OK,
    STATUS_RANGE, TS_US_MAX, TS_US_MIN, core_kernel, core_step
)

__all__ = [
    "CORE_N_ISTATE", "CoreBank", "CoreController", "CoreParams", "DESIGN_FORMAT", "FAULT_ADC_RANGE",
    "FAULT_MISSING", "FAULT_OVERPRESSURE", "FAULT_STUCK", "FAULT_VENT", "GAINS", "GAIN_IDS", "Gain", "IP_ADC_MAX",
    "IP_ADC_MIN", "IP_ADC_ZERO", "IP_ALPHA", "IP_BETA_Q8", "IP_C_DREF", "IP_C_E", "IP_C_EPS", "IP_C_KD",
    "IP_C_KI", "IP_C_KIP", "IP_C_KP", "IP_C_P", "IP_C_U0", "IP_GAIN0", "IP_GS_PA", "IP_ISUM_MAX", "IP_N_MISSING",
    "HEADROOM_SHIFT", "IP_N_STUCK", "IP_OL_BLEED", "IP_OL_INLET", "IP_PPC_Q8", "IP_P_MAX", "IP_P_OVER", "IP_RESP_U", "IP_S_SAT",
    "IP_TS_US", "IS_DQ", "IS_E_PREV", "IS_FIRST", "IS_HELD_ADC", "IS_ISUM", "IS_IU", "IS_LAST_BLEED",
    "IS_LAST_INLET", "IS_LATCHED", "IS_MISSING_N", "IS_MODE", "IS_OVER", "IS_PREF_PREV", "IS_P_PREV", "IS_P_SEEN",
    "IS_REFERENCE", "IS_STUCK_N", "IS_SURFACE", "LEAD_SAMPLES", "MODE_OFF", "MODE_OPEN_LOOP", "MODE_PID",
    "MODE_SMC", "N_GAINS", "N_IPARAMS", "N_ISTATE", "P_MAX_LIMIT", "P_NONE", "RESP_DU", "RESP_P_MIN",
    "STATUS_GAIN_ID", "STATUS_OK", "STATUS_RANGE", "TS_US_MAX", "TS_US_MIN", "core_kernel", "core_spec",
    "core_step", "counts_from_command", "derive", "derive_arrays", "fill_coefficients", "float_command",
    "gain_values", "load_design", "mulq16", "pack_batch", "pack_params", "save_design", "tanh_q15", "tanh_table"
]

"""The one table of the controllers' SET_MODE and SET_GAIN ids (the protocol's numbers).

Every id the firmware's protocol carries is written here once: the mode of each controller and
the id of each gain (the supervisor's and every controller's), by the gain's protocol name.
The controller files (:mod:`mckibben.control.laws`) take their mode and their gains' ids from
this table; nothing else numbers them.

The C side is held to the table in two ways, chosen by who writes the C:

- ``firmware/core/laws.h`` (the extension laws' ids and their list) is **generated** from this
  table (``python -m mckibben.control.laws``) and checked in; a test regenerates it and requires
  the file to be equal. Adding a controller adds one row here and one regeneration, never a
  hand-numbered ``#define``.
- The core's own ids (``MCK_MODE_SMC``, ``MCK_GAIN_SMC_BETA`` ... in ``firmware/core/controller.h``)
  stay hand-written beside the C code that uses them, in the enum the firmware is read from, and
  are **checked**: the controller conformance suite parses the header and requires every one to
  equal this table (generating them would put the core's enum, which the C developers read and
  edit with its code, behind a Python step).
"""

from __future__ import annotations

#: owner -> (SET_MODE id or None, {gain's protocol name: SET_GAIN id}). ``off`` and
#: ``open_loop`` are the core's modes that run no law; ``supervisor`` owns the ADC's and the
#: sensor checks' settings (every mode). A controller's row lists its gains in its file's order.
TABLE: dict[str, tuple[int | None, dict[str, int]]] = {
    "off": (0, {}),
    "smc": (1, {"smc_beta": 0, "smc_eps": 1, "smc_ki": 2, "smc_tau": 3, "smc_g": 4, "smc_i_max": 5, "smc_u0": 17}),
    "pid": (2, {"pid_kp": 6, "pid_ki": 7, "pid_kd": 8, "pid_tf": 9}),
    "open_loop": (3, {}),
    "supervisor": (None, {"adc_zero": 10, "pa_per_count": 11, "margin": 12, "adc_min": 13, "adc_max": 14,
                          "n_stuck": 15, "n_missing": 16, "sup_g": 18, "sup_u0": 19}),
    "stsmc": (4, {"stsmc_k1": 20, "stsmc_k2": 21, "stsmc_phi": 22, "stsmc_g": 23, "stsmc_u0": 24}),
}

#: SET_MODE id by owner (the owners that have one).
MODES: dict[str, int] = {name: mode for name, (mode, _) in TABLE.items() if mode is not None}
#: SET_GAIN id by the gain's protocol name.
GAIN_IDS: dict[str, int] = {g: i for _, gains in TABLE.values() for g, i in gains.items()}

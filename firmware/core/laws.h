/* GENERATED from src/mckibben/control/laws/_table.py by `python -m mckibben.control.laws`:
 * do not edit; tests/test_controller_conformance.py holds the two equal.
 *
 * The registry of the core's extension laws (docs/controller.md, "Adding a controller").
 * Sliding mode (mode 1) and PID (mode 2) are the core's own laws (controller.c). A further law
 * lives in one header of its own, core/law_<name>.h, which defines, for NAME/name:
 *   MCK_<NAME>_GAINS(G)             G(id, default, lo, hi) per gain, in id order (values in
 *                                   the fixed-point scale of SET_GAIN),
 *   mck_<name>_state_t, mck_<name>_coef_t   its state (reset by SET_MODE) and coefficients,
 *   mck_<name>_reset(state), mck_<name>_derive(coef, gains, ts_us),
 *   mck_<name>_law(state, coef, p, pref, e, &surface) -> u [counts Q8].
 * Its ids come from here: MCK_MODE_<NAME> (SET_MODE), MCK_<NAME>_N_GAINS and
 * MCK_GAIN_<NAME>_<GAIN> (SET_GAIN, contiguous after the previous law's). */
#ifndef MCK_LAWS_H
#define MCK_LAWS_H

#define MCK_MODE_STSMC 4u
#define MCK_STSMC_N_GAINS 5
#define MCK_GAIN_STSMC_K1 20
#define MCK_GAIN_STSMC_K2 21
#define MCK_GAIN_STSMC_PHI 22
#define MCK_GAIN_STSMC_G 23
#define MCK_GAIN_STSMC_U0 24

#define MCK_EXT_LAWS(X) X(STSMC, stsmc)

#endif

#include "law_stsmc.h"

/* The registry of the core's extension laws (docs/firmware.md, "Adding a controller").
 *
 * Sliding mode (mode 1) and PID (mode 2) are the core's own laws (controller.c). A further law
 * lives in one header of its own, core/law_<name>.h, which defines, for NAME/name:
 *   MCK_MODE_<NAME>                 its SET_MODE id (4, 5, ... in the order of the list below)
 *   MCK_<NAME>_N_GAINS              how many SET_GAIN ids it owns, and for each
 *   MCK_GAIN_<NAME>_<GAIN>          the id (contiguous after the previous law's),
 *   MCK_<NAME>_GAINS(G)             G(id, default, lo, hi) per gain, in id order (values in
 *                                   the fixed-point scale of SET_GAIN),
 *   mck_<name>_state_t, mck_<name>_coef_t   its state (reset by SET_MODE) and coefficients,
 *   mck_<name>_reset(state), mck_<name>_derive(coef, gains, ts_us),
 *   mck_<name>_law(state, coef, p, pref, e, &surface) -> u [counts Q8].
 * and is entered here: one #include and one X(NAME, name) in MCK_EXT_LAWS. The Python
 * registry (mckibben.control.registry) holds the same entry; tests/test_control_registry.py
 * holds the two against each other. */
#include "law_stsmc.h"

#ifndef MCK_LAWS_H
#define MCK_LAWS_H

#define MCK_EXT_LAWS(X) X(STSMC, stsmc)

#endif

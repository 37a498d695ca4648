"""The names of ``mckibben fit --model``: the fits' vocabulary, cheap to import.

The command line builds its options from these at start-up (every command module is imported
by ``mckibben --version``), so they live apart from the fits (:mod:`mckibben.fit.registry`,
which imports SciPy's users and re-exports them).
"""

from __future__ import annotations

from mckibben.models import laws

FIT_MODELS = {
    "kinematic": "eq. 2, l = k1·Ls·cos θ + k2, on braid_angle data (needs the muscle file)",
    "cubic": "one cubic in pressure per load/direction (isotonic, hysteresis, braid_angle, blocked_force)",
    "surface": "one cubic-in-pressure, linear-in-load surface of the length (isotonic)",
    "force-contraction": "one cubic of load vs contraction per pressure, Fig. 5 (isotonic; muscle file)",
    # a law with a procedure of its own on the tables only it takes (the spring model's: force_length;
    # isotonic with --split-pressure): Law.own_fit, mckibben.fit.static.OWN_FITS
    **{n: law.own_fit.note for n, law in laws.own_fit_laws().items()},
    "first-order": "p0, p_final, tau of pressure step responses (step_response)",
}
#: Models fitted by a procedure of their own on non-isometric tables (no muscle file needed there).
_OWN_PROCEDURE = frozenset(FIT_MODELS)
# every force law with a fit spec (mckibben.models.laws, the one vocabulary) fits isometric tables,
# and isotonic ones through its force, F(P, L) = load (mckibben.fit.isometric.fit_isotonic_law)
FIT_MODELS.update({n: f"{law.description} (isometric{', a family table' if law.family else ''}, or isotonic "
                      "through its force; muscle file)"
                   for n, law in laws.fit_laws().items() if n not in FIT_MODELS})
NEEDS_MUSCLE = ({"kinematic", "force-contraction", *(set(laws.fit_laws()) - _OWN_PROCEDURE)}
                | {a for a, n in laws.ALIASES.items() if n in laws.fit_laws()})

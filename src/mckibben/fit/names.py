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
    "spring": "Lu(P) and K(P, Ls) per direction and pressure range (force_length, isotonic or isometric)",
    "chou-hannaford": "fitted braid geometry: length under load (isotonic) or force(P, L) (isometric); muscle file",
    "tondu-lopez": "fitted k and r0 (and alpha0 if unknown): isotonic or isometric; muscle file",
    "first-order": "p0, p_final, tau of pressure step responses (step_response)",
}
# every force law with a fit spec (mckibben.models.laws, the one vocabulary) fits isometric tables,
# and isotonic ones through its force (mckibben.fit.isometric.fit_isotonic_law)
FIT_MODELS.update({n: f"{law.description} (isometric{', a family table' if law.family else ''}, or isotonic "
                      "through its force; muscle file)"
                   for n, law in laws.fit_laws().items() if n not in FIT_MODELS})
NEEDS_MUSCLE = ({"kinematic", "force-contraction", *laws.fit_laws()} - {"spring"}
                | {a for a, n in laws.ALIASES.items() if n in laws.fit_laws()})

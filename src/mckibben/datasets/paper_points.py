"""Published results the library compares against, as data with their source.

Plots and tables read these values from here; no plotting routine holds a paper's number.

``FIG13``: the sliding-mode pressure step of [mpam-characterization], §IV.B and Fig. 13: a step
to 0.55 MPa (80 psi) under the paper's law β·tanh(S/ε); "the time constant of the controller
response is found to be ~0.06 s for the low gain [β = 120]. By choosing β to be 150, the response
time can be further reduced to 0.01 s with a small increase in overshoot (~7 %)". The overshoot
at β = 120 is not stated (NaN). The "~" means these are approximate readings.

``OPEN_LOOP``: §IV.A, the voltage step that identified the plant: "the system is fast and has a
time constant of ~0.09 s and [...] damped with no overshoot".
"""

from __future__ import annotations

import math

__all__ = ["FIG13", "OPEN_LOOP"]

FIG13 = {
    "source": "[mpam-characterization], §IV.B, Fig. 13",
    "target_Pa": 0.55e6,
    "law": "paper",
    #: β [PWM counts] -> what the text states
    "points": {
        120.0: {"time_constant_s": 0.06, "overshoot_pct": math.nan},
        150.0: {"time_constant_s": 0.01, "overshoot_pct": 7.0},
    },
}

OPEN_LOOP = {
    "source": "[mpam-characterization], §IV.A",
    "time_constant_s": 0.09,
    "overshoot_pct": 0.0,
}

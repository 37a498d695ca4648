"""The fit characterize calls: a Tondu-Lopez law with its pressure threshold, fitted on isotonic points.

The plant's muscle (a published set) takes 0.29 MPa before its braid moves ([mpam-characterization]
Fig. 10); a fit without the threshold cannot follow the first millimetres of motion.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from mckibben.data.io import read_muscle
from mckibben.fit.isometric import fit_points, force_law, parameter_names
from mckibben.models.laws import LAWS
from mckibben.models.laws.tondu_lopez import TonduLopez

MUSCLE = Path(__file__).resolve().parents[1] / "src" / "mckibben" / "datasets" / "campaign" / "mpam97" / "muscle.toml"


def _points(law, loads=(0.6, 1.0, 1.4, 1.8, 2.1), pressures=np.linspace(0.0, 0.759e6, 12)):
    p, f = np.meshgrid(pressures, loads)
    ell, _ = law.length_under_load(p.ravel(), f.ravel())
    keep = np.isfinite(ell) & (ell < law.nominal_length - 3e-4)  # where the muscle moved off its rest length
    return pd.DataFrame({"held_length": ell[keep], "pressure": p.ravel()[keep], "force": f.ravel()[keep],
                         "direction": "inflate", "trial": 1})


@pytest.mark.parametrize("p_th", [0.0, 0.29e6])
def test_tondu_lopez_fit_recovers_the_pressure_threshold(p_th):
    spec = read_muscle(MUSCLE)
    truth = TonduLopez(0.432e-3, spec.braid_angle, 1.63, p_th, spec.nominal_length)
    d = _points(truth)
    res = fit_points(d, spec, "tondu-lopez")
    v = dict(zip(res.names, res.values))
    assert v["p_threshold_Pa"] == pytest.approx(p_th, abs=2e3)
    assert v["r0_m"] == pytest.approx(0.432e-3, rel=1e-3) and v["k"] == pytest.approx(1.63, rel=1e-3)
    # the law as a muscle file keeps it (the load cell's zero dropped): the lengths come back
    law = LAWS["tondu-lopez"].from_values(v, spec)
    ell, _ = law.length_under_load(d["pressure"].to_numpy(), d["force"].to_numpy())
    np.testing.assert_allclose(ell, d["held_length"], rtol=1e-5)


def test_a_saved_tondu_lopez_law_without_a_threshold_still_reads():
    spec = read_muscle(MUSCLE)
    names = parameter_names("tondu-lopez", spec)  # the names a law is saved with now, the threshold among them
    # and optional, so a law saved before the threshold was fitted (without it) reads
    assert "p_threshold_Pa" in names and "p_threshold_Pa" in LAWS["tondu-lopez"].extra["optional_names"]
    old = force_law("tondu-lopez", spec, [0.432e-3, 1.63, 0.0])
    new = force_law("tondu-lopez", spec, [0.432e-3, 1.63, 0.29e6, 0.0])
    assert float(old(0.5e6, 0.09)) > float(new(0.5e6, 0.09)) > 0 and float(new(0.2e6, 0.09)) == 0.0


def test_a_muscle_file_saved_without_the_threshold_reads_and_predicts(tmp_path):
    """A Tondu–Lopez [force_model] written before the threshold was fitted (no p_threshold_Pa)
    reads through the muscle-file reader and pulls as a law with no threshold."""
    from mckibben.data.muscle_file import read_muscle as read
    from mckibben.fit.muscle_file import muscle_force_law

    text = MUSCLE.read_text() + (
        '\n[force_model]\nmodel = "tondu-lopez"\nsource = "a campaign fitted before the threshold"\n'
        "[force_model.parameters]\nr0_m = 0.000432\nk = 1.63\noffset_N = 0.0\n")
    f = tmp_path / "old.toml"
    f.write_text(text)
    law = muscle_force_law(read(f))
    assert "p_threshold_Pa" not in law.parameters
    old = force_law("tondu-lopez", read(f), [0.432e-3, 1.63, 0.0])
    assert float(law.force(0.5e6, 0.09)[0]) == pytest.approx(float(old(0.5e6, 0.09)))

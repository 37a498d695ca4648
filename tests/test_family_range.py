"""A family law's validity range: rest lengths outside those it was fitted on are flagged, wherever it is used.

Synthetic family (three muscles, 150/250/350 mm, drawn from the relative-strain law with noise):
held out in ``compare``, saved to a muscle file for another rest length, and read back as a
:class:`~mckibben.models.muscle.Muscle` for yet another.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from mckibben.data import read_muscle, read_table
from mckibben.fit.isometric import compare_isometric, fit_isometric
from mckibben.fit.muscle_file import muscle_force_law, save_muscle_file
from mckibben.models.laws.relative_strain import RelativeStrain
from mckibben.models.muscle import Muscle

RESTS = {"m150": 0.150, "m250": 0.250, "m350": 0.350}


@pytest.fixture(scope="module")
def family(tmp_path_factory):
    rng = np.random.default_rng(2)
    rows = []
    for m, rest in RESTS.items():
        law = RelativeStrain(450.0, 200.0, 300.0, 2500.0, 0.02, rest)
        for frac in (0.0, 0.05, 0.10):
            ell = rest - frac * (rest - 0.02)
            p = np.linspace(0.0, 0.6e6, 13)
            for trial in (1, 2):
                f = law.force(p, ell) + rng.normal(0, 1.0, p.size)
                rows += [dict(held_length_mm=ell * 1e3, pressure_kPa=x / 1e3, force_N=y, direction="inflate",
                              trial=trial, muscle=m, rest_length_mm=rest * 1e3) for x, y in zip(p, f)]
    folder = tmp_path_factory.mktemp("range")
    pd.DataFrame(rows).to_csv(folder / "family.csv", index=False)
    (folder / "type.toml").write_text('id = "type"\nnominal_length_mm = 250\nouter_diameter_mm = 12\n')
    return folder / "family.csv", folder / "type.toml"


def test_held_out_muscles_outside_the_others_rest_lengths_are_flagged(family):
    c = compare_isometric(read_table(family[0]), read_muscle(family[1]), "leave-one-muscle-out",
                          models=["relative-strain"])
    folds = {f["held_out"]: f["extrapolated"] for f in c.scores[0]["folds"]}
    assert "rest_length_out_of_range" in folds["m150"] and "rest_length_out_of_range" in folds["m350"]
    assert "rest_length_out_of_range" not in folds["m250"]  # between the other two: interpolated


def test_a_saved_family_file_and_its_muscle_say_when_the_rest_length_is_outside(family, tmp_path):
    fit = fit_isometric(read_table(family[0]), read_muscle(family[1]), "relative-strain")
    spec = read_muscle(family[1])
    inside = save_muscle_file(tmp_path / "in.toml", spec, fit, rest_length=0.20)
    beyond = save_muscle_file(tmp_path / "out.toml", spec, fit, rest_length=0.50)
    assert "rest_length_out_of_range" not in muscle_force_law(read_muscle(inside)).flags
    assert "rest_length_out_of_range" in muscle_force_law(read_muscle(beyond)).flags
    assert "rest_length_out_of_range" in Muscle.from_muscle_file(beyond).flags
    # read back for another rest length: flagged outside, and the valid lengths follow the rest length
    m = Muscle.from_muscle_file(inside, rest_length=0.10)
    ref = Muscle.from_muscle_file(inside)
    assert "rest_length_out_of_range" in m.flags and "rest_length_out_of_range" not in ref.flags
    assert m.length_range == pytest.approx(tuple(x * 0.10 / 0.20 for x in ref.length_range))
    assert "rest_length_out_of_range" not in Muscle.from_muscle_file(inside, rest_length=0.30).flags

"""The relative-strain family law: kernel and NumPy face, physics, a family fit, held-out muscles, the plant.

The family is synthetic: three muscles of one type (rest lengths 150, 250 and 350 mm, 20 mm end
fittings) drawn from the law itself with noise, tared as a lab would. The plant check is the
muscle-file plant's (tests/test_muscle_file_plant.py) on a family law's file.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from mckibben.data import read_muscle, read_table
from mckibben.errors import InputError
from mckibben.fit.isometric import compare_isometric, fit_isometric
from mckibben.fit.muscle_file import muscle_force_law, save_muscle_file
from mckibben.models import laws
from mckibben.models.laws.relative_strain import RelativeStrain
from mckibben.models.muscle import Muscle
from mckibben.plant import PlantParams, simulate

TRUE = dict(a1_N_per_MPa=450.0, a2_N_per_MPa2=200.0, c0_N=300.0, c1_N_per_MPa=2500.0, end_length_m=0.02)
RESTS = {"m150": 0.150, "m250": 0.250, "m350": 0.350}


def _law(rest):
    return RelativeStrain(TRUE["a1_N_per_MPa"], TRUE["a2_N_per_MPa2"], TRUE["c0_N"], TRUE["c1_N_per_MPa"],
                          TRUE["end_length_m"], rest)


@pytest.fixture(scope="module")
def family(tmp_path_factory):
    """A family table (muscle, rest_length_mm) and the type's muscle file."""
    rng = np.random.default_rng(0)
    rows = []
    for m, rest in RESTS.items():
        for frac in (0.0, 0.05, 0.10, 0.15):  # held at rest and at 5, 10, 15 % relative strain
            ell = rest - frac * (rest - TRUE["end_length_m"])
            for trial in (1, 2, 3):
                p = np.linspace(0.0, 0.6e6, 13)
                for dn, pp in (("inflate", p), ("deflate", p[::-1])):
                    f = _law(rest).force(pp, ell) + rng.normal(0, 1.0, pp.size) + 3.0  # an unzeroed load cell
                    rows += [dict(held_length_mm=ell * 1e3, pressure_kPa=x / 1e3, force_N=y, direction=dn,
                                  trial=trial, muscle=m, rest_length_mm=rest * 1e3) for x, y in zip(pp, f)]
    folder = tmp_path_factory.mktemp("family")
    pd.DataFrame(rows).to_csv(folder / "family.csv", index=False)
    (folder / "type.toml").write_text('id = "type"\nnominal_length_mm = 250\nouter_diameter_mm = 12\n')
    return folder / "family.csv", folder / "type.toml"


def test_the_numpy_face_is_the_kernel_and_the_physics_holds():
    law = _law(0.25)
    p, ell = np.meshgrid(np.linspace(0, 0.6e6, 7), np.linspace(0.18, 0.26, 9))
    eps = (0.25 - ell) / (0.25 - 0.02)
    x = p / 1e6
    want = np.maximum(450 * x + 200 * x * x - (300 + 2500 * x) * eps, 0.0)
    # the same formula, written twice: agreement to round-off
    np.testing.assert_allclose(law.force(p, ell), want, rtol=1e-12, atol=1e-9)
    np.testing.assert_array_equal(laws.evaluate("relative-strain", p, ell, law.theta()), law.force(p, ell))
    f = law.force(p, ell)
    assert np.all(np.diff(f, axis=1) >= 0)  # rises with pressure
    assert np.all(np.diff(f, axis=0) >= 0)  # falls with contraction (rises with length)
    assert law.force(0.6e6, 0.12) == 0.0  # slack far below the free length: no push
    assert laws.law_of(law) == ("relative-strain", pytest.approx(law.theta()))
    with pytest.raises(InputError, match="end length"):
        RelativeStrain(1, 0, 0, 0, 0.3, 0.25)


def test_a_family_fit_recovers_the_law_and_its_end_length(family):
    fit = fit_isometric(read_table(family[0]), read_muscle(family[1]), "relative-strain", tare="lowest")
    r = fit.result
    assert "end_length_m" in r.names and r.flags == ()
    # 3 muscles x 4 lengths x 3 trials x 26 points of 1 N noise on forces up to ~380 N: the end length
    # to a millimetre, the blocked force's slope to 2 % (the tare at ~0 kPa removes ~3 N exactly)
    assert r["end_length_m"] == pytest.approx(0.02, abs=1e-3)
    assert r["a1_N_per_MPa"] == pytest.approx(450.0, rel=0.02)
    assert r.valid_range["rest_length"] == pytest.approx((0.15, 0.35))


def test_a_whole_muscle_is_predicted_from_its_rest_length(family):
    table, spec = read_table(family[0]), read_muscle(family[1])
    c = compare_isometric(table, spec, "leave-one-muscle-out", tare="lowest", models=["relative-strain"])
    assert c.best == "relative-strain" and [s["model"] for s in c.scores] == ["relative-strain"]
    folds = c.scores[0]["folds"]
    assert {f["held_out"] for f in folds} == set(RESTS)
    # the noise is 1 N on peaks of 280..380 N: every held-out muscle within 1 % of its peak
    assert max(f["rmse_pct_of_peak"] for f in folds) < 1.0
    c = compare_isometric(table, spec, "leave-one-length-out", tare="lowest", models=["relative-strain"])
    assert len(c.scores[0]["folds"]) == 12 and c.scores[0]["worst_fold_pct_of_peak"] < 1.0


def test_one_muscle_fits_without_an_end_length(family):
    d = pd.read_csv(family[0])
    one = family[0].parent / "one.csv"
    d[d["muscle"] == "m250"].drop(columns=["rest_length_mm"]).to_csv(one, index=False)
    spec = read_muscle(family[1])  # id "type", nominal 250 mm
    (family[0].parent / "m250.toml").write_text('id = "m250"\nnominal_length_mm = 250\nouter_diameter_mm = 12\n')
    fit = fit_isometric(read_table(one), read_muscle(family[0].parent / "m250.toml"), "relative-strain", "lowest")
    assert "end_length_m" not in fit.result.names and fit.result.r2 > 0.99
    assert spec.id == "type"


def test_a_family_file_drives_the_plant_to_the_law(family, tmp_path):
    fit = fit_isometric(read_table(family[0]), read_muscle(family[1]), "relative-strain", tare="lowest")
    path = save_muscle_file(tmp_path / "m300.toml", read_muscle(family[1]), fit, rest_length=0.30)
    law = muscle_force_law(read_muscle(path))
    m = Muscle.from_muscle_file(path)
    assert m.nominal_length == 0.30 and law.model == "relative-strain"
    lo, hi = m.length_range  # the fitted relative lengths, scaled to the 300 mm muscle
    shortest = min((r - 0.15 * (r - 0.02)) / r for r in RESTS.values())  # the 350 mm muscle at 15 % relative strain
    assert lo == pytest.approx(0.30 * shortest, rel=1e-6) and hi == pytest.approx(0.30)
    plant = PlantParams.from_muscle_file(m)
    # blocked at the rest length and at 5 % relative strain: the plant pulls the family law's force
    p = np.array([0.2e6, 0.4e6, 0.6e6])
    for ell in (0.30, 0.30 - 0.05 * (0.30 - fit.result["end_length_m"])):
        r = simulate(plant.replace(supply_pressure=p, load_kind="blocked", leak_conductance=0.0, nominal_length=0.30),
                     0.5, inlet=255, initial_pressure=p, initial_length=ell)
        want = law.force(r.pressure[:, -1], ell)[0] - fit.result["offset_N"]
        # the bar: within 1 % of the static law (the plant runs the same kernel)
        np.testing.assert_allclose(r.force[:, -1], want, rtol=0.01)
        if ell < 0.30:
            break


def test_muscle_file_refuses_a_bad_rest_length(family, tmp_path):
    fit = fit_isometric(read_table(family[0]), read_muscle(family[1]), "relative-strain", tare="lowest")
    with pytest.raises(InputError, match="rest_length"):
        save_muscle_file(tmp_path / "x.toml", read_muscle(family[1]), fit, rest_length=-1.0)
    assert not (tmp_path / "x.toml").exists()

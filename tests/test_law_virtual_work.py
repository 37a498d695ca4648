"""The virtual-work family law: kernel and NumPy face, physics, a family fit, held-out muscles, the plant.

The family is synthetic: three muscles of one type (rest lengths 150, 250 and 350 mm, end zones of
20 mm) drawn from the law itself with noise, tared as a lab would. The plant
check is the muscle-file plant's (tests/test_muscle_file_plant.py) on a family law's file.
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
from mckibben.models.laws.virtual_work import VirtualWork, ends_share
from mckibben.models.muscle import Muscle
from mckibben.plant import PlantParams, simulate

TRUE = dict(a0_N_per_MPa=530.0, a1_N_per_MPa=-2400.0, a2_N_per_MPa2=400.0, g0_N=130.0, e0=0.025, g1_N=720.0,
            end_zone_m=0.02)
RESTS = {"m150": 0.150, "m250": 0.250, "m350": 0.350}
CONTRACTIONS = (0.0, 0.04, 0.08, 0.12)


def _law(rest, **change):
    t = {**TRUE, **change}
    return VirtualWork(t["a0_N_per_MPa"], t["a1_N_per_MPa"], t["a2_N_per_MPa2"], t["g0_N"], t["e0"], t["g1_N"],
                       t["end_zone_m"], rest)


@pytest.fixture(scope="module")
def family(tmp_path_factory):
    """A family table (muscle, rest_length_mm) and the type's muscle file."""
    rng = np.random.default_rng(1)
    rows = []
    for m, rest in RESTS.items():
        for eps in CONTRACTIONS:
            ell = rest * (1.0 - eps)
            for trial in (1, 2, 3):
                p = np.linspace(0.0, 0.6e6, 13)
                for dn, pp in (("inflate", p), ("deflate", p[::-1])):
                    f = _law(rest).force(pp, ell) + rng.normal(0, 1.0, pp.size) + 3.0  # an unzeroed load cell
                    rows += [dict(held_length_mm=ell * 1e3, pressure_kPa=x / 1e3, force_N=y, direction=dn,
                                  trial=trial, muscle=m, rest_length_mm=rest * 1e3) for x, y in zip(pp, f)]
    folder = tmp_path_factory.mktemp("family")
    pd.DataFrame(rows).to_csv(folder / "family.csv", index=False)
    (folder / "type.toml").write_text('id = "type"\nnominal_length_mm = 250\nouter_diameter_mm = 10\n')
    return folder / "family.csv", folder / "type.toml"


def test_the_numpy_face_is_the_kernel_and_the_physics_holds():
    law = _law(0.25)
    p, ell = np.meshgrid(np.linspace(0, 0.6e6, 7), np.linspace(0.20, 0.26, 13))
    eps = 1.0 - ell / 0.25
    x = p / 1e6
    g = np.where(eps >= 0, 130 * (1 - np.exp(-np.maximum(eps, 0) / 0.025)) + 720 * eps, (130 / 0.025 + 720) * eps)
    share = 1 - (2 * 0.02 / 0.25) * (1 - np.exp(-0.25 / (2 * 0.02)))  # the ends' share of a 250 mm muscle
    want = share * np.maximum((530 - 2400 * eps + 400 * x) * x - g, 0.0)
    # the same formula, written twice: agreement to round-off
    np.testing.assert_allclose(law.force(p, ell), want, rtol=1e-12, atol=1e-9)
    np.testing.assert_array_equal(laws.evaluate("virtual-work", p, ell, law.theta()), law.force(p, ell))
    f = law.force(p, ell)
    assert np.all(np.diff(f, axis=1) >= 0)  # rises with pressure
    assert np.all(np.diff(f, axis=0) >= 0)  # falls with contraction (rises with length)
    # held shorter than its rest length the muscle is slack until a threshold that rises with contraction
    thresholds = [p[0][np.argmax(law.force(p[0], 0.25 * (1 - e)) > 0)] for e in (0.0, 0.04, 0.08)]
    assert thresholds[0] < thresholds[1] < thresholds[2]
    assert law.force(0.6e6, 0.15) == 0.0  # far below its free length: no push
    # a longer muscle of the type pulls more at the same contraction: a smaller share is ends
    assert _law(0.35).force(0.5e6, 0.35 * 0.96) > _law(0.15).force(0.5e6, 0.15 * 0.96)
    # stretched beyond the rest length the elastic term is its tangent: linear in length, no exponential blow-up
    f3 = law.force(0.1e6, np.array([0.30, 0.35, 0.40]))
    assert f3[2] - 2 * f3[1] + f3[0] == pytest.approx(0.0, abs=1e-9 * f3[2])
    assert laws.law_of(law) == ("virtual-work", pytest.approx(law.theta()))
    # the ends' share: 1 − 2λ/L0 for a long muscle, in (0, 1] however short
    assert ends_share(100.0, 0.02) == pytest.approx(1 - 0.04 / 100.0, rel=1e-9) and ends_share(0.25, 0.0) == 1.0
    assert 0 < ends_share(0.01, 0.02) < ends_share(0.05, 0.02) < ends_share(0.25, 0.02) < 1
    with pytest.raises(InputError, match="end zone"):
        _law(0.25, end_zone_m=-0.01)
    with pytest.raises(InputError, match="e0"):
        _law(0.25, e0=0.0)


def test_a_family_fit_recovers_the_law_and_its_end_zone(family):
    fit = fit_isometric(read_table(family[0]), read_muscle(family[1]), "virtual-work", tare="lowest")
    r = fit.result
    assert "end_zone_m" in r.names and r.flags == ()
    # 3 muscles x 4 lengths x 3 trials x 26 points of 1 N noise on forces up to ~330 N
    assert r["end_zone_m"] == pytest.approx(0.02, abs=2e-3)
    assert r["a0_N_per_MPa"] == pytest.approx(530.0, rel=0.03)
    assert r["e0"] == pytest.approx(0.025, rel=0.15)
    assert r.valid_range["rest_length"] == pytest.approx((0.15, 0.35))


def test_a_whole_muscle_is_predicted_from_its_rest_length(family):
    table, spec = read_table(family[0]), read_muscle(family[1])
    c = compare_isometric(table, spec, "leave-one-muscle-out", tare="lowest", models=["virtual-work"])
    s = c.scores[0]
    assert c.best == "virtual-work" and {f["held_out"] for f in s["folds"]} == set(RESTS)
    # the noise is 1 N on peaks of 230..290 N: every held-out muscle within 1 % of its peak
    assert s["worst_fold_pct_of_peak"] < 1.0
    # the shortest and the longest muscle lie outside what the others span: flagged as extrapolated
    assert s["extrapolated_folds"] >= 2


def test_one_muscle_fits_without_an_end_zone(family):
    d = pd.read_csv(family[0])
    one = family[0].parent / "one.csv"
    d[d["muscle"] == "m250"].drop(columns=["rest_length_mm"]).to_csv(one, index=False)
    (family[0].parent / "m250.toml").write_text('id = "m250"\nnominal_length_mm = 250\nouter_diameter_mm = 10\n')
    fit = fit_isometric(read_table(one), read_muscle(family[0].parent / "m250.toml"), "virtual-work", "lowest")
    assert "end_zone_m" not in fit.result.names and fit.result.r2 > 0.99
    # one muscle: the ends' share is folded into the areas, a0·s
    assert fit.result["a0_N_per_MPa"] == pytest.approx(530.0 * float(ends_share(0.25, 0.02)), rel=0.03)


def test_a_non_physical_fit_is_flagged():
    from mckibben.data.muscle_file import MuscleSpec
    from mckibben.models.laws.virtual_work import fit_spec

    spec = MuscleSpec(id="x", nominal_length=0.2, outer_diameter=0.01)
    data = {"pressure": np.array([0.1e6, 0.6e6]), "held_length": np.array([0.2, 0.16]),
            "force": np.array([10.0, 100.0]), "rest_length": np.array([0.2, 0.2])}
    fs = fit_spec(spec, 100.0, data)
    v = dict(zip(fs.names, fs.starts[0]))
    v.update(a0_N_per_MPa=100.0, a1_N_per_MPa=-5000.0, a2_N_per_MPa2=0.0, offset_N=0.0)
    assert "negative_area" in fs.physical([v[n] for n in fs.names])  # 100 − 5000·0.2 < 0 at the shortest length
    v.update(a1_N_per_MPa=-100.0, offset_N=50.0)
    assert fs.physical([v[n] for n in fs.names]) == ["large_offset"]


def test_a_family_file_drives_the_plant_to_the_law(family, tmp_path):
    fit = fit_isometric(read_table(family[0]), read_muscle(family[1]), "virtual-work", tare="lowest")
    path = save_muscle_file(tmp_path / "m300.toml", read_muscle(family[1]), fit, rest_length=0.30)
    law = muscle_force_law(read_muscle(path))
    m = Muscle.from_muscle_file(path)
    assert m.nominal_length == 0.30 and law.model == "virtual-work"
    lo, hi = m.length_range  # the fitted relative lengths, scaled to the 300 mm muscle
    assert lo == pytest.approx(0.30 * (1 - max(CONTRACTIONS)), rel=1e-6) and hi == pytest.approx(0.30)
    plant = PlantParams.from_muscle_file(m)
    # blocked at the rest length and at 4 % contraction: the plant pulls the family law's force
    p = np.array([0.2e6, 0.4e6, 0.6e6])
    for ell in (0.30, 0.30 * 0.96):
        r = simulate(plant.replace(supply_pressure=p, load_kind="blocked", leak_conductance=0.0, nominal_length=0.30),
                     0.5, inlet=255, initial_pressure=p, initial_length=ell)
        want = law.force(r.pressure[:, -1], ell)[0] - fit.result["offset_N"]
        assert np.all(want[1:] > 10.0)  # pulling, not the slack branch
        # the bar: within 1 % of the static law (the plant runs the same kernel)
        np.testing.assert_allclose(r.force[:, -1], want, rtol=0.01)

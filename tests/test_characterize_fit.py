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


# -- the braid's friction: the plant's own branches, and A_f fitted with the law held ---------------------------------

#: A plant whose friction is all proportional to pressure (the muscle file's form) and whose leak is shut. [N/Pa]
A_F = 0.2e-6
LOADS = (0.6, 1.0, 1.4)
PRESSURES = np.linspace(0.4e6, 0.76e6, 7)


def _plant(**kw):
    from mckibben.plant import params as PP

    return PP.PlantParams(friction_force=0.0, friction_per_pa=A_F, **kw)


def test_the_plant_branch_lengths_are_where_a_slow_sweep_leaves_its_muscle():
    # the plant's pressure ramped slowly up, then down, through one valve at a time (no leak, isothermal): its Dahl
    # element ends each leg at its slip limit, and the integrated length is the branch's of static_branch_lengths
    from mckibben.plant import params as PP
    from mckibben.plant.simulator import PlantStepper, static_branch_lengths, static_length

    plant = PP.PlantParams(load_force=1.0, leak_conductance=0.0, thermal="polytropic", polytropic_n=1.0)
    st = PlantStepper(plant)

    def ramp(p0, p1, rate):  # [Pa], [Pa], [Pa/s]
        n = int(abs(p1 - p0) / rate / st.ts)
        for k in range(n):
            target = p0 + (p1 - p0) * (k + 1) / n
            st.advance(*((115 if st.pressure < target else 0, 0) if p1 > p0 else (0, 115 if st.pressure > target else 0)))

    seen = {}
    for k, (branch, legs) in enumerate((("inflate", ((0.0, 0.4e6, 1e6), (0.4e6, 0.43e6, 0.05e6), (0.43e6, 0.45e6, 0.01e6))),
                                        ("deflate", ((0.45e6, 0.6e6, 1e6), (0.6e6, 0.53e6, 0.2e6), (0.53e6, 0.515e6, 0.05e6),
                                                     (0.515e6, 0.5e6, 0.01e6))))):
        for leg in legs:
            ramp(*leg)
        want = float(static_branch_lengths(plant, st.pressure)[k][0])
        # quasi-static at the end (0.01 MPa/s): the damping's drag is ~0.04 mm; the static length is ~1 mm away
        assert st.length == pytest.approx(want, abs=0.1e-3), (branch, st.length, want)
        seen[branch] = want - float(static_length(plant, st.pressure)[0])
    assert seen["inflate"] > 0.5e-3 and seen["deflate"] < -0.5e-3
    # no friction: both branches are the static length
    bare = plant.replace(friction_force=0.0, friction_per_pa=0.0)
    up, down = static_branch_lengths(bare, 0.5e6)
    assert up[0] == down[0] == static_length(bare, 0.5e6)[0]


def _branch_table(tmp_path, ripple):
    """Both branches of the plant's loop, each point where its braid slipped at P_slip and recorded at the hold's
    mean pressure, ``ripple`` below (inflating) or above (deflating) it: (table, slip pressures, static table)."""
    from mckibben.data import read_table
    from mckibben.errors import UnreachableError
    from mckibben.plant.simulator import static_branch_lengths, static_length

    rows, static = [], []
    for f in LOADS:
        for p in PRESSURES:
            try:
                up, down = static_branch_lengths(_plant(load_force=f), p)
                mid = static_length(_plant(load_force=f), p)
            except UnreachableError:
                continue
            rows += [(p - ripple, f, up[0], "inflate", p), (p + ripple, f, down[0], "deflate", p)]
            static.append((p, f, mid[0]))
    df = pd.DataFrame(rows, columns=["p", "f", "ell", "direction", "slip"])
    pd.DataFrame({"pressure_MPa": df["p"] / 1e6, "load_N": df["f"], "length_mm": df["ell"] * 1e3,
                  "direction": df["direction"], "trial": 1}).to_csv(tmp_path / "h.csv", index=False)
    s = pd.DataFrame(static, columns=["p", "f", "ell"])
    pd.DataFrame({"pressure_MPa": s["p"] / 1e6, "load_N": s["f"], "length_mm": s["ell"] * 1e3,
                  "trial": 1}).to_csv(tmp_path / "s.csv", index=False)
    return read_table(tmp_path / "h.csv", "hysteresis"), df["slip"].to_numpy(), read_table(tmp_path / "s.csv", "isotonic")


def test_friction_with_the_law_held_finds_the_plant_area_where_the_braid_slipped(tmp_path):
    from mckibben.errors import InputError
    from mckibben.fit.direction import fit_isotonic_friction
    from mckibben.fit.isometric import fit_isotonic_law
    from mckibben.models.hysteresis.direction import FRICTION_NAME

    spec = read_muscle(MUSCLE)
    table, slip, static = _branch_table(tmp_path, ripple=10e3)
    law = fit_isotonic_law(static, spec, "tondu-lopez", tube=True)
    fr = fit_isotonic_friction(table, spec, "tondu-lopez", tube=True, held=law, slip_pressure=slip)
    k = fr.names.index(FRICTION_NAME)
    # the law is held: its values and standard errors are the static fit's, A_f has its own interval
    np.testing.assert_array_equal(fr.values[:k], law.values)
    np.testing.assert_array_equal(fr.stderr[:k], law.stderr)
    assert fr.valid_range == law.valid_range and fr.stderr[k] > 0
    # the plant's branches evaluated where its braid slipped give its A_f back (measured to 1e-12: the plant's law is
    # Tondu-Lopez, which the static fit finds exactly; 0.1 % leaves room for the optimizer's tolerance)
    assert fr.values[k] == pytest.approx(A_F, rel=1e-3), fr.values[k]  # noise-free: its interval is ~1e-19 m² wide
    # at the hold's mean pressure the loop looks narrower by the ripple's reach on each branch: A_f comes out low
    # (0.138e-6 measured for a 10 kPa ripple)
    mean = fit_isotonic_friction(table, spec, "tondu-lopez", tube=True, held=law)
    assert mean.values[k] < 0.8 * A_F, mean.values[k]
    # bad input: named
    with pytest.raises(InputError, match="slip_pressure"):
        fit_isotonic_friction(table, spec, "tondu-lopez", tube=True, held=law, slip_pressure=slip[:-1])
    with pytest.raises(InputError, match="held"):
        fit_isotonic_friction(table, spec, "tondu-lopez", tube=False, held=law)

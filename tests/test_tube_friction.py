"""The tube's passive stretch and the braid's friction as fitted terms of any law (issue 35's two bars).

Known parameters come from the plant (its compiled physics, an independent source of the same
terms): its static length with a tube stiffness it was given, and its Dahl element's slip limit
F_c = friction_per_pa·P while the pressure moves one way. The fits must find them back, the muscle
file must carry them, and the file's statics and plant must give the plant's lengths.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from mckibben.data import read_table
from mckibben.data.muscle_file import read_muscle
from mckibben.fit.direction import fit_isotonic_friction
from mckibben.errors import InputError
from mckibben.fit.isometric import IsometricFit, fit_isotonic_law, fit_points
from mckibben.fit.muscle_file import muscle_file_text, muscle_force_law
from mckibben.models.hysteresis.direction import FRICTION_FORCE_NAME, FRICTION_NAME, branch_force
from mckibben.models.law_statics import LawMuscle
from mckibben.models.muscle import Muscle
from mckibben.models.tube import TUBE_NAME, tube_force
from mckibben.plant import params as PP
from mckibben.plant import physics as ph
from mckibben.plant.simulator import PlantStepper
from mckibben.plant.simulator import static_branch_lengths as plant_branch_lengths
from mckibben.plant.simulator import static_length as plant_static_length

from conftest import run_cli

MUSCLE = str(Path(__file__).resolve().parents[1] / "src" / "mckibben" / "datasets" / "campaign" / "mpam97"
             / "muscle.toml")
#: The plant's tube and friction in these tests: known, and unlike the defaults (200 N/m, 0.2e-6 N/Pa).
K_TUBE, A_F = 150.0, 0.15e-6
LOADS = (0.6, 0.9, 1.2, 1.5)
PRESSURES = np.linspace(0.32e6, 0.76e6, 9)


def _plant(**kw) -> PP.PlantParams:
    return PP.PlantParams(passive_stiffness=K_TUBE, friction_force=0.0, friction_per_pa=A_F, **kw)


def _lengths(load, pressure):
    """The plant's static (friction-free) length at each (load, pressure), NaN where it rests on a stop. [m]"""
    load, pressure = np.broadcast_arrays(np.asarray(load, float), np.asarray(pressure, float))
    out = np.full(load.size, np.nan)
    for i, (f, p) in enumerate(zip(load.ravel(), pressure.ravel())):
        try:
            out[i] = float(plant_static_length(_plant(load_force=float(f)), float(p))[0])
        except Exception:  # UnreachableError: on an end stop, no static length
            pass
    return out.reshape(load.shape)


def _table(tmp_path, rows: list[dict], kind: str):
    df = pd.DataFrame(rows)
    path = tmp_path / f"{kind}.csv"
    cols = {"pressure_MPa": df["pressure"] / 1e6, "load_N": df["load"], "length_mm": df["length"] * 1e3,
            "trial": np.ones(len(df), int)}
    if kind == "hysteresis":
        cols["direction"] = df["direction"]
    pd.DataFrame(cols).to_csv(path, index=False)
    return read_table(path, kind)


@pytest.fixture(scope="module")
def isotonic_points():
    """The plant's static lengths over loads and pressures (the muscle moved: off its stops)."""
    f, p = np.meshgrid(LOADS, PRESSURES, indexing="ij")
    ell = _lengths(f, p)
    ok = np.isfinite(ell)
    return [{"pressure": pp, "load": ff, "length": ll} for pp, ff, ll in zip(p[ok], f[ok], ell[ok])]


def test_tube_stiffness_is_found_back_with_its_interval(tmp_path, isotonic_points):
    table = _table(tmp_path, isotonic_points, "isotonic")
    spec = read_muscle(MUSCLE)
    stretched = sum(r["length"] > spec.nominal_length for r in isotonic_points)
    assert stretched >= 4  # points past the rest length: the data see the tube
    res = fit_isotonic_law(table, spec, "tondu-lopez", tube=True)
    k, (lo, hi) = res[TUBE_NAME], res.ci95[res.names.index(TUBE_NAME)]
    # the plant's static lengths are exact (no noise) and tondu-lopez is the plant's law: k_t within 2 %
    assert k == pytest.approx(K_TUBE, rel=0.02) and lo <= K_TUBE <= hi, (k, lo, hi, res.flags)
    assert not [f for f in res.flags if f.startswith(TUBE_NAME)]
    plain = fit_isotonic_law(table, spec, "tondu-lopez")
    assert res.residual_rms < 0.2 * plain.residual_rms  # without the term the law misfits the stretched points


def test_tube_stiffness_unconstrained_without_a_stretched_point_is_flagged(tmp_path, isotonic_points):
    spec = read_muscle(MUSCLE)
    short = [r for r in isotonic_points if r["length"] < spec.nominal_length]
    res = fit_isotonic_law(_table(tmp_path, short, "isotonic"), spec, "tondu-lopez", tube=True)
    assert f"{TUBE_NAME}_unconstrained" in res.flags, res.flags


def test_the_surface_model_has_no_tube_term(isotonic_points):
    pts = pd.DataFrame({"held_length": [r["length"] for r in isotonic_points],
                        "pressure": [r["pressure"] for r in isotonic_points],
                        "force": [r["load"] for r in isotonic_points], "direction": "inflate", "trial": 1})
    with pytest.raises(InputError, match="tube: the tube's stretch is a term of a registered force law"):
        fit_points(pts, read_muscle(MUSCLE), "surface", tube=True)


def _saved(tmp_path, res, spec, name="fitted.toml"):
    path = tmp_path / name
    path.write_text(muscle_file_text(dataclasses.replace(spec, path=str(path)),
                                     IsometricFit("tondu-lopez", res, spec, {"method": "none"}, pd.DataFrame())))
    return path


def test_the_muscle_file_carries_the_tube_to_predict_and_to_its_plant(tmp_path, isotonic_points):
    spec = read_muscle(MUSCLE)
    res = fit_isotonic_law(_table(tmp_path, isotonic_points, "isotonic"), spec, "tondu-lopez", tube=True)
    path = _saved(tmp_path, res, spec)
    m = Muscle.from_muscle_file(path)
    assert m.tube_stiffness == pytest.approx(res[TUBE_NAME], rel=1e-12) and m.friction_area == 0.0
    plant = PP.PlantParams.from_muscle_file(path)
    assert plant.passive_stiffness == pytest.approx(res[TUBE_NAME], rel=1e-12)
    # predict length (the file's statics) equals the plant of the same file (its compiled tube term), stretched
    # past the rest length and not
    for load, p in ((1.5, 0.45e6), (0.9, 0.5e6), (0.6, 0.7e6)):
        want = float(plant_static_length(plant.replace(load_force=load), p)[0])
        r = run_cli("predict", "length", "--muscle-file", str(path), "--pressure", f"{p}Pa", "--load", f"{load}N",
                    "--json")
        assert r.code == 0, r.err
        # both solve the same balance to their root finders' tolerance (1e-9 m and better)
        assert r.json()["length_m"] == pytest.approx(want, abs=1e-7), (load, p)
    # and the file gives the plant's own static lengths back: the fit found the plant's law and tube
    pts = [r for r in isotonic_points if r["length"] > spec.nominal_length]
    got = m.length_for_pressure(np.array([r["pressure"] for r in pts]), np.array([r["load"] for r in pts])).length
    assert np.max(np.abs(got - [r["length"] for r in pts])) < 0.1e-3  # m: within 0.1 mm of the plant's
    # predict force adds the tube's pull past the rest length
    law = muscle_force_law(read_muscle(path))
    f, _ = law.force(0.5e6, 0.100)
    bare = dataclasses.replace(law, parameters={n: v for n, v in law.parameters.items() if n != TUBE_NAME})
    f0, _ = bare.force(0.5e6, 0.100)
    assert float(f - f0) == pytest.approx(float(tube_force(0.100, spec.nominal_length, res[TUBE_NAME])), rel=1e-12)


def test_a_muscle_file_without_the_terms_reads_as_before_and_a_negative_one_is_refused(tmp_path, isotonic_points):
    spec = read_muscle(MUSCLE)
    res = fit_isotonic_law(_table(tmp_path, isotonic_points, "isotonic"), spec, "tondu-lopez")
    path = _saved(tmp_path, res, spec, "old.toml")
    assert TUBE_NAME not in path.read_text()
    m = Muscle.from_muscle_file(path)
    assert m.tube_stiffness == 0.0 and m.friction_area == 0.0 and m.friction_force == 0.0 and not m.has_friction
    plant = PP.PlantParams.from_muscle_file(path)
    assert plant.passive_stiffness == 0.0 and plant.friction_per_pa == 0.0 and plant.friction_force == 0.0
    bad = tmp_path / "bad.toml"
    bad.write_text(path.read_text().replace("[force_model.parameters]\n",
                                            f"[force_model.parameters]\n{TUBE_NAME} = -5.0\n"))
    r = run_cli("predict", "length", "--muscle-file", str(bad), "--pressure", "0.5MPa", "--load", "1N")
    assert r.code == 2 and "bad.toml" in r.err and TUBE_NAME in r.err and "Traceback" not in r.err, r.err
    assert len(r.err.strip().splitlines()) == 1


def test_friction_branches_have_the_plant_dahl_elements_sign():
    # the plant's pressure ramped slowly up (then down) through the inlet (bleed) alone, no leak, isothermal: the
    # pressure moves one way, the muscle with it, its Dahl element sits at its slip limit, and the length is the
    # branch's: law -/+ A_f.P = load (the tube included, 150 N/m)
    load = 1.0
    plant = _plant(load_force=load, leak_conductance=0.0, thermal="polytropic", polytropic_n=1.0)
    st = PlantStepper(plant)
    name, th = plant.law(1)
    m = LawMuscle("plant", 0.097, name, th[:, 0], 0.112, (0.0, 1e6), (0.05, 0.2), 1.2e-3, tube_stiffness=K_TUBE,
                  friction_area=A_F)

    def ramp(p0, p1, rate):  # the pressure from p0 to p1 at rate [Pa/s], one valve only (a one-way pressure)
        n = int(abs(p1 - p0) / rate / st.ts)
        for k in range(n):
            target = p0 + (p1 - p0) * (k + 1) / n
            if p1 > p0:
                st.advance(115 if st.pressure < target else 0, 0)
            else:
                st.advance(0, 115 if st.pressure > target else 0)

    seen = {}
    for branch, legs in (("inflate", ((0.0, 0.4e6, 1e6), (0.4e6, 0.43e6, 0.05e6), (0.43e6, 0.45e6, 0.01e6))),
                         ("deflate", ((0.45e6, 0.6e6, 1e6), (0.6e6, 0.53e6, 0.2e6), (0.53e6, 0.515e6, 0.05e6),
                                      (0.515e6, 0.5e6, 0.01e6)))):
        for leg in legs:
            ramp(*leg)
        z, fc = st.bk[ph.Z_FRIC], A_F * st.pressure
        # the braid slips: inflating (contracting) it pulls against the load and the friction, deflating with it
        assert z / fc == pytest.approx(-1.0 if branch == "inflate" else 1.0, abs=0.01)
        branch_len = float(m.length_for_pressure(st.pressure, load, branch).length)
        static = float(m.length_for_pressure(st.pressure, load).length)
        # quasi-static (0.01 MPa/s at the end): the muscle lags its branch by its damping's drag, measured 0.04 mm;
        # the static length is 1 mm away
        assert st.length == pytest.approx(branch_len, abs=0.1e-3), (branch, st.length, branch_len, static)
        seen[branch] = branch_len - static
    assert seen["inflate"] > 0.5e-3 and seen["deflate"] < -0.5e-3  # inflating the muscle is longer than static


def test_friction_area_is_found_back_on_both_branches_and_reaches_the_plant(tmp_path):
    # the branches of a sweep: law(P, L) - A_f.P = load inflating, + A_f.P deflating, i.e. the plant's static length
    # under load + A_f.P (inflate) and load - A_f.P (deflate)
    rows = []
    for f in LOADS:
        for dn, sign in (("inflate", 1.0), ("deflate", -1.0)):
            ell = _lengths(f + sign * A_F * PRESSURES, PRESSURES)
            rows += [{"pressure": p, "load": f, "length": x, "direction": dn}
                     for p, x in zip(PRESSURES, ell) if np.isfinite(x)]
    table = _table(tmp_path, rows, "hysteresis")
    spec = read_muscle(MUSCLE)
    fr = fit_isotonic_friction(table, spec, "tondu-lopez", tube=True)
    a, (lo, hi) = fr[FRICTION_NAME], fr.ci95[fr.names.index(FRICTION_NAME)]
    # exact branch lengths of the plant's law: A_f and k_t within 2 %
    assert a == pytest.approx(A_F, rel=0.02) and lo <= A_F <= hi, (a, lo, hi, fr.flags)
    assert fr[TUBE_NAME] == pytest.approx(K_TUBE, rel=0.02)
    path = tmp_path / "friction.toml"
    path.write_text(muscle_file_text(dataclasses.replace(spec, path=str(path)),
                                     IsometricFit("tondu-lopez", fr, spec, {"method": "none"}, pd.DataFrame())))
    m = Muscle.from_muscle_file(path)
    plant = PP.PlantParams.from_muscle_file(path)
    assert plant.friction_per_pa == pytest.approx(a, rel=1e-12) and plant.friction_force == 0.0
    assert plant.passive_stiffness == pytest.approx(fr[TUBE_NAME], rel=1e-12)
    for r in rows[::5]:
        got = float(m.length_for_pressure(r["pressure"], r["load"], r["direction"]).length)
        assert got == pytest.approx(r["length"], abs=0.1e-3), r  # m: the branch's length within 0.1 mm
    # the static length is the loop's middle: between the branches
    up, down, mid = (float(m.length_for_pressure(0.5e6, 1.2, b).length) for b in ("inflate", "deflate", None))
    assert up > mid > down
    # mckibben predict length gives each branch (--branch) and the static length (without)
    for branch, want in (("inflate", up), ("deflate", down), (None, mid)):
        r = run_cli("predict", "length", "--muscle-file", str(path), "--pressure", "0.5MPa", "--load", "1.2N",
                    *(["--branch", branch] if branch else []), "--json")
        assert r.code == 0 and r.json()["length_m"] == pytest.approx(want, rel=1e-12), (branch, r.err)


def test_a_branch_is_refused_where_there_is_no_friction_or_no_such_branch(tmp_path, isotonic_points):
    spec = read_muscle(MUSCLE)
    res = fit_isotonic_law(_table(tmp_path, isotonic_points, "isotonic"), spec, "tondu-lopez", tube=True)
    path = _saved(tmp_path, res, spec)
    for args, words in ((["--muscle-file", str(path), "--branch", "sideways"], "sideways"),
                        (["--muscle-file", str(path), "--branch", "inflate"], "no fitted friction"),
                        (["--muscle", "mpam97", "--branch", "deflate"], "no fitted friction")):
        r = run_cli("predict", "length", "--pressure", "0.5MPa", "--load", "1N", *args)
        assert r.code == 2 and words in r.err and "branch" in r.err and "Traceback" not in r.err, (args, r.err)
        assert len(r.err.strip().splitlines()) == 1


def test_branch_force_is_the_friction_structure_far_along_a_branch():
    def law(v, p, ell, **kw):
        return v[0] * np.asarray(p) * np.asarray(ell)

    p, ell = np.array([1e5, 4e5]), np.array([0.09, 0.1])
    static = law([2.0], p, ell)
    assert np.allclose(branch_force(law, [2.0], 1e-7, p, ell, "inflate"), static - 1e-7 * p, rtol=1e-12)
    assert np.allclose(branch_force(law, [2.0], 1e-7, p, ell, "deflate"), static + 1e-7 * p, rtol=1e-12)
    assert np.allclose(branch_force(law, [2.0], 1e-7, p, ell, None), static, rtol=1e-12)
    # the slip limit's constant part beside A_f.P (the plant's friction_force): law -/+ (F_0 + A_f.P)
    for b, sign in (("inflate", -1.0), ("deflate", 1.0)):
        got = branch_force(law, [2.0], 1e-7, p, ell, b, friction_force=0.03)
        assert np.allclose(got, static + sign * (0.03 + 1e-7 * p), rtol=1e-12)
    assert np.allclose(branch_force(law, [2.0], 1e-7, p, ell, None, friction_force=0.03), static, rtol=1e-12)


#: A constant friction (the plant's ``friction_force``) for the tests of F_0: a third of A_f.P's range here. [N]
F_0 = 0.04


def _branch_rows(f0: float, pressures=PRESSURES) -> list[dict]:
    """The branches of a sweep of each load: the plant's static length under load + (F_0 + A_f.P) inflating, less
    deflating (its Dahl slip limit with a constant part)."""
    rows = []
    for f in LOADS:
        for dn, sign in (("inflate", 1.0), ("deflate", -1.0)):
            ell = _lengths(f + sign * (f0 + A_F * pressures), pressures)
            rows += [{"pressure": p, "load": f, "length": x, "direction": dn}
                     for p, x in zip(pressures, ell) if np.isfinite(x)]
    return rows


def test_a_constant_friction_is_found_back_with_its_interval_and_reaches_predict_and_the_plant(tmp_path):
    rows = _branch_rows(F_0, np.linspace(0.1e6, 0.76e6, 12))
    table = _table(tmp_path, rows, "hysteresis")
    spec = read_muscle(MUSCLE)
    fr = fit_isotonic_friction(table, spec, "tondu-lopez", tube=True, constant=True)
    k, c = fr.names.index(FRICTION_NAME), fr.names.index(FRICTION_FORCE_NAME)
    # exact branch lengths of the plant's law: both terms within 3 %, each inside its interval
    assert fr[FRICTION_FORCE_NAME] == pytest.approx(F_0, rel=0.03), (fr.values, fr.flags)
    assert fr[FRICTION_NAME] == pytest.approx(A_F, rel=0.03), (fr.values, fr.flags)
    for i, want in ((k, A_F), (c, F_0)):
        assert fr.ci95[i][0] <= want <= fr.ci95[i][1] and fr.ci95[i][0] > 0, (fr.names[i], fr.ci95[i])
    assert not [x for x in fr.flags if x.startswith(FRICTION_FORCE_NAME)], fr.flags
    path = tmp_path / "constant.toml"
    path.write_text(muscle_file_text(dataclasses.replace(spec, path=str(path)),
                                     IsometricFit("tondu-lopez", fr, spec, {"method": "none"}, pd.DataFrame())))
    assert f"{FRICTION_FORCE_NAME} = " in path.read_text()
    m = Muscle.from_muscle_file(path)
    plant = PP.PlantParams.from_muscle_file(path)
    assert m.friction_force == pytest.approx(fr[FRICTION_FORCE_NAME], rel=1e-12)
    assert plant.friction_force == pytest.approx(fr[FRICTION_FORCE_NAME], rel=1e-12)
    assert plant.friction_per_pa == pytest.approx(fr[FRICTION_NAME], rel=1e-12)
    for r in rows[::5]:
        got = float(m.length_for_pressure(r["pressure"], r["load"], r["direction"]).length)
        assert got == pytest.approx(r["length"], abs=0.1e-3), r  # m: the branch's length within 0.1 mm
    # one formula: the file's branches (predict length --branch) are its plant's own slip-limit branches
    for load, p in ((0.9, 0.3e6), (1.2, 0.6e6)):
        want_up, want_down = (float(x[0]) for x in plant_branch_lengths(plant.replace(load_force=load), p))
        for b, want in (("inflate", want_up), ("deflate", want_down)):
            r = run_cli("predict", "length", "--muscle-file", str(path), "--pressure", f"{p}Pa", "--load", f"{load}N",
                        "--branch", b, "--json")
            # both solve the same balance to their root finders' tolerance
            assert r.code == 0 and r.json()["length_m"] == pytest.approx(want, abs=1e-7), (b, r.err)


def test_a_constant_friction_the_data_do_not_show_is_flagged_and_left_out_by_default(tmp_path):
    table = _table(tmp_path, _branch_rows(0.0), "hysteresis")
    spec = read_muscle(MUSCLE)
    fr = fit_isotonic_friction(table, spec, "tondu-lopez", tube=True, constant=True)
    # no constant in the data: F_0 at its bound of 0, or an interval that reaches it, is flagged
    assert [x for x in fr.flags if x.startswith(FRICTION_FORCE_NAME)], (fr[FRICTION_FORCE_NAME], fr.flags)
    plain = fit_isotonic_friction(table, spec, "tondu-lopez", tube=True)
    assert FRICTION_FORCE_NAME not in plain.names and plain[FRICTION_NAME] == pytest.approx(A_F, rel=0.02)


def test_a_muscle_file_with_a_constant_friction_alone_has_branches_and_a_negative_one_is_refused(tmp_path,
                                                                                                 isotonic_points):
    spec = read_muscle(MUSCLE)
    res = fit_isotonic_law(_table(tmp_path, isotonic_points, "isotonic"), spec, "tondu-lopez", tube=True)
    text = _saved(tmp_path, res, spec).read_text()
    path = tmp_path / "f0.toml"
    path.write_text(text.replace("[force_model.parameters]\n", f"[force_model.parameters]\n{FRICTION_FORCE_NAME} = 0.05\n"))
    m = Muscle.from_muscle_file(path)
    assert m.friction_force == 0.05 and m.friction_area == 0.0 and m.has_friction
    up, down, mid = (float(m.length_for_pressure(0.5e6, 1.2, b).length) for b in ("inflate", "deflate", None))
    assert up > mid > down
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace("[force_model.parameters]\n", f"[force_model.parameters]\n{FRICTION_FORCE_NAME} = -0.05\n"))
    r = run_cli("predict", "length", "--muscle-file", str(bad), "--pressure", "0.5MPa", "--load", "1N",
                "--branch", "inflate")
    assert r.code == 2 and "bad.toml" in r.err and FRICTION_FORCE_NAME in r.err and "Traceback" not in r.err, r.err
    assert len(r.err.strip().splitlines()) == 1


def test_a_two_branch_law_on_one_branch_keeps_the_tube_interval(tmp_path, isotonic_points):
    # the spring law's deflate coefficients see no isotonic row (all inflate): they get no interval, flagged, and
    # the parameters the data see keep theirs (the tube's stiffness among them)
    res = fit_isotonic_law(_table(tmp_path, isotonic_points, "isotonic"), read_muscle(MUSCLE), "spring", tube=True)
    se = dict(zip(res.names, res.stderr))
    assert np.isfinite(se[TUBE_NAME]) and se[TUBE_NAME] > 0 and np.isfinite(se["h0_m"])
    assert all(np.isnan(se[f"c{k}_deflate"]) and f"c{k}_deflate_unconstrained" in res.flags for k in range(4))


@pytest.mark.slow  # every model of the comparison, twice each law: ~12 s
def test_the_held_out_comparison_scores_each_law_with_and_without_the_tube(tmp_path, isotonic_points):
    from mckibben.fit.compare import TUBE_SUFFIX, compare_models

    res = compare_models(_table(tmp_path, isotonic_points, "isotonic"), read_muscle(MUSCLE), tube=True)
    cv = {s.name: s.cv_rmse_m for s in res["scores"]}
    # the plant's law with its tube is found on loads it did not see; without the term it cannot follow the points
    # hung past the rest length
    assert cv["tondu-lopez" + TUBE_SUFFIX] < 0.2 * cv["tondu-lopez"], cv
    assert cv["tondu-lopez" + TUBE_SUFFIX] < 0.1e-3  # m: within 0.1 mm held out, on exact data


def _held_and_labels(tmp_path, rows):
    """The law (with the tube) fitted to the branches' mean at each (load, pressure), and each row's set-point label."""
    spec = read_muscle(MUSCLE)
    df = pd.DataFrame(rows)
    mid = df.groupby(["load", "pressure"], as_index=False)["length"].mean()
    held = fit_isotonic_law(_table(tmp_path, mid.to_dict("records"), "isotonic"), spec, "tondu-lopez", tube=True)
    return spec, held, (df["load"].astype(str) + "/" + df["pressure"].astype(str)).to_numpy()


def test_the_friction_on_the_loops_width_finds_the_constant_and_the_area_back_with_the_law_held(tmp_path):
    rows = _branch_rows(F_0, np.linspace(0.1e6, 0.76e6, 12))
    table = _table(tmp_path, rows, "hysteresis")
    spec, held, labels = _held_and_labels(tmp_path, rows)
    fr = fit_isotonic_friction(table, spec, "tondu-lopez", tube=True, held=held, constant=True, width=labels)
    # the law held (its values and intervals the static fit's), F_0 and A_f found back within 10 % (the held law is a
    # fit to the branches' mean, itself a little off the friction-free length: 6.5 % on F_0, 2.6 % on A_f, more than
    # the exact data's intervals, which are only bounded away from zero here), the width residuals one per
    # set-point with both branches, no R2 flag (every target is 0)
    assert np.array_equal(fr.values[:len(held.values)], held.values)
    assert not [x for x in fr.flags if x.startswith("r2_")], fr.flags
    for name, want in ((FRICTION_FORCE_NAME, F_0), (FRICTION_NAME, A_F)):
        i = fr.names.index(name)
        assert fr[name] == pytest.approx(want, rel=0.10), (name, fr.values, fr.flags)
        assert fr.ci95[i][0] > 0, (name, fr.ci95[i])
    assert not [x for x in fr.flags if x.startswith(FRICTION_FORCE_NAME)], fr.flags
    both = {lab for lab in set(labels) if {r["direction"] for r, x in zip(rows, labels) if x == lab} == {"inflate", "deflate"}}
    assert fr.residuals.size == len(both) < len(set(labels)), (fr.residuals.size, len(both))  # one on a stop


def test_the_loops_width_leaves_out_a_branch_point_without_its_partner(tmp_path):
    # a sweep's top visited once (inflating only), where the held law misses (its length read 0.5 mm long): on
    # rig characterize's runs such rows are what trades F_0 for A_f on the branches (docs/rig.md)
    rows = _branch_rows(F_0, np.linspace(0.1e6, 0.76e6, 12))
    spec, held, labels = _held_and_labels(tmp_path, rows)
    top = [dict(r, length=r["length"] + 0.5e-3) for r in _branch_rows(F_0, np.array([0.78e6, 0.8e6]))
           if r["direction"] == "inflate"]
    table = _table(tmp_path, rows + top, "hysteresis")
    labels = np.r_[labels, [f"top{i}" for i in range(len(top))]]
    width = fit_isotonic_friction(table, spec, "tondu-lopez", tube=True, held=held, constant=True, width=labels)
    branch = fit_isotonic_friction(table, spec, "tondu-lopez", tube=True, held=held, constant=True)
    assert width[FRICTION_FORCE_NAME] == pytest.approx(F_0, rel=0.10), width.values
    assert width[FRICTION_NAME] == pytest.approx(A_F, rel=0.10), width.values
    off = (abs(branch[FRICTION_FORCE_NAME] - F_0) / F_0, abs(branch[FRICTION_NAME] - A_F) / A_F)
    assert max(off) > 0.25, (branch.values, off)


def test_the_loops_width_is_refused_without_the_law_held_or_with_labels_that_do_not_fit(tmp_path):
    rows = _branch_rows(F_0)
    table = _table(tmp_path, rows, "hysteresis")
    spec, held, labels = _held_and_labels(tmp_path, rows)
    with pytest.raises(InputError, match="^width: .*held"):
        fit_isotonic_friction(table, spec, "tondu-lopez", tube=True, constant=True, width=labels)
    with pytest.raises(InputError, match=r"^width: \d+ labels; want one set-point label per row"):
        fit_isotonic_friction(table, spec, "tondu-lopez", tube=True, held=held, width=labels[:-1])
    # every row its own label: no set-point has both branches
    with pytest.raises(InputError, match="^width: 0 set-points with both branches"):
        fit_isotonic_friction(table, spec, "tondu-lopez", tube=True, held=held, width=np.arange(len(rows)))


def test_an_area_the_widths_do_not_show_is_flagged(tmp_path):
    # a constant friction alone (A_f = 0): on the loop's width A_f at its bound of 0, or an interval reaching it, flagged
    rows = []
    for f in LOADS:
        for dn, sign in (("inflate", 1.0), ("deflate", -1.0)):
            ell = _lengths(np.full(PRESSURES.size, f + sign * F_0), PRESSURES)
            rows += [{"pressure": p, "load": f, "length": x, "direction": dn} for p, x in zip(PRESSURES, ell)
                     if np.isfinite(x)]
    table = _table(tmp_path, rows, "hysteresis")
    spec, held, labels = _held_and_labels(tmp_path, rows)
    fr = fit_isotonic_friction(table, spec, "tondu-lopez", tube=True, held=held, constant=True, width=labels)
    assert [x for x in fr.flags if x.startswith(FRICTION_NAME)], (fr.values, fr.flags)
    assert fr[FRICTION_FORCE_NAME] == pytest.approx(F_0, rel=0.10), fr.values

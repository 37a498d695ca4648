"""The Hunt–Graber-Tilton–Quinn law: its force solves the published pressure model; published numbers; a fit.

The fit's data are synthetic: one 300 mm muscle drawn from the law with known constants and noise,
tared as a lab would. The published constants are those of :data:`HUNT_QUINN_SETS`.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

from mckibben.data import read_muscle, read_table
from mckibben.datasets.published import HUNT_QUINN_SETS
from mckibben.errors import InputError
from mckibben.fit.isometric import fit_isometric
from mckibben.fit.muscle_file import muscle_force_law, save_muscle_file
from mckibben.models import laws
from mckibben.models.laws.hunt_quinn import HuntQuinn
from mckibben.models.muscle import Muscle
from mckibben.plant import PlantParams, simulate

PUB = HUNT_QUINN_SETS["festo-dmsp10-189"]
TRUE = dict(c0_kPa=254.3, c1_kPa=192.0, c3=-0.461, c4_per_N=-0.331e-3, c5_kPa_per_N=1.23, max_strain=0.16)


def _law(**kw):
    d = TRUE | kw
    return HuntQuinn(d["c0_kPa"], d["c1_kPa"], 2.0265, d["c3"], d["c4_per_N"], d["c5_kPa_per_N"], 0.0,
                     d["max_strain"], 0.30)


def test_the_force_solves_the_published_pressure_model():
    p, eps = np.meshgrid(np.linspace(50e3, 620e3, 12), np.linspace(0.005, PUB.max_strain, 9))
    ell = PUB.rest_length * (1 - eps)
    f = PUB.force(p, ell)
    pull = f > 0
    assert pull.mean() > 0.5 and np.all(PUB.pressure(0.0, ell[~pull]) >= p[~pull])  # slack below its threshold
    # the kernel's bisection runs to the bracket's round-off: P(F(P)) = P to 1e-9 relative
    np.testing.assert_allclose(PUB.pressure(f[pull], ell[pull]), p[pull], rtol=1e-9)
    np.testing.assert_array_equal(laws.evaluate("hunt-quinn", p, ell, PUB.theta()), f)
    assert np.all(np.diff(f, axis=1) >= 0) and np.all(np.diff(f[pull.all(axis=1)], axis=1) > 0)  # rises with P
    assert np.all(np.diff(f, axis=0) <= 0)  # falls with contraction
    assert laws.law_of(PUB) == ("hunt-quinn", pytest.approx(PUB.theta()))
    # beyond the rest length the model has no range: held at its rest-length force
    assert PUB.force(400e3, PUB.rest_length * 1.02) == pytest.approx(PUB.force(400e3, PUB.rest_length))
    # the extension branch needs c6 = 15.6 kPa more for the same force
    ext = HuntQuinn(**{**PUB.__dict__, "extending": True})
    assert ext.pressure(100.0, 0.17) - PUB.pressure(100.0, 0.17) == pytest.approx(15.6e3)


def test_the_published_constants_reproduce_the_published_stroke():
    # The set's muscle: 189 mm at rest, 157.5 mm free at 620 kPa (90 psi), so ε_max = 0.1667. The
    # model must then need ~620 kPa to hold the free muscle (F = 0) at ε_max: it needs 624.4 kPa,
    # 0.7 % more (the constants are published to 3-4 digits; 1 % is that rounding's reach).
    p = float(PUB.pressure(0.0, 0.1575))
    assert p == pytest.approx(620e3, rel=0.01)
    assert PUB.force(p, 0.1575) == pytest.approx(0.0, abs=1e-6)
    # and at 620 kPa it is (just) slack at its free length (the root is -0.92 N); at its rest length the pull is the
    # limit from the contracted side, the pole F = ε_max/(−c4) = 503.6 N (at ε = 0 itself the
    # formula alone would give 508.1 N: the model is discontinuous there above ~615 kPa)
    assert PUB.force(620e3, 0.1575) == 0.0
    assert PUB.force(620e3, 0.189) == pytest.approx(PUB.max_strain / 0.331e-3, rel=1e-9)
    assert PUB.force(620e3, 0.189 * (1 - 1e-9)) == pytest.approx(PUB.force(620e3, 0.189), rel=1e-5)


def test_bad_constants_are_refused():
    with pytest.raises(InputError, match="c4"):
        HuntQuinn(254.3, 192, 2.0265, -0.461, +1e-3, 1.23, 0, 0.16, 0.3)
    with pytest.raises(InputError, match="max strain"):
        HuntQuinn(254.3, 192, 2.0265, -0.461, -1e-4, 1.23, 0, 0.0, 0.3)


@pytest.fixture(scope="module")
def table(tmp_path_factory):
    rng = np.random.default_rng(3)
    law, rows = _law(), []
    for eps in (0.0, 0.04, 0.08, 0.12):
        ell = 0.30 * (1 - eps)
        for trial in (1, 2):
            p = np.linspace(0.0, 0.6e6, 16)
            f = law.force(p, ell) + rng.normal(0, 0.5, p.size) + 4.0  # an unzeroed load cell
            rows += [dict(held_length_mm=ell * 1e3, pressure_kPa=x / 1e3, force_N=y, direction="inflate", trial=trial)
                     for x, y in zip(p, f)]
    folder = tmp_path_factory.mktemp("hq")
    pd.DataFrame(rows).to_csv(folder / "iso.csv", index=False)
    (folder / "m.toml").write_text('id = "m300"\nnominal_length_mm = 300\nouter_diameter_mm = 12\n')
    return folder / "iso.csv", folder / "m.toml"


def test_a_fit_recovers_the_constants(table):
    fit = fit_isometric(read_table(table[0]), read_muscle(table[1]), "hunt-quinn", tare="lowest")
    r = fit.result
    assert r.names == ("c0_kPa", "c1_kPa", "c3", "c4_per_N", "c5_kPa_per_N", "max_strain")
    # 128 points of 0.5 N noise on forces up to ~490 N: every constant within 4 standard errors of
    # the truth, and the stroke within 2 %
    for name, want in TRUE.items():
        assert abs(r[name] - want) < 4 * r.stderr[r.names.index(name)] + 1e-9, name
    assert r["max_strain"] == pytest.approx(0.16, rel=0.02)


def test_a_fitted_file_drives_the_plant_to_the_law(table, tmp_path):
    fit = fit_isometric(read_table(table[0]), read_muscle(table[1]), "hunt-quinn", tare="lowest")
    path = save_muscle_file(tmp_path / "f.toml", read_muscle(table[1]), fit)
    law = muscle_force_law(read_muscle(path))
    plant = PlantParams.from_muscle_file(Muscle.from_muscle_file(path))
    p = np.array([0.2e6, 0.4e6, 0.6e6])
    for ell in (0.30, 0.30 * 0.96):
        r = simulate(plant.replace(supply_pressure=p, load_kind="blocked", leak_conductance=0.0),
                     0.5, inlet=255, initial_pressure=p, initial_length=ell)
        want = law.force(r.pressure[:, -1], ell)[0]
        # the plant runs the same kernel: its steady blocked force within 0.1 % of the static law
        np.testing.assert_allclose(r.force[:, -1], want, rtol=1e-3)


def test_the_c_face_equals_the_kernel(tmp_path):
    """The FMU's C face (laws/hunt_quinn.c), compiled by the system cc, against the Python kernel."""
    cc = shutil.which("cc")
    if cc is None:
        pytest.skip("no C compiler")
    law = laws.LAWS["hunt-quinn"]
    rows = "\n".join(f"#define MK_{k} {v}" for k, v in law.c_rows.items())
    main = """
#include <stdio.h>
int main(void) {
    double th[%d], p, ell;
    for (int r = 0; r < %d; r++) if (scanf("%%lf", &th[r]) != 1) return 2;
    while (scanf("%%lf %%lf", &p, &ell) == 2) printf("%%.17g\\n", %s(p, ell, th));
    return 0;
}
""" % (laws.NTH, laws.NTH, law.c_function)
    src = tmp_path / "face.c"
    src.write_text("#include <math.h>\n" + rows + "\n" + law.c_source() + main)
    exe = tmp_path / "face"
    subprocess.run([cc, "-std=c99", "-O2", "-Wall", "-Werror", str(src), "-o", str(exe), "-lm"], check=True)
    p, eps = np.meshgrid(np.linspace(0.0, 650e3, 27), np.linspace(-0.05, 0.2, 26))
    for m in (PUB, HuntQuinn(**{**PUB.__dict__, "extending": True}), _law()):
        th, ell = m.theta(), m.rest_length * (1 - eps)
        stdin = " ".join(repr(float(x)) for x in th) + "\n" + "\n".join(f"{float(a)!r} {float(b)!r}" for a, b in
                                                                       zip(p.ravel(), ell.ravel()))
        out = subprocess.run([str(exe)], input=stdin, capture_output=True, text=True, check=True).stdout
        c = np.array([float(x) for x in out.split()])
        py = laws.evaluate("hunt-quinn", p.ravel(), ell.ravel(), th)
        assert (py > 0).sum() > 300  # most of the grid pulls
        # the same bisection in both languages: equal to 1e-9 relative (the bar)
        np.testing.assert_allclose(c, py, rtol=1e-9, atol=1e-9)


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "mckibben.cli", *args], capture_output=True, text=True, timeout=300)


@pytest.mark.slow  # three CLI processes (a few seconds each on a loaded machine)
def test_params_lists_and_shows_the_published_set():
    r = _cli("params", "list", "--json")
    assert r.returncode == 0, r.stderr
    rows = {row["name"]: row for row in json.loads(r.stdout)["parameter_sets"]}
    assert rows["festo-dmsp10-189"]["kind"] == "hunt-quinn law"
    r = _cli("params", "show", "festo-dmsp10-189", "--json")
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert d["kind"] == "hunt-quinn" and d["c0_Pa"] == pytest.approx(254.3e3) and d["c4_per_N"] == -0.331e-3
    assert d["c5_Pa_per_N"] == pytest.approx(1230.0) and d["max_strain"] == pytest.approx(31.5 / 189)
    r = _cli("params", "show", "festo-dmsp10")  # a mistyped name: one line, the closest name, exit 2
    assert r.returncode == 2 and "Traceback" not in r.stderr and "festo-dmsp10-189" in r.stderr


@pytest.mark.slow  # three CLI processes, one of them a fit
def test_the_cli_fits_saves_and_predicts_the_library_number(table, tmp_path):
    out = tmp_path / "f.toml"
    r = _cli("fit", str(table[0]), "--muscle", str(table[1]), "--model", "hunt-quinn", "--tare", "lowest",
             "--save", str(out), "--json")
    assert r.returncode == 0, r.stderr
    r = _cli("predict", "force", "--muscle-file", str(out), "--pressure", "0.45MPa", "--length", "280mm", "--json")
    assert r.returncode == 0, r.stderr
    law = muscle_force_law(read_muscle(out))
    assert json.loads(r.stdout)["force_N"] == pytest.approx(float(law.force(0.45e6, 0.28, "inflate")[0]), rel=1e-12)
    r = _cli("predict", "force", "--muscle-file", str(out), "--pressure", "-3bar", "--length", "280mm")
    assert r.returncode == 2 and "Traceback" not in r.stderr and "pressure" in r.stderr  # bad input: one line


def test_the_published_set_is_a_muscle_of_the_library():
    # datasets.law_set_muscle: the set as a muscle whose force, length and pressure are its law's
    from mckibben import models
    from mckibben.datasets import law_set_muscle

    m = law_set_muscle("Festo-DMSP10-189")
    assert (m.name, m.law, m.nominal_length, m.pressure_range) == ("festo-dmsp10-189", "hunt-quinn", 0.189, (0.0, 620e3))
    r = models.force([0.3e6, 0.65e6], 0.18, m)
    np.testing.assert_array_equal(r.load, PUB.force([0.3e6, 0.65e6], 0.18))  # the same kernel, the same bits
    assert [models.flag_names(f) for f in r.flags] == [[], ["pressure_out_of_range"]]
    ell = models.length(0.4e6, 80.0, m)
    assert float(PUB.pressure(80.0, ell.length)) == pytest.approx(0.4e6, rel=1e-9)  # the published P(ε, F)
    with pytest.raises(InputError, match="model: 'chou-hannaford' is not the hunt-quinn law of muscle"):
        models.force(0.3e6, 0.18, m, model="chou-hannaford")
    with pytest.raises(InputError, match="k: muscle 'festo-dmsp10-189' carries its own hunt-quinn parameters"):
        models.force(0.3e6, 0.18, m, k=1.2)
    with pytest.raises(InputError, match="unknown parameter set 'festo-dmsp10-190'"):
        law_set_muscle("festo-dmsp10-190")

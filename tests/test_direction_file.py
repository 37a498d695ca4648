"""A direction-aware fit travels in its muscle file (issue #33, item 1).

``fit --direction-aware --save`` writes the law with its operator (``play``: ``play_threshold_Pa``;
``friction``: ``friction_area_m2``, the key the isotonic friction already uses); the file's branch
forces are the fit's own (``.predict_branch``), through ``predict force|length|pressure --branch``
and the muscle (:class:`~mckibben.models.muscle.Muscle`); the plant takes both forms. Real parts: the bundled synthetic isometric table (its truth has a friction
loop), the real ``mckibben`` command in a subprocess.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tomllib

import numpy as np
import pytest

from mckibben.data.muscle_file import read_muscle
from mckibben.datasets.isometric import BUNDLED_ISOMETRIC
from mckibben.errors import InputError
from mckibben.fit import fit_table
from mckibben.fit.muscle_file import muscle_force_law
from mckibben.models import static
from mckibben.models.muscle import Muscle
from mckibben.plant.params import PlantParams

COMMERCIAL = BUNDLED_ISOMETRIC / "commercial10"
LAW = "relative-strain"  # fits the bundled table without a flag, in a fraction of a second
PRESSURES = np.linspace(0.0, 0.6e6, 13)  # [Pa] inside the fitted 0..622 kPa
LENGTH = 0.28  # [m] inside the fitted 245..300 mm


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    """structure -> (the fit, the muscle file it saved), by the library's one save path (fit_table)."""
    folder = tmp_path_factory.mktemp("direction_file")
    out = {}
    for structure in ("play", "friction"):
        path = folder / f"{structure}.toml"
        res = fit_table(COMMERCIAL / "isometric.csv", LAW, COMMERCIAL / "muscle.toml", save=str(path),
                        direction_aware=structure)
        assert res.summary["saved"] == str(path)
        out[structure] = (res.fits[0], path)
    plain = folder / "plain.toml"
    fit_table(COMMERCIAL / "isometric.csv", LAW, COMMERCIAL / "muscle.toml", save=str(plain))
    out["plain"] = (None, plain)
    return out


def _doc(path) -> dict:
    return tomllib.loads(path.read_text(encoding="utf-8"))["force_model"]


def test_the_file_holds_the_law_and_its_operator(saved):
    fit, path = saved["play"]
    fm = _doc(path)
    r = fit.result
    assert fm["direction_aware"] == "play"
    assert fm["parameters"]["play_threshold_Pa"] == r["play_threshold_Pa"]
    assert fm["stderr"]["play_threshold_Pa"] == r.stderr[r.names.index("play_threshold_Pa")]
    lo, hi = fm["ci95_play_threshold_Pa"]
    assert lo < r["play_threshold_Pa"] < hi
    assert "friction_area_m2" not in fm["parameters"]
    law_names = [n for n in r.names if n != "play_threshold_Pa"]
    assert [n for n in fm["parameters"] if n != "play_threshold_Pa"] == law_names

    fit, path = saved["friction"]
    fm = _doc(path)
    assert fm["direction_aware"] == "friction"
    assert fm["parameters"]["friction_area_m2"] == fit.result["friction_area_m2"]
    # far along a branch the friction form does not depend on r: the file leaves it (and flags of it) out
    assert "play_threshold_Pa" not in fm["parameters"] and "play_threshold_Pa" not in fm["stderr"]
    assert not any(f.startswith("play_threshold_Pa") for f in fm["flags"])
    # the synthetic truth has a friction loop of a few % of the blocked force: a friction area is found
    assert fm["ci95_friction_area_m2"][0] > 0


@pytest.mark.parametrize("structure", ["play", "friction"])
def test_file_branch_forces_are_the_fits(saved, structure):
    fit, path = saved[structure]
    law = muscle_force_law(read_muscle(path))
    assert law.has_operator
    muscle = Muscle.from_muscle_file(path)
    assert muscle.has_operator
    offset = law.parameters["offset_N"]  # the load cell's zero: the fit's force has it, the muscle's not
    for branch in ("inflate", "deflate"):
        want = fit.predict_branch(PRESSURES, LENGTH, branch)[0]
        got, flags = law.force(PRESSURES, LENGTH, branch=branch)
        # the same kernel on the same values: equal to round-off
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)
        assert not np.any(flags)
        np.testing.assert_allclose(muscle.force(PRESSURES, LENGTH, branch) + offset, want, rtol=0, atol=1e-9)
        r = static.force(PRESSURES, LENGTH, muscle, branch=branch)
        np.testing.assert_allclose(r.load + offset, want, rtol=0, atol=1e-9)
    # a loop: deflating pulls more than inflating, strictly once the muscle pulls at 280 mm (the law is
    # flat below ~60 kPa there: a play shifts a flat law's pressure for nothing)
    up = law.force(PRESSURES, LENGTH, branch="inflate")[0]
    down = law.force(PRESSURES, LENGTH, branch="deflate")[0]
    pulls = PRESSURES >= 0.1e6
    assert np.all(down >= up) and np.all(down[pulls] > up[pulls])
    # without a branch: the law alone, between the branches
    mid = law.force(PRESSURES, LENGTH)[0]
    assert np.all((up <= mid) & (mid <= down)) and np.all((up[pulls] < mid[pulls]) & (mid[pulls] < down[pulls]))


@pytest.mark.parametrize("structure", ["play", "friction"])
def test_length_and_pressure_on_a_branch_solve_the_fits_branch(saved, structure):
    fit, path = saved[structure]
    muscle = Muscle.from_muscle_file(path)
    offset = muscle.values["offset_N"]
    load = 100.0  # [N]
    p = np.array([0.2e6, 0.4e6])
    lengths = {}
    for branch in ("inflate", "deflate"):
        r = static.length(p, load, muscle, branch=branch)
        # the fit's branch pulls the load (less its zero) at the length found; root-finder tolerance
        np.testing.assert_allclose(fit.predict_branch(p, r.length, branch)[0] - offset, load, rtol=1e-6)
        lengths[branch] = r.length
        q = static.pressure(r.length, load, muscle, p_max=0.62e6, branch=branch)
        np.testing.assert_allclose(q.pressure, p, rtol=1e-6)  # the inverse of the same branch
        # the compensation's feed-forward from the file is the fit's own (.pressure, its inverse on a branch)
        np.testing.assert_allclose(q.pressure, fit.pressure(load + offset, r.length, branch), rtol=1e-6)
    # inflating, the muscle pulls less: it hangs longer under the same load
    assert np.all(lengths["inflate"] > lengths["deflate"])


def test_the_plant_takes_both_forms(saved):
    fit, path = saved["friction"]
    plant = PlantParams.from_muscle_file(path)
    assert plant.friction_per_pa == fit.result["friction_area_m2"] and plant.play_threshold == 0.0
    fit, path = saved["play"]  # the play in the compiled plant: tests/test_plant_play.py runs it
    plant = PlantParams.from_muscle_file(path)
    assert plant.play_threshold == fit.result["play_threshold_Pa"] and plant.friction_per_pa == 0.0


def test_old_files_read_as_before(saved):
    _, path = saved["plain"]
    fm = _doc(path)
    assert "play_threshold_Pa" not in fm["parameters"] and "direction_aware" not in fm
    muscle = Muscle.from_muscle_file(path)
    assert muscle.play_threshold == 0.0 and not muscle.has_operator
    with pytest.raises(InputError, match="no fitted friction or play"):
        static.force(PRESSURES, LENGTH, muscle, branch="inflate")
    with pytest.raises(InputError, match="no fitted friction or play"):
        muscle_force_law(read_muscle(path)).force(PRESSURES, LENGTH, branch="deflate")


def test_a_file_with_a_play_and_a_friction_is_refused(saved, tmp_path):
    _, path = saved["play"]
    text = path.read_text().replace("[force_model.parameters]\n", "[force_model.parameters]\nfriction_area_m2 = 1e-6\n")
    both = tmp_path / "both.toml"
    both.write_text(text)
    for read in (Muscle.from_muscle_file, lambda p: muscle_force_law(read_muscle(p))):
        with pytest.raises(InputError, match="one hysteresis operator") as exc:
            read(both)
        assert str(both) in str(exc.value)


def test_a_two_branch_law_is_not_saved_with_an_operator(tmp_path):
    out = tmp_path / "spring.toml"
    with pytest.raises(InputError, match="save: the spring law has an inflate and a deflate branch"):
        fit_table(COMMERCIAL / "isometric.csv", "spring", COMMERCIAL / "muscle.toml", save=str(out),
                  direction_aware="play")
    assert not out.exists()


def _mckibben(*args, cwd):
    code = "import sys; from mckibben.cli import main; sys.exit(main(sys.argv[1:]))"
    return subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, cwd=cwd, timeout=300)


@pytest.mark.slow  # five real CLI runs, ~2-8 s
def test_cli_round_trip(tmp_path):
    run = _mckibben("fit", str(COMMERCIAL / "isometric.csv"), "--model", LAW, "--muscle-file",
                    str(COMMERCIAL / "muscle.toml"), "--direction-aware", "--save", "play.toml", "--json", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    out = json.loads(run.stdout)
    path = tmp_path / "play.toml"
    assert out["saved"] == "play.toml" and out["direction_aware"]["structure"] == "play"
    fm = _doc(path)
    assert fm["parameters"]["play_threshold_Pa"] == out["parameters"]["play_threshold_Pa"]
    law = muscle_force_law(read_muscle(path))
    forces = {}
    for branch in ("inflate", "deflate"):
        run = _mckibben("predict", "force", "--muscle-file", "play.toml", "--branch", branch, "--pressure",
                        "0:0.6MPa:13", "--length", "280mm", "--json", cwd=tmp_path)
        assert run.returncode == 0, run.stderr
        got = json.loads(run.stdout)
        assert got["branch"] == branch
        np.testing.assert_allclose(got["force_N"], law.force(PRESSURES, LENGTH, branch=branch)[0], rtol=0, atol=1e-9)
        forces[branch] = np.asarray(got["force_N"])
    assert np.all(forces["deflate"][PRESSURES >= 0.1e6] > forces["inflate"][PRESSURES >= 0.1e6])
    run = _mckibben("predict", "length", "--muscle-file", "play.toml", "--branch", "inflate", "--pressure",
                    "0.2,0.4MPa", "--load", "100N", "--json", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    ell = np.asarray(json.loads(run.stdout)["length_m"])
    np.testing.assert_allclose(law.force([0.2e6, 0.4e6], ell, branch="inflate")[0] - law.parameters["offset_N"],
                               100.0, rtol=1e-6)
    run = _mckibben("predict", "pressure", "--muscle-file", "play.toml", "--branch", "deflate", "--length",
                    "280mm", "--load", "100N", "--json", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    p = json.loads(run.stdout)["pressure_Pa"]
    np.testing.assert_allclose(law.force(p, LENGTH, branch="deflate")[0] - law.parameters["offset_N"], 100.0,
                               rtol=1e-6)


@pytest.mark.slow  # six real CLI runs, ~4-8 s
def test_cli_bad_input(saved, tmp_path):
    plain, play = str(saved["plain"][1]), str(saved["play"][1])
    cases = [
        (["predict", "force", "--muscle-file", plain, "--branch", "inflate", "--pressure", "0.3MPa"],
         "no fitted friction or play"),
        (["predict", "pressure", "--muscle-file", plain, "--branch", "deflate", "--length", "280mm", "--load", "10N"],
         "no fitted friction or play"),
        (["predict", "force", "--muscle-file", play, "--branch", "sideways", "--pressure", "0.3MPa"], "sideways"),
        (["predict", "force", "--model", "chou-hannaford", "--branch", "inflate", "--pressure", "0.3MPa"], "--branch"),
        (["fit", str(COMMERCIAL / "isometric.csv"), "--model", "spring", "--muscle-file",
          str(COMMERCIAL / "muscle.toml"), "--direction-aware", "--save", "spring.toml"], "save"),
        (["fit", str(COMMERCIAL / "isometric.csv"), "--model", LAW, "--muscle-file", str(COMMERCIAL / "muscle.toml"),
          "--direction-aware", "--structure", "sideways"], "--structure: 'sideways' is not one of play, friction"),
        (["compare", str(COMMERCIAL / "isometric.csv"), "--muscle-file", str(COMMERCIAL / "muscle.toml"),
          "--structure", "friction"], "--structure: 'friction' needs --direction-aware"),
    ]
    for args, words in cases:
        run = _mckibben(*args, cwd=tmp_path)
        assert run.returncode == 2, (args, run.stdout, run.stderr)
        lines = [ln for ln in run.stderr.strip().splitlines() if ln.strip()]
        assert len(lines) == 1 and words in lines[0] and "Traceback" not in run.stderr, (args, run.stderr)
    assert not (tmp_path / "spring.toml").exists()


@pytest.mark.slow  # two real CLI runs, ~3 s
def test_cli_saves_the_friction_form_the_plant_runs(tmp_path):
    """``--structure friction``: the form that also reaches the plant, saved from the command line."""
    run = _mckibben("fit", str(COMMERCIAL / "isometric.csv"), "--model", LAW, "--muscle-file",
                    str(COMMERCIAL / "muscle.toml"), "--direction-aware", "--structure", "friction", "--save",
                    "friction.toml", "--json", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    out = json.loads(run.stdout)
    assert out["direction_aware"]["structure"] == "friction"
    fm = _doc(tmp_path / "friction.toml")
    assert fm["parameters"]["friction_area_m2"] == out["parameters"]["friction_area_m2"] > 0
    assert "play_threshold_Pa" not in fm["parameters"]
    plant = PlantParams.from_muscle_file(tmp_path / "friction.toml")
    assert plant.friction_per_pa == pytest.approx(out["parameters"]["friction_area_m2"], rel=1e-12)

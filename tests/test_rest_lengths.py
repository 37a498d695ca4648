"""Each muscle's rest length as a fitted nuisance parameter, with its interval (issue 33, item 4).

A family generated with known errors in its recorded rest lengths: the fit that takes the records
as true moves the end length to absorb them; the fit with the rest lengths fitted recovers each
muscle's error and the end length within their intervals.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from mckibben.data import read_muscle, read_table
from mckibben.errors import InputError
from mckibben.fit.isometric import compare_isometric, fit_isometric
from mckibben.models.laws.virtual_work import VirtualWork

TRUE_SHIFT = {"m120": 1.5e-3, "m200": 0.5e-3, "m320": 1.0e-3}  # true rest length − recorded [m]
RECORDED = {"m120": 0.120, "m200": 0.200, "m320": 0.320}
END_ZONE = 0.02


@pytest.fixture(scope="module")
def family(tmp_path_factory):
    rng = np.random.default_rng(337)
    rows = []
    for m, rec in RECORDED.items():
        true = rec + TRUE_SHIFT[m]
        law = VirtualWork(530.0, -2400.0, 400.0, 130.0, 0.025, 720.0, END_ZONE, true)
        for eps in (0.0, 0.04, 0.08, 0.12):
            ell = rec * (1 - eps)  # the rig holds lengths measured from the recorded rest length
            for trial in (1, 2):
                p = np.linspace(0.0, 0.6e6, 13)
                f = law.force(p, ell) + rng.normal(0, 1.0, p.size)
                rows += [dict(held_length_mm=ell * 1e3, pressure_kPa=a / 1e3, force_N=b, direction="inflate",
                              trial=trial, muscle=m, rest_length_mm=rec * 1e3) for a, b in zip(p, f)]
    folder = tmp_path_factory.mktemp("rest")
    pd.DataFrame(rows).to_csv(folder / "fam.csv", index=False)
    (folder / "t.toml").write_text('id = "t"\nnominal_length_mm = 200\nouter_diameter_mm = 10\n')
    return read_table(folder / "fam.csv"), read_muscle(folder / "t.toml")


def test_fitted_rest_lengths_recover_each_muscles_error_and_the_end_length(family):
    table, muscle = family
    fitted = fit_isometric(table, muscle, "virtual-work", rest_lengths="fitted").result
    ci = dict(zip(fitted.names, fitted.ci95))
    for m, shift in TRUE_SHIFT.items():
        lo, hi = ci[f"rest_shift_{m}_m"]
        assert lo < shift < hi and hi - lo < 1.5e-3, (m, lo, hi)  # a millimetre resolved on 1 N of noise
    assert ci["end_zone_m"][0] < END_ZONE < ci["end_zone_m"][1]
    assert fitted.flags == (), fitted.flags
    assert fitted.to_dict()["ci95"]["rest_shift_m120_m"] == pytest.approx(list(ci["rest_shift_m120_m"]))
    nominal = fit_isometric(table, muscle, "virtual-work").result
    # taking the records as true costs fit and moves the end length to absorb the errors
    assert nominal.residual_rms > 1.5 * fitted.residual_rms
    lo, hi = dict(zip(nominal.names, nominal.ci95))["end_zone_m"]
    assert not lo < END_ZONE < hi, (lo, hi)
    # a muscle the fit saw is predicted at its fitted rest length, an unseen one at the mean shift
    p, ell = np.array([0.4e6]), np.array([0.19])
    at = {r: fitted.func(fitted.values, pressure=p, length=ell, rest_length=np.array([r]))[0] for r in (0.2, 0.21)}
    k = len(nominal.names)
    base = fitted.func(fitted.values[:k], pressure=p, length=ell, rest_length=np.array([0.2 + fitted["rest_shift_m200_m"]]))
    assert at[0.2] == pytest.approx(base[0], rel=1e-12)
    mean = np.mean(fitted.values[k:])
    assert at[0.21] == pytest.approx(fitted.func(fitted.values[:k], pressure=p, length=ell,
                                                 rest_length=np.array([0.21 + mean]))[0], rel=1e-12)


def test_rest_lengths_refused_where_they_mean_nothing(family, tmp_path):
    table, muscle = family
    with pytest.raises(InputError, match="rest_lengths"):
        fit_isometric(table, muscle, "virtual-work", rest_lengths="free")
    d = table.data
    one = d[d["muscle"] == "m200"].drop(columns=["muscle", "rest_length"])
    one = one.assign(held_length_mm=one["held_length"] * 1e3, pressure_kPa=one["pressure"] / 1e3, force_N=one["force"])
    one[["held_length_mm", "pressure_kPa", "force_N", "direction", "trial"]].to_csv(tmp_path / "one.csv", index=False)
    with pytest.raises(InputError, match="family table"):
        fit_isometric(read_table(tmp_path / "one.csv"), muscle, "virtual-work", rest_lengths="fitted")
    with pytest.raises(InputError, match="family table"):
        compare_isometric(read_table(tmp_path / "one.csv"), muscle, rest_lengths="fitted")


@pytest.mark.slow  # four runs of the command as separate processes: ~9 s
def test_the_commands_fit_and_compare_with_fitted_rest_lengths(family, tmp_path):
    table, _ = family
    data = str(table.path)
    toml = str(Path(data).parent / "t.toml")

    def run(*args):
        return subprocess.run([sys.executable, "-m", "mckibben.cli", *args], capture_output=True, text=True, timeout=600)

    r = run("fit", data, "--model", "virtual-work", "--muscle-file", toml, "--rest-lengths", "fitted", "--json")
    assert r.returncode == 0, r.stderr
    fit = json.loads(r.stdout)["fits"][0]
    lo, hi = fit["ci95"]["rest_shift_m120_m"]
    assert lo < TRUE_SHIFT["m120"] < hi  # reported with its interval
    r = run("compare", data, "--muscle-file", toml, "--cv", "leave-one-muscle-out", "--rest-lengths", "fitted", "--json")
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["best"] == "virtual-work"
    for bad, says in ((["--rest-lengths", "free"], "free"), (["--rest-lengths", "fitted", "--save", str(tmp_path / "x.toml")], "save")):
        r = run("fit", data, "--model", "virtual-work", "--muscle-file", toml, *bad)
        assert r.returncode == 2 and says in r.stderr and "Traceback" not in r.stderr, r.stderr
        assert len(r.stderr.strip().splitlines()) == 1, r.stderr
        assert not (tmp_path / "x.toml").exists()  # nothing half-written

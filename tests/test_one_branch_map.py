"""A published force map as it is printed: held length, pressure, force, one value per point.

Such a map has no direction and no trial. It is read as an isometric table of one branch (every row
``inflate``, trial 1) with a note, while a lab's table whose branch column has another name
(``phase``) is still refused with the hint to map it. On one branch the spring law fits its
inflate coefficients alone: the deflate ones, which no row constrains, are neither fitted nor
flagged, and its saved law runs that branch both ways.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

from mckibben.data import read_muscle, read_table
from mckibben.errors import InputError
from mckibben.fit.direction import fit_direction_aware
from mckibben.fit.isometric import compare_isometric, fit_isometric, force_law
from mckibben.models.laws.spring import SPRING_DEFLATE_NAMES, SPRING_NAMES, from_values
from test_scale_invariance import BUNDLED


@pytest.fixture(scope="module")
def printed(tmp_path_factory):
    """The bundled campaign's inflating rows of trial 1, as a printed map: three columns."""
    d = pd.read_csv(BUNDLED / "isometric.csv")
    d = d[(d["direction"] == "inflate") & (d["trial"] == 1)]
    folder = tmp_path_factory.mktemp("map")
    d[["held_length_mm", "pressure_kPa", "force_N"]].to_csv(folder / "map.csv", index=False)
    (folder / "muscle.toml").write_text((BUNDLED / "muscle.toml").read_text())
    return folder, d


def test_a_three_column_map_is_an_isometric_table_of_one_branch(printed):
    folder, d = printed
    table = read_table(folder / "map.csv")
    assert table.kind == "isometric" and len(table.data) == len(d)
    assert set(table.data["direction"]) == {"inflate"} and set(table.data["trial"]) == {1}
    assert any("no direction column: every row read as inflate" in n for n in table.notes)
    # the same rows with the two columns written out are the same table, without the note
    d5 = d[["held_length_mm", "pressure_kPa", "force_N"]].assign(direction="inflate", trial=1)
    d5.to_csv(folder / "map5.csv", index=False)
    full = read_table(folder / "map5.csv")
    assert full.data[list(table.data.columns)].equals(table.data)
    assert not any("no direction column" in n for n in full.notes)


def test_spring_on_one_branch_fits_the_inflate_branch_alone_and_runs_it_both_ways(printed, tmp_path):
    folder, _ = printed
    table, muscle = read_table(folder / "map.csv"), read_muscle(folder / "muscle.toml")
    fit = fit_isometric(table, muscle, "spring").result
    assert fit.names == SPRING_NAMES[:7]
    assert not any("deflate" in f for f in fit.flags), fit.flags
    p, ell = np.array([0.2e6, 0.5e6]), np.array([0.29, 0.27])
    up = fit.func(fit.values, pressure=p, length=ell, direction="inflate")
    assert fit.func(fit.values, pressure=p, length=ell, direction="deflate") == pytest.approx(up, rel=1e-12)
    # saved and read back: the file holds the inflate coefficients only, and its law is the fit's
    saved = tmp_path / "saved.toml"
    subprocess.run([sys.executable, "-m", "mckibben.cli", "fit", str(folder / "map.csv"), "--model", "spring",
                    "--muscle-file", str(folder / "muscle.toml"), "--save", str(saved)], check=True,
                   capture_output=True)
    spec = read_muscle(saved)
    assert tuple(spec.force_model["parameters"]) == SPRING_NAMES[:7]
    law = force_law("spring", spec, list(spec.force_model["parameters"].values()))
    assert law(p, ell) == pytest.approx(up, rel=1e-6)
    assert law(p, ell, "deflate") == pytest.approx(up, rel=1e-6)
    values = dict(spec.force_model["parameters"])
    assert from_values(values, spec, "deflate").coefficients == from_values(values, spec, "inflate").coefficients
    # a table with both branches keeps both sets of coefficients, as before
    both = fit_isometric(read_table(BUNDLED / "isometric.csv"), muscle, "spring").result
    assert both.names == SPRING_NAMES and set(SPRING_DEFLATE_NAMES) <= set(both.names)


def test_the_map_is_compared_and_the_direction_aware_form_refused_by_name(printed):
    folder, _ = printed
    table, muscle = read_table(folder / "map.csv"), read_muscle(folder / "muscle.toml")
    c = compare_isometric(table, muscle, "leave-one-length-out").to_dict()
    spring = next(s for s in c["models"] if s["model"] == "spring")
    assert not any("deflate" in f for f in spring["flags"])
    with pytest.raises(InputError, match="needs both inflate and deflate rows"):
        fit_direction_aware(table, muscle, "spring")


def test_a_lab_branch_column_under_another_name_is_still_refused(tmp_path):
    path = tmp_path / "lab.csv"
    path.write_text("held_length_mm,pressure_kPa,force_N,phase\n300,0,1,inflate\n280,100,5,deflate\n")
    with pytest.raises(InputError, match=r"missing column direction \(without it every row would be read as "
                                         r"inflate\); the unknown column phase .*columns. phase=direction"):
        read_table(path)

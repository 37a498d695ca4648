"""A published force map as it is printed: held length, pressure, force, one value per point.

Such a map has no direction and no trial. It is read as an isometric table of one branch (every row
``inflate``, trial 1) with a note, while a lab's table whose branch column has another name
(``phase``) is still refused with the hint to map it. Every law fits it; the spring law's deflate
coefficients, which no row constrains, are flagged.
"""

from __future__ import annotations

import pandas as pd
import pytest

from mckibben.data import read_muscle, read_table
from mckibben.errors import InputError
from mckibben.fit.direction import fit_direction_aware
from mckibben.fit.isometric import compare_isometric
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


def test_the_map_is_compared_and_the_direction_aware_form_refused_by_name(printed):
    folder, _ = printed
    table, muscle = read_table(folder / "map.csv"), read_muscle(folder / "muscle.toml")
    c = compare_isometric(table, muscle, "leave-one-length-out").to_dict()
    assert {s["model"] for s in c["models"] if s["cv_rmse_N"] is not None} >= {"virtual-work", "spring", "relative-strain"}
    spring = next(s for s in c["models"] if s["model"] == "spring")
    assert {f"c{k}_deflate_unconstrained" for k in range(4)} <= set(spring["flags"])  # no row sees that branch
    with pytest.raises(InputError, match="needs both inflate and deflate rows"):
        fit_direction_aware(table, muscle, "spring")


def test_a_lab_branch_column_under_another_name_is_still_refused(tmp_path):
    path = tmp_path / "lab.csv"
    path.write_text("held_length_mm,pressure_kPa,force_N,phase\n300,0,1,inflate\n280,100,5,deflate\n")
    with pytest.raises(InputError, match=r"missing column direction \(without it every row would be read as "
                                         r"inflate\); the unknown column phase .*columns. phase=direction"):
        read_table(path)

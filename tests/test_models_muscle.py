"""The Muscle object: geometry + force law + ranges + end stops, from and to a muscle file, taken by plant and tool."""

from __future__ import annotations

import numpy as np
import pytest

from mckibben.data import read_muscle, read_table
from mckibben.datasets.isometric import BUNDLED_ISOMETRIC
from mckibben.errors import InputError
from mckibben.fit.isometric import fit_isometric
from mckibben.fit.muscle_file import save_muscle_file
from mckibben.models import laws
from mckibben.models.muscle import Muscle
from mckibben.plant import PlantParams
from mckibben.tool.muscles import file_muscle

FOLDER = BUNDLED_ISOMETRIC / "commercial10"
ISO, MUSCLE = FOLDER / "isometric.csv", FOLDER / "muscle.toml"


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("muscles")
    table, spec = read_table(ISO), read_muscle(MUSCLE)
    return {m: save_muscle_file(folder / f"{m}.toml", spec, fit_isometric(table, spec, m))
            for m in ("spring", "tondu-lopez", "surface")}


@pytest.mark.parametrize("model", ["spring", "tondu-lopez"])
def test_a_muscle_round_trips_through_its_file(files, tmp_path, model):
    m = Muscle.from_muscle_file(files[model])
    assert m.law == model and m.end_stops == (m.strand_length / np.sqrt(3.0), m.strand_length)
    again = Muscle.from_muscle_file(m.save(tmp_path / "again.toml"))
    # the same numbers written with repr(): the same law, bit for bit
    np.testing.assert_array_equal(again.theta, m.theta)
    assert again.values == m.values and again.pressure_range == m.pressure_range and again.flags == m.flags
    p, ell = np.linspace(0, 5e5, 7), np.full(7, m.nominal_length)
    np.testing.assert_array_equal(again.force(p, ell), laws.evaluate(model, p, ell, m.theta))


def test_plant_and_tool_take_a_muscle(files):
    m = Muscle.from_muscle_file(files["spring"])
    a, b = PlantParams.from_muscle_file(m), PlantParams.from_muscle_file(files["spring"])
    np.testing.assert_array_equal(a.pack(), b.pack())  # the same rig from the object as from the file
    t = file_muscle(m)
    assert t is m and t.strand_length == a.strand_length  # the tool reads the muscle, not a plant's field


def test_a_muscle_refuses_bad_input(files):
    with pytest.raises(InputError, match="rest_length"):
        Muscle.from_muscle_file(files["spring"], rest_length=-0.1)
    with pytest.raises(InputError, match="has no physical law"):
        Muscle.from_muscle_file(files["surface"])
    with pytest.raises(InputError, match="direction"):
        Muscle.from_muscle_file(files["spring"], direction="up")
    with pytest.raises(InputError, match="no \\[force_model\\]"):
        Muscle.from_muscle_file(MUSCLE)

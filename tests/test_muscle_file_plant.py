"""A lab's own muscle through the plant: a fitted muscle file drives the simulator with its own law.

The muscle file is written by the fit (``mckibben fit … --save``) from the bundled SYNTHETIC
commercial-size isometric campaign; the plant built from it (:meth:`PlantParams.from_muscle_file`)
must come to rest where the saved static law says, under a hanging load and blocked.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq

from mckibben.data import read_muscle, read_table
from mckibben.datasets.isometric import BUNDLED_ISOMETRIC
from mckibben.errors import InputError
from mckibben.fit.isometric import fit_isometric
from mckibben.fit.muscle_file import muscle_force_law, save_muscle_file
from mckibben.plant import PlantParams, simulate
from mckibben.plant import params as PP

FOLDER = BUNDLED_ISOMETRIC / "commercial10"
ISO, MUSCLE = FOLDER / "isometric.csv", FOLDER / "muscle.toml"


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    """Muscle files of the fitted laws, by model name (each fit once per module)."""
    folder = tmp_path_factory.mktemp("muscles")
    table, spec = read_table(ISO), read_muscle(MUSCLE)
    return {m: save_muscle_file(folder / f"{m}.toml", spec, fit_isometric(table, spec, m))
            for m in ("spring", "chou-hannaford", "tondu-lopez", "surface")}


def _static_length(law, pressure, load, lo, hi):
    """Length where the saved law (less the load cell's zero) balances the load; NaN if none in [lo, hi]."""
    off = law.parameters.get("offset_N", 0.0)
    g = lambda ell, p, w: float(law.force(p, ell)[0]) - off - w  # noqa: E731
    return np.array([brentq(g, lo, hi, args=(p, w), xtol=1e-9) if g(lo, p, w) < 0 < g(hi, p, w) else np.nan
                     for p, w in zip(pressure, load)])


@pytest.mark.parametrize("model", ["spring", "chou-hannaford", "tondu-lopez"])
def test_plant_of_a_fitted_muscle_file_rests_where_its_saved_law_says(saved, model):
    law = muscle_force_law(read_muscle(saved[model]))
    plant = PlantParams.from_muscle_file(saved[model])
    assert isinstance(plant.force_model, type(law.static_model()))
    # hanging loads of 60..250 N at 0.2..0.6 MPa, kept where the rest length lies inside the fitted
    # lengths (245..300 mm): the law is only known there
    p, w = (a.ravel() for a in np.meshgrid(np.arange(2, 7) * 0.1e6, [60.0, 100.0, 150.0, 200.0, 250.0]))
    lo, hi = law.valid_range["length"]
    want = _static_length(law, p, w, 0.8 * lo, hi)
    ok = np.isfinite(want) & (want > lo) & (want < hi)
    assert ok.sum() >= 12
    p, w, want = p[ok], w[ok], want[ok]
    # the rig's own isotonic experiment: supply at the pressure, inlet open, no leak, from 3 mm to
    # alternate sides of the answer
    run = plant.replace(supply_pressure=p, load_force=w, leak_conductance=0.0)
    r = simulate(run, 2.0, inlet=255, initial_pressure=p, initial_length=want + np.where(np.arange(p.size) % 2, 3e-3,
                                                                                           -3e-3))
    assert np.all(r.flags & 1 == 0)
    # the bar: within 1 % of the static law (same law through the registry; what is left is
    # the 2 s of settling, friction is off in a file's plant)
    np.testing.assert_allclose(r.length[:, -1], want, rtol=0.01)
    # blocked at the rest length: the muscle pulls the saved law's force at the chamber's pressure
    blocked = simulate(plant.replace(supply_pressure=p, load_kind="blocked", leak_conductance=0.0), 0.5, inlet=255,
                       initial_pressure=p, initial_length=plant.nominal_length)
    f_law = law.force(blocked.pressure[:, -1], plant.nominal_length)[0] - law.parameters.get("offset_N", 0.0)
    np.testing.assert_allclose(blocked.force[:, -1], f_law, rtol=0.01)


def test_a_muscle_file_plant_is_sized_from_the_muscle(saved):
    spec = read_muscle(saved["chou-hannaford"])
    plant = PlantParams.from_muscle_file(spec)
    base = PlantParams()
    # the fitted braid: strand length L0/cos θ0, the ideal braid (k1 = 1, k2 = 0) of eq. (2)
    theta0 = muscle_force_law(spec).parameters["theta0_rad"]
    assert plant.strand_length == pytest.approx(spec.nominal_length / np.cos(theta0), rel=1e-12)
    assert (plant.k1, plant.k2) == (1.0, 0.0)
    # the file gives no tube: the lumen is the documented fraction of the outer diameter
    assert plant.inner_diameter == pytest.approx(PP.FILE_LUMEN_FRACTION * spec.outer_diameter)
    # valves scaled with the rest chamber volume: conductance over volume as the calibrated rig's
    vol = lambda pl: pl.dead_volume + np.pi / 4 * pl.inner_diameter**2 * pl.nominal_length  # noqa: E731
    assert plant.valve_conductance / vol(plant) == pytest.approx(base.valve_conductance / vol(base), rel=1e-12)
    # the supply is the top of the fitted pressures (622 kPa in the campaign)
    assert plant.supply_pressure == pytest.approx(muscle_force_law(spec).valid_range["pressure"][1])
    # overrides win, and are validated like any plant's
    assert PlantParams.from_muscle_file(spec, load_force=50.0, supply_pressure=0.5e6).load_force == 50.0
    with pytest.raises(InputError, match="moving_mass"):
        PlantParams.from_muscle_file(spec, moving_mass=-1.0)


def test_the_fill_of_a_muscle_file_plant_keeps_the_calibrated_time_constant(saved):
    from mckibben.plant import open_loop_step

    # blocked (the chamber keeps its volume): the valves are scaled with the rest chamber volume, so
    # the open-loop fill is about as fast as the calibrated rig's. 25 % allowed for what is not
    # scaled: the 4 mm tubing exchanges less heat than the 1 mm one (closer to adiabatic, faster)
    # and the supply is the fitted 622 kPa, not 0.8 MPa
    _, ours = open_loop_step(PlantParams.from_muscle_file(saved["spring"], load_kind="blocked"), duration=0.5)
    _, ref = open_loop_step(PlantParams().replace(load_kind="blocked"), duration=0.5)
    assert ours["time_constant_s"] == pytest.approx(ref["time_constant_s"], rel=0.25)


def test_a_surface_law_and_a_file_without_a_law_are_refused_naming_the_file(saved, tmp_path):
    with pytest.raises(InputError, match=r"surface\.toml: .*surface force law has no physical law the plant can run"):
        PlantParams.from_muscle_file(saved["surface"])
    with pytest.raises(InputError, match=r"muscle\.toml: no \[force_model\] table"):
        PlantParams.from_muscle_file(MUSCLE)
    with pytest.raises(InputError, match="nope.toml"):
        PlantParams.from_muscle_file(tmp_path / "nope.toml")
    with pytest.raises(InputError, match="direction"):
        PlantParams.from_muscle_file(saved["spring"], direction="up")


def test_the_miniature_plant_still_validates_its_tondu_lopez_radius():
    with pytest.raises(InputError, match="r0"):
        PlantParams(muscle_name="", r0=0.0).pack()

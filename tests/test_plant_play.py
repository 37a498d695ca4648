"""The play on the pressure in the compiled plant (issue #33, item 1).

A direction-aware law's ``"play"`` form (the law fed through a play operator on the pressure,
:mod:`mckibben.models.hysteresis.direction`) saved in a muscle file runs in the plant: the kernel's
scalar play equals the library's operator on a pressure history; the plant's play state is the
library's operator sampled at every step; a muscle held (and one under a hanging load) driven slowly
up and down pulls (hangs) on each branch what the file's ``predict --branch`` gives; a threshold of
0 is the plant without a play; bad files are refused in one line. Real parts: a real joint fit
(``fit_table(..., direction_aware="play", save=...)``) of a table generated with a known play, the
compiled plant, the real ``mckibben`` command in a subprocess.
"""

from __future__ import annotations

import shutil
import subprocess
import sys

import numpy as np
import pytest

from mckibben.data import read_muscle, read_table
from mckibben.datasets.isometric import BUNDLED_ISOMETRIC
from mckibben.errors import InputError
from mckibben.export import export_fmu
from mckibben.fit import fit_table
from mckibben.fit.isometric import fit_isometric
from mckibben.models.hysteresis.direction import play_pressure
from mckibben.models.muscle import Muscle
from mckibben.plant import packing as PK
from mckibben.plant import physics as ph
from mckibben.plant import simulate, static_branch_lengths
from mckibben.plant.params import PlantParams
from mckibben.plant.simulator import initial_states

from test_direction_aware import LAW, _campaign

COMMERCIAL = BUNDLED_ISOMETRIC / "commercial10"
R_TRUE = 30e3  # [Pa] play threshold of the synthetic truth


@pytest.fixture(scope="module")
def play_file(tmp_path_factory):
    """(the fitted play threshold, the muscle file the joint fit saved) for a campaign with a known play."""
    folder = tmp_path_factory.mktemp("plant_play")
    muscle = read_muscle(COMMERCIAL / "muscle.toml")
    theta = fit_isometric(read_table(COMMERCIAL / "isometric.csv"), muscle, LAW).result.values
    table = _campaign(folder, muscle, theta, "play", [R_TRUE], trials=(1, 2))
    path = folder / "play.toml"
    res = fit_table(str(table), LAW, str(COMMERCIAL / "muscle.toml"), save=str(path), direction_aware="play")
    r = res.fits[0].result["play_threshold_Pa"]
    assert r == pytest.approx(R_TRUE, rel=0.2)  # the fit found the play it was generated with
    return r, path


def test_kernel_play_is_the_library_operator():
    """The kernel's scalar play (physics.play_step) equals play_pressure on a pressure history, bit for bit."""
    rng = np.random.default_rng(1)
    p = np.cumsum(rng.normal(0, 20e3, 400)) + 300e3  # reversals of every size, some within the play
    for r, z0 in ((25e3, 0.0), (1e3, 310e3), (80e3, 290e3)):
        want, last = play_pressure(p, r, state=z0)
        got, z = np.empty_like(p), z0
        for k, pk in enumerate(p):
            z = ph.play_step(z, pk, r)
            got[k] = z
        np.testing.assert_array_equal(got, want)
        assert z == last
    # threshold 0: the pressure itself, whatever the state
    assert all(ph.play_step(z, 123.25e3, 0.0) == 123.25e3 for z in (0.0, 1e6, 123.25e3, -5.0))


def _steps(plant, inlet_x, bleed_x, n):
    """Run the plant's RK4 step n times per valve phase on one lane; the gauge pressure and the play row after each."""
    prm, law, th, _ = plant.prepare()
    s0 = initial_states(prm, law, th, 0.0)
    bk = np.zeros(ph.BLOCK)
    ph.load_block(0, 1, prm, th, s0, bk)
    dt = 1e-4
    pg, zz = [], []
    for xin, xbl in zip(inlet_x, bleed_x):
        bk[ph.Y_XIN], bk[ph.Y_XBL] = xin, xbl
        for _ in range(n):
            ph.rk4_step(1, bk, law, dt)
            pg.append(bk[ph.Z_P] - ph.P_ATM)
            zz.append(bk[ph.Z_PLAY])
    return s0[0, ph.S_PLAY], np.array(pg), np.array(zz)


def test_plant_play_state_is_the_operator_sampled_at_each_step(play_file):
    r, path = play_file
    plant = PlantParams.from_muscle_file(path, load_kind="blocked")
    assert plant.play_threshold == r
    # fill, vent part way, fill again, vent: reversals wider and narrower than the play
    z0, pg, zz = _steps(plant, [0.3, 0.0, 0.3, 0.0, 0.0], [0.0, 0.3, 0.0, 0.05, 0.3], 400)
    assert z0 == 0.0 and pg.max() > 10 * r
    want, _ = play_pressure(pg, r, state=z0)
    np.testing.assert_array_equal(zz, want)
    # threshold 0: the play row is the gauge pressure at every step
    _, pg0, zz0 = _steps(plant.replace(play_threshold=0.0), [0.3, 0.0], [0.0, 0.3], 400)
    np.testing.assert_array_equal(zz0, pg0)


def _up_and_down(plant, seconds=1.6, **kwargs):
    """A slow fill through a barely open inlet, then a slow vent through a barely open bleed."""
    n = int(round(seconds / 1e-3))
    half = n // 2
    inlet = np.r_[np.full(half, 121), np.zeros(n - half)].astype(int)  # (the valves lift off at 113 counts)
    bleed = np.r_[np.zeros(half), np.full(n - half, 113)].astype(int)
    return simulate(plant, seconds, inlet=inlet, bleed=bleed, **kwargs), half


def _branches(p, half, r):
    """Masks of the samples far along the inflate branch (the play's output at P − r, while filling) and the
    deflate branch (at P + r, while venting): the library's operator over the recorded pressures."""
    z, _ = play_pressure(p, r, state=p[0])
    k = np.arange(p.size)
    rising = (k < half) & (np.abs(z - (p - r)) < 1e-9 * r)
    falling = (k >= half) & (np.abs(z - (p + r)) < 1e-9 * r)
    return rising, falling


def test_held_muscle_pulls_the_files_branch_forces(play_file):
    """Blocked at a length: the plant's force on each branch is the muscle file's branch force (predict --branch)."""
    r, path = play_file
    length = 0.28  # [m] inside the fitted 255..300 mm
    res, half = _up_and_down(PlantParams.from_muscle_file(path, load_kind="blocked"), initial_length=length)
    p, f = res.pressure[0], res.force[0]
    assert np.all(res.length[0] == length)
    rising, falling = _branches(p, half, r)
    assert rising.sum() > 100 and falling.sum() > 100
    muscle = Muscle.from_muscle_file(path)
    for mask, branch in ((rising, "inflate"), (falling, "deflate")):
        want = muscle.force(p[mask], length, branch=branch)
        assert np.sum(want > 10.0) > 100  # (below ~0.15 MPa the law at 280 mm pulls nothing)
        # the same law kernel at the same play output (a muscle never pushes): equal to rounding (1e-9 relative)
        np.testing.assert_allclose(f[mask], np.maximum(want, 0.0), rtol=1e-9, atol=1e-9)
    # the loop is there: at a pressure both branches pass, deflating pulls more by about 2r·∂F/∂P
    pm = 0.5 * (p[rising].min() + p[rising].max())
    gap = np.interp(pm, p[falling][::-1], f[falling][::-1]) - np.interp(pm, p[rising], f[rising])
    slope = (muscle.force(pm + 1e3, length) - muscle.force(pm - 1e3, length)) / 2e3
    assert gap == pytest.approx(2 * r * float(slope), rel=0.05)


def test_hanging_muscle_rests_where_the_library_puts_it(play_file):
    """Under a hanging load, filled and vented in bursts with the valves shut between them (a tight rig: no leak):
    once the muscle has come to rest, its length is the file's static length at the play's output that the
    library's operator gives over the same pressure history (the held muscle's test checks the branches)."""
    r, path = play_file
    load = 150.0  # [N]
    plant = PlantParams.from_muscle_file(path, load_force=load, leak_conductance=0.0)
    burst, hold = 12, 1500  # [periods] a burst of an open valve, then both shut until the muscle is at rest
    inlet, bleed = [], []
    for valve in ("inlet",) * 4 + ("bleed",) * 4:
        inlet += [255 if valve == "inlet" else 0] * burst + [0] * hold
        bleed += [255 if valve == "bleed" else 0] * burst + [0] * hold
    res = simulate(plant, len(inlet) * 1e-3, inlet=np.array(inlet), bleed=np.array(bleed))
    p, ell = res.pressure[0], res.length[0]
    z, _ = play_pressure(p, r, state=p[0])  # the library's operator over the recorded pressures
    rest = (np.arange(p.size) % (burst + hold)) >= burst + hold - 100  # each hold's last 0.1 s
    assert np.ptp(p[rest]) > 5 * r  # the holds span the pressure range, up and down
    muscle = Muscle.from_muscle_file(path)
    want = muscle.length_for_pressure(z[rest], load).length
    lo, hi = plant.prepare()[0][0, [PK.Col.l_min, PK.Col.l_max]]
    free = (want > lo + 1e-3) & (want < hi - 1e-3)  # hanging off the braid, not on an end stop
    assert free.sum() >= 400
    # at rest (the motion's lag c·v/k below 1 µm): equal to 0.02 mm
    np.testing.assert_allclose(ell[rest][free], want[free], atol=2e-5)
    # the play counts here: the muscle settling after a burst moves the pressure by more than r (the chamber's
    # volume changes with the length), and the law at the pressure itself would put the muscle mm away
    plain = muscle.length_for_pressure(p[rest], load).length
    assert np.median(np.abs(ell[rest][free] - plain[free])) > 5e-4


def test_static_branch_lengths_are_the_files_branch_lengths(play_file):
    """plant.static_branch_lengths of a play file's plant: predict length --branch inflate|deflate's (the library's)."""
    r, path = play_file
    load, p = 100.0, np.array([0.25e6, 0.4e6, 0.55e6])
    plant = PlantParams.from_muscle_file(path, load_force=np.full(p.size, load))  # one rig per pressure
    up, down = static_branch_lengths(plant, p)
    muscle = Muscle.from_muscle_file(path)
    for got, branch in ((up, "inflate"), (down, "deflate")):
        np.testing.assert_allclose(got, muscle.length_for_pressure(p, load, branch=branch).length, atol=1e-6)
    assert np.all(up - down > 1e-3)  # the loop: inflating, the muscle hangs longer


def test_threshold_zero_is_the_plant_without_a_play(play_file):
    _, path = play_file
    plant = PlantParams.from_muscle_file(path, load_kind="blocked").replace(play_threshold=0.0)
    res, _ = _up_and_down(plant, seconds=0.4, initial_length=0.28)
    # the law sees the pressure itself: the file's middle law (no branch) at the recorded pressure
    np.testing.assert_allclose(res.force[0], np.maximum(Muscle.from_muscle_file(path).force(res.pressure[0], 0.28), 0),
                               rtol=1e-12, atol=1e-12)
    with pytest.raises(InputError, match="play_threshold") as exc:
        PlantParams(play_threshold=-1.0).prepare()
    assert "\n" not in str(exc.value)


def _mckibben(*args, cwd):
    code = "import sys; from mckibben.cli import main; sys.exit(main(sys.argv[1:]))"
    return subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, cwd=cwd, timeout=300)


@pytest.mark.slow  # three real CLI runs, ~6 s
def test_cli_runs_a_play_file_and_refuses_a_negative_play(play_file, tmp_path):
    _, path = play_file
    run = _mckibben("simulate", "open-loop", "--muscle-file", str(path), "--load", "100N", "--json", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    run = _mckibben("control", "step", "--muscle-file", str(path), "--duration", "0.3s", "--json", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    bad = tmp_path / "bad.toml"
    text = path.read_text(encoding="utf-8")
    assert "play_threshold_Pa = " in text
    bad.write_text("\n".join(("play_threshold_Pa = -25000.0" if ln.startswith("play_threshold_Pa = ") else ln)
                             for ln in text.splitlines()) + "\n", encoding="utf-8")
    with pytest.raises(InputError, match="force_model.parameters.play_threshold_Pa") as exc:
        PlantParams.from_muscle_file(bad)
    assert "\n" not in str(exc.value)
    run = _mckibben("simulate", "open-loop", "--muscle-file", str(bad), "--load", "100N", cwd=tmp_path)
    lines = [ln for ln in run.stderr.splitlines() if ln.strip()]
    assert run.returncode == 2 and len(lines) == 1 and "play_threshold_Pa" in lines[0], run.stderr
    assert "Traceback" not in run.stderr


def test_the_fmus_c_plant_runs_the_play_as_the_python_plant(play_file, tmp_path):
    """The FMU's C plant (export/c/mk_plant.c) with a play file: filled and vented through FMPy, equal to
    simulate() to round-off, and its force on the vent is the deflate branch's, not the law at the pressure."""
    fmpy = pytest.importorskip("fmpy", reason="the FMU export needs FMPy (pip install 'mckibben[fmu]')")
    if shutil.which("gcc") is None:
        pytest.skip("the FMU export needs the system C compiler (gcc)")
    r, path = play_file
    fmu = export_fmu(muscle_file=path, load=100.0, out=tmp_path / "play.fmu")
    half, n = 0.25, 500  # [s], [periods]
    inp = np.array([(0.0, 121, 0), (half, 121, 0), (half, 0, 113), (2 * half, 0, 113)],
                   dtype=[("time", float), ("inlet", np.int32), ("bleed", np.int32)])
    res = fmpy.simulate_fmu(str(fmu), stop_time=2 * half, step_size=1e-3, output_interval=1e-3, input=inp,
                            output=["pressure", "length", "force"])
    plant = PlantParams.from_muscle_file(path, load_force=100.0)
    sim = simulate(plant, 2 * half, inlet=np.r_[np.full(n // 2, 121), np.zeros(n // 2)].astype(int),
                   bleed=np.r_[np.zeros(n // 2), np.full(n // 2, 113)].astype(int))
    np.testing.assert_allclose(res["time"][:n], sim.t, atol=1e-12)
    # round-off (FMA or not), as tests/test_export_fmu.py holds the port without a play
    assert np.max(np.abs(res["pressure"][:n] - sim.pressure[0])) < 1e-3
    assert np.max(np.abs(res["length"][:n] / sim.length[0] - 1.0)) < 1e-9
    assert np.max(np.abs(res["force"][:n] - sim.force[0])) < 1e-6
    # and the play is in it: while venting, the force is the law's at P + r, not at P
    p, ell = sim.pressure[0], sim.length[0]
    _, falling = _branches(p, n // 2, r)
    muscle = Muscle.from_muscle_file(path)
    k = falling & (p > 200e3)
    assert k.sum() > 20
    np.testing.assert_allclose(res["force"][:n][k], np.maximum(muscle.force(p[k], ell[k], branch="deflate"), 0),
                               rtol=1e-9)
    assert np.all(res["force"][:n][k] > muscle.force(p[k], ell[k]) + 1.0)


def test_a_play_muscle_in_mujoco_is_the_plant(play_file):
    """MuJoCo's bank runs the plant's kernel (export/mujoco.py): a play file's muscle lifting and lowering a
    hanging mass follows simulate() with the same play, and not the plant without one."""
    mujoco = pytest.importorskip("mujoco")
    from mckibben.export.mujoco import MuscleBank, hanging_mass_mjcf, load_model, muscle_plant

    _, path = play_file
    load = 100.0  # [N]
    plant = muscle_plant(path).replace(load_force=load)
    model = load_model(hanging_mass_mjcf(plant, load, 1e-4))
    data = mujoco.MjData(model)
    n = 400
    inlet = np.where(np.arange(n) < 200, 121, 0)
    bleed = np.where(np.arange(n) < 200, 0, 113)
    bank = MuscleBank(model, ["muscle"], plant)
    length, pressure = np.empty(n), np.empty(n)
    for k in range(n):
        mujoco.mj_forward(model, data)
        length[k], pressure[k] = bank.length(data)[0], bank.pressure[0]
        for s in range(bank.steps_per_period):
            bank.step(data, inlet=int(inlet[k]) if s == 0 else None, bleed=int(bleed[k]) if s == 0 else None)
    kw = dict(inlet=inlet, bleed=bleed, initial_length=plant.nominal_length)
    sim = simulate(plant, n * 1e-3, **kw)
    plain = simulate(plant.replace(play_threshold=0.0), n * 1e-3, **kw)
    # as tests/test_mujoco.py holds the bank to the plant (the integrators of the mass differ, not the physics;
    # measured 0.07 mm and 0.7 kPa here, where the play moves the muscle by 6 mm)
    err = np.max(np.abs(length - sim.length[0]))
    assert err < 0.2e-3 and np.max(np.abs(pressure - sim.pressure[0])) < 3e3
    assert np.max(np.abs(length - plain.length[0])) > 10 * err  # the play moves the muscle: the bank runs it

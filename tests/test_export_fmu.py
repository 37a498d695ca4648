"""The plant as an FMU (issue 25): its C port held equal to the Numba plant, checked by a real importer.

The Python/Numba plant is the source of truth (docs/fmu.md, DESIGN.md); the FMU's C99 port
(``mckibben/export/c/mk_plant.c``) must give the same open-loop step through FMPy, an FMI importer
that loads the binary built at export: pressure within 1 kPa and length within 0.1 % of
:func:`mckibben.plant.simulate` (measured: to round-off), for the published set and a fitted
muscle file, FMI 3.0 and 2.0; ``fmpy.validation.validate_fmu`` finds no problem; the FMU's final
pressure lies within 1 % of ``mckibben simulate open-loop --valve 117 --json``'s.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import zipfile

import numpy as np
import pytest

fmpy = pytest.importorskip("fmpy", reason="the FMU tests need FMPy (pip install 'mckibben[fmu]')")
if shutil.which("gcc") is None:
    pytest.skip("the FMU export needs the system C compiler (gcc)", allow_module_level=True)

from fmpy.validation import validate_fmu  # noqa: E402

from mckibben.control.core import MODE_PID, core_spec, save_design  # noqa: E402
from mckibben.control.metrics import step_metrics  # noqa: E402
from mckibben.control.experiment_setup import controller_params, muscle_file_plant, rest_pull  # noqa: E402
from mckibben.experiments.pressure import step_response  # noqa: E402
from mckibben.data import read_muscle, read_table  # noqa: E402
from mckibben.datasets import get_muscle  # noqa: E402
from mckibben.datasets.isometric import BUNDLED_ISOMETRIC  # noqa: E402
from mckibben.errors import InputError  # noqa: E402
from mckibben.export import export_fmu  # noqa: E402
from mckibben.export.fmu import CFLAGS, FILE_LOAD_FRACTION, FIRMWARE_SOURCES  # noqa: E402
from mckibben.fit.isometric import fit_isometric  # noqa: E402
from mckibben.fit.muscle_file import save_muscle_file  # noqa: E402
from mckibben.models.laws.relative_strain import RelativeStrain  # noqa: E402
from mckibben.models.laws.virtual_work import VirtualWork  # noqa: E402
from mckibben.plant import PlantParams, simulate  # noqa: E402
from mckibben.plant.params import FILE_LUMEN_FRACTION  # noqa: E402

STEP, DURATION = 117, 0.5


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    """A muscle file with a fitted spring law (the bundled SYNTHETIC commercial10 campaign)."""
    folder = BUNDLED_ISOMETRIC / "commercial10"
    spec = read_muscle(folder / "muscle.toml")
    path = tmp_path_factory.mktemp("muscle") / "spring.toml"
    return save_muscle_file(path, spec, fit_isometric(read_table(folder / "isometric.csv"), spec, "spring"))


def _run(fmu, duration=DURATION, inlet=STEP, start_values=None):
    """The FMU through FMPy: the inlet held at a count from t = 0, sampled every 1 ms."""
    inp = np.array([(0.0, inlet, 0), (duration, inlet, 0)],
                   dtype=[("time", float), ("inlet", np.int32), ("bleed", np.int32)])
    return fmpy.simulate_fmu(str(fmu), stop_time=duration, step_size=1e-3, output_interval=1e-3, input=inp,
                             output=["pressure", "length", "force"], start_values=start_values or {})


def _final(res, n=int(round(DURATION / 1e-3))):
    """The open-loop step's "final pressure" as ``simulate open-loop`` defines it: the mean of the last
    5 % of the samples at the start of each period (t = 0 .. 0.499 s). [Pa]"""
    return float(np.mean(res["pressure"][:n][-max(1, n // 20):]))


def _assert_equivalent(res, sim):
    """The FMU's samples at t = k·1 ms against simulate()'s, which samples at the start of each period."""
    n = sim.pressure.shape[1]
    np.testing.assert_allclose(res["time"][:n], sim.t, atol=1e-12)
    dp = np.max(np.abs(res["pressure"][:n] - sim.pressure[0]))
    dl = np.max(np.abs(res["length"][:n] / sim.length[0] - 1.0))
    df = np.max(np.abs(res["force"][:n] - sim.force[0]))
    assert dp < 1e3 and dl < 1e-3  # the bar: 1 kPa, 0.1 %
    assert dp < 1e-3 and dl < 1e-9 and df < 1e-6  # what the port gives: round-off (FMA or not)
    return dp, dl


@pytest.mark.parametrize("fmi", [3, 2])
def test_published_fmu_validates_and_equals_the_numba_plant(tmp_path, fmi):
    fmu = export_fmu("mpam97", out=tmp_path / "m.fmu", fmi=fmi)
    assert validate_fmu(str(fmu)) == []
    md = fmpy.read_model_description(str(fmu))
    assert md.fmiVersion == f"{fmi}.0" and md.coSimulation is not None
    names = {v.name: v for v in md.modelVariables}
    assert {"inlet", "bleed", "pressure", "length", "force", "supply_pressure", "load_force"} <= set(names)
    assert float(names["supply_pressure"].start) == 0.8e6 and float(names["load_force"].start) == 0.6
    with zipfile.ZipFile(fmu) as z:  # the C99 sources and the FMI headers (from FMPy) travel with it
        files = set(z.namelist())
    assert {"sources/mk_plant.c", "sources/mk_plant.h", "sources/mk_model.h", f"sources/fmi{fmi}_plant.c",
            f"sources/fmi{fmi}Functions.h"} <= files
    sim = simulate(PlantParams(), DURATION, inlet=STEP, n=1)
    _assert_equivalent(_run(fmu), sim)


_PLANTS = {  # every law of the registry with its C face, the other chamber model, the other loads
    "chou-hannaford": lambda: PlantParams.for_muscle(get_muscle("mpam143"), force_model="chou-hannaford"),
    "wall-corrected": lambda: PlantParams.for_muscle(get_muscle("mpam143"), force_model="wall-corrected"),
    "braid-map": lambda: PlantParams.for_muscle(get_muscle("mpam143"), force_model="empirical"),
    "relative-strain": lambda: PlantParams(force_model=RelativeStrain(4.0, 1.0, 10.0, 5.0, 0.005, 0.097)),
    "virtual-work": lambda: PlantParams(force_model=VirtualWork(5.0, -4.0, 1.0, 0.3, 0.02, 2.0, 0.004, 0.097)),
    "polytropic": lambda: PlantParams(thermal="polytropic"),
    "blocked": lambda: PlantParams().replace(load_kind="blocked"),
    "spring load": lambda: PlantParams().replace(load_kind="spring", spring_stiffness=100.0, load_force=0.3),
}


@pytest.mark.parametrize("case", list(_PLANTS))
def test_every_law_and_load_of_the_c_port_equals_the_numba_plant(tmp_path, case):
    plant = _PLANTS[case]()
    fmu = export_fmu(plant=plant, out=tmp_path / "p.fmu")
    _assert_equivalent(_run(fmu, 0.3, 150), simulate(plant, 0.3, inlet=150, n=1))


def test_a_law_the_integrator_refuses_is_refused_at_export(tmp_path):
    with pytest.raises(InputError, match="negative stiffness"):
        export_fmu(plant=PlantParams(force_model="wall-corrected"), out=tmp_path / "w.fmu")
    assert list(tmp_path.iterdir()) == []


def test_fmu_parameters_change_the_run_as_they_change_the_plant(tmp_path):
    fmu = export_fmu("mpam97", out=tmp_path / "m.fmu")
    res = _run(fmu, 0.2, 150, {"supply_pressure": 0.6e6, "load_force": 1.5})
    _assert_equivalent(res, simulate(PlantParams(supply_pressure=0.6e6, load_force=1.5), 0.2, inlet=150, n=1))


def test_fmu_final_pressure_is_the_cli_open_loop_one(tmp_path, cli):
    r = cli("export", "fmu", "--muscle", "mpam97", "--out", str(tmp_path / "m.fmu"))
    assert r.code == 0, r.err
    want = cli("simulate", "open-loop", "--valve", "117", "--json").json()["final_pressure_Pa"]
    res = _run(tmp_path / "m.fmu")
    assert _final(res) == pytest.approx(want, rel=0.01)
    assert res["pressure"][-1] == pytest.approx(want, rel=0.01)  # and the FMU's value at 0.5 s itself


@pytest.mark.parametrize("fmi", [3, 2])
def test_fitted_muscle_file_fmu(tmp_path, cli, fitted, fmi):
    out = tmp_path / "fitted.fmu"
    r = cli("export", "fmu", "--muscle-file", str(fitted), "--out", str(out), "--fmi", str(fmi))
    assert r.code == 0, r.err
    assert validate_fmu(str(out)) == []
    # the default load is scaled to the muscle at hand: a quarter of what it pulls at rest (0.6 N, the
    # miniature muscle's load, is nothing to this one)
    names = {v.name: v for v in fmpy.read_model_description(str(out)).modelVariables}
    load = float(names["load_force"].start)
    assert load == round(FILE_LOAD_FRACTION * rest_pull(muscle_file_plant(fitted, 0.0)), 1) and load > 50
    res = _run(out)
    _assert_equivalent(res, simulate(muscle_file_plant(fitted, load), DURATION, inlet=STEP, n=1))
    want = cli("simulate", "open-loop", "--valve", "117", "--muscle-file", str(fitted), "--load", f"{load!r}N",
               "--json").json()
    # the same metric on both (the fitted plant still rises at 0.5 s: its value there is 1.1 % above the
    # mean of the last 25 ms that the command reports)
    assert _final(res) == pytest.approx(want["final_pressure_Pa"], rel=0.01)


def _closed_loop(fmu, step_time, target, duration):
    """The closed-loop FMU through FMPy: the reference steps from 0 to ``target`` at ``step_time``;
    the rows at t = k·1 ms (FMPy adds one at the input's event). [Pa]"""
    inp = np.array([(0.0, 0.0), (step_time, 0.0), (step_time, target), (duration, target)],
                   dtype=[("time", float), ("reference", float)])
    res = fmpy.simulate_fmu(str(fmu), stop_time=duration, step_size=1e-3, output_interval=1e-3, input=inp,
                            output=["pressure", "length", "inlet", "bleed", "faults"])
    t = np.arange(int(round(duration / 1e-3))) * 1e-3
    return res[np.searchsorted(np.round(res["time"], 9), np.round(t, 9), side="right") - 1]


@pytest.mark.parametrize("controller, law, beta, fmi", [("smc", "paper", 150, 3), ("smc", "paper", 150, 2),
                                                        ("pid", "model", None, 3)])
def test_closed_loop_fmu_is_control_step_with_the_firmware_core(tmp_path, controller, law, beta, fmi):
    """The issue's bar: ``control step --controller smc --law paper --beta 150 --target 0.55MPa``'s time
    constant within 5 % (measured: the same to round-off, the firmware's C core being the Python
    mirror's bit for bit)."""
    want = step_response(controller, target=0.55e6, law=law, beta=beta)
    df = want.to_pandas()
    fmu = export_fmu("mpam97", out=tmp_path / "c.fmu", fmi=fmi, controller=controller, law=law, beta=beta)
    assert validate_fmu(str(fmu)) == []
    with zipfile.ZipFile(fmu) as z:
        assert "sources/controller.c" in z.namelist()
    got = _closed_loop(fmu, want.step_time, 0.55e6, float(df["time_s"].iloc[-1]) + 1e-3)
    assert np.max(np.abs(got["pressure"] - df["pressure_Pa"].to_numpy())) < 1.0
    np.testing.assert_array_equal(got["inlet"][1:], df["inlet_pwm"].to_numpy()[:-1])  # the command of the period before
    tau = step_metrics(df["time_s"].to_numpy(), got["pressure"], df["reference_Pa"].to_numpy(),
                       t_step=want.step_time)["time_constant_s"]
    assert tau == pytest.approx(want.metrics["time_constant_s"], rel=0.05)
    assert tau == pytest.approx(want.metrics["time_constant_s"], rel=1e-9)


def test_closed_loop_fmu_tracks_a_sine_as_simulate_does(tmp_path):
    """The issue's third case: a sine reference (0.4 ± 0.2 MPa at 2 Hz, 0.5 s), our sliding mode."""
    params = controller_params("smc")
    t = np.arange(500) * 1e-3
    ref = 0.4e6 + 0.2e6 * np.sin(2 * np.pi * 2.0 * t)
    want = simulate(PlantParams(), 0.5, controller=core_spec(params), reference=ref)
    fmu = export_fmu("mpam97", out=tmp_path / "s.fmu", controller=params)
    inp = np.array(list(zip(np.append(t, 0.5), np.append(ref, ref[-1]))), dtype=[("time", float), ("reference", float)])
    got = fmpy.simulate_fmu(str(fmu), stop_time=0.5, step_size=1e-3, output_interval=1e-3, input=inp,
                            output=["pressure", "length"])
    assert np.max(np.abs(got["pressure"][:500] - want.pressure[0])) < 1.0  # the bar: 1 kPa
    assert np.max(np.abs(got["length"][:500] / want.length[0] - 1.0)) < 1e-9  # the bar: 0.1 %


def test_closed_loop_from_the_cli_and_a_design_file(tmp_path, cli):
    design = tmp_path / "smc.json"
    save_design(controller_params("smc", law="paper", beta=150), design)
    r = cli("export", "fmu", "--out", str(tmp_path / "d.fmu"), "--controller", "smc", "--design", str(design))
    assert r.code == 0, r.err
    assert "input reference" in r.out
    pid = controller_params("pid")
    assert pid.mode == MODE_PID
    save_design(pid, tmp_path / "pid.json")
    r = cli("export", "fmu", "--out", str(tmp_path / "e.fmu"), "--controller", "smc", "--design",
            str(tmp_path / "pid.json"))
    assert r.code == 2 and "--design" in r.err and not (tmp_path / "e.fmu").exists()


@pytest.mark.parametrize("args, named", [
    (("--controller", "lqr"), "controller"),
    (("--beta", "150"), "beta"),
    (("--muscle", "mpam999"), "mpam999"),
    (("--fmi", "4"), "fmi"),
    (("--muscle", "mpam97", "--muscle-file", "x.toml"), "muscle_file"),
    (("--muscle-file", "/nonexistent/m.toml"), "--muscle-file"),
    (("--load", "-1N"), "--load"),
    (("--supply", "2MPa"), "supply"),
])
def test_bad_input_is_one_line_exit_2_and_writes_nothing(tmp_path, cli, args, named):
    out = tmp_path / "m.fmu"
    r = cli("export", "fmu", "--out", str(out), *args)
    assert r.code == 2
    assert r.err.count("\n") == 1 and named in r.err and "Traceback" not in r.err
    assert not out.exists() and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("controller", [None, "smc"])
def test_the_fmu_rebuilds_from_its_own_sources_without_a_warning(tmp_path, controller):
    """The sources inside are complete (another platform rebuilds from them) and warning-free."""
    fmu = export_fmu("mpam97", out=tmp_path / "m.fmu", fmi=3, controller=controller)
    with zipfile.ZipFile(fmu) as z:
        z.extractall(tmp_path / "x")
    src = tmp_path / "x" / "sources"
    sources = [str(src / f) for f in sorted(os.listdir(src)) if f.endswith(".c")]
    done = subprocess.run(["gcc", *CFLAGS, "-Werror", "-pedantic", f"-I{src}", "-o", str(tmp_path / "re.so"),
                           *sources, "-lm"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    nm = subprocess.run(["nm", "-D", "--defined-only", str(tmp_path / "re.so")], capture_output=True, text=True)
    if nm.returncode == 0:  # only the FMI functions are exported
        names = {ln.split()[-1] for ln in nm.stdout.splitlines() if " T " in ln}
        assert "fmi3DoStep" in names and all(n.startswith("fmi3") for n in names)


def test_bad_out_and_controller_are_refused(tmp_path):
    with pytest.raises(InputError, match="out"):
        export_fmu("mpam97", out=tmp_path / "m.zip")
    with pytest.raises(InputError, match="controller"):
        export_fmu("mpam97", out=tmp_path / "m.fmu", controller="lqr")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.timeout(600)
def test_a_built_package_carries_the_firmware_core(tmp_path):
    """pip install . (a wheel) takes the firmware's C core along (setup.py copies firmware/core into
    mckibben/export/firmware_core), so an installed mckibben closes the FMU's loop with the C that
    runs on the Mega, byte for byte, without a source checkout."""
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    r = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(tmp_path), str(root)],
                       capture_output=True, text=True, timeout=580, cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-2000:]
    (wheel,) = tmp_path.glob("mckibben-*.whl")
    with zipfile.ZipFile(wheel) as z:
        core = root / "firmware" / "core"
        for name in sorted(f.name for f in core.glob("*.[ch]")):  # every file of the core, each law's header too
            assert z.read(f"mckibben/export/firmware_core/{name}") == (core / name).read_bytes()
    # and the FMU compiles every law the core's registry includes
    assert {f for f in FIRMWARE_SOURCES if f.startswith("law_")} == {f.name for f in core.glob("law_*.h")}


def test_a_wall_corrected_file_whose_wall_sits_at_its_bound_exports(tmp_path, cli):
    """A 26 mm muscle's wall-corrected fit often puts the wall at its lower bound (a Festo 10 mm
    sleeve's real table gives 3.4e-19 m): od − 2·wall is then od itself. Such a wall is not a
    measure of the tube; the plant takes the default lumen, and the file exports."""
    f = tmp_path / "w.toml"
    f.write_text('id = "m26"\nnominal_length_mm = 281\nouter_diameter_mm = 26\n\n[force_model]\nmodel = '
                 '"wall-corrected"\nsource = "iso.csv"\ntare = "none"\nflags = ["wall_m_at_lower_bound"]\n'
                 'rmse_N = 30.0\nr2 = 0.9\nvalid_pressure_Pa = [8180.0, 624300.0]\nvalid_length_m = [0.2442, 0.281]\n'
                 '\n[force_model.parameters]\ntheta0_rad = 0.5\nd0_m = 0.0535\nwall_m = 3.4254048518600805e-19\n'
                 'offset_N = -40.0\n')
    plant = PlantParams.from_muscle_file(f)
    assert plant.inner_diameter == pytest.approx(FILE_LUMEN_FRACTION * 0.026, rel=1e-12)
    r = cli("export", "fmu", "--muscle-file", str(f), "--out", str(tmp_path / "w.fmu"))
    assert r.code == 0, r.err
    assert (tmp_path / "w.fmu").is_file()

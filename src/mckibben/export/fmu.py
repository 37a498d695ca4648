"""The plant as an FMU (Functional Mock-up Unit, FMI 3.0 or 2.0, co-simulation) for Simulink, Modelica, FMPy.

:func:`export_fmu` writes one ``.fmu`` file holding the C99 sources of the plant (valves →
chamber → muscle → load: ``mckibben/export/c/``), a binary for this platform built with the
system C compiler, and its ``modelDescription.xml``:

- inputs ``inlet``, ``bleed``: the valves' PWM commands, whole counts 0..255 (held over each
  communication step, as the firmware holds them over its control period);
- outputs ``pressure`` (chamber, gauge) [Pa], ``length`` (muscle) [m], ``force`` (muscle pull) [N];
- parameters ``supply_pressure`` [Pa], ``load_force`` [N] (hanging load) and the force law's θ
  (``law_theta_RR``: row RR of the law's parameter vector, :mod:`mckibben.models.laws`), with the
  published set's or the muscle file's values as start values; the rest of the rig is fixed at export;
- with ``controller="smc"|"pid"``: the firmware's own controller core (``firmware/core/controller.c``)
  closes the loop inside at 1 kHz; the input is then the pressure ``reference`` [Pa] and the valve
  commands and the core's fault flags are outputs.

**One physics, the Python side is the source.** The Numba plant (:mod:`mckibben.plant.physics`,
:func:`mckibben.plant.packing.derive`, the static start of :mod:`mckibben.plant.simulator`, the law
kernels of :mod:`mckibben.models.laws`) is the source of truth; ``c/mk_plant.c`` is a port of it
and each law's C face (``models/laws/<law>.c``, gathered into a generated ``mk_laws.c``) a port of
its kernel, the same equations and the same classical RK4 with the same substep (the control period over its
substeps, 0.1 ms), the law chosen by its registry index. The layout the C reads (parameter columns,
law indices, θ rows) and this FMU's values are generated from the Python objects at export
(``mk_model.h``), so the two cannot drift in layout; ``tests/test_export_fmu.py`` holds them
equal in behaviour (an open-loop step through FMPy against :func:`mckibben.plant.simulate`).

The FMI headers are read from the installed FMPy (``fmpy/c-code``), not kept in this
repository, and the written FMU is checked with ``fmpy.validation.validate_fmu`` (FMI's XML schema, from
FMPy's package) before it is renamed into place.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import tempfile
import uuid
import zipfile
from importlib import resources
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from mckibben import __version__
from mckibben import hardware as HW
from mckibben.atomic import atomic_file, check_output_file
from mckibben.control import registry as R
from mckibben.control.core import MODE_PID, MODE_SMC, CoreParams, gain_values
from mckibben.control.experiment_setup import (controller_params, identify_file_plant, muscle_file_plant, plant_load,
                                               rest_pull, tuned_controller)
from mckibben.datasets import get_muscle
from mckibben.errors import InputError, check_instance
from mckibben.models import laws as LW
from mckibben.plant import c_layout as CL
from mckibben.plant import params as PP
from mckibben.plant import packing as PK
from mckibben.units import si

#: The FMU's model identifier (the binary's and the functions' name).
MODEL_IDENTIFIER = "mckibben_plant"
#: The C sources of the plant, package data of :mod:`mckibben.export` (``c/``).
PLANT_SOURCES = ("mk_plant.h", "mk_plant.c", "mk_loop.h", "mk_loop.c")
#: The firmware's controller core compiled into a closed-loop FMU (``firmware/core``, the C that runs on the Mega).
FIRMWARE_SOURCES = ("controller.c", "controller.h", "laws.h", *(f"law_{c.name}.h" for c in R.EXTENSIONS))
#: Controllers that close the loop inside the FMU (the firmware core's modes).
CONTROLLERS = ("smc", "pid")
#: FMI versions written. [-]
FMI_VERSIONS = (2, 3)
#: The FMI headers each version's wrapper includes, read from FMPy's package.
FMI_HEADERS = {2: ("fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h"),
               3: ("fmi3Functions.h", "fmi3FunctionTypes.h", "fmi3PlatformTypes.h")}
#: Value references (both FMI versions): outputs, inputs, parameters; θ row r is THETA_VR + r.
VR = {"time": 0, "pressure": 1, "length": 2, "force": 3, "inlet": 4, "bleed": 5, "reference": 6, "faults": 7,
      "supply_pressure": 10, "load_force": 11}
THETA_VR = 100
#: The compiler's flags for the FMU's binary (C99, position-independent, only the FMI functions exported).
CFLAGS = ("-std=c99", "-O2", "-fPIC", "-shared", "-fvisibility=hidden", "-Wall", "-Wextra")
#: Control period and RK4 substeps of the FMU's integrator: :func:`mckibben.plant.simulate`'s defaults.
TS, SUBSTEPS = CL.TS, CL.SUBSTEPS

_UNITS = {"Pa": 'kg="1" m="-1" s="-2"', "m": 'm="1"', "N": 'kg="1" m="1" s="-2"'}


def export_fmu(muscle: str | None = None, muscle_file=None, out="plant.fmu", fmi: int = 3, controller=None, *,
               load=None, supply=None, direction: str = "inflate", law: str = "model", beta=None,
               plant: PP.PlantParams | None = None) -> Path:
    """Write the plant as an FMU: a published muscle set or a fitted muscle file, FMI 3.0 or 2.0.

    Parameters
    ----------
    muscle : str, optional
        A published set (``mpam97``, ``mpam117``, ``mpam143``; see ``mckibben params list``);
        default ``mpam97`` when no ``muscle_file`` or ``plant`` is given. [-]
    muscle_file : str or pathlib.Path, optional
        A muscle file with a fitted ``[force_model]`` (``mckibben fit … --save``): its own law on a
        rig sized for it (:meth:`mckibben.plant.PlantParams.from_muscle_file`). [-]
    out : str or pathlib.Path, default "plant.fmu"
        The FMU to write (``.fmu``); written whole or not at all. [-]
    fmi : {3, 2}, default 3
        FMI version. [-]
    controller : {None, "smc", "pid"} or CoreParams, optional
        Close the loop inside the FMU with the firmware's own controller core
        (``firmware/core/controller.c``, the C that runs on the Mega) at the 1 ms control period:
        ``"smc"``/``"pid"`` with the documented design (:func:`mckibben.control.experiment_setup.controller_params`,
        or tuned on a muscle file's plant as ``control step --muscle-file`` does), or a design's
        :class:`~mckibben.control.core.CoreParams` (``mckibben.control.core.load_design``). The FMU
        then takes a pressure ``reference`` [Pa] and gives the valve commands as outputs. None: the
        open plant. [-]
    load : float, optional
        Hanging load, the FMU's ``load_force`` start value; default 0.6 N (as ``mckibben simulate
        open-loop``), or for a muscle file :data:`FILE_LOAD_FRACTION` of what its muscle pulls at
        rest at the supply pressure (0.6 N is nothing to a 400 N muscle). [N]
    supply : float, optional
        Supply pressure (gauge), the ``supply_pressure`` start value; default 0.8 MPa, or a muscle
        file's top fitted pressure. [Pa]
    direction : {"inflate", "deflate"}, default "inflate"
        With ``muscle_file``: the branch of its law. [-]
    law : {"model", "paper"}, default "model"
        With ``controller="smc"``: our sliding mode (model term) or the paper's β·tanh(S/ε). [-]
    beta : float, optional
        With ``controller="smc"``: the switching gain (default the law's). [PWM counts]
    plant : PlantParams, optional
        Any one rig (scalar fields) instead of ``muscle``/``muscle_file``. [-]

    Returns
    -------
    pathlib.Path
        The FMU written.

    Raises
    ------
    InputError
        One line naming the argument: an unknown muscle, a bad muscle file, two sources, a bad
        ``fmi``, ``out`` not a writable ``.fmu``, an unknown controller, a law the C port lacks;
        or no FMPy (the FMI headers) or no C compiler.
    """
    if fmi not in FMI_VERSIONS or isinstance(fmi, bool):
        raise InputError(f"fmi: {fmi!r}; choose 3 (FMI 3.0) or 2 (FMI 2.0)")
    dest = check_output_file(out, "out", suffixes=(".fmu",))
    plant = _plant(muscle, muscle_file, plant, load, supply, direction)
    ctrl = _controller(controller, plant, muscle_file, law, beta)
    prm, law_index, theta, name = plant.prepare(1)
    have = CL.c_laws()
    if name not in have:
        raise InputError(f"force law {name}: it has no C face (models/laws/{LW.LAWS[name].stem}.c), so no FMU "
                         f"(these laws have one: {', '.join(have)})")
    headers = _fmi_headers(fmi)
    cc = _compiler()
    label = _label(plant, muscle, muscle_file)
    core = _firmware_core() if ctrl is not None else None
    model_h = _model_header(prm[0], theta[:, 0], law_index, plant.thermal, ctrl)
    guid = "{" + str(uuid.UUID(bytes=hashlib.sha256((model_h + str(fmi)).encode()).digest()[:16])) + "}"
    model_h += f'#define MK_GUID "{guid}"\n\n#endif\n'
    with tempfile.TemporaryDirectory(prefix="mckibben-fmu-") as tmp:
        root = Path(tmp)
        src = root / "sources"
        src.mkdir()
        pkg = resources.files("mckibben.export") / "c"
        for fname in PLANT_SOURCES + (f"fmi{fmi}_plant.c",):
            (src / fname).write_bytes((pkg / fname).read_bytes())
        (src / "mk_laws.c").write_text(CL.laws_c())
        sources: tuple[str, ...] = ("mk_plant.c", "mk_laws.c", "mk_loop.c", f"fmi{fmi}_plant.c")
        if core is not None:
            for fname in FIRMWARE_SOURCES:
                shutil.copyfile(core / fname, src / fname)
            sources += ("controller.c",)
        for h in headers:
            shutil.copyfile(h, src / h.name)
        (src / "mk_model.h").write_text(model_h)
        plat = _platform(fmi)
        binary = root / "binaries" / plat / (MODEL_IDENTIFIER + ".so")
        binary.parent.mkdir(parents=True)
        _compile(cc, src, [src / f for f in sources], binary)
        variables = _variables(name, theta[:, 0], prm[0], ctrl is not None)
        desc = (_description3 if fmi == 3 else _description2)(guid, label, name, variables, sources)
        (root / "modelDescription.xml").write_text(desc, encoding="utf-8")
        if fmi == 3:
            (src / "buildDescription.xml").write_text(_build_description(sources), encoding="utf-8")
        with atomic_file(dest, "out") as part:
            with zipfile.ZipFile(part, "w", zipfile.ZIP_DEFLATED) as z:
                for f in sorted(root.rglob("*")):
                    if f.is_file():
                        z.write(f, f.relative_to(root).as_posix())
            _validate(part)
    return dest


#: A muscle file's FMU hangs this fraction of what its muscle pulls at rest (at the supply
#: pressure) by default: a load it lifts through a quarter of its range. [-]
FILE_LOAD_FRACTION = 0.25


def _plant(muscle, muscle_file, plant, load, supply, direction) -> PP.PlantParams:
    """The one rig to export, from exactly one of a published set, a muscle file, a PlantParams."""
    given = [k for k, v in (("muscle", muscle), ("muscle_file", muscle_file), ("plant", plant)) if v is not None]
    if len(given) > 1:
        raise InputError(f"{given[1]}: give one of muscle, muscle_file, plant; not {' and '.join(given)}")
    if plant is not None:
        plant = check_instance(plant, "plant", PP.PlantParams, "a PlantParams")
        if plant.size() != 1:
            raise InputError(f"plant: one rig (scalar parameters), not {plant.size()} instances")
        if load is not None or supply is not None:
            raise InputError("load, supply: give them in the PlantParams (load_force, supply_pressure)")
        return plant
    if muscle_file is not None:
        if load is None:  # a load scaled to the muscle at hand
            load = round(FILE_LOAD_FRACTION * rest_pull(muscle_file_plant(muscle_file, 0.0, supply, direction)), 1)
        return muscle_file_plant(muscle_file, load, supply, direction)
    if direction != "inflate":
        raise InputError(f"direction: {direction!r} applies to a muscle file's law only")
    f = plant_load(0.6 if load is None else load)
    s = float(PP.PlantParams().supply_pressure) if supply is None else si(supply, "pressure", "supply",
                                                                          allow_zero=False)
    if not 0 < s <= HW.P_MAX_LIMIT:
        raise InputError(f"supply: {supply!r} must be above 0 and at most the compressor's 1 MPa")
    name = "mpam97" if muscle is None else muscle
    try:
        published = get_muscle(name)
    except InputError as exc:
        raise InputError(f"muscle: {exc}") from None
    if published.name == PP.PlantParams().muscle_name:  # the calibrated default rig, as `simulate open-loop`
        return PP.PlantParams(supply_pressure=s, load_force=f)
    return PP.PlantParams.for_muscle(published, supply_pressure=s, load_force=f)


def _controller(controller, plant, muscle_file, law, beta) -> CoreParams | None:
    """The firmware core's parameters to close the loop with, or None for the open plant."""
    if controller is None:
        if beta is not None or law != "model":
            raise InputError("law, beta: they tune a controller; give controller='smc'")
        return None
    if isinstance(controller, CoreParams):
        return controller
    if not isinstance(controller, str) or controller not in CONTROLLERS:
        raise InputError(f"controller: {controller!r}; choose {' or '.join(CONTROLLERS)} (or a CoreParams design)")
    if muscle_file is not None:  # tuned on the file's own plant, as `control step --muscle-file`
        return tuned_controller(controller, identify_file_plant(plant), plant, law=law, beta=beta).params
    return controller_params(controller, law=law, beta=beta)


def controller_mode(controller: str) -> int:
    """The firmware core's mode of a controller name (``smc``, ``pid``).

    Parameters
    ----------
    controller : str
        A name of :data:`CONTROLLERS`. [-]
    """
    if controller not in CONTROLLERS:
        raise InputError(f"controller: {controller!r}; choose {' or '.join(CONTROLLERS)}")
    return MODE_SMC if controller == "smc" else MODE_PID


def _firmware_core() -> Path:
    """The firmware's C core: the copy a built package carries (``export/firmware_core``, made by
    ``setup.py`` from ``firmware/core``), else ``firmware/core`` of the source tree it runs from."""
    here = Path(__file__).resolve()
    for core in (here.parent / "firmware_core", here.parents[3] / "firmware" / "core"):
        if all((core / f).is_file() for f in FIRMWARE_SOURCES):
            return core
    raise InputError("controller: the firmware's C core is not in this installation (a package built "
                     "without firmware/core); export a closed-loop FMU from a source checkout of mckibben")


def _label(plant, muscle, muscle_file) -> str:
    if muscle_file is not None:
        return f"muscle file {Path(muscle_file).name}"
    if muscle is not None or plant is None:
        return f"published set {muscle or 'mpam97'}"
    return plant._law_label()


def _fmi_headers(fmi: int) -> list[Path]:
    """The FMI headers of a version, from the installed FMPy (``fmpy/c-code``)."""
    try:
        import fmpy  # deferred: an optional dependency (the `fmu` extra), only export needs it
    except ImportError:
        raise InputError("export fmu needs FMPy for the FMI headers and schemas: pip install 'mckibben[fmu]'") from None
    folder = Path(fmpy.__file__).parent / "c-code"
    paths = [folder / h for h in FMI_HEADERS[fmi]]
    missing = [p.name for p in paths if not p.is_file()]
    if missing:
        raise InputError(f"FMPy {fmpy.__version__} at {folder} lacks the FMI headers {', '.join(missing)}")
    return paths


def _platform(fmi: int) -> str:
    import fmpy  # deferred: optional (checked by _fmi_headers)

    return fmpy.platform_tuple if fmi == 3 else fmpy.platform


def _compiler() -> str:
    cc = shutil.which(os.environ.get("CC", "gcc"))
    if cc is None:
        raise InputError("export fmu needs the system C compiler (gcc, or $CC) to build the FMU's binary")
    return cc


def _compile(cc: str, include: Path, sources: list[Path], binary: Path) -> None:
    """Build the shared library; a compiler error is an internal error (the sources are ours)."""
    # warnings do not fail a user's export (another compiler, another release); the tests build the
    # FMU's sources with -Werror (tests/test_export_fmu.py)
    cmd = [cc, *CFLAGS, f"-I{include}", "-o", str(binary), *map(str, sources), "-lm"]
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"building the FMU's binary failed ({' '.join(cmd)}):\n{done.stderr}")


def _validate(path: Path) -> None:
    from fmpy.validation import validate_fmu  # deferred: optional (checked by _fmi_headers)

    problems = validate_fmu(str(path))
    if problems:
        raise RuntimeError("the written FMU does not validate: " + "; ".join(problems))



def _xml(x: float) -> str:
    """An xs:double that reads back to the same bits."""
    x = float(x)
    if np.isnan(x):
        return "NaN"
    if np.isinf(x):
        return "INF" if x > 0 else "-INF"
    return repr(x)


def _model_header(fields: np.ndarray, theta: np.ndarray, law: int, thermal: str, ctrl: CoreParams | None) -> str:
    """``mk_model.h``: the plant's layout and values (:func:`mckibben.plant.c_layout.plant_header`) and the controller's."""
    lines = CL.plant_header(fields, theta, law, thermal)
    d = lines.append
    d(f"#define MK_CONTROLLER {0 if ctrl is None else 1}")
    if ctrl is not None:
        gains = gain_values(ctrl)
        d(f"#define MK_CTRL_TS_US {int(round(TS * 1e6))}")
        d(f"#define MK_CTRL_MODE {int(ctrl.mode)}")
        d(f"#define MK_CTRL_P_MAX {int(np.rint(ctrl.p_max))}L")
        d(f"#define MK_CTRL_OL_INLET {int(ctrl.open_loop_inlet)}")
        d(f"#define MK_CTRL_OL_BLEED {int(ctrl.open_loop_bleed)}")
        d(f"#define MK_CTRL_N_GAINS {len(gains)}")
        d("static const long MK_CTRL_GAINS[MK_CTRL_N_GAINS] = {" + ", ".join(f"{int(g)}L" for g in gains) + "};")
    return "\n".join(lines) + "\n"


def _units3() -> str:
    return "".join(f'    <Unit name="{u}"><BaseUnit {b}/></Unit>\n' for u, b in _UNITS.items())


_PLANT_OUTPUTS = (("pressure", "Pa", "chamber pressure, gauge"), ("length", "m", "muscle length"),
                  ("force", "N", "muscle pulling force"))


def _variables(name: str, theta: np.ndarray, prm: np.ndarray, closed: bool) -> list[dict]:
    """The FMU's variables, in modelDescription order: outputs, inputs, parameters."""
    c = PK.Col
    out = [dict(name=v, vr=VR[v], causality="output", variability="continuous", type="real", unit=u, desc=d)
           for v, u, d in _PLANT_OUTPUTS]
    commands = (("inlet", "inlet valve command, PWM counts 0..255 (lift-off near 112)"),
                ("bleed", "bleed valve command, PWM counts 0..255"))
    if closed:
        out += [dict(name=v, vr=VR[v], causality="output", variability="discrete", type="int",
                     desc=d + ", from the firmware's controller core") for v, d in commands]
        out.append(dict(name="faults", vr=VR["faults"], causality="output", variability="discrete", type="int",
                        desc="the controller core's fault flags (MCK_FAULT_*, firmware/core/controller.h)"))
        out.append(dict(name="reference", vr=VR["reference"], causality="input", variability="continuous",
                        type="real", unit="Pa", start=0.0,
                        desc="pressure reference of the controller, gauge (sampled every control period)"))
    else:
        out += [dict(name=v, vr=VR[v], causality="input", variability="discrete", type="int", start=0, desc=d,
                     bounds=(0, 255)) for v, d in commands]
    out.append(dict(name="supply_pressure", vr=VR["supply_pressure"], causality="parameter", variability="fixed",
                    type="real", unit="Pa", start=prm[c["supply_pressure"]],
                    desc="regulated supply pressure, gauge (at most 1 MPa)"))
    out.append(dict(name="load_force", vr=VR["load_force"], causality="parameter", variability="fixed",
                    type="real", unit="N", start=prm[c["load_force"]], desc="hanging load on the muscle"))
    out += [dict(name=f"law_theta_{r:02d}", vr=THETA_VR + r, causality="parameter", variability="fixed",
                 type="real", start=v, desc=f"force law {name}: row {r} of its parameters (mckibben.models.laws, SI)")
            for r, v in enumerate(theta)]
    return out


def _head(fmi: str, guid_attr: str, guid: str, label: str, name: str) -> str:
    return (f'<?xml version="1.0" encoding="UTF-8"?>\n<fmiModelDescription fmiVersion="{fmi}" '
            f'modelName="{MODEL_IDENTIFIER}" {guid_attr}="{guid}" '
            f'description={quoteattr(f"McKibben muscle rig plant ({label}, {name} force law): valves, chamber, muscle, load")} '
            f'generationTool="mckibben {__version__}" variableNamingConvention="flat">\n')


def _attrs(v: dict, fmi: int) -> str:
    a = ""
    if "start" in v:
        a += f' start="{_xml(v["start"]) if v["type"] == "real" else int(v["start"])}"'
    if "bounds" in v:
        a += f' min="{v["bounds"][0]}" max="{v["bounds"][1]}"'
    if v.get("unit"):
        a += f' unit="{v["unit"]}"'
    return a


def _description3(guid, label, name, variables, sources) -> str:
    s = _head("3.0", "instantiationToken", guid, label, name)
    s += (f'  <CoSimulation modelIdentifier="{MODEL_IDENTIFIER}" canHandleVariableCommunicationStepSize="true" '
          f'fixedInternalStepSize="{_xml(TS / SUBSTEPS)}" canBeInstantiatedOnlyOncePerProcess="false"/>\n')
    s += "  <UnitDefinitions>\n" + _units3() + "  </UnitDefinitions>\n"
    s += f'  <DefaultExperiment startTime="0" stopTime="1" stepSize="{_xml(TS)}"/>\n  <ModelVariables>\n'
    s += '    <Float64 name="time" valueReference="0" causality="independent" variability="continuous"/>\n'
    for v in variables:
        tag = "Float64" if v["type"] == "real" else "Int32"
        s += (f'    <{tag} name="{v["name"]}" valueReference="{v["vr"]}" causality="{v["causality"]}" '
              f'variability="{v["variability"]}"{_attrs(v, 3)} description={quoteattr(v["desc"])}/>\n')
    s += "  </ModelVariables>\n  <ModelStructure>\n"
    outputs = [v for v in variables if v["causality"] == "output"]
    s += "".join(f'    <Output valueReference="{v["vr"]}" dependencies=""/>\n' for v in outputs)
    s += "".join(f'    <InitialUnknown valueReference="{v["vr"]}"/>\n' for v in outputs)
    s += "  </ModelStructure>\n</fmiModelDescription>\n"
    return s


def _description2(guid, label, name, variables, sources) -> str:
    s = _head("2.0", "guid", guid, label, name)
    s += (f'  <CoSimulation modelIdentifier="{MODEL_IDENTIFIER}" canHandleVariableCommunicationStepSize="true">\n'
          "    <SourceFiles>\n" + "".join(f'      <File name="{f}"/>\n' for f in sources)
          + "    </SourceFiles>\n  </CoSimulation>\n")
    s += "  <UnitDefinitions>\n" + _units3() + "  </UnitDefinitions>\n"
    s += f'  <DefaultExperiment startTime="0" stopTime="1" stepSize="{_xml(TS)}"/>\n  <ModelVariables>\n'
    for v in variables:
        tag = "Real" if v["type"] == "real" else "Integer"
        initial = ' initial="exact"' if v["causality"] == "parameter" else ""
        s += (f'    <ScalarVariable name="{v["name"]}" valueReference="{v["vr"]}" causality="{v["causality"]}" '
              f'variability="{v["variability"]}"{initial} description={quoteattr(v["desc"])}>'
              f'<{tag}{_attrs(v, 2)}/></ScalarVariable>\n')
    index = [i + 1 for i, v in enumerate(variables) if v["causality"] == "output"]
    s += "  </ModelVariables>\n  <ModelStructure>\n    <Outputs>\n"
    s += "".join(f'      <Unknown index="{i}" dependencies=""/>\n' for i in index)
    s += "    </Outputs>\n    <InitialUnknowns>\n"
    s += "".join(f'      <Unknown index="{i}"/>\n' for i in index)
    s += "    </InitialUnknowns>\n  </ModelStructure>\n</fmiModelDescription>\n"
    return s


def _build_description(sources) -> str:
    files = "".join(f'        <SourceFile name="{f}"/>\n' for f in sources)
    return ('<?xml version="1.0" encoding="UTF-8"?>\n<fmiBuildDescription fmiVersion="3.0">\n'
            f'  <BuildConfiguration modelIdentifier="{MODEL_IDENTIFIER}">\n'
            f'    <SourceFileSet language="C99">\n{files}    </SourceFileSet>\n'
            "  </BuildConfiguration>\n</fmiBuildDescription>\n")

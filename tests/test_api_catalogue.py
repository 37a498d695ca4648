"""The catalogue of bad calls to the public API of plant, tool, sweep, report, datasets and units.

Each case is a call a notebook user could make by mistake. It must be refused *before* anything
is allocated or written, with the project's error (:class:`~mckibben.errors.InputError`, a
``ValueError``, or :class:`~mckibben.errors.ArgumentTypeError`, also a ``TypeError``) whose one-line
message names the Python argument (or, where the library still shares a message with the command
line, its flag spelling). No file may be left behind. The cases that would exhaust memory or run
for hours are run in a subprocess with a time limit, so a regression cannot take the suite down.

A hypothesis test then throws random values at the numeric arguments: the answer is a result or
the project's error, never another exception.
"""

from __future__ import annotations

import math
import textwrap

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import mckibben as mk
from conftest import names_argument as _named, refusals_in_subprocess
from mckibben.errors import ArgumentTypeError, InputError
from mckibben.units import parse_quantity

NAN, INF = float("nan"), float("inf")
ERR = (InputError, ArgumentTypeError)


def _sim(**kw):
    from mckibben.plant import simulate

    args = {"duration": 0.01}
    args.update(kw)
    return simulate(**args)


def _static(**kw):
    from mckibben.plant import static_length

    return static_length(**kw)


def _params(**kw):
    from mckibben.plant import PlantParams

    return PlantParams(**kw).prepare()


def _tool(**kw):
    from mckibben.tool import make_tool

    return make_tool(**kw)


def _tip(lengths=(0.117, 0.117, 0.117), pitch_radius=4e-3, n_gaps=None):
    from mckibben.tool.kinematics import tip_from_lengths

    return tip_from_lengths(lengths, pitch_radius, n_gaps)


def _path(text="circle:radius=5mm,period=1s"):
    from mckibben.tool import parse_path

    return parse_path(text)


_DEFAULT_PATH = object()


def _track(path=_DEFAULT_PATH, **kw):
    kw.setdefault("reference_only", True)
    return mk.track_tip(_path() if path is _DEFAULT_PATH else path, **kw)


def _quantity(value, dimension="pressure"):
    return mk.quantity(value, dimension, "pressure")


# (id, call, argument named in the message)
CASES = [
    # plant.simulate: types, finiteness, ranges (the budget cases run in a subprocess below)
    *[(f"simulate-duration-{v!r}", lambda v=v: _sim(duration=v), "duration")
      for v in (None, True, "1s", NAN, INF, -1.0, 0.0, 0.0105, 1e-9, [1.0])],
    *[(f"simulate-ts-{v!r}", lambda v=v: _sim(ts=v), "ts") for v in (None, False, "1ms", NAN, INF, 0.0, -1e-3)],
    *[(f"simulate-n-{v!r}", lambda v=v: _sim(n=v), "n") for v in (True, 0, -3, 2.5, "2")],
    *[(f"simulate-substeps-{v!r}", lambda v=v: _sim(substeps=v), "substeps") for v in (None, True, 0, -1, 2.5, "10")],
    *[(f"simulate-reference-{i}", lambda v=v: _sim(reference=v), "reference")
      for i, v in enumerate((NAN, INF, -INF, None, "0.5MPa", [NAN] * 10, np.zeros(7), np.zeros((2, 3, 4)), True,
                             {"a": 1}, np.array(["a"] * 10)))],
    *[(f"simulate-initial_pressure-{v!r}", lambda v=v: _sim(initial_pressure=v), "initial_pressure")
      for v in (NAN, -1.0, 5e6, None, "x")],
    *[(f"simulate-initial_length-{v!r}", lambda v=v: _sim(initial_length=v), "initial_length")
      for v in (NAN, 0.0, 1.0, "x")],
    *[(f"simulate-inlet-{v!r}", lambda v=v: _sim(inlet=v), "inlet") for v in (300, -1, NAN, "x", None)],
    ("simulate-bleed-300", lambda: _sim(bleed=300), "bleed"),
    ("simulate-record-typo", lambda: _sim(record=("presure",)), "record"),
    *[(f"simulate-plant-{v!r}", lambda v=v: _sim(plant=v), "plant") for v in (97, "mpam97", 0.5)],
    ("simulate-controller-5", lambda: _sim(controller=5), "controller"),
    # plant.static_length
    *[(f"static_length-pressure-{i}", lambda v=v: _static(pressure=v), "pressure")
      for i, v in enumerate((NAN, INF, None, "0.5MPa", True, -2e5, [NAN], np.zeros((2, 2)), np.zeros(3)))],
    ("static_length-plant-97", lambda: _static(plant=97), "plant"),
    # PlantParams: a user's value is never replaced silently
    *[(f"PlantParams-{k}-{v!r}", lambda k=k, v=v: _params(**{k: v}), k)
      for k, v in (("alpha0", math.pi / 2), ("alpha0", NAN), ("alpha0", -0.1), ("alpha0", 1.2), ("k_tl", -5.0),
                   ("k_tl", NAN), ("p_threshold", 5e6), ("p_threshold", -1.0), ("load_force", NAN),
                   ("supply_pressure", 5e6), ("valve_tau", 0.0), ("force_model", "calibratd"), ("thermal", "hot"))],
    *[(f"PlantParams-r0-given-{k}", lambda k=k, v=v: _params(r0=4e-4, **{k: v}), k)
      for k, v in (("alpha0", math.pi / 2), ("k_tl", -5.0), ("p_threshold", 5e6))],
    # datasets
    *[(f"get_muscle-{v!r}", lambda v=v: mk.get_muscle(v), "muscle" if isinstance(v, str) else "name")
      for v in (None, 97, 0.5, ["mpam97"], "mpam9", "")],
    # tool.make_tool
    *[(f"make_tool-muscle-{v!r}", lambda v=v: _tool(muscle=v), "muscle") for v in (97, 0.5, ["mpam97"], "mpam9")],
    *[(f"make_tool-bending_stiffness-{v!r}", lambda v=v: _tool(bending_stiffness=v), "bending_stiffness")
      for v in (1e308, 1e6, -1.0, NAN, True, "abc")],
    *[(f"make_tool-pitch_radius-{v!r}", lambda v=v: _tool(pitch_radius=v), "pitch_radius")
      for v in (0.0, -1e-3, NAN, INF, True, "abc", 1.0)],
    *[(f"make_tool-discs-{v!r}", lambda v=v: _tool(discs=v), "discs") for v in (1, 0, True, "x", 2.5)],
    *[(f"make_tool-p_max-{v!r}", lambda v=v: _tool(p_max=v), "p_max") for v in (2e6, 0.0, NAN, "5MPa")],
    *[(f"make_tool-preload-{v!r}", lambda v=v: _tool(preload=v), "preload") for v in (NAN, -1.0, True)],
    ("make_tool-direction", lambda: _tool(direction="up"), "direction"),
    # tool.kinematics.tip_from_lengths
    *[(f"tip_from_lengths-pitch_radius-{v!r}", lambda v=v: _tip(pitch_radius=v), "pitch_radius")
      for v in (0, 0.0, -4e-3, NAN, INF, None, True, "4mm", 2.0)],
    *[(f"tip_from_lengths-lengths-{i}", lambda v=v: _tip(lengths=v), "lengths")
      for i, v in enumerate((None, "abc", [0.1, 0.1], [NAN] * 3, [True] * 3, [0.1, -0.1, 0.1], [[0.1, 0.1], [0.1]]))],
    *[(f"tip_from_lengths-n_gaps-{v!r}", lambda v=v: _tip(n_gaps=v), "n_gaps") for v in (0, -2, 1.5, True, "12")],
    # track_tip
    ("track_tip-periods-empty", lambda: _track(periods=[]), "periods"),
    ("track_tip-periods-empty-array", lambda: _track(periods=np.array([])), "periods"),
    ("track_tip-period-0.2ms", lambda: _track(_path("circle:radius=5mm,period=0.2ms")), "period"),
    ("track_tip-period-0.2ms-run", lambda: mk.track_tip(_path("circle:radius=5mm,period=0.2ms")), "period"),
    *[(f"track_tip-periods-{v!r}", lambda v=v: _track(periods=v), "periods")
      for v in ([NAN], [0.0], [-1.0], "0s", [None], [[1.0, 2.0]])],
    *[(f"track_tip-path-{v!r}", lambda v=v: _track(path=v), "path") for v in (None, 97, "spiral:radius=5mm")],
    ("track_tip-progress-5", lambda: mk.track_tip(_path(), progress=5), "progress"),
    ("track_tip-tool-5", lambda: _track(tool=5), "tool"),
    *[(f"track_tip-beta-{v!r}", lambda v=v: mk.track_tip(_path(), beta=v), "beta")
      for v in (NAN, 0.0, 300.0)],
    # units at the edge: finite in its unit, infinite in SI
    *[(f"quantity-{v!r}", lambda v=v: _quantity(v), "pressure")
      for v in ("1e308MPa", "1e306bar", "nanMPa", "infMPa", None, True, "5")],
    # reproduce: a bad progress is found before the run
    ("reproduce-progress-5", lambda: mk.reproduce("rep", progress=5), "progress"),
    ("reproduce-out-None", lambda: mk.reproduce(None), "out"),
    ("reproduce-data-5", lambda: mk.reproduce("rep", data=5), "data"),
    # the static models' entry points (issue 24: NaN, None, bool and a name where a muscle goes)
    ("predict_length-pressure-nan", lambda: mk.predict_length(mk.get_muscle("mpam97"), NAN, 0.6), "pressure"),
    ("predict_length-pressure-None", lambda: mk.predict_length(mk.get_muscle("mpam97"), None, 0.6), "pressure"),
    ("predict_length-load-nan", lambda: mk.predict_length(mk.get_muscle("mpam97"), 0.4e6, NAN), "load"),
    ("predict_length-load-True", lambda: mk.predict_length(mk.get_muscle("mpam97"), 0.4e6, True), "load"),
    ("predict_length-muscle-name", lambda: mk.predict_length("mpam97", 0.4e6, 0.6), "muscle"),
    ("predict_length-muscle-None", lambda: mk.predict_length(None, 0.4e6, 0.6), "muscle"),
    ("pressure_for_length-muscle-name", lambda: mk.pressure_for_length("mpam97", 0.08, 0.6), "muscle"),
    ("pressure_for_length-length-None", lambda: mk.pressure_for_length(mk.get_muscle("mpam97"), None, 0.6), "length"),
    ("pressure_for_length-load-True", lambda: mk.pressure_for_length(mk.get_muscle("mpam97"), 0.08, True), "load"),
    ("pressure_for_length-p_max-0", lambda: mk.pressure_for_length(mk.get_muscle("mpam97"), 0.08, 0.6, 0.0),
     "p_max"),
    # the static models' one calling convention (mckibben.models.static)
    ("models.force-pressure-nan", lambda: _models().force(NAN, 0.09, mk.get_muscle("mpam97"), model="chou-hannaford"),
     "pressure"),
    ("models.force-pressure-None", lambda: _models().force(None, 0.09, mk.get_muscle("mpam97")), "pressure"),
    ("models.force-length-True", lambda: _models().force(0.5e6, True, mk.get_muscle("mpam97"), model="wall-corrected"),
     "length"),
    ("models.force-muscle-name", lambda: _models().force(0.5e6, 0.09, "mpam97", model="chou-hannaford"), "muscle"),
    ("models.force-model-number", lambda: _models().force(0.5e6, 0.09, mk.get_muscle("mpam97"), model=3), "model"),
    # model=None is the default (braid-map on a catalogue muscle, a muscle file's own law)
    ("models.length-model-number", lambda: _models().length(0.5e6, 0.6, mk.get_muscle("mpam97"), model=3), "model"),
    ("models.pressure-model-number", lambda: _models().pressure(0.08, 0.6, mk.get_muscle("mpam97"), model=3), "model"),
    ("models.pressure-length-None", lambda: _models().pressure(None, 0.6, mk.get_muscle("mpam97")), "length"),
    ("models.pressure-p_max-0", lambda: _models().pressure(0.08, 0.6, mk.get_muscle("mpam97"), p_max=0.0), "p_max"),
    ("models.pressure-muscle-None", lambda: _models().pressure(0.08, 0.6, None, model="chou-hannaford"), "muscle"),
    ("models.length-load-True", lambda: _models().length(0.4e6, True, mk.get_muscle("mpam97")), "load"),
    ("models.length-load-negative", lambda: _models().length(0.4e6, -1.0, mk.get_muscle("mpam97"),
                                                             model="chou-hannaford"), "load"),
    ("models.length-muscle-None", lambda: _models().length(0.4e6, 0.6, None, model="wall-corrected"), "muscle"),
    # the identification's record is sized before it is allocated
    ("identify_plant-duration-1e9", lambda: _identify(duration=1e9), "duration"),
    ("identify_plant-duration-nan", lambda: _identify(duration=NAN), "duration"),
    ("identify_plant-duration-None", lambda: _identify(duration=None), "duration"),
    # the fits read a table file
    ("fit_table-data-DataFrame", lambda: _fit().fit_table(__import__("pandas").DataFrame({"a": [1.0]}), "cubic"),
     "data"),
    ("fit_table-data-None", lambda: _fit().fit_table(None, "cubic"), "data"),
    ("compare_table-data-5", lambda: _fit().compare_table(5), "data"),
]


def _models():
    from mckibben import models

    return models


def _identify(**kw):
    from mckibben.control.runs import identify_plant

    return identify_plant(**kw)


def _fit():
    from mckibben import fit

    return fit




@pytest.mark.parametrize("call,name", [pytest.param(c, n, id=i) for i, c, n in CASES])
def test_bad_call_is_refused_naming_its_argument(call, name, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ERR) as info:
        call()
    message = str(info.value)
    assert "\n" not in message
    assert _named(message, name), message
    assert list(tmp_path.iterdir()) == []  # nothing half-written


# ---------------------------------------------------------------------------------------------
# sweeps: load_sweep refuses a description that would fail (or be silently wrong) in the middle

SWEEP = """
[sweep]
seed = 1
samples = 2
chunk_size = 2

[scenario]
{scenario}

[plant]
{plant}
"""

STEP = 'kind = "step"\ntarget = "0.5MPa"\nduration = "0.03s"'


@pytest.mark.parametrize("scenario,plant,name", [
    pytest.param(STEP, "load_force = { lognormal = [1, 1000] }", "load_force", id="lognormal-spread"),
    pytest.param(STEP, 'load_force = { uniform = ["1N", "1e9N"] }', "load_force", id="load-1e9N"),
    pytest.param(STEP, 'load_force = { normal = ["1N", "1e7N"] }', "load_force", id="normal-huge"),
    pytest.param('kind = "sine"\nfrequency = "1000kHz"\nduration = "0.5s"', "", "frequency", id="sine-aliases"),
    pytest.param('kind = "sine"\nfrequency = "2Hz"\nduration = "0.1s"', "", "duration", id="sine-short"),
    pytest.param('kind = "step"\ntarget = "0.5MPa"\nduration = "0.011s"', "", "duration", id="step-short"),
])
def test_load_sweep_refuses_what_would_fail_in_the_middle(tmp_path, scenario, plant, name):
    p = tmp_path / "s.toml"
    p.write_text(textwrap.dedent(SWEEP.format(scenario=scenario, plant=plant)))
    with pytest.raises(InputError) as info:
        mk.load_sweep(p)
    assert _named(str(info.value), name), str(info.value)


@pytest.fixture(scope="module")
def small_sweep(tmp_path_factory):
    p = tmp_path_factory.mktemp("sweep") / "s.toml"
    p.write_text(textwrap.dedent(SWEEP.format(scenario=STEP, plant="")))
    return mk.load_sweep(p)


@pytest.mark.parametrize("kwargs,name", [
    pytest.param({"workers": -1}, "workers", id="workers--1"),
    pytest.param({"workers": 0}, "workers", id="workers-0"),
    pytest.param({"workers": True}, "workers", id="workers-True"),
    pytest.param({"workers": 2.5}, "workers", id="workers-2.5"),
    pytest.param({"workers": "2"}, "workers", id="workers-str"),
    pytest.param({"workers": 10**6}, "workers", id="workers-huge"),
    pytest.param({"scheduler": 5}, "scheduler", id="scheduler-int"),
    pytest.param({"workers": 2, "scheduler": "tcp://h:1"}, "scheduler", id="workers-and-scheduler"),
    pytest.param({"progress": 5}, "progress", id="progress-not-callable"),
    pytest.param({"out": None}, "out", id="out-None"),
    pytest.param({"sweep": None}, "sweep", id="sweep-None"),
    pytest.param({"sweep": "s.toml"}, "sweep", id="sweep-path"),
])
def test_run_sweep_refuses_before_starting(small_sweep, tmp_path, kwargs, name):
    args = {"sweep": small_sweep, "out": str(tmp_path / "out")}
    args.update(kwargs)
    with pytest.raises(ERR) as info:
        mk.run_sweep(args.pop("sweep"), args.pop("out"), **args)
    assert _named(str(info.value), name), str(info.value)
    assert not (tmp_path / "out").exists()


# ---------------------------------------------------------------------------------------------
# .plot(ax=...) of a result


@pytest.mark.parametrize("ax", ["x", 5, [1, 2], object()])
def test_plot_refuses_what_is_not_an_axes(ax):
    result = _track()
    with pytest.raises(ArgumentTypeError, match="^ax = "):
        result.plot(ax=ax)


# ---------------------------------------------------------------------------------------------
# memory and hang cases: each in a subprocess with a time limit

HEAVY = {
    "duration-1e5": "simulate(duration=1e5)",
    "duration-1e9": "simulate(duration=1e9)",
    "ts-1e-9": "simulate(duration=1.0, ts=1e-9)",
    "n-1e9": "simulate(duration=1.0, n=10**9)",
    "substeps-1e9": "simulate(duration=1.0, substeps=10**9)",
    "n-and-duration": "simulate(duration=10.0, n=10**5)",
}


def test_memory_and_hang_cases_are_refused_quickly():
    got = refusals_in_subprocess("from mckibben.plant import simulate\n", HEAVY)
    for key, message in got.items():
        assert "duration" in message and "substeps" in message, (key, message)
        assert "limit" in message or "available" in message, (key, message)


def test_lifted_limits_still_refuse_more_than_the_machine_has():
    from mckibben.limits import lifted
    from mckibben.plant import simulate

    with lifted(), pytest.raises(InputError, match="available"):
        simulate(duration=1e9)


# ---------------------------------------------------------------------------------------------
# random values at the numeric arguments: a result or the project's error, nothing else

_weird = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True, width=64),
    st.sampled_from([0, -1, 1e308, -1e308, 1e-320, True, False, None, "x", "5mm", [], [1.0, 2.0], [[1.0]],
                     np.array([NAN]), np.zeros((2, 2)), {"a": 1}]),
    st.integers(min_value=-(10**12), max_value=10**12),
)

_SETTINGS = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                           HealthCheck.function_scoped_fixture])


def _only_ours(call, value, takes_none: bool = False):
    """A result or the project's error, and never a result for a value that is no number at all."""
    try:
        call()
    except ERR:
        return
    assert not _no_number(value, takes_none), f"a result for {value!r}"


@_SETTINGS
@given(value=_weird, which=st.sampled_from(["duration", "ts", "n", "substeps", "reference", "initial_pressure"]))
def test_simulate_random_values(value, which):
    if which == "duration" and isinstance(value, (int, float)) and not isinstance(value, bool) and 0 < value <= 0.05:
        value = 0.01  # a valid run, kept short
    if which == "n" and isinstance(value, int) and not isinstance(value, bool) and 0 < value:
        value = min(value, 4)
    _only_ours(lambda: _sim(**{which: value}), value, which in ("reference", "n"))  # n=None: the plant's batch


@_SETTINGS
@given(value=_weird)
def test_static_length_random_values(value):
    _only_ours(lambda: _static(pressure=value), value)


@_SETTINGS
@given(value=_weird, which=st.sampled_from(["pitch_radius", "discs", "preload", "bending_stiffness",
                                            "axial_stiffness", "p_max", "muscle"]))
def test_make_tool_random_values(value, which):
    _only_ours(lambda: _tool(**{which: value}), value, takes_none=True)  # None: each default


@_SETTINGS
@given(value=_weird, which=st.sampled_from(["lengths", "pitch_radius", "n_gaps"]))
def test_tip_from_lengths_random_values(value, which):
    _only_ours(lambda: _tip(**{which: value}), value, which == "n_gaps")  # n_gaps=None: the tool's own


@settings(max_examples=15, deadline=None)
@given(value=_weird, which=st.sampled_from(["periods", "path", "beta"]))
def test_track_tip_random_values(value, which):
    _only_ours(lambda: _track(**{which: value}), value, which in ("periods", "beta"))  # None: their defaults


@pytest.mark.parametrize("model", ["chou-hannaford", "wall-corrected"])
def test_the_physical_force_laws_flag_a_length_off_the_braid(model):
    """Chou–Hannaford returns a number for any length; off the braid (past the straight strand,
    below the locking length) it is flagged, as the fitted models flag what they extrapolate."""
    from mckibben import models

    m = mk.get_muscle("mpam97")
    r = models.force(0.5e6, [10.0, 0.09, 0.01], m, model=model)
    names = [models.flags.flag_names(int(f)) for f in r.flags]
    assert "length_out_of_range" in names[0] and "length_out_of_range" in names[2]
    assert names[1] == []  # inside the braid's range, at a characterized pressure
    assert "slack" in names[2]  # below the locking length the law would push


@pytest.mark.parametrize("key,value", [("outer_diameter_mm", "1e308"), ("nominal_length_m", "1e6"),
                                       ("outer_diameter_cm", "120")])
def test_a_muscle_file_with_an_implausible_size_is_refused(tmp_path, key, value):
    p = tmp_path / "m.toml"
    base = {"nominal_length_mm": "97", "outer_diameter_mm": "1.2"}
    base = {k: v for k, v in base.items() if k.rpartition("_")[0] != key.rpartition("_")[0]}
    p.write_text('id = "m"\n' + "".join(f"{k} = {v}\n" for k, v in {**base, key: value}.items()))
    with pytest.raises(InputError, match=key):
        mk.read_muscle(p)


# every public entry point's numeric arguments, each replaced by a random value in turn: a result or
# the project's error; and never a result for a value that is no number at all (None where a number
# is required, a bool, text, a mapping, NaN)

def _experiments():
    import importlib

    return importlib.import_module("mckibben.experiments")


_ENTRY_POINTS = {
    # name: (call taking the replaced keyword, numeric arguments, those that take None)
    "predict_length": (lambda **k: mk.predict_length(mk.get_muscle("mpam97"), **{"pressure": 4e5, "load": 0.6, **k}),
                       ("pressure", "load"), ()),
    "pressure_for_length": (lambda **k: mk.pressure_for_length(mk.get_muscle("mpam97"),
                                                               **{"length": 0.09, "load": 0.6, **k}),
                            ("length", "load", "p_max"), ()),
    "models.force": (lambda **k: _mod_models().force(**{"pressure": 4e5, "length": 0.09, "muscle": mk.get_muscle("mpam97"),
                                                        "model": "chou-hannaford", **k}), ("pressure", "length"), ()),
    "models.length": (lambda **k: _mod_models().length(**{"pressure": 4e5, "load": 0.6, "muscle": mk.get_muscle("mpam97"),
                                                          **k}), ("pressure", "load"), ()),
    "models.pressure": (lambda **k: _mod_models().pressure(**{"length": 0.09, "load": 0.6,
                                                              "muscle": mk.get_muscle("mpam97"), **k}),
                        ("length", "load", "p_max"), ()),
    "step_response": (lambda **k: _experiments().step_response(**{"duration": 0.05, **k}),
                      ("target", "start", "load", "supply", "duration", "p_max", "beta", "eps", "ki"),
                      ("supply", "beta", "eps", "ki")),
    "open_loop": (lambda **k: _experiments().open_loop(**{"duration": 0.05, **k}),
                  ("valve", "supply", "load", "duration"), ("valve", "supply")),
    "linearize": (lambda **k: _mod_plant().linearize(**k), ("pressure",), ()),
    "static_length": (lambda **k: _mod_plant().static_length(**k), ("pressure",), ()),
    "make_tool": (lambda **k: _mod_tool().make_tool(**k),
                  ("pitch_radius", "discs", "preload", "bending_stiffness", "axial_stiffness", "p_max"),
                  ("pitch_radius", "discs", "preload", "bending_stiffness", "axial_stiffness", "p_max")),  # discs=None: continuous
}


#: The arguments that take text with a unit by design (``mckibben.models.force``/``length``: "0.8MPa"),
#: with their dimension: text there is refused or gives the result of the number it reads as.
_TAKES_TEXT = {"models.force": {"pressure": "pressure", "length": "length"},
               "models.length": {"pressure": "pressure", "load": "force"}}


def _mod_models():
    from mckibben import models

    return models


def _mod_plant():
    from mckibben import plant

    return plant


def _mod_tool():
    from mckibben import tool

    return tool


def _no_number(value, takes_none: bool) -> bool:
    if value is None:
        return not takes_none
    if isinstance(value, (bool, str, dict)):
        return True
    return isinstance(value, float) and math.isnan(value)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_every_entry_point_random_values(data):
    name = data.draw(st.sampled_from(sorted(_ENTRY_POINTS)))
    call, numeric, takes_none = _ENTRY_POINTS[name]
    which = data.draw(st.sampled_from(numeric))
    value = data.draw(_weird)
    try:
        res = call(**{which: value})
    except ERR:
        return
    dimension = _TAKES_TEXT.get(name, {}).get(which)
    if isinstance(value, str) and dimension is not None:
        same = call(**{which: parse_quantity(value, dimension)})
        assert res.to_pandas().equals(same.to_pandas()), f"{name}({which}={value!r}) is not its number's result"
        return
    assert not _no_number(value, which in takes_none), f"{name}({which}={value!r}) returned a result"

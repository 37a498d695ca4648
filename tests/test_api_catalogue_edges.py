"""More bad calls to the public API: the cases issue 24's probe found below the entry points.

A sibling of ``test_api_catalogue.py``, with its rules: each call is refused with the project's
error (:class:`~mckibben.errors.InputError`, a ``ValueError``, or
:class:`~mckibben.errors.ArgumentTypeError`, also a ``TypeError``) whose one-line message names
the Python argument, before anything is allocated or written (nothing is left in the working
folder). The calls that would take minutes or gigabytes run in a subprocess with a memory limit and
a timeout. The probe that found them (about 950 calls, in a subprocess each with a memory limit)
is not shipped; these are the ones it found wrong, kept so they stay right.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import mckibben as mk
from conftest import names_argument as _named, refusals_in_subprocess
from mckibben.errors import ArgumentTypeError, InputError

NAN, INF = float("nan"), float("inf")
ERR = (InputError, ArgumentTypeError)


def _m():
    return mk.get_muscle("mpam97")


def _mod(name):
    import importlib

    return importlib.import_module(f"mckibben.{name}")


def _table():
    from mckibben.datasets.campaign import BUNDLED

    return mk.read_table(BUNDLED / "mpam97" / "isotonic.csv")


def _path(text="circle:radius=5mm,period=1s"):
    return _mod("tool").parse_path(text)


# (id, call, argument named in the message)
CASES = [
    # the static models: broadcasting, size, muscles, the low-level faces (type checks)
    ("predict_length-shapes", lambda: mk.predict_length(_m(), [1e5, 2e5, 3e5], [0.6, 1.0]), "pressure"),
    ("predict_length-broadcast-size",
     lambda: mk.predict_length(_m(), np.zeros((10**4, 1)), np.full(10**4, 0.6)), "pressure"),
    ("pressure_for_length-length-nan", lambda: mk.pressure_for_length(_m(), NAN, 0.6), "length"),
    ("pressure_for_length-length-dict", lambda: mk.pressure_for_length(_m(), {"a": 1}, 0.6), "length"),
    ("pressure_for_length-length-broadcast-size",
     lambda: mk.pressure_for_length(_m(), np.broadcast_to(0.08, (10**7,)), 0.6), "length"),
    *[(f"force_from_length-{n}-{v!r}", lambda n=n, v=v: mk.force_from_length(_m(), **{"pressure": 4e5, "length": 0.09,
                                                                                       n: v}), n)
      for n in ("pressure", "length") for v in (NAN, None, True, "abc")],
    ("force_from_length-muscle-None", lambda: mk.force_from_length(None, 4e5, 0.09), "muscle"),
    *[(f"models.force-muscle-{v!r}", lambda v=v: _mod("models").force(5e5, 0.09, v), "muscle")
      for v in (None, "mpam97", 5)],
    ("models.length-broadcast-size",
     lambda: _mod("models").length(np.broadcast_to(4e5, (10**8,)), 0.6, _m()), "pressure"),
    ("chou_hannaford_force-pressure-text",
     lambda: _mod("models").chou_hannaford_force("abc", 0.09, _mod("models").miniature_geometry(0.097)), "pressure"),
    ("length_under_load-geom-None", lambda: _mod("models").length_under_load(5e5, 0.6, None), "geom"),
    ("length_under_load-load-text",
     lambda: _mod("models").length_under_load(5e5, "abc", _mod("models").miniature_geometry(0.097)), "load"),
    ("predict_length-muscle-table", lambda: mk.predict_length(_table(), 4e5, 0.6), "muscle"),
    ("length_under_load-load-negative",
     lambda: _mod("models").length_under_load(5e5, -1.0, _mod("models").miniature_geometry(0.097)), "load"),
    ("braid_from_length-length-text", lambda: _mod("models").braid_from_length("abc", 0.112), "length"),
    ("length_from_braid-cos_theta-None", lambda: _mod("models").length_from_braid(None, 0.112), "cos_theta"),
    ("braid_cos_theta-braid_map-None", lambda: _mod("models").braid_cos_theta(4e5, 0.6, None), "braid_map"),
    ("braid_cos_theta-pressure-True", lambda: _mod("models").braid_cos_theta(True, 0.6, _m().braid_map), "pressure"),
    ("tondu_lopez_force-initial_angle-text",
     lambda: _mod("models").tondu_lopez_force(3e5, 0.1, 0.005, "abc"), "initial_angle"),
    ("tondu_lopez_contraction-force-None",
     lambda: _mod("models").tondu_lopez_contraction(3e5, None, 0.005, 0.35), "force"),
    ("unstretched_length-pressure-text", lambda: _mod("models").unstretched_length("abc", (0.3, 0.01, 0.0)),
     "pressure"),
    *[(f"BraidGeometry-{n}-{v!r}", lambda n=n, v=v: _mod("models").BraidGeometry(**{"strand_length": 0.112,
                                                                                    "turns": 2.0, n: v}), n)
      for n in ("strand_length", "turns") for v in (None, True, NAN, INF, -1.0, 1e308, "abc")],
    *[(f"MiniatureGeometry-outer_diameter-{v!r}", lambda v=v: _mod("models").MiniatureGeometry(outer_diameter=v),
       "outer_diameter") for v in (None, True, NAN, -1.0, 1e308, "abc")],
    *[(f"miniature_geometry-nominal_length-{v!r}", lambda v=v: _mod("models").miniature_geometry(v),
       "nominal_length") for v in (None, True, NAN, INF, -1.0, 1e308, "abc")],
    *[(f"flag_names-mask-{v!r}", lambda v=v: _mod("models").flag_names(v), "mask") for v in (None, "x", -1, 1.5)],
    # data
    *[(f"read_table-path-{v!r}", lambda v=v: mk.read_table(v), "path") for v in (None, 97, True)],
    *[(f"read_table-kind-{v!r}", lambda v=v: mk.read_table("x.csv", kind=v), "kind") for v in (5, True)],
    ("read_muscle-path-None", lambda: mk.read_muscle(None), "path"),
    *[(f"apply_tare-method-{v!r}", lambda v=v: _mod("data").apply_tare(_table(), v), "method")
      for v in (None, 5, "firts")],
    *[(f"apply_tare-table-{i}", lambda v=v: _mod("data").apply_tare(v), "table") for i, v in enumerate((None, "x"))],
    ("check_muscle-table-None", lambda: _mod("data").check_muscle(None, None), "table"),
    ("check_muscle-muscle-M", lambda: _mod("data").check_muscle(_table(), _m()), "muscle"),
    *[(f"detect_kind-{v!r}", lambda v=v: _mod("data").detect_kind(v), "quantities") for v in (None, 5)],
    *[(f"find_muscle_file-{v!r}", lambda v=v: _mod("data").find_muscle_file(v), "data_path") for v in (None, 5)],
    # fits
    *[(f"fit_table-model-{v!r}", lambda v=v: _mod("fit").fit_table("x.csv", v), "model") for v in (None, 5)],
    *[(f"fit_table-split_pressure-{v!r}", lambda v=v: _fit_iso(split_pressure=v), "split_pressure")
      for v in (True, NAN, INF, -1.0, "abc", 3e5)],
    *[(f"fit_table-rest_length-{v!r}",
       lambda v=v: _mod("fit").fit_table(_iso_file(), "spring", rest_length=v, save="m.toml"), "rest_length")
      for v in (True, NAN, -1.0)],
    ("fit_table-kind-5", lambda: _mod("fit").fit_table(_iso_file(), "cubic", kind=5), "kind"),
    ("fit_isometric-table-None", lambda: _mod("fit").fit_isometric(None, None), "table"),
    ("fit_isometric-muscle-M", lambda: _mod("fit").fit_isometric(_iso(), _m()), "muscle"),
    ("compare_isometric-table-frame", lambda: _mod("fit").compare_isometric(_iso().data, None), "table"),
    ("fit_prandtl_ishlinskii-u-text",
     lambda: _mod("fit").fit_prandtl_ishlinskii("x", np.linspace(0, 1, 50), [0.0, 0.5]), "u"),
    ("fit_prandtl_ishlinskii-thresholds-nan",
     lambda: _mod("fit").fit_prandtl_ishlinskii(np.linspace(0, 1, 50), np.linspace(0, 1, 50), [NAN]), "thresholds"),
    # plant
    *[(f"PlantParams-{k}-{v!r}", lambda k=k, v=v: _mod("plant").PlantParams(**{k: v}).prepare(), k)
      for k, v in (("supply_pressure", "0.8MPa"), ("supply_pressure", True), ("load_force", 1e308),
                   ("load_force", None), ("force_model", None), ("valve_tau", [[1.0]]))],
    *[(f"PlantStepper-{k}-{v!r}", lambda k=k, v=v: _mod("plant").PlantStepper(**{k: v}), k)
      for k, v in (("ts", None), ("ts", True), ("ts", INF), ("ts", "x"), ("substeps", True), ("substeps", 10**9),
                   ("initial_pressure", NAN), ("initial_pressure", -1.0), ("initial_pressure", "x"), ("plant", 5))],
    *[(f"calibrate_force_law-{k}-{v!r}", lambda k=k, v=v: _mod("plant").calibrate_force_law(_m(), **{k: v}), k)
      for k, v in (("blocked_force", True), ("blocked_force", NAN), ("blocked_force", -1.0), ("blocked_force", "x"),
                   ("alpha0", math.pi / 2), ("alpha0", NAN), ("alpha0", -1.0), ("alpha0", 1e308), ("alpha0", "x"))],
    ("calibrate_force_law-muscle-None", lambda: _mod("plant").calibrate_force_law(None), "muscle"),
    *[(f"linearize-pressure-{v!r}", lambda v=v: _mod("plant").linearize(pressure=v), "pressure")
      for v in (None, True, "x", NAN)],
    ("linearize-plant-5", lambda: _mod("plant").linearize(plant=5), "plant"),
    *[(f"simulate-record-{v!r}", lambda v=v: _mod("plant").simulate(duration=0.01, record=v), "record")
      for v in (None, 5, (), [1])],
    ("simulate-inlet-fraction", lambda: _mod("plant").simulate(duration=0.01, inlet=1.5), "inlet"),
    ("simulate-substeps-1e7", lambda: _mod("plant").simulate(duration=0.05, substeps=10**7), "substeps"),
    ("simulate-ts-1e308", lambda: _mod("plant").simulate(duration=0.05, ts=1e308), "ts"),
    ("open_loop_step-duration-nan", lambda: _mod("plant").open_loop_step(duration=NAN), "duration"),
    # the tool: SI numbers, a TipPath, objects of the right type
    ("Tool-muscle-None", lambda: _mod("tool").Tool(None), "muscle"),
    ("Tool-muscle-name", lambda: _mod("tool").Tool("mpam97"), "muscle"),
    *[(f"Tool-p_max-{v!r}", lambda v=v: _mod("tool").Tool(_m(), p_max=v), "p_max") for v in (NAN, -1.0, 2e6, True)],
    *[(f"ToolGeometry-pitch_radius-{v!r}", lambda v=v: _mod("tool").ToolGeometry(pitch_radius=v), "pitch_radius")
      for v in ("x", NAN, True, 1e308, 0.0)],
    *[(f"ToolGeometry-n_discs-{v!r}", lambda v=v: _mod("tool").ToolGeometry(n_discs=v), "n_discs")
      for v in (0, True, 2.5)],
    *[(f"StackLoad-{k}-{v!r}", lambda k=k, v=v: _mod("tool").StackLoad(**{k: v}), k)
      for k, v in (("preload", 1e308), ("preload", "1N"), ("preload", True), ("bending_stiffness", 1e308),
                   ("bending_stiffness", "x"), ("axial_stiffness", NAN))],
    *[(f"Arc-arc_length-{v!r}", lambda v=v: _mod("tool").Arc(v, 0.0, 0.0), "arc_length") for v in (None, NAN, -1.0)],
    *[(f"{f}-arc-None", lambda f=f: getattr(_mod("tool"), f)(None, *((4e-3,) if f == "lengths_from_arc" else ())),
       "arc") for f in ("lengths_from_arc", "tip_position", "tip_rotation")],
    *[(f"arc_from_tip-tip-{v!r}", lambda v=v: _mod("tool").arc_from_tip(v), "tip") for v in ("abc", {"a": 1}, None)],
    ("tip_from_lengths-poses", lambda: _mod("tool").tip_from_lengths(np.broadcast_to(0.1, (10**7, 3)), 4e-3),
     "lengths"),
    *[(f"forward-tool-{v!r}", lambda v=v: _mod("tool").forward(v, pressures=[4e5, 4e5, 4e5]), "tool") for v in (5, "x")],
    ("forward-lengths-text", lambda: _mod("tool").forward(lengths="117mm,112mm,115mm"), "lengths"),
    ("forward-pressures-text", lambda: _mod("tool").forward(pressures="0.4MPa,0MPa,0MPa"), "pressures"),
    ("inverse-tip-text", lambda: _mod("tool").inverse("20mm,0mm,110mm"), "tip"),
    ("inverse-tool-text", lambda: _mod("tool").inverse([0.0, 0.0, 0.11], "x"), "tool"),
    ("map_workspace-tool-5", lambda: _mod("tool").map_workspace(5), "tool"),
    ("tool_dict-None", lambda: _mod("tool").tool_dict(None), "tool"),
    ("state_dict-None", lambda: _mod("tool").state_dict(None), "state"),
    *[(f"make_tool-text-{k}", lambda k=k, v=v: mk.make_tool(**{k: v}), k)
      for k, v in (("pitch_radius", "4mm"), ("preload", "1N"), ("bending_stiffness", "2e-4Nm2"),
                   ("axial_stiffness", "0N"), ("p_max", "0.5MPa"))],
    *[(f"make_tool-{k}-1e308", lambda k=k: mk.make_tool(**{k: 1e308}), k) for k in ("preload", "axial_stiffness")],
    ("make_tool-muscle_file-5", lambda: mk.make_tool(muscle_file=5), "muscle_file"),
    ("track_tip-path-text", lambda: mk.track_tip("circle:radius=5mm,period=1s"), "path"),
    ("track_tip-periods-text", lambda: mk.track_tip(_path(), periods="1s", reference_only=True), "periods"),
    ("track_tip-periods-many", lambda: mk.track_tip(_path(), periods=[1.0] * 10**4, reference_only=True), "periods"),
    *[(f"track_tip-reference_only-{v!r}", lambda v=v: mk.track_tip(_path(), reference_only=v), "reference_only")
      for v in ("yes", None)],
    *[(f"track_tip-beta-{v!r}", lambda v=v: mk.track_tip(_path(), beta=v), "beta") for v in ("x", True, -1.0)],
    *[(f"TipPath-{k}-{v!r}", lambda k=k, v=v: _mod("tool").TipPath(**{"kind": "circle", "size": 5e-3, "period": 1.0,
                                                                     k: v}), k)
      for k, v in (("kind", None), ("kind", "circl"), ("size", NAN), ("size", -1.0), ("size", 1e308), ("size", "5mm"),
                   ("period", 0.0), ("period", True), ("cycles", 0.0), ("z", -0.1))],
    ("parse_path-radius-huge", lambda: _path("circle:radius=1e300mm,period=2s"), "path"),
    # sweeps, report, export, results
    *[(f"load_sweep-path-{v!r}", lambda v=v: mk.load_sweep(v), "path") for v in (None, 5)],
    ("characterize-root-5", lambda: _mod("report").characterize(5), "root"),
    ("characterize-root-missing", lambda: _mod("report").characterize("nope"), "root"),
    ("characterize-progress-5", lambda: _mod("report").characterize(progress=5), "progress"),
    *[(f"summarize-char-{v!r}", lambda v=v: _mod("report").summarize(v), "char") for v in (None, 5, {})],
    ("render_html-summary-None", lambda: _mod("report").render_html(None, []), "summary"),
    ("write_report-char-None", lambda: _mod("report").write_report(None, "out"), "char"),
    *[(f"check_report_folder-{v!r}", lambda v=v: _mod("report").check_report_folder(v), "out") for v in (None, 5)],
    *[(f"export_fmu-out-{v!r}", lambda v=v: _mod("export").export_fmu(out=v), "out") for v in (None, 5)],
    *[(f"write_table-df-{v!r}", lambda v=v: _mod("results").write_table(v, "x.csv"), "df") for v in (None, 5)],
    ("read_provenance-None", lambda: _mod("results").read_provenance(None), "path"),
    ("read_provenance-missing", lambda: _mod("results").read_provenance("nope.csv"), "nope.csv"),
    ("Table.plot-ax-x", lambda: _table().plot(ax="x"), "ax"),
]


def _iso_file():
    from mckibben.datasets.isometric import BUNDLED_ISOMETRIC

    return BUNDLED_ISOMETRIC / "commercial10" / "isometric.csv"


def _iso():
    return mk.read_table(_iso_file())


def _fit_iso(**kw):
    """A fit whose other arguments are right: the isotonic campaign table, the cubic model."""
    from mckibben.datasets.campaign import BUNDLED

    return _mod("fit").fit_table(BUNDLED / "mpam97" / "isotonic.csv", "cubic", **kw)


def _frame():
    import pandas as pd

    return pd.DataFrame({"time_constant_s_median": [0.01, 0.02], "grid_id": [0, 1]})


# the experiments and the rig (found by the probe after the experiments moved)
CASES += [
    ("robustness-progress-not-callable", lambda: _mod("experiments").robustness(4, progress=5), "progress"),
    ("fig13-betas-none", lambda: _mod("experiments").fig13(betas=None), "betas"),
    ("fig13-betas-empty", lambda: _mod("experiments").fig13(betas=()), "betas"),
    ("fig13-laws-empty", lambda: _mod("experiments").fig13(laws=()), "laws"),
    ("fig13-betas-out-of-range", lambda: _mod("experiments").fig13(betas=(300.0,)), "betas"),
    ("device-port-none", lambda: _mod("rig").Device(None), "port"),
    ("device-port-number", lambda: _mod("rig").Device(5), "port"),
    ("fig13-laws-typo", lambda: _mod("experiments").fig13(laws=("mdoel",)), "laws"),
    # durations so long that duration / 1 ms overflows (found by the entry points' hypothesis test)
    ("open_loop-duration-1e305", lambda: _mod("experiments").open_loop(duration=1.8e305), "duration"),
    ("step_response-duration-1e306", lambda: _mod("experiments").step_response(duration=1e306), "duration"),
    # the sweep's summaries: a table that is not a sweep's results, and their own arguments
    ("best_setting-table-none", lambda: _mod("sweep").best_setting(None), "table"),
    ("best_setting-not-a-sweep", lambda: _mod("sweep").best_setting(_table()), "table"),
    ("best_setting-constraint-number", lambda: _mod("sweep").best_setting(_table(), constraint=5), "constraint"),
    ("best_setting-quantile-above-1", lambda: _mod("sweep").best_setting(_table(), quantile=2.0), "quantile"),
    ("settings_table-quantile-nan", lambda: _mod("sweep").settings_table(_table(), quantile=NAN), "quantile"),
    ("pareto_front-objectives-typo", lambda: _mod("sweep").pareto_front(_frame(), ["nope"]), "objectives"),
    ("pareto_front-objectives-none", lambda: _mod("sweep").pareto_front(_frame(), None), "objectives"),
    ("sensitivity-table-none", lambda: _mod("sweep").sensitivity(None), "table"),
    ("read_results-out-none", lambda: _mod("sweep").read_results(None), "out"),
    ("plot_pareto-ax-text", lambda: _mod("sweep").plot_pareto(_table(), ax="x"), "ax"),
    ("plot_sensitivity-ax-text", lambda: _mod("sweep").plot_sensitivity(_table(), ax="x"), "ax"),
    # physically impossible values that passed silently (issue 34's catalogue)
    ("plant-moving_mass-1e-308", lambda: _mod("plant").PlantParams(moving_mass=1e-308).prepare(), "moving_mass"),
    ("plant-temperature-1e-308", lambda: _mod("plant").PlantParams(temperature=1e-308).prepare(), "temperature"),
    ("plant-temperature-celsius", lambda: _mod("plant").PlantParams(temperature=20.0).prepare(), "temperature"),
    ("plant-supply-empty", lambda: _mod("plant").PlantParams(supply_pressure=[]).prepare(), "supply_pressure"),
    ("plant-supply-empty-array",
     lambda: _mod("plant").PlantParams(supply_pressure=np.array([])).prepare(), "supply_pressure"),
    ("force_from_length-length-negative", lambda: mk.force_from_length(_m(), 4e5, -0.01), "length"),
    ("force_from_length-length-zero", lambda: mk.force_from_length(_m(), 4e5, 0.0), "length"),
    ("pressure_for_length-length-zero", lambda: mk.pressure_for_length(_m(), 0.0, 0.6), "length"),
    ("pressure_for_length-length-negative", lambda: mk.pressure_for_length(_m(), [0.09, -1.0], 0.6), "length"),
    ("models.force-length-zero", lambda: _mod("models").force(4e5, 0.0, _m(), model="chou-hannaford"), "length"),
    ("models.pressure-length-zero", lambda: _mod("models").pressure(0.0, 0.6, _m()), "length"),
    ("tool-forward-lengths-nanometre",
     lambda: _mod("tool").forward(lengths=[1e-9, 1e-9, 1.1e-9]), "lengths"),
    ("tool-forward-lengths-past-strands", lambda: _mod("tool").forward(lengths=[1.0, 1.0, 0.99]), "lengths"),
]




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
# what would exhaust memory or run for minutes: each refused quickly, in a subprocess with limits

HEAVY = {
    "pressure_for_length-1e7": "mk.pressure_for_length(M, np.full(10**7, .08), .6)",
    "predict_length-1e8": "mk.predict_length(M, np.full(10**8, 4e5), 0.6)",
    "force-1e7": "models.force(5e5, np.full(10**7, 0.09), M, model='chou-hannaford')",
    "length-1e7": "models.length(np.full(10**7, 4e5), 0.6, M, model='wall-corrected')",
    "substeps-1e7": "plant.simulate(duration=0.05, substeps=10**7)",
    "tip_from_lengths-1e7": "kinematics.tip_from_lengths(np.full((10**7, 3), 0.1), 4e-3)",
    "track_pressure-1e8": "experiments.track_pressure(np.full(10**8, 4e5))",
}


def test_memory_and_time_cases_are_refused_quickly():
    got = refusals_in_subprocess("""
        import numpy as np
        import mckibben as mk
        from mckibben import experiments, models, plant
        from mckibben.tool import kinematics
        M = mk.get_muscle("mpam97")
    """, HEAVY, memory_limit=3 * 2**30)
    names = {"pressure_for_length-1e7": "length", "predict_length-1e8": "pressure", "force-1e7": "length",
             "length-1e7": "pressure", "substeps-1e7": "substeps", "tip_from_lengths-1e7": "lengths",
             "track_pressure-1e8": "reference"}
    for key, message in got.items():
        assert names[key] in message and not message.startswith(("ran", "crash")), (key, message)


# ---------------------------------------------------------------------------------------------
# a table draws itself (issue 24 item 4), once in Jupyter like a result


@pytest.mark.parametrize("kind_file", ["campaign/mpam97/isotonic.csv", "campaign/mpam97/hysteresis.csv",
                                       "campaign/mpam97/blocked_force.csv", "campaign/mpam97/step_response.parquet",
                                       "isometric/commercial10/isometric.csv"])
def test_a_table_plots_what_its_kind_measures(kind_file):
    from pathlib import Path

    from matplotlib.figure import Figure

    root = Path(_mod("datasets").__file__).parent
    table = mk.read_table(root / kind_file)
    fig = table.plot()
    assert isinstance(fig, Figure)
    ax = fig.axes[0]
    x, y, _ = _mod("data.tables")._TABLE_PLOTS[table.kind]
    assert x.replace("_", " ") in ax.get_xlabel() and y.replace("_", " ") in ax.get_ylabel()
    # every row is drawn once, in the lab's units
    drawn = np.concatenate([line.get_ydata() for line in ax.lines])
    factor = _mod("data.tables")._PLOT_SCALE[y][0]
    np.testing.assert_allclose(np.sort(drawn), np.sort(table.data[y].to_numpy() * factor))
    # on a given Axes: that Axes' figure, drawn there
    import matplotlib.pyplot as plt

    fig2, ax2 = plt.subplots()
    assert table.plot(ax=ax2) is fig2 and len(ax2.lines) == len(ax.lines)
    plt.close("all")


def test_a_table_plot_shows_once_in_jupyter(monkeypatch):
    """Under the inline backend the returned figure draws itself and leaves pyplot (as Result.plot does)."""
    import matplotlib

    monkeypatch.setattr(matplotlib, "get_backend", lambda: "module://matplotlib_inline.backend_inline")
    fig = _table().plot()
    assert hasattr(fig, "_ipython_display_")


# ---------------------------------------------------------------------------------------------
# answers that used to come back bare: now flagged


@pytest.mark.parametrize("force", [NAN, INF, -0.5, 1e308])
def test_the_tondu_lopez_inverse_flags_a_load_that_is_no_finite_pull(force):
    from mckibben.models.laws.tondu_lopez import tondu_lopez_contraction

    eps, flags = tondu_lopez_contraction(4e5, force, 2.5e-4, 0.4)
    assert int(flags) != 0, (force, eps)
    ok, none = tondu_lopez_contraction(4e5, 0.6, 2.5e-4, 0.4)
    assert int(none) == 0 and 0.0 < float(ok) < 0.3


@pytest.mark.parametrize("reference", [-1.0, 2e6, 1e308])
def test_a_reference_outside_the_rigs_range_is_flagged(reference):
    from mckibben.control.core import CoreParams, core_spec
    from mckibben.plant import PlantParams, simulate
    from mckibben.plant.simulator import FLAG_REFERENCE_OUTSIDE

    r = simulate(PlantParams(), 0.01, controller=core_spec(CoreParams(), 2), n=2,
                 reference=np.array([[5e5] * 10, [reference] * 10]))
    assert r.flags[0] & FLAG_REFERENCE_OUTSIDE == 0 and r.flags[1] & FLAG_REFERENCE_OUTSIDE


def test_values_just_inside_the_physical_limits_are_accepted():
    """The limits the catalogue holds are limits, not a wider ban: the value just inside each passes."""
    from mckibben.plant import PlantParams
    from mckibben.plant.packing import MIN_MOVING_MASS, TEMPERATURE_RANGE

    PlantParams(moving_mass=MIN_MOVING_MASS).prepare()
    PlantParams(temperature=TEMPERATURE_RANGE[0]).prepare()
    PlantParams(temperature=TEMPERATURE_RANGE[1]).prepare()
    PlantParams(supply_pressure=np.array([0.5e6])).prepare()
    m = _m()
    lo, hi = m.length_stops
    assert mk.force_from_length(m, 4e5, 1e-12).force.shape == ()  # tiny but positive: flagged, not refused
    tool = _mod("tool").make_tool()
    tlo, thi = tool.muscle.length_stops
    mid = 0.5 * (tlo + thi)
    _mod("tool").forward(tool, lengths=[mid, mid, mid])
    with pytest.raises(InputError, match="lengths"):
        _mod("tool").forward(tool, lengths=[mid, mid, thi * 1.001])


def test_a_muscle_file_with_a_nominal_length_of_1e_300_mm_is_refused(tmp_path):
    from mckibben.datasets.campaign import BUNDLED

    text = (BUNDLED / "mpam97" / "muscle.toml").read_text()
    f = tmp_path / "tiny.toml"
    f.write_text(text.replace("nominal_length_mm = 97", "nominal_length_mm = 1e-300"))
    with pytest.raises(InputError, match=r"nominal_length_mm: 1e-300 is not a plausible length"):
        mk.read_muscle(f)

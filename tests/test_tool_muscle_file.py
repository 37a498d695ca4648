"""A lab's own muscle in the three-muscle tool: ``make_tool(muscle_file=…)``, ``mckibben tool … --muscle-file``.

The muscle files are written by the real fit (``fit_isometric`` + ``save_muscle_file``, what
``mckibben fit ISO.csv --model … --save`` runs) on the bundled SYNTHETIC commercial-size isometric
campaign. The tool's statics solve the file's law for pressures and lengths; the checks go back
through the file's law as :func:`muscle_force_law` evaluates it (the fit's own function, not the
registry kernel the statics use).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import mckibben.experiments as mx
import mckibben.tool as mt
from conftest import run_cli
from mckibben.data import read_muscle, read_table
from mckibben.datasets import get_muscle
from mckibben.datasets.isometric import BUNDLED_ISOMETRIC
from mckibben.errors import InputError, UnreachableError
from mckibben.fit.isometric import fit_isometric
from mckibben.fit.muscle_file import muscle_force_law, save_muscle_file
from mckibben.hardware import P_MAX_DEFAULT
from mckibben.models.flags import Flag
from mckibben.tool import Tool, ToolGeometry
from mckibben.tool.statics import pressures_for_tip, tip_from_pressures
from mckibben.tool.tracking import muscle_plants, tip_reference
from mckibben.tool.paths import parse_path

FOLDER = BUNDLED_ISOMETRIC / "commercial10"


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    """Muscle files of fitted laws, by model name (one fit each per module)."""
    folder = tmp_path_factory.mktemp("muscles")
    table, spec = read_table(FOLDER / "isometric.csv"), read_muscle(FOLDER / "muscle.toml")
    return {m: save_muscle_file(folder / f"{m}.toml", spec, fit_isometric(table, spec, m))
            for m in ("spring", "chou-hannaford", "surface")}


def _targets(tool, n=24):
    """Tip targets inside the workspace: the forward pose of pressures spread over the box."""
    rng = np.random.default_rng(7)
    p = rng.uniform(0.05, 0.95, (n, 3)) * tool.p_max
    return tip_from_pressures(p, tool).tip


@pytest.mark.parametrize("model, direction", [("spring", "inflate"), ("spring", "deflate"),
                                              ("chou-hannaford", "inflate")])
def test_inverse_then_forward_returns_the_tip_and_the_files_law_gives_the_tensions(saved, model, direction):
    tool = mt.make_tool(muscle_file=saved[model], direction=direction)
    targets = _targets(tool)
    inv = pressures_for_tip(targets, tool)
    assert np.all(inv.reachable)
    assert np.all((inv.pressures >= 0) & (inv.pressures <= tool.p_max))
    fwd = tip_from_pressures(inv.pressures, tool)
    assert np.all(fwd.converged)
    # the forward equilibrium converges to 1e-12 m of length; the tip moves ~L/r = 8 times that
    np.testing.assert_allclose(fwd.tip, targets, rtol=0, atol=1e-10)
    # and the inverse found the pressures that made the targets (1e-3 Pa: the inverse's tolerance)
    rng = np.random.default_rng(7)
    np.testing.assert_allclose(inv.pressures, rng.uniform(0.05, 0.95, (24, 3)) * tool.p_max, rtol=0, atol=1e-3)
    # independent check: the file's law (as predict force --muscle-file evaluates it, less the
    # load cell's zero, which is the instrument's) at the pressures and lengths found gives the
    # tensions the load model asked for; rtol: the root finder's full precision
    law = muscle_force_law(read_muscle(saved[model]))
    pull = law.force(inv.pressures, inv.lengths, direction)[0] - law.parameters.get("offset_N", 0.0)
    np.testing.assert_allclose(pull, inv.tensions, rtol=1e-9)


def test_a_file_tool_is_the_papers_stack_scaled_and_spans_the_fitted_lengths(saved):
    spec = read_muscle(saved["spring"])
    law = muscle_force_law(spec)
    tool = mt.make_tool(muscle_file=saved["spring"])
    g = tool.geometry
    # the paper's 12 mm disc around a 1.2 mm muscle, scaled to the file's 12 mm muscle
    assert (g.disc_diameter, g.hole_diameter, g.channel_diameter) == pytest.approx((0.12, 0.022, 0.04), rel=1e-12)
    assert g.hole_diameter > spec.outer_diameter
    # p_max: the top of the fitted pressures (622 kPa), below the configured 0.8 MPa
    top = law.valid_range["pressure"][1]
    assert tool.p_max == top < P_MAX_DEFAULT
    # the default load model puts the straight tool at the fitted lengths' ends at 0 and p_max
    short, long_ = law.valid_range["length"]
    s = tip_from_pressures(np.array([[0.0] * 3, [tool.p_max] * 3]), tool).arc.arc_length
    np.testing.assert_allclose(s, [long_, short], rtol=1e-9)
    # the tool names its file, law and branch
    d = mt.tool_dict(tool)
    assert (d["muscle_file"], d["force_law"], d["direction"]) == (str(saved["spring"]), "spring", "inflate")
    # a lower p_max is the user's; one above the fitted top is refused, naming p_max
    assert mt.make_tool(muscle_file=saved["spring"], p_max=0.5e6).p_max == 0.5e6
    with pytest.raises(InputError, match=r"^p_max: 0\.7 MPa is above the top of the pressures .*0\.622 MPa"):
        mt.make_tool(muscle_file=saved["spring"], p_max=0.7e6)
    # a 12 mm muscle in the paper's 2.2 mm holes cannot be built
    with pytest.raises(InputError, match=r"^hole diameter: 2\.2 mm holes do not pass the 12 mm muscle commercial10"):
        Tool(tool.muscle, ToolGeometry(), tool.load, tool.p_max)


def test_no_pressure_above_p_max_in_any_answer(saved):
    tool = mt.make_tool(muscle_file=saved["spring"], p_max=0.5e6)
    ws = mt.map_workspace(tool, 7)
    assert ws.samples.pressures.max() == tool.p_max
    # targets past the workspace's faces: NaN, never a pressure above p_max
    s = ws.samples.state
    tips = np.concatenate([s.tip.reshape(-1, 3), s.tip.reshape(-1, 3) * [1.05, 1.05, 0.97]])
    p = pressures_for_tip(tips, tool).pressures
    assert np.nanmax(p) <= tool.p_max and np.isnan(p).any()
    ref = tip_reference(tool, parse_path("circle:radius=30mm,period=0.5s"))
    assert ref.pressures.max() <= tool.p_max
    with pytest.raises(InputError, match="pressures"):
        mt.forward(tool, pressures=[0.6e6, 0.0, 0.0])


def test_unreachable_targets_name_the_muscle_and_why(saved):
    tool = mt.make_tool(muscle_file=saved["spring"])
    # shorter than the muscle gets at p_max under the backbone's compression
    with pytest.raises(UnreachableError, match=r"muscle 1 \(at 0°\) would have to be .* mm under .* N, shorter than "
                                               r"its .* mm at 0\.622 MPa: more pressure than p_max"):
        mt.inverse([0.04, 0.0, 0.25], tool)
    # longer than the straight unpressurized tool: the backbone would have to pull the muscles
    with pytest.raises(UnreachableError, match=r"muscle 2 \(at 120°\) would have to push"):
        mt.inverse([0.0, 0.0, 0.31], tool)


def test_the_tracking_plant_is_the_statics_muscle(saved):
    """The tool's statics and its tracking plant run one law: the file's, the same branch."""
    for direction in ("inflate", "deflate"):
        tool = mt.make_tool(muscle_file=saved["spring"], direction=direction)
        plants = muscle_plants(tool, np.array([20.0, 40.0, 60.0]))
        name, theta = plants.law(3)
        from mckibben.models.laws import evaluate

        p, ell = np.meshgrid(np.linspace(0, tool.p_max, 5), np.linspace(0.25, 0.3, 5))
        np.testing.assert_array_equal(evaluate(name, p, ell, theta[:, 0]), tool.muscle.force(p, ell))
        assert plants.supply_pressure == tool.p_max


def test_the_miniature_tool_is_unchanged_by_the_interface():
    """The paper's tool goes through the muscle's own methods: the same functions, bit for bit."""
    from mckibben.models.mpam import predict_length, pressure_for_length

    m = get_muscle("mpam117")
    p, f = np.linspace(0, 0.8e6, 7), np.linspace(0.5, 2.5, 7)
    a, b = m.length_for_pressure(p, f), predict_length(m, p, f)
    np.testing.assert_array_equal(a.length, b.length)
    c, d = m.pressure_for_length(a.length, f, 0.8e6), pressure_for_length(m, a.length, f, 0.8e6)
    np.testing.assert_array_equal(c.pressure, d.pressure)
    assert mt.make_tool().p_max == P_MAX_DEFAULT and mt.make_tool().muscle.name == "mpam117"


def test_length_for_pressure_rests_on_the_braids_end_stops(saved):
    tool = mt.make_tool(muscle_file=saved["chou-hannaford"])
    m = tool.muscle
    lo, hi = m.length_stops
    # a Chou–Hannaford muscle pulls nothing at 0 Pa: under a tension it runs to the straight braid
    r = m.length_for_pressure(0.0, 10.0)
    assert float(r.length) == hi and r.flags & Flag.COS_THETA_ABOVE_ONE
    # a slack muscle is where it just becomes taut (CH: the locking angle)
    r = m.length_for_pressure(0.3e6, -5.0)
    assert float(r.length) == pytest.approx(lo, rel=1e-6)
    # past the end stops no pressure holds the length
    r = m.pressure_for_length(np.array([0.9 * lo, 1.01 * hi]), 10.0, tool.p_max)
    assert np.isnan(r.pressure).all() and np.all(r.flags & Flag.UNREACHABLE)


def test_cli_tool_commands_take_a_muscle_file(saved):
    f = str(saved["spring"])
    r = run_cli("tool", "ik", "--tip", "40mm,0mm,270mm", "--muscle-file", f, "--json")
    assert r.code == 0, r.err
    ik = json.loads(r.out)
    assert ik["tool"]["muscle_file"] == f and ik["reachable"]
    r = run_cli("tool", "fk", "--pressures", ",".join(f"{p}Pa" for p in ik["pressures_Pa"]), "--muscle-file", f,
                "--json")
    assert r.code == 0, r.err
    # the CLI prints pressures with repr precision: the round trip holds to the solver's 1e-9 m
    np.testing.assert_allclose(json.loads(r.out)["tip_m"], [0.04, 0.0, 0.27], atol=1e-9)
    r = run_cli("tool", "workspace", "--grid", "3", "--muscle-file", f, "--direction", "deflate", "--json")
    assert r.code == 0, r.err
    assert json.loads(r.out)["tool"]["direction"] == "deflate"
    r = run_cli("tool", "track", "--path", "circle:radius=20mm,period=1s", "--reference-only", "--muscle-file", f,
                "--json")
    assert r.code == 0, r.err
    out = json.loads(r.out)
    assert max(out["runs"][0]["reference_pressure_max_Pa"]) <= out["tool"]["p_max_Pa"] == 622e3


def test_cli_bad_muscle_files_and_options_are_one_line(saved, tmp_path):
    from test_bad_input import assert_refused

    f = str(saved["spring"])
    tip = ["tool", "ik", "--tip", "40mm,0mm,270mm"]
    assert_refused(run_cli(*tip, "--muscle-file", str(tmp_path / "nope.toml")), "--muscle-file", "nope.toml")
    assert_refused(run_cli(*tip, "--muscle-file", str(FOLDER / "muscle.toml")), "--muscle-file",
                   "no [force_model] table")
    assert_refused(run_cli("tool", "workspace", "--muscle-file", str(saved["surface"])), "--muscle-file",
                   "surface force law has no physical law")
    assert_refused(run_cli(*tip, "--muscle-file", f, "--direction", "up"), "--direction", "inflate or deflate")
    assert_refused(run_cli(*tip, "--muscle-file", str(saved["chou-hannaford"]), "--direction", "deflate"),
                   "--direction deflate", "has one branch")
    assert_refused(run_cli(*tip, "--muscle-file", f, "--muscle", "mpam97"), "--muscle-file", "not both")
    assert_refused(run_cli(*tip, "--muscle-file", f, "--p-max", "0.7MPa"), "--p-max", "fitted on")
    assert_refused(run_cli("tool", "track", "--path", "circle:radius=20mm,period=1s", "--muscle-file", f,
                           "--pitch-radius", "4mm"), "pitch radius", "use")


def test_tracking_a_circle_with_the_files_plant(saved):
    """Three plants of the file's muscle, each with its controller, follow a 20 mm circle in 1 s."""
    tool = mt.make_tool(muscle_file=saved["spring"])
    res = mx.track_tip(parse_path("circle:radius=20mm,period=1s,cycles=1"), tool=tool)
    run = res.results[0]
    assert run.faults == 0 and run.reference.max() <= tool.p_max
    # measured 0.86 mm RMS: the tracking gains are the miniature rig's, on a plant whose fill is
    # slower (identified τ ≈ 0.55 s); 2 mm is 10 % of the radius, the tip clearly follows
    assert res.metrics["rms_error_m"] < 2e-3

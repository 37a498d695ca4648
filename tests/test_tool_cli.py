"""``mckibben tool`` from the command line: answers, JSON, and bad input (exit 2, one line)."""

import numpy as np
import pytest
from numpy.testing import assert_allclose

from mckibben.datasets import get_muscle
from mckibben.tool.geometry import Tool
from mckibben.tool.kinematics import tip_from_lengths
from mckibben.tool.statics import tip_from_pressures


def test_fk_lengths_json(cli):
    r = cli("tool", "fk", "--lengths", "117mm,112mm,115mm", "--json")
    assert r.code == 0, r.err
    out = r.json()
    expected = tip_from_lengths([0.117, 0.112, 0.115], 4e-3, 12)
    assert_allclose(out["tip_m"], expected, rtol=0, atol=1e-15)  # same function, JSON round trip
    assert out["lengths_m"] == pytest.approx([0.117, 0.112, 0.115], abs=1e-12)
    # muscle 2 is the shortest: the tip bends toward 120°..240° side, nearest muscle 2
    assert np.degrees(out["bend_plane_angle_rad"]) == pytest.approx(143.41, abs=0.01)
    assert len(out["pressures_Pa"]) == 3 and out["reachable"] is True
    assert out["tool"]["pitch_radius_m"] == pytest.approx(4e-3)
    assert np.linalg.norm(out["tip_direction"]) == pytest.approx(1.0)


def test_fk_pressures_matches_library(cli):
    r = cli("tool", "fk", "--pressures", "0.4,0,0.2MPa", "--json")
    assert r.code == 0, r.err
    st = tip_from_pressures([0.4e6, 0, 0.2e6], Tool(get_muscle("mpam117")))
    assert_allclose(r.json()["tip_m"], st.tip, rtol=0, atol=1e-15)


def test_ik_round_trip_through_the_cli(cli):
    fk = cli("tool", "fk", "--pressures", "0.5,0.1,0.3MPa", "--json").json()
    x, y, z = fk["tip_m"]
    r = cli("tool", "ik", "--tip", f"{x * 1e3!r}mm,{y * 1e3!r}mm,{z * 1e3!r}mm", "--json")
    assert r.code == 0, r.err
    out = r.json()
    # repr of mm values keeps 17 digits; the pressures come back to the cubic's root precision
    assert_allclose(out["pressures_Pa"], [0.5e6, 0.1e6, 0.3e6], rtol=0, atol=1e-2)
    assert out["reachable"] is True


def test_ik_table_output(cli):
    r = cli("tool", "ik", "--tip", "20mm,0mm,110mm")
    assert r.code == 0
    assert "pressure MPa" in r.out and "muscle" in r.out


def test_options_change_the_tool(cli):
    a = cli("tool", "ik", "--tip", "20mm,0mm,110mm", "--json").json()
    b = cli("tool", "ik", "--tip", "20mm,0mm,110mm", "--pitch-radius", "4.5mm", "--discs", "continuous",
            "--preload", "1.2N", "--bending-stiffness", "150Nmm2", "--json").json()
    assert b["tool"]["pitch_radius_m"] == pytest.approx(4.5e-3)
    assert b["tool"]["n_discs"] is None
    assert b["tool"]["bending_stiffness_Nm2"] == pytest.approx(1.5e-4)
    assert b["tool"]["preload_N"] == pytest.approx(1.2)
    assert a["pressures_Pa"] != b["pressures_Pa"]


def test_workspace_json_and_plot(cli, tmp_path):
    png = tmp_path / "ws.png"
    r = cli("tool", "workspace", "--grid", "5", "--plot", str(png), "--json")
    assert r.code == 0, r.err
    out = r.json()
    assert out["samples"] == 125 and out["converged"] == 125
    assert 0.05 < out["lateral_reach_m"] < 0.125  # bent sideways, never further than the arc length
    assert out["tip_angle_max_rad"] > 1.0
    assert png.exists() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    "args, message",
    [
        (["fk", "--lengths", "117mm,112mm"], "exactly 3"),
        (["fk", "--lengths", "117mm,112mm,115mm,116mm"], "exactly 3"),
        (["fk", "--lengths", "117,112,115"], "no unit"),
        (["fk", "--lengths", "117MPa,112MPa,115MPa"], "is a pressure, but a length is wanted"),
        (["fk", "--lengths", "117mm,-112mm,115mm"], "negative"),
        (["fk"], "exactly one of --lengths or --pressures"),
        (["fk", "--lengths", "117mm,112mm,115mm", "--pressures", "0,0,0MPa"], "exactly one"),
        (["fk", "--pressures", "0.9,0,0MPa"], "above p_max"),
        (["fk", "--lengths", "117mm,112mm,115mm", "--pitch-radius", "6mm"], "pitch radius"),
        (["fk", "--lengths", "117mm,112mm,115mm", "--discs", "many"], "--discs"),
        (["fk", "--lengths", "117mm,112mm,115mm", "--bending-stiffness", "stiff"], "--bending-stiffness"),
        (["fk", "--lengths", "117mm,112mm,115mm", "--muscle", "mpam118"], "unknown muscle"),
        (["ik", "--tip", "0,0,130mm"], "unreachable: muscle 1"),
        (["ik", "--tip", "80mm,0mm,100mm"], "can only shorten"),
        (["ik", "--tip", "0mm,0mm,-50mm"], "negative z"),
        (["ik", "--tip", "1mm,2mm"], "exactly 3"),
        (["ik", "--tip", "1s,2s,3s"], "is a time"),
        (["workspace", "--grid", "1"], "grid: 1"),
    ],
)
def test_bad_input_is_one_line_exit_2(cli, args, message):
    r = cli("tool", *args)
    assert r.code == 2
    assert message in r.err
    assert r.err.count("\n") == 1 and r.out == ""


def test_workspace_plot_into_missing_folder_writes_nothing(cli, tmp_path):
    target = tmp_path / "missing" / "ws.png"
    r = cli("tool", "workspace", "--grid", "3", "--plot", str(target))
    assert r.code == 2 and "does not exist" in r.err
    assert not target.exists() and list(tmp_path.iterdir()) == []


def test_track_reference_only_json(cli):
    r = cli("tool", "track", "--path", "circle:radius=5mm,period=0.5s,cycles=1", "--periods", "0.5s,0.25s",
            "--reference-only", "--json")
    assert r.code == 0, r.err
    out = r.json()
    assert out["simulated"] is False and len(out["runs"]) == 2
    assert out["runs"][1]["mean_speed_m_per_s"] == pytest.approx(2 * np.pi * 0.005 / 0.25)
    assert out["runs"][0]["samples"] == 500
    lo, hi = out["runs"][0]["reference_pressure_min_Pa"], out["runs"][0]["reference_pressure_max_Pa"]
    assert all(0 < a < b < 0.8e6 for a, b in zip(lo, hi))


@pytest.mark.parametrize(
    "path, message",
    [
        ("circle:radius=5,period=2s", "no unit"),
        ("ellipse:radius=5mm,period=2s", "unknown path kind"),
        ("circle:period=2s", "circle needs radius"),
        ("circle:radius=60mm,period=1s", "is unreachable: muscle 1"),
    ],
)
def test_track_bad_path_exit_2(cli, path, message):
    r = cli("tool", "track", "--path", path)
    assert r.code == 2 and message in r.err and r.err.count("\n") == 1


def test_track_bad_periods_exit_2(cli):
    r = cli("tool", "track", "--path", "circle:radius=5mm,period=1s", "--periods", "1s,0s", "--reference-only")
    assert r.code == 2 and "--periods" in r.err


@pytest.mark.slow  # ~7 s: the first plant simulation in the process loads the Numba cache
def test_track_simulated_json_and_plot(cli, tmp_path):
    png = tmp_path / "track.png"
    r = cli("tool", "track", "--path", "figure8:size=8mm,period=0.25s,cycles=1", "--periods", "0.25s,0.125s",
            "--plot", str(png), "--json")
    assert r.code == 0, r.err
    out = r.json()
    assert out["simulated"] is True and out["plot"] == str(png)
    for run in out["runs"]:
        assert run["controller_faults"] == 0
        assert 0 < run["rms_error_m"] <= run["max_error_m"] < 5e-3  # mm-scale errors on an 8 mm path
    assert png.exists() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_track_bad_beta(cli):
    r = cli("tool", "track", "--path", "circle:radius=5mm,period=0.1s,cycles=1", "--beta", "0")
    assert r.code == 2 and "--beta" in r.err

"""``mckibben identify``: known parameters back from a generated log; bad input exits 2."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from mckibben.control.identify import fopdt_response


@pytest.fixture
def step_log(tmp_path):
    t = np.arange(0, 1.0, 1e-3)
    u = np.where(t >= 0.1, 200, 0)
    y = fopdt_response(t, 2500.0, 0.09, 0.01, t_step=0.1, input_step=200)
    y += np.random.default_rng(0).normal(0, 2e3, t.size)
    path = tmp_path / "step.csv"
    pd.DataFrame({"time_ms": t * 1e3, "pressure_MPa": y / 1e6, "inlet_pwm": u, "bleed_pwm": 0}).to_csv(path, index=False)
    return path


def test_identify_json_recovers_parameters(cli, step_log, tmp_path):
    png = tmp_path / "fit.png"
    r = cli("identify", str(step_log), "--order", "both", "--plot", str(png), "--json")
    assert r.code == 0, r.err
    d = r.json()
    # 2 kPa noise on a 0.5 MPa step: tau within 1 ms, dead time within 1 ms, gain within 0.5 %
    assert abs(d["time_constant_s"] - 0.09) < 1e-3
    assert abs(d["dead_time_s"] - 0.01) < 1e-3
    assert abs(d["gain_Pa_per_count"] - 2500) < 12.5
    first = d["models"][0]
    assert first["order"] == 1 and first["tau_s_stderr"] > 0 and first["input_step"] == 200
    assert png.stat().st_size > 10_000


def test_identify_parquet_and_table(cli, step_log, tmp_path):
    pq = tmp_path / "step.parquet"
    pd.read_csv(step_log).to_parquet(pq)
    r = cli("identify", str(pq))
    assert r.code == 0 and "tau_s" in r.out


@pytest.mark.parametrize(
    "content, message",
    [
        ("time_s,pressure_MPa,inlet_pwm,bleed_pwm\n0,0.1,0,0\n0.001,abc,0,0\n", ":2:pressure_MPa:"),
        ("time_s,inlet_pwm\n0,0\n", "no pressure_<unit> column"),
        ("time_s,pressure_furlong\n0,1\n", "no pressure_<unit> column"),
        ("time_s,pressure_m\n0,1\n0.1,2\n", "is a length, but a pressure is wanted"),
        ("time_s,pressure_MPa\n0,1\n0,2\n", ":2:time_s: time must be strictly increasing"),
    ],
)
def test_identify_bad_logs_exit_2(cli, tmp_path, content, message):
    path = tmp_path / "bad.csv"
    path.write_text(content)
    png = tmp_path / "out.png"
    r = cli("identify", str(path), "--plot", str(png))
    assert r.code == 2
    assert message in r.err and r.err.count("\n") == 1
    assert not png.exists()  # nothing half-written on error


def test_identify_bad_options(cli, step_log, tmp_path):
    assert "no such file" in cli("identify", str(tmp_path / "missing.csv")).err
    r = cli("identify", str(step_log), "--order", "3")
    assert r.code == 2 and "--order" in r.err
    r = cli("identify", str(step_log), "--t-step", "5kg")
    assert r.code == 2 and "--t-step" in r.err


def _plant_step_log(path, u1):
    """A step of the calibrated plant's inlet from rest to u1 counts, as the rig logs it."""
    from mckibben.plant import simulate

    n = 800
    inlet = np.r_[np.zeros(50, int), np.full(n - 50, u1)]
    r = simulate(None, n * 1e-3, inlet=inlet, n=1)
    pd.DataFrame({"time_s": r.t, "pressure_Pa": r.pressure[0], "inlet_pwm": inlet, "bleed_pwm": 0}).to_csv(
        path, index=False)
    return path


def test_identify_two_logs_gives_the_lift_off(cli, tmp_path):
    from mckibben.control.experiments import identify_plant

    a = _plant_step_log(tmp_path / "a.csv", 117)
    b = _plant_step_log(tmp_path / "b.csv", 119)
    r = cli("identify", str(a), str(b), "--json")
    assert r.code == 0, r.err
    d = r.json()
    assert len(d["logs"]) == 2 and d["logs"][0]["time_constant_s"] > 0.08
    # the same steps as identify_plant (there from rest at t = 0): the same line, to the fits' noise
    model = identify_plant()[1]
    assert abs(d["lift_off"]["lift_off_counts"] - model.lift_off) < 0.5
    # the plant's valves lift off at 0.63 · 255 / 1.43 = 112.3 counts
    assert 105 < d["lift_off"]["lift_off_counts"] < 112.3
    c = _plant_step_log(tmp_path / "c.csv", 121)
    r = cli("identify", str(a), str(b), str(c), "--json")
    lift = r.json()["lift_off"]
    assert lift["lift_off_counts_stderr"] > 0 and 100 < lift["lift_off_counts"] < 112.3


def test_identify_lift_off_bad_input(cli, tmp_path, step_log):
    a = _plant_step_log(tmp_path / "a.csv", 117)
    r = cli("identify", str(a), str(a))
    assert r.code == 2 and "different commands" in r.err and r.err.count("\n") == 1
    nocmd = tmp_path / "nocmd.csv"
    pd.read_csv(step_log).drop(columns=["inlet_pwm", "bleed_pwm"]).to_csv(nocmd, index=False)
    r = cli("identify", str(a), str(nocmd))
    assert r.code == 2 and "nocmd.csv" in r.err and "command" in r.err


def test_lift_off_outside_the_commands_is_refused(cli, tmp_path):
    # 117 counts and a wide-open 250: the map is far from one line, u0 would come out negative
    a = _plant_step_log(tmp_path / "a.csv", 117)
    sat = _plant_step_log(tmp_path / "sat.csv", 250)
    r = cli("identify", str(a), str(sat))
    assert r.code == 2 and "meets zero at" in r.err and r.err.count("\n") == 1


def test_held_command_is_the_one_after_the_step(cli, tmp_path):
    # a log that shuts the valve for its last samples still pairs its step with 119 counts
    a = _plant_step_log(tmp_path / "a.csv", 117)
    b = _plant_step_log(tmp_path / "b.csv", 119)
    both = cli("identify", str(a), str(b), "--json").json()["lift_off"]
    df = pd.read_csv(b)
    df.loc[df.index[-20:], "inlet_pwm"] = 0
    df.to_csv(tmp_path / "b_shut.csv", index=False)
    r = cli("identify", str(a), str(tmp_path / "b_shut.csv"), "--json")
    assert r.code == 0, r.err
    assert r.json()["lift_off"]["commands_pwm"] == [117.0, 119.0]
    assert abs(r.json()["lift_off"]["lift_off_counts"] - both["lift_off_counts"]) < 1.0

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
        ("time_s,pressure_MPa\n0,1\n0.1,2\n0.05,2\n", ":3:time_s: time goes back within trial 1"),
        ("time_s,pressure_MPa\n0,1\n0,2\n", ":time_s: needs at least two time stamps"),
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
    from mckibben.control.runs import identify_plant

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


# --- real logs: the project's step_response tables, repeated time stamps, supply, fills -------------


def test_identify_reads_the_campaigns_six_trial_table(cli):
    from mckibben.datasets.campaign import BUNDLED, STEP_TIME, TAU

    r = cli("identify", str(BUNDLED / "mpam97" / "step_response.parquet"), "--json")
    assert r.code == 0, r.err
    d = r.json()
    assert d["n_trials"] == 6 and d["columns"]["command"] == "command"
    for t in d["trials"]:
        m = t["models"][0]
        # the step is at 0.05 s, found from the command column (not t = 0: 49.6 ms of false dead
        # time before); the generator has no dead time: within one 5 ms sample
        assert m["t_step_s"] == pytest.approx(STEP_TIME) and m["dead_time_s"] < 5e-3
        assert m["flags"] == []  # a first-order log fitted by a first-order model: nothing to flag
    pooled = d["pooled"]["1"]
    assert pooled["n_trials"] == 6
    lo, hi = pooled["tau_s"]["ci95"]
    assert lo <= TAU <= hi  # the generating time constant, within the interval across trials
    # gain per unit command: 0.8 MPa full scale (campaign README), 2 kPa noise -> within 0.5 %
    assert pooled["gain"]["mean"] == pytest.approx(0.8e6, rel=5e-3)


def test_identify_averages_repeated_time_stamps(cli, tmp_path):
    # a 2 kHz log with a millisecond clock: every stamp twice
    t = np.arange(0, 0.6, 5e-4)
    y = fopdt_response(t, 0.5e6, 0.09, 0.02, 0.08e6, t_step=0.1)
    y += np.random.default_rng(1).normal(0, 2e3, t.size)
    path = tmp_path / "ms.csv"
    pd.DataFrame({"time_ms": np.floor(t * 1e3), "pressure_Pa": y,
                  "command": np.where(t >= 0.1, 1.0, 0.0)}).to_csv(path, index=False)
    r = cli("identify", str(path), "--json")
    assert r.code == 0, r.err
    d = r.json()
    assert d["notes"] and "averaged" in d["notes"][0]
    # a dead time of 20 ms after a step at 0.1 s: within 1.5 ms (the 1 ms clock plus the averaging)
    assert d["dead_time_s"] == pytest.approx(0.02, abs=1.5e-3)


def _fill_log(tmp_path, supply=620e3, b=0.3, tau=0.25, dead=0.015):
    from mckibben.control.identify import fill_response

    t = np.arange(0, 1.0, 2e-3)
    y = fill_response(t, 0.0, supply, tau, b, dead, t_step=0.1) + np.random.default_rng(2).normal(0, 1e3, t.size)
    path = tmp_path / "fill.csv"
    pd.DataFrame({"time_s": t, "pressure_kPa": y / 1e3, "command": np.where(t >= 0.1, 1.0, 0.0)}).to_csv(path, index=False)
    return path


def test_fill_from_a_supply_first_order_is_flagged_and_bounded(cli, tmp_path):
    path = _fill_log(tmp_path)
    r = cli("identify", str(path), "--order", "all", "--supply", "620kPa", "--json")
    assert r.code == 0
    d = r.json()
    first, second, fill = d["models"]
    assert first["p_final"] <= 620e3 * (1 + 1e-9)  # never above its supply
    assert "residual_runs" in first["flags"]  # the ramp-then-bend is not a first-order step
    assert fill["flags"] == [] and d["best_order"] == "fill"
    # the generating fill back: b within 0.03 and tau_fill within 3 % (1 kPa noise on 620 kPa)
    assert fill["b"] == pytest.approx(0.3, abs=0.03) and fill["tau_fill_s"] == pytest.approx(0.25, rel=0.03)
    assert fill["dead_time_s"] == pytest.approx(0.015, abs=3e-3)
    assert r.err.startswith("warning: identify: flagged:") and r.err.count("\n") == 1


def test_second_order_at_its_damping_bound_is_flagged(cli, step_log):
    # a first-order log: the second-order fit runs to its largest damping ratio (20), and says so
    r = cli("identify", str(step_log), "--order", "2", "--json")
    assert r.code == 0
    m = r.json()["models"][0]
    assert m["zeta"] == pytest.approx(20.0, rel=1e-3) and m["flags"] == ["zeta_at_upper_bound"]
    assert "zeta_at_upper_bound" in r.err

"""mckibben rig characterize against both device engines: the issue's bar, the kill -9 / --resume bar, safety.

Real ptys, the real image in simavr (avr engine, unthrottled) and the Python emulator; the bench
side channel changes the loads (--unattended); the command runs as a user runs it (in-process for
the bar, in its own process for the kill -9).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from mckibben.data import read_table
from mckibben.data.io import read_muscle
from mckibben.examples import copy_example
from mckibben.models.muscle import Muscle
from mckibben.models.static import length as static_length
from mckibben.plant import params as PP
from mckibben.plant.simulator import static_branch_lengths as plant_branch_lengths
from mckibben.plant.simulator import static_length as plant_static_length
from mckibben.rig.bench import Bench
from mckibben.rig.characterize import (CharacterizeStopped, _moving, collect_steps, read_protocol, run_characterization,
                                      run_protocol)
from mckibben.errors import UnreachableError

from conftest import DEVICE_ENGINES, _avr_engine_missing, run_cli, start_device

MUSCLE = str(Path(__file__).resolve().parents[1] / "src" / "mckibben" / "datasets" / "campaign" / "mpam97"
             / "muscle.toml")


def _device(engine, **kw):
    return start_device(engine, n_channels=1, boot_time=0.1, **({"unthrottled": True} if engine == "avr" else {}),
                        **kw)


@pytest.fixture(scope="module", params=DEVICE_ENGINES)
def bar_run(request, tmp_path_factory):
    """The example protocol, unattended, on one engine: the folder, the JSON summary, the protocol."""
    engine = request.param
    if engine == "avr" and _avr_engine_missing():
        pytest.skip(_avr_engine_missing())
    tmp = tmp_path_factory.mktemp(f"bar-{engine}")
    proto = copy_example("characterize.toml", tmp)
    out = tmp / "run"
    with _device(engine) as dev:
        r = run_cli("rig", "characterize", "--port", dev.port, "--protocol", str(proto), "--out", str(out),
                    "--unattended", "--json", "--muscle-file", MUSCLE)
    assert r.code == 0, r.err
    return engine, out, r.json(), read_protocol(proto)


#: Motion from the vented length past which the muscle file is held to the issue's 2 % (see the bar test). [m]
MOVED = 5e-3


def _grid(out, moved=1.5 * 0.17e-3, below=np.inf):
    """The run's (set-point, load) pairs where both branches moved from the vented length by at least ``moved``
    (and the first by less than ``below``) and the plant has a static length, with that length."""
    steps = collect_steps(out)
    pts = []
    for (f, p), g in steps.groupby(["load_N", "set_point_Pa"]):
        rest = steps[(steps["load_N"] == f) & (steps["step"] == 0)]["length_m"].mean()
        motion = rest - g["length_m"].to_numpy()
        if p == 0 or motion.min() <= moved or motion.min() >= below:
            continue
        try:
            pts.append((float(p), float(f), float(plant_static_length(PP.PlantParams(load_force=f), p)[0])))
        except UnreachableError:  # the muscle rests on a stop: no static length to match
            continue
    return pts


def _predict(muscle_toml, grid):
    m = Muscle.from_spec(read_muscle(muscle_toml))
    return np.array([float(static_length(np.array([p]), f, m, None).length[0]) for p, f, _ in grid])


@pytest.mark.slow
def test_bar_unattended_run_fits_a_muscle_file_that_matches_the_plant(bar_run):
    engine, out, summary, proto = bar_run
    assert summary["load_steps"] == summary["load_steps_expected"] == len(proto.loads) * proto.trials
    # the tables are the project's kinds, readable by read_table and by mckibben fit
    for kind in ("isotonic", "hysteresis"):
        t = read_table(out / f"{kind}.csv")
        assert t.kind == kind and len(t.data) == len(proto.loads) * proto.trials * len(proto.sweep)
    assert (out / "isotonic.csv.provenance.json").is_file()
    r = run_cli("fit", str(out / "isotonic.csv"), "--model", "surface", "--json")
    assert r.code == 0, r.err
    # no recorded pressure (any telemetry frame of any step) above the configured maximum
    steps = pd.read_parquet(out / "steps.parquet")
    assert steps["pressure_max_Pa"].max() <= proto.max_pressure
    assert summary["report"] and Path(summary["report"]).is_file()
    # the command line gives the same number as the library for one point
    grid = _grid(out, MOVED)
    assert len(grid) >= 15, grid
    pred = _predict(out / "muscle.toml", grid)
    p, f, _ = grid[len(grid) // 2]
    r = run_cli("predict", "length", "--muscle-file", str(out / "muscle.toml"), "--pressure", f"{p}Pa",
                "--load", f"{f}N", "--json")
    assert r.code == 0 and r.json()["length_m"] == pytest.approx(pred[len(grid) // 2], rel=1e-9)
    # mckibben predict length with D/muscle.toml vs the emulated plant's static length (friction-free)
    everywhere = _grid(out)
    pred_all = _predict(out / "muscle.toml", everywhere)
    plant_all = np.array([g[2] for g in everywhere])
    err_all = np.abs(pred_all - plant_all) / plant_all
    plant = np.array([g[2] for g in grid])
    err = np.abs(pred - plant) / plant
    worst = sorted(zip(np.round(err_all * 100, 2), [(round(p / 1e6, 3), round(f, 2)) for p, f, _ in everywhere]),
                   reverse=True)
    print(f"{engine}: best law {summary['fit']['best']}; moved >= 5 mm: {len(grid)} points, max error "
          f"{err.max() * 100:.2f} %; everywhere the muscle moved: {len(everywhere)} points, worst (%, (MPa, N)) "
          f"{worst[:5]}")
    # the bar: 2 % of the plant's static length everywhere the muscle moved. Met since the laws carry the
    # tube's stretch past the rest length (models/tube.py): the plant pulls with it, and a quarter of the protocol
    # hangs the muscle past its rest length. Ramped (the example): 1.30-1.44 % Python, 1.21-1.28 % avr, three runs
    # each, worst at the top of the sweep (0.759 MPa, 0.6 N: visited once, on its inflating branch); stepped 0.8 %
    assert err_all.max() <= 0.02, worst
    assert np.all(err <= 0.02), worst


def _gaps(out):
    """Per load, at the run's set-points where both branches moved off the vented length and the plant's both branches
    are off its stops: the set-points and the up/down gaps (inflating less deflating length) of the plant (its Dahl
    slip limit, from its own parameters), of the muscle file (``--branch``) and measured (trials' mean). [Pa], [m]"""
    steps = collect_steps(out)
    steps = steps.assign(moved=_moving(steps))
    m = Muscle.from_spec(read_muscle(out / "muscle.toml"))
    gaps = {}
    for f, g in steps.groupby("load_N"):
        rows = []
        for p, h in g.groupby("set_point_Pa"):
            if p == 0 or not h["moved"].all() or set(h["direction"]) != {"inflate", "deflate"}:
                continue
            try:
                up, down = plant_branch_lengths(PP.PlantParams(load_force=f), p)
            except UnreachableError:  # a branch rests on a stop: the plant has no loop there to compare
                continue
            file_up, file_down = (float(m.length_for_pressure(p, f, b).length) for b in ("inflate", "deflate"))
            meas = h.groupby("direction")["length_m"].mean()
            rows.append((p, float(up[0] - down[0]), file_up - file_down, meas["inflate"] - meas["deflate"]))
        if rows:
            gaps[float(f)] = np.array(rows)
    return gaps


@pytest.mark.slow
def test_bar_hysteresis_model_reproduces_the_gap(bar_run):
    engine, out, summary, _ = bar_run
    fit = summary["fit"]
    # the model that holds across loads: the muscle file's law with its friction, law -/+ A_f.P = load, one A_f,
    # fitted with the law held at the branches' mean on the loop's width at each set-point, each branch point where
    # its braid slipped; the constant part F_0 fitted beside it (on the branches and on the width) is reported, not
    # written
    assert "error" not in fit["friction"] and fit["friction"]["friction_area_m2"] > 0, fit["friction"]
    assert np.isfinite(fit["friction"]["with_constant"]["friction_force_N"]), fit["friction"]
    gaps = _gaps(out)
    assert len(gaps) == 5 and all(len(a) >= 4 for a in gaps.values()), gaps
    # the bar: per load, the mean gap of the muscle file within 20 % of the plant's over those set-points
    rel = {f: abs(a[:, 2].mean() - a[:, 1].mean()) / a[:, 1].mean() for f, a in gaps.items()}
    pi = {h["load_N"]: h["prandtl_ishlinskii"].get("gap_model_m", np.nan) for h in fit["hysteresis"].values()
          if "error" not in h}
    wc, ow = fit["friction"]["with_constant"], fit["friction"]["on_width"]
    # F_0 and A_f on the loop's width, reported: both terms finite, one width per set-point both branches visited
    assert np.isfinite([ow["friction_force_N"], ow["friction_area_m2"]]).all() and ow["n_widths"] >= 20, ow
    print(f"{engine}: A_f = {fit['friction']['friction_area_m2']:.3g} m2 ({fit['best']}; fitted with F_0: F_0 "
          f"{wc['friction_force_N'] * 1e3:.0f} mN, A_f {wc['friction_area_m2']:.3g} m2; on the loop's width: F_0 "
          f"{ow['friction_force_N'] * 1e3:.0f} mN, A_f {ow['friction_area_m2']:.3g} m2); up/down gap per load [mm] "
          f"over its set-points: " + ", ".join(
              f"{f:.2f} N ({len(a)}): plant {a[:, 1].mean() * 1e3:.2f}, file {a[:, 2].mean() * 1e3:.2f} "
              f"({rel[f] * 100:.0f} %), measured {a[:, 3].mean() * 1e3:.2f}, PI of the load "
              f"{pi.get(f, np.nan) * 1e3:.2f}" for f, a in gaps.items()))
    # a regression guard kept from when the bar was an expected failure: 24-50 % on avr with single-frame slip
    # pressures, 8-21 % with A_f fitted on each branch
    assert max(rel.values()) <= 0.30, rel
    # the bar. Measured (docs/rig.md, benchmarks/RESULTS.md), the example ramped at 0.25 MPa/s, each branch
    # point at the extreme of the pressure averaged over 20 ms (slip_pressure), A_f fitted on the loop's width,
    # worst load per run: avr 5-9 % in eight runs, Python 4-7 % in six runs (before, A_f on each branch: avr 6-21 %, Python 7-19 %)
    assert max(rel.values()) <= 0.20, (f"{engine}: the muscle file's up/down gap is off the plant's by "
                                       + ", ".join(f"{f:.2f} N {r * 100:.0f} %" for f, r in rel.items()))


@pytest.mark.slow
def test_kill_9_then_resume_keeps_every_load_step_once(bar_run, tmp_path):
    engine, full, _, proto = bar_run
    if engine == "python" and not _avr_engine_missing():
        # CI's time: the journal and --resume are the host's, alike for both engines; the avr engine runs
        # unthrottled (20 s here, the real-time Python engine 35 s)
        pytest.skip("kill -9 / --resume runs on the avr engine where it is available")
    copy = copy_example("characterize.toml", tmp_path)
    out = tmp_path / "run"
    with _device(engine) as dev:
        cmd = [sys.executable, "-m", "mckibben.cli", "rig", "characterize", "--port", dev.port, "--protocol",
               str(copy), "--out", str(out), "--unattended", "--json", "--muscle-file", MUSCLE]
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)})
        journal = out / "steps.journal"
        end = time.monotonic() + 240
        while time.monotonic() < end and len(list(journal.glob("part-*.parquet"))) < 2 and proc.poll() is None:
            time.sleep(0.05)
        code = proc.poll()  # None: still running, as it should be
        proc.send_signal(signal.SIGKILL)  # halfway: two load steps done, the third under way
        _, err = proc.communicate()
        kept = sorted(p.name for p in journal.glob("part-*.parquet"))
        assert 2 <= len(kept) < len(proto.loads), (kept, code, err.decode(errors="replace")[-2000:])
        assert not (out / "muscle.toml").exists()
        r = run_cli("rig", "characterize", "--port", dev.port, "--protocol", str(copy), "--out", str(out),
                    "--unattended", "--json", "--muscle-file", MUSCLE, "--resume")
    assert r.code == 0, r.err
    steps = collect_steps(out)
    counts = steps.groupby(["load_index", "trial"]).size()
    assert sorted(counts.index) == [(i, t) for i, t, _ in proto.load_steps()]  # every load step exactly once
    assert (counts == len(proto.sweep)).all()  # each complete
    assert len(read_table(out / "hysteresis.csv").data) == len(steps)
    grid = _grid(full, MOVED)
    a, b = _predict(out / "muscle.toml", grid), _predict(full / "muscle.toml", grid)
    rel = float(np.max(np.abs(a - b) / b))
    print(f"{engine}: resumed vs uninterrupted: max {rel * 100:.3f} %")
    # the bar: 1 %. Two sessions of one bench now read one length alike (both engines count the encoder
    # from the reset, the avr harness no longer drops counts after it): 0.13-0.51 % measured on the avr engine
    # (ramped, the law held at the static fit; 0.10-0.35 % stepped)
    assert rel <= 0.01


@pytest.mark.slow
def test_ctrl_c_vents_and_keeps_what_was_measured(tmp_path):
    proto = read_protocol(copy_example("characterize.toml", tmp_path))
    asked = []

    def operator(text):
        asked.append(text)
        if len(asked) == 3:  # Ctrl-C at the second load's prompt
            raise KeyboardInterrupt
        if "length" in text:
            return "99.98mm"
        return ""

    with _device("python") as dev:
        with pytest.raises(CharacterizeStopped, match="stopped by the operator; valves vented; 1 load steps kept"):
            run_characterization(dev.port, proto, tmp_path / "run", prompt=operator)
        assert "hang 61 g" in asked[0] and "Ctrl-C" in asked[0]
        time.sleep(0.5)
        assert Bench.of_port(dev.port).state().pressure < 5e3  # vented
    assert len(collect_steps(tmp_path / "run")) == len(proto.sweep)


@pytest.mark.parametrize("fault, words", [
    ({"hold_adc": 400}, "stopped: "),  # a stuck sensor: the firmware's sensor_stuck fault or the runner's check
    ({"plant": PP.PlantParams(leak_conductance=5e-9)}, "stopped: "),
])
def test_safety_stops_vented_with_one_line(tmp_path, fault, words):
    with _device("python", **fault) as dev:
        r = run_cli("rig", "characterize", "--port", dev.port, "--protocol",
                    str(copy_example("characterize.toml", tmp_path)), "--out", str(tmp_path / "run"), "--unattended")
        assert r.code == 2 and words in r.err and "valves vented" in r.err, r.err
        assert len(r.err.strip().splitlines()) == 1 and "Traceback" not in r.err
        print(r.err.strip())


@pytest.mark.slow
def test_attended_run_without_an_operator_stops_vented(tmp_path):
    with _device("python") as dev:  # the command in its own process, its standard input closed (as in CI)
        r = subprocess.run([sys.executable, "-m", "mckibben.cli", "rig", "characterize", "--port", dev.port,
                            "--protocol", str(copy_example("characterize.toml", tmp_path)), "--out",
                            str(tmp_path / "run")], stdin=subprocess.DEVNULL, capture_output=True, text=True,
                           env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}, timeout=120)
    err = r.stderr.strip().splitlines()[-1]
    assert r.returncode == 2 and "no operator to answer" in err and "Traceback" not in r.stderr, r.stderr


def test_bad_input_is_refused_before_anything_moves(tmp_path):
    proto = copy_example("characterize.toml", tmp_path)
    bad = tmp_path / "bad.toml"
    bad.write_text(proto.read_text().replace('hold = "0.1s"', 'hold = "fast"'))
    full = tmp_path / "full"
    full.mkdir()
    (full / "x").write_text("")
    cases = [
        (["--protocol", str(bad), "--out", str(tmp_path / "a")], f"{bad}:"),
        (["--protocol", str(proto), "--out", str(full)], "not empty"),
        (["--protocol", str(proto), "--out", str(tmp_path / "b"), "--resume"], "no run to resume"),
        (["--protocol", str(proto), "--out", str(tmp_path / "c"), "--muscle-file", str(tmp_path / "none.toml")],
         "none.toml"),
        (["--protocol", str(proto), "--out", str(tmp_path / "d"), "--unattended"], "no bench socket"),
    ]
    for args, words in cases:
        r = run_cli("rig", "characterize", "--port", "/dev/null", *args)
        assert r.code == 2 and words in r.err and "Traceback" not in r.err, (args, r.err)
        assert len(r.err.strip().splitlines()) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.toml", "characterize.toml", "full"]  # nothing written


@pytest.mark.slow  # two loads in real time: ~30 s on a loaded machine
def test_a_rig_with_a_load_cell_is_tared_at_the_start_of_each_run(tmp_path):
    # the cell reads 0.3 N with nothing on it: each run tares it (vented, the weight off) and the steps' force is
    # the muscle's tension less that zero, which a hanging load at rest pulls
    from mckibben.hardware import LoadCell

    proto_file = tmp_path / "p.toml"
    proto_file.write_text('[protocol]\nname = "tare"\ntrials = 1\nmax_pressure = "0.8MPa"\n'
                          '[isotonic]\nloads = ["61g", "150g"]\npressures = { from = "0MPa", to = "0.6MPa", steps = 3 }\n'
                          'hold = "0.1s"\n[settling]\nwindow = "0.08s"\ntolerance = "0.2mm"\ntimeout = "2s"\n')
    proto = read_protocol(proto_file)
    with _device("python", load_cell=LoadCell(5.0, 0.3, 0.002)) as dev:
        meta = run_protocol(dev.port, proto, tmp_path / "run", unattended=True)
    tares = meta["load_cell_tares"]
    assert [(t["load_index"], t["trial"]) for t in tares] == [(0, 1), (1, 1)]
    # the cell's zero, and the braid friction's hold on a vented muscle (the plant's 0.01 N)
    assert all(t["force_offset_N"] == pytest.approx(0.3, abs=0.02) for t in tares), tares
    steps = collect_steps(tmp_path / "run")
    moved = steps[steps["pressure_Pa"] > 0.4e6]
    assert len(moved) >= 2
    # the tension is the load to within the braid's friction (the plant's Dahl limit) and the cell's counts
    pp = PP.PlantParams()
    limit = pp.friction_force + pp.friction_per_pa * moved["pressure_Pa"] + 0.02
    assert np.all(np.abs(moved["force_N"] - moved["load_N"]) <= limit), moved[["load_N", "force_N"]]
    assert moved["force_N"].notna().all()


@pytest.mark.slow  # two short sweeps in real time on the Python engine: 9-10 s
def test_a_ramped_step_does_not_overshoot_where_a_stepped_one_does(tmp_path):
    # one load, 0 -> 0.4 MPa and back, on the Python engine: stepped, the device's sliding-mode controller
    # overshoots each inflating step (its reference feed-forward sees the whole step in one period: 46-175 kPa
    # measured on 63-190 kPa steps); ramped at 0.25 MPa/s the recorded pressure stays within the controller's own
    # ripple when it holds a set-point (5-12 kPa measured at 0.19-0.57 MPa, docs/rig.md), here 25 kPa
    text = ('[protocol]\nname = "ramp"\nmax_pressure = "0.8MPa"\n[isotonic]\nloads = ["100g"]\n'
            'pressures = ["0MPa", "0.4MPa"]\nhold = "0.1s"\n{ramp}'
            '[settling]\nwindow = "0.08s"\ntolerance = "0.2mm"\ntimeout = "1s"\n')
    over = {}
    with _device("python") as dev:
        for name, ramp in (("step", ""), ("ramp", 'ramp = "0.25MPa/s"\n')):
            f = tmp_path / f"{name}.toml"
            f.write_text(text.replace("{ramp}", ramp))
            run_protocol(dev.port, read_protocol(f), tmp_path / name, unattended=True)
            steps = collect_steps(tmp_path / name)
            up = steps[(steps["direction"] == "inflate") & (steps["set_point_Pa"] > 0)]
            assert len(up) == 1
            over[name] = (up["pressure_max_Pa"] - up["set_point_Pa"]).to_numpy()
            assert steps["pressure_max_Pa"].max() <= 0.8e6
    print({k: np.round(v / 1e3, 1).tolist() for k, v in over.items()})
    assert over["ramp"].max() <= 25e3, over
    assert over["step"].max() >= 40e3, over


def test_slip_pressure_is_the_extreme_of_the_pressure_averaged_over_the_muscles_response():
    from mckibben.rig.characterize import SLIP_SMOOTHING, _slip_pressures, slip_pressure

    # a held set-point rippling +/-15 kPa every other frame at 100 Hz (the avr controller's): one frame's extreme is
    # 15 kPa past the hold, the average over the muscle's response is not
    t = np.arange(40) * 0.01
    p = 0.4e6 + 15e3 * np.where(np.arange(40) % 2, 1.0, -1.0)
    assert SLIP_SMOOTHING >= 0.02  # two frames or more at 100 Hz
    assert abs(slip_pressure(t, p, "inflate") - 0.4e6) < 15e3 / 2
    assert abs(slip_pressure(t, p, "deflate") - 0.4e6) < 15e3 / 2
    # a ramp up to a hold: inflating the braid slipped at the top, the hold
    ramp = np.r_[np.linspace(0.3e6, 0.4e6, 50), np.full(10, 0.4e6)]
    t_r = np.r_[np.arange(50) * 0.002, 0.1 + np.arange(1, 11) * 0.01]
    assert slip_pressure(t_r, ramp, "inflate") == pytest.approx(0.4e6, rel=1e-12)
    down = np.r_[np.linspace(0.4e6, 0.3e6, 50), np.full(10, 0.3e6)]
    assert slip_pressure(t_r, down, "deflate") == pytest.approx(0.3e6, rel=1e-12)
    for args, words in (((t, p, "sideways"), "direction"), ((t[:3], p, "inflate"), "pressure")):
        with pytest.raises(ValueError, match=words):
            slip_pressure(*args)
    # a journal recorded before the slip pressure was kept: the step's extreme on its branch, else its mean
    steps = pd.DataFrame({"direction": ["inflate", "inflate", "deflate"], "pressure_Pa": [1e5, 2e5, 1e5],
                          "pressure_max_Pa": [1.1e5, 2.2e5, 1.5e5], "pressure_min_Pa": [0.5e5, 1.8e5, 0.9e5],
                          "pressure_slip_Pa": [1.05e5, np.nan, 0.95e5]})
    np.testing.assert_array_equal(_slip_pressures(steps), [1.05e5, 2.2e5, 0.95e5])
    old = steps.drop(columns=["pressure_slip_Pa", "pressure_min_Pa"])
    np.testing.assert_array_equal(_slip_pressures(old), [1.1e5, 2.2e5, 1e5])

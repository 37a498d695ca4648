"""``mckibben control``: bad input is refused (exit 2, one line) before any simulation runs."""

from __future__ import annotations

import pytest

from mckibben.control.registry import EXTENSIONS


@pytest.mark.parametrize(
    "args, message",
    [
        (("control", "step", "--controller", "smx"), "unknown controller 'smx'. Did you mean smc?"),
        (("control", "step", "--beta", "300"), "--beta"),
        (("control", "step", "--eps", "5N"), "--eps"),
        (("control", "step", "--ki", "-1"), "--ki"),
        (("control", "step", "--target", "fast"), "--target"),
        (("control", "step", "--target", "0MPa"), "no step"),
        (("control", "step", "--plot", "out.xyz"), "--plot"),
        (("control", "step", "--out", "out.xlsx"), "--out"),
        (("control", "step", "--dpi", "0"), "--dpi"),
        (("control", "fig13", "--out", "/no/such/dir/f.csv"), "--out"),
        (("control", "step", "--law", "papr"), "unknown --law 'papr'. Did you mean paper?"),
        (("control", "track", "--reference", "sine:0.4MPa,0.1MPa,2Hz", "--law", "x"), "--law"),
        (("control", "compare", "--beta", "-5"), "--beta"),
        (("control", "track", "--reference", "sine:0.4MPa,0.1MPa"), "sine:MEAN,AMPLITUDE,FREQUENCY"),
        (("control", "track", "--reference", "sine:0.4MPa,0.1MPa,0Hz"), "--reference frequency"),
        (("control", "robustness", "--n", "0"), "--n"),
        (("control", "fig13", "--ki", "nan"), "--ki"),
    ],
)
def test_bad_input_exits_2(cli, args, message):
    r = cli(*args)
    assert r.code == 2
    assert message in r.err and r.err.count("\n") == 1


def test_missing_reference_file(cli, tmp_path):
    r = cli("control", "track", "--reference", str(tmp_path / "none.csv"))
    assert r.code == 2 and "no such file" in r.err


def test_step_json_reports_the_law_and_the_lift_off(cli):
    r = cli("control", "step", "--law", "paper", "--beta", "150", "--duration", "0.3s", "--json")
    assert r.code == 0, r.err
    d = r.json()
    assert d["gains"]["law"] == "paper" and d["gains"]["g_Pa_per_count"] == 0.0
    assert d["time_constant_s"] <= 0.015  # the paper's β = 150, as in Fig. 13
    r = cli("control", "step", "--duration", "0.3s", "--json")
    d = r.json()
    assert d["gains"]["law"] == "model" and d["gains"]["beta_counts"] == 50.0
    assert 100 < d["model"]["lift_off_counts"] < 115 and d["gains"]["lift_off_counts"] == d["model"]["lift_off_counts"]


def test_fig13_and_robustness_plots_are_written(cli, tmp_path):
    png = tmp_path / "fig13.png"
    r = cli("control", "fig13", "--plot", str(png))
    assert r.code == 0, r.err
    assert "paper" in r.out and png.stat().st_size > 20_000  # responses and the τ(β) sweep
    png = tmp_path / "rob.png"
    r = cli("control", "robustness", "--n", "4", "--plot", str(png), "--json")
    assert r.code == 0, r.err
    assert set(r.json()["summary"]) == {"pid", "smc", "smc_paper", *(c.name for c in EXTENSIONS)} and png.stat().st_size > 10_000
    assert not list(tmp_path.glob("*.tmp*"))  # written atomically, nothing left behind

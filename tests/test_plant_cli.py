"""``mckibben simulate`` from the command line."""

import pytest


def test_calibration_from_the_cli(cli):
    r = cli("simulate", "calibrate", "--json")
    assert r.code == 0, r.err
    c = r.json()
    assert 0.08 <= c["time_constant_s"] <= 0.10  # §IV.A, accepted band of the issue
    assert c["overshoot_pct"] < 1.0  # "no overshoot"
    assert c["blocked_force_N"] == pytest.approx(4.2, rel=0.10)  # §III.A, within 10 %
    assert c["length_m"] == pytest.approx(78.1e-3, rel=0.10)  # eq. 2+3, within 10 %
    assert c["final_pressure_Pa"] > 0 and c["pass"] is True


def test_open_loop_with_plot(cli, tmp_path):
    png = tmp_path / "step.png"
    r = cli("simulate", "open-loop", "--valve", "150", "--duration", "0.5s", "--plot", str(png), "--json")
    assert r.code == 0, r.err
    out = r.json()
    assert png.stat().st_size > 10_000
    # a large step fills faster than the calibration step and ends at the supply
    assert out["time_constant_s"] < 0.05
    assert out["final_pressure_Pa"] == pytest.approx(0.8e6, rel=0.03)
    # the calibration step (the default): τ ≈ 0.09 s, as the paper's open-loop step (§IV.A)
    r = cli("simulate", "open-loop", "--json")
    assert r.code == 0 and 0.08 <= r.json()["time_constant_s"] <= 0.10
    # below the valves' lift-off (112 counts) nothing flows: no time constant, not an error
    r = cli("simulate", "open-loop", "--valve", "40", "--json")
    assert r.code == 0 and r.json()["time_constant_s"] is None and r.json()["final_pressure_Pa"] < 1e3


@pytest.mark.parametrize(
    "args, message",
    [
        (["--valve", "300"], "error: --valve: 300 must be a PWM count in 0..255"),
        (["--duration", "0.5"], "error: --duration: '0.5' has no unit; write it with one of s, ms, us, min (e.g. 0.5s, 20ms)"),
        (["--duration", "0.5005s"], "error: --duration: '0.5005s' must be a whole number of 1 ms control periods"),
        (["--supply", "2MPa"], "error: --supply: '2MPa' is above the compressor's 1 MPa"),
        (["--load", "-1N"], "error: --load: '-1N' is negative; a force here must be >= 0"),
        (["--plot", "out.txt"], "error: --plot: 'out.txt' must end in .avif, .eps, .gif"),  # any Matplotlib format
        (["--plot", "/no/such/dir/a.png"], "error: --plot: folder '/no/such/dir' does not exist"),
    ],
)
def test_bad_input(cli, args, message):
    r = cli("simulate", "open-loop", *args)
    assert r.code == 2 and r.out == ""
    assert r.err.startswith(message) and r.err.count("\n") == 1

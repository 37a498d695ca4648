"""The command line of the foundation: params, predict, errors."""

import numpy as np
import pytest


def test_worked_example_from_the_cli(cli):
    r = cli("predict", "length", "--muscle", "mpam97", "--pressure", "0.8MPa", "--load", "0.6N", "--json")
    assert r.code == 0, r.err
    out = r.json()
    assert out["length_m"] == pytest.approx(78.1e-3, abs=0.05e-3)  # NOTES.md, printed to 0.1 mm
    assert out["contraction"] == pytest.approx(0.195, abs=5e-4)
    assert out["cos_theta"] == pytest.approx(0.7508, abs=1e-12)
    assert out["flags"] == []


def test_several_pressures_give_arrays(cli):
    out = cli("predict", "length", "--pressure", "0:0.8MPa:9", "--json").json()
    assert len(out["length_m"]) == 9
    assert out["flags"][0] == ["cos_theta_above_one"]
    r = cli("predict", "length", "--pressure", "0.2,0.5MPa", "--muscle", "mpam117", "--load", "2.1N")
    assert r.code == 0 and "mpam117 under 2.1 N" in r.out


def test_inverse_from_the_cli(cli):
    out = cli("predict", "pressure", "--muscle", "mpam97", "--length", "78.132432mm", "--load", "0.6N", "--json").json()
    assert out["pressure_Pa"] == pytest.approx(0.8e6, rel=1e-6)
    out = cli("predict", "pressure", "--length", "70mm,85mm", "--json").json()
    assert out["pressure_Pa"][0] is None and out["flags"][0] == ["unreachable"]


def test_length_and_pressure_from_any_law_with_a_published_set(cli):
    # the default is the braid map (eq. 2 + 3); --model solves another law for the length
    base = cli("predict", "length", "--pressure", "0.8MPa", "--json").json()
    out = cli("predict", "length", "--model", "braid-map", "--pressure", "0.8MPa", "--json").json()
    assert out == base and out["model"] == "braid-map"
    out = cli("predict", "length", "--model", "chou-hannaford", "--pressure", "0.8MPa", "--json").json()
    assert out["model"] == "chou-hannaford" and out["flags"] == []
    force = cli("predict", "force", "--model", "chou-hannaford", "--pressure", "0.8MPa",
                "--length", f"{out['length_m'] * 1e3!r}mm", "--json").json()
    assert force["force_N"] == pytest.approx(0.6, rel=1e-9)  # the law pulls the load at the length it gives
    back = cli("predict", "pressure", "--model", "chou-hannaford", "--length", f"{out['length_m'] * 1e3!r}mm",
               "--json").json()
    assert back["pressure_Pa"] == pytest.approx(0.8e6, rel=1e-9)
    r = cli("predict", "length", "--model", "mpam", "--pressure", "0.8MPa", "--json")
    assert r.code == 0 and r.json()["length_m"] == base["length_m"]
    assert "'mpam' is deprecated; use 'braid-map'" in r.err  # the old name, read with a deprecation note


def test_force_from_the_cli(cli):
    out = cli("predict", "force", "--model", "chou-hannaford", "--pressure", "0.8MPa", "--json").json()
    assert out["force_N"] == pytest.approx(10.72, abs=0.01)
    out = cli("predict", "force", "--model", "tondu-lopez", "--pressure", "0.8MPa", "--json").json()
    assert out["force_N"] == pytest.approx(10.72, abs=0.01)  # equal to Chou–Hannaford at rest
    out = cli("predict", "force", "--model", "wall-corrected", "--pressure", "0.8MPa", "--json").json()
    assert out["force_N"] == pytest.approx(7.00, abs=0.01)
    out = cli("predict", "force", "--model", "empirical", "--pressure", "0.4,0.8MPa", "--json").json()
    assert len(out["force_N"]) == 2


def test_force_length_and_pressure_of_a_law_with_its_own_published_set(cli):
    # hunt-quinn has no parameters for a catalogue miniature muscle, but a published set of its own
    # (datasets.LAW_SETS): --model LAW takes it, as does --muscle SET; the numbers are the set's own
    from mckibben.datasets import LAW_SETS

    law, hq = LAW_SETS["festo-dmsp10-189"]
    out = cli("predict", "force", "--model", "hunt-quinn", "--pressure", "0.2,0.5,0.7MPa", "--length", "180mm",
              "--json").json()
    assert out["model"] == law == "hunt-quinn" and out["muscle"] == "festo-dmsp10-189"
    np.testing.assert_array_equal(out["force_N"], hq.force([0.2e6, 0.5e6, 0.7e6], 0.18))  # the same kernel: same bits
    assert out["flags"] == [[], [], ["pressure_out_of_range"]]  # the set was identified on 0-620 kPa
    same = cli("predict", "force", "--muscle", "festo-dmsp10-189", "--pressure", "0.2,0.5,0.7MPa", "--length", "180mm",
               "--json").json()
    assert same == out
    rest = cli("predict", "force", "--model", "hunt-quinn", "--pressure", "0.5MPa", "--json").json()
    assert rest["length_m"] == hq.rest_length and rest["force_N"] == float(hq.force(0.5e6, hq.rest_length))
    # its length under a load is where its force pulls the load, and the pressure for that length the same
    ell = cli("predict", "length", "--model", "hunt-quinn", "--pressure", "0.5MPa", "--load", "100N", "--json").json()
    assert ell["flags"] == [] and float(hq.force(0.5e6, ell["length_m"])) == pytest.approx(100.0, rel=1e-9)
    back = cli("predict", "pressure", "--muscle", "festo-dmsp10-189", "--length", f"{ell['length_m'] * 1e3!r}mm",
               "--load", "100N", "--json").json()
    assert back["pressure_Pa"] == pytest.approx(0.5e6, rel=1e-9)
    # the model as published gives the pressure back from the force at that length (P(ε, F), its own form)
    assert float(hq.pressure(100.0, ell["length_m"])) == pytest.approx(0.5e6, rel=1e-9)


def test_params(cli):
    out = cli("params", "list", "--json").json()
    names = [p["name"] for p in out["parameter_sets"]]
    assert names[:3] == ["mpam97", "mpam117", "mpam143"] and "spring-pam-a" in names
    out = cli("params", "show", "mpam143", "--json").json()
    assert out["strand_length_m"] == pytest.approx(0.175) and out["k2_m"] == pytest.approx(4.19e-3)
    assert out["cos_theta_cubics"][0]["coefficients_P3_P2_P1_P0_P_in_MPa"] == [0.8, -1.2, 0.34, 0.87]
    out = cli("params", "show", "spring-pam-b", "--json").json()
    assert "unreadable" in out["structure"]["coefficients"]
    assert cli("params", "show", "mpam117").code == 0


@pytest.mark.parametrize(
    "args, message",
    [
        (["predict", "length", "--muscle", "mpam98", "--pressure", "1MPa"],
         "error: unknown muscle 'mpam98'. Did you mean mpam97, mpam143, mpam117? Provide one of: festo-dmsp10-189, mpam117, mpam143, mpam97"),
        (["predict", "length", "--pressure", "0.8"],
         "error: --pressure: '0.8' has no unit; write it with one of Pa, kPa, MPa, bar, mbar, psi (e.g. 0.8MPa, 80psi, 5bar)"),
        (["predict", "length", "--pressure", "97mm"],
         "error: --pressure: unit 'mm' is a length, but a pressure is wanted (use one of Pa, kPa, MPa, bar, mbar, psi)"),
        (["predict", "length", "--pressure", "nanMPa"], "error: --pressure: 'nanMPa' is not a finite number"),
        (["predict", "length", "--pressure", "-0.2MPa"], "error: --pressure: '-0.2MPa' is negative; a pressure here must be >= 0"),
        (["predict", "length", "--pressure", "0.5MPa", "--load", "-1N"], "error: --load: '-1N' is negative; a force here must be >= 0"),
        (["predict", "pressure", "--length", "0mm"], "error: --length: '0mm' is zero; a length here must be > 0"),
        (["predict", "pressure", "--length", "80mm", "--p-max", "3furlongs"],
         "error: --p-max: unknown unit 'furlongs'; use one of Pa, kPa, MPa, bar, mbar, psi"),
        (["predict", "force", "--model", "hill", "--pressure", "1MPa"],
         "error: unknown force model 'hill'. Provide one of: braid-map, chou-hannaford, hunt-quinn, tondu-lopez, wall-corrected"),
        (["predict", "force", "--pressure", "1MPa", "--braid-angle", "95deg"], "error: --braid-angle: '95deg' must be below 90deg"),
        (["params", "show", "spring-pam-z"], "error: unknown parameter set 'spring-pam-z'. Did you mean spring-pam-c, spring-pam-b, spring-pam-a?"),
        (["predict", "length", "--pressure", "1MPa", "--model", "hill"],
         "error: unknown --model 'hill'. Provide one of: braid-map, chou-hannaford, hunt-quinn, tondu-lopez, wall-corrected"),
        (["predict", "pressure", "--length", "80mm", "--model", "virtual-work"],
         "error: --model: virtual-work has no published parameters for a catalogue muscle; fit it"),
        (["predict", "force", "--model", "hunt-quinn", "--muscle", "mpam97", "--pressure", "0.5MPa"],
         "error: --muscle: 'mpam97': the hunt-quinn law's published parameters are the set(s) festo-dmsp10-189, not a "
         "catalogue muscle's; give --muscle festo-dmsp10-189 or leave it out"),
        (["predict", "length", "--model", "chou-hannaford", "--muscle", "festo-dmsp10-189", "--pressure", "0.5MPa"],
         "error: --model: chou-hannaford is not the law of the published set festo-dmsp10-189 (hunt-quinn); leave "
         "--model out or give --model hunt-quinn"),
        (["predict", "force", "--muscle", "festo-dmsp10-189", "--pressure", "0.5MPa", "--wall", "1mm"],
         "error: --wall: the published set festo-dmsp10-189 carries its own hunt-quinn constants for its 189 mm "
         "muscle; --wall changes a catalogue miniature muscle only"),
        (["predict", "length", "--pressure", "1MPa", "--model", "spring", "--muscle-file", "F.toml"],
         "error: --model: 'spring' with --muscle-file: the file carries its own fitted law; give one of them"),
        (["predict", "pressure", "--length", "80mm", "--muscle-file", "no-such-file.toml"], "error: "),
        (["predict", "length", "--pressure", "1MPa", "--bogus"], "error: mckibben predict length: No such option: --bogus"),
        (["predict", "length"], "error: mckibben predict length: Missing option '--pressure'."),
    ],
)
def test_bad_input_gives_one_line_and_exit_2(cli, args, message):
    r = cli(*args)
    assert r.code == 2
    assert r.out == ""
    assert r.err.count("\n") == 1 and r.err.startswith(message)


def test_reproduce_prints_the_published_tables(cli, tmp_path):
    r = cli("reproduce", "--out", str(tmp_path / "report"), "--json")
    assert r.code == 0
    tables = r.json()["length_tables"]
    assert tables["mpam97@0.6N"]["length_m"][-1] == pytest.approx(78.13e-3, abs=0.01e-3)
    assert np.isclose(tables["mpam117@2.1N"]["pressure_Pa"][-1], 0.8e6)

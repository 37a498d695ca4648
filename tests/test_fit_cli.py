"""`mckibben fit` and `mckibben compare` from the command line: JSON results and one-line errors."""

import numpy as np
import pytest

from mckibben.datasets.campaign import BUNDLED
from mckibben.models.laws import fit_laws

MUSCLE = 'id = "mpam117"\nnominal_length_mm = 117\nouter_diameter_mm = 1.2\nstrand_length_mm = 145\nbraid_angle_deg = 20\n'


def test_kinematic_fit_from_a_two_column_csv(cli, tmp_path):
    # eq. 2 with Table I's mpam117 values and a length error of 0.8 mm (the paper's)
    r = np.random.default_rng(1)
    angle = np.arange(18, 42, 1.0)
    length = 0.88 * 145 * np.cos(np.deg2rad(angle)) + 1.09 + r.normal(0, 0.8, angle.size)
    lines = ["braid_angle_deg,length_mm"] + [f"{a:.1f},{ell:.2f}" for a, ell in zip(angle, length)]
    (tmp_path / "photos.csv").write_text("\n".join(lines) + "\n")
    (tmp_path / "m117.toml").write_text(MUSCLE)
    res = cli("fit", str(tmp_path / "photos.csv"), "--model", "kinematic", "--muscle-file", str(tmp_path / "m117.toml"), "--json")
    assert res.code == 0, res.err
    out = res.json()
    k1, k2 = out["parameters"]["k1"], out["parameters"]["k2_m"]
    se1, se2 = out["stderr"]["k1"], out["stderr"]["k2_m"]
    assert 0 < se1 < 0.05 and 0 < se2 < 5e-3
    assert out["ci95"]["k1"][0] <= 0.88 <= out["ci95"]["k1"][1]  # this seed's interval holds the truth
    assert out["ci95"]["k2_m"][0] <= 1.09e-3 <= out["ci95"]["k2_m"][1]
    assert out["n_points"] == angle.size and out["dof"] == angle.size - 2
    assert out["valid_range"]["cos_theta"][1] == pytest.approx(np.cos(np.deg2rad(18)), abs=1e-12)
    assert out["synthetic"] is False and out["kind"] == "braid_angle"
    assert k1 == pytest.approx(0.88, abs=4 * se1) and k2 == pytest.approx(1.09e-3, abs=4 * se2)


def test_fit_prints_a_table_and_marks_synthetic(cli):
    r = cli("fit", str(BUNDLED / "mpam97" / "blocked_force.csv"), "--model", "cubic")
    assert r.code == 0 and "SYNTHETIC" in r.out and "c3_N_per_MPa3" in r.out


def test_fit_json_on_the_bundled_spring_data(cli):
    r = cli("fit", str(BUNDLED / "mpam143" / "force_length.csv"), "--model", "spring", "--json")
    assert r.code == 0
    out = r.json()
    assert out["synthetic"] is True and len(out["blocks"]) == 4 and len(out["parameters"]) == 19
    assert out["r2"] > 0.99  # the loops are generated from this model with 10 mN noise on forces up to 3 N


@pytest.mark.parametrize("args, message", [
    (["--model", "kinematik"], "error: unknown model 'kinematik'. Did you mean kinematic?"),
    (["--model", "kinematic"], "error: fit kinematic: needs a braid_angle table; {iso} is a isotonic table"),
    (["--model", "first-order"], "error: fit first-order: needs a step_response table; {iso} is a isotonic table"),
])
def test_fit_refuses_with_one_line(cli, tmp_path, args, message):
    iso = tmp_path / "isotonic.csv"
    iso.write_text("pressure_MPa,load_N,length_mm\n0.1,0.6,100\n0.2,0.6,99\n")
    (tmp_path / "muscle.toml").write_text(MUSCLE)
    r = cli("fit", str(iso), *args)
    assert r.code == 2 and r.out == ""
    assert r.err.count("\n") == 1 and r.err.startswith(message.format(iso=iso))


def test_fit_needs_a_muscle_file(cli, tmp_path):
    (tmp_path / "a.csv").write_text("braid_angle_deg,length_mm\n20,100\n25,98\n30,95\n")
    r = cli("fit", str(tmp_path / "a.csv"), "--model", "kinematic")
    assert r.code == 2
    assert r.err == (f"error: fit kinematic: needs a muscle file; give --muscle-file FILE.toml or put muscle.toml beside"
                     f" {tmp_path / 'a.csv'}\n")


def test_fit_bad_cell_is_one_line_with_exit_2(cli, tmp_path):
    (tmp_path / "a.csv").write_text("braid_angle_deg,length_mm\n20,100\n25,ninety\n30,95\n")
    r = cli("fit", str(tmp_path / "a.csv"), "--model", "kinematic", "--json")
    assert r.code == 2 and r.out == ""
    assert r.err == f"error: {tmp_path / 'a.csv'}: row 2 (line 3), column length_mm: 'ninety' is not a number\n"


def test_fit_too_few_pressures_from_the_cli(cli, tmp_path):
    (tmp_path / "bf.csv").write_text("pressure_psi,force_N\n0,0\n10,0.2\n20,0.5\n30,0.9\n")
    r = cli("fit", str(tmp_path / "bf.csv"), "--model", "cubic")
    assert r.code == 2
    assert r.err == (f"error: fit cubic on {tmp_path / 'bf.csv'}: 4 distinct pressures; a cubic in pressure"
                     " (4 coefficients and a check of its fit) needs at least 5\n")


def test_compare_on_a_bundled_muscle(cli):
    r = cli("compare", str(BUNDLED / "mpam117"), "--json")
    assert r.code == 0, r.err
    out = r.json()
    models = {m["model"]: m for m in out["models"]}
    # the fixed models and every registered law with a fit spec (the others through their force)
    assert set(models) == {"paper (eq. 2+3)", "cubic per load", "surface", "spring", "chou-hannaford", "tondu-lopez",
                           "gaussian process", *fit_laws()}
    assert out["cv_method"] == "leave one load out" and out["synthetic"] is True
    # the data are generated from the paper's model with 0.3 mm trial scatter and 0.17 mm encoder
    # counts: the models that contain it fit to about that noise; the physical baselines do not
    for name in ("cubic per load", "surface", "paper (eq. 2+3)"):
        assert models[name]["rmse_m"] < 0.5e-3 and models[name]["within_20pct"] > 0.9
    assert models["chou-hannaford"]["rmse_m"] > 2e-3


def test_compare_refuses_other_kinds(cli):
    r = cli("compare", str(BUNDLED / "mpam97" / "blocked_force.csv"))
    assert r.code == 2
    assert r.err == (f"error: compare: needs an isotonic table (length under loads vs pressure);"
                     f" {BUNDLED / 'mpam97' / 'blocked_force.csv'} is a blocked_force table\n")


def test_datasets_generate_and_list(cli, tmp_path):
    r = cli("datasets", "generate", "--out", str(tmp_path / "c"), "--seed", "3", "--json")
    assert r.code == 0 and r.json()["synthetic"] is True
    assert (tmp_path / "c" / "mpam143" / "step_response.parquet").is_file()
    r = cli("datasets", "list", "--json")
    files = r.json()["files"]
    assert r.code == 0 and len(files) == 19  # 3 muscles x 6 tables + the commercial isometric test
    assert [f["synthetic"] for f in files if f["kind"] == "isometric"] == [True]
    r = cli("datasets", "generate", "--out", str(tmp_path / "c"), "--seed", "-1")
    assert r.code == 2 and r.err == "error: --seed: -1 must be >= 0\n"


def test_isotonic_fits_accept_measured_loads(cli, tmp_path):
    # a load cell reads the hanging weights (0.6 .. 2.1 N, sd 5 mN) and a transducer the pressure set
    # points (sd 1 kPa): every value differs, yet the set points are clear
    from mckibben.models.physical import BraidGeometry, length_under_load

    r = np.random.default_rng(4)
    geom = BraidGeometry.from_initial(0.117, 1.1e-3, np.deg2rad(20))
    p_set = np.tile(np.linspace(0.1e6, 0.8e6, 8), 6)
    f_set = np.repeat([0.6, 0.9, 1.2, 1.5, 1.8, 2.1], 8)
    p = p_set + r.normal(0, 1e3, p_set.size)
    f = f_set + r.normal(0, 5e-3, f_set.size)
    ell, _ = length_under_load(p, f, geom)
    (tmp_path / "isotonic.csv").write_text("pressure_kPa,load_N,length_mm\n" + "".join(
        f"{a / 1e3:.3f},{b:.4f},{c * 1e3:.3f}\n" for a, b, c in zip(p, f, ell)))
    (tmp_path / "muscle.toml").write_text(MUSCLE)
    res = cli("fit", str(tmp_path / "isotonic.csv"), "--model", "cubic", "--json")
    assert res.code == 0, res.err
    loads = [fit["condition"]["load_N"] for fit in res.json()["fits"]]
    # six groups, each centred on its set weight (the mean of 8 readings of sd 5 mN: within 6 mN)
    np.testing.assert_allclose(loads, [0.6, 0.9, 1.2, 1.5, 1.8, 2.1], atol=6e-3)
    res = cli("fit", str(tmp_path / "isotonic.csv"), "--model", "force-contraction", "--json")
    assert res.code == 0, res.err
    assert len(res.json()["fits"]) == 8  # one cubic per pressure set point


def test_isotonic_chou_hannaford_is_bounded_and_flagged(cli):
    # the ideal braid cannot explain the miniature muscle (wall, elasticity, friction: 000 §III); the
    # fit used to exit 0 with R2 = -0.73 and a strand shorter than the muscle, unflagged. It is the
    # law's own fit spec through its force (F(P, L) = load), as on an isometric table
    r = cli("fit", str(BUNDLED / "mpam117" / "isotonic.csv"), "--model", "chou-hannaford", "--json")
    assert r.code == 0
    out = r.json()
    assert out["response"] == "force_N" and set(out["parameters"]) == {"d0_m", "offset_N"}  # θ0 from the muscle file
    assert 0.5 * 1.2e-3 <= out["parameters"]["d0_m"] <= 4 * 1.2e-3
    assert out["flags"] and "r2_below_0.5" in out["flags"]
    assert r.err.startswith("warning: fit chou-hannaford on") and r.err.count("\n") == 1


@pytest.mark.parametrize("command", [["fit", str(BUNDLED / "mpam97" / "blocked_force.csv"), "--model", "cubic"],
                                     ["compare", str(BUNDLED / "mpam117")]])
def test_fit_and_compare_draw_their_figure(cli, tmp_path, command):
    import json

    from PIL import Image

    out = tmp_path / "fig.png"
    r = cli(*command, "--plot", str(out))
    assert r.code == 0, r.err
    prov = json.loads(Image.open(out).text["Description"])  # with where it came from
    assert prov["call"].startswith("mckibben.fit.registry.") and prov["command"].startswith(f"mckibben {command[0]} ")


def test_fit_refuses_a_figure_it_cannot_write_before_fitting(cli, tmp_path):
    r = cli("fit", str(BUNDLED / "mpam97" / "blocked_force.csv"), "--model", "cubic", "--plot", str(tmp_path / "f.xyz"))
    assert r.code == 2 and "--plot" in r.err and not list(tmp_path.iterdir())


@pytest.mark.parametrize("header, message", [
    ("pressure_MPa;force_N", "the file looks separated by ';'"),
    ("pressure_MPa\tforce_N", "the file looks separated by tabs"),
    ("presure_MPa,force_N", "the unknown column presure_MPa (did you mean pressure_MPa?) may be it"),
])
def test_a_misnamed_or_misseparated_header_gets_a_hint(cli, tmp_path, header, message):
    (tmp_path / "blocked_force.csv").write_text(header + "\n")
    (tmp_path / "muscle.toml").write_text(MUSCLE)
    r = cli("fit", str(tmp_path / "blocked_force.csv"), "--model", "cubic")
    assert r.code == 2 and message in r.err, r.err


def test_a_misnamed_column_is_kept_aside_with_a_hint(cli, tmp_path):
    f = tmp_path / "blocked_force.csv"
    f.write_text("pressure_MPa,force_N,tral\n" + "".join(f"{p / 10:g},{2 * p + p ** 2 / 10},1\n" for p in range(8)))
    (tmp_path / "muscle.toml").write_text(MUSCLE)
    r = cli("fit", str(f), "--model", "cubic", "--json")
    assert r.code == 0, r.err
    assert f"note: {f}: column tral (did you mean trial?) is unknown: kept aside, not read; known columns are " in r.err
    assert r.json()["notes"][0].startswith(f"{f}: column tral (did you mean trial?) is unknown")


def test_the_muscle_file_is_muscle_file_and_the_old_spelling_warns(cli, tmp_path):
    (tmp_path / "m117.toml").write_text(MUSCLE)
    photos = tmp_path / "photos.csv"
    photos.write_text("braid_angle_deg,length_mm\n" + "".join(f"{a},{0.88 * 145 * np.cos(np.deg2rad(a)) + 1:.2f}\n"
                                                               for a in range(18, 40, 2)))
    new = cli("fit", str(photos), "--model", "kinematic", "--muscle-file", str(tmp_path / "m117.toml"), "--json")
    assert new.code == 0 and new.err == "", new.err
    old = cli("fit", str(photos), "--model", "kinematic", "--muscle", str(tmp_path / "m117.toml"), "--json")
    assert old.code == 0 and old.json() == new.json()
    assert old.err == (f"warning: fit --muscle FILE is deprecated: use --muscle-file {tmp_path / 'm117.toml'} "
                       "(--muscle names a published parameter set in every command)\n")


@pytest.mark.parametrize("args, message", [
    (["--muscle", "mpam117"], "error: --muscle: fit reads a muscle file (TOML), not a published parameter set; give "
                              "--muscle-file FILE.toml ('mpam117' is not a .toml file)\n"),
    (["--muscle", "a.toml", "--muscle-file", "b.toml"],
     "error: --muscle: given with --muscle-file; in fit --muscle is the old spelling of --muscle-file: keep "
     "--muscle-file\n"),
])
def test_fit_muscle_flags_bad_input(cli, tmp_path, args, message):
    r = cli("fit", str(BUNDLED / "mpam97" / "blocked_force.csv"), "--model", "cubic", *args)
    assert r.code == 2 and r.err == message and r.out == ""


@pytest.mark.parametrize("command, hint", [
    (["predict", "force", "--pressure", "0.3MPa"], "give a muscle file with --muscle-file mine.toml"),
    (["predict", "length", "--pressure", "0.3MPa"], "give a muscle file with --muscle-file mine.toml"),
    (["export", "fmu", "--out", "x.fmu"], "give a muscle file with --muscle-file mine.toml"),
    (["tool", "fk", "--lengths", "117mm,112mm,115mm"], "give a muscle file with --muscle-file mine.toml"),
])
def test_muscle_names_a_published_set_in_every_command(cli, command, hint):
    r = cli(*command, "--muscle", "mine.toml")
    assert r.code == 2 and r.out == "" and r.err.count("\n") == 1
    assert r.err.startswith("error: --muscle: 'mine.toml' is a file; --muscle names a published parameter set "
                            "(mckibben params list); ") and hint in r.err, r.err

"""Reading and validating experiment tables and muscle files: every bad input has its exact message."""

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from mckibben.data import check_muscle, read_muscle, read_table
from mckibben.errors import InputError
from mckibben.units import G_N

MUSCLE = 'id = "m97"\nnominal_length_mm = 97\nouter_diameter_mm = 1.2\nstrand_length_mm = 112\nbraid_angle_deg = 20\n'


def _write(tmp_path: Path, name: str, text: str) -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def test_units_are_converted_to_si(tmp_path):
    p = _write(tmp_path, "a.csv", "pressure_psi,load_g,length_mm,trial\n10,60,97.1,1\n20,60,96.0,2\n")
    t = read_table(p)
    assert t.kind == "isotonic"
    # exact conversions: psi by definition, grams times standard gravity
    np.testing.assert_allclose(t.data["pressure"], [68947.57293168361, 137895.14586336722], rtol=1e-12)
    np.testing.assert_allclose(t.data["load"], 0.060 * G_N, rtol=1e-12)
    np.testing.assert_allclose(t.data["length"], [0.0971, 0.0960], rtol=1e-12)
    assert list(t.data.index) == [1, 2]  # 1-based data rows


def test_parquet_is_read_like_csv(tmp_path):
    df = pd.DataFrame({"braid_angle_deg": [20.0, 25.0, 30.0], "length_mm": [97.0, 94.0, 90.0]})
    df.to_parquet(tmp_path / "photos.parquet")
    t = read_table(tmp_path / "photos.parquet")
    assert t.kind == "braid_angle"
    np.testing.assert_allclose(t.data["braid_angle"], np.deg2rad([20, 25, 30]), rtol=1e-12)


BAD_TABLES = [
    ("missing.csv", "pressure_MPa,length_mm\n0.1,90\n",
     "missing.csv: missing column load_<unit> (e.g. load_N): no experiment kind matches the columns"
     " (closest: isotonic, which needs pressure, load, length)"),
    ("isotonic.csv", "pressure_MPa,length_mm\n0.1,90\n",
     "isotonic.csv: missing column load_<unit> (e.g. load_N); a isotonic table needs pressure, load, length"),
    ("typo.csv", "presure_MPa,load_N,length_mm\n0.1,0.6,90\n",
     "typo.csv: missing column pressure_<unit> (e.g. pressure_MPa): no experiment kind matches the columns"
     " (closest: isotonic, which needs pressure, load, length); the unknown column presure_MPa (did you mean"
     " pressure_MPa?) may be it"),
    ("other.csv", "pressure_MPa,load_N,length_mm,time_s\n0.1,0.6,90,0\n",
     "other.csv: column time_s is not part of the isotonic schema (required: pressure, load, length;"
     " optional: trial, muscle)"),
    ("unit.csv", "pressure_atm,load_N,length_mm\n0.1,0.6,90\n",
     "unit.csv: column pressure_atm: unknown unit 'atm' for pressure; use one of Pa, kPa, MPa, bar, mbar, psi"),
    ("dim.csv", "pressure_mm,load_N,length_mm\n0.1,0.6,90\n",
     "dim.csv: column pressure_mm: unit 'mm' is a length, not a pressure; use one of Pa, kPa, MPa, bar, mbar, psi"),
    ("text.csv", "pressure_MPa,load_N,length_mm\n0.1,0.6,90\n0.2,abc,89\n",
     "text.csv: row 2 (line 3), column load_N: 'abc' is not a number"),
    ("nan.csv", "pressure_MPa,load_N,length_mm\n0.1,0.6,nan\n",
     "nan.csv: row 1 (line 2), column length_mm: value is missing (NaN)"),
    ("inf.csv", "pressure_MPa,load_N,length_mm\n0.1,0.6,inf\n",
     "inf.csv: row 1 (line 2), column length_mm: 'inf' is not a finite number"),
    ("empty.csv", "pressure_MPa,load_N,length_mm\n0.1,,90\n",
     "empty.csv: row 1 (line 2), column load_N: value is missing"),
    ("negp.csv", "pressure_MPa,load_N,length_mm\n0.1,0.6,90\n-0.1,0.6,90\n",
     "negp.csv: row 2 (line 3), column pressure_MPa: -0.1 is negative; a gauge pressure must be >= 0"),
    ("negload.csv", "pressure_MPa,load_g,length_mm\n0.1,-60,90\n",
     "negload.csv: row 1 (line 2), column load_g: -60 is negative; a hanging load must be >= 0"),
    ("dir.csv", "pressure_MPa,load_N,length_mm,direction\n0.1,0.6,90,up\n",
     "dir.csv: row 1 (line 2), column direction: 'up' is not a direction; use inflate or deflate"),
    ("time.csv", "time_s,pressure_kPa,command,trial\n0,80,0.1,1\n0.01,80,0.1,1\n0.01,81,0.4,1\n",
     "time.csv: row 3 (line 4), column time_s: time 0.01 does not increase (row 2 has 0.01);"
     " time must increase within each trial"),
    ("trial.csv", "pressure_MPa,force_N,trial\n0.1,0.6,1.5\n",
     "trial.csv: row 1 (line 2), column trial: 1.5 is not a whole number (trials are counted 1, 2, ...)"),
    ("first.csv", "pressure_MPa,load_N,length_mm\n0.1,0.6,x\n-1,y,90\n",
     "first.csv: row 1 (line 2), column length_mm: 'x' is not a number"),  # lowest row first
]


@pytest.mark.parametrize("name, text, message", BAD_TABLES, ids=[b[0] for b in BAD_TABLES])
def test_bad_table_message(tmp_path, name, text, message):
    with pytest.raises(InputError) as exc:
        read_table(_write(tmp_path, name, text))
    assert str(exc.value) == message.replace(name, str(tmp_path / name), 1)


def test_parquet_rows_have_no_line_numbers(tmp_path):
    pd.DataFrame({"pressure_MPa": [0.1, np.nan], "force_N": [1.0, 2.0]}).to_parquet(tmp_path / "bf.parquet")
    with pytest.raises(InputError) as exc:
        read_table(tmp_path / "bf.parquet")
    assert str(exc.value) == f"{tmp_path / 'bf.parquet'}: row 2, column pressure_MPa: value is missing (NaN)"


BAD_MUSCLES = [
    ('nominal_length_mm = 97\nstrand_length_mm = 112\n', 'key id: missing; give the muscle an id, e.g. id = "mpam97"'),
    ('id = "a"\nstrand_length_mm = 112\n', "key nominal_length_<unit> missing (e.g. nominal_length_mm = ...)"),
    ('id = "a"\nnominal_length_mm = 97\nstrand_length_furlong = 1\n',
     "key strand_length_furlong: unknown unit 'furlong' for strand_length; use one of m, cm, mm, um, in"),
    ('id = "a"\nnominal_length_mm = -97\nstrand_length_mm = 112\n', "key nominal_length_mm: -97 is not a positive number"),
    ('id = "a"\nnominal_length_mm = 97\nouter_diameter_mm = 1.2\nstrand_length_mm = 90\n',
     "key strand_length: 90 mm is shorter than the nominal length 97 mm; a braid strand is at least as long as the muscle (eq. 1)"),
    ('id = "a"\ncolour = "red"\n', "key 'colour' is unknown; known keys are nominal_length_<unit>, strand_length_<unit>,"
     " outer_diameter_<unit>, tube_inner_diameter_<unit>, tube_outer_diameter_<unit>, strand_diameter_<unit>,"
     " braid_angle_<unit>, id, notes, synthetic, force_model"),
    ('id = "a"\nnominal_length_mm = 97\n', "key outer_diameter_<unit> missing (e.g. outer_diameter_mm = ...)"),
    ('id = "a"\nnominal_length_mm = 97\nouter_diameter_mm = 12\n[force_model]\nmodel = "spring"\n',
     "key force_model.parameters: missing; a fitted force law needs its parameters"),
]


@pytest.mark.parametrize("text, message", BAD_MUSCLES)
def test_bad_muscle_message(tmp_path, text, message):
    p = _write(tmp_path, "m.toml", text)
    with pytest.raises(InputError) as exc:
        read_muscle(p)
    assert str(exc.value) == f"{p}: {message}"


def test_muscle_file_that_does_not_match(tmp_path):
    m = read_muscle(_write(tmp_path, "m.toml", MUSCLE))
    assert m.strand_length == pytest.approx(0.112) and m.braid_angle == pytest.approx(np.deg2rad(20))
    t = read_table(_write(tmp_path, "a.csv", "braid_angle_deg,length_mm,muscle\n20,97,m117\n25,95,m117\n"))
    with pytest.raises(InputError) as exc:
        check_muscle(t, m)
    assert str(exc.value) == (f"{tmp_path / 'a.csv'}: row 1 (line 2), column muscle: 'm117' does not match muscle file"
                              f" {tmp_path / 'm.toml'} (id 'm97')")
    # a table of several muscles, the file's among them: pick its rows
    t = read_table(_write(tmp_path, "a.csv", "braid_angle_deg,length_mm,muscle\n20,97,m97\n25,95,m117\n"))
    with pytest.raises(InputError) as exc:
        check_muscle(t, m)
    assert str(exc.value) == (f"{tmp_path / 'a.csv'}: column muscle: holds 2 muscles (m97, m117); pick the one of "
                              f"muscle file {tmp_path / 'm.toml'} with `select` muscle=m97")
    check_muscle(read_table(tmp_path / "a.csv", select={"muscle": "m97"}), m)
    t = read_table(_write(tmp_path, "b.csv", "braid_angle_deg,length_mm\n20,97\n10,140\n"))
    with pytest.raises(InputError) as exc:
        check_muscle(t, m)
    assert str(exc.value) == (f"{tmp_path / 'b.csv'}: row 2 (line 3), column length_mm: 140 mm is longer than the strand"
                              f" length 112 mm of muscle file {tmp_path / 'm.toml'} (id 'm97'); does the muscle file match the data?")


# --- isometric tables ---------------------------------------------------------------------------

ISO = ("held_length_cm,pressure_bar,force_N,direction,trial\n"
       "30,0,2.0,inflate,1\n30,3,60.0,inflate,1\n30,6,110.0,inflate,1\n30,3,64.0,deflate,1\n30,0,2.5,deflate,1\n"
       "27,0,-1.0,inflate,1\n27,3,30.0,inflate,1\n27,6,70.0,inflate,1\n27,3,33.0,deflate,1\n27,0,-0.5,deflate,1\n")


def test_isometric_table_in_any_units_and_detected_from_its_columns(tmp_path):
    t = read_table(_write(tmp_path, "iso.csv", ISO))
    assert t.kind == "isometric"
    assert t.data["held_length"].tolist()[:2] == pytest.approx([0.30, 0.30])  # cm -> m
    assert t.data["pressure"].max() == pytest.approx(6e5)  # bar -> Pa


def test_isometric_tare_lowest_is_per_run_and_reported(tmp_path):
    from mckibben.data import apply_tare

    t = read_table(_write(tmp_path, "iso.csv", ISO))
    same, rep = apply_tare(t)
    assert same is t and rep == {"method": "none"}
    tared, rep = apply_tare(t, "lowest")
    # the run at 30 cm reads 2.0 and 2.5 N at 0 bar: its tare is their mean
    assert [r["tare_N"] for r in rep["per_run_N"]] == pytest.approx([-0.75, 2.25])
    assert tared.data["force"].iloc[1] == pytest.approx(60.0 - 2.25)
    col = read_table(_write(tmp_path, "iso2.csv", ISO.replace("trial\n", "trial,tare_N\n").replace(",1\n", ",1,0.5\n")))
    assert apply_tare(col)[1]["note"].startswith("the tare column was not subtracted")
    assert apply_tare(col, "column")[0].data["force"].iloc[1] == pytest.approx(59.5)
    with pytest.raises(InputError, match="tare 'column' needs a tare_<unit> column"):
        apply_tare(t, "column")


BAD_ISO = [
    ("noheld.csv", "pressure_kPa,force_N,direction,trial\n0,1,inflate,1\n100,5,inflate,1\n",
     "noheld.csv: missing column held_length_<unit> (e.g. held_length_mm); a isometric table needs held_length,"
     " pressure, force"),
    ("phase.csv", "held_length_mm,pressure_kPa,force_N,phase,trial\n300,0,1,inflate,1\n280,100,5,deflate,1\n",
     "phase.csv: missing column direction (without it every row would be read as inflate); the unknown column phase"
     " (its values are a loop's branches: map it with `columns` phase=direction) may be it"),
    ("onelength.csv", "held_length_mm,pressure_kPa,force_N,direction,trial\n300,0,1,inflate,1\n300,100,5,inflate,1\n",
     "onelength.csv: column held_length_mm: only one held length (300 mm); an isometric table needs two or more to"
     " fit force(P, L) (one length at rest is a blocked_force table)"),
    ("onepressure.csv", "held_length_mm,pressure_kPa,force_N,direction,trial\n300,100,1,inflate,1\n"
     "300,100,5,deflate,1\n280,0,1,inflate,1\n280,100,3,inflate,1\n",
     "onepressure.csv: row 1 (line 2), column pressure_kPa: the run at held length 300 mm, trial 1 has one pressure"
     " (100 kPa); an isometric run steps the pressure up and down"),
    ("baddir.csv", "held_length_mm,pressure_kPa,force_N,direction,trial\n300,0,1,up,1\n280,100,5,inflate,1\n",
     "baddir.csv: row 1 (line 2), column direction: 'up' is not a direction; use inflate or deflate"),
]


@pytest.mark.parametrize("name, text, message", BAD_ISO, ids=[b[0] for b in BAD_ISO])
def test_bad_isometric_table(tmp_path, name, text, message):
    with pytest.raises(InputError) as exc:
        read_table(_write(tmp_path, name, text))
    assert str(exc.value) == message.replace(name, str(tmp_path / name), 1)


def test_commercial_muscle_needs_only_id_length_and_diameter(tmp_path):
    m = read_muscle(_write(tmp_path, "f.toml", 'id = "festo10"\nnominal_length_mm = 300\nouter_diameter_mm = 12\n'))
    assert (m.strand_length, m.braid_angle, m.tube_inner_diameter) == (None, None, None)
    with pytest.raises(InputError) as exc:
        m.need("strand_length", "fit kinematic (eq. 2)")
    assert str(exc.value) == (f"{tmp_path / 'f.toml'}: key strand_length_<unit> missing; fit kinematic (eq. 2) needs it"
                              " (e.g. strand_length_mm = ...)")


def test_isometric_pressure_slightly_below_zero_is_a_transducer_zero(tmp_path):
    # -2 kPa against a 600 kPa top is within 1 %: read as 0; -50 kPa is not a zero error
    t = read_table(_write(tmp_path, "iso.csv", ISO.replace("30,0,2.0,inflate", "30,-0.02,2.0,inflate")))
    assert t.data["pressure"].iloc[0] == 0.0
    with pytest.raises(InputError, match="row 1 \\(line 2\\), column pressure_bar: -0.5 is negative"):
        read_table(_write(tmp_path, "iso2.csv", ISO.replace("30,0,2.0,inflate", "30,-0.5,2.0,inflate")))

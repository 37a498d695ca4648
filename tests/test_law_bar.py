"""Issue 32's bar, through the command line: every law that can be fitted to an isometric table is
fitted, saved, predicted from and exported as an FMU, on commercial muscles' tables.

The tables are SYNTHETIC and Festo-like: drawn from the published Hunt–Graber-Tilton–Quinn set of a
Festo DMSP-10 (``festo-dmsp10-189``, :data:`mckibben.datasets.LAW_SETS`), held at 0, 25, 50 and 75 %
of its stroke, 0–620 kPa, two trials, a load cell never zeroed (+2 N) and 0.5 N of noise; the
muscle file gives only what a datasheet gives (id, rest length, outer diameter: 10 mm or 26 mm).
The family laws get a family table of three rest lengths from the same set (the published ε_max
for all three: the set has one). No law is the truth but hunt-quinn; the bar is that every command
works and agrees with the library, not that every law fits well.
"""

from __future__ import annotations

import dataclasses
import zipfile

import numpy as np
import pandas as pd
import pytest

from mckibben.data import read_muscle
from mckibben.datasets import LAW_SETS
from mckibben.fit.muscle_file import muscle_force_law
from mckibben.models import laws

LAW, SET = LAW_SETS["festo-dmsp10-189"]
#: The commercial sizes the bar names: a 10 mm muscle and the 26 mm one whose wall-corrected fit
#: could not be exported. [mm]
DIAMETERS_MM = (10, 26)
#: Rest lengths of the family table: the set's own and two others. [m]
FAMILY_RESTS = (0.15, SET.rest_length, 0.25)


def _rows(rest: float, rng, muscle: str | None = None) -> list:
    law = dataclasses.replace(SET, rest_length=rest)
    rows = []
    for frac in (0.0, 0.25, 0.5, 0.75):
        ell = rest * (1.0 - frac * SET.max_strain)
        for trial in (1, 2):
            p = np.linspace(0.0, 620e3, 10)
            f = law.force(p, ell) + 2.0 + rng.normal(0.0, 0.5, p.size)
            rows += [dict(held_length_mm=round(ell * 1e3, 2), pressure_kPa=round(x / 1e3, 1), force_N=round(y, 1),
                          direction="inflate", trial=trial, **({"muscle": muscle, "rest_length_mm": rest * 1e3}
                                                               if muscle else {})) for x, y in zip(p, f)]
    return rows


@pytest.fixture(scope="module")
def tables(tmp_path_factory):
    """Per outer diameter [mm]: (single-muscle table, family table, muscle file)."""
    out = {}
    for od in DIAMETERS_MM:
        folder = tmp_path_factory.mktemp(f"festo{od}")
        rng = np.random.default_rng(od)
        pd.DataFrame(_rows(SET.rest_length, rng)).to_csv(folder / "isometric.csv", index=False)
        pd.DataFrame([r for i, rest in enumerate(FAMILY_RESTS) for r in _rows(rest, rng, f"m{i}")]).to_csv(
            folder / "family.csv", index=False)
        (folder / "muscle.toml").write_text(f'id = "festo{od}"\nnominal_length_mm = {SET.rest_length * 1e3:g}\n'
                                            f'outer_diameter_mm = {od}\nsynthetic = true\n')
        out[od] = folder / "isometric.csv", folder / "family.csv", folder / "muscle.toml"
    return out


def test_the_tables_come_from_the_published_set():
    assert LAW == "hunt-quinn" and len(laws.fit_laws()) >= 7  # every fitted law is in the bar below


#: Every fitted law on the 10 mm muscle, and on the 26 mm one those whose fit reads the diameter.
CASES = ([(n, DIAMETERS_MM[0]) for n in laws.fit_laws()]
         + [(n, od) for od in DIAMETERS_MM[1:] for n, law in laws.fit_laws().items() if "outer_diameter" in law.needs])


@pytest.mark.slow  # ~3 s a law: a fit, a prediction and an FMU export each
@pytest.mark.parametrize("name, od", CASES)
def test_fit_save_predict_and_export_every_fitted_law(cli, tables, tmp_path, name, od):
    single, family, muscle = tables[od]
    law = laws.LAWS[name]
    saved = tmp_path / "F.toml"
    rest = ("--rest-length", f"{SET.rest_length * 1e3:g}mm") if law.family else ()
    r = cli("fit", str(family if law.family else single), "--muscle-file", str(muscle), "--model", name,
            "--save", str(saved), *rest, "--json")
    assert r.code == 0, r.err
    assert r.json()["saved"] == str(saved)
    # predict force from the file: the library's number
    r = cli("predict", "force", "--muscle-file", str(saved), "--pressure", "0.2,0.4MPa", "--length", "180mm", "--json")
    assert r.code == 0, r.err
    out = r.json()
    want, _ = muscle_force_law(read_muscle(saved)).force(np.array([0.2e6, 0.4e6]), 0.18, "inflate")
    np.testing.assert_array_equal(out["force_N"], want)
    assert np.all(np.isfinite(want)) and want[1] > want[0] > 0  # it pulls, more at the higher pressure
    # and the FMU
    r = cli("export", "fmu", "--muscle-file", str(saved), "--out", str(tmp_path / "m.fmu"))
    assert r.code == 0, r.err
    with zipfile.ZipFile(tmp_path / "m.fmu") as z:
        assert f"{name} force law" in z.read("modelDescription.xml").decode()

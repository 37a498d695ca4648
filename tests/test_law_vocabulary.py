"""A muscle file or a fit that lacks the outer diameter says which law needs it (issue 32)."""

from __future__ import annotations

import pytest

from mckibben.data import read_muscle
from mckibben.datasets.isometric import BUNDLED_ISOMETRIC
from mckibben.errors import InputError

COMMERCIAL = BUNDLED_ISOMETRIC / "commercial10"


def test_a_muscle_file_of_a_fitted_law_without_its_outer_diameter_names_the_law(cli, tmp_path):
    saved = tmp_path / "fit.toml"
    r = cli("fit", str(COMMERCIAL / "isometric.csv"), "--muscle-file", str(COMMERCIAL / "muscle.toml"),
            "--model", "spring", "--save", str(saved))
    assert r.code == 0, r.err
    stripped = tmp_path / "no_od.toml"
    stripped.write_text("".join(ln for ln in saved.read_text().splitlines(keepends=True)
                                if not ln.startswith("outer_diameter")))
    with pytest.raises(InputError, match=r"no_od\.toml: key outer_diameter_<unit> missing; its force law spring "):
        read_muscle(stripped)
    r = cli("predict", "force", "--muscle-file", str(stripped), "--pressure", "0.3MPa", "--length", "290mm")
    assert r.code == 2 and "Traceback" not in r.err
    assert r.err.count("\n") == 1 and "outer_diameter" in r.err and "force law spring" in r.err, r.err


def test_a_muscle_file_without_a_law_keeps_the_plain_message(tmp_path):
    f = tmp_path / "m.toml"
    f.write_text('id = "m"\nnominal_length_mm = 300\n')
    with pytest.raises(InputError, match=r"m\.toml: key outer_diameter_<unit> missing \(e\.g\."):
        read_muscle(f)


@pytest.mark.parametrize("model", ["spring", "relative-strain"])
def test_saving_a_law_fitted_without_a_muscle_file_names_the_law_and_writes_nothing(cli, tmp_path, model):
    # the table's rest length stands for the muscle file: no outer diameter, so nothing readable to save
    import pandas as pd

    d = pd.read_csv(COMMERCIAL / "isometric.csv")
    d["rest_length_mm"] = 300
    table = tmp_path / "iso.csv"
    d.to_csv(table, index=False)
    out = tmp_path / "saved.toml"
    r = cli("fit", str(table), "--model", model, "--save", str(out))
    assert r.code == 2 and "Traceback" not in r.err
    assert f"--save: a muscle file of the {model} force law needs the muscle's outer diameter" in r.err, r.err
    assert not out.exists()

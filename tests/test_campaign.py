"""The bundled example campaign: deterministic, small, marked synthetic, and its fits recover the
parameters it was generated from (coverage over 20 seeds, see tests/test_fit.py for the rule)."""

import tomllib

import numpy as np
import pandas as pd
import pytest

from mckibben.data import read_muscle, read_table
from mckibben.datasets.campaign import BUNDLED, CAMPAIGN_MUSCLES, ISOTONIC_LOADS, PHOTO_LOADS, campaign_truth, write_campaign
from mckibben.fit.static import fit_cubics, fit_first_order, fit_kinematic, fit_spring

MIN_COVERED = 16  # of 20: P(count <= 15 | 95 % coverage) = 0.26 % (binomial), as in tests/test_fit.py


def test_bundled_campaign_is_seed_0_regenerated(tmp_path):
    out = write_campaign(tmp_path / "c", seed=0)
    bundled = sorted(p.relative_to(BUNDLED) for p in BUNDLED.rglob("*") if p.is_file())
    fresh = sorted(p.relative_to(out) for p in out.rglob("*") if p.is_file())
    assert bundled == fresh
    for rel in bundled:
        if rel.suffix == ".parquet":  # bytes depend on the pyarrow version; the content must not
            pd.testing.assert_frame_equal(pd.read_parquet(BUNDLED / rel), pd.read_parquet(out / rel))
        else:
            assert (BUNDLED / rel).read_text() == (out / rel).read_text(), rel


def test_bundled_campaign_is_small_and_marked_synthetic():
    size = sum(p.stat().st_size for p in BUNDLED.rglob("*") if p.is_file())
    assert size < 300_000  # "a few hundred KB total" (issue 4, point 5)
    meta = tomllib.loads((BUNDLED / "campaign.toml").read_text())
    assert meta["synthetic"] is True and meta["seed"] == 0
    assert "SYNTHETIC" in (BUNDLED / "README.md").read_text()
    for name in CAMPAIGN_MUSCLES:
        spec = read_muscle(BUNDLED / name / "muscle.toml")
        assert spec.synthetic and "SYNTHETIC" in spec.notes
        kinds = {read_table(f).kind for f in (BUNDLED / name).iterdir() if f.suffix in (".csv", ".parquet")}
        assert kinds == {"blocked_force", "isotonic", "hysteresis", "braid_angle", "force_length", "step_response"}


def test_generate_refuses_a_folder_that_is_not_a_campaign(tmp_path):
    (tmp_path / "keep.txt").write_text("mine")
    from mckibben.errors import InputError

    with pytest.raises(InputError):
        write_campaign(tmp_path, seed=1)
    assert (tmp_path / "keep.txt").read_text() == "mine"  # nothing touched


@pytest.mark.slow
@pytest.mark.parametrize("name", ["mpam117", "mpam97"])
def test_campaign_round_trip_over_seeds(tmp_path, name):
    truth = campaign_truth(name)
    m = truth.muscle
    expected = {"kinematic": [m.k1, m.k2]}
    for load in PHOTO_LOADS:
        expected[f"braid {load}"] = list(m.braid_map.coefficients_at(load))
    for load in ISOTONIC_LOADS:
        expected[f"isotonic {load}"] = list(truth.length_cubic(m.braid_map.coefficients_at(load)))
    expected["blocked"] = list(truth.blocked_force)
    for d in ("inflate", "deflate"):
        expected[f"hysteresis {d}"] = list(truth.length_cubic(truth.hysteresis[d]))
    sm = truth.spring
    expected["spring"] = list(sm.h) + [v for b in [("elongation", "low"), ("elongation", "high"), ("contraction", "low"),
                                                    ("contraction", "high")] for v in sm.coefficients[b]]
    expected["tau"] = [truth.tau] * 3
    covered = {k: np.zeros(len(v), int) for k, v in expected.items()}

    def count(key, res):
        ci, want = res.ci95, np.asarray(expected[key])
        covered[key] += (ci[:, 0] <= want) & (want <= ci[:, 1])

    from mckibben.datasets.campaign import _muscle_toml, _write_csv, generate_muscle

    for seed in range(20):
        folder = tmp_path / f"s{seed}"
        folder.mkdir()
        (folder / "muscle.toml").write_text(_muscle_toml(name, seed))
        for fname, df in generate_muscle(name, seed).items():
            df.to_parquet(folder / fname) if fname.endswith(".parquet") else _write_csv(df, folder / fname)
        spec = read_muscle(folder / "muscle.toml")
        braid = read_table(folder / "braid_angle.csv")
        count("kinematic", fit_kinematic(braid, spec))
        for (load, _), res in fit_cubics(braid).items():
            count(f"braid {load:g}", res)
        for (load, _), res in fit_cubics(read_table(folder / "isotonic.csv")).items():
            count(f"isotonic {load:g}", res)
        count("blocked", fit_cubics(read_table(folder / "blocked_force.csv"))[(None, None)])
        for (_, d), res in fit_cubics(read_table(folder / "hysteresis.csv")).items():
            count(f"hysteresis {d}", res)
        count("spring", fit_spring(read_table(folder / "force_length.csv")).result)
        for i, res in enumerate(fit_first_order(read_table(folder / "step_response.parquet")).values()):
            covered["tau"][i] += res.ci95[2, 0] <= truth.tau <= res.ci95[2, 1]  # one τ per command step
    low = {k: v.tolist() for k, v in covered.items() if np.any(v < MIN_COVERED)}
    assert not low, low

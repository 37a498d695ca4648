"""Round trips: data generated from known parameters plus noise; every fit recovers them.

Coverage: each test repeats the round trip over 20 seeds and counts, per parameter, how often the
reported 95 % interval holds the generating value. With a true coverage of 95 % that count is
Binomial(20, 0.95); P(count <= 15) = 0.26 %, so we require >= 16 of 20 for every parameter. A fit
whose intervals were too narrow by a factor of 2 (true coverage ~68 %) fails this with
probability ~80 % per parameter. The seeds are fixed, so the test is deterministic.
"""

import re

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from mckibben.data import MuscleSpec, Table
from mckibben.errors import InputError
from mckibben.fit.static import (
    fit_chou_hannaford,
    fit_cubics,
    fit_first_order,
    fit_force_contraction,
    fit_kinematic,
    fit_spring,
    fit_surface,
    fit_tondu_lopez,
    first_order_step,
    trial_stats,
)
from mckibben.models.flags import Flag
from mckibben.models.physical import BraidGeometry, length_under_load, tondu_lopez_contraction
from mckibben.models.spring import CONTRACTION, DEFAULT_TERMS, ELONGATION, HIGH, LOW, SpringModel, spring_force

SEEDS = range(20)
MIN_COVERED = 16  # of 20; see the module docstring
#: the miniature muscle of 000 (§II): 1.2 mm outer, tube 0.5/0.9 mm, strand 0.1 mm, braid ~20°
MINI = dict(outer_diameter=1.2e-3, tube_inner_diameter=0.5e-3, tube_outer_diameter=0.9e-3, strand_diameter=0.1e-3,
            braid_angle=float(np.deg2rad(20.0)))
MUSCLE = MuscleSpec("m", nominal_length=0.117, strand_length=0.145, **MINI)


def table(kind, **cols):
    n = len(next(iter(cols.values())))
    df = pd.DataFrame(cols, index=pd.Index(np.arange(1, n + 1), name="row"))
    if "trial" not in df:
        df["trial"] = 1
    return Table(kind, f"{kind}.csv", df, {k: k for k in cols})


def assert_coverage(truth, fitted):
    """fitted: list of FitResult over seeds; truth: generating values in the result's order."""
    truth = np.asarray(truth, dtype=float)
    covered = np.zeros(truth.size, int)
    for res in fitted:
        ci = res.ci95
        covered += (ci[:, 0] <= truth) & (truth <= ci[:, 1])
    assert np.all(covered >= MIN_COVERED), dict(zip(fitted[0].names, covered))


def test_coverage_threshold_is_what_the_docstring_says():
    assert stats.binom.cdf(MIN_COVERED - 1, 20, 0.95) < 0.005


def test_kinematic_round_trip():
    k1, k2 = 0.88, 1.09e-3
    fits = []
    for seed in SEEDS:
        r = np.random.default_rng(seed)
        angle = np.deg2rad(np.repeat(np.arange(20, 42, 2.0), 3))
        ell = k1 * MUSCLE.strand_length * np.cos(angle) + k2 + r.normal(0, 0.8e-3, angle.size)
        fits.append(fit_kinematic(table("braid_angle", braid_angle=angle, length=ell), MUSCLE))
    assert_coverage([k1, k2], fits)
    res = fits[0]
    assert res.names == ("k1", "k2_m") and res.n_points == 33 and res.dof == 31
    # the interval is the t-quantile times the standard error
    np.testing.assert_allclose(res.ci95[:, 1] - res.values, stats.t.ppf(0.975, 31) * res.stderr, rtol=1e-12)


def test_cubic_per_load_round_trip_table_ii():
    truth = {0.6: (0.2, -0.2, -0.22, 0.98), 2.1: (-0.2, 0.3, -0.16, 0.94)}  # Table II, mpam117
    fits = {0.6: [], 2.1: []}
    for seed in SEEDS:
        r = np.random.default_rng(seed)
        p = np.tile(np.linspace(0, 0.8e6, 9), 6)
        load = np.repeat([0.6, 2.1], 27)
        cos_t = np.where(load == 0.6, np.polyval(truth[0.6], p / 1e6), np.polyval(truth[2.1], p / 1e6))
        angle = np.arccos(cos_t + r.normal(0, 0.004, p.size))
        res = fit_cubics(table("braid_angle", braid_angle=angle, length=np.full(p.size, 0.1), pressure=p, load=load))
        for f in (0.6, 2.1):
            fits[f].append(res[(f, None)])
    for f in (0.6, 2.1):
        assert_coverage(truth[f], fits[f])
    assert fits[0.6][0].names == ("c3_per_MPa3", "c2_per_MPa2", "c1_per_MPa", "c0")


def test_surface_round_trip_and_flags():
    a = np.array([-0.08, 0.12, -0.1, 0.113, 0.036, -0.057, 0.045, -0.0075])
    fits = []
    for seed in SEEDS:
        r = np.random.default_rng(seed)
        p = np.tile(np.linspace(0, 0.8e6, 9), 12)
        load = np.repeat([0.6, 1.1, 1.6, 2.1], 27)
        x = p / 1e6
        ell = sum(c * x**i * load**j for c, (i, j) in zip(a, [(3, 0), (2, 0), (1, 0), (0, 0), (3, 1), (2, 1), (1, 1), (0, 1)]))
        fits.append(fit_surface(table("isotonic", pressure=p, load=load, length=ell + r.normal(0, 0.3e-3, p.size))))
    assert_coverage(a, fits)
    value, flags = fits[0].predict(pressure=[0.4e6, 0.9e6, 0.4e6], load=[1.3, 1.3, 3.0])
    assert list(flags) == [0, Flag.PRESSURE_OUT_OF_RANGE, Flag.LOAD_OUT_OF_RANGE]
    # between characterized loads the band is narrower than the noise of one point (0.3 mm)
    assert 0 < fits[0].band(pressure=0.4e6, load=1.3) < 0.3e-3


def test_force_contraction_round_trip():
    c = np.array([30.0, -10.0, -25.0, 2.5])  # load [N] as a cubic in the contraction
    fits = []
    for seed in SEEDS:
        r = np.random.default_rng(seed)
        eps = np.tile(np.linspace(-0.02, 0.08, 6), 3)
        load = np.polyval(c, eps) + r.normal(0, 0.02, eps.size)
        t = table("isotonic", pressure=np.full(eps.size, 0.5e6), load=load, length=MUSCLE.nominal_length * (1 - eps))
        fits.append(fit_force_contraction(t, MUSCLE)[0.5e6])
    assert_coverage(c, fits)


def _spring_truth():
    h = (-0.22 * 0.1 / 0.8e6**2, 1e-9, 0.1)
    coeffs = {(ELONGATION, LOW): (1e-4, 0.02, 1.5e4, 200.0), (ELONGATION, HIGH): (-1e-4, 0.01, 1.2e4, 300.0),
              (CONTRACTION, LOW): (0.8e-4, 0.016, 1.2e4, 160.0), (CONTRACTION, HIGH): (-0.8e-4, 0.008, 1.0e4, 240.0)}
    return SpringModel(0.1, h, coeffs, DEFAULT_TERMS, 0.45e6)


def test_spring_round_trip():
    sm = _spring_truth()
    fits = []
    for seed in SEEDS:
        r = np.random.default_rng(seed)
        rows = []
        for p in (0.2e6, 0.3e6, 0.4e6, 0.5e6, 0.65e6, 0.8e6):
            lu = (sm.h[0] * p + sm.h[1]) * p + sm.h[2]
            for dn, ell in ((ELONGATION, np.linspace(lu, 0.1, 12)), (CONTRACTION, np.linspace(0.1, lu, 12))):
                f, _ = spring_force(ell, p, sm, dn)
                rows += [(p, e, ff, dn) for e, ff in zip(ell, f + r.normal(0, 0.01, ell.size))]
        p, ell, f, dn = map(np.array, zip(*rows))
        fits.append(fit_spring(table("force_length", pressure=p, length=ell, force=f, direction=dn)).result)
    truth = list(sm.h) + [v for b in [(ELONGATION, LOW), (ELONGATION, HIGH), (CONTRACTION, LOW), (CONTRACTION, HIGH)]
                          for v in sm.coefficients[b]]
    assert_coverage(truth, fits)


def test_chou_hannaford_round_trip():
    geom = BraidGeometry.from_initial(0.117, 1.1e-3, np.deg2rad(20))
    fits = []
    for seed in SEEDS:
        r = np.random.default_rng(seed)
        p = np.tile(np.linspace(0.1e6, 0.8e6, 8), 6)
        load = np.repeat([0.6, 1.1, 1.6, 2.1, 2.6, 3.1], 8)
        ell, _ = length_under_load(p, load, geom)
        fits.append(fit_chou_hannaford(table("isotonic", pressure=p, load=load, length=ell + r.normal(0, 0.3e-3, p.size)),
                                       MuscleSpec("m", 0.117, 0.145, **(MINI | dict(outer_diameter=1.3e-3, braid_angle=np.deg2rad(25))))))
    assert_coverage([geom.strand_length, geom.d0], fits)


def test_tondu_lopez_round_trip():
    k, r0 = 1.6, 0.6e-3
    spec = MuscleSpec("m", 0.117, 0.145, **MINI)
    fits = []
    for seed in SEEDS:
        r = np.random.default_rng(seed)
        p = np.tile(np.linspace(0.1e6, 0.8e6, 8), 6)
        load = np.repeat([0.6, 1.1, 1.6, 2.1, 2.6, 3.1], 8)
        eps, _ = tondu_lopez_contraction(p, load, r0, spec.braid_angle, k)
        ell = spec.nominal_length * (1 - eps) + r.normal(0, 0.3e-3, p.size)
        fits.append(fit_tondu_lopez(table("isotonic", pressure=p, load=load, length=ell), spec))
    assert_coverage([k, r0], fits)


def test_first_order_round_trip():
    fits = []
    for seed in SEEDS:
        r = np.random.default_rng(seed)
        t = np.tile(np.arange(0, 0.6, 0.005), 2)
        trial = np.repeat([1, 2], t.size // 2)
        p = first_order_step(t, 0.08e6, 0.56e6, 0.09, 0.05) + r.normal(0, 2e3, t.size)
        cmd = np.where(t >= 0.05, 0.7, 0.1)
        tb = table("step_response", time=t, pressure=p, command=cmd, trial=trial)
        fits.append(fit_first_order(tb)[0.7])
    assert_coverage([0.08e6, 0.56e6, 0.09], fits)


def test_trial_stats_are_the_error_bars():
    t = table("isotonic", pressure=[0.1e6, 0.1e6, 0.1e6, 0.2e6], load=[0.6] * 4, length=[0.090, 0.091, 0.092, 0.08],
              trial=[1, 2, 3, 1])
    s = trial_stats(t, "pressure", "length", ("load",))
    np.testing.assert_allclose(s["mean"], [0.091, 0.08], rtol=1e-12)
    np.testing.assert_allclose(s["std"].iloc[0], 0.001, rtol=1e-9)  # sample sd (ddof=1) of 90, 91, 92 mm
    assert list(s["n"]) == [3, 1]


# ---- fits that must refuse, with their exact messages


def test_too_few_distinct_angles():
    t = table("braid_angle", braid_angle=np.deg2rad([20, 20, 25, 25]), length=[0.1, 0.1, 0.09, 0.09])
    with pytest.raises(InputError) as exc:
        fit_kinematic(t, MUSCLE)
    assert str(exc.value) == ("fit kinematic on braid_angle.csv: 2 distinct braid angles; a straight line with a check"
                              " of its fit needs at least 3")


def test_too_few_distinct_pressures_for_a_cubic():
    t = table("isotonic", pressure=np.repeat([0, 0.2e6, 0.4e6, 0.6e6], 3), load=[0.6] * 12, length=np.linspace(0.1, 0.09, 12))
    with pytest.raises(InputError) as exc:
        fit_cubics(t)
    assert str(exc.value) == ("fit cubic on isotonic.csv (load 0.6 N): 4 distinct pressures; a cubic in pressure"
                              " (4 coefficients and a check of its fit) needs at least 5")


def test_too_few_points():
    p = np.array([0.2e6] * 5 + [0.3e6] * 5 + [0.4e6] * 5 + [0.4e6] * 3)
    dn = np.array([ELONGATION] * 15 + [CONTRACTION] * 3)
    ell = np.linspace(0.09, 0.1, 18)
    t = table("force_length", pressure=p, length=ell, force=np.linspace(0, 1, 18), direction=dn)
    with pytest.raises(InputError) as exc:
        fit_spring(t, split_pressure=np.inf)
    assert str(exc.value) == "fit spring on force_length.csv (contraction, low range): 3 points for 4 parameters; needs at least 5"


def test_ill_conditioned_fit():
    # two "loads" a nanonewton apart: distinct, but they cannot tell the load terms from the others
    p = np.tile(np.linspace(0, 0.8e6, 9), 2)
    load = np.repeat([0.6, 0.6 + 1e-9], 9)
    t = table("isotonic", pressure=p, load=load, length=0.1 - 0.02 * p / 0.8e6)
    with pytest.raises(InputError) as exc:
        fit_surface(t)
    assert re.fullmatch(r"fit surface on isotonic\.csv: ill-conditioned \(condition number [0-9.e+]+ > 1e\+10\): the data"
                        r" do not determine the parameters; add points that vary the inputs more", str(exc.value)), str(exc.value)

"""The conformance suite of the force laws: every registered law, each check (scikit-learn's check_estimator).

Parametrized over :data:`mckibben.models.laws.LAWS`, so a new law file is picked up with nothing
else changed. Each law is checked on a parameter set of its own, found without a hand list:

- a law fitted to isometric data (it has a fit spec) on its fit to the bundled commercial-size
  table (``datasets/isometric/commercial10``, synthetic), saved as a muscle file and read back;
- a law that is not fitted, on its published parameters for the catalogue's 143 mm muscle
  (:attr:`~mckibben.models.laws.Law.published`).

A law with neither is a failure: it could not be used by anything.

The checks: the NumPy face equals the compiled kernel (and the plain-Python kernel, to the bit); a
fit on data generated from the law recovers its parameters within their intervals; the plant's
steady state (blocked at the rest length, supply pressure) equals the static law within 0.1 %; the
FMU's C face (compiled here with the system C compiler) equals the Python to 1e-9 relative; the
command line gives the library's number; a muscle file round-trips and exports as an FMU; a
pressure or length outside the valid range is flagged.
"""

from __future__ import annotations

import ctypes
import shutil
import subprocess
import sys
import warnings
import zipfile

import numpy as np
import pytest

from mckibben import _kernels
from mckibben.data import read_muscle, read_table
from mckibben.datasets import get_muscle
from mckibben.datasets.isometric import BUNDLED_ISOMETRIC
from mckibben.errors import InputError
from mckibben.export import export_fmu
from mckibben.plant.c_layout import law_defines, laws_c
from mckibben.fit.compare import compare_models
from mckibben.fit.isometric import fit_isometric, fit_isotonic_law, fit_points, law_length
from mckibben.fit.muscle_file import muscle_force_law, save_muscle_file
from mckibben import models
from mckibben.models import law_statics, laws
from mckibben.models.muscle import Muscle
from mckibben.plant import PlantParams, simulate

NAMES = list(laws.LAWS)
COMMERCIAL = BUNDLED_ISOMETRIC / "commercial10"
#: The catalogue muscle whose published parameters drive the laws that are not fitted.
CATALOGUE = "mpam143"


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    """Per law (cached): ``(kind, params, θ, plant, muscle_file or None, fit or None)``."""
    cache: dict = {}
    root = tmp_path_factory.mktemp("laws")

    def get(name):
        if name in cache:
            return cache[name]
        law = laws.LAWS[name]
        if law.fit_spec is not None:
            spec = read_muscle(COMMERCIAL / "muscle.toml")
            fit = fit_isometric(read_table(COMMERCIAL / "isometric.csv"), spec, name)
            path = save_muscle_file(root / f"{law.stem}.toml", spec, fit)
            m = Muscle.from_spec(read_muscle(path))
            theta = laws.law_of(m.params, name)[1]
            cache[name] = ("fitted", m.params, theta, m, path, fit)
        elif law.published is not None:
            m = get_muscle(CATALOGUE)
            params = law.published(m)
            cache[name] = ("published", params, law.theta_of(params, "elongation"), m, None, None)
        else:
            pytest.fail(f"law {name}: neither a fit spec nor a published parameter set; nothing can use it")
        return cache[name]

    return get


def _grid(m):
    """Pressures 0..0.8 MPa and lengths over the muscle's range (a little beyond both ends). [Pa], [m]"""
    l0 = float(m.nominal_length)
    p = np.linspace(0.0, 0.8e6, 17)
    ell = np.linspace(0.75 * l0, 1.02 * l0, 23)
    return np.meshgrid(p, ell, indexing="ij")


@pytest.mark.parametrize("name", NAMES)
def test_numpy_face_equals_the_kernel(case, name):
    kind, params, theta, m, *_ = case(name)
    p, ell = _grid(m)
    face = laws.evaluate(name, p, ell, theta)
    law = laws.LAWS[name]
    module = sys.modules[law.kernel.__module__]
    _kernels.jit()  # the module's kernel is now the compiled dispatcher
    compiled = getattr(module, law.kernel.__name__)
    plain = getattr(compiled, "py_func", compiled)
    th = np.ascontiguousarray(theta, dtype=float)
    want_c = np.array([compiled(float(a), float(b), th, 0, 1) for a, b in zip(p.ravel(), ell.ravel())])
    with np.errstate(all="ignore"):  # as the compiled kernel: error_model="numpy"
        want_py = np.array([plain(float(a), float(b), th, 0, 1) for a, b in zip(p.ravel(), ell.ravel())])
    np.testing.assert_array_equal(face.ravel(), want_c)  # the same kernel: the same bits
    np.testing.assert_array_equal(face.ravel(), want_py)  # Python and compiled: error_model="numpy", no fastmath
    assert np.isfinite(face).mean() > 0.5, f"{name}: the example set gives mostly non-finite forces"


@pytest.fixture(scope="module")
def c_laws(tmp_path_factory):
    """Every law's C face, as the FMU compiles it (``mk_laws.c``), built as a shared library here."""
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        pytest.skip("no system C compiler")
    d = tmp_path_factory.mktemp("claws")
    (d / "mk_model.h").write_text("#ifndef MK_MODEL_H\n#define MK_MODEL_H\n#include <math.h>\n"
                                  + "\n".join(law_defines()) + "\n#endif\n")
    (d / "mk_laws.c").write_text(laws_c())
    lib = d / "mk_laws.so"
    done = subprocess.run([cc, "-std=c99", "-O2", "-fPIC", "-shared", "-Wall", "-Wextra", "-Werror", f"-I{d}",
                           "-o", str(lib), str(d / "mk_laws.c"), "-lm"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    so = ctypes.CDLL(str(lib))
    so.mk_law.restype = ctypes.c_double
    so.mk_law.argtypes = [ctypes.c_int, ctypes.c_double, ctypes.c_double, ctypes.POINTER(ctypes.c_double)]
    return so


@pytest.mark.parametrize("name", NAMES)
def test_the_c_face_equals_the_python(case, c_laws, name):
    assert laws.LAWS[name].c_source() is not None, f"{name}: no C face models/laws/{laws.LAWS[name].stem}.c"
    kind, params, theta, m, *_ = case(name)
    p, ell = _grid(m)
    want = laws.evaluate(name, p, ell, theta).ravel()
    th = np.ascontiguousarray(theta, dtype=float)
    ptr = th.ctypes.data_as(ctypes.POINTER(ctypes.c_double))
    got = np.array([c_laws.mk_law(laws.LAW_INDEX[name], float(a), float(b), ptr) for a, b in zip(p.ravel(), ell.ravel())])
    assert np.array_equal(np.isnan(got), np.isnan(want))
    ok = ~np.isnan(want)
    # 1e-9 relative (the bar) of the largest force on the grid: the C and Python libm
    # (exp, expm1, sqrt) may differ in the last bit; where the law crosses zero a relative error
    # of each element would be meaningless
    scale = np.max(np.abs(want[ok]))
    np.testing.assert_allclose(got[ok], want[ok], rtol=1e-9, atol=1e-9 * scale)


@pytest.mark.parametrize("name", NAMES)
def test_a_fit_on_data_from_the_law_recovers_its_parameters(case, name):
    kind, params, theta, m, path, fit = case(name)
    if kind != "fitted":
        pytest.skip(f"{name} is not fitted to isometric data (no fit spec)")
    r = fit.result
    d = fit.data
    f = d["force"].to_numpy(float)
    spec = laws.LAWS[name].fit_spec(fit.muscle, float(np.abs(f).max()),
                                    {"pressure": d["pressure"].to_numpy(float), "held_length": d["held_length"].to_numpy(float),
                                     "force": f, "direction": d["direction"].to_numpy(),
                                     "rest_length": np.full(len(d), fit.muscle.nominal_length)})
    # the truth: the fit to the table, with a value its fit left at a bound moved a tenth inside
    # (a parameter on its bound has no interval, and holds its neighbours' intervals off)
    span = spec.hi - spec.lo
    with np.errstate(invalid="ignore"):
        inside = np.clip(r.values, spec.lo + 0.1 * span, spec.hi - 0.1 * span)
    truth = np.where(np.isfinite(r.stderr) | ~np.isfinite(span), r.values, inside)
    ok = np.ones(truth.size, dtype=bool)
    # data generated from the law at the fitted values, on the table's own points and runs
    clean = d.assign(force=r.func(truth, d["pressure"].to_numpy(float), d["held_length"].to_numpy(float),
                                  d["direction"].to_numpy()))
    back = fit_points(clean, fit.muscle, name).values
    # noise-free: the same values, to the optimizer's tolerance, wherever the fit identifies them
    # (a value at a bound of its fit, flagged, has no interval)
    np.testing.assert_allclose(back[ok], truth[ok], rtol=1e-3, atol=1e-3 * np.abs(truth[ok]).max())
    # with noise of 1 % of the peak force: the truth lies within each 95 % interval. Seeded, so
    # deterministic; a 95 % interval misses one draw in twenty by design (seed 7 is such a draw
    # for the load cell's zero of every law here, at 1.3-2 half-widths), seed 0 is not
    rng = np.random.default_rng(0)
    noisy = clean.assign(force=clean["force"] + 0.01 * np.abs(clean["force"]).max() * rng.standard_normal(len(clean)))
    rn = fit_points(noisy, fit.muscle, name)
    half = rn.t_quantile * rn.stderr
    inside = np.abs(rn.values - truth) <= half
    assert inside[ok & np.isfinite(half)].all(), dict(zip(rn.names, zip(rn.values, truth, half)))


@pytest.mark.parametrize("name", NAMES)
def test_the_plant_at_rest_equals_the_static_law(case, name):
    law = laws.LAWS[name]
    if law.published is not None:  # the catalogue muscle's rig (the fitted file's may refuse the law: below)
        m = get_muscle(CATALOGUE)
        try:  # the rig's own geometry for a law it knows by name (its braid: the published 143 mm one's)
            plant = PlantParams.for_muscle(m, force_model=name)
            plant.law(1)
        except InputError:  # a law the rig has no fields for: its published parameter object
            plant = PlantParams.for_muscle(m, force_model=law.published(m))
    else:
        kind, params, theta, m, path, fit = case(name)
        plant = PlantParams.from_muscle_file(path)
    plant = plant.replace(load_kind="blocked")
    theta = plant.law(1)[1][:, 0]
    s = simulate(plant, 1.0, inlet=255, n=1)
    pg, held = float(s.pressure[0, -1]), float(s.length[0, -1])
    static = max(float(laws.evaluate(name, pg, held, theta)), 0.0)  # the plant never pushes
    # the bar: 0.1 %; the plant adds nothing at the rest length (no stretch, friction at rest)
    assert float(s.force[0, -1]) == pytest.approx(static, rel=1e-3)
    assert static > 0.0 and pg > 0.5 * plant.supply_pressure


@pytest.mark.parametrize("name", NAMES)
def test_the_command_line_gives_the_library_number(case, cli, name):
    kind, params, theta, m, path, fit = case(name)
    ell = round(0.95 * float(m.nominal_length), 6)
    if kind == "fitted":
        r = cli("predict", "force", "--muscle-file", str(path), "--pressure", "0.4MPa", "--length", f"{ell * 1e3:g}mm",
                "--json")
        law = muscle_force_law(read_muscle(path))
        want = float(law.force(0.4e6, ell)[0])
        # the file's law is the registered law plus the load cell's zero it was fitted with
        zero = law.parameters.get("offset_N", 0.0)
        assert want == pytest.approx(float(laws.evaluate(name, 0.4e6, ell, theta)) + zero, rel=1e-12)
    else:
        r = cli("predict", "force", "--model", name, "--muscle", CATALOGUE, "--pressure", "0.4MPa",
                "--length", f"{ell * 1e3:g}mm", "--json")
        want = float(laws.evaluate(name, 0.4e6, ell, theta))
    assert r.code == 0, r.err
    assert r.json()["force_N"] == pytest.approx(want, rel=1e-12)


@pytest.mark.parametrize("name", NAMES)
def test_the_command_line_gives_the_library_length_and_pressure(case, cli, name):
    kind, params, theta, m, path, fit = case(name)
    l0 = float(m.nominal_length)
    load = round(0.5 * float(laws.evaluate(name, 0.4e6, l0, theta)), 6)  # half the blocked force: reached
    which = ("--muscle-file", str(path)) if kind == "fitted" else ("--model", name, "--muscle", CATALOGUE)
    r = cli("predict", "length", *which, "--pressure", "0.4MPa", "--load", f"{load!r}N", "--json")
    assert r.code == 0, r.err
    want = models.length(0.4e6, load, m, None if kind == "fitted" else name)
    out = r.json()
    assert out["model"] == name and out["length_m"] == pytest.approx(float(want.length), rel=1e-12)
    ell = out["length_m"]
    if not out["flags"]:
        # solved with the law's own force: it pulls the load there (the root to ~4 ulp of the length)
        assert float(laws.evaluate(name, 0.4e6, ell, theta)) == pytest.approx(load, rel=1e-8)
    back = cli("predict", "pressure", *which, "--length", f"{ell * 1e3!r}mm", "--load", f"{load!r}N", "--json")
    assert back.code == 0, back.err
    want = models.pressure(ell, load, m, None if kind == "fitted" else name)
    assert back.json()["pressure_Pa"] == pytest.approx(float(want.pressure), rel=1e-12)
    assert float(want.pressure) == pytest.approx(0.4e6, rel=1e-7)  # the two inverses agree


@pytest.mark.parametrize("name", NAMES)
def test_a_closed_form_length_equals_the_solved_one(case, name):
    law = laws.LAWS[name]
    if law.length_of is None:
        pytest.skip(f"{name} has no closed-form length (Law.length_of): solved by the scan alone")
    kind, params, theta, m, path, fit = case(name)
    l0 = float(m.nominal_length)
    p = np.linspace(0.1e6, 0.8e6, 8)
    load = 0.5 * laws.evaluate(name, p, l0, theta)
    force = lambda pp, ell: laws.evaluate(name, pp, ell, theta)  # noqa: E731
    exact = law_statics.rising_root(force, p, load, 0.5 * l0, 1.5 * l0, lambda pp, ww: law.length_of(theta, pp, ww))
    scanned = law_statics.rising_root(force, p, load, 0.5 * l0, 1.5 * l0)
    np.testing.assert_array_equal(exact[1], scanned[1])
    # Chandrupatla's root to its default tolerance against the closed form
    np.testing.assert_allclose(exact[0], scanned[0], rtol=1e-12)


@pytest.mark.parametrize("name", NAMES)
def test_the_plant_runs_the_law_by_name_on_its_own_fields(name):
    law = laws.LAWS[name]
    base = PlantParams.for_muscle(get_muscle(CATALOGUE), force_model=name)
    if law.plant_theta is None:  # its θ is not in the plant's fields: it needs the parameter object
        with pytest.raises(InputError, match=f"force_model='{name}' needs its model object"):
            base.law(1)
        return
    # a sweep over the plant's fields: each instance's θ is the law's of that instance alone
    sweep = base.replace(r0=np.array([0.9, 1.1]) * base.r0, strand_length=np.array([1.0, 1.02]) * base.strand_length)
    got, th = sweep.law()
    assert got == name and th.shape == (laws.NTH, 2)
    for i in range(2):
        one = base.replace(r0=sweep.r0[i], strand_length=sweep.strand_length[i]).law(1)[1][:, 0]
        np.testing.assert_array_equal(th[:, i], one)
    f = laws.evaluate(name, 0.4e6, float(base.nominal_length), th)
    assert np.all(np.isfinite(f)) and np.all(f > 0)  # it pulls at rest under pressure


@pytest.mark.parametrize("name", NAMES)
def test_a_muscle_file_round_trips_and_exports(case, tmp_path, name):
    kind, params, theta, m, path, fit = case(name)
    if kind != "fitted":
        pytest.skip(f"{name} is not fitted: it has no muscle file of its own")
    again = Muscle.from_spec(read_muscle(path))
    copy = again.save(tmp_path / "again.toml")
    np.testing.assert_array_equal(laws.law_of(Muscle.from_spec(read_muscle(copy)).params, name)[1], theta)
    assert dict(again.values) == dict(m.values)
    fmu = export_fmu(muscle_file=path, out=tmp_path / "m.fmu")
    with zipfile.ZipFile(fmu) as z:
        desc = z.read("modelDescription.xml").decode()
    assert f"{name} force law" in desc


@pytest.mark.parametrize("name", NAMES)
def test_a_muscle_file_stops_where_its_law_stops_pulling_more(case, name):
    # a law whose pull peaks as the muscle stretches (Law.peak_length) peaks there at every pressure,
    # and the muscle file's braid ends there when it lies beyond the rest length; its plant then runs
    # (the wall-corrected fit of the commercial table peaks 28 % beyond the rest length, and its plant
    # was refused for the falling branch beyond: negative stiffness)
    law = laws.LAWS[name]
    kind, params, theta, m, path, fit = case(name)
    if law.peak_length is None:
        pytest.skip(f"{name}: its pull does not peak before the straight braid (no Law.peak_length)")
    peak = law.peak_length(theta)
    p = np.array([[0.1e6], [0.4e6], [0.8e6]])
    side = np.array([1 - 1e-6, 1 + 1e-6]) * peak  # just before, just after
    f_peak, f_side = laws.evaluate(name, p, peak, theta), laws.evaluate(name, p, side[None, :], theta)
    assert np.all(f_side < f_peak), f"{name}: the pull does not peak at {peak!r} m"
    if kind == "fitted":
        l0 = float(m.nominal_length)
        if l0 < peak:
            assert m.length_stops[1] <= peak  # the braid ends at the peak (or before it: a shorter strand)
        PlantParams.from_muscle_file(m)  # runs: no negative stiffness inside its end stops


@pytest.mark.parametrize("name", NAMES)
def test_inputs_outside_the_valid_range_are_flagged(case, cli, name):
    kind, params, theta, m, path, fit = case(name)
    if kind == "fitted":
        args = ("--muscle-file", str(path))
        hi = m.pressure_range[1]
    else:
        args = ("--model", name, "--muscle", CATALOGUE)
        hi = m.braid_map.pressure_range[1]
    r = cli("predict", "force", *args, "--pressure", f"{hi * 1.5 / 1e6:.6g}MPa", "--json")
    assert r.code == 0, r.err
    assert "pressure_out_of_range" in r.json()["flags"]
    inside = cli("predict", "force", *args, "--pressure", f"{hi * 0.5 / 1e6:.6g}MPa", "--json")
    assert "pressure_out_of_range" not in inside.json()["flags"]


def test_every_registered_law_is_checked_here():
    # the suite reads the registry: a law file added is a law tested, nothing to list
    assert NAMES == list(laws.LAW_NAMES) and len(NAMES) >= 7
    assert not hasattr(laws, "PLANT_SLOTS")  # the plant has no slots: any number of laws
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        assert all(laws.resolve(a) == n for a, n in laws.ALIASES.items())


@pytest.mark.parametrize("name", NAMES)
def test_an_isotonic_table_from_the_law_is_fitted_and_compared_through_its_force(case, tmp_path, name):
    kind, params, theta, m, path, fit = case(name)
    if kind != "fitted":
        pytest.skip(f"{name} is not fitted (no fit spec)")
    l0 = float(fit.muscle.nominal_length)
    peak = float(np.abs(fit.data["force"]).max())
    p, f = (a.ravel() for a in np.meshgrid(np.linspace(0.25e6, 0.6e6, 8), np.linspace(0.2, 0.6, 5) * peak))
    ell = law_length(fit.result, p, f, 0.6 * l0, 1.05 * l0)  # the law's rest length under each load
    ok = np.isfinite(ell)
    assert ok.sum() >= 20, f"{name}: the law holds too few of the loads"
    csv = tmp_path / "isotonic.csv"
    csv.write_text("pressure_kPa,load_N,length_mm,trial\n" + "".join(
        f"{float(a) / 1e3!r},{float(b)!r},{float(c) * 1e3!r},1\n" for a, b, c in zip(p[ok], f[ok], ell[ok])))
    table = read_table(csv, "isotonic")
    res = fit_isotonic_law(table, fit.muscle, name)
    # the lengths come back (to the fit's tolerance on noise-free data)
    np.testing.assert_allclose(law_length(res, p[ok], f[ok], 0.6 * l0, 1.05 * l0), ell[ok], rtol=1e-4)
    # and the isotonic comparison scores the law (spring, Chou-Hannaford and Tondu-Lopez by their own
    # fits in length, which have no load-cell zero; every other law through its force, as here)
    scores = {s.name: s for s in compare_models(table, fit.muscle)["scores"]}
    assert name in scores


def test_a_law_with_its_own_procedure_has_one_and_every_fit_spec_reads_without_data(case):
    # Law.own_fit (non-isometric tables) is served by mckibben.fit.static.OWN_FITS, nothing else
    # names the law; and a saved law is read back through its spec with no data (names and force)
    from mckibben.fit import static
    from mckibben.fit.isometric import force_law, parameter_names

    assert set(static.OWN_FITS) == set(laws.own_fit_laws())
    for name in laws.fit_laws():
        fit = case(name)[5]
        assert parameter_names(name, fit.muscle) == tuple(fit.result.names), name
        p, ell = fit.data["pressure"].to_numpy(), fit.data["held_length"].to_numpy()
        np.testing.assert_allclose(force_law(name, fit.muscle, fit.result.values)(p, ell),
                                   fit.result.func(fit.result.values, p, ell), rtol=1e-12, err_msg=name)


@pytest.mark.parametrize("name", [n for n in NAMES if laws.LAWS[n].branches == 2])
def test_a_two_branch_law_fits_both_branches_of_a_hysteresis_table(case, tmp_path, name):
    # a hysteresis table's direction column labels each point's branch: before, every row was
    # 'inflate' and the deflate coefficients came back unconstrained (no data held them)
    kind, params, theta, m, path, fit = case(name)
    l0 = float(fit.muscle.nominal_length)
    peak = float(np.abs(fit.data["force"]).max())
    p, f = (a.ravel() for a in np.meshgrid(np.linspace(0.25e6, 0.6e6, 8), np.linspace(0.2, 0.6, 5) * peak))
    rows, lengths = [], {}
    for direction in ("inflate", "deflate"):
        ell, state = law_statics.rising_root(lambda pp, ww, dn=direction: fit.result.func(fit.result.values, pp, ww, dn),
                                             p, f, 0.6 * l0, 1.05 * l0)
        ok = state == 0
        assert ok.sum() >= 20, f"{name} {direction}: the law holds too few of the loads"
        lengths[direction] = (p[ok], f[ok], ell[ok])
        rows += [f"{float(a) / 1e3!r},{float(b)!r},{float(c) * 1e3!r},{direction},1\n"
                 for a, b, c in zip(p[ok], f[ok], ell[ok])]
    gap = np.max(np.abs(fit.result.func(fit.result.values, p, 0.9 * l0, "inflate")
                        - fit.result.func(fit.result.values, p, 0.9 * l0, "deflate")))
    assert gap > 0.01 * peak, f"{name}: the branches do not differ; the test could not tell them apart"
    csv = tmp_path / "hysteresis.csv"
    csv.write_text("pressure_kPa,load_N,length_mm,direction,trial\n" + "".join(rows))
    res = fit_isotonic_law(read_table(csv, "hysteresis"), fit.muscle, name)
    assert not [fl for fl in res.flags if fl.endswith("_unconstrained")], res.flags
    for direction, (pp, ff, ell) in lengths.items():  # each branch's lengths come back
        back, state = law_statics.rising_root(lambda a, b, dn=direction: res.func(res.values, a, b, dn),
                                              pp, ff, 0.6 * l0, 1.05 * l0)
        # rtol: the fit's tolerance on noise-free data (as the isotonic test above)
        np.testing.assert_allclose(back, ell, rtol=1e-4, err_msg=f"{name} {direction}")

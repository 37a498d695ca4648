"""The controller conformance suite: every registered controller through the same checks.

A controller is tested by being registered (DESIGN.md, "One concept, one room"; scikit-learn's
``check_estimator`` is the model): every entry of :data:`mckibben.control.registry.CONTROLLERS`
(the files of ``src/mckibben/control/laws/``) gets its ids held against the one table and the C
headers, its C law against its Python mirror step by step (the host-C core through ctypes,
``tests/test_core_equivalence.py``'s harness), its design and tuning candidates run, its rows in
the comparison and the robustness study, and its bank of three channels measured in cycles and
checked bit for bit on the AVR (simavr). Adding a controller adds a parameter here, not a test.
"""

from __future__ import annotations

import inspect
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from test_core_equivalence import CCore, clib, py_core, run_both  # noqa: F401  (clib: the fixture)
from test_firmware import BANK_CYCLE_BUDGET, Lcg, _mix

from mckibben.control import core, laws, runs
from mckibben.control import registry as R
from mckibben.control.experiment_setup import identified_model

FIRMWARE = Path(__file__).resolve().parents[1] / "firmware"
HEADER = (FIRMWARE / "core" / "controller.h").read_text()
SOURCE = (FIRMWARE / "core" / "controller.c").read_text()
LAWS_H = (FIRMWARE / "core" / "laws.h").read_text()
ENTRIES = list(R.CONTROLLERS.values())
each = pytest.mark.parametrize("spec", ENTRIES, ids=lambda c: c.name)


def _c_int(text: str) -> int:
    return int(re.sub(r"[uUlL]+$", "", text.strip()))


# --- the one table ---------------------------------------------------------------------------------


def test_the_registry_is_the_files_of_control_laws():
    files = sorted(p.stem for p in (Path(laws.__file__).parent).glob("*.py") if not p.stem.startswith("_"))
    assert sorted(R.NAMES) == files
    assert R.NAMES == tuple(sorted(R.NAMES, key=lambda n: R.get(n).mode))


def test_every_id_once_from_the_table():
    assert [g.id for g in R.ALL_GAINS] == list(range(R.N_GAINS))
    assert sorted(laws.GAIN_IDS.values()) == list(range(R.N_GAINS))
    assert len({g.name for g in R.ALL_GAINS}) == len({g.param for g in R.ALL_GAINS}) == R.N_GAINS
    assert R.MODE_IDS == tuple(sorted(laws.MODES.values())) == tuple(range(len(R.MODE_IDS)))
    for name, (mode, gains) in laws.TABLE.items():
        if name in R.CONTROLLERS:
            spec = R.get(name)
            assert spec.mode == mode and {g.name: g.id for g in spec.gains} == gains


@each
def test_gains_have_one_default_in_range(spec):
    assert core.GAINS is R.ALL_GAINS  # one table of the gains: the core reads the registry's
    defaults = core.CoreParams()
    for g in spec.gains:
        assert getattr(defaults, g.param) == g.default
        assert g.lo <= g.default_value <= g.hi, g.name


def test_extension_modes_follow_the_core_s():
    assert [c.mode for c in R.EXTENSIONS] == list(range(R.MODE_OPEN_LOOP + 1, R.MODE_OPEN_LOOP + 1 + len(R.EXTENSIONS)))


def test_laws_h_is_generated_from_the_table():
    """``firmware/core/laws.h`` is what ``python -m mckibben.control.laws`` writes (regenerate it when this fails)."""
    assert LAWS_H == laws.c_header()


@pytest.mark.skipif(not R.EXTENSIONS, reason="no extension law registered: laws.h lists none")
def test_the_generated_header_follows_the_table(monkeypatch):
    """The generator reads the table: another id there is another id in the header (the check can fail)."""
    gain = R.EXTENSIONS[-1].gains[-1]
    monkeypatch.setitem(laws.GAIN_IDS, gain.name, 99)
    assert f"#define {gain.c_name} 99" in laws.c_header() and laws.c_header() != LAWS_H
    assert gain.id == 99


def test_core_ids_in_controller_h_equal_the_table():
    """The core's own ids are hand-written in controller.h (the table's docstring says why): checked here."""
    rows = {}
    for line in HEADER.splitlines():
        r = re.match(r"\s*\*\s+(\d+)\s+(MCK_GAIN_\w+)\s+.*?\s(1e\d+|1)\s+(\d+)(?: \(off\))?\s+(\d+)\s+(\d+)\s*$", line)
        if r:
            rows[int(r.group(1))] = (r.group(2), float(r.group(3)), int(r.group(4)), int(r.group(5)), int(r.group(6)))
    enum = {m.group(1): int(m.group(2)) for m in re.finditer(r"(MCK_(?:GAIN_\w+|N_CORE_GAINS))\s*=\s*(\d+)", HEADER)}
    arrays = {}
    for name in ("default", "lo", "hi"):
        body = re.search(rf"mck_gain_{name}\[MCK_N_GAINS\]\s*=\s*\{{(.*?)\}};", SOURCE, re.S).group(1)
        body = re.sub(r"/\*.*?\*/", "", body, flags=re.S)
        arrays[name] = [_c_int(v) for v in re.findall(r"-?\d+[uUlL]*", body.split("#define")[0])]
    core_gains = [g for g in R.ALL_GAINS if g.id < enum["MCK_N_CORE_GAINS"]]
    assert len(core_gains) == enum["MCK_N_CORE_GAINS"] == len(rows)
    for g in core_gains:
        assert rows[g.id] == (g.c_name, g.scale, g.lo, g.hi, g.default_value), g.name
        assert enum[g.c_name] == g.id
        assert (arrays["default"][g.id], arrays["lo"][g.id], arrays["hi"][g.id]) == (g.default_value, g.lo, g.hi)
    for name in ("off", "open_loop"):
        assert _c_int(re.search(rf"#define MCK_MODE_{name.upper()}\s+(\w+)", HEADER).group(1)) == laws.MODES[name]
    for c in ENTRIES:
        if not c.extension:
            assert _c_int(re.search(rf"#define MCK_MODE_{c.c_name}\s+(\w+)", HEADER).group(1)) == c.mode


@each
def test_the_c_face_of_a_controller(spec):
    """An extension law has its header, listed in the generated laws.h, with the gains of its file."""
    if not spec.extension:
        assert f"law_{spec.name}(" in SOURCE  # the core's own law, in controller.c
        return
    listed = re.findall(r"X\((\w+),\s*(\w+)\)", re.search(r"#define MCK_EXT_LAWS\(X\)(.*)", LAWS_H).group(1))
    assert (spec.c_name, spec.name) in listed and f'#include "law_{spec.name}.h"' in LAWS_H
    text = (FIRMWARE / "core" / f"law_{spec.name}.h").read_text()
    assert _c_int(re.search(rf"#define MCK_MODE_{spec.c_name}\s+(\w+)", LAWS_H).group(1)) == spec.mode
    assert _c_int(re.search(rf"#define MCK_{spec.c_name}_N_GAINS\s+(\w+)", LAWS_H).group(1)) == len(spec.gains)
    table = re.findall(r"G\((MCK_GAIN_\w+),\s*(-?\d+)L?,\s*(-?\d+)L?,\s*(-?\d+)L?\)", text)
    assert [(n, int(d), int(lo), int(hi)) for n, d, lo, hi in table] == [
        (g.c_name, g.default_value, g.lo, g.hi) for g in spec.gains]
    for g in spec.gains:
        assert _c_int(re.search(rf"#define {g.c_name}\s+(\w+)", LAWS_H).group(1)) == g.id
        assert f"#define {g.c_name} " not in text  # the ids are the table's, not the law header's


# --- one file, real functions ------------------------------------------------------------------------


@each
def test_an_entry_is_its_file_s_functions(spec):
    module = f"mckibben.control.laws.{spec.name}"
    hooks = ["law", "design", "candidates", "describe"] + (["derive", "float_law"] if spec.extension else [])
    for what in hooks:
        func = getattr(spec, what)
        assert inspect.isfunction(func) and func.__module__ == module, (spec.name, what, func)
    assert not any(isinstance(v, str) and ":" in v and v.startswith("mckibben.") for v in vars(spec).values())
    assert set(spec.grid) <= set(spec.designs) | set(spec.variants), spec.name


# --- C == Python, bit for bit ------------------------------------------------------------------------


@each
def test_c_equals_python_step_by_step(clib, spec):  # noqa: F811
    """Random references, noisy readings, missing samples, faults and gain changes in the controller's mode."""
    rng = np.random.default_rng(spec.mode)
    c, py = CCore(clib), py_core()
    events = [("set_mode", spec.mode)]
    pref = 0
    for k in range(6000):
        if k % 300 == 0:
            pref = int(rng.integers(0, 900_000))
        if k % 1000 == 500:
            g = spec.gains[int(rng.integers(len(spec.gains)))]
            events.append(("set_gain", g.id, int(rng.integers(g.lo, g.hi + 1))))
        if k % 1500 == 1400:
            events.append(("set_mode", spec.mode))
        adc = int(np.clip(pref / core.HW.PA_PER_COUNT + rng.normal(0, 40 if k % 700 < 350 else 4), 0, 1023))
        events.append(("step", adc, bool(rng.random() > 0.03), pref))
    assert run_both(c, py, events) == 6000
    assert py.istate[core.IS_MODE] == spec.mode


# --- design, tuning, rows ----------------------------------------------------------------------------


@pytest.fixture(scope="module")
def model():
    return identified_model()


@each
def test_every_documented_design_runs_on_the_calibrated_plant(model, spec):
    base = core.CoreParams()
    for variant in spec.variants or (None,):
        params = spec.design(model, base, law=variant)
        assert isinstance(params, core.CoreParams) and params.mode == spec.mode
        described = spec.describe(params)
        assert described and all(isinstance(v, (int, float, str)) for v in described.values())
        rec = runs.run_closed_loop(core.core_spec(params), runs.step_reference(600, 100, 0.0, 0.4e6), 0.6, None)
        m = rec.metrics(0, 0.1)
        # every documented design reaches a 0.4 MPa step within 0.5 s to 5 % (the weakest, the
        # paper's PID, settles slowest) and the supervisor keeps every law below p_max + margin
        assert abs(m["steady_state_error_Pa"]) < 0.05 * 0.4e6, (spec.name, variant, m)
        assert rec.pressure.max() <= params.p_max + runs.SAFETY_TRANSIENT_PA


@each
def test_tuning_candidates_are_designs_of_the_controller(model, spec):
    for name, grid in spec.grid.items():
        variant = name if name in spec.variants else None
        cands, params = spec.candidates(model, core.CoreParams(), 0.6e6, grid, law=variant)
        assert len(cands) == len(params) > 1
        assert all(p.mode == spec.mode for p in params)
        assert len({tuple(sorted(c.items())) for c in cands}) == len(cands)  # no candidate twice


@each
def test_compare_and_robustness_have_rows_for_it(model, spec):
    names = [n for n, c, _ in runs.comparison_entries() if c == spec.name]
    assert len(names) == max(1, len(spec.variants)) and set(names) <= set(runs.CONTROLLER_NAMES)
    rows = runs.step_size_table(model, steps=((0.0, 0.3e6),), loads=(0.6,), hold=0.05, duration=0.3)
    assert {r["controller"] for r in rows} == set(runs.CONTROLLER_NAMES)
    for r in rows:
        if r["controller"] in names:
            assert np.isfinite(r["steady_state_error_Pa"])
    out = runs.robustness_runs(model, n=2, duration=0.3)
    for name in names:
        assert set(out["summary"][name]) >= {"overshoot_pct", "steady_state_error_Pa"}


# --- the firmware bank on the AVR --------------------------------------------------------------------

needs_avr = pytest.mark.skipif(shutil.which("avr-gcc") is None or shutil.which("simavr") is None,
                               reason="avr-gcc or simavr not installed (Debian: gcc-avr avr-libc simavr)")


def _bank_mode_checksum(mode: int) -> int:
    """bench/cycles.c's run_bank_modes() for one mode, with the Python mirror."""
    rnd = Lcg()
    bank = core.CoreBank([core.CoreParams(mode=core.MODE_OFF)] * 3)
    for i in range(3):
        bank[i].set_mode(mode)
    bank[2].set_gain(core.GAIN_IDS["n_stuck"], 20)
    h, pref = 0, [0, 0, 0]
    for k in range(3000):
        adcs, oks = [0, 0, 0], [False] * 3
        for i in range(3):
            r1, r2 = rnd(), rnd()
            if k % 100 == 0:
                pref[i] = r1 * 15
            if (r2 & 1) and i != 2:
                adcs[i] = 100 + (r2 >> 6) % 800
            else:
                adcs[i] = max((pref[i] >> 10) + ((r2 >> 8) & 31) - 16, 0)
            if i == 2 and (k // 50) % 4 == 3:
                adcs[i] = 200
            oks[i] = (r2 & 0x3E) != 0
        if k % 500 == 250:
            for i in range(3):
                bank[i].set_mode(mode)
        for i, (inlet, bleed, faults) in enumerate(bank.step(adcs, oks, pref)):
            h = _mix(h, inlet, bleed, faults, bank[i])
    return h


@pytest.fixture(scope="module")
def cycles(tmp_path_factory):
    build = tmp_path_factory.mktemp("avr")
    return subprocess.run(["make", "-s", "-C", str(FIRMWARE), "cycles", f"BUILD={build}"], capture_output=True,
                          text=True, timeout=180, check=True).stdout


@needs_avr
@pytest.mark.slow
@each
def test_the_bank_in_its_mode_within_the_cycle_budget_and_bit_exact_on_the_avr(cycles, spec):
    """Three channels in the controller's mode on the ATmega2560 (simavr): cycles per step and checksum."""
    m = re.search(rf"bank in mode {spec.mode}: 3000 steps, cycles min \d+ mean \d+ max (\d+)", cycles)
    assert m, cycles
    assert int(m.group(1)) <= BANK_CYCLE_BUDGET, (spec.name, int(m.group(1)))
    s = re.search(rf"bank in mode {spec.mode}: checksum (\d+)", cycles)
    assert int(s.group(1)) == _bank_mode_checksum(spec.mode), spec.name

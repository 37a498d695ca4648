"""The controller registry against the firmware, and every registered law through the same checks.

A controller is tested by being registered (STYLE.md, "Registries"): its gains against the C
headers, its C law against its Python mirror step by step, its cycles on the AVR.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from test_core_equivalence import CCore, clib, py_core, run_both  # noqa: F401  (clib: the fixture)
from test_firmware import BANK_CYCLE_BUDGET, Lcg, _mix

from mckibben.control import core
from mckibben.control import registry as R

FIRMWARE = Path(__file__).resolve().parents[1] / "firmware"
HEADER = (FIRMWARE / "core" / "controller.h").read_text()
SOURCE = (FIRMWARE / "core" / "controller.c").read_text()
LAWS_H = (FIRMWARE / "core" / "laws.h").read_text()


def _c_int(text: str) -> int:
    return int(re.sub(r"[uUlL]+$", "", text.strip()))


def test_every_gain_once_in_id_order_and_one_default_each():
    assert [g.id for g in R.GAINS] == list(range(R.N_GAINS))
    assert len({g.name for g in R.GAINS}) == len({g.param for g in R.GAINS}) == R.N_GAINS
    assert core.GAINS == tuple(core.Gain(g.id, g.name, g.unit, g.scale, g.lo, g.hi, g.default_value) for g in R.GAINS)
    defaults = core.CoreParams()
    for g in R.GAINS:
        assert getattr(defaults, g.param) == g.default
        assert g.lo <= g.default_value <= g.hi, g.name


def test_modes_are_contiguous_and_named_once():
    assert R.MODES == tuple(range(len(R.MODES)))
    assert len(set(R.NAMES)) == len(R.NAMES)
    assert [c.mode for c in R.EXTENSIONS] == list(range(R.MODE_OPEN_LOOP + 1, R.MODE_OPEN_LOOP + 1 + len(R.EXTENSIONS)))


def test_core_gain_table_equals_controller_h_and_c():
    # the table of the header's comment: id name ... scale lo hi default
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
    core_gains = [g for g in R.GAINS if g.id < enum["MCK_N_CORE_GAINS"]]
    assert len(core_gains) == enum["MCK_N_CORE_GAINS"] == len(rows)
    for g in core_gains:
        assert rows[g.id] == (g.c_name, g.scale, g.lo, g.hi, g.default_value), g.name
        assert enum[g.c_name] == g.id
        assert (arrays["default"][g.id], arrays["lo"][g.id], arrays["hi"][g.id]) == (g.default_value, g.lo, g.hi)
    for c in (R.SMC, R.PID):
        assert _c_int(re.search(rf"#define MCK_MODE_{c.c_name}\s+(\w+)", HEADER).group(1)) == c.mode


def test_extension_laws_equal_their_headers():
    listed = re.findall(r"X\((\w+),\s*(\w+)\)", re.search(r"#define MCK_EXT_LAWS\(X\)(.*)", LAWS_H).group(1))
    assert listed == [(c.c_name, c.name) for c in R.EXTENSIONS]
    for c in R.EXTENSIONS:
        assert f'#include "law_{c.name}.h"' in LAWS_H
        text = (FIRMWARE / "core" / f"law_{c.name}.h").read_text()
        assert _c_int(re.search(rf"#define MCK_MODE_{c.c_name}\s+(\w+)", text).group(1)) == c.mode
        assert _c_int(re.search(rf"#define MCK_{c.c_name}_N_GAINS\s+(\w+)", text).group(1)) == len(c.gains)
        table = re.findall(r"G\((MCK_GAIN_\w+),\s*(-?\d+)L?,\s*(-?\d+)L?,\s*(-?\d+)L?\)", text)
        assert [(n, int(d), int(lo), int(hi)) for n, d, lo, hi in table] == [
            (g.c_name, g.default_value, g.lo, g.hi) for g in c.gains]
        for g in c.gains:
            assert _c_int(re.search(rf"#define {g.c_name}\s+(\w+)", text).group(1)) == g.id


def test_every_entry_resolves():
    for c in R.CONTROLLERS.values():
        for what in ("law", "design", "candidates") + (("derive", "float_law") if c.extension else ()):
            assert callable(c.resolve(what)), (c.name, what)
        assert set(c.grid) <= set(c.designs) | set(c.laws), c.name
        if c.extension:
            assert c.describe == "" or callable(c.resolve("describe"))


@pytest.mark.parametrize("spec", R.EXTENSIONS, ids=lambda c: c.name)
def test_extension_law_c_equals_python_step_by_step(clib, spec):  # noqa: F811
    """Random references, noisy readings, missing samples, faults and gain changes in the law's mode."""
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


@needs_avr
@pytest.mark.skipif(not R.EXTENSIONS, reason="no extension law registered")
def test_extension_laws_within_the_bank_cycle_budget_and_bit_exact_on_the_avr(tmp_path):
    out = subprocess.run(["make", "-s", "-C", str(FIRMWARE), "cycles", f"BUILD={tmp_path}"], capture_output=True,
                         text=True, timeout=180, check=True).stdout
    for spec in R.EXTENSIONS:
        m = re.search(rf"bank in mode {spec.mode}: 3000 steps, cycles min \d+ mean \d+ max (\d+)", out)
        assert m, out
        assert int(m.group(1)) <= BANK_CYCLE_BUDGET, (spec.name, int(m.group(1)))
        s = re.search(rf"bank in mode {spec.mode}: checksum (\d+)", out)
        assert int(s.group(1)) == _bank_mode_checksum(spec.mode), spec.name

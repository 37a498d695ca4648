"""The C controller core (built for the host, loaded with ctypes) against the Python mirror.

Every test requires identical outputs (inlet, bleed, faults, surface, reference) at every step:
there is no tolerance, the mirror is bit-exact by construction.
"""

from __future__ import annotations

import ctypes
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mckibben.control import core

FIRMWARE = Path(__file__).resolve().parents[1] / "firmware"


class _Out(ctypes.Structure):
    _fields_ = [
        ("inlet", ctypes.c_uint8),
        ("bleed", ctypes.c_uint8),
        ("faults", ctypes.c_uint8),
        ("reference", ctypes.c_int32),
        ("surface", ctypes.c_int32),
    ]


@pytest.fixture(scope="session")
def clib(tmp_path_factory):
    if shutil.which("gcc") is None or shutil.which("make") is None:
        pytest.skip("gcc/make not installed: cannot build the C core for the host")
    build = tmp_path_factory.mktemp("fw")
    subprocess.run(["make", "-s", "-C", str(FIRMWARE), "host", f"BUILD={build}"], check=True,
                   capture_output=True)
    lib = ctypes.CDLL(str(build / "host" / "libmckcore.so"))
    lib.mck_ctrl_init.argtypes = [ctypes.c_void_p, ctypes.c_uint16]
    lib.mck_ctrl_set_gain.argtypes = [ctypes.c_void_p, ctypes.c_uint8, ctypes.c_int32]
    lib.mck_ctrl_set_gain.restype = ctypes.c_uint8
    lib.mck_ctrl_set_mode.argtypes = [ctypes.c_void_p, ctypes.c_uint8]
    lib.mck_ctrl_set_mode.restype = ctypes.c_uint8
    lib.mck_ctrl_set_max_pressure.argtypes = [ctypes.c_void_p, ctypes.c_int32]
    lib.mck_ctrl_set_max_pressure.restype = ctypes.c_uint8
    lib.mck_ctrl_set_open_loop.argtypes = [ctypes.c_void_p, ctypes.c_uint8, ctypes.c_uint8]
    lib.mck_ctrl_vent.argtypes = [ctypes.c_void_p]
    lib.mck_ctrl_step.argtypes = [ctypes.c_void_p, ctypes.c_uint16, ctypes.c_uint8,
                                  ctypes.c_int32, ctypes.POINTER(_Out)]
    lib.mck_bank_step.argtypes = [ctypes.c_void_p, ctypes.c_uint8, ctypes.POINTER(ctypes.c_uint16), ctypes.c_uint8,
                                  ctypes.POINTER(ctypes.c_int32), ctypes.POINTER(_Out)]
    lib.mck_mulq16.argtypes = [ctypes.c_int32, ctypes.c_int32]
    lib.mck_mulq16.restype = ctypes.c_int32
    lib.mck_mulq16s24.argtypes = [ctypes.c_int32, ctypes.c_int32]
    lib.mck_mulq16s24.restype = ctypes.c_int32
    lib.mck_tanh_q15.argtypes = [ctypes.c_uint16]
    lib.mck_tanh_q15.restype = ctypes.c_uint16
    lib.mck_ctrl_sizeof.restype = ctypes.c_uint
    return lib


class CCore:
    """The C core through ctypes, with the interface of core.CoreController."""

    def __init__(self, lib, ts_us=1000):
        self.lib = lib
        self.buf = ctypes.create_string_buffer(lib.mck_ctrl_sizeof())
        self.out = _Out()
        lib.mck_ctrl_init(self.buf, ts_us)

    def step(self, adc, ok, pref):
        self.lib.mck_ctrl_step(self.buf, adc, int(ok), pref, ctypes.byref(self.out))
        o = self.out
        return o.inlet, o.bleed, o.faults, o.surface, o.reference

    def set_gain(self, i, v):
        return self.lib.mck_ctrl_set_gain(self.buf, i, v)

    def set_mode(self, m):
        return self.lib.mck_ctrl_set_mode(self.buf, m)

    def set_max_pressure(self, p):
        return self.lib.mck_ctrl_set_max_pressure(self.buf, p)

    def set_open_loop(self, i, b):
        self.lib.mck_ctrl_set_open_loop(self.buf, i, b)

    def vent(self):
        self.lib.mck_ctrl_vent(self.buf)


def py_core(ts=1e-3):
    """The Python mirror with the C core's defaults (mode off, as after mck_ctrl_init)."""
    return core.CoreController(core.CoreParams(mode=core.MODE_OFF, ts=ts))


def py_step(ctrl, adc, ok, pref):
    i, b, f = ctrl.step(adc, ok, pref)
    return i, b, f, ctrl.surface_pa, ctrl.reference_pa


def run_both(c, py, events):
    """Apply the same events to both; return the number of steps compared."""
    n = 0
    for ev in events:
        kind, args = ev[0], ev[1:]
        if kind == "step":
            rc, rp = c.step(*args), py_step(py, *args)
            assert rc == rp, f"step {n} {args}: C {rc} != Python {rp}"
            n += 1
        else:
            sc, sp = getattr(c, kind)(*args), getattr(py, kind)(*args)
            assert sc == sp, f"{kind}{args}: C status {sc} != Python {sp}"
    return n


def test_defaults_match(clib):
    """Python's CoreParams defaults are the C defaults, gain by gain."""
    values = core.gain_values(core.CoreParams())
    assert [g.default_value for g in core.GAINS] == list(values)
    c, py = CCore(clib), py_core()
    # Setting each default again changes nothing: compare a short closed run before/after.
    for g in core.GAINS:
        assert c.set_gain(g.id, g.default_value) == py.set_gain(g.id, g.default_value) == 0


def test_mulq16_and_tanh(clib):
    rng = np.random.default_rng(1)
    xs = rng.integers(-(2**31), 2**31, 3000)
    cs = rng.integers(0, 2**31, 3000) >> rng.integers(0, 31, 3000)
    edge_x = [0, -1, -(2**31), 2**31 - 1, 65535, -65536]
    edge_c = [0, 1, 65535, 65536, 2**31 - 1]
    pairs = list(zip(xs.tolist(), cs.tolist(), strict=True))
    pairs += [(x, c) for x in edge_x for c in edge_c]
    for x, c in pairs:
        assert clib.mck_mulq16(x, c) == core.mulq16(x, c), (x, c)
        assert clib.mck_mulq16s24(x >> 8, c) == core.mulq16(x >> 8, c), (x >> 8, c)
    # The whole domain of the interpolated tanh: C and Python agree everywhere.
    for x in range(0, 32768):
        assert clib.mck_tanh_q15(x) == core.tanh_q15(x)
    # The table in controller.c is the one tanh_table() generates.
    src = (FIRMWARE / "core" / "controller.c").read_text()
    body = src.split("mck_tanh_tab[129] MCK_ROM = {")[1].split("};")[0]
    assert [int(v) for v in body.replace("\n", " ").split(",") if v.strip()] == \
        core.tanh_table().tolist()


def _closed_loop(c, py, mode, pref_fn, n, seed):
    """Closed loop on a crude pressure model driven by the C core's outputs.

    The model only generates realistic measurement sequences (tracking, saturation, noise);
    both cores see the same ADC values and must give the same outputs at every step.
    """
    rng = np.random.default_rng(seed)
    run_both(c, py, [("set_mode", mode)])
    p = 0.0
    for k in range(n):
        adc = int(np.clip(round(p / (1e6 / 1023) + rng.normal(0, 0.7)), 0, 1023))
        inlet, bleed, *_ = c.step(adc, True, int(pref_fn(k)))
        assert (inlet, bleed, *_) == py_step(py, adc, True, int(pref_fn(k))), f"step {k}"
        # inlet fills towards 3 kPa per count with tau = 90 ms; bleed empties in 50 ms at 255
        p += 1e-3 / 0.09 * (3000.0 * inlet - p) if inlet else -1e-3 / 0.05 * bleed / 255 * p
        p = max(p, 0.0)


@pytest.mark.parametrize("mode", [core.MODE_SMC, core.MODE_PID])
def test_closed_loop_steps_ramps_noise(clib, mode):
    c, py = CCore(clib), py_core()
    _closed_loop(c, py, mode, lambda k: 550_000 if k >= 10 else 0, 1500, 1)
    _closed_loop(c, py, mode, lambda k: min(k * 400, 700_000), 1500, 2)
    _closed_loop(c, py, mode, lambda k: 300_000 + 200_000 * np.sin(2 * np.pi * k / 500), 1500, 3)


def test_supervisor_paths(clib):
    """ADC faults, stuck sensor, missing samples, overpressure, vent, clamps, mode switches."""
    c, py = CCore(clib), py_core()
    ev = [("set_mode", 1)]
    ev += [("step", 300, True, 2_000_000)] * 5          # reference above p_max: clamped
    ev += [("step", 300, True, -50_000)] * 3            # negative reference: clamped to 0
    ev += [("step", 1023, True, 400_000)] * 3           # ADC at the rail: latched vent
    ev += [("step", 300, True, 400_000)] * 3            # still latched
    ev += [("set_mode", 1)] + [("step", 300, True, 400_000)] * 3
    ev += [("step", 850, True, 400_000)] * 2            # overpressure (> 820 kPa)
    ev += [("step", 830, True, 400_000)] * 2            # hysteresis: still venting
    ev += [("step", 700, True, 400_000)] * 2            # below p_max: released
    ev += [("step", 300, False, 400_000)] * 12          # missing samples: latched at 10
    ev += [("set_mode", 2), ("step", 600, True, 0)] + [("step", 100, True, 700_000)] * 300  # stuck, inlet 255
    ev += [("set_mode", 3), ("set_open_loop", 200, 40)] + [("step", 300, True, 0)] * 3
    for inlet, bleed, adc in ((207, 0, 100), (208, 0, 100), (0, 135, 400), (0, 136, 400), (0, 255, 10), (255, 0, 790)):
        # the response rule's edges (tests/test_core.py): the supply showed 800 counts first
        ev += [("set_mode", 3), ("set_open_loop", 0, 0), ("step", 800, True, 0),
               ("set_open_loop", inlet, bleed)] + [("step", adc, True, 0)] * 255
    ev += [("vent",)] + [("step", 300, True, 0)] * 2
    ev += [("set_mode", 0)] + [("step", 300, True, 0)] * 2
    ev += [("set_mode", 7), ("set_max_pressure", 1_000_001), ("set_max_pressure", -1)]
    ev += [("set_max_pressure", 500_000), ("set_mode", 1)] + [("step", 300, True, 600_000)] * 3
    ev += [("set_gain", 20, 5), ("set_gain", 0, 255_001), ("set_gain", 4, -1), ("set_gain", 17, 255_001)]
    ev += [("set_gain", 18, 100_000_001), ("set_gain", 19, 255_001), ("set_gain", 18, 499), ("set_gain", 19, 109_600)]
    ev += [("set_gain", 13, 200)] + [("step", 150, True, 100_000)] * 2
    ev += [("set_gain", 17, 114_000)] + [("step", 150 + k, True, 300_000) for k in range(10)]  # u0: lift-off
    ev += [("set_gain", 4, 0)] + [("step", 150 + k, True, 300_000) for k in range(20)]  # G = 0: no model term
    assert run_both(c, py, ev) > 600


def test_other_control_period(clib):
    c, py = CCore(clib, ts_us=500), py_core(ts=500e-6)
    ev = [("set_mode", 1)] + [("step", 200 + k % 7, k % 13 != 0, 300_000 + 37 * k)
                              for k in range(300)]
    ev += [("set_mode", 2)] + [("step", 400 - k % 5, True, 350_000) for k in range(300)]
    run_both(c, py, ev)


# --- property test: random gains, random inputs -------------------------------------------------

_gain_values = st.tuples(*[st.integers(g.lo, g.hi) for g in core.GAINS])
_event = st.one_of(
    st.tuples(st.just("step"), st.integers(0, 1100), st.booleans(),
              st.integers(-200_000, 1_300_000)),
    st.tuples(st.just("set_mode"), st.integers(0, 4)),
    st.tuples(st.just("vent")),
    st.tuples(st.just("set_gain"), st.integers(0, core.N_GAINS - 1), st.integers(-10, 2**31 - 1)),
)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(gains=_gain_values, mode=st.integers(1, 2), p_max=st.integers(0, core.P_MAX_LIMIT),
       events=st.lists(_event, min_size=1, max_size=120),
       walk=st.lists(st.integers(-40, 40), min_size=200, max_size=200))
def test_property_random_gains_and_inputs(clib, gains, mode, p_max, events, walk):
    c, py = CCore(clib), py_core()
    setup = [("set_gain", i, v) for i, v in enumerate(gains)]
    setup += [("set_max_pressure", p_max), ("set_mode", mode)]
    # a random walk of the ADC near a reference (inside the tanh table), then random events
    adc = 400
    for d in walk:
        adc = min(max(adc + d, 0), 1023)
        setup.append(("step", adc, True, 400_000))
    run_both(c, py, setup + list(events))


# --- three channels: mck_bank_step against CoreBank -------------------------------------------


class CBank:
    """N channels of the C core in one array, stepped by mck_bank_step."""

    def __init__(self, lib, n):
        self.lib, self.n = lib, n
        self.size = lib.mck_ctrl_sizeof()
        self.buf = ctypes.create_string_buffer(self.size * n)
        self.out = (_Out * n)()
        for i in range(n):
            lib.mck_ctrl_init(self.ptr(i), 1000)

    def ptr(self, i):
        return ctypes.addressof(self.buf) + i * self.size

    def step(self, adcs, oks, refs):
        a = (ctypes.c_uint16 * self.n)(*adcs)
        r = (ctypes.c_int32 * self.n)(*refs)
        mask = sum(1 << i for i, ok in enumerate(oks) if ok)
        self.lib.mck_bank_step(self.buf, self.n, a, mask, r, self.out)
        return [(o.inlet, o.bleed, o.faults, o.surface, o.reference) for o in self.out]


@pytest.mark.parametrize("n", [1, 2, 3])
def test_bank_of_channels_with_different_gains(clib, n):
    """Three channels with different gains and laws, one shared supply estimate: C == Python."""
    gains = [{}, {"smc_beta": 150_000, "smc_eps": 5000, "pid_kd": 20_000_000},
             {"smc_g": 62_000_000, "smc_u0": 109_000, "sup_g": 62_000_000, "sup_u0": 109_000, "n_stuck": 20}]
    c = CBank(clib, n)
    py = core.CoreBank([core.CoreParams(mode=core.MODE_OFF)] * n)
    for i in range(n):
        for name, v in gains[i].items():
            assert clib.mck_ctrl_set_gain(c.ptr(i), core.GAIN_IDS[name], v) == py[i].set_gain(core.GAIN_IDS[name], v) == 0
    rng = np.random.default_rng(7)
    p = np.zeros(n)
    steps = 0
    stuck_seen = [False] * n
    for phase, mode in enumerate([1, 2, 1, 3, 1]):
        for i in range(n):
            assert clib.mck_ctrl_set_mode(c.ptr(i), mode if i != 1 or phase != 2 else 2) == \
                py[i].set_mode(mode if i != 1 or phase != 2 else 2)
            clib.mck_ctrl_set_open_loop(c.ptr(i), 150 + 30 * i, 0)
            py[i].set_open_loop(150 + 30 * i, 0)
        refs = [int(v) for v in rng.integers(0, 800_000, n)]
        for k in range(400):
            adcs = [int(np.clip(round(p[i] / (1e6 / 1023) + rng.normal(0, 0.3)), 0, 1023)) for i in range(n)]
            if n == 3 and 100 <= k < 250:
                adcs[2] = 300  # channel 2's sensor freezes: its response rule must see it
            oks = [bool(rng.random() > 0.02) for _ in range(n)]
            rc = c.step(adcs, oks, refs)
            rp = py.step(adcs, oks, refs)
            rp = [(*o, py[i].surface_pa, py[i].reference_pa) for i, o in enumerate(rp)]
            assert rc == rp, f"phase {phase} step {k}: C {rc} != Python {rp}"
            for i in range(n):
                stuck_seen[i] |= bool(rc[i][2] & core.FAULT_STUCK)
            steps += 1
            for i in range(n):  # a crude chamber per channel, driven by that channel's outputs
                inlet, bleed = rc[i][0], rc[i][1]
                p[i] += 1e-3 / 0.09 * (3000.0 * inlet - p[i]) if inlet else -1e-3 / 0.05 * bleed / 255 * p[i]
                p[i] = max(p[i], 0.0)
    assert steps == 2000
    # the frozen channel was caught, and only it: a stuck sensor on one channel leaves the others alone
    assert stuck_seen == [n == 3 and i == 2 for i in range(n)]

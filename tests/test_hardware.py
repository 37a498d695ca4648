"""The rig's constants equal the firmware's, and the one sensor model behaves as documented."""

import re
from pathlib import Path

import numpy as np

from mckibben import hardware as HW

FIRMWARE = Path(__file__).resolve().parents[1] / "firmware"


def _define(text: str, name: str) -> int:
    m = re.search(rf"#define\s+{name}\s+(\d+)[uUlL]*\b", text)
    assert m, f"{name} not found"
    return int(m.group(1))


def test_constants_equal_the_firmware():
    header = (FIRMWARE / "core" / "controller.h").read_text()
    source = (FIRMWARE / "core" / "controller.c").read_text()
    main = (FIRMWARE / "src" / "main.c").read_text()
    assert HW.P_MAX_LIMIT == _define(header, "MCK_P_MAX_LIMIT")
    assert (HW.TS_US_MIN, HW.TS_US_MAX) == (_define(header, "MCK_TS_US_MIN"), _define(header, "MCK_TS_US_MAX"))
    assert HW.CONTROL_PERIOD_US == _define(main, "TS_US")
    assert HW.CONTROL_PERIOD == 1e-3
    # mck_ctrl_init's default maximum pressure
    m = re.search(r"c->(?:k\.)?p_max\s*=\s*(\d+)L?;", source)
    assert m and HW.P_MAX_DEFAULT == int(m.group(1))
    # the gain table of the header: adc_zero's upper bound is the ADC's largest count, and the
    # default pa_per_count (fixed point, scale 1e3) is our scale rounded the firmware's way
    row = {}
    for line in header.splitlines():
        r = re.match(r"\s*\*\s+(\d+)\s+(MCK_GAIN_\w+)\s+.*?\s(\d+)\s+(\d+)\s+(\d+)\s*$", line)
        if r:
            row[r.group(2)] = tuple(int(r.group(k)) for k in (3, 4, 5))
    assert row["MCK_GAIN_ADC_ZERO"][1] == HW.ADC_MAX == 2**HW.ADC_BITS - 1
    assert row["MCK_GAIN_ADC_MAX"][1] == HW.ADC_MAX
    assert row["MCK_GAIN_PA_PER_COUNT"][2] == round(HW.PA_PER_COUNT * 1e3)
    # and the ADC clamp of the step
    assert f"> {HW.ADC_MAX}u ? {HW.ADC_MAX}u" in source
    # the load cell's ADC input
    assert HW.LOAD_CELL_ADC == _define(main, "MCK_LOAD_CELL_ADC")
    assert HW.PIN_MAP["load_cell"] == (f"A{HW.LOAD_CELL_ADC}",)


def test_adc_rounds_to_the_nearest_count_halves_up_and_saturates():
    ppc = HW.PA_PER_COUNT
    # exact halves (x.5 counts) go up, just below goes down: one rule, not Python's half-even
    halves = np.array([0.5, 1.5, 2.5, 562.5]) * 1024.0  # a scale where halves are exact in binary
    assert HW.adc_from_pressure(halves, 0, 1024.0).tolist() == [1, 2, 3, 563]
    assert HW.adc_from_pressure(np.nextafter(2.5 * 1024.0, 0), 0, 1024.0) == 2
    assert HW.adc_from_pressure(0.55e6) == 563  # 0.55e6/977.5 = 562.65
    assert HW.adc_from_pressure([-5e4, 2e6]).tolist() == [0, HW.ADC_MAX]  # saturated both ends
    assert HW.adc_from_pressure(0.0, adc_zero=12) == 12
    # the compiled scalar kernel and the array face are the same function
    p = np.linspace(-1e4, 1.1e6, 2001)
    assert HW.adc_from_pressure(p, 3, ppc).tolist() == [HW.adc_count(x, ppc, 3.0) for x in p]
    # reading back: within half a count of the truth inside the range
    back = HW.pressure_from_adc(HW.adc_from_pressure(p[(p >= 0) & (p <= 1e6)]))
    assert np.max(np.abs(back - p[(p >= 0) & (p <= 1e6)])) <= 0.5 * ppc + 1e-9


def test_encoder_counts_shortening_from_the_rest_length():
    l0, res = 0.097, HW.ENCODER_RESOLUTION
    assert HW.encoder_from_length(l0, l0) == 0
    assert HW.encoder_from_length(l0 - 10 * res, l0) == 10
    assert HW.encoder_from_length(l0 + 3 * res, l0) == -3  # stretched beyond rest: negative
    x = np.linspace(0.07, 0.104, 999)
    q = HW.quantize_length(x, l0)
    assert np.max(np.abs(q - x)) <= 0.5 * res + 1e-12
    assert [HW.encoder_count(v, l0, res) for v in x] == HW.encoder_from_length(x, l0).tolist()


def test_bench_constants_equal_the_firmware_main():
    main = (FIRMWARE / "src" / "main.c").read_text()
    assert HW.N_CHANNELS == _define(main, "MCK_N_CHANNELS")
    assert HW.BAUD == _define(main, "BAUD")
    ubrr = _define(main, "UBRR_VALUE")
    assert 16_000_000 / (8 * (ubrr + 1)) == HW.BAUD  # U2X: 0 % error
    # the pin map of the header comment, channel by channel, and the compare unit of each pin
    for i in range(HW.N_CHANNELS):
        assert f"A{i}" == HW.PIN_MAP["pressure"][i]
        inlet, bleed = HW.PIN_MAP["inlet"][i], HW.PIN_MAP["bleed"][i]
        line = re.search(rf"\*\s+{inlet}, {bleed}\s+channel {i} inlet, bleed\s+\((\w+), (\w+)\)", main)
        assert line, f"channel {i} pins not in main.c's header"
        assert (line.group(1), line.group(2)) == (HW.PWM_UNIT[inlet], HW.PWM_UNIT[bleed])
        # and set_valves writes those compare registers for that channel
        for unit, side in ((HW.PWM_UNIT[inlet], "inlet"), (HW.PWM_UNIT[bleed], "bleed")):
            assert re.search(rf"PWM_OUT\(OCR{unit[2:]}, TCCR{unit[2]}A, COM{unit[2:]}1, o\[{i}\]\.{side}\)", main)

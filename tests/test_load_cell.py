"""The load cell (issue 35, item 3): its one model, protocol version 3, both device engines, the host.

The device tests run on both engines (the Python emulator and the firmware image in simavr, built
with ``LOAD_CELL_MN``), against real ptys, with the library's own host and the CLI in its own
process. The plant's true tension comes from the engine itself (the Python plant's outputs, the C
plant's ``mk_outputs`` in the harness's counters line), not from a copy of the model here.
"""

import ctypes
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from mckibben import hardware as HW
from mckibben.errors import InputError
from mckibben.rig import Device
from mckibben.rig import firmware as FW
from mckibben.rig import protocol as P
from mckibben.rig.device import connect

from conftest import start_device

ROOT = Path(__file__).resolve().parents[1]
#: The cell the device tests fit: the paper rig's 5 N, a zero offset of 0.15 N and 10 mN noise.
CELL = HW.LoadCell(full_scale=5.0, offset=0.15, noise=0.01)


# ---- the one model -------------------------------------------------------------------------


def test_the_model_is_the_sensor_model_on_the_force_with_the_rail_at_zero():
    cell = HW.LoadCell(5.0)
    res = 5.0 / HW.ADC_MAX
    assert cell.resolution == res
    assert cell.count(0.0) == 0
    assert cell.count(-0.3) == 0  # a cell in tension: below zero force, the rail
    assert HW.LoadCell(5.0, offset=-0.2).count(0.1) == 0  # an offset below zero clips too
    assert cell.count(7.0) == HW.ADC_MAX  # above the full scale, the other rail
    assert cell.count(1.0) == round(1.0 / res)
    # nearest count, halves up, as the pressure sensor (one kernel: hardware.adc_count)
    assert cell.count(2.5 * res) == 3 and cell.count(2.49 * res) == 2
    assert cell.count(1.0, noise_sample=0.05) == HW.adc_count(1.05, res, 0.0)
    assert HW.LoadCell(5.0, offset=0.1).count(1.0) == cell.count(1.1)
    assert HW.force_from_count(cell.count(1.0), 5.0) == pytest.approx(1.0, abs=res / 2)


@pytest.mark.parametrize("kw, names", [
    ({"full_scale": -5.0}, "load_cell"),
    ({"full_scale": 0.0}, "load_cell"),
    ({"full_scale": 2e4}, "load_cell"),
    ({"full_scale": float("nan")}, "load_cell"),
    ({"offset": 6.0}, "load_cell_offset"),
    ({"noise": -0.01}, "load_cell_noise"),
    ({"noise": 1.0}, "load_cell_noise"),
])
def test_a_bad_cell_is_refused_naming_the_argument(kw, names):
    with pytest.raises(InputError) as e:
        HW.LoadCell(**{"full_scale": 5.0, **kw})
    assert str(e.value).startswith(names + ":") and "\n" not in str(e.value)


def test_the_firmware_build_takes_the_full_scale_in_mn_and_refuses_a_bad_one():
    assert FW.load_cell_mn(None) == 0 and FW.load_cell_mn(5.0) == 5000
    for bad in (-1.0, 0.0, 1e6, "five"):
        with pytest.raises(InputError, match=r"^load_cell: "):
            FW.load_cell_mn(bad)


def test_firmware_build_load_cell_makes_an_image_that_reads_a3(cli, tmp_path):
    r = cli("firmware", "build", "--load-cell", "5N", "--out", str(tmp_path / "img"), "--json")
    assert r.code == 0, r.err
    out = r.json()
    assert out["load_cell_N"] == 5.0
    syms = subprocess.run(["avr-nm", out["elf"]], capture_output=True, text=True, check=True).stdout
    assert " force_val" in syms  # the ADC3 count the tick streams: only in an image with a load cell
    for bad in ("-1N", "0N", "2e4N", "5Pa"):
        r = cli("firmware", "build", "--load-cell", bad, "--out", str(tmp_path / "bad"))
        assert r.code == 2 and r.err.startswith("error: --load-cell:") and len(r.err.strip().splitlines()) == 1, r.err
    assert not (tmp_path / "bad").exists()  # nothing half-written


# ---- protocol version 3, and the old versions ------------------------------------------------


def _frame(seq, force_adc=None):
    chans = [P.ChannelTelemetry(100 + i, 10, 0, 1, 0, 400_000, -5) for i in range(3)]
    return P.Telemetry.of_channels(seq, 1234, -7, chans, force_adc)


def test_version_3_carries_the_force_and_versions_1_and_2_still_parse():
    p = P.Parser(load_cell=5.0)
    got = p.feed(P.encode_telemetry(_frame(1, 512)))[0]
    assert got.force_adc == 512 and got.force == pytest.approx(512 * 5.0 / HW.ADC_MAX)
    assert len(P.encode_telemetry(_frame(1, 512))) == P.telemetry_wire_bytes(3, force=True) == 61
    # a device without a load cell: no force field, force None
    assert P.Parser().feed(P.encode_telemetry(_frame(2)))[0].force is None
    # version 2 (before the load cell) and version 1 (one channel) frames: read, force None
    old = P.Parser()
    v2, v1 = old.feed(P.encode_telemetry_v2(_frame(3, 512)) + P.encode_telemetry_v1(_frame(4)))
    assert (v2.seq, v2.force, v2.force_adc, len(v2.channels)) == (3, None, None, 3)
    assert (v1.seq, v1.force, len(v1.channels)) == (4, None, 1)
    assert old.bad_version == 0 and old.corrupt == 0
    # a version 2 frame of the force's length is not a version 3 one: corrupt, not misread
    bad = P.encode_frame(P.TELEMETRY, 5, _raw_body(_frame(5, 1)), version=2)
    assert old.feed(bad) == [] and old.corrupt == 1


def _raw_body(t):
    raw = P.cobs_decode(P.encode_telemetry(t)[:-1])
    return raw[4:-2]


def test_hello_says_whether_a_load_cell_is_fitted_and_the_parser_takes_its_full_scale():
    p = P.Parser()
    hello, frame = p.feed(P.encode_hello(0, 3, 1000, 1_000_000, 25, load_cell=2.5) + P.encode_telemetry(_frame(1, 1023)))
    assert hello == P.Hello(0, 3, 1000, 1_000_000, 25, 2.5)
    assert frame.force == pytest.approx(2.5)  # the device's full scale, from its HELLO
    assert P.Parser().feed(P.encode_hello(0, 3, 1000, 1_000_000, 25))[0].load_cell is None
    # a version 2 HELLO (8 bytes): no load cell
    assert P.Parser().feed(P.encode_hello(0, 3, 1000, 1_000_000, 25, version=2)) == [P.Hello(0, 3, 1000, 1_000_000, 25)]


class _ChannelC(ctypes.Structure):
    _fields_ = [("pressure_adc", ctypes.c_uint16), ("inlet_pwm", ctypes.c_uint8), ("bleed_pwm", ctypes.c_uint8),
                ("mode", ctypes.c_uint8), ("faults", ctypes.c_uint8), ("reference_pa", ctypes.c_int32),
                ("surface_pa", ctypes.c_int32)]


class _TelemetryC(ctypes.Structure):
    _fields_ = [("t_us", ctypes.c_uint32), ("encoder", ctypes.c_int32), ("n", ctypes.c_uint8),
                ("ch", _ChannelC * 3), ("force_adc", ctypes.c_uint16)]


def test_the_firmware_encoder_writes_the_force_as_the_host_reads_it(tmp_path):
    so = tmp_path / "libproto.so"
    subprocess.run(["gcc", "-std=c99", "-Wall", "-Wextra", "-Werror", "-O2", "-fPIC", "-shared", "-o", str(so),
                    str(ROOT / "firmware" / "core" / "protocol.c")], check=True)
    lib = ctypes.CDLL(str(so))
    lib.mck_encode_telemetry.restype = lib.mck_encode_telemetry_force.restype = ctypes.c_size_t
    chans = (_ChannelC * 3)(*[_ChannelC(100 + i, 10, 0, 1, 0, 400_000, -5) for i in range(3)])
    buf = (ctypes.c_uint8 * 80)()
    t = ctypes.byref(_TelemetryC(1234, -7, 3, chans, 777))
    n = lib.mck_encode_telemetry_force(t, 9, buf, 80)
    assert bytes(buf[:n]) == P.encode_telemetry(_frame(9, 777))
    n = lib.mck_encode_telemetry(t, 9, buf, 80)  # the image without a load cell
    assert bytes(buf[:n]) == P.encode_telemetry(_frame(9))


# ---- both engines ------------------------------------------------------------------------------


def _tension(dev) -> float:
    """Channel 0's true tension, from the engine (python: its plant; avr: the C plant's counters)."""
    if hasattr(dev, "wait_until"):  # avr: the counters line comes every 0.2 s
        assert dev.wait_until(lambda: len(dev.tensions()) > 0, timeout=30)
    return float(dev.tensions()[0])


def _frames(port, seconds, **stream):
    link, hello, parser = connect(port)
    out = []
    try:
        link.write(P.stream(0, True, 1))
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            out += [f for f in parser.feed(link.read(8192)) if isinstance(f, P.Telemetry)]
        link.write(P.stream(1, False, 1))
    finally:
        link.close()
    return hello, out


def test_streamed_force_agrees_with_the_plants_tension(engine):
    """At rest (valves shut, the hanging load on the muscle) the tension is constant: the mean of
    the streamed force is the tension plus the cell's offset within the noise's standard error and
    one count, and its spread is the modelled noise with the count's rounding."""
    with start_device(engine, load_cell=CELL, boot_time=0.05) as dev:
        hello, frames = _frames(dev.port, 1.0)
        tension = _tension(dev)
    assert hello.load_cell == CELL.full_scale
    f = np.array([fr.force for fr in frames[100:]])  # after the first 0.1 s
    assert len(f) >= 300, len(frames)
    assert tension > 0.1  # the hanging load: something to read
    res = CELL.resolution
    spread = np.hypot(CELL.noise, res / np.sqrt(12))  # noise and the rounding to a count
    # 5 standard errors of the mean, plus one count (the rounding's bias where the noise is small)
    assert abs(f.mean() - (tension + CELL.offset)) <= 5 * spread / np.sqrt(len(f)) + res
    assert 0.7 * spread <= f.std() <= 1.3 * spread  # the sample spread of >= 300 draws is within 30 %
    # every reading is a whole count of the resolution
    np.testing.assert_allclose(f / res, np.round(f / res), atol=1e-9)


def test_the_cell_rails_at_zero_below_zero_force(engine):
    """An offset that takes the reading below zero force: every count is 0 (the rail), none negative."""
    cell = HW.LoadCell(5.0, offset=-2.0, noise=0.01)
    with start_device(engine, load_cell=cell, boot_time=0.05) as dev:
        _, frames = _frames(dev.port, 0.4)
        tension = _tension(dev)
    assert tension + cell.offset < -10 * cell.noise  # well below zero force
    assert len(frames) > 100 and {fr.force_adc for fr in frames} == {0}


def test_tare_then_read_force_and_step_report_the_tared_force(engine):
    with start_device(engine, load_cell=CELL, boot_time=0.05) as dev:
        d = Device(dev.port)
        tare = d.tare(300)
        tension = _tension(dev)
        time.sleep(0.1)  # a port closed and reopened within one poll is not seen as a reset
        reading = d.read_force(200)
        time.sleep(0.1)
        step = subprocess.run([sys.executable, "-m", "mckibben.cli", "rig", "step", "--port", dev.port, "--target",
                               "0.3MPa", "--duration", "0.3s", "--json"], capture_output=True, text=True, timeout=120)
    res = CELL.resolution
    # the tare is the untared mean at zero load: the rest tension plus the offset
    assert tare.metrics["offset_N"] == pytest.approx(tension + CELL.offset, abs=5 * CELL.noise / np.sqrt(300) + res)
    assert d.force_offset == tare.offset and tare.metrics["force_N"] == pytest.approx(0.0, abs=1e-12)
    assert reading.metrics["offset_N"] == tare.offset
    assert abs(reading.metrics["force_N"]) <= 5 * CELL.noise / np.sqrt(200) + 2 * res  # nothing changed: ~0
    assert reading.to_pandas()["force_N"].mean() == pytest.approx(reading.metrics["force_N"])
    assert step.returncode == 0, step.stderr
    out = json.loads(step.stdout)
    # a new Device in the CLI: no tare, so the force reported is the untared reading at the step's end
    assert out["force_offset_N"] == 0.0
    assert out["force_N"] == pytest.approx(tension + CELL.offset, abs=0.1)  # the load holds the tension


def test_rig_record_writes_a_force_column(engine, tmp_path):
    out = tmp_path / "rec.parquet"
    with start_device(engine, load_cell=CELL, boot_time=0.05) as dev:
        r = subprocess.run([sys.executable, "-m", "mckibben.cli", "rig", "record", "--port", dev.port, "--out",
                            str(out), "--duration", "0.5s", "--json"], capture_output=True, text=True, timeout=120)
        tension = _tension(dev)
    assert r.returncode == 0, r.stderr
    df = pd.read_parquet(out)
    assert df.columns[-1] == "force_N" and len(df) > 100
    assert abs(df["force_N"].iloc[50:].mean() - (tension + CELL.offset)) <= 5 * CELL.noise / 10 + CELL.resolution


def test_without_a_load_cell_there_is_no_force(engine, tmp_path):
    with start_device(engine, boot_time=0.05) as dev:
        hello, frames = _frames(dev.port, 0.2)
        time.sleep(0.1)
        with pytest.raises(InputError, match=r"^port: .* has no load cell"):
            Device(dev.port).tare(10)
    assert hello.load_cell is None and frames and all(f.force is None for f in frames)


# ---- bad input ---------------------------------------------------------------------------------


@pytest.mark.parametrize("args, flag", [
    (["--load-cell", "-5N"], "--load-cell"),
    (["--load-cell", "0N"], "--load-cell"),
    (["--load-cell", "5N", "--load-cell-offset", "9N"], "--load-cell-offset"),
    (["--load-cell", "5N", "--load-cell-noise", "2N"], "--load-cell-noise"),
    (["--load-cell", "5N", "--load-cell-noise", "-1N"], "--load-cell-noise"),
    (["--load-cell", "5 parsecs"], "--load-cell"),
    (["--load-cell-noise", "0.1N"], "--load-cell-offset/--load-cell-noise"),
])
def test_rig_emulate_refuses_a_bad_load_cell_in_one_line(cli, args, flag):
    r = cli("rig", "emulate", *args, "--duration", "1s")
    assert r.code == 2, r.err
    lines = r.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: {flag}:"), r.err
    assert "Traceback" not in r.err and r.out == ""


@pytest.mark.parametrize("samples", [0, -3, 2.5, True, 10**6])
def test_tare_refuses_a_bad_sample_count_before_opening_the_port(samples):
    with pytest.raises(InputError, match=r"^samples: "):
        Device("/dev/nonexistent-mckibben").tare(samples)

"""The serial protocol: CRC, COBS, frames, the parser's guarantees, and C ↔ Python byte equality."""

import ctypes
import random
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mckibben.rig import protocol as P

ROOT = Path(__file__).resolve().parents[1]


def test_crc_check_value():
    assert P.crc16(b"123456789") == 0x29B1  # the catalogued check value of CRC-16/CCITT-FALSE


@given(st.binary(max_size=300))
def test_cobs_round_trip_and_no_zero_bytes(data):
    enc = P.cobs_encode(data)
    assert 0 not in enc
    assert P.cobs_decode(enc) == data


def _telemetry(seq, **kw):
    base = dict(t_us=123456, pressure_adc=563, encoder=-42, inlet_pwm=200, bleed_pwm=0, mode=1, faults=0,
                reference_pa=550000, surface_pa=-1234)
    base.update(kw)
    return P.Telemetry(seq, **base)


def _three(seq, t_us=123456):
    chans = [P.ChannelTelemetry(563 + i, 200 - i, i, 1, i, 550000 + i, -1234 * i) for i in range(3)]
    return P.Telemetry.of_channels(seq, t_us, -42, chans)


def test_telemetry_frame_sizes_on_the_wire():
    # docs/protocol.md baud arithmetic: 9 + 14 n body bytes, 8 of framing
    assert len(P.encode_telemetry(_telemetry(7))) == 31 == P.telemetry_wire_bytes(1)
    assert len(P.encode_telemetry(_three(7))) == 59 == P.telemetry_wire_bytes(3)
    # 1 kHz of three-channel frames at 10 bits per byte fits 1 Mbaud with room for ACKs
    assert P.telemetry_wire_bytes(3) * 10 * 1000 <= 0.6 * 1_000_000


def test_three_channel_frame_round_trip_and_version_1_still_read():
    t = _three(9)
    got = P.Parser().feed(P.encode_telemetry(t))
    assert got == [t] and len(got[0].channels) == 3 and got[0].pressure_adc == 563
    # an old one-channel stream (protocol version 1) parses into the same shape
    old = P.Parser()
    v1 = old.feed(P.encode_telemetry_v1(_telemetry(3)) + P.encode_telemetry_v1(_telemetry(4)))
    assert [f.seq for f in v1] == [3, 4] and old.bad_version == 0 and v1[0] == _telemetry(3)
    # HELLO and the ACK's value
    assert P.Parser().feed(P.encode_hello(0, 3, 1000, 1_000_000, 20)) == [P.Hello(0, 3, 1000, 1_000_000, 20)]
    assert P.Parser().feed(P.encode_ack(5, 6, P.GET_GAIN, 0, -7)) == [P.Ack(5, 6, P.GET_GAIN, 0, -7)]


def test_parser_resynchronizes_and_counts():
    p = P.Parser()
    good = [P.encode_telemetry(_telemetry(i)) for i in range(6)]
    stream = good[0] + b"\x13\x37garbage\x00" + good[1][:12] + good[2] + good[3] + good[5]
    got = p.feed(stream[:17]) + p.feed(stream[17:])
    # frame 1 is cut before its delimiter, so it and frame 2 arrive as one packet, which fails
    # its CRC: both are lost, and the parser is back in step at frame 3
    assert [f.seq for f in got] == [0, 3, 5]
    assert p.corrupt == 2  # the garbage packet, and frame 1's head glued to frame 2
    assert p.missing == 3  # seq 1, 2 and 4 never arrived intact
    assert p.frames == 3


def test_missing_counts_across_the_16_bit_wrap():
    p = P.Parser()
    p.feed(P.encode_telemetry(_telemetry(65534)) + P.encode_telemetry(_telemetry(1)))
    assert p.missing == 2  # 65535 and 0


def test_bad_version_and_wrong_length_are_counted():
    p = P.Parser()
    raw = bytes([max(P.VERSIONS_READ) + 1, P.TELEMETRY, 0, 0]) + bytes(22)
    raw += P.crc16(raw).to_bytes(2, "little")
    p.feed(P.cobs_encode(raw) + b"\x00")
    assert p.bad_version == 1 and p.frames == 0
    p.feed(P.encode_frame(P.TELEMETRY, 1, bytes(5)))
    assert p.corrupt == 1


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=600), st.integers(0, 600))
def test_parser_never_raises_on_any_bytes(data, cut):
    p = P.Parser()
    frames = p.feed(data[:cut]) + p.feed(data[cut:])
    assert p.frames == len(frames)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.booleans(), st.binary(min_size=1, max_size=20)), min_size=1, max_size=30))
def test_every_intact_frame_between_corruptions_is_recovered(parts):
    # a stream of valid frames, some followed by noise that ends in a delimiter (a corrupt packet)
    stream, expected = bytearray(), []
    for seq, (noisy, noise) in enumerate(parts):
        stream += P.encode_telemetry(_telemetry(seq))
        expected.append(seq)
        if noisy:
            stream += noise.replace(b"\x00", b"\x01") + b"\x00"
    p = P.Parser()
    got = []
    rng = random.Random(len(stream))
    i = 0
    while i < len(stream):  # arbitrary piece sizes
        j = i + rng.randrange(1, 40)
        got += p.feed(bytes(stream[i:j]))
        i = j
    assert [f.seq for f in got] == expected
    assert p.missing == 0


def test_fuzz_target_short_run():
    r = subprocess.run([sys.executable, str(ROOT / "fuzz" / "fuzz_parser.py"), "--iterations", "3000"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert "3000 streams, no exception" in r.stdout


# ---- C <-> Python -------------------------------------------------------------------------


class RxC(ctypes.Structure):
    _fields_ = [("buf", ctypes.c_uint8 * 66), ("len", ctypes.c_uint8), ("overflow", ctypes.c_uint8),
                ("type", ctypes.c_uint8), ("seq", ctypes.c_uint16), ("body", ctypes.c_uint8 * 64),
                ("body_len", ctypes.c_uint8), ("frames", ctypes.c_uint16), ("corrupt", ctypes.c_uint16)]


class ChannelC(ctypes.Structure):
    _fields_ = [("pressure_adc", ctypes.c_uint16), ("inlet_pwm", ctypes.c_uint8), ("bleed_pwm", ctypes.c_uint8),
                ("mode", ctypes.c_uint8), ("faults", ctypes.c_uint8), ("reference_pa", ctypes.c_int32),
                ("surface_pa", ctypes.c_int32)]


class TelemetryC(ctypes.Structure):
    _fields_ = [("t_us", ctypes.c_uint32), ("encoder", ctypes.c_int32), ("n", ctypes.c_uint8),
                ("ch", ChannelC * 3), ("force_adc", ctypes.c_uint16)]


@pytest.fixture(scope="module")
def clib(tmp_path_factory):
    so = tmp_path_factory.mktemp("proto") / "libproto.so"
    subprocess.run(["gcc", "-std=c99", "-Wall", "-Wextra", "-Werror", "-O2", "-fPIC", "-shared", "-o", str(so),
                    str(ROOT / "firmware" / "core" / "protocol.c")], check=True)
    lib = ctypes.CDLL(str(so))
    lib.mck_crc16.restype = ctypes.c_uint16
    lib.mck_encode_telemetry.restype = ctypes.c_size_t
    lib.mck_encode_ack.restype = ctypes.c_size_t
    lib.mck_encode_hello.restype = ctypes.c_size_t
    lib.mck_rx_feed.restype = ctypes.c_int
    return lib


def test_c_crc_matches(clib):
    assert clib.mck_crc16(b"123456789", 9) == 0x29B1


@settings(max_examples=100, deadline=None)
@given(seq=st.integers(0, 65535), t=st.integers(0, 2**32 - 1), enc=st.integers(-2**31, 2**31 - 1),
       n=st.integers(1, 3),
       chans=st.lists(st.tuples(st.integers(0, 1023), st.integers(0, 255), st.integers(0, 255), st.integers(0, 3),
                                st.integers(0, 31), st.integers(-2**31, 2**31 - 1), st.integers(-2**31, 2**31 - 1)),
                      min_size=3, max_size=3))
def test_c_telemetry_is_byte_for_byte_the_python_one(clib, seq, t, enc, n, chans):
    tc = TelemetryC(t, enc, n, (ChannelC * 3)(*[ChannelC(*c) for c in chans]))
    buf = (ctypes.c_uint8 * 80)()
    k = clib.mck_encode_telemetry(ctypes.byref(tc), seq, buf, 80)
    tp = P.Telemetry.of_channels(seq, t, enc, [P.ChannelTelemetry(*c) for c in chans[:n]])
    py = P.encode_telemetry(tp)
    assert bytes(buf[:k]) == py
    assert P.Parser().feed(py)[0] == tp


def test_c_ack_and_hello_match(clib):
    buf = (ctypes.c_uint8 * 32)()
    n = clib.mck_encode_ack(9, 513, P.GET_GAIN, 4, ctypes.c_int32(-5), buf, 32)
    assert bytes(buf[:n]) == P.encode_ack(9, 513, P.GET_GAIN, 4, -5)
    n = clib.mck_encode_hello(0, 3, 1000, ctypes.c_uint32(1_000_000), 20, ctypes.c_uint32(0), buf, 32)
    assert bytes(buf[:n]) == P.encode_hello(0, 3, 1000, 1_000_000, 20)
    n = clib.mck_encode_hello(0, 3, 1000, ctypes.c_uint32(1_000_000), 20, ctypes.c_uint32(20_000), buf, 32)
    assert bytes(buf[:n]) == P.encode_hello(0, 3, 1000, 1_000_000, 20, load_cell=20.0)


@pytest.mark.parametrize(
    "packet, kind, body",
    [
        (P.set_point(3, 550000, 2), P.SET_POINT, bytes([2]) + (550000).to_bytes(4, "little", signed=True)),
        (P.set_points(3, [1, -2, 3]), P.SET_POINTS, b"".join(v.to_bytes(4, "little", signed=True) for v in (1, -2, 3))),
        (P.set_gain(4, 7, -5, 1), P.SET_GAIN, bytes([1, 7]) + (-5).to_bytes(4, "little", signed=True)),
        (P.get_gain(4, 19, 2), P.GET_GAIN, bytes([2, 19])),
        (P.set_mode(5, 2), P.SET_MODE, bytes([P.ALL, 2])),
        (P.set_max_pressure(6, 800000), P.SET_MAX_PRESSURE, bytes([P.ALL]) + (800000).to_bytes(4, "little", signed=True)),
        (P.vent(7), P.VENT, bytes([P.ALL])),
        (P.stream(8, True, 3), P.STREAM, bytes([1, 3])),
        (P.set_open_loop(9, 40, 0, 1), P.SET_OPEN_LOOP, bytes([1, 40, 0])),
    ],
)
def test_python_commands_decode_in_c(clib, packet, kind, body):
    rx = RxC()
    clib.mck_rx_init(ctypes.byref(rx))
    garbage = b"\x55\xaa\x00"
    done = [clib.mck_rx_feed(ctypes.byref(rx), ctypes.c_uint8(b)) for b in garbage + packet]
    assert done[-1] == 1 and sum(done) == 1
    assert (rx.type, bytes(rx.body[:rx.body_len])) == (kind, body)
    assert rx.corrupt == 1  # the garbage packet

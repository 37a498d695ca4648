"""The serial protocol, version 3, host side (``docs/protocol.md``; the C side is
``firmware/core/protocol.c``).

Frames are ``COBS(version | type | seq | body | crc16) 0x00``, little-endian, CRC-16/CCITT-FALSE.
:class:`Parser` takes any bytes in any pieces and never raises: it resynchronizes at the next
delimiter after garbage or a cut frame and counts what it skipped. It reads version 1 frames
too (one channel: recordings and captures made before the three-channel firmware), and version 2
(three channels, no load cell: version 3 adds the load cell's count to TELEMETRY and its full scale
to HELLO).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field

from mckibben import hardware as HW
from mckibben.control import registry as R

VERSION = 3
#: Versions the parser reads: 1 (one channel, 500000 baud), 2 (no load cell) and 3.
VERSIONS_READ = (1, 2, 3)
MAX_FRAME = 64  #: largest decoded frame (version..crc) [bytes]
MAX_PACKET = MAX_FRAME + MAX_FRAME // 254 + 2  #: largest COBS packet with its delimiter [bytes]
MAX_CHANNELS = 3  #: channels a TELEMETRY frame carries at most
ALL = 0xFF  #: channel byte of SET_MODE, SET_MAX_PRESSURE and VENT: every channel

TELEMETRY, ACK, HELLO = 0x01, 0x02, 0x03
SET_POINT, SET_GAIN, SET_MODE, SET_MAX_PRESSURE, VENT, STREAM, SET_OPEN_LOOP = 0x10, 0x11, 0x12, 0x13, 0x14, 0x15, 0x16
SET_POINTS, GET_GAIN = 0x17, 0x18
#: SET_MODE ids by name: off, every registered controller (:mod:`mckibben.control.registry`), open loop.
MODES = {"off": R.MODE_OFF, **{c.name: c.mode for c in R.CONTROLLERS.values()}, "open-loop": R.MODE_OPEN_LOOP}

_TELEMETRY_V1 = struct.Struct("<IHiBBBBii")  # 22 bytes, version 1
_TELEMETRY_HEAD = struct.Struct("<IiB")  # t_us, encoder, n: 9 bytes
_CHANNEL = struct.Struct("<HBBBBii")  # 14 bytes per channel
_ACK_V1 = struct.Struct("<HBB")
_ACK = struct.Struct("<HBBi")  # 8 bytes
_HELLO_V2 = struct.Struct("<BHIB")  # 8 bytes, version 2
_HELLO = struct.Struct("<BHIBI")  # 12 bytes: version 2's and the load cell's full scale [mN] (0: none)
_FORCE = struct.Struct("<H")  # the load cell's count after the channels (version 3, when fitted)
#: Body length of each type (None: variable, checked by the decoder).
BODY_LENGTH = {TELEMETRY: None, ACK: _ACK.size, HELLO: None, SET_POINT: 5, SET_GAIN: 6, SET_MODE: 2,
               SET_MAX_PRESSURE: 5, VENT: 1, STREAM: 2, SET_OPEN_LOOP: 3, SET_POINTS: None, GET_GAIN: 2}
BODY_LENGTH_V1 = {TELEMETRY: _TELEMETRY_V1.size, ACK: _ACK_V1.size, SET_POINT: 4, SET_GAIN: 5, SET_MODE: 1,
                  SET_MAX_PRESSURE: 4, VENT: 0, STREAM: 2, SET_OPEN_LOOP: 2}


def telemetry_wire_bytes(n_channels: int, force: bool = False) -> int:
    """Bytes on the wire of one TELEMETRY frame: header 4, body 9 + 14 n (+ 2 with a load cell), CRC 2,
    COBS 1, delimiter 1.

    Parameters
    ----------
    n_channels : int
        Channels in the frame, 1..3. [-]
    force : bool, default False
        The frame carries the load cell's count. [-]
    """
    return 4 + _TELEMETRY_HEAD.size + _CHANNEL.size * n_channels + (_FORCE.size if force else 0) + 2 + 1 + 1


FAULT_NAMES = ("overpressure", "adc_out_of_range", "sensor_stuck", "sample_missing", "vent_commanded")


def _crc_table() -> tuple[int, ...]:
    table = []
    for byte in range(256):
        crc = byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) & 0xFFFF if crc & 0x8000 else (crc << 1) & 0xFFFF
        table.append(crc)
    return tuple(table)


_CRC_TABLE = _crc_table()


def crc16(data: bytes) -> int:
    """CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF); ``crc16(b"123456789") == 0x29B1``.

    Table-driven (one lookup per byte): the host parses 1,000 frames a second.

    Parameters
    ----------
    data : bytes
        The bytes to check. [-]
    """
    crc = 0xFFFF
    table = _CRC_TABLE
    for byte in data:
        crc = ((crc << 8) & 0xFFFF) ^ table[(crc >> 8) ^ byte]
    return crc


def cobs_encode(data: bytes) -> bytes:
    """Consistent Overhead Byte Stuffing of ``data`` (no delimiter).

    Parameters
    ----------
    data : bytes
        Raw frame. [-]
    """
    out = bytearray([0])
    code_at, code = 0, 1
    for byte in data:
        if byte == 0:
            out[code_at] = code
            code_at, code = len(out), 1
            out.append(0)
        else:
            out.append(byte)
            code += 1
            if code == 0xFF:
                out[code_at] = code
                code_at, code = len(out), 1
                out.append(0)
    out[code_at] = code
    return bytes(out)


def cobs_decode(data: bytes) -> bytes | None:
    """Inverse of :func:`cobs_encode`; None for a malformed packet.

    Parameters
    ----------
    data : bytes
        A COBS packet without its delimiter. [-]
    """
    out = bytearray()
    i, n = 0, len(data)
    while i < n:
        code = data[i]
        i += 1
        if code == 0 or i + code - 1 > n:
            return None
        out += data[i:i + code - 1]
        i += code - 1
        if code != 0xFF and i < n:
            out.append(0)
    return bytes(out)


def encode_frame(kind: int, seq: int, body: bytes = b"", version: int = VERSION) -> bytes:
    """One packet ready for the wire: COBS of the frame, then the 0x00 delimiter.

    Parameters
    ----------
    kind : int
        Frame type. [-]
    seq : int
        Sequence number (taken modulo 65536). [-]
    body : bytes
        The type's body. [-]
    version : int, default VERSION
        Protocol version byte (1 only to reproduce old streams). [-]
    """
    raw = struct.pack("<BBH", version, kind, seq & 0xFFFF) + bytes(body)
    raw += struct.pack("<H", crc16(raw))
    if len(raw) > MAX_FRAME:
        raise ValueError(f"frame of {len(raw)} bytes exceeds {MAX_FRAME}")
    return cobs_encode(raw) + b"\x00"


@dataclass(frozen=True)
class ChannelTelemetry:
    """One channel's values in a telemetry frame (raw counts and Pa)."""

    pressure_adc: int
    inlet_pwm: int
    bleed_pwm: int
    mode: int
    faults: int
    reference_pa: int
    surface_pa: int


@dataclass(frozen=True)
class Telemetry:
    """One telemetry frame's values (raw counts; SI conversion in the recorder).

    The scalar fields are channel 0's (the only one of a version 1 frame); ``channels`` holds
    every channel of the frame, channel 0 first. ``force_adc`` is the load cell's count and
    ``force`` the tension it reads as [N] (untared: :func:`mckibben.hardware.force_from_count` with
    the device's full scale); both None when the device has no load cell (and in frames of
    versions 1 and 2).
    """

    seq: int
    t_us: int
    pressure_adc: int
    encoder: int
    inlet_pwm: int
    bleed_pwm: int
    mode: int
    faults: int
    reference_pa: int
    surface_pa: int
    channels: tuple = ()
    force_adc: int | None = None
    force: float | None = None

    def __post_init__(self):
        if not self.channels:
            object.__setattr__(self, "channels", (ChannelTelemetry(self.pressure_adc, self.inlet_pwm, self.bleed_pwm,
                                                                   self.mode, self.faults, self.reference_pa,
                                                                   self.surface_pa),))

    @classmethod
    def of_channels(cls, seq: int, t_us: int, encoder: int, channels, force_adc: int | None = None,
                    force: float | None = None) -> "Telemetry":
        """A frame from its channels (channel 0 first).

        Parameters
        ----------
        seq, t_us, encoder : int
            Sequence number [-], device time [µs], encoder count [count].
        channels : sequence of ChannelTelemetry
            1..3 channels. [-]
        force_adc : int, optional
            The load cell's count; None without a load cell. [count]
        force : float, optional
            What that count reads as (the parser fills it in). [N]
        """
        chans = tuple(channels)
        c = chans[0]
        return cls(seq, t_us, c.pressure_adc, encoder, c.inlet_pwm, c.bleed_pwm, c.mode, c.faults, c.reference_pa,
                   c.surface_pa, chans, force_adc, force)


@dataclass(frozen=True)
class Ack:
    """A device's answer to a command; ``value`` carries GET_GAIN's gain (0 otherwise)."""

    seq: int
    cmd_seq: int
    cmd_type: int
    status: int
    value: int = 0


@dataclass(frozen=True)
class Hello:
    """The frame the firmware sends once it runs (after a reset).

    ``load_cell`` is the full scale of its load cell [N] (a version 3 device that has one), else None.
    """

    seq: int
    n_channels: int
    ts_us: int
    baud: int
    n_gains: int
    load_cell: float | None = None


@dataclass(frozen=True)
class Frame:
    """Any other valid frame: its type, sequence number and body."""

    kind: int
    seq: int
    body: bytes


def encode_telemetry(t: Telemetry) -> bytes:
    """Packet of a telemetry frame (the device's side; used by the emulator and tests).

    Parameters
    ----------
    t : Telemetry
        The values; every channel of ``t.channels`` goes in. [-]
    """
    if not 1 <= len(t.channels) <= MAX_CHANNELS:
        raise ValueError(f"a telemetry frame carries 1..{MAX_CHANNELS} channels, not {len(t.channels)}")
    body = _TELEMETRY_HEAD.pack(t.t_us & 0xFFFFFFFF, t.encoder, len(t.channels))
    for c in t.channels:
        body += _CHANNEL.pack(c.pressure_adc, c.inlet_pwm, c.bleed_pwm, c.mode, c.faults, c.reference_pa, c.surface_pa)
    if t.force_adc is not None:
        body += _FORCE.pack(t.force_adc)
    return encode_frame(TELEMETRY, t.seq, body)


def encode_telemetry_v2(t: Telemetry) -> bytes:
    """Packet of a version 2 telemetry frame (no load cell), as the firmware before version 3 sent.

    Parameters
    ----------
    t : Telemetry
        The values; its force, if any, is left out. [-]
    """
    body = _TELEMETRY_HEAD.pack(t.t_us & 0xFFFFFFFF, t.encoder, len(t.channels))
    for c in t.channels:
        body += _CHANNEL.pack(c.pressure_adc, c.inlet_pwm, c.bleed_pwm, c.mode, c.faults, c.reference_pa, c.surface_pa)
    return encode_frame(TELEMETRY, t.seq, body, version=2)


def encode_telemetry_v1(t: Telemetry) -> bytes:
    """Packet of a version 1 telemetry frame (channel 0 only), as the one-channel firmware sent.

    Parameters
    ----------
    t : Telemetry
        The values. [-]
    """
    body = _TELEMETRY_V1.pack(t.t_us & 0xFFFFFFFF, t.pressure_adc, t.encoder, t.inlet_pwm, t.bleed_pwm, t.mode,
                              t.faults, t.reference_pa, t.surface_pa)
    return encode_frame(TELEMETRY, t.seq, body, version=1)


def encode_ack(seq: int, cmd_seq: int, cmd_type: int, status: int, value: int = 0) -> bytes:
    """Packet of an acknowledgement.

    Parameters
    ----------
    seq, cmd_seq, cmd_type, status : int
        The ACK's sequence number, and the command's sequence number, type and status. [-]
    value : int, default 0
        GET_GAIN's gain value. [-]
    """
    return encode_frame(ACK, seq, _ACK.pack(cmd_seq & 0xFFFF, cmd_type, status, value))


def encode_hello(seq: int, n_channels: int, ts_us: int, baud: int, n_gains: int, load_cell: float | None = None,
                 version: int = VERSION) -> bytes:
    """Packet of the HELLO frame.

    Parameters
    ----------
    seq, n_channels : int
        Sequence number and channels. [-]
    ts_us : int
        Control period. [µs]
    baud : int
        Line rate. [1/s]
    n_gains : int
        Gains per channel. [-]
    load_cell : float, optional
        The load cell's full scale, sent in mN; None: no load cell. [N]
    version : int, default VERSION
        2 to reproduce an older firmware's HELLO (no load cell field). [-]
    """
    if version == 2:
        return encode_frame(HELLO, seq, _HELLO_V2.pack(n_channels, ts_us, baud, n_gains), version=2)
    mn = 0 if load_cell is None else int(round(load_cell * 1e3))
    return encode_frame(HELLO, seq, _HELLO.pack(n_channels, ts_us, baud, n_gains, mn))


def set_point(seq: int, pressure_pa: float, channel: int = 0) -> bytes:
    """SET_POINT command. Parameters: seq [-], pressure_pa: the set-point [Pa], channel [-]."""
    return encode_frame(SET_POINT, seq, struct.pack("<Bi", channel, int(round(pressure_pa))))


def set_points(seq: int, pressures_pa) -> bytes:
    """SET_POINTS command: one set-point per channel, channel 0 first. Parameters: seq [-], pressures_pa [Pa]."""
    values = [int(round(p)) for p in pressures_pa]
    return encode_frame(SET_POINTS, seq, struct.pack(f"<{len(values)}i", *values))


def set_gain(seq: int, gain_id: int, value: int, channel: int = 0) -> bytes:
    """SET_GAIN command. Parameters: seq, gain_id [-], value in the gain's fixed-point scale [-], channel [-]."""
    return encode_frame(SET_GAIN, seq, struct.pack("<BBi", channel, gain_id, value))


def get_gain(seq: int, gain_id: int, channel: int = 0) -> bytes:
    """GET_GAIN command: the ACK's value is the gain. Parameters: seq, gain_id, channel [-]."""
    return encode_frame(GET_GAIN, seq, struct.pack("<BB", channel, gain_id))


def set_mode(seq: int, mode: int, channel: int = ALL) -> bytes:
    """SET_MODE command. Parameters: seq [-], mode 0 off, 1 smc, 2 pid, 3 open loop [-], channel [-]."""
    return encode_frame(SET_MODE, seq, struct.pack("<BB", channel, mode))


def set_max_pressure(seq: int, pressure_pa: float, channel: int = ALL) -> bytes:
    """SET_MAX_PRESSURE command. Parameters: seq [-], pressure_pa: the limit [Pa], channel [-]."""
    return encode_frame(SET_MAX_PRESSURE, seq, struct.pack("<Bi", channel, int(round(pressure_pa))))


def vent(seq: int, channel: int = ALL) -> bytes:
    """VENT command (latched until the next SET_MODE). Parameters: seq [-], channel [-]."""
    return encode_frame(VENT, seq, struct.pack("<B", channel))


def stream(seq: int, on: bool, decimation: int = 1) -> bytes:
    """STREAM command. Parameters: seq [-], on [-], decimation: every k-th control step [-]."""
    return encode_frame(STREAM, seq, struct.pack("<BB", 1 if on else 0, decimation))


def set_open_loop(seq: int, inlet: int, bleed: int, channel: int = 0) -> bytes:
    """SET_OPEN_LOOP command. Parameters: seq [-], inlet, bleed PWM counts 0..255 [counts], channel [-]."""
    return encode_frame(SET_OPEN_LOOP, seq, struct.pack("<BBB", channel, inlet, bleed))


@dataclass
class Parser:
    """Streaming frame parser. ``feed(bytes) -> list of Telemetry | Ack | Frame``; never raises.

    Counters: ``frames`` (valid), ``corrupt`` (COBS or CRC failure, wrong body length,
    oversize), ``bad_version``, ``missing`` (frames lost, from gaps in the sender's ``seq``),
    ``bytes``.

    ``load_cell`` is the device's load cell full scale [N] that turns a frame's ``force_adc`` into
    its ``force``: given (from the device's HELLO, as :func:`mckibben.rig.device.connect` does), or
    taken from a HELLO frame the parser reads; :data:`mckibben.hardware.LOAD_CELL_FULL_SCALE` until then.
    """

    load_cell: float | None = None

    frames: int = 0
    corrupt: int = 0
    bad_version: int = 0
    missing: int = 0
    bytes: int = 0
    _buf: bytearray = field(default_factory=bytearray, repr=False)
    _overflow: bool = field(default=False, repr=False)
    _last_seq: int | None = field(default=None, repr=False)

    def feed(self, data: bytes) -> list:
        """Parse a piece of the stream.

        Parameters
        ----------
        data : bytes
            Any bytes. [-]
        """
        out = []
        try:
            data = bytes(data)
        except Exception:
            return out
        self.bytes += len(data)
        start = 0
        while True:
            end = data.find(b"\x00", start)
            if end < 0:
                piece = data[start:]
                if len(self._buf) + len(piece) > MAX_PACKET:
                    self._overflow = True
                    self._buf.clear()
                else:
                    self._buf += piece
                return out
            piece = data[start:end]
            start = end + 1
            if self._overflow or len(self._buf) + len(piece) > MAX_PACKET:
                self.corrupt += 1
            elif self._buf or piece:
                frame = self._decode(bytes(self._buf) + piece)
                if frame is not None:
                    out.append(frame)
            self._buf.clear()
            self._overflow = False

    def _decode(self, packet: bytes):
        raw = cobs_decode(packet)
        if raw is None or len(raw) < 6 or crc16(raw[:-2]) != int.from_bytes(raw[-2:], "little"):
            self.corrupt += 1
            return None
        version, kind, seq = struct.unpack_from("<BBH", raw)
        if version not in VERSIONS_READ:
            self.bad_version += 1
            return None
        body = raw[4:-2]
        frame = _decode_body(version, kind, seq, body, self.load_cell)
        if frame is None:
            self.corrupt += 1
            return None
        if isinstance(frame, Hello) and frame.load_cell is not None:
            self.load_cell = frame.load_cell
        if self._last_seq is not None:
            gap = (seq - self._last_seq - 1) & 0xFFFF
            if gap < 0x8000:
                self.missing += gap
        self._last_seq = seq
        self.frames += 1
        return frame

    def counters(self) -> dict:
        """The counters as a dict."""
        return {"frames": self.frames, "corrupt": self.corrupt, "bad_version": self.bad_version,
                "missing": self.missing, "bytes": self.bytes}


def _decode_body(version: int, kind: int, seq: int, body: bytes, load_cell: float | None = None):
    """The frame of a checked packet, or None when its body has the wrong length."""
    if version == 1:
        want = BODY_LENGTH_V1.get(kind)
        if want is not None and len(body) != want:
            return None
        if kind == TELEMETRY:
            return Telemetry(seq, *_TELEMETRY_V1.unpack(body))
        if kind == ACK:
            return Ack(seq, *_ACK_V1.unpack(body))
        return Frame(kind, seq, body)
    if kind == TELEMETRY:
        if len(body) < _TELEMETRY_HEAD.size:
            return None
        t_us, enc, n = _TELEMETRY_HEAD.unpack_from(body)
        size = _TELEMETRY_HEAD.size + n * _CHANNEL.size
        with_force = version >= 3 and len(body) == size + _FORCE.size
        if not 1 <= n <= MAX_CHANNELS or (len(body) != size and not with_force):
            return None
        chans = tuple(ChannelTelemetry(*_CHANNEL.unpack_from(body, _TELEMETRY_HEAD.size + i * _CHANNEL.size))
                      for i in range(n))
        if not with_force:
            return Telemetry.of_channels(seq, t_us, enc, chans)
        count = _FORCE.unpack_from(body, size)[0]
        scale = HW.LOAD_CELL_FULL_SCALE if load_cell is None else load_cell
        return Telemetry.of_channels(seq, t_us, enc, chans, count, float(HW.force_from_count(count, scale)))
    if kind == HELLO:
        if version == 2 and len(body) == _HELLO_V2.size:
            return Hello(seq, *_HELLO_V2.unpack(body))
        if version != 3 or len(body) != _HELLO.size:
            return None
        *head, mn = _HELLO.unpack(body)
        return Hello(seq, *head, mn / 1e3 if mn else None)
    want = BODY_LENGTH.get(kind)
    if want is not None and len(body) != want:
        return None
    if kind == SET_POINTS and not (4 <= len(body) <= 4 * MAX_CHANNELS and len(body) % 4 == 0):
        return None
    if kind == ACK:
        return Ack(seq, *_ACK.unpack(body))
    return Frame(kind, seq, body)


def fault_names(faults: int) -> list[str]:
    """Names of the fault bits set in a telemetry ``faults`` byte.

    Parameters
    ----------
    faults : int
        The byte. [-]
    """
    return [name for bit, name in enumerate(FAULT_NAMES) if faults & (1 << bit)]

"""The serial protocol, version 1, host side (``docs/protocol.md``; the C side is
``firmware/core/protocol.c``).

Frames are ``COBS(version | type | seq | body | crc16) 0x00``, little-endian, CRC-16/CCITT-FALSE.
:class:`Parser` takes any bytes in any pieces and never raises: it resynchronizes at the next
delimiter after garbage or a cut frame and counts what it skipped.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field

VERSION = 1
MAX_FRAME = 64  #: largest decoded frame (version..crc) [bytes]
MAX_PACKET = MAX_FRAME + MAX_FRAME // 254 + 2  #: largest COBS packet with its delimiter [bytes]

TELEMETRY, ACK = 0x01, 0x02
SET_POINT, SET_GAIN, SET_MODE, SET_MAX_PRESSURE, VENT, STREAM, SET_OPEN_LOOP = 0x10, 0x11, 0x12, 0x13, 0x14, 0x15, 0x16
MODES = {"off": 0, "smc": 1, "pid": 2, "open-loop": 3}

_TELEMETRY = struct.Struct("<IHiBBBBii")  # 22 bytes
_ACK = struct.Struct("<HBB")
#: Body length of each type (None: any length up to the frame limit).
BODY_LENGTH = {TELEMETRY: _TELEMETRY.size, ACK: _ACK.size, SET_POINT: 4, SET_GAIN: 5, SET_MODE: 1,
               SET_MAX_PRESSURE: 4, VENT: 0, STREAM: 2, SET_OPEN_LOOP: 2}

FAULT_NAMES = ("overpressure", "adc_out_of_range", "sensor_stuck", "sample_missing", "vent_commanded")


def crc16(data: bytes) -> int:
    """CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF); ``crc16(b"123456789") == 0x29B1``.

    Parameters
    ----------
    data : bytes
        The bytes to check. [-]
    """
    crc = 0xFFFF
    for byte in data:
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) & 0xFFFF if crc & 0x8000 else (crc << 1) & 0xFFFF
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


def encode_frame(kind: int, seq: int, body: bytes = b"") -> bytes:
    """One packet ready for the wire: COBS of the frame, then the 0x00 delimiter.

    Parameters
    ----------
    kind : int
        Frame type. [-]
    seq : int
        Sequence number (taken modulo 65536). [-]
    body : bytes
        The type's body. [-]
    """
    raw = struct.pack("<BBH", VERSION, kind, seq & 0xFFFF) + bytes(body)
    raw += struct.pack("<H", crc16(raw))
    if len(raw) > MAX_FRAME:
        raise ValueError(f"frame of {len(raw)} bytes exceeds {MAX_FRAME}")
    return cobs_encode(raw) + b"\x00"


@dataclass(frozen=True)
class Telemetry:
    """One telemetry frame's values (raw counts; SI conversion in the recorder)."""

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


@dataclass(frozen=True)
class Ack:
    """A device's answer to a command."""

    seq: int
    cmd_seq: int
    cmd_type: int
    status: int


@dataclass(frozen=True)
class Frame:
    """Any valid frame: its type, sequence number and body."""

    kind: int
    seq: int
    body: bytes


def encode_telemetry(t: Telemetry) -> bytes:
    """Packet of a telemetry frame (the device's side; used by the emulator and tests).

    Parameters
    ----------
    t : Telemetry
        The values. [-]
    """
    body = _TELEMETRY.pack(t.t_us & 0xFFFFFFFF, t.pressure_adc, t.encoder, t.inlet_pwm, t.bleed_pwm, t.mode,
                           t.faults, t.reference_pa, t.surface_pa)
    return encode_frame(TELEMETRY, t.seq, body)


def encode_ack(seq: int, cmd_seq: int, cmd_type: int, status: int) -> bytes:
    """Packet of an acknowledgement.

    Parameters
    ----------
    seq, cmd_seq, cmd_type, status : int
        The ACK's sequence number, and the command's sequence number, type and status. [-]
    """
    return encode_frame(ACK, seq, _ACK.pack(cmd_seq & 0xFFFF, cmd_type, status))


def set_point(seq: int, pressure_pa: float) -> bytes:
    """SET_POINT command. Parameters: seq [-], pressure_pa: the set-point [Pa]."""
    return encode_frame(SET_POINT, seq, struct.pack("<i", int(round(pressure_pa))))


def set_gain(seq: int, gain_id: int, value: int) -> bytes:
    """SET_GAIN command. Parameters: seq, gain_id [-], value in the gain's fixed-point scale [-]."""
    return encode_frame(SET_GAIN, seq, struct.pack("<Bi", gain_id, value))


def set_mode(seq: int, mode: int) -> bytes:
    """SET_MODE command. Parameters: seq [-], mode 0 off, 1 smc, 2 pid, 3 open loop [-]."""
    return encode_frame(SET_MODE, seq, struct.pack("<B", mode))


def set_max_pressure(seq: int, pressure_pa: float) -> bytes:
    """SET_MAX_PRESSURE command. Parameters: seq [-], pressure_pa: the limit [Pa]."""
    return encode_frame(SET_MAX_PRESSURE, seq, struct.pack("<i", int(round(pressure_pa))))


def vent(seq: int) -> bytes:
    """VENT command (latched until the next SET_MODE). Parameters: seq [-]."""
    return encode_frame(VENT, seq)


def stream(seq: int, on: bool, decimation: int = 1) -> bytes:
    """STREAM command. Parameters: seq [-], on [-], decimation: every k-th control step [-]."""
    return encode_frame(STREAM, seq, struct.pack("<BB", 1 if on else 0, decimation))


def set_open_loop(seq: int, inlet: int, bleed: int) -> bytes:
    """SET_OPEN_LOOP command. Parameters: seq [-], inlet, bleed PWM counts 0..255 [counts]."""
    return encode_frame(SET_OPEN_LOOP, seq, struct.pack("<BB", inlet, bleed))


@dataclass
class Parser:
    """Streaming frame parser. ``feed(bytes) -> list of Telemetry | Ack | Frame``; never raises.

    Counters: ``frames`` (valid), ``corrupt`` (COBS or CRC failure, wrong body length,
    oversize), ``bad_version``, ``missing`` (frames lost, from gaps in the sender's ``seq``),
    ``bytes``.
    """

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
        if version != VERSION:
            self.bad_version += 1
            return None
        body = raw[4:-2]
        want = BODY_LENGTH.get(kind)
        if want is not None and len(body) != want:
            self.corrupt += 1
            return None
        if self._last_seq is not None:
            gap = (seq - self._last_seq - 1) & 0xFFFF
            if gap < 0x8000:
                self.missing += gap
        self._last_seq = seq
        self.frames += 1
        if kind == TELEMETRY:
            return Telemetry(seq, *_TELEMETRY.unpack(body))
        if kind == ACK:
            return Ack(seq, *_ACK.unpack(body))
        return Frame(kind, seq, body)

    def counters(self) -> dict:
        """The counters as a dict."""
        return {"frames": self.frames, "corrupt": self.corrupt, "bad_version": self.bad_version,
                "missing": self.missing, "bytes": self.bytes}


def fault_names(faults: int) -> list[str]:
    """Names of the fault bits set in a telemetry ``faults`` byte.

    Parameters
    ----------
    faults : int
        The byte. [-]
    """
    return [name for bit, name in enumerate(FAULT_NAMES) if faults & (1 << bit)]

"""Hostile bytes against the real firmware image (in simavr, ``mckibben.rig.engines.avr``).

Random bytes, truncated frames, bad CRCs, oversize packets, valid frames with out-of-range values
and floods faster than the receive ring drains, in one open session. After each burst the image
must: not have reset (no watchdog, no other reset), answer the next valid command (an ACK to
GET_GAIN), and never command a valve toward more than the configured maximum pressure (every
telemetry frame's reference at most p_max). ``tests/test_device_engines.py`` runs a bounded
property test of the same check in CI (Hypothesis); this script runs it longer:

``python fuzz/fuzz_device.py --bursts 2000 [--seed N]`` (about 25 bursts a second).
"""

from __future__ import annotations

import argparse
import random
import struct
import sys
import time

from mckibben import hardware as HW
from mckibben.rig import protocol as P

#: The command types the firmware knows, and one it does not.
KINDS = (P.SET_POINT, P.SET_GAIN, P.SET_MODE, P.SET_MAX_PRESSURE, P.VENT, P.STREAM, P.SET_OPEN_LOOP, P.SET_POINTS,
         P.GET_GAIN, 0x7E)


def hostile(rng: random.Random) -> bytes:
    """One burst of hostile bytes (a mix of the issue's kinds)."""
    kind = rng.randrange(6)
    if kind == 0:  # random bytes
        return rng.randbytes(rng.randrange(1, 400))
    body = rng.randbytes(rng.randrange(0, 20))
    frame = P.encode_frame(rng.choice(KINDS), rng.randrange(65536), body)
    if kind == 1:  # truncated frame (no delimiter), then a delimiter
        return frame[: rng.randrange(1, len(frame))] + b"\x00"
    if kind == 2:  # a bad CRC
        b = bytearray(frame)
        b[-2] ^= 1 + rng.randrange(255) or 1
        b[-2] = b[-2] or 1
        return bytes(b)
    if kind == 3:  # an oversize packet (no delimiter for hundreds of bytes)
        return bytes(rng.randrange(1, 256) for _ in range(rng.randrange(200, 1200))) + b"\x00"
    if kind == 4:  # valid frames with out-of-range values
        k = rng.choice(KINDS[:-1])
        bodies = {P.SET_POINT: struct.pack("<Bi", rng.choice([0, 1, 2, 7, 255]), rng.randrange(-2**31, 2**31)),
                  P.SET_GAIN: struct.pack("<BBi", rng.randrange(256), rng.randrange(256), rng.randrange(-2**31, 2**31)),
                  P.SET_MODE: struct.pack("<BB", rng.randrange(256), rng.randrange(256)),
                  P.SET_MAX_PRESSURE: struct.pack("<Bi", rng.randrange(256), rng.randrange(-2**31, 2**31)),
                  P.VENT: struct.pack("<B", rng.randrange(256)),
                  P.STREAM: struct.pack("<BB", rng.randrange(256), rng.randrange(256)),
                  P.SET_OPEN_LOOP: struct.pack("<BBB", rng.randrange(256), rng.randrange(256), rng.randrange(256)),
                  P.SET_POINTS: rng.randbytes(rng.choice([0, 4, 8, 12, 16])),
                  P.GET_GAIN: struct.pack("<BB", rng.randrange(256), rng.randrange(256))}
        return P.encode_frame(k, rng.randrange(65536), bodies[k])
    return rng.randbytes(rng.randrange(2000, 6000))  # a flood faster than the receive ring drains


def check_burst(dev, link, parser, burst: bytes, seq: int, p_max: float = HW.P_MAX_DEFAULT) -> list[str]:
    """Send a burst, then a valid GET_GAIN; the problems seen (empty: the image held). [-]"""
    resets = dev.resets + dev.wdt_resets
    link.write(burst)
    # the next valid command, once the burst is on the line (1 Mbaud: 10 us a byte) and a little
    # more: bytes a flood pushes past a full receive ring are lost, whichever frame they belong to
    time.sleep(len(burst) * 10e-6 + 0.05)
    link.write(b"\x00" + P.get_gain(seq, 0, channel=0))
    end, acked, frames = time.monotonic() + 3.0, False, []
    while time.monotonic() < end and not acked:
        got = parser.feed(link.read(65536))
        frames += got
        acked = any(isinstance(f, P.Ack) and f.cmd_seq == seq and f.cmd_type == P.GET_GAIN for f in got)
    problems = []
    if not acked:
        problems.append("no ACK to the valid GET_GAIN after the burst")
    refs = [c.reference_pa for f in frames if isinstance(f, P.Telemetry) for c in f.channels]
    if refs and max(refs) > p_max:
        problems.append(f"a reference of {max(refs)} Pa, above p_max {p_max:g} Pa")
    time.sleep(0.25)  # the harness's counters line
    if dev.resets + dev.wdt_resets != resets:
        problems.append("the image reset")
    return problems


def main() -> int:
    from mckibben.plant import PlantParams
    from mckibben.rig.device import connect
    from mckibben.rig.engines.avr import AvrDevice

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bursts", type=int, default=2000)
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args()
    rng = random.Random(a.seed)
    failures = 0
    with AvrDevice([PlantParams(supply_pressure=1.0e6)] * 3) as dev:
        link, _, parser = connect(dev.port, timeout=0)
        link.write(P.set_mode(1, P.MODES["smc"]) + P.set_points(2, [2e6, 2e6, 2e6]) + P.stream(3, True, 5))
        for i in range(a.bursts):
            burst = hostile(rng)
            problems = check_burst(dev, link, parser, burst, 10 + i % 60000)
            if problems:
                failures += 1
                print(f"burst {i} ({len(burst)} bytes, {burst[:24].hex()}...): {'; '.join(problems)}", flush=True)
            if i % 100 == 0:
                print(f"{i} bursts, {failures} failed, pressures {dev.pressures()}", flush=True)
        link.close()
    print(f"{a.bursts} bursts, {failures} failed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())

"""Fuzz target for the host frame parser: it must never raise, whatever bytes arrive.

With atheris installed (``pip install atheris``): ``python fuzz/fuzz_parser.py -atheris_runs=1000000``.
Without it, the same target runs on random and mutated streams:
``python fuzz/fuzz_parser.py --iterations 100000 [--seed N]``.
"""

from __future__ import annotations

import argparse
import random
import sys

from mckibben.rig import protocol as P


def target(data: bytes) -> None:
    """Feed ``data`` to a parser in two pieces and check its counters stay consistent."""
    parser = P.Parser()
    cut = data[0] % (len(data) + 1) if data else 0
    frames = parser.feed(data[:cut]) + parser.feed(data[cut:])
    assert parser.frames == len(frames)
    assert min(parser.counters().values()) >= 0


def _valid_stream(rng: random.Random) -> bytes:
    out = bytearray()
    for seq in range(rng.randrange(1, 6)):
        out += P.encode_telemetry(P.Telemetry(seq, rng.randrange(2**32), rng.randrange(1024), rng.randrange(-2**31, 2**31),
                                              rng.randrange(256), rng.randrange(256), rng.randrange(4), rng.randrange(32),
                                              rng.randrange(-2**31, 2**31), rng.randrange(-2**31, 2**31)))
    return bytes(out)


def _mutate(rng: random.Random, data: bytes) -> bytes:
    b = bytearray(data)
    for _ in range(rng.randrange(1, 8)):
        op = rng.randrange(3)
        if op == 0 and b:
            b[rng.randrange(len(b))] = rng.randrange(256)
        elif op == 1:
            b.insert(rng.randrange(len(b) + 1), rng.randrange(256))
        elif b:
            del b[rng.randrange(len(b))]
    return bytes(b)


def run_random(iterations: int, seed: int = 0) -> int:
    """Run the target on ``iterations`` random or mutated streams; returns how many ran."""
    rng = random.Random(seed)
    for _ in range(iterations):
        kind = rng.randrange(3)
        if kind == 0:
            data = bytes(rng.randrange(256) for _ in range(rng.randrange(200)))
        else:
            data = _mutate(rng, _valid_stream(rng))
        target(data)
    return iterations


def main() -> None:
    try:
        import atheris  # noqa: F401
    except ImportError:
        atheris = None
    if atheris is not None and not any(a.startswith("--iterations") for a in sys.argv):
        atheris.Setup(sys.argv, target)
        atheris.Fuzz()
        return
    ap = argparse.ArgumentParser()
    ap.add_argument("--iterations", type=int, default=100_000)
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args()
    print(f"{run_random(a.iterations, a.seed)} streams, no exception")


if __name__ == "__main__":
    main()

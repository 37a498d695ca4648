"""Processor in the loop: what only the real firmware image can show, measured (issue 31).

The image ``make -C firmware`` builds runs in simavr (``mckibben.rig.engines.avr``) against the C
plant, behind a pty; this script is the host, as ``rig record``/``rig step`` are:

1. frames per second and sequence gaps with three channels streaming, at decimation 1, 2 and 5
   (``--seconds`` each, the harness throttled to wall time);
2. SET_POINT -> ACK round trip (wall clock, host to host) while streaming at decimation 1, one
   command every 10 ms, and the same with a SET_POINTS every 1 ms (tool track's traffic): frames
   and ACKs delivered;
3. the simulation's real-time factor unthrottled, under streaming at decimation 1 plus a command
   every 1 ms (simulated seconds per wall second; below 1 the bench could not keep wall time);
4. the watchdog path: the control tick stalls (Timer1 masked) with channel 0's inlet open; when
   the MCU resets, whether the valves shut and HELLO reaches the host;
5. the command-rate ceiling and what the harness reads off the CPU (``AvrDevice.instruments``):
   three channels in closed loop (sliding mode), SET_POINTS every 1, 2 or 3 ms beside telemetry at
   decimation 1 or 2: ACKs and telemetry delivered, the TX and RX rings' high-water marks, the
   control tick's period (min/max: its jitter) and the longest time interrupts are masked;
6. where the CPU's cycles go under SET_POINTS every 1 ms plus telemetry at decimation 1 (the
   harness's ``--profile``, mapped to the image's functions with avr-nm);
7. a conversion that misses the tick: the ADC's interrupt masked for 1 and for 10 periods (the
   default ``n_missing`` is 10) under closed loop at 0.5 MPa: what the telemetry shows.

Usage: ``python benchmarks/bench_pil.py [--seconds 5] [--load-cell 5]``; prints a Markdown table per
part. ``--load-cell FS`` runs every part on the image built with a load cell of full scale FS [N]
(``LOAD_CELL_MN``: ADC3 converted after every tick, its count in every telemetry frame).
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

from mckibben import hardware as HW
from mckibben.plant import PlantParams
from mckibben.rig import protocol as P
from mckibben.rig.device import connect
from mckibben.rig.engines.avr import AvrDevice

PLANTS = [PlantParams()] * 3
#: Set by ``--load-cell``: the cell every device of the run carries (None: the image without one).
CELL: dict = {"load_cell": None}


def _read(link, parser, seconds, on_tick=None, every=None):
    frames, t0 = [], time.monotonic()
    nxt = t0
    while time.monotonic() - t0 < seconds:
        if on_tick is not None and time.monotonic() >= nxt:
            on_tick()
            nxt += every
        frames += parser.feed(link.read(65536))
    return frames


def streaming(seconds: float) -> None:
    print("| decimation | telemetry frames/s | expected /s | sequence gaps | gaps % | corrupt |")
    print("| --- | --- | --- | --- | --- | --- |")
    for dec in (1, 2, 5):
        with AvrDevice(PLANTS, **CELL, boot_time=0.3) as dev:
            link, _, parser = connect(dev.port, timeout=0)
            link.write(P.stream(1, True, dec))
            _read(link, parser, 0.5)
            c0 = parser.counters()
            frames = _read(link, parser, seconds)
            c = parser.counters()
            link.close()
        tel = sum(isinstance(f, P.Telemetry) for f in frames)
        gaps = c["missing"] - c0["missing"]
        print(f"| {dec} | {tel / seconds:.0f} | {1000 / dec:.0f} | {gaps} | {100 * gaps / max(tel + gaps, 1):.2f} | "
              f"{c['corrupt']} |")


def round_trip(seconds: float) -> None:
    print("| traffic | commands sent | ACKs back | round trip median / p95 / max [ms] | telemetry frames/s | gaps % |")
    print("| --- | --- | --- | --- | --- | --- |")
    for label, every, many in (("SET_POINT every 10 ms", 0.010, False), ("SET_POINTS every 1 ms", 0.001, True)):
        with AvrDevice(PLANTS, **CELL, boot_time=0.3) as dev:
            link, _, parser = connect(dev.port, timeout=0)
            link.write(P.set_mode(1, P.MODES["smc"]))
            link.write(P.stream(2, True, 1))
            _read(link, parser, 0.5)
            sent: dict[int, float] = {}
            seq = [3]

            def send():
                s = seq[0] & 0xFFFF
                pkt = P.set_points(s, [3e5, 3e5, 3e5]) if many else P.set_point(s, 3e5)
                sent[s] = time.monotonic()
                link.write(pkt)
                seq[0] += 1

            rtt, tel, missing0 = [], 0, parser.missing
            t0 = time.monotonic()
            nxt = t0
            while time.monotonic() - t0 < seconds:
                if time.monotonic() >= nxt:
                    send()
                    nxt += every
                for f in parser.feed(link.read(65536)):
                    if isinstance(f, P.Ack) and f.cmd_seq in sent:
                        rtt.append(time.monotonic() - sent.pop(f.cmd_seq))
                    elif isinstance(f, P.Telemetry):
                        tel += 1
            gaps = parser.missing - missing0
            link.close()
        q = sorted(rtt)
        stat = (f"{1e3 * statistics.median(q):.2f} / {1e3 * q[int(0.95 * (len(q) - 1))]:.2f} / {1e3 * q[-1]:.2f}"
                if q else "-")
        print(f"| {label} | {seq[0] - 3} | {len(rtt)} | {stat} | {tel / seconds:.0f} | "
              f"{100 * gaps / max(tel + gaps, 1):.1f} |")


def real_time_factor(seconds: float) -> None:
    print("| load | simulated s | wall s | real-time factor |")
    print("| --- | --- | --- | --- |")
    for label, cmd in (("idle, no host", False), ("streaming at decimation 1 + SET_POINTS every 1 ms", True)):
        with AvrDevice(PLANTS, **CELL, boot_time=0.3, unthrottled=True) as dev:
            if cmd:
                link, _, parser = connect(dev.port, timeout=0)
                link.write(P.stream(1, True, 1))
                s = [2]

                def send():
                    link.write(P.set_points(s[0] & 0xFFFF, [3e5] * 3))
                    s[0] += 1

                a = (dev._stat("t_sim", 0.0), dev._stat("wall", 0.0))
                _read(link, parser, seconds, send, 0.001)
                time.sleep(0.3)
                b = (dev._stat("t_sim", 0.0), dev._stat("wall", 0.0))
                link.close()
            else:
                time.sleep(0.5)
                a = (dev._stat("t_sim", 0.0), dev._stat("wall", 0.0))
                time.sleep(seconds)
                b = (dev._stat("t_sim", 0.0), dev._stat("wall", 0.0))
        sim, wall = b[0] - a[0], b[1] - a[1]
        print(f"| {label} | {sim:.2f} | {wall:.2f} | {sim / wall:.2f} |")


def watchdog() -> None:
    stall = 1.5
    with AvrDevice(PLANTS, **CELL, boot_time=0.3, stall_at=stall) as dev:
        link, _, parser = connect(dev.port, timeout=0)
        link.write(P.set_mode(1, P.MODES["open-loop"], channel=0))
        link.write(P.set_open_loop(2, 120, 0, channel=0))
        link.write(P.stream(3, True, 10))
        frames = _read(link, parser, 2.5)
        time.sleep(0.3)
        valves, reset_at = dev._stat("valves"), dev.wdt_reset_at
        link.close()
    kinds = [type(f).__name__ for f in frames]
    hello = kinds.index("Hello") if "Hello" in kinds else None
    print("| stall at (simulated) [s] | watchdog reset at [s] | stall -> reset [ms] | valves after | HELLO to host |")
    print("| --- | --- | --- | --- | --- |")
    print(f"| {stall:.3f} | {reset_at:.4f} | {1e3 * (reset_at - stall):.1f} | {valves} | "
          f"{'yes, after ' + str(kinds[:hello].count('Telemetry')) + ' frames' if hello is not None else 'no'} |")


def _closed_loop_traffic(dev, every: float, decimation: int, seconds: float):
    """SMC on all channels at 0.3 MPa, STREAM at ``decimation``, SET_POINTS every ``every`` s."""
    link, _, parser = connect(dev.port, timeout=0)
    link.write(P.set_points(1, [3e5] * 3))
    link.write(P.set_mode(2, P.MODES["smc"]))
    link.write(P.stream(3, True, decimation))
    _read(link, parser, 0.5)
    seq, acks, tel, t0 = [4], [0], [0], time.monotonic()
    m0 = parser.missing
    nxt = t0
    while time.monotonic() - t0 < seconds:
        if every and time.monotonic() >= nxt:
            link.write(P.set_points(seq[0] & 0xFFFF, [3e5, 3.1e5, 2.9e5]))
            seq[0] += 1
            nxt += every
        for f in parser.feed(link.read(65536)):
            acks[0] += isinstance(f, P.Ack)
            tel[0] += isinstance(f, P.Telemetry)
    gaps = parser.missing - m0
    link.close()
    time.sleep(0.3)  # the harness's next counters line
    return seq[0] - 4, acks[0], tel[0], gaps


def ceiling(seconds: float) -> None:
    print("| SET_POINTS every | decimation | sent | ACKs | telemetry | gaps % | TX ring max [B] | RX ring max [B] "
          "| tick period min / max [us] | interrupts masked max [us] |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for every, dec in ((0.0, 1), (0.001, 1), (0.001, 2), (0.002, 2), (0.002, 1), (0.003, 1)):
        with AvrDevice(PLANTS, boot_time=0.3) as dev:
            sent, acks, tel, gaps = _closed_loop_traffic(dev, every, dec, seconds)
            ins = dev.instruments
        print(f"| {f'{1e3 * every:.0f} ms' if every else 'none'} | {dec} | {sent} | {acks} | {tel} | "
              f"{100 * gaps / max(tel + gaps, 1):.1f} | {ins['tx_hwm']} | {ins['rx_hwm']} | "
              f"{ins['tick_min_cycles'] / 16:.1f} / {ins['tick_max_cycles'] / 16:.1f} | "
              f"{ins['masked_max_cycles'] / 16:.1f} |")


def profile(seconds: float) -> None:
    import bisect
    import subprocess
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "profile.txt")
        with AvrDevice(PLANTS, boot_time=0.3, profile=path) as dev:
            _closed_loop_traffic(dev, 0.001, 1, seconds)
            elf = dev.elf
        rows = [line.split() for line in open(path)]
    syms = sorted((int(f[0], 16), f[-1]) for f in (line.split() for line in subprocess.run(
        ["avr-nm", "-n", str(elf)], capture_output=True, text=True).stdout.splitlines())
        if len(f) == 3 and f[1] in "Tt")
    addrs = [a for a, _ in syms]
    cycles: dict[str, int] = {}
    for a, c in rows:
        i = bisect.bisect_right(addrs, int(a, 16)) - 1
        name = syms[i][1] if i >= 0 else "?"
        cycles[name] = cycles.get(name, 0) + int(c)
    total = sum(cycles.values())
    vectors = {"__vector_17": "Timer1 compare A (control tick)", "__vector_25": "USART0 RX",
               "__vector_26": "USART0 UDRE (TX)", "__vector_29": "ADC", "__vector_18": "Timer1 compare B"}
    print("| function | share of the CPU % | cycles per ms |")
    print("| --- | --- | --- |")
    for name, c in sorted(cycles.items(), key=lambda kv: -kv[1])[:12]:
        print(f"| {name} {('(' + vectors[name] + ')') if name in vectors else ''} | {100 * c / total:.1f} | "
              f"{16000 * c / total:.0f} |")


def adc_miss() -> None:
    print("| periods missed | frames with no sample (to the first fault) | faults seen | valves after |")
    print("| --- | --- | --- | --- |")
    for n in (1, 10):
        with AvrDevice(PLANTS, boot_time=0.3, adc_miss_at=1.5, adc_miss_n=n) as dev:
            link, _, parser = connect(dev.port, timeout=0)
            link.write(P.set_points(1, [5e5] * 3))
            link.write(P.set_mode(2, P.MODES["smc"]))
            link.write(P.stream(3, True, 1))
            frames = _read(link, parser, 2.0)
            link.close()
            time.sleep(0.3)
            valves = dev._stat("valves")
        tel = [f for f in frames if isinstance(f, P.Telemetry)]
        # a frame with no sample reports pressure_adc 0 (a vented chamber reads ~0 as well: count
        # those up to the first fault only)
        first = next((i for i, f in enumerate(tel) if any(c.faults for c in f.channels)), len(tel))
        empty = sum(all(c.pressure_adc == 0 for c in f.channels) for f in tel[:first + 1])
        faults = sorted({hex(c.faults) for f in tel for c in f.channels if c.faults})
        print(f"| {n} | {empty} | {', '.join(faults) or 'none'} | {valves} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=5.0)
    ap.add_argument("--load-cell", type=float, default=None, help="full scale of a load cell on A3 [N]")
    ap.add_argument("--only", choices=("ceiling", "profile", "adc-miss"), help="run one of parts 5-7 alone")
    a = ap.parse_args()
    if a.load_cell is not None:
        CELL["load_cell"] = HW.LoadCell(a.load_cell, noise=0.01 * a.load_cell / 5)
        print(f"load cell: {a.load_cell:g} N full scale on A3\n")
    if a.only:
        {"ceiling": lambda: ceiling(a.seconds), "profile": lambda: profile(a.seconds), "adc-miss": adc_miss}[a.only]()
        return
    print(f"load average at start: {os.getloadavg()[0]:.2f}\n")
    print("### Streaming, three channels at 1 kHz\n")
    streaming(a.seconds)
    print("\n### Command round trip under streaming at decimation 1\n")
    round_trip(a.seconds)
    print("\n### Real-time factor, unthrottled\n")
    real_time_factor(a.seconds)
    print("\n### Watchdog path\n")
    watchdog()
    print("\n### Command-rate ceiling, closed loop on three channels, and the CPU's instruments\n")
    ceiling(a.seconds)
    print("\n### Where the cycles go: SET_POINTS every 1 ms + telemetry at decimation 1\n")
    profile(a.seconds)
    print("\n### A conversion that misses the tick\n")
    adc_miss()
    print(f"\nload average at end: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()

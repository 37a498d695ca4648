"""The rig over a real pseudo-terminal: the device engines (the Python emulator, and the firmware
image itself in simavr against the C plant) and the host. Every device test runs against both.

Real ptys, real processes and signals. Waits are bounded and generous; assertions are on counts
and contents, not on how long something took.
"""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import serial

from mckibben.control import core
from mckibben.errors import InputError
from mckibben.rig import protocol as P
from mckibben.rig.device import connect
from mckibben.rig.emulator import Emulator
from mckibben.rig.recorder import read_recording

from conftest import start_device


def _wait(cond, timeout=30.0, every=0.02):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if cond():
            return True
        time.sleep(every)
    return cond()


def _record(port, out, seconds):
    """``mckibben rig record`` in its own process (as on a bench); returns its counters and the data."""
    r = subprocess.run([sys.executable, "-m", "mckibben.cli", "rig", "record", "--port", port, "--out", str(out),
                        "--duration", f"{seconds}s", "--json"], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    data, meta = read_recording(out)
    return meta["counters"], data


def test_ten_seconds_at_1khz_three_channels_with_no_missing_frame(tmp_path, engine):
    with start_device(engine) as em:
        c, df = _record(em.port, tmp_path / "run.parquet", 10.0)
        dropped = em.dropped
    # every frame the device sent arrived, intact; the only gaps would be frames the device's
    # UART queue dropped (a host starved of CPU stops reading: counted, never hidden) and, on the
    # image, the periods its main loop came too late for (measured under 1 %: docs/firmware.md)
    late = 0.01 * len(df) if engine == "avr" else 0
    assert c["corrupt"] == 0 and c["missing"] <= dropped + late
    assert c["missing"] <= 100  # a recorder in its own process keeps up
    assert len(df) >= 9_400  # 10 s at 1 kHz, less the start-up of the stream (≤ 0.5 s)
    seq = df["seq"].to_numpy()
    assert np.all(np.diff(seq) >= 1) and seq[-1] - seq[0] + 1 - len(df) == c["missing"]
    t = df["time_s"].to_numpy()
    assert np.allclose(np.diff(t), 1e-3 * np.diff(seq))  # every control period, 1 ms apart
    assert {"ch1_pressure_Pa", "ch2_faults"} <= set(df.columns)
    data, meta = read_recording(tmp_path / "run.parquet")
    assert meta["protocol_version"] == P.VERSION and meta["n_channels"] == 3
    assert not (tmp_path / "run.parquet.journal").exists()


def test_garbage_and_cut_frames_are_counted_and_skipped(tmp_path):
    with Emulator(garbage_every=100, cut_every=250) as em:
        c, df = _record(em.port, tmp_path / "run.parquet", 2.0)
        dropped = em.dropped
    seqs = df["seq"].to_numpy()
    first = int(seqs[0])  # telemetry frame j (1, 2, ...) has seq j + first - 1
    j_max = int(seqs[-1]) - first + 1
    # a cut frame has no delimiter, so it glues to the next packet: both are lost, unless garbage
    # (every 100th frame) ends the cut frame's packet; every garbage burst is one corrupt packet
    cut = [j for j in range(1, j_max + 1) if j % 250 == 0]
    lost = set(cut) | {j + 1 for j in cut if j % 100 != 0 and j + 1 <= j_max}
    got = set((seqs - first + 1).tolist())
    missing = set(range(1, j_max + 1)) - got
    assert lost <= missing and len(missing - lost) <= dropped  # beyond the cuts: only device drops
    assert c["missing"] == len(missing)
    corrupt = len([j for j in range(1, j_max + 1) if j % 100 == 0]) + len([j for j in cut if j % 100 != 0])
    # the recording stops at an arbitrary byte: the last frame's garbage may be cut off, or the
    # packet a last cut frame glued to may have come in; a dropped frame can take its garbage along
    assert corrupt - 1 - dropped <= c["corrupt"] <= corrupt + 1


def test_opening_the_port_resets_the_device_and_the_host_waits_for_hello(engine):
    with start_device(engine, boot_time=0.5) as em:
        assert _wait(lambda: em.steps > 50)
        assert em.resets == 0
        # a host that writes at once, as rig step did: the bootloader swallows the command
        raw = serial.Serial(em.port, P_BAUD, timeout=0.02)
        raw.write(P.stream(0, True, 1))
        assert _wait(lambda: em.resets == 1)
        parser, frames = P.Parser(), []
        end = time.monotonic() + 5
        while time.monotonic() < end and not any(isinstance(f, P.Hello) for f in frames):
            frames += parser.feed(raw.read(4096))
        frames += parser.feed(raw.read(4096))  # a little more: no telemetry follows, no ACK
        assert any(isinstance(f, P.Hello) for f in frames)
        assert not any(isinstance(f, (P.Telemetry, P.Ack)) for f in frames)
        raw.close()
        assert _wait(lambda: not em.host_present)  # the pty cannot show DTR: it sees the close
        # connect() waits for HELLO: its commands arrive
        link, hello, parser = connect(em.port)
        assert (hello.n_channels, hello.ts_us, hello.baud) == (3, 1000, 1_000_000)
        assert em.resets == 2
        link.write(P.stream(0, True, 1))
        got = []
        assert _wait(lambda: got.extend(parser.feed(link.read(8192))) or
                     sum(isinstance(f, P.Telemetry) for f in got) >= 10, timeout=10)
        link.close()


P_BAUD = 1_000_000


def test_no_hello_is_a_clear_error():
    master, slave = os.openpty()  # a port with nothing behind it
    try:
        with pytest.raises(InputError, match=r"no HELLO frame from .* within 0.3 s after opening it"):
            connect(os.ttyname(slave), hello_timeout=0.3)
    finally:
        os.close(master)
        os.close(slave)


def test_the_clock_runs_when_nobody_reads_and_drops_are_counted_like_a_uart(engine):
    with start_device(engine) as em:
        link, _, parser = connect(em.port)
        link.write(P.stream(0, True, 1))
        # stop reading: the pty fills, the UART queue overflows, frames are dropped and counted
        steps0 = em.steps
        assert _wait(lambda: em.dropped >= 300, timeout=30)
        assert em.steps - steps0 >= 300  # the control loop kept running meanwhile
        frames = []
        # read again: the host's parser sees every dropped frame as a gap in the device's seq
        assert _wait(lambda: frames.extend(parser.feed(link.read(65536))) or
                     parser.missing >= 300, timeout=30)
        frames.extend(parser.feed(link.read(65536)))
        link.close()
        time.sleep(0.5)  # the avr engine's counters are a line its harness prints every 0.2 s
        dropped = em.dropped
    assert parser.corrupt == 0
    late = 0.01 * (len(frames) + parser.missing) if engine == "avr" else 0  # as in the ten-second test
    assert 300 <= parser.missing <= dropped + late
    # the device clock in the telemetry followed every period, dropped or not
    t = [f.t_us for f in frames if isinstance(f, P.Telemetry)]
    assert (t[-1] - t[0]) / 1000 + 1 >= len(t) + parser.missing - 5


def test_kill_9_loses_at_most_a_quarter_second_and_the_next_recorder_keeps_nothing_older(tmp_path, engine):
    out = tmp_path / "run.parquet"
    with start_device(engine) as em:
        rec = subprocess.Popen([sys.executable, "-m", "mckibben.cli", "rig", "record", "--port", em.port, "--out",
                                str(out), "--duration", "60s", "--json"], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        journal = Path(str(out) + ".journal")
        assert _wait(lambda: len(list(journal.glob("part-*.parquet"))) >= 8, timeout=60)
        time.sleep(0.13)  # an arbitrary moment between journal parts
        device_time_at_kill = em.device_time
        rec.send_signal(signal.SIGKILL)
        dropped_by_device = em.dropped  # frames the UART model dropped while the recorder lagged
        rec.wait(timeout=10)
        # a recorder started after the crash: the device resets when it opens the port, and the
        # recorder keeps nothing from before its start
        r2 = subprocess.run([sys.executable, "-m", "mckibben.cli", "rig", "record", "--port", em.port, "--out",
                             str(tmp_path / "after.parquet"), "--duration", "1s", "--json"],
                            capture_output=True, text=True, timeout=60)
    assert rec.returncode == -signal.SIGKILL
    assert journal.is_dir() and not out.exists()
    from mckibben.cli import main

    assert main(["rig", "recover", str(journal), "--out", str(out), "--json"]) == 0
    df, meta = read_recording(out)
    assert len(df) > 1000
    gaps = np.diff(df["seq"].to_numpy()) - 1
    # what was kept is whole: the only gaps are frames the device itself dropped (its transmit
    # queue overflows when a recorder starved of CPU stops reading, as a real UART's would)
    assert np.all(gaps >= 0) and gaps.sum() <= dropped_by_device
    assert device_time_at_kill - df["time_s"].max() <= 0.25  # at most a quarter second lost
    assert r2.returncode == 0, r2.stderr
    after, _ = read_recording(tmp_path / "after.parquet")
    assert len(after) >= 100
    # it starts with the first telemetry frame after its own reset (HELLO is seq 0, the STREAM
    # ACK seq 1): nothing of the killed session's stream, whose seqs ran into the thousands
    assert after["seq"].iloc[0] <= 5 and after["time_s"].iloc[0] < 0.1
    assert np.all(np.diff(after["time_s"].to_numpy()) > 0)


def test_rig_step_metrics_over_the_link(cli, engine):
    with start_device(engine) as em:
        r = cli("rig", "step", "--port", em.port, "--target", "0.4MPa", "--duration", "0.5s", "--json")
    assert r.code == 0, r.err
    m = r.json()
    assert m["missing"] == 0 and m["target_Pa"] == 0.4e6 and m["faults"] == 0
    assert 0 < m["rise_time_s"] < 0.3 and np.isfinite(m["time_constant_s"])


def test_rig_gains_round_trip_and_the_emulator_applies_them_identically(cli, tmp_path, engine):
    design = tmp_path / "design.json"
    r = cli("control", "step", "--target", "0.4MPa", "--duration", "0.2s", "--save-design", str(design), "--json")
    assert r.code == 0, r.err
    params = core.load_design(design)
    assert params.g > 0 and params.sup_g == params.g  # the identified model, for law and supervisor
    with start_device(engine) as em:
        r = cli("rig", "gains", "--port", em.port, "--from", str(design), "--json")
        assert r.code == 0, r.err
        out = r.json()
        assert out["verified"] is True and out["channels"] == [0, 1, 2]
        want = core.pack_params(params)[1]
        for i in range(3):  # bit for bit what pack_params (the Python API) makes of the design
            assert out["read_back"][str(i)] == out["gains"]  # read back by GET_GAIN from the device
            if engine == "python":
                assert np.array_equal(em.bank[i].iparams, want)
        r = cli("rig", "gains", "--port", em.port, "--from", str(design), "--channel", "1")
        assert r.code == 0 and "verified" in r.out


@pytest.mark.parametrize("kind", ["SIGTERM", "SIGINT"])
def test_emulate_removes_its_link_on_signals(tmp_path, kind, engine):
    link = tmp_path / "tty"
    p = subprocess.Popen([sys.executable, "-m", "mckibben.cli", "rig", "emulate", "--engine", engine, "--link",
                          str(link), "--json"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert _wait(link.is_symlink, timeout=60)
        text = ""
        while not text.endswith("}\n"):
            text += p.stdout.readline()
        info = json.loads(text)
        assert os.path.realpath(link) == info["port"] and info["channels"] == 3 and info["engine"] == engine
        p.send_signal(getattr(signal, kind))
        p.wait(timeout=20)
    finally:
        if p.poll() is None:
            p.kill()
    assert not link.is_symlink() and not link.exists()


@pytest.mark.parametrize(
    "args, message",
    [
        (["rig", "record", "--port", "/dev/nonexistent-tty", "--out", "{tmp}/a.parquet"], "error: --port: cannot open '/dev/nonexistent-tty'"),
        (["rig", "record", "--port", "{pty}", "--out", "/no/such/dir/a.parquet"], "error: --out: folder '/no/such/dir' does not exist"),
        (["rig", "record", "--port", "{pty}", "--out", "{tmp}/a.csv"], "error: --out: '{tmp}/a.csv' must end in .parquet"),
        (["rig", "record", "--port", "{pty}", "--out", "{tmp}/a.parquet", "--duration", "10"], "error: --duration: '10' has no unit"),
        (["rig", "recover", "{tmp}", "--out", "{tmp}/a.parquet"], "error: '{tmp}' is not a recorder journal (no meta.json)"),
        (["rig", "step", "--port", "{pty}", "--target", "0.9MPa"], "error: --target: '0.9MPa' is above the 0.8 MPa safe limit"),
        (["rig", "step", "--port", "{pty}", "--controller", "lqr"], "error: --controller: 'lqr' must be one of smc, pid"),
        (["rig", "emulate", "--link", "/no/such/dir/tty"], "error: --link: cannot create '/no/such/dir/tty'"),
        (["rig", "emulate", "--channels", "4"], "error: --channels: 4 must be 1, 2 or 3"),
        (["rig", "emulate", "--engine", "qemu"], "error: --engine: 'qemu' must be one of python, avr"),
        (["rig", "emulate", "--supply", "2MPa"], "error: --supply: '2MPa' must be above 0 and at most 1 MPa"),
        (["rig", "emulate", "--engine", "avr", "--supply", "fast"], "error: --supply: cannot read 'fast' as a pressure"),
        (["rig", "gains", "--port", "{pty}", "--from", "{tmp}/none.json"], "error: --from: '{tmp}/none.json' does not exist"),
        (["rig", "gains", "--port", "{pty}", "--from", "{tmp}/bad.json"], "error: --from: '{tmp}/bad.json' is not JSON"),
        (["rig", "gains", "--port", "{pty}", "--from", "{tmp}/other.json"], "error: --from: '{tmp}/other.json' is not a controller design"),
        (["rig", "gains", "--port", "{pty}", "--from", "{tmp}/range.json"], "error: --from: '{tmp}/range.json': controller parameter beta=300"),
        (["rig", "gains", "--port", "{pty}", "--from", "{tmp}/range.json", "--channel", "x"], "error: --from: '{tmp}/range.json'"),
        (["rig", "gains", "--port", "{pty}", "--from", "{tmp}/ok.json", "--channel", "x"], "error: --channel: 'x' must be a channel number or all"),
        (["rig", "gains", "--port", "{pty}", "--from", "{tmp}/ok.json"], "error: --port: no HELLO frame from '{pty}'"),
        (["control", "step", "--save-design", "{tmp}/d.txt"], "error: --save-design: '{tmp}/d.txt' must end in .json"),
    ],
)
def test_bad_input(cli, tmp_path, args, message):
    (tmp_path / "bad.json").write_text("{not json")
    (tmp_path / "other.json").write_text('{"format": "something else"}')
    (tmp_path / "range.json").write_text(json.dumps({"format": core.DESIGN_FORMAT, "params": {"beta": 300.0}}))
    core.save_design(core.CoreParams(), tmp_path / "ok.json")
    master, slave = os.openpty()
    try:
        fill = {"tmp": str(tmp_path), "pty": os.ttyname(slave)}
        if args[:2] == ["rig", "gains"] and "ok.json" in args[5] and "--channel" not in args:
            import mckibben.rig.device as D

            old, D.HELLO_TIMEOUT_S = D.HELLO_TIMEOUT_S, 0.3
            try:
                r = cli(*[a.format(**fill) for a in args])
            finally:
                D.HELLO_TIMEOUT_S = old
        else:
            r = cli(*[a.format(**fill) for a in args])
    finally:
        os.close(master)
        os.close(slave)
    assert r.code == 2, r.err
    assert r.err.startswith(message.format(**fill)) and r.err.count("\n") == 1
    assert not (tmp_path / "a.parquet").exists() and not (tmp_path / "d.txt").exists()


def test_device_step_names_every_controller_of_the_registry(tmp_path):
    """The refusal lists the registry's names (a new controller appears without touching the rig)."""
    from mckibben.control.registry import NAMES
    from mckibben.rig import Device

    with pytest.raises(InputError, match="controller: 'lqr' must be one of") as e:
        Device(str(tmp_path / "no-port")).step(0.3e6, controller="lqr")  # refused before the port is opened
    assert all(name in str(e.value) for name in NAMES) and {"smc", "pid"} <= set(NAMES)

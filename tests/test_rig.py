"""The rig over a real pseudo-terminal: the emulator (firmware core on the plant) and the host."""

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

from mckibben.rig import protocol as P
from mckibben.rig.emulator import Emulator
from mckibben.rig.recorder import Recorder, read_recording, recover


def _record(port, out, seconds, decimation=1):
    link = serial.Serial(port, 500000, timeout=0.02)
    rec = Recorder(Path(out), meta={"port": port})
    link.write(P.stream(0, True, decimation))
    t0 = time.monotonic()
    while time.monotonic() - t0 < seconds:
        rec.feed(link.read(8192))
    link.close()
    return rec, rec.close()


def test_ten_seconds_at_1khz_with_no_missing_frame(tmp_path):
    with Emulator() as em:
        rec, df = _record(em.port, tmp_path / "run.parquet", 10.0)
    c = rec.parser.counters()
    assert c["missing"] == 0 and c["corrupt"] == 0
    assert len(df) >= 9_500  # 10 s at 1 kHz, less the start-up of the stream (≤ 0.5 s)
    assert np.all(np.diff(df["seq"].to_numpy()) == 1)  # contiguous device frames
    dt = np.diff(df["time_s"].to_numpy())
    assert np.allclose(dt, 1e-3)  # every control period, 1 ms apart
    data, meta = read_recording(tmp_path / "run.parquet")
    assert meta["protocol_version"] == 1 and meta["counters"]["frames"] == c["frames"]
    assert not (tmp_path / "run.parquet.journal").exists()


def test_garbage_and_cut_frames_are_counted_and_skipped(tmp_path):
    with Emulator(garbage_every=100, cut_every=250) as em:
        rec, df = _record(em.port, tmp_path / "run.parquet", 2.0)
        cuts = em.cut
    c = rec.parser.counters()
    # every garbage burst is one corrupt packet; a cut frame has no delimiter, so it glues to the
    # next packet: one corrupt packet, and the next frame is lost with it unless that packet was
    # garbage (every 500th frame here)
    n = int(df["seq"].max())
    garbage = n // 100
    cut = n // 250
    both = n // 500
    # the recording stops at an arbitrary byte: frame n's garbage burst may be cut off (one
    # corrupt packet fewer), and if frame n + 1 was cut, the packet it glued to may have come in
    # (one more, both frames lost after n)
    edge = {0} | ({-1} if n % 100 == 0 else set()) | ({1} if (n + 1) % 250 == 0 else set())
    assert c["corrupt"] - (garbage + cut - both) in edge
    assert c["missing"] == 2 * cut - both
    assert cuts >= cut
    assert len(df) == n + 1 - c["missing"] - 1  # rows: every telemetry seq but the lost ones (seq 0 is the ACK)


def test_kill_9_loses_at_most_one_second(tmp_path):
    out = tmp_path / "run.parquet"
    with Emulator() as em:
        rec = subprocess.Popen([sys.executable, "-m", "mckibben.cli", "rig", "record", "--port", em.port, "--out", str(out),
                                "--duration", "60s", "--json"], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        journal = Path(str(out) + ".journal")
        end = time.monotonic() + 60
        while time.monotonic() < end and len(list(journal.glob("part-*.parquet"))) < 8:
            time.sleep(0.05)
        time.sleep(0.37)  # an arbitrary moment between journal parts
        device_time_at_kill = em.steps * em.ts
        rec.send_signal(signal.SIGKILL)
        rec.wait(timeout=10)
    assert rec.returncode == -signal.SIGKILL
    assert journal.is_dir() and not out.exists()
    from mckibben.cli import main

    assert main(["rig", "recover", str(journal), "--out", str(out), "--json"]) == 0
    df, meta = read_recording(out)
    assert len(df) > 1000
    assert np.all(np.diff(df["seq"].to_numpy()) == 1)  # what was kept is whole
    assert device_time_at_kill - df["time_s"].max() <= 1.0  # at most one second lost


def test_rig_step_metrics_over_the_link(cli):
    with Emulator() as em:
        r = cli("rig", "step", "--port", em.port, "--target", "0.4MPa", "--duration", "0.5s", "--json")
    assert r.code == 0, r.err
    m = r.json()
    assert m["missing"] == 0 and m["target_Pa"] == 0.4e6
    assert 0 < m["rise_time_s"] < 0.3 and np.isfinite(m["time_constant_s"])


@pytest.mark.parametrize(
    "args, message",
    [
        (["rig", "record", "--port", "/dev/nonexistent-tty", "--out", "{tmp}/a.parquet"], "error: --port: cannot open '/dev/nonexistent-tty'"),
        (["rig", "record", "--port", "{pty}", "--out", "/no/such/dir/a.parquet"], "error: --out: folder '/no/such/dir' does not exist"),
        (["rig", "record", "--port", "{pty}", "--out", "{tmp}/a.csv"], "error: --out: '{tmp}/a.csv' must end in .parquet"),
        (["rig", "record", "--port", "{pty}", "--out", "{tmp}/a.parquet", "--duration", "10"], "error: --duration: '10' has no unit"),
        (["rig", "recover", "{tmp}", "--out", "{tmp}/a.parquet"], "error: '{tmp}' is not a recorder journal (no meta.json)"),
        (["rig", "step", "--port", "{pty}", "--target", "0.9MPa"], "error: --target: '0.9MPa' is above the 0.8 MPa safe limit"),
        (["rig", "step", "--port", "{pty}", "--controller", "lqr"], "error: --controller: 'lqr' must be smc or pid"),
        (["rig", "emulate", "--link", "/no/such/dir/tty"], "error: --link: cannot create '/no/such/dir/tty'"),
    ],
)
def test_bad_input(cli, tmp_path, args, message):
    master, slave = os.openpty()
    try:
        fill = {"tmp": str(tmp_path), "pty": os.ttyname(slave)}
        r = cli(*[a.format(**fill) for a in args])
    finally:
        os.close(master)
        os.close(slave)
    assert r.code == 2
    assert r.err.startswith(message.format(**fill)) and r.err.count("\n") == 1
    assert not (tmp_path / "a.parquet").exists()

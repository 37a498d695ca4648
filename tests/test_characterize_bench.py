"""The bench side channel (mckibben.rig.bench), served alike by both device engines over a real Unix socket."""

from __future__ import annotations

import time

import pytest

from mckibben.errors import InputError
from mckibben.rig.bench import Bench, bench_path, parse_request

from conftest import start_device


def _settle(b: Bench, seconds: float = 0.6):
    time.sleep(seconds)
    return b.state()


def test_load_hold_release_on_both_engines(engine):
    with start_device(engine, n_channels=1, boot_time=0.1) as dev:
        b = Bench.of_port(dev.port)
        assert b.path == bench_path(dev.port) and b.path.is_socket()
        first = b.state()
        assert first.load == pytest.approx(0.6) and not first.held  # the calibrated rig's 0.6 N
        b.load(2.1)
        s = _settle(b)
        assert s.load == pytest.approx(2.1) and not s.held
        # vented, the heavier weight pulls the muscle to its straight-braid end stop, past the 0.6 N rest
        assert s.length >= first.length
        b.hold(0.09)
        s = _settle(b, 0.3)
        assert s.held and s.length == pytest.approx(0.09, abs=1e-12)  # clamped: it does not move
        b.release()
        s = _settle(b)
        assert not s.held and s.length > 0.09
        with pytest.raises(InputError, match="outside the muscle's travel"):
            b.hold(5.0)
        for bad, words in (("fly 3", "unknown request"), ("load", "takes one number"), ("load -1", ">= 0"),
                           ("state 2", "takes no value"), ("load x", "number")):
            with pytest.raises(InputError, match=words):
                b.request(bad)
    assert not b.path.exists()  # the device removes its socket when it stops


def test_parse_request_grammar():
    assert parse_request("load 0.6") == ("load", 0.6)
    assert parse_request(" hold 0.092 ") == ("hold", 0.092)
    assert parse_request("release") == ("release", None)
    for bad in ("", "hold 0", "load nan", "load 1 2", "jump"):
        with pytest.raises(InputError):
            parse_request(bad)


def test_cli_bench(cli, tmp_path):
    with start_device("python", n_channels=1, boot_time=0.1) as dev:
        link = tmp_path / "mega"
        link.symlink_to(dev.port)
        r = cli("rig", "bench", "--port", str(link), "load", "214g", "--json")
        assert r.code == 0, r.err
        r = cli("rig", "bench", "--port", str(link), "state", "--json")
        assert r.code == 0 and r.json()["load_N"] == pytest.approx(0.214 * 9.80665)
        for args, words in ((("load",), "give a weight"), (("load", "3mm"), "load"), (("state", "1"), "no value"),
                            (("fly",), "load, hold, release, state"), (("hold", "5m"), "travel")):
            r = cli("rig", "bench", "--port", str(link), *args)
            assert r.code == 2 and words in r.err and "Traceback" not in r.err, (args, r.err)
    r = cli("rig", "bench", "--port", str(tmp_path / "nothing"), "state")
    assert r.code == 2 and "no bench socket" in r.err


def test_no_place_for_the_socket_the_device_runs_without_a_bench(engine, monkeypatch, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("")
    monkeypatch.setenv("MCKIBBEN_BENCH_DIR", str(blocker / "bench"))  # under a file: no folder can be made
    with start_device(engine, n_channels=1, boot_time=0.1) as dev:
        assert dev.bench is None
        with pytest.raises(InputError, match="no bench socket"):
            Bench.of_port(dev.port).state()
        from mckibben.rig.device import connect

        link, hello, _ = connect(dev.port)  # the device itself answers
        link.close()
        assert hello.n_channels == 1


def _encoder(port: str, link, parser, seconds: float = 0.2) -> int:
    """The encoder count of the newest telemetry frame after reading for ``seconds`` (what was queued drained). [count]"""
    from mckibben.rig import protocol as P

    got: list = []
    end = time.monotonic() + seconds
    while time.monotonic() < end or not got and time.monotonic() < end + 5.0:
        got += [f.encoder for f in parser.feed(link.read(4096)) if isinstance(f, P.Telemetry)]
    assert got, f"{port}: no telemetry"
    return got[-1]


@pytest.mark.slow  # the avr engine's image in simavr: 5-40 s on a loaded machine
def test_both_engines_count_the_encoder_from_where_the_muscle_was_at_reset(engine):
    # an incremental encoder: the Mega's count starts at 0 on reset (opening the port), wherever the muscle is;
    # the avr harness (firmware/pil/pil.c) and the Python emulator agree on it
    from mckibben import hardware as HW
    from mckibben.rig import protocol as P
    from mckibben.rig.device import connect

    with start_device(engine, n_channels=1, boot_time=0.1) as dev:
        b = Bench.of_port(dev.port)
        b.load(2.1)  # vented, the heavy weight pulls the muscle well past its nominal length
        at_reset = _settle(b).length
        assert at_reset - 0.097 > 5 * HW.ENCODER_RESOLUTION
        link, _, parser = connect(dev.port)  # the open resets the device
        try:
            link.write(P.stream(1, True, 1))
            assert abs(_encoder(dev.port, link, parser)) <= 1  # not the shortening from the nominal length
            b.hold(at_reset - 3e-3)  # 3 mm shorter: about 17.6 counts of shortening
            time.sleep(0.3)
            assert abs(_encoder(dev.port, link, parser) - 3e-3 / HW.ENCODER_RESOLUTION) <= 1
        finally:
            link.close()

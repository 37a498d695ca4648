"""``mckibben firmware build|flash|sketch``: the real Makefile, avr-gcc and make; bad input is one line, exit 2."""

import os
import subprocess
import sys

import pytest

from test_firmware import needs_avr


@needs_avr
def test_build_writes_an_image_simavr_loads(cli, tmp_path):
    r = cli("firmware", "build", "--channels", "2", "--out", str(tmp_path / "img"), "--json")
    assert r.code == 0, r.err
    out = r.json()
    assert out["channels"] == 2 and out["bytes"] > 10_000
    elf = tmp_path / "img" / "mckibben.elf"
    assert elf.read_bytes()[:4] == b"\x7fELF" and (tmp_path / "img" / "mckibben.hex").read_text().startswith(":")
    assert sorted(p.name for p in (tmp_path / "img").iterdir()) == ["mckibben.elf", "mckibben.hex"]


@needs_avr
def test_flash_dry_run_prints_the_makefiles_avrdude_command(cli):
    r = cli("firmware", "flash", "--port", "/dev/ttyACM7", "--dry-run")
    assert r.code == 0, r.err
    line = r.out.strip()
    assert line.startswith("avrdude -p atmega2560 -c wiring -P /dev/ttyACM7 -b 115200 -D -U flash:w:")
    hex_file = line.rsplit("flash:w:", 1)[1].removesuffix(":i")
    assert os.path.isfile(hex_file)  # the command flashes an image that exists


def test_sketch_writes_the_arduino_folder(cli, tmp_path):
    r = cli("firmware", "sketch", "--out", str(tmp_path), "--json")
    assert r.code == 0, r.err
    folder = tmp_path / "mckibben"
    assert (folder / "mckibben.ino").is_file() and (folder / "src" / "main.c").is_file()
    assert (folder / "src" / "controller.c").is_file() and (folder / "src" / "protocol.c").is_file()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".mckibben")]  # no leftovers


@pytest.mark.parametrize("args, message", [
    (["build", "--channels", "4", "--out", "{tmp}/x"], "error: --channels: 4 must be 1, 2 or 3"),
    (["build", "--out", "/no/such/dir/img"], "error: --out: folder '/no/such/dir' does not exist"),
    (["build", "--out", "{tmp}/file.txt"], "error: --out: '{tmp}/file.txt' is not a folder"),
    (["flash", "--port", "/dev/no-such-mega"], "error: --port: '/dev/no-such-mega' does not exist"),
    (["flash", "--port", " ", "--dry-run"], "error: --port: give the Mega's serial port"),
    (["sketch", "--out", "/no/such/dir"], "error: --out: '/no/such/dir' is not an existing folder"),
])
def test_bad_input(cli, tmp_path, args, message):
    (tmp_path / "file.txt").write_text("x")
    r = cli("firmware", *[a.format(tmp=tmp_path) for a in args])
    assert r.code == 2, r.err
    assert r.err.startswith(message.format(tmp=tmp_path)) and r.err.count("\n") == 1
    assert not (tmp_path / "x").exists()


@pytest.mark.parametrize("args, tool, package", [
    (["firmware", "build", "--out", "{tmp}/img"], "avr-gcc", "gcc-avr avr-libc"),
    (["rig", "emulate", "--engine", "avr", "--duration", "1s"], "avr-gcc", "gcc-avr avr-libc"),
])
def test_a_missing_tool_is_one_line_naming_the_package(tmp_path, args, tool, package):
    env = {**os.environ, "PATH": str(tmp_path)}  # no tool on the PATH
    r = subprocess.run([sys.executable, "-m", "mckibben.cli", *[a.format(tmp=tmp_path) for a in args]],
                       capture_output=True, text=True, env=env, timeout=120)
    assert r.returncode == 2, r.stderr
    assert r.stderr.strip().splitlines()[-1] == (f"error: {tool} not found: install it (Debian/Ubuntu: sudo apt-get "
                                                  f"install {package})")
    assert not (tmp_path / "img").exists()

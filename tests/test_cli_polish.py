"""The command line's manners: --version, -h, completion, plain tables when piped, the user's umask."""

from __future__ import annotations

import os
import stat
import subprocess
import sys

import pytest

import mckibben


def test_version_and_short_help(cli):
    r = cli("--version")
    assert r.code == 0 and r.out.strip() == f"mckibben {mckibben.__version__}"
    r = cli("-h")
    assert r.code == 0 and "Usage: mckibben" in r.out and "control" in r.out
    r = cli("control", "step", "-h")
    assert r.code == 0 and "--target" in r.out


def test_shell_completion_script(cli, tmp_path):
    r = cli("completion", "bash")
    assert r.code == 0 and "_MCKIBBEN_COMPLETE=complete_bash" in r.out
    # the script really completes: bash asks the program, which answers with the commands
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path), "_MCKIBBEN_COMPLETE": "complete_bash",
           "COMP_WORDS": "mckibben cont", "COMP_CWORD": "1"}
    done = subprocess.run([sys.executable, "-m", "mckibben.cli"], capture_output=True, text=True, env=env,
                          timeout=120, cwd=tmp_path)
    assert "control" in done.stdout.split()
    r = cli("completion", "tcsh")
    assert r.code == 2 and "unknown shell 'tcsh'" in r.err and r.err.count("\n") == 1


def test_piped_tables_are_plain_and_never_cut(cli):
    # stdout is a StringIO here, as it is a pipe for `mckibben control fig13 | cat`
    r = cli("predict", "length", "--muscle", "mpam97", "--pressure", "0.1,0.2,0.3,0.4,0.5,0.6,0.7,0.8MPa",
            "--load", "0.6N")
    assert r.code == 0, r.err
    assert "…" not in r.out and "━" not in r.out and "│" not in r.out
    assert max(len(line) for line in r.out.splitlines()) > 0


@pytest.fixture
def umask022():
    old = os.umask(0o022)
    yield
    os.umask(old)


def test_files_and_folders_follow_the_umask(cli, tmp_path, umask022):
    pdf = tmp_path / "ws.pdf"
    r = cli("tool", "workspace", "--grid", "3", "--plot", str(pdf))
    assert r.code == 0, r.err
    assert stat.S_IMODE(pdf.stat().st_mode) == 0o644
    out = tmp_path / "campaign"
    r = cli("datasets", "generate", "--out", str(out))
    assert r.code == 0, r.err
    assert stat.S_IMODE(out.stat().st_mode) == 0o755
    modes = {stat.S_IMODE(p.stat().st_mode) for p in out.rglob("*") if p.is_file()}
    assert modes == {0o644}


def test_examples_ship_in_the_package_and_copy_out(cli, tmp_path):
    r = cli("examples", "list", "--json")
    assert r.code == 0 and "sweep.toml" in r.json()["examples"]
    r = cli("examples", "copy", "sweep.toml", str(tmp_path))
    assert r.code == 0, r.err
    from mckibben.sweep import load_sweep

    assert load_sweep(tmp_path / "sweep.toml").n_runs > 0  # the copy is a valid sweep
    r = cli("examples", "copy", "sweep.toml", str(tmp_path))
    assert r.code == 2 and "exists" in r.err and r.err.count("\n") == 1
    r = cli("examples", "copy", "swep.toml", str(tmp_path))
    assert r.code == 2 and "Did you mean sweep.toml?" in r.err


def test_sweep_run_writes_only_where_asked(cli, tmp_path):
    r = cli("sweep", "run", "sweep.toml")
    assert r.code == 2 and "--out" in r.err


OUT_COMMANDS = [
    ["simulate", "open-loop"],
    ["control", "step"],
    ["control", "track", "--reference", "sine:0.4MPa,0.1MPa,2Hz"],
    ["control", "fig13"],
    ["control", "compare"],
    ["control", "robustness", "--n", "2"],
    ["tool", "workspace", "--grid", "3"],
    ["tool", "track", "--path", "circle:radius=3mm,period=1s"],
]


@pytest.mark.parametrize("cmd", OUT_COMMANDS, ids=lambda c: "-".join(c[:2]))
@pytest.mark.parametrize("option, value, says", [("--out", "x.xlsx", "must end in .csv or .parquet"),
                                                 ("--out", "nodir/x.csv", "does not exist"),
                                                 ("--plot", "x.docx", "must end in .avif, .eps"),
                                                 ("--dpi", "5", "--dpi")])
def test_outputs_refused_before_any_work(cli, tmp_path, cmd, option, value, says):
    if option == "--dpi":
        args = [*cmd, "--plot", str(tmp_path / "f.png"), "--dpi", value]
    else:
        args = [*cmd, option, str(tmp_path / value)]
    r = cli(*args)
    assert r.code == 2 and says in r.err and r.err.count("\n") == 1, r.err
    assert list(tmp_path.iterdir()) == []  # nothing written


def test_simulate_and_control_step_print_labels_with_units_alike(cli):
    sim = cli("simulate", "open-loop")
    step = cli("control", "step")
    assert sim.code == 0 and step.code == 0, sim.err + step.err
    for out in (sim.out, step.out):
        assert "time constant (63 %)" in out and "rise time (10–90 %)" in out and " ms" in out
        assert "_s " not in out and "_Pa" not in out and "_pct" not in out  # no raw JSON keys
    assert " kPa" in step.out and "counts" in step.out and " MPa" in sim.out and " mm" in sim.out


def test_every_error_line_has_the_one_prefix(cli):
    usage = cli("fit", "x.csv")  # a usage error (Click's)
    bad = cli("fit", "x.csv", "--model", "spring")  # the library's InputError
    empty = cli("fit", "x.csv", "--model", "spring", "--plot", "")
    for r in (usage, bad, empty):
        assert r.code == 2 and r.err.startswith("error: ") and r.err.count("\n") == 1, r.err
    assert usage.err == "error: mckibben fit: Missing option '--model'.\n"


def _commands(group, path=()):
    for name, cmd in getattr(group, "commands", {}).items():
        yield (*path, name), cmd
        yield from _commands(cmd, (*path, name))


def test_the_command_lists_short_help_is_not_cut_at_an_abbreviation():
    import typer

    from mckibben.cli import app

    root = typer.main.get_command(app)
    helps = {" ".join(p): c.get_short_help_str(200) for p, c in _commands(root)}
    assert helps["control fig13"].startswith("The paper's Fig. 13: sliding mode")
    cut = {k: h for k, h in helps.items() if h.endswith(("Fig.", "e.g.", "eq.", "i.e."))}
    assert not cut, cut


def test_plain_tables_fit_columns_when_told(cli, monkeypatch):
    monkeypatch.setenv("COLUMNS", "70")
    r = cli("params", "show", "mpam97")
    assert r.code == 0 and max(len(line) for line in r.out.splitlines()) <= 70, r.out
    rows = [line for line in r.out.splitlines() if line.strip()]
    assert "citation" in r.out and len(rows) > 14  # the long citation wrapped onto continuation lines, not cut
    monkeypatch.delenv("COLUMNS")
    assert max(len(line) for line in cli("params", "show", "mpam97").out.splitlines()) > 70  # piped: a line per row


@pytest.mark.parametrize("args", [["params", "show", "mpam97"], ["doctor", "--no-warm"]])
def test_tables_fit_the_terminal(args):
    import os
    import pty
    import re
    import subprocess
    import sys
    from pathlib import Path

    leader, follower = pty.openpty()
    env = {**os.environ, "COLUMNS": "72", "LINES": "40", "TERM": "xterm",
           "PYTHONPATH": str(Path(__file__).resolve().parents[1] / "src")}
    proc = subprocess.Popen([sys.executable, "-m", "mckibben.cli", *args], stdin=follower, stdout=follower,
                            stderr=follower, env=env, close_fds=True)
    os.close(follower)
    chunks = []
    while True:
        try:
            data = os.read(leader, 65536)
        except OSError:  # the child closed the terminal
            break
        if not data:
            break
        chunks.append(data)
    proc.wait(timeout=120)
    os.close(leader)
    text = re.sub(r"\x1b\[[0-9;?]*[A-Za-z]", "", b"".join(chunks).decode("utf-8", "replace"))
    assert proc.returncode in (0, 1), text  # doctor exits 1 when an optional part is missing
    assert max(len(line.rstrip("\r")) for line in text.splitlines()) <= 72, text

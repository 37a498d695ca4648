"""The library names Python arguments; the command line says the flags the user typed (issue 23 item 3)."""

from __future__ import annotations

import pytest

from mckibben import experiments
from mckibben.cli import app
from mckibben.cli._common import command_of, option_flags, in_flags
from mckibben.errors import InputError


def test_a_commands_flags_come_from_its_own_options():
    flags = option_flags(command_of(app, ["control", "step", "--beta", "300"]))
    assert flags["beta"] == "--beta" and flags["start"] == "--from" and flags["p_max"] == "--p-max"
    assert flags["muscle_file"] == "--muscle-file"


@pytest.mark.parametrize("message, shown", [
    ("beta: 300.0 must be in 0..255 PWM counts", "--beta: 300.0 must be in 0..255 PWM counts"),
    ("p_max = 2: outside", "--p-max = 2: outside"),
    ("target: equals `start`, there is no step", "--target: equals --from, there is no step"),
    ("target/start: clamped", "--target/--from: clamped"),
    ("unknown `law` 'papr'. Did you mean paper?", "unknown --law 'papr'. Did you mean paper?"),
    ("muscle_file my.toml: no [force_model] table", "--muscle-file my.toml: no [force_model] table"),
    ("loads: 3 given", "loads: 3 given"),  # not an argument of the command: as written
    ("`order` 1 or 2", "`order` 1 or 2"),
])
def test_in_flags_rewrites_the_arguments_a_message_names(message, shown):
    assert in_flags(message, option_flags(command_of(app, ["control", "step"]))) == shown


def test_the_library_names_the_python_argument():
    with pytest.raises(InputError) as info:
        experiments.step_response("smc", beta=300)
    assert str(info.value).startswith("beta:") and "--" not in str(info.value)


def test_the_command_line_names_the_flag(cli):
    r = cli("control", "step", "--target", "0.3MPa", "--from", "0.3MPa")
    assert r.code == 2 and r.err == "error: --target: equals --from, there is no step\n"

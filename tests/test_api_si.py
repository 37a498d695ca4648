"""The library takes numbers in SI and objects; the command line parses (issue 23).

Text with a unit given to an experiment is refused at once with the SI number (or the object) to
pass, naming the Python argument; the one parser of the command line's ``--reference`` text is
:func:`mckibben.control.parse_reference`.
"""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

import mckibben.control as mc
import mckibben.experiments as mx
from mckibben.control.references import SineReference, parse_reference
from mckibben.errors import ArgumentTypeError, InputError
from mckibben.rig import Device

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "mckibben"


@pytest.mark.parametrize("call, name, number", [
    (lambda: mx.step_response("smc", target="0.55MPa"), "target", "550000"),
    (lambda: mx.step_response("smc", start="0.1MPa"), "start", "100000"),
    (lambda: mx.step_response("smc", load="0.6N"), "load", "0.6"),
    (lambda: mx.step_response("smc", duration="300ms"), "duration", "0.3"),
    (lambda: mx.step_response("smc", p_max="0.7MPa"), "p_max", "700000"),
    (lambda: mx.step_response("smc", eps="20kPa"), "eps", "20000"),
    (lambda: mx.step_response("pid", lam="30ms"), "lam", "0.03"),
    (lambda: mx.track_pressure(SineReference(0.4e6, 0.1e6, 2.0), duration="1s"), "duration", "1"),
    (lambda: mx.open_loop(supply="0.8MPa"), "supply", "800000"),
    (lambda: mx.hysteresis_compensation("4s"), "period", "4"),
    (lambda: mx.fig13(eps="50kPa"), "eps", "50000"),
    (lambda: mc.controller_params("smc", mc.FirstOrderModel(3000.0, 0.09), p_max="0.8MPa"), "p_max", "800000"),
    (lambda: Device("/nonexistent/tty").step("0.4MPa"), "target", "400000"),
])
def test_text_is_refused_with_the_si_number_to_pass(call, name, number):
    with pytest.raises(ArgumentTypeError) as info:
        call()
    message = str(info.value)
    assert message.startswith(f"{name} = ") and f"pass {number} " in message and "--" not in message


def test_a_sine_reference_is_an_object_and_its_text_is_refused():
    with pytest.raises(ArgumentTypeError) as info:
        mx.track_pressure("sine:0.4MPa,0.1MPa,2Hz")
    assert "SineReference(mean=400000.0, amplitude=100000.0, frequency=2.0)" in str(info.value)
    t, p = mc.pressure_reference(SineReference(0.4e6, 0.1e6, 2.0), 0.5)
    assert t.size == 500 and np.allclose(p, 0.4e6 + 0.1e6 * np.sin(2 * np.pi * 2.0 * t))


def test_parse_reference_is_the_one_parser_of_the_command_line_text(tmp_path):
    ref = parse_reference("sine:0.4MPa,100kPa,2Hz")
    assert ref == SineReference(0.4e6, 0.1e6, 2.0)
    assert parse_reference(ref.text) == ref  # the text form reads back exactly
    assert parse_reference(str(tmp_path / "r.csv")) == tmp_path / "r.csv"  # a file: its path
    for bad, says in [("sine:0.4MPa,0.2MPa", "reference: "), ("sine:nanMPa,0.2MPa,2Hz", "reference mean"),
                      ("sine:0.4MPa,0.2MPa,0Hz", "reference frequency"), ("sine:0.4MPa,2N,1Hz", "reference amplitude")]:
        with pytest.raises(InputError, match=says):
            parse_reference(bad)


def test_a_sine_reference_checks_its_numbers():
    with pytest.raises(InputError, match="^mean = "):
        SineReference(-1.0, 0.1e6, 2.0)
    with pytest.raises(InputError, match="^frequency = 0"):
        SineReference(0.4e6, 0.1e6, 0.0)
    with pytest.raises(ArgumentTypeError, match="^amplitude = '0.1MPa'"):
        SineReference(0.4e6, "0.1MPa", 2.0)
    with pytest.raises(InputError, match="^reference frequency: 600 Hz is above the 500 Hz"):
        mc.pressure_reference(SineReference(0.4e6, 0.1e6, 600.0), 1.0)


#: Where the library takes numbers (issue 23): these packages and modules, and the one parser of
#: text among them (the command line's ``--reference``).
TAKES_NUMBERS = ("control", "rig", "experiments", "export")
PARSERS = {("control/references.py", "parse_reference"),
           # a characterization protocol is a file a user writes, with units ("0.6N", "0.8MPa"): its
           # reader is an edge, like a reference file's
           ("rig/characterize.py", "_ask_length"), ("rig/characterize.py", "_protocol"),
           ("rig/characterize.py", "quantity"), ("rig/characterize.py", "quantities")}


def _text_parsing_calls():
    """(file, enclosing function) of every call of quantity/parse_quantity/parse_values there."""
    found = []
    for where in TAKES_NUMBERS:
        paths = [PACKAGE / where] if where.endswith(".py") else sorted((PACKAGE / where).rglob("*.py"))
        for path in paths:
            tree = ast.parse(path.read_text(encoding="utf-8"))
            for fn in ast.walk(tree):
                if not isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
                    continue
                for node in ast.walk(fn):
                    if (isinstance(node, ast.Call) and isinstance(node.func, (ast.Name, ast.Attribute))
                            and getattr(node.func, "id", getattr(node.func, "attr", None))
                            in ("quantity", "parse_quantity", "parse_values")):
                        found.append((path.relative_to(PACKAGE).as_posix(), fn.name))
    return found


def test_only_the_reference_parser_reads_text_there():
    calls = set(_text_parsing_calls())
    assert ("control/references.py", "parse_reference") in calls  # the walk sees the packages
    assert calls - PARSERS == set()

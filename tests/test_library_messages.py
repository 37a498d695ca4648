"""Library messages name Python arguments, not command-line flags (issue 23).

A notebook user who passes ``beta=300`` must read ``beta: ...``, not ``--beta``; the command line
maps the argument to its flag (:func:`mckibben.cli._common.in_flags`). The walk reads every string
the library code holds outside ``mckibben.cli`` (docstrings excepted: they may show a command
line) and refuses one that writes a flag (``--out``, ``(--pressure)``, ``… --save FILE``).
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "mckibben"
FLAG = re.compile(r"(?:^|[\s(`'\"/])--[a-z][a-z-]*")

#: Strings that write a flag on purpose or are not converted yet, by file, with why.
KNOWN = {
    # another program's command line, quoted in a hint
    ("doctor.py", "; start one with: dask scheduler --port "): "the Dask scheduler's own flag",
    # the processor-in-the-loop harness's own command line (firmware/pil/pil.c), which the engine runs
    ("rig/engines/avr.py", "--boot-time"): "the PIL harness's own flag",
    ("rig/engines/avr.py", "--unthrottled"): "the PIL harness's own flag",
    ("rig/engines/avr.py", "--stall-at"): "the PIL harness's own flag",
    ("rig/engines/avr.py", "--hold-adc"): "the PIL harness's own flag",
    ("rig/engines/avr.py", "--load-cell"): "the PIL harness's own flags (--load-cell, -offset, -noise, -seed)",
    ("rig/engines/avr.py", "--bench-dir"): "the PIL harness's own flag",
    ("rig/engines/avr.py", "--adc-miss-at"): "the PIL harness's own flag",
    ("rig/engines/avr.py", "--adc-miss-n"): "the PIL harness's own flag",
    ("rig/engines/avr.py", "--profile"): "the PIL harness's own flag",
    ("rig/engines/avr.py", "--rings"): "the PIL harness's own flag",
    # provenance notes of the generated data: the command that generated them
    ("datasets/campaign.py", "mckibben datasets generate --seed"): "provenance of generated data",
    ("datasets/isometric.py", "mckibben fit isometric.csv --model spring --json"): "the generated data's README",
    ("datasets/published.py", "unreadable in our copy: fit them with `mckibben fit --model spring`"): "a data note",
    ("fit/muscle_file.py", "Force law fitted by mckibben fit --model "): "provenance note written into the file",
    ("fit/muscle_file.py", " --direction-aware ("): "the same provenance note, of a direction-aware fit",
    # the report's closing section: the command lines that run the same on a lab's own data
    ("report/html.py", "<h2>Run it on your data</h2>"): "the report shows the commands to type",
}


def _docstrings(tree: ast.AST) -> set[int]:
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
                out.add(id(first.value))
    return out


def flag_strings(path: Path) -> list[str]:
    """The string constants (and f-string pieces) of a module that write a ``--flag``, docstrings excepted."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    skip = _docstrings(tree)
    return [node.value for node in ast.walk(tree)
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in skip
            and FLAG.search(node.value)]


def test_no_library_message_names_a_flag():
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE).as_posix()
        if rel.startswith("cli/"):
            continue
        found += [(rel, s) for s in flag_strings(path) if (rel, s) not in KNOWN
                  and not any(rel == f and k in s for f, k in KNOWN)]
    assert found == []


def test_the_walk_finds_a_flag(tmp_path):
    """The check can fail: a message with a flag, in code or in an f-string, is found; a docstring is not."""
    p = tmp_path / "m.py"
    p.write_text('"""Run ``mckibben sweep run --out R``."""\n'
                 'def f(out, x):\n    """--doc"""\n    check(out, "--out")\n'
                 '    raise ValueError(f"{x} (--pressure) bad")\n')
    assert flag_strings(p) == ["--out", " (--pressure) bad"]

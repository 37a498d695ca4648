"""Citations: the papers are cited by bibliography key and author–year, never by the file names of our
copies of their texts, in any command's output, in the report and in the documentation sources; the
library's bibliography and docs/references.md hold the same records.

The two file names are spelled out here, once, because this is the test that looks for them.
"""

from __future__ import annotations

import ast
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
import typer

from mckibben.cli import app
from mckibben import datasets
from mckibben.datasets import MUSCLES, parameter_sets
from mckibben.datasets.references import KEY_PATTERN, REFERENCES, cited, reference, render
from mckibben.errors import InputError

ROOT = Path(__file__).resolve().parents[1]
FILE_NAMES = ("000_909f662a44080c85", "001_9d98bcef9f07dbeb")


def _clean(text: str, where: str) -> None:
    for name in FILE_NAMES:
        assert name not in text, f"{where} shows {name}"


def _mckibben(*args: str, cwd: Path) -> tuple[str, str]:
    """``mckibben ARGS`` as a user runs it, a separate process: (stdout, stderr)."""
    env = {**os.environ, "COLUMNS": "250"}  # a wide terminal: the tables wrap their cells to $COLUMNS
    r = subprocess.run([sys.executable, "-m", "mckibben.cli", *args], capture_output=True, text=True, timeout=600,
                       cwd=cwd, env=env)
    assert r.returncode == 0, (args, r.stderr[-2000:])
    return r.stdout, r.stderr


def _in_process(cli):
    def run(*args: str) -> tuple[str, str]:
        r = cli(*args)
        assert r.code == 0, (args, r.err)
        return r.out, r.err
    return run


def _commands(cmd=None, path=()):
    cmd = cmd if cmd is not None else typer.main.get_command(app)
    yield list(path)
    for name, sub in getattr(cmd, "commands", {}).items():
        yield from _commands(sub, (*path, name))


def _check_params(run) -> None:
    """``params list``, ``params list --json`` and ``params show NAME [--json]`` of every set."""
    out, err = run("params", "list")
    _clean(out + err, "params list")
    assert "Wickramatunge & Leephakpreeda (2010) [wickramatunge2010]" in out
    assert "[mpam-characterization]" in out

    sets = json.loads(run("params", "list", "--json")[0])["parameter_sets"]
    assert [s["name"] for s in sets] == [s["name"] for s in parameter_sets()]
    assert len(sets) == len(datasets.MUSCLES) + len(datasets.SPRING_MUSCLE_SIZES) + len(datasets.LAW_SETS)
    for s in sets:
        record = REFERENCES[s["citation"]["key"]]
        assert s["citation"] == json.loads(json.dumps(record.to_dict())), s["name"]
        # a year is an integer wherever it is established; where it is not, the record says so
        assert isinstance(s["citation"]["year"], int) or (
            s["citation"]["year"] is None and "year" in s["citation"]["unestablished"]), s["name"]
        _clean(json.dumps(s), f"params list --json ({s['name']})")
    spring = [s for s in sets if s["name"].startswith("spring-")]
    assert {s["citation"]["year"] for s in spring} == {2010}

    for s in sets:
        out, err = run("params", "show", s["name"])
        _clean(out + err, f"params show {s['name']}")
        assert s["citation"]["short"] in out
        data = json.loads(run("params", "show", s["name"], "--json")[0])
        assert data["citation"] == s["citation"], s["name"]
        _clean(json.dumps(data), f"params show {s['name']} --json")


def test_params_list_and_show_print_citations(cli):
    _check_params(_in_process(cli))


@pytest.mark.slow
def test_params_commands_as_separate_processes(tmp_path):
    _check_params(lambda *args: _mckibben(*args, cwd=tmp_path))


def test_every_help_text_is_clean(cli):
    commands = list(_commands())
    assert ["params", "list"] in commands and ["reproduce"] in commands and len(commands) > 30
    for path in commands:
        r = cli(*path, "--help")
        assert r.code == 0, (path, r.err)
        _clean(r.out + r.err, f"mckibben {' '.join(path)} --help")


@pytest.mark.slow
def test_reproduce_prints_and_reports_citations(tmp_path):
    out = tmp_path / "report"
    stdout, stderr = _mckibben("reproduce", "--out", str(out), cwd=tmp_path)
    _clean(stdout + stderr, "reproduce")
    assert "Table I (“Experimental Characterization and Control of Miniaturized Pneumatic Artificial Muscle”" \
           " (n.d.))" in stdout
    page = (out / "index.html").read_text(encoding="utf-8")
    assert "Spring model of Wickramatunge &amp; Leephakpreeda (2010):" in page
    assert "<h2>References</h2>" in page and "Study on mechanical behaviors of pneumatic artificial muscle" in page
    for f in out.rglob("*"):  # every file the report writes: the page, its data, its figures' metadata
        if f.is_file():
            _clean(f.read_bytes().decode("utf-8", errors="replace"), str(f.relative_to(tmp_path)))
    _clean("".join(_mckibben("reproduce", "--out", str(tmp_path / "again"), "--json", cwd=tmp_path)),
           "reproduce --json")


def _sources() -> list[Path]:
    """The text files a user reads or a command prints from: docs, the package (with its bundled
    data), the firmware shipped in the wheel, the benchmarks, README and CHANGELOG."""
    text = {".md", ".py", ".ipynb", ".rst", ".txt", ".toml", ".csv", ".json", ".c", ".h", ".ino", ".cfg", ".in"}
    found = [p for d in ("docs", "src", "firmware", "benchmarks") for p in (ROOT / d).rglob("*")
             if p.is_file() and p.suffix in text and "__pycache__" not in p.parts]
    return found + [ROOT / "README.md", ROOT / "CHANGELOG.md"]


def _prose(path: Path) -> str:
    """A file's text, or for Python its string constants (docstrings and messages, not code)."""
    text = path.read_text(encoding="utf-8", errors="replace")
    if path.suffix != ".py":
        return text
    return "\n".join(n.value for n in ast.walk(ast.parse(text)) if isinstance(n, ast.Constant) and isinstance(n.value, str))


def test_docs_and_docstrings_cite_by_key():
    # the docs pages, and the package whose docstrings the API page renders (and the rest a user
    # reads), name no file of ours and cite only keys the bibliography holds
    keys = set()
    for path in _sources():
        _clean(path.read_text(encoding="utf-8", errors="replace"), str(path.relative_to(ROOT)))
        for key in KEY_PATTERN.findall(_prose(path)):
            assert key in REFERENCES, f"{path.relative_to(ROOT)} cites [{key}], which docs/references.md does not hold"
            keys.add(key)
    assert keys == set(REFERENCES)  # and every record is cited somewhere


def test_docs_bibliography_matches_the_library():
    page = (ROOT / "docs" / "references.md").read_text(encoding="utf-8")
    sections = {s.split("\n", 1)[0].strip(): s for s in re.split(r"^### ", page, flags=re.M)[1:]}
    assert set(sections) == set(REFERENCES)
    for key, ref in REFERENCES.items():
        text = sections[key]
        assert ref.title in text and f"{{{key}," in text, key  # the title, and a BibTeX entry under the key
        fields = dict(re.findall(r"^\| (title|authors|venue|year|DOI) \| (.*) \|$", text, flags=re.M))
        for field, value in (("year", ref.year), ("DOI", ref.doi), ("venue", ref.venue)):
            if value is None:
                assert "not established" in fields[field] and field.lower() in ref.unestablished.lower(), (key, field)
            else:
                assert str(value) == fields[field], (key, field)
        if ref.authors:
            assert all(a in fields["authors"] for a in ref.authors), key
        else:
            assert "not established" in fields["authors"] and "authors" in ref.unestablished, key


def test_short_forms_and_rendering():
    assert reference("wickramatunge2010").short() == "Wickramatunge & Leephakpreeda (2010)"
    assert reference("[mpam-characterization]").short() == (
        "“Experimental Characterization and Control of Miniaturized Pneumatic Artificial Muscle” (n.d.)")
    assert render("Wickramatunge & Leephakpreeda (2010) [wickramatunge2010], eq. (1)") == (
        "Wickramatunge & Leephakpreeda (2010), eq. (1)")
    assert render("[wickramatunge2010]: Table 1") == "Wickramatunge & Leephakpreeda (2010): Table 1"
    assert [r.key for r in cited(MUSCLES["mpam97"].citation)] == ["mpam-characterization"]
    assert render("length [mm], row [n-1]") == "length [mm], row [n-1]"  # not keys
    with pytest.raises(InputError, match="unknown citation key 'wickramatunge2011'. Did you mean wickramatunge2010"):
        reference("wickramatunge2011")

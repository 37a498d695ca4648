"""The law registry is the only vocabulary of force laws (issue 32).

A law's name (or an old alias) written as a string literal outside its own law file, the registry,
the bundled data sets and the sites listed below is a second vocabulary: a hand list that a new law
would have to join. Consumers iterate :data:`mckibben.models.laws.LAWS` or ask a law for a
capability (:class:`mckibben.models.laws.Law`). Docstrings are prose, not a vocabulary, and are not
read; f-strings and messages that merely mention a law inside a longer text are not exact literals.

Also here: a muscle file or a fit that lacks the outer diameter says which law needs it.
"""

from __future__ import annotations

import ast
import functools
from pathlib import Path

import numpy as np
import pytest

import mckibben
from mckibben.data import read_muscle
from mckibben.datasets.isometric import BUNDLED_ISOMETRIC
from mckibben.errors import InputError
from mckibben.models import laws

SRC = Path(mckibben.__file__).parent
#: Where a law's name belongs: its own file, the registry, published data sets.
HOME = ("models/laws/", "datasets/")

#: (file, enclosing function or "<module>", literal) -> why that literal is not a hand list.
ALLOWED = {
    # defaults: one law chosen where the caller names none
    ("models/static.py", "<module>", "braid-map"): "DEFAULT_LAW: a catalogue muscle's own law, the one default",
    ("models/physical.py", "length_under_load", "chou-hannaford"): "default of a BraidGeometry's law",
    ("fit/isometric.py", "fit_isometric", "spring"): "default model of the public fit_isometric",
    ("cli/predict.py", "force_cmd", "chou-hannaford"): "default law of `predict force` on a catalogue geometry",
    # deprecated named functions and aliases, kept readable
    ("models/static.py", "force_mpam", "mpam"): "deprecated force_mpam labels its result with its old name",
    ("models/static.py", "length_mpam", "mpam"): "length_mpam (the braid map's closed form) labels its result",
    ("plant/params.py", "<module>", "tondu-lopez"): "`calibrated`, the plant's default: Tondu-Lopez with the "
                                                    "plant's calibrated columns (not an old name: no deprecation)",
    # data, not vocabulary
    ("cli/params.py", "show_cmd", "spring"): "`params list`: the kind of the published spring sets",
    ("models/mpam.py", "force_from_length", "braid-map"): "the braid map's kernel called by name for its messages",
    # old alias used inside (left for their owners; reported, not a second list)
    ("tool/mujoco_model.py", "simulate_tracking_mujoco", "empirical"): "old alias of braid-map, the tool's catalogue law",
}


def _names() -> set:
    return set(laws.LAWS) | set(laws.ALIASES)


@functools.lru_cache
def law_literals(root: Path = SRC) -> list[tuple[str, str, str, int]]:
    """Every exact law-name string literal under ``root`` outside the law files and data: (file, scope, literal, line)."""
    names, hits = _names(), []
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root).as_posix()
        if rel.startswith(HOME):
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        docs = {id(n.body[0].value) for n in ast.walk(tree)
                if isinstance(n, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and n.body
                and isinstance(n.body[0], ast.Expr) and isinstance(n.body[0].value, ast.Constant)}

        def visit(node, scope):
            for child in ast.iter_child_nodes(node):
                if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                    visit(child, child.name if scope == "<module>" else f"{scope}.{child.name}")
                    continue
                if (isinstance(child, ast.Constant) and isinstance(child.value, str) and child.value in names
                        and id(child) not in docs):
                    hits.append((rel, scope, child.value, child.lineno))
                visit(child, scope)

        visit(tree, "<module>")
    return hits


def test_no_law_name_is_written_outside_its_file_the_registry_and_the_allowed_sites():
    stray = [f"src/mckibben/{f}:{line}: {lit!r} in {scope}" for f, scope, lit, line in law_literals()
             if (f, scope, lit) not in ALLOWED]
    assert not stray, ("a law named by hand outside its file (iterate mckibben.models.laws.LAWS or ask the Law "
                       "for a capability; an alias or default goes in ALLOWED with its reason):\n" + "\n".join(stray))


def test_the_allow_list_holds_only_sites_that_exist():
    # a stale entry would let a hand list come back at that site unseen
    found = {(f, scope, lit) for f, scope, lit, _ in law_literals()}
    assert set(ALLOWED) <= found, sorted(set(ALLOWED) - found)


def test_the_scan_finds_a_hand_list(tmp_path):
    # the test can fail: a consumer that branches on a law's name is caught
    fake = tmp_path / "mckibben"
    (fake / "fit").mkdir(parents=True)
    (fake / "fit" / "newcode.py").write_text('"""doc naming spring"""\n\ndef f(model):\n'
                                             '    return model == "spring" or f"the {model} law"\n')
    assert [(f, s, lit) for f, s, lit, _ in law_literals(fake)] == [("fit/newcode.py", "f", "spring")]


# --- the outer diameter: which law needs it ---------------------------------------------------------

COMMERCIAL = BUNDLED_ISOMETRIC / "commercial10"


def test_a_muscle_file_of_a_fitted_law_without_its_outer_diameter_names_the_law(cli, tmp_path):
    saved = tmp_path / "fit.toml"
    r = cli("fit", str(COMMERCIAL / "isometric.csv"), "--muscle-file", str(COMMERCIAL / "muscle.toml"),
            "--model", "spring", "--save", str(saved))
    assert r.code == 0, r.err
    stripped = tmp_path / "no_od.toml"
    stripped.write_text("".join(ln for ln in saved.read_text().splitlines(keepends=True)
                                if not ln.startswith("outer_diameter")))
    with pytest.raises(InputError, match=r"no_od\.toml: key outer_diameter_<unit> missing; its force law spring "):
        read_muscle(stripped)
    r = cli("predict", "force", "--muscle-file", str(stripped), "--pressure", "0.3MPa", "--length", "290mm")
    assert r.code == 2 and "Traceback" not in r.err
    assert r.err.count("\n") == 1 and "outer_diameter" in r.err and "force law spring" in r.err, r.err


@pytest.mark.parametrize("name", [n for n, law in laws.LAWS.items() if "outer_diameter" in law.needs])
def test_fitting_a_law_that_needs_the_outer_diameter_to_a_file_without_it_names_the_law(cli, tmp_path, name):
    m = tmp_path / "m.toml"
    m.write_text('id = "x"\nnominal_length_mm = 300\n')
    r = cli("fit", str(COMMERCIAL / "isometric.csv"), "--model", name, "--muscle-file", str(m))
    assert r.code == 2 and r.err.strip() == (f"error: {m}: key outer_diameter_<unit> missing; {name} needs it"
                                             " (e.g. outer_diameter_mm = ...)"), r.err


def test_a_muscle_file_without_a_law_keeps_the_plain_message(tmp_path):
    f = tmp_path / "m.toml"
    f.write_text('id = "m"\nnominal_length_mm = 300\n')
    with pytest.raises(InputError, match=r"m\.toml: key outer_diameter_<unit> missing \(e\.g\."):
        read_muscle(f)


@pytest.mark.parametrize("model", ["spring", "relative-strain"])
def test_saving_a_law_fitted_without_a_muscle_file_names_the_law_and_writes_nothing(cli, tmp_path, model):
    # the table's rest length stands for the muscle file: no outer diameter, so nothing readable to save
    import pandas as pd

    d = pd.read_csv(COMMERCIAL / "isometric.csv")
    d["rest_length_mm"] = 300
    table = tmp_path / "iso.csv"
    d.to_csv(table, index=False)
    out = tmp_path / "saved.toml"
    r = cli("fit", str(table), "--model", model, "--save", str(out))
    assert r.code == 2 and "Traceback" not in r.err
    assert f"--save: a muscle file of the {model} force law needs the muscle's outer diameter" in r.err, r.err
    assert not out.exists()


# --- the old named functions: second names of registered laws, deprecated ----------------------------

@pytest.mark.parametrize("old, new, law", [
    ("force_chou_hannaford", "force", "chou-hannaford"), ("force_wall_corrected", "force", "wall-corrected"),
    ("force_mpam", "force", "braid-map"), ("length_chou_hannaford", "length", "chou-hannaford"),
    ("length_wall_corrected", "length", "wall-corrected")])
def test_an_old_named_static_function_warns_and_gives_its_law(old, new, law):
    from mckibben.datasets import get_muscle
    from mckibben.models import static

    m = get_muscle("mpam97")
    second = 0.09 if new == "force" else 0.3  # a length [m] for force, a load [N] for length
    with pytest.warns(DeprecationWarning, match=rf"{old} is deprecated; use {new}\(.*'{law}'\)"):
        got = getattr(static, old)(0.5e6, second, m)
    want = getattr(static, new)(0.5e6, second, m, law)
    out = "load" if new == "force" else "length"  # a force result holds the pull as its load
    np.testing.assert_array_equal(getattr(got, out), getattr(want, out))
    assert got.model == ("mpam" if old == "force_mpam" else law)

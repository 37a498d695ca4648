"""CI installs a lock, not whatever is newest: ``.ci/run``, the README and ``requirements/ci.lock`` agree."""

import re
import tomllib
from pathlib import Path

from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

ROOT = Path(__file__).resolve().parents[1]
LOCK = ROOT / "requirements" / "ci.lock"


def _blocks(text):
    return re.findall(r"^```\n(.*?)\n```$", text, re.M | re.S)


def _pins():
    return {canonicalize_name(m[1]): m[2] for m in re.finditer(r"^([A-Za-z0-9._-]+)==(\S+)", LOCK.read_text(), re.M)}


def test_ci_runs_the_readme_test_command_which_installs_the_lock():
    readme = (ROOT / "README.md").read_text()
    command = next(b for b in _blocks(readme) if "python3 -m pytest" in b)
    ci = [ln for ln in (ROOT / ".ci" / "run").read_text().splitlines() if ln and not ln.startswith(("#", "set ", "cd ",
                                                                                                     "export "))]
    assert ci == [command]
    assert "--require-hashes -r requirements/ci.lock && python3 -m pip install -q --no-deps -e . &&" in command


def test_the_lock_names_its_refresh_command_the_readme_documents():
    readme = (ROOT / "README.md").read_text()
    refresh = next(b for b in _blocks(readme) if "uv pip compile" in b)
    header = LOCK.read_text().splitlines()[:2]
    assert header[1].strip("# ") == refresh
    config = tomllib.loads((ROOT / "requirements" / "ci-lock.toml").read_text())["pip"]
    assert config["custom-compile-command"] == refresh and config["extra"] == ["test"]


def test_the_lock_pins_every_dependency_within_pyproject_ranges():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    pins = _pins()
    for spec in project["dependencies"] + project["optional-dependencies"]["test"]:
        req = Requirement(spec)
        name = canonicalize_name(req.name)
        assert name in pins, f"{name} is not in requirements/ci.lock: refresh it (README, Development)"
        assert req.specifier.contains(pins[name]), f"{name}=={pins[name]} is outside {spec!r}: refresh the lock"
    # every pin carries its hashes (pip's --require-hashes refuses the install otherwise)
    assert len(re.findall(r"^\S+==\S+ \\\n +--hash=sha256:[0-9a-f]{64}", LOCK.read_text(), re.M)) == len(pins)


def test_the_compiler_stack_has_an_upper_bound_within_the_tested_lock():
    """numba and llvmlite carry an upper bound (the compile layer is tested on the lock's versions only)."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    pins = _pins()
    for name in ("numba", "llvmlite"):
        spec = next(Requirement(s) for s in project["dependencies"] if canonicalize_name(Requirement(s).name) == name)
        assert any(s.operator in ("<", "<=", "~=", "==") for s in spec.specifier), f"{name} has no upper bound"
        assert spec.specifier.contains(pins[name])

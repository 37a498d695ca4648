"""The documentation site builds without a warning, with every example notebook executed in a fresh
Jupyter kernel (myst-nb) and its figures inline."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted(p.stem for p in (ROOT / "docs" / "notebooks").glob("*.ipynb"))


@pytest.mark.slow
def test_site_builds_without_warnings_and_notebooks_run(tmp_path):
    assert len(NOTEBOOKS) >= 4
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")]),
           "MCKIBBEN_NB_EXECUTION": "force", "MPLBACKEND": ""}
    env.pop("MPLBACKEND")
    r = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html", str(ROOT / "docs"),
                        str(tmp_path / "html"), "-d", str(tmp_path / "doctrees")],
                       capture_output=True, text=True, env=env, timeout=1200, cwd=tmp_path)
    # Sphinx's own warnings ("file:line: WARNING: ..."); the Jupyter kernel logs its transport on
    # stderr too ("[IPKernelApp] WARNING | ..."), which is not about the documentation
    warnings = [line for line in r.stderr.splitlines() if re.search(r"\b(WARNING|ERROR|CRITICAL):", line)]
    assert r.returncode == 0 and not warnings, r.stderr[-4000:]
    for name in NOTEBOOKS:
        page = (tmp_path / "html" / "notebooks" / f"{name}.html").read_text(encoding="utf-8")
        assert re.search(r'<img[^>]+src="[^"]*\.png"', page), f"{name}: no inline figure"
        assert "Traceback" not in page, name
    api = (tmp_path / "html" / "api.html").read_text(encoding="utf-8")
    assert "step_response" in api and "Result" in api

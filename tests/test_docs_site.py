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


def guide_pages() -> list[str]:
    """The pages of the "Guides" toctree of docs/index.md, in its order."""
    index = (ROOT / "docs" / "index.md").read_text(encoding="utf-8")
    block = re.search(r"```\{toctree\}\n(?::[^\n]*\n)*?:caption: Guides\n(.*?)```", index, flags=re.S)
    assert block, "docs/index.md has no toctree captioned Guides"
    return [line.strip() for line in block.group(1).splitlines() if line.strip() and not line.startswith(":")]


def test_the_guides_toctree_is_read():
    guides = guide_pages()
    assert len(guides) >= 8 and "plant" in guides and "api" not in guides and "references" not in guides
    assert all((ROOT / "docs" / f"{g}.md").is_file() for g in guides), guides


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
    # every guide shows at least one figure that this build computed (the plot directive writes
    # its PNGs into the build; none is committed under docs/)
    images = tmp_path / "html" / "_images"
    for name in guide_pages():
        page = (tmp_path / "html" / f"{name}.html").read_text(encoding="utf-8")
        pngs = re.findall(r'<img[^>]+src="(?:\.\./)*_images/([^"/]+\.png)"', page)
        assert pngs, f"guide {name}: no figure"
        assert all((images / png).stat().st_size > 1000 for png in pngs), (name, pngs)
        assert not list((ROOT / "docs").rglob(pngs[0])), f"guide {name}: {pngs[0]} is committed, not built"
        assert "Traceback" not in page, name
    api = (tmp_path / "html" / "api.html").read_text(encoding="utf-8")
    assert "step_response" in api and "Result" in api
    # no built page names the file of our copy of a paper (test_citations.py checks the sources and the commands)
    for page in (tmp_path / "html").rglob("*.html"):
        text = page.read_text(encoding="utf-8", errors="replace")
        assert "000_909f662a44080c85" not in text and "001_9d98bcef9f07dbeb" not in text, page.name
    assert "wickramatunge2010" in (tmp_path / "html" / "references.html").read_text(encoding="utf-8")

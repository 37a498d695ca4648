"""Sphinx configuration of the mckibben documentation site.

Build: ``python -m sphinx -W -b html docs build/html`` (warnings are errors; the tests do it,
tests/test_docs_site.py). The example notebooks are executed in a fresh Jupyter kernel on every
build (myst-nb), so a notebook that no longer runs fails the build.
"""

import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))
os.environ["PYTHONPATH"] = os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep)

import mckibben  # noqa: E402

project = "mckibben"
author = "the mckibben contributors"
copyright = "2026, the mckibben contributors"
release = mckibben.__version__

extensions = [
    "myst_nb",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
]

exclude_patterns = ["_build", "build", "notebooks/make_notebooks.py", "**.ipynb_checkpoints", "jupyter_execute"]
source_suffix = {".md": "myst-nb", ".ipynb": "myst-nb"}
root_doc = "index"

# numpydoc docstrings, read by napoleon
napoleon_numpy_docstring = True
napoleon_google_docstring = False
napoleon_use_rtype = False

autodoc_member_order = "bysource"
autodoc_typehints = "none"
autodoc_default_options: dict = {}
autosummary_generate = False

# the notebooks: executed in a fresh kernel on every build; any error fails the build
nb_execution_mode = os.environ.get("MCKIBBEN_NB_EXECUTION", "force")
nb_execution_timeout = 600
nb_execution_raise_on_error = True
nb_execution_in_temp = True  # a notebook runs in a temporary folder: it writes nothing into docs/
nb_execution_show_tb = True
nb_merge_streams = True
myst_enable_extensions = ["dollarmath"]
myst_heading_anchors = 3

html_theme = "alabaster"
html_title = f"mckibben {release}"
html_static_path = []

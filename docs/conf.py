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
    "matplotlib.sphinxext.plot_directive",
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

# the guides' figures: a ```{plot}``` block runs its code in this process at every build and
# shows the code above its PNG. Chosen over myst-nb code cells for the guides: one process, so
# mckibben is imported and its kernels loaded once for all guides (a notebook page starts a
# Jupyter kernel of its own), and the shown code is exactly what runs. A block that raises is a
# Sphinx warning, so the build (-W) fails (tests/test_docs_site.py).
plot_include_source = True
plot_pre_code = ""  # the shown code is complete: its imports are the user's
plot_formats = [("png", 100)]
plot_html_show_formats = False
plot_html_show_source_link = False
plot_rcparams = {"figure.max_open_warning": 0}
myst_heading_anchors = 3

html_theme = "alabaster"
html_title = f"mckibben {release}"
html_static_path = []

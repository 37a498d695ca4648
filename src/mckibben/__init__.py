"""mckibben: braided pneumatic artificial muscles from the bench to the tool.

characterize -> fit -> predict -> simulate -> control -> deploy -> steer a three-muscle tool.

SI units inside every function (Pa, m, N, s, rad); units appear only at the edges (CLI
arguments, file columns named ``quantity_unit``, plots and reports).
"""

from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

from mckibben._numba_cache import drop_stale
from mckibben.errors import InputError

drop_stale(Path(__file__).parent)

try:
    __version__ = version("mckibben")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+unknown"

__all__ = ["InputError", "__version__"]

"""mckibben: braided pneumatic artificial muscles from the bench to the tool.

characterize -> fit -> predict -> simulate -> control -> deploy -> steer a three-muscle tool.

SI units inside every function (Pa, m, N, s, rad): the experiments take numbers in SI (text with
a unit is refused with the number to pass) and the command line parses units
(:func:`mckibben.units.parse_quantity`). The main entry points are here::

    import mckibben as mk
    muscle = mk.get_muscle("mpam97")                          # a published set (Table I, II)
    mk.predict_length(muscle, 0.8e6, 0.6).length              # eq. 2 and 3 -> 0.0781 m
    step = mk.step_response("smc", target=0.55e6, law="paper", beta=150)   # Pa
    step.metrics, step.to_pandas(), step.plot()               # result objects
    mk.track_tip(mk.tool.parse_path("circle:radius=5mm,period=2s")).plot()  # the three-muscle tool

Subpackages: :mod:`~mckibben.models`, :mod:`~mckibben.data`, :mod:`~mckibben.datasets`,
:mod:`~mckibben.fit`, :mod:`~mckibben.plant`, :mod:`~mckibben.control`, :mod:`~mckibben.rig`,
:mod:`~mckibben.tool`, :mod:`~mckibben.experiments`, :mod:`~mckibben.sweep`, :mod:`~mckibben.report`. They are imported on
first use, so ``import mckibben`` stays quick.
"""

from importlib import import_module as _import_module
from importlib.metadata import PackageNotFoundError as _PackageNotFoundError
from importlib.metadata import version as _version

from mckibben.errors import InputError

try:
    __version__ = _version("mckibben")
except _PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+unknown"

#: Top-level name -> (module, attribute): imported on first use (PEP 562).
_ENTRY_POINTS = {
    "quantity": ("mckibben.units", "quantity"),
    "get_muscle": ("mckibben.datasets", "get_muscle"),
    "list_muscles": ("mckibben.datasets", "list_muscles"),
    "read_table": ("mckibben.data", "read_table"),
    "read_muscle": ("mckibben.data", "read_muscle"),
    "predict_length": ("mckibben.models", "predict_length"),
    "pressure_for_length": ("mckibben.models", "pressure_for_length"),
    "force_from_length": ("mckibben.models", "force_from_length"),
    "open_loop": ("mckibben.experiments", "open_loop"),
    "identify_plant": ("mckibben.control", "identify_plant"),
    "step_response": ("mckibben.experiments", "step_response"),
    "track_pressure": ("mckibben.experiments", "track_pressure"),
    "fig13": ("mckibben.experiments", "fig13"),
    "robustness": ("mckibben.experiments", "robustness"),
    "make_tool": ("mckibben.tool", "make_tool"),
    "track_tip": ("mckibben.experiments", "track_tip"),
    "Device": ("mckibben.rig", "Device"),
    "load_sweep": ("mckibben.sweep", "load_sweep"),
    "run_sweep": ("mckibben.sweep", "run_sweep"),
    "reproduce": ("mckibben.report", "reproduce"),
}
_SUBPACKAGES = ("control", "data", "datasets", "experiments", "fit", "models", "plant", "report", "rig", "sweep", "tool",
                "units", "results")


def __getattr__(name: str):

    if name in _ENTRY_POINTS:
        module, attr = _ENTRY_POINTS[name]
        value = getattr(_import_module(module), attr)
    elif name in _SUBPACKAGES:
        value = _import_module(f"mckibben.{name}")
    else:
        raise AttributeError(f"module 'mckibben' has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_ENTRY_POINTS) | set(_SUBPACKAGES))


__all__ = ["InputError", "__version__", *_ENTRY_POINTS, *_SUBPACKAGES]

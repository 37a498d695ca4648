"""Every pressure controller of the core, one file each, discovered: the controllers' registry source.

A controller is a file here, ``laws/<name>.py`` (its law, the bit-exact Python mirror of the C;
its gains and defaults; its documented designs, tuning grid and candidates; its description in
results), exporting one :class:`ControllerSpec` named ``CONTROLLER`` of real function objects, and
its C face ``firmware/core/law_<name>.h`` (the sliding mode's and the PID's C laws are the core's
own, in ``controller.c``). Every module of this package not starting with ``_`` that defines
``CONTROLLER`` is an entry; :data:`CONTROLLERS` holds them in mode order, and
:mod:`mckibben.control.registry` builds every table the core, the rig, the sweeps and the command
line read from them. ``tests/test_controller_conformance.py`` runs every entry.

Modes and gain ids are numbered in one table, :mod:`mckibben.control.laws._table`; the C list of
extension laws and their ids, ``firmware/core/laws.h``, is generated from it by
``python -m mckibben.control.laws`` (:func:`c_header`; why generated for these and checked for the
core's own ids: the table's docstring).

**Adding a controller**: ``laws/<name>.py`` and ``firmware/core/law_<name>.h`` (with its test),
one row of the table, and ``python -m mckibben.control.laws`` to regenerate ``laws.h``.
"""

from __future__ import annotations

import importlib
import pkgutil

from mckibben.control.laws._spec import ControllerSpec, GainSpec, Params, with_supervisor_model
from mckibben.control.laws._table import GAIN_IDS, MODES, TABLE

__all__ = ["CONTROLLERS", "ControllerSpec", "GAIN_IDS", "GainSpec", "MODES", "Params", "TABLE", "c_header",
           "with_supervisor_model"]

#: The core's modes that run no law, and the supervisor's row: table rows that are no file here.
NOT_FILES = ("off", "open_loop", "supervisor")


def _discover() -> dict[str, ControllerSpec]:
    """The entries of this package's modules, by name, in mode order; each checked against the table."""
    found = []
    for info in sorted(pkgutil.iter_modules(__path__), key=lambda i: i.name):
        if info.name.startswith("_"):
            continue
        spec = getattr(importlib.import_module(f"{__name__}.{info.name}"), "CONTROLLER", None)
        if not isinstance(spec, ControllerSpec):
            continue
        if spec.name != info.name:
            raise ImportError(f"{__name__}.{info.name}: its CONTROLLER is named {spec.name!r}, not its file's name")
        if spec.name not in TABLE or TABLE[spec.name][0] is None:
            raise ImportError(f"{__name__}.{info.name}: controller {spec.name!r} has no mode in the table "
                              "(mckibben/control/laws/_table.py)")
        listed = tuple(TABLE[spec.name][1])
        if tuple(g.name for g in spec.gains) != listed:
            raise ImportError(f"{__name__}.{info.name}: gains {[g.name for g in spec.gains]} differ from the "
                              f"table's row {list(listed)}")
        found.append(spec)
    missing = set(TABLE) - set(NOT_FILES) - {s.name for s in found}
    if missing:
        raise ImportError(f"{__name__}: the table lists {sorted(missing)} but no file here defines them")
    return {s.name: s for s in sorted(found, key=lambda s: s.mode)}


#: Every controller, by name, in mode order.
CONTROLLERS: dict[str, ControllerSpec] = _discover()


def c_header() -> str:
    """The text of ``firmware/core/laws.h``: the extension laws' ids and list, from the table.

    Returns
    -------
    str
        The header, ending in a newline. [-]
    """
    ext = [c for c in CONTROLLERS.values() if c.extension]
    lines = [
        "/* GENERATED from src/mckibben/control/laws/_table.py by `python -m mckibben.control.laws`:",
        " * do not edit; tests/test_controller_conformance.py holds the two equal.",
        " *",
        " * The registry of the core's extension laws (docs/controller.md, \"Adding a controller\").",
        " * Sliding mode (mode 1) and PID (mode 2) are the core's own laws (controller.c). A further law",
        " * lives in one header of its own, core/law_<name>.h, which defines, for NAME/name:",
        " *   MCK_<NAME>_GAINS(G)             G(id, default, lo, hi) per gain, in id order (values in",
        " *                                   the fixed-point scale of SET_GAIN),",
        " *   mck_<name>_state_t, mck_<name>_coef_t   its state (reset by SET_MODE) and coefficients,",
        " *   mck_<name>_reset(state), mck_<name>_derive(coef, gains, ts_us),",
        " *   mck_<name>_law(state, coef, p, pref, e, &surface) -> u [counts Q8].",
        " * Its ids come from here: MCK_MODE_<NAME> (SET_MODE), MCK_<NAME>_N_GAINS and",
        " * MCK_GAIN_<NAME>_<GAIN> (SET_GAIN, contiguous after the previous law's). */",
        "#ifndef MCK_LAWS_H",
        "#define MCK_LAWS_H",
        "",
    ]
    for c in ext:
        lines.append(f"#define MCK_MODE_{c.c_name} {c.mode}u")
        lines.append(f"#define MCK_{c.c_name}_N_GAINS {len(c.gains)}")
        lines += [f"#define {g.c_name} {g.id}" for g in c.gains]
        lines.append("")
    lines.append("#define MCK_EXT_LAWS(X)" + "".join(f" X({c.c_name}, {c.name})" for c in ext))
    lines += ["", "#endif", ""]
    lines += [f'#include "law_{c.name}.h"' for c in ext]
    return "\n".join(lines) + "\n"

"""Controller designs on disk: :func:`save_design` and :func:`load_design` (``--save-design``, ``rig gains --from``).

A design file is JSON with ``format`` :data:`DESIGN_FORMAT`: the :class:`~mckibben.control.core_params.CoreParams`
of a design, in SI, with a note; reading one checks every field and names the file.
"""

from __future__ import annotations



from mckibben.errors import InputError
from mckibben.atomic import atomic_file, check_output_file
from mckibben.atomic import check_input_file
import dataclasses
import json
from pathlib import Path
from mckibben.control.core_params import GAINS, CoreParams, gain_values, pack_params


# --- controller designs on disk (``--save-design``, ``rig gains --from``) ---------------------

#: The ``format`` key of a design file.
DESIGN_FORMAT = "mckibben.controller-design"


def save_design(params: CoreParams, path, note: str = "") -> None:
    """Write a controller design as JSON (atomically): every :class:`CoreParams` field, SI.

    The file is what ``mckibben control step --save-design`` writes and ``mckibben rig gains
    --from`` sends to the device: the physical values and, for checking, the SET_GAIN integers
    they become (``gains``).

    Parameters
    ----------
    params : CoreParams
        The design; its values must fit the firmware's ranges (checked). [SI]
    path : str or os.PathLike
        A ``.json`` file. [-]
    note : str, optional
        Free text kept in the file (what it was designed on). [-]
    """


    check_output_file(path, "save_design", (".json",))
    values = gain_values(params)
    doc = {"format": DESIGN_FORMAT, "version": 1, "note": note,
           "params": {f.name: getattr(params, f.name) for f in dataclasses.fields(params)},
           "gains": {g.name: int(values[g.id]) for g in GAINS}}
    with atomic_file(path, "save_design") as tmp:
        tmp.write_text(json.dumps(doc, indent=2) + "\n")


def load_design(path, name: str = "path") -> CoreParams:
    """Read a design written by :func:`save_design`.

    Parameters
    ----------
    path : str or os.PathLike
        The JSON file. [-]
    name : str, default "path"
        The caller's argument that gave ``path``, for the messages. [-]

    Returns
    -------
    CoreParams
        The design, range-checked against the firmware's gains.

    Raises
    ------
    InputError
        The file is missing, not JSON, not a design, or names an unknown or out-of-range value.
    """


    p = Path(path)
    if not p.exists():
        raise InputError(f"{name}: {str(p)!r} does not exist")
    check_input_file(p, name, "controller design")  # a folder or a FIFO (which would block the read)
    try:
        doc = json.loads(p.read_text())
    except FileNotFoundError:
        raise InputError(f"{name}: {str(p)!r} does not exist") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{name}: cannot read {str(p)!r} ({exc})") from None
    except ValueError as exc:
        raise InputError(f"{name}: {str(p)!r} is not JSON ({exc.args[0].split(':')[0]})") from None
    if not isinstance(doc, dict) or doc.get("format") != DESIGN_FORMAT or not isinstance(doc.get("params"), dict):
        raise InputError(f"{name}: {str(p)!r} is not a controller design (no format {DESIGN_FORMAT!r})")
    names = {f.name for f in dataclasses.fields(CoreParams)}
    unknown = sorted(set(doc["params"]) - names)
    if unknown:
        raise InputError(f"{name}: {str(p)!r}: unknown parameter {unknown[0]!r}")
    for k, v in doc["params"].items():
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise InputError(f"{name}: {str(p)!r}: parameter {k!r} is not a number")
    params = CoreParams(**doc["params"])
    try:
        pack_params(params)
    except InputError as exc:
        raise InputError(f"{name}: {str(p)!r}: {exc}") from None
    return params

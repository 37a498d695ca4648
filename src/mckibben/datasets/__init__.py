"""Bundled parameter sets (published, with citations) and example campaigns (marked synthetic)."""

from __future__ import annotations

from mckibben import _lazy

from mckibben.datasets.published import LAW_SETS, MUSCLES, law_set_muscle, SPRING_MODEL_STRUCTURE, SPRING_MUSCLE_SIZES, parameter_sets
from mckibben.datasets.references import REFERENCES, Reference, reference
from mckibben.errors import ArgumentTypeError, unknown_name
from mckibben.models.mpam import MiniatureMuscle


def list_muscles() -> list[str]:
    """Names of the published miniature-muscle parameter sets."""
    return list(MUSCLES)


def get_muscle(name: str) -> MiniatureMuscle:
    """A published miniature-muscle parameter set by name (``mpam97``, ``mpam117``, ``mpam143``).

    Parameters
    ----------
    name : str
        The set's name, case-insensitive. [-]

    Raises
    ------
    InputError
        For an unknown name, listing the closest matches and all valid names.
    ArgumentTypeError
        For a name that is not text (``None``, a number).
    """
    if not isinstance(name, str):
        raise ArgumentTypeError(f"name = {name!r}: not a muscle name ({type(name).__name__}); give one of "
                                f"{', '.join(MUSCLES)}")
    key = name.strip().lower()
    if key not in MUSCLES:
        raise unknown_name("muscle", name, MUSCLES)
    return MUSCLES[key]


__all__ = ["LAW_SETS", "MUSCLES", "REFERENCES", "Reference", "SPRING_MODEL_STRUCTURE", "SPRING_MUSCLE_SIZES", "get_muscle", "law_set_muscle", "list_muscles",
           "parameter_sets", "reference"]


__getattr__, __dir__ = _lazy.package(__name__, None)

"""Published parameter sets, each reproducing a table of its paper.

Miniature muscles of [mpam-characterization] (OD ≈ 1.2 mm):

=========  ======  ======  ====  =======  ==========================  ===================
name       L0      Ls      k1    k2       cos θ(P) cubics (P in MPa)  blocked force
=========  ======  ======  ====  =======  ==========================  ===================
mpam97     97 mm   112 mm  0.92  0.77 mm  0.6 N (Table II), 2.1 N     4.2 N at 0.8 MPa
                                          (eq. 3)
mpam117    117 mm  145 mm  0.88  1.09 mm  0.6 N, 2.1 N (Table II)     3.5 N at 0.8 MPa
mpam143    143 mm  175 mm  0.86  4.19 mm  0.6 N, 2.1 N (Table II)     3.0 N at 0.8 MPa
=========  ======  ======  ====  =======  ==========================  ===================

Table I gives Ls, k1 and k2; k2 is read as millimetres (its size beside lengths of ~100 mm and
the worked example 97 mm, 0.6 N, 0.8 MPa → 78.1 mm both support it). The cubics are
characterized on 0–0.8 MPa (the paper's safe operating limit). Construction (§II): silicone tube
ID 0.5 mm / OD 0.9 mm, nylon strand ~0.1 mm, braid angle ~20°, outer diameter ~1.2 mm.

The spring model of Wickramatunge & Leephakpreeda (2010) [wickramatunge2010] (Festo muscles PAM-A, -B, -C) is shipped as its
structure and muscle sizes only: its coefficient tables are unreadable in our copy, and we ship
no invented numbers; ``mckibben fit`` fits them from data.

The length-effect model of Hunt, Graber-Tilton and Quinn (2017) for Festo DMSP-10 muscles,
P = c0 + c1·tan(c2·(ε/(c4·F + ε_max) + c3)) + c5·F + c6·S (law ``hunt-quinn``):

==================  ========  ======  ======  ======  ===========  ========  =======  ======  =======
name                c0        c1      c2      c3      c4           c5        c6       L0      ε_max
==================  ========  ======  ======  ======  ===========  ========  =======  ======  =======
festo-dmsp10-189    254.3     192     2.0265  −0.461  −0.331e-3    1.23      15.6     189 mm  0.1667
                    kPa       kPa                     1/N          kPa/N     kPa
==================  ========  ======  ======  ======  ===========  ========  =======  ======  =======

The constants are those of the authors' lab code (the paper's text was not available to check them
against); L0 = 189 mm and the free length 157.5 mm at 620 kPa (ε_max = 0.1667) are its worked
example's muscle.
"""

from __future__ import annotations

import math

import numpy as np

from mckibben.datasets.references import cited, render
from mckibben.errors import ArgumentTypeError, unknown_name
from mckibben.models import laws
from mckibben.models.law_statics import LawMuscle
from mckibben.models.muscle import FILE_BRAID_ANGLE
from mckibben.models.laws.hunt_quinn import HuntQuinn
from mckibben.models.mpam import BraidAngleMap, MiniatureGeometry, MiniatureMuscle

MM = 1e-3
#: The bibliography keys (:mod:`mckibben.datasets.references`) of the two papers.
PAPER_MPAM = "[mpam-characterization]"
PAPER_SPRING = "[wickramatunge2010]"

#: Construction shared by the three miniature muscles (§II).
MPAM_GEOMETRY = MiniatureGeometry(
    outer_diameter=1.2e-3,
    tube_inner_diameter=0.5e-3,
    tube_outer_diameter=0.9e-3,
    strand_diameter=0.1e-3,
    braid_angle=float(np.deg2rad(20.0)),
)

_PRESSURE_RANGE = (0.0, 0.8e6)


def _mpam(name, l0_mm, ls_mm, k1, k2_mm, rows, force_n, cubic_source):
    return MiniatureMuscle(
        name=name,
        nominal_length=l0_mm * MM,
        strand_length=ls_mm * MM,
        k1=k1,
        k2=k2_mm * MM,
        braid_map=BraidAngleMap(
            loads=tuple(load for load, _ in rows),
            coefficients=tuple(tuple(c) for _, c in rows),
            pressure_range=_PRESSURE_RANGE,
            citation=f"{PAPER_MPAM}, {cubic_source}",
        ),
        blocked_force=((0.8e6, force_n),),
        geometry=MPAM_GEOMETRY,
        citation=(
            f"{PAPER_MPAM}: Table I (Ls, k1, k2; eq. 2), {cubic_source} (cos θ cubics, P in MPa),"
            f" §III.A (blocked force {force_n} N at 0.8 MPa), §II (geometry)"
        ),
    )


#: The miniature muscles of [mpam-characterization], by name.
MUSCLES: dict[str, MiniatureMuscle] = {
    "mpam97": _mpam(
        "mpam97", 97, 112, 0.92, 0.77,
        [(0.6, (-0.6, 0.9, -0.71, 1.05)), (2.1, (-0.1, 0.1, -0.06, 0.94))],
        4.2, "Table II (0.6 N) and eq. 3 (2.1 N)",
    ),
    "mpam117": _mpam(
        "mpam117", 117, 145, 0.88, 1.09,
        [(0.6, (0.2, -0.2, -0.22, 0.98)), (2.1, (-0.2, 0.3, -0.16, 0.94))],
        3.5, "Table II",
    ),
    "mpam143": _mpam(
        "mpam143", 143, 175, 0.86, 4.19,
        [(0.6, (0.8, -1.2, 0.34, 0.87)), (2.1, (-0.4, 0.5, -0.31, 0.96))],
        3.0, "Table II",
    ),
}

#: Festo muscles of Wickramatunge & Leephakpreeda (2010) [wickramatunge2010]: nominal diameter and length (read as cm in the
#: extraction; PAM-A's diameter digit was lost and is read as 20 mm). Coefficients: none shipped.
SPRING_MUSCLE_SIZES: dict[str, dict[str, float]] = {
    "pam-a": {"nominal_diameter_m": 20e-3, "nominal_length_m": 0.30},
    "pam-b": {"nominal_diameter_m": 10e-3, "nominal_length_m": 0.30},
    "pam-c": {"nominal_diameter_m": 10e-3, "nominal_length_m": 0.075},
}

#: The spring model's published structure (Wickramatunge & Leephakpreeda (2010) [wickramatunge2010], eq. 1–2, Tables 1–2).
SPRING_MODEL_STRUCTURE = {
    "force": "F = K(P, Ls)·Ls, Ls = L − Lu(P)  (eq. 1)",
    "unstretched_length": "Lu = h2·P² + h1·P + h0  (Table 1)",
    "stiffness": "K = c3·P + c2·P·Ls + c1·Ls + c0  (eq. 2, read as)",
    "coefficient_sets": "per direction (elongation dL/dt > 0, contraction dL/dt < 0) and pressure"
    " range (low ≤ 2.5 bar < high ≤ 5 bar)",
    "split_pressure_Pa": 2.5e5,
    "coefficients": "unreadable in our copy: fit them with `mckibben fit --model spring`",
    "citation": f"{PAPER_SPRING}, eq. (1)–(2), Tables 1–2, §5",
}

#: Hunt, Graber-Tilton and Quinn (2017): published constants of their Festo DMSP-10 model, by name
#: (law ``hunt-quinn``; see the module's table).
HUNT_QUINN_SETS: dict[str, HuntQuinn] = {
    "festo-dmsp10-189": HuntQuinn(
        c0=254.3, c1=192.0, c2=2.0265, c3=-0.461, c4=-0.331e-3, c5=1.23, c6=15.6,
        max_strain=(189.0 - 157.5) / 189.0, rest_length=189.0 * MM, pressure_range=(0.0, 620e3),
        citation="[hunt2017]: c0..c6 as in the authors' lab code (BPA pressure model); L0 189 mm, free length "
                 "157.5 mm at 620 kPa (its worked example)",
    ),
}

#: Published parameter sets of registered force laws, by set name: (law name, parameter object).
#: ``mckibben params list`` and ``params show`` read this.
LAW_SETS: dict[str, tuple[str, object]] = {name: ("hunt-quinn", m) for name, m in HUNT_QUINN_SETS.items()}


def law_set_muscle(name: str) -> LawMuscle:
    """A published parameter set of a registered law (:data:`LAW_SETS`) as a muscle.

    Its force, length under a load and pressure for a length are the law's with the set's
    constants (:func:`mckibben.models.force`, :func:`~mckibben.models.length`,
    :func:`~mckibben.models.pressure`; ``predict force|length|pressure --muscle NAME`` or ``--model
    LAW``). The rest length is the set's; the pressures are those the set was identified on; the
    length's end stops are those of an ideal braid of strand ``L0/cos θ0`` with the construction
    angle :data:`~mckibben.models.muscle.FILE_BRAID_ANGLE` (a published set gives no braid, as a
    muscle file without one); the outer diameter is not given by the sources (NaN).

    Parameters
    ----------
    name : str
        A key of :data:`LAW_SETS`, case-insensitive. [-]

    Returns
    -------
    LawMuscle
        Named after the set, with its law and the set's citation.

    Raises
    ------
    InputError
        An unknown name, with the closest sets.
    """
    if not isinstance(name, str):
        raise ArgumentTypeError(f"name = {name!r}: not a parameter set's name ({type(name).__name__}); give one of "
                                f"{', '.join(LAW_SETS)}")
    key = name.strip().lower()
    if key not in LAW_SETS:
        raise unknown_name("parameter set", name, LAW_SETS)
    law_name, params = LAW_SETS[key]
    law = laws.LAWS[law_name]
    l0 = float(params.rest_length)
    b = l0 / math.cos(FILE_BRAID_ANGLE)
    return LawMuscle(key, l0, law_name, law.theta_of(params, "elongation"), b, tuple(params.pressure_range),
                     (b / math.sqrt(3.0), b), math.nan, citation=params.citation)


def parameter_sets() -> list[dict]:
    """Every published parameter set with what it is and whom it cites.

    Returns
    -------
    list of dict
        One per set, in the order ``mckibben params list`` prints them: ``name``, ``kind``,
        ``citation`` (the cited work's record, :meth:`~mckibben.datasets.references.Reference.to_dict`:
        key, short author–year form, title, authors, venue, year, DOI) and ``source`` (where in it,
        with the work named by its short form).
    """
    sets = [(name, "miniature muscle", m.citation) for name, m in MUSCLES.items()]
    sets += [(f"spring-{name}", "spring model (structure and size only)", SPRING_MODEL_STRUCTURE["citation"])
             for name in SPRING_MUSCLE_SIZES]
    sets += [(name, f"{law} law", m.citation) for name, (law, m) in LAW_SETS.items()]
    return [{"name": name, "kind": kind, "citation": cited(text)[0].to_dict(), "source": render(text)}
            for name, kind, text in sets]

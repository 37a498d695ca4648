"""The three-muscle endoscope: its geometry and the load model its muscles share.

The tool of [mpam-characterization] §V (Fig. 14): a stack of spacer discs 12 mm across, each
with three peripheral holes 2.2 mm across, 120° apart, and a 4 mm central channel for a
fibre-optic camera or an instrument. One miniature muscle runs through each ring of holes; the
three are pressurized independently and bend the stack.

What the paper gives and what we assume
---------------------------------------
Given (§V): disc diameter 12 mm, hole diameter 2.2 mm, holes 120° apart, central channel 4 mm,
muscles of the characterized lengths (97, 117, 143 mm, §III). Not given, so chosen here and
settable: the pitch radius of the holes (default 4.0 mm, the middle of the ring between channel
and rim, which leaves the same 0.9 mm ligament inside and outside each hole; any value in
3.1–4.9 mm keeps the holes inside the disc and clear of the channel), the number of discs
(default 13, i.e. discs about 10 mm apart on a 117 mm muscle: "closely spaced"), and the whole
load model (:class:`StackLoad`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from mckibben.errors import InputError, check_instance, check_int, check_real
from mckibben.models.law_statics import LawMuscle
from mckibben.models.mpam import MiniatureMuscle
from mckibben.limits import PLAUSIBLE_MAX, check_p_max

#: Largest backbone bending stiffness accepted: a steel rod as wide as the paper's 12 mm disc is
#: about 2e2 N·m²; far past it the statics' Jacobian is singular in floating point. [N·m²]
MAX_BENDING_STIFFNESS = 1e4

#: The muscle of the paper's tool (§V) when none is named. [-]
DEFAULT_MUSCLE = "mpam117"

PAPER = "[mpam-characterization]"

#: Angular positions of muscles 1, 2, 3, counter-clockwise from the base x axis. [rad]
#: Closest spacing of two discs along the tool (a disc is about this thick, §V). [m]
MIN_DISC_GAP = 1e-3
MUSCLE_ANGLES = (0.0, 2.0 * math.pi / 3.0, 4.0 * math.pi / 3.0)


def default_pitch_radius(disc_diameter: float, hole_diameter: float, channel_diameter: float) -> float:
    """Pitch radius of the muscle holes: the middle of the ring between channel and rim.

    Parameters
    ----------
    disc_diameter : float
        Outer diameter of a spacer disc. [m]
    hole_diameter : float
        Diameter of a peripheral hole. [m]
    channel_diameter : float
        Diameter of the central channel. [m]

    Returns
    -------
    float
        The pitch radius that leaves equal ligaments between a hole and the channel and between
        the hole and the rim, ``(disc/2 + channel/2)/2``. [m]

    Examples
    --------
    >>> round(default_pitch_radius(12e-3, 2.2e-3, 4e-3) * 1e3, 3)
    4.0
    """
    del hole_diameter  # the ligaments are equal whatever the hole size
    return 0.25 * (disc_diameter + channel_diameter)


def pitch_radius_limits(disc_diameter: float, hole_diameter: float, channel_diameter: float) -> tuple[float, float]:
    """The pitch radii that keep a hole inside the disc and clear of the central channel.

    Parameters
    ----------
    disc_diameter : float
        Outer diameter of a spacer disc. [m]
    hole_diameter : float
        Diameter of a peripheral hole. [m]
    channel_diameter : float
        Diameter of the central channel. [m]

    Returns
    -------
    tuple of float
        ``(channel/2 + hole/2, disc/2 − hole/2)``: 3.1 and 4.9 mm for the paper's disc. [m]
    """
    return 0.5 * (channel_diameter + hole_diameter), 0.5 * (disc_diameter - hole_diameter)


@dataclass(frozen=True)
class ToolGeometry:
    """The spacer-disc stack of the endoscope ([mpam-characterization] §V).

    Attributes
    ----------
    disc_diameter : float, default 12 mm
        Outer diameter of a spacer disc (§V). [m]
    hole_diameter : float, default 2.2 mm
        Diameter of the three peripheral holes (§V). [m]
    channel_diameter : float, default 4 mm
        Diameter of the central channel for camera or instrument (§V). [m]
    pitch_radius : float, optional
        Radius of the circle through the hole centres; default
        :func:`default_pitch_radius` (4.0 mm). Must lie in :func:`pitch_radius_limits`. [m]
    n_discs : int or None, default 13
        Number of discs including base and tip disc; the muscles run straight between discs
        (chords). ``None`` is the continuous limit. [-]
    citation : str
        Where the numbers come from.
    """

    disc_diameter: float = 12e-3
    hole_diameter: float = 2.2e-3
    channel_diameter: float = 4e-3
    pitch_radius: float | None = None
    n_discs: int | None = 13
    citation: str = (
        f"{PAPER} §V (12 mm discs, 2.2 mm holes 120° apart, 4 mm channel); pitch radius and disc"
        " count are our choices (docs/tool.md)"
    )

    def __post_init__(self):
        for name in ("disc_diameter", "hole_diameter", "channel_diameter"):
            check_real(getattr(self, name), name, lo=0.0, lo_open=True, hi=1.0, unit="m")
        if self.pitch_radius is not None:
            check_real(self.pitch_radius, "pitch_radius", unit="m")
        if self.n_discs is not None:
            check_int(self.n_discs, "n_discs", lo=2)
        if self.pitch_radius is None:
            object.__setattr__(
                self, "pitch_radius", default_pitch_radius(self.disc_diameter, self.hole_diameter, self.channel_diameter)
            )
        lo, hi = pitch_radius_limits(self.disc_diameter, self.hole_diameter, self.channel_diameter)
        r = self.pitch_radius
        if not (math.isfinite(r) and lo - 1e-12 <= r <= hi + 1e-12):
            raise InputError(
                f"pitch_radius: a pitch radius of {r * 1e3:.3g} mm puts the {self.hole_diameter * 1e3:.3g} mm holes outside the"
                f" {self.disc_diameter * 1e3:.3g} mm disc or into the {self.channel_diameter * 1e3:.3g} mm channel;"
                f" use {lo * 1e3:.3g}..{hi * 1e3:.3g} mm"
            )
        if self.n_discs is not None and (int(self.n_discs) != self.n_discs or self.n_discs < 2):
            raise InputError(f"discs: {self.n_discs!r} must be a whole number of at least 2 (base and tip)")

    @property
    def n_gaps(self) -> int | None:
        """Number of gaps between discs (``n_discs − 1``), ``None`` in the continuous limit. [-]"""
        return None if self.n_discs is None else int(self.n_discs) - 1

    @property
    def hole_positions(self) -> np.ndarray:
        """Hole centres on a disc, one row per muscle, in the disc frame. [m]"""
        a = np.asarray(MUSCLE_ANGLES)
        return self.pitch_radius * np.column_stack([np.cos(a), np.sin(a)])


@dataclass(frozen=True)
class StackLoad:
    """The tension each muscle carries: one load model shared by the three muscles.

    The muscles pull the disc stack against the central tube (the backbone: the camera or
    instrument channel). Equilibrium of the tip disc (our derivation,
    /work/shared/notes/continuum-kinematics.md "Forces"): the backbone's bending moment
    ``Kb·κ`` is the muscles' moment ``r·Σ F_i·ĥ_i`` and the backbone's compression is ``Σ F_i``:

    ``F_i = A/3 + (2/3)·(Kb/r)·(κx·cos θi + κy·sin θi)``,
    ``A = 3·F0 + Ka·(s_ref − s)/s_ref``.

    ``F0`` is the preload per muscle in the straight tool at the reference length (the
    assembled tool is pre-tensioned so no muscle is slack), ``Kb`` the backbone's bending
    stiffness, ``Ka`` its axial stiffness (0: a constant preload whatever the length). None of
    these is in the paper; the defaults put the tensions inside the characterized loads
    0.6–2.1 N (Table II) for moderate bends, and every answer flags loads outside them.

    Attributes
    ----------
    preload : float, default 1.0
        Tension of each muscle in the straight tool at the reference length, F0. [N]
    bending_stiffness : float, default 2e-4
        Bending stiffness of the backbone, Kb = E·I. [N·m²]
    axial_stiffness : float, default 0.0
        Axial stiffness of the backbone, Ka (force per unit strain). [N]
    reference_length : float or None, default None
        Arc length at which the backbone's axial force is 3·F0, s_ref; ``None`` is the
        muscle's nominal length. [m]
    """

    preload: float = 1.0
    bending_stiffness: float = 2e-4
    axial_stiffness: float = 0.0
    reference_length: float | None = None

    def __post_init__(self):
        # bounds: plausible magnitudes (mckibben.limits.PLAUSIBLE_MAX), past which the statics overflow
        check_real(self.preload, "preload", lo=0.0, hi=PLAUSIBLE_MAX["force"], unit="N")
        check_real(self.bending_stiffness, "bending_stiffness", lo=0.0, hi=MAX_BENDING_STIFFNESS, unit="N·m²")
        check_real(self.axial_stiffness, "axial_stiffness", lo=0.0, hi=PLAUSIBLE_MAX["force"], unit="N")
        if self.reference_length is not None:
            check_real(self.reference_length, "reference_length", lo=0.0, lo_open=True, hi=PLAUSIBLE_MAX["length"],
                       unit="m")


@dataclass(frozen=True)
class Tool:
    """A three-muscle endoscope: geometry, the three (identical) muscles, load model, pressure limit.

    The muscles' statics are the muscle object's own: ``muscle.pressure_for_length(lengths,
    tensions, p_max)`` and ``muscle.length_for_pressure(pressures, tensions)``, a braid-angle map
    inverted for a miniature muscle (eq. 2+3), a force law solved by root finding for a lab's
    fitted muscle file (:class:`~mckibben.models.law_statics.LawMuscle`).

    Attributes
    ----------
    muscle : MiniatureMuscle or LawMuscle
        The parameter set of each of the three muscles (e.g. ``get_muscle("mpam117")``, or
        :func:`mckibben.tool.muscles.file_muscle`).
    geometry : ToolGeometry
        The disc stack.
    load : StackLoad
        The tension model shared by the three muscles.
    p_max : float, default 0.8e6
        Highest pressure allowed in any muscle (the paper's safe limit); for a
        :class:`LawMuscle` at most the top of the pressures its law was fitted on. [Pa]
    """

    muscle: MiniatureMuscle | LawMuscle
    geometry: ToolGeometry = field(default_factory=ToolGeometry)
    load: StackLoad = field(default_factory=StackLoad)
    p_max: float = 0.8e6

    def __post_init__(self):
        check_instance(self.muscle, "muscle", (MiniatureMuscle, LawMuscle),
                       "a muscle (get_muscle, or mckibben.tool.muscles.file_muscle)")
        check_instance(self.geometry, "geometry", ToolGeometry, "a ToolGeometry")
        check_instance(self.load, "load", StackLoad, "a StackLoad")
        check_p_max(check_real(self.p_max, "p_max", unit="Pa"), "p_max")
        m = self.muscle
        if isinstance(m, LawMuscle) and self.p_max > m.pressure_range[1]:
            raise InputError(f"p_max: {self.p_max / 1e6:g} MPa is above the top of the pressures {m.name}'s force law was"
                             f" fitted on ({m.pressure_range[1] / 1e6:g} MPa): the law is not known there")
        hole = self.geometry.hole_diameter
        if m.outer_diameter > hole:
            raise InputError(f"hole diameter: {hole * 1e3:.4g} mm holes do not pass the {m.outer_diameter * 1e3:.4g} mm"
                             f" muscle {m.name}; give a geometry with holes at least its outer diameter")
        gaps = self.geometry.n_gaps
        if gaps is not None and self.reference_length / gaps < MIN_DISC_GAP:
            most = int(self.reference_length / MIN_DISC_GAP) + 1
            raise InputError(
                f"discs: {self.geometry.n_discs} discs leave {self.reference_length / gaps * 1e3:.3g} mm between discs"
                f" on a {self.reference_length * 1e3:.3g} mm tool; at most {most} fit at {MIN_DISC_GAP * 1e3:g} mm"
                " apart (use 'continuous' for the limit of many discs)")

    @property
    def reference_length(self) -> float:
        """The load model's reference arc length s_ref (default: the muscle's nominal length). [m]"""
        return self.load.reference_length if self.load.reference_length is not None else self.muscle.nominal_length

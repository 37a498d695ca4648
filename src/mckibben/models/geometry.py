"""Muscle geometry: the braid of the physical laws and the miniature muscle's construction.

Geometry is data only (frozen dataclasses in SI); no force law lives here, so every law file
(:mod:`mckibben.models.laws`) and every model module can import it without a cycle.

Geometry of a braid: a strand of length ``b`` wound ``n`` turns around the muscle. At braid
angle θ (from the axis) the muscle is ``l = b·cos θ`` long and ``D = b·sin θ/(n·π)`` across, so
``D0 = b/(n·π)`` is the diameter at θ = 90°.

References
----------
Chou, C.-P., Hannaford, B. (1996), Measurement and modeling of McKibben pneumatic artificial
muscles, IEEE Trans. Robot. Autom. 12(1), 90–102. doi:10.1109/70.481753 (the braid's geometry).
[mpam-characterization], §II (the miniature muscle's construction).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mckibben.errors import check_instance, check_real

__all__ = ["BraidGeometry", "MiniatureGeometry", "miniature_geometry"]

#: Largest length or diameter of a braided muscle accepted (the plausible bound of
#: :data:`mckibben.limits.PLAUSIBLE_MAX`); past it the geometry is a unit slip. [m]
MAX_SIZE = 10.0
#: Most turns of a braid strand accepted: far past any braid (the miniature's is about 3). [-]
MAX_TURNS = 1e6


@dataclass(frozen=True)
class BraidGeometry:
    """A braided muscle's geometry for the physical models.

    Attributes
    ----------
    strand_length : float
        Length of one braid strand, b. [m]
    turns : float
        Number of turns one strand makes around the muscle, n. [-]
    wall_thickness : float
        Thickness of the inner tube's wall, t (0 for the thin-wall models). [m]
    """

    strand_length: float
    turns: float
    wall_thickness: float = 0.0

    def __post_init__(self):
        check_real(self.strand_length, "strand_length", lo=0.0, lo_open=True, hi=MAX_SIZE, unit="m")
        check_real(self.turns, "turns", lo=0.0, lo_open=True, hi=MAX_TURNS, unit="-")
        check_real(self.wall_thickness, "wall_thickness", lo=0.0, hi=MAX_SIZE, unit="m")

    @classmethod
    def from_initial(cls, length: float, diameter: float, braid_angle: float, wall_thickness: float = 0.0):
        """Geometry from the muscle at rest: its length, braid diameter and braid angle.

        Parameters
        ----------
        length : float
            Rest length l0. [m]
        diameter : float
            Braid diameter at rest, D. [m]
        braid_angle : float
            Braid angle at rest θ0, from the axis. [rad]
        wall_thickness : float, default 0.0
            Tube wall thickness. [m]
        """
        check_real(length, "length", lo=0.0, lo_open=True, hi=MAX_SIZE, unit="m")
        check_real(diameter, "diameter", lo=0.0, lo_open=True, hi=MAX_SIZE, unit="m")
        check_real(braid_angle, "braid_angle", lo=0.0, hi=np.pi / 2, lo_open=True, hi_open=True, unit="rad")
        b = length / np.cos(braid_angle)
        n = b * np.sin(braid_angle) / (np.pi * diameter)
        return cls(float(b), float(n), float(wall_thickness))

    @property
    def d0(self) -> float:
        """Diameter at θ = 90°, D0 = b/(nπ). [m]"""
        return self.strand_length / (self.turns * np.pi)

    @property
    def locking_length(self) -> float:
        """Length where the thin-wall force vanishes, cos²θ = 1/3 (θ ≈ 54.7°). [m]"""
        return self.strand_length / np.sqrt(3.0)


@dataclass(frozen=True)
class MiniatureGeometry:
    """Construction of a miniature muscle.

    Attributes
    ----------
    outer_diameter : float
        Outer diameter of the braided muscle. [m]
    tube_inner_diameter : float
        Inner diameter of the silicone tube. [m]
    tube_outer_diameter : float
        Outer diameter of the silicone tube. [m]
    strand_diameter : float
        Diameter of one braid strand. [m]
    braid_angle : float
        Initial braid angle, from the muscle axis. [rad]
    """

    outer_diameter: float = 1.2e-3
    tube_inner_diameter: float = 0.5e-3
    tube_outer_diameter: float = 0.9e-3
    strand_diameter: float = 0.1e-3
    braid_angle: float = np.deg2rad(20.0)

    def __post_init__(self):
        for name in ("outer_diameter", "tube_inner_diameter", "tube_outer_diameter", "strand_diameter"):
            check_real(getattr(self, name), name, lo=0.0, lo_open=True, hi=MAX_SIZE, unit="m")
        check_real(self.braid_angle, "braid_angle", lo=0.0, hi=np.pi / 2, lo_open=True, hi_open=True, unit="rad")

    @property
    def wall_thickness(self) -> float:
        """Silicone tube wall thickness. [m]"""
        return 0.5 * (self.tube_outer_diameter - self.tube_inner_diameter)

    @classmethod
    def from_spec(cls, spec) -> "MiniatureGeometry":
        """The construction a muscle file states (:class:`mckibben.data.MuscleSpec`; every size needed).

        It was ``MuscleSpec.geometry``; it lives here because ``data`` may not import ``models``.
        """
        sizes = [spec.need(q, "the miniature geometry") for q in ("outer_diameter", "tube_inner_diameter",
                                                                 "tube_outer_diameter", "strand_diameter",
                                                                 "braid_angle")]
        return cls(*sizes)


def check_geometry(geom) -> "BraidGeometry":
    """``geom`` if it is a :class:`BraidGeometry`; else an error naming ``geom`` (what the physical laws take).

    Parameters
    ----------
    geom : BraidGeometry
        The argument. [-]
    """
    return check_instance(geom, "geom", BraidGeometry, "a BraidGeometry (miniature_geometry)")


def miniature_geometry(nominal_length: float, geometry=None, wall: bool = True) -> BraidGeometry:
    """The physical-model geometry of a miniature muscle of [mpam-characterization].

    The braid diameter is the outer diameter less one strand diameter (the braid's mid-line,
    1.1 mm), the braid angle the construction's ~20° (§II), and the wall the silicone tube's
    (OD 0.9 − ID 0.5)/2 = 0.2 mm.

    Parameters
    ----------
    nominal_length : float
        Rest length. [m]
    geometry : MiniatureGeometry, optional
        Construction; the paper's by default.
    wall : bool, default True
        Include the tube wall thickness (False: thin-wall ideal).
    """
    check_real(nominal_length, "nominal_length", lo=0.0, lo_open=True, hi=MAX_SIZE, unit="m")
    g = MiniatureGeometry() if geometry is None else check_instance(geometry, "geometry", MiniatureGeometry,
                                                                   "a MiniatureGeometry")
    return BraidGeometry.from_initial(
        nominal_length,
        g.outer_diameter - g.strand_diameter,
        g.braid_angle,
        g.wall_thickness if wall else 0.0,
    )

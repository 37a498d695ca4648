"""Physical baselines from braid geometry: Chou–Hannaford, Tondu–Lopez, wall thickness.

The laws themselves live one per file in :mod:`mckibben.models.laws` (kernel, NumPy face,
parameters, fit spec) and the geometry in :mod:`mckibben.models.geometry`; this module keeps their
statics (length under a load) and re-exports them under their historical names.

These models use no fitted data: force from pressure and geometry by the principle of virtual
work on a thin cylindrical braid. For the 1.2 mm muscle they over-predict badly (wall thickness,
elasticity and friction matter at this size), which is why the papers fit empirical maps; see
``tests/test_physical.py`` for how far.

Geometry: a braid of strand length ``b`` wound ``n`` turns around the muscle. At braid angle θ
(from the axis) the muscle is ``l = b·cos θ`` long and ``D = b·sin θ/(n·π)`` across, so
``D0 = b/(n·π)`` is the diameter at θ = 90°.

Examples
--------
A braid of 100 mm strands wound three turns, at 0.5 MPa, holding 1 N (Chou–Hannaford, closed
form), and the same muscle unpressurized (slack: flagged):

>>> from mckibben.models.geometry import BraidGeometry
>>> g = BraidGeometry(strand_length=0.1, turns=3.0)
>>> length, flags = length_under_load(0.5e6, 1.0, g)
>>> round(float(length) * 1e3, 2), int(flags)
(58.38, 0)
>>> int(length_under_load(0.0, 1.0, g)[1]) != 0
True

References
----------
Chou, C.-P., Hannaford, B. (1996), Measurement and modeling of McKibben pneumatic artificial
muscles, IEEE Trans. Robot. Autom. 12(1), 90–102. doi:10.1109/70.481753
Tondu, B., Lopez, P. (2000), Modeling and control of McKibben artificial muscle robot actuators,
IEEE Control Syst. Mag. 20(2), 15–38. doi:10.1109/37.833638
Tsagarakis, N., Caldwell, D. G. (2000), Improved modelling and assessment of pneumatic muscle
actuators, ICRA 2000; Davis, S. et al. (2003), Enhanced modelling and performance in braided
pneumatic muscle actuators, IJRR 22(3–4), 213–227 (wall-thickness term).
Both cited as the standard physical models in Wickramatunge & Leephakpreeda (2010) [wickramatunge2010] §1; NOTES.md.
"""

from __future__ import annotations

import numpy as np

from mckibben.errors import ArgumentTypeError, InputError, check_array
from mckibben.models.flags import Flag, flag_where
from mckibben.models import laws
from mckibben.models.geometry import BraidGeometry, miniature_geometry
from mckibben.models.law_statics import rising_root
from mckibben.models.laws.chou_hannaford import chou_hannaford_force
from mckibben.models.laws.tondu_lopez import TonduLopez, tondu_lopez_contraction, tondu_lopez_force
from mckibben.models.laws.wall_corrected import wall_corrected_force

__all__ = ["BraidGeometry", "TonduLopez", "chou_hannaford_force", "length_under_load", "miniature_geometry",
           "tondu_lopez_contraction", "tondu_lopez_force", "wall_corrected_force"]


def length_under_load(pressure, load, geom: BraidGeometry, model: str = "chou-hannaford"):
    """Equilibrium length of a braid law holding a hanging load.

    Solves F(P, l) = load for l with the law's own force (:func:`mckibben.models.laws.evaluate`
    on the θ of ``geom``) by :func:`mckibben.models.law_statics.rising_root` between cos θ = 0 and
    the straight braid ``b``: the first length where the pull passes the load,
    so the wall-corrected law (whose −1/sin θ term makes its pull fall again near the straight
    braid) is solved on its rising branch.

    Parameters
    ----------
    pressure : array_like
        Gauge pressure. [Pa]
    load : array_like
        Hanging load. [N]
    geom : BraidGeometry
        Braid geometry.
    model : str, default "chou-hannaford"
        A registered law whose parameters are a :class:`BraidGeometry` (``chou-hannaford``,
        ``wall-corrected``; old names read). [-]

    Returns
    -------
    length : numpy.ndarray
        Equilibrium length (capped at the strand length b where the load would straighten the
        braid, flagged). [m]
    flags : numpy.ndarray
        ``length_out_of_range`` where capped; ``slack`` where P = 0.

    References
    ----------
    Chou & Hannaford (1996), eq. (6); the wall term: Tsagarakis & Caldwell (2000).
    """
    if not isinstance(geom, BraidGeometry):
        raise ArgumentTypeError(f"geom = {geom!r}: not a BraidGeometry ({type(geom).__name__}); get one from "
                                "miniature_geometry")
    p, f = np.broadcast_arrays(check_array(pressure, "pressure"), check_array(load, "load", lo=0.0, unit="N"))
    if not isinstance(model, str):
        raise InputError(f"model = {model!r}: not a law name")
    name = laws.resolve(model, "model")
    law = laws.LAWS[name]
    if law.params is not BraidGeometry:
        braid = [n for n, law_ in laws.LAWS.items() if law_.params is BraidGeometry]
        raise InputError(f"model = {model!r}: its parameters are not a braid's geometry; use {' or '.join(braid)}")
    theta = law.theta_of(geom, "elongation")
    # from cos θ = 0: the wall-corrected law still pulls at the locking angle (cos²θ = 1/3)
    exact = None if law.length_of is None else (lambda pp, ff: law.length_of(theta, pp, ff))
    length, state = rising_root(lambda pp, ell: laws.evaluate(name, pp, ell, theta), p, f, 0.0, geom.strand_length,
                                exact)
    slack = ~(p > 0)
    capped = (state > 0) | slack
    length = np.where(capped, geom.strand_length, length)
    flags = flag_where(capped, Flag.LENGTH_OUT_OF_RANGE) | flag_where(slack, Flag.SLACK)
    return length, flags

"""The shape of a controller entry: :class:`GainSpec` and :class:`ControllerSpec`.

A controller file (``control/laws/<name>.py``) exports one :class:`ControllerSpec` named
``CONTROLLER`` holding real function objects (its law, design, tuning candidates, description);
its mode and its gains' SET_GAIN ids come from the one table (:mod:`mckibben.control.laws._table`).

The designs take and return a parameter set of the core (:class:`mckibben.control.core.CoreParams`),
which is built *from* the registry's gains; a controller file therefore never imports it (that
would be an import circle): it changes the ``base`` it is given with :func:`dataclasses.replace`.
The type :data:`Params` says so.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import Any

from mckibben.control.first_order import FirstOrderModel
from mckibben.control.laws._table import GAIN_IDS, MODES

#: A :class:`mckibben.control.core.CoreParams` (defined above the registry, which it is built from).
Params = Any


@dataclass(frozen=True)
class GainSpec:
    """One SET_GAIN entry: the value sent is ``round(physical · scale)`` in ``[lo, hi]``.

    Parameters
    ----------
    name : str
        Gain name of the protocol and the design files (``smc_beta``); its id is the table's. [-]
    param : str
        The :class:`~mckibben.control.core.CoreParams` field that carries it (``beta``). [-]
    unit : str
        Unit of the physical value. [-]
    scale : float
        Fixed-point scale of the value sent. [-]
    lo, hi : int
        Accepted range of the value sent. [-]
    default : float or int
        The default physical value, in ``unit``: the one place it is written. [unit]
    c_name : str
        The C enumerator (``MCK_GAIN_SMC_BETA``). [-]
    doc : str
        One line for the docs. [-]
    """

    name: str
    param: str
    unit: str
    scale: float
    lo: int
    hi: int
    default: float | int
    c_name: str
    doc: str = ""

    @property
    def id(self) -> int:
        """SET_GAIN id, from the one table (:data:`mckibben.control.laws._table.TABLE`). [-]"""
        return GAIN_IDS[self.name]

    @property
    def default_value(self) -> int:
        """The default in the SET_GAIN scale, ``round(default · scale)``. [-]"""
        return int(round(self.default * self.scale))


@dataclass(frozen=True)
class ControllerSpec:
    """One controller of the core: everything the library knows about it.

    Parameters
    ----------
    name : str
        Name used everywhere (``--controller``, sweeps, the rig); its mode is the table's. [-]
    c_name : str
        Its name in the C core's macros (``MCK_MODE_<c_name>``). [-]
    label : str
        Label of figures. [-]
    summary : str
        One line: what the law is. [-]
    gains : tuple of GainSpec
        The gains it owns (the supervisor's are :data:`mckibben.control.registry.SUPERVISOR_GAINS`). [-]
    law : callable
        The Python law, the bit-exact mirror of the C law (a marked kernel,
        :func:`mckibben._kernels.kernel`). [-]
    design : callable
        ``design(model, base, **gains) -> CoreParams``: the controller with its documented
        design on an identified model. [-]
    candidates : callable
        ``candidates(model, base, top, grid, law=..., beta=..., ...) -> (gains, params)``: the
        candidates :func:`~mckibben.control.tuning.tune_gains` simulates. [-]
    describe : callable
        ``describe(params) -> dict``: the gains as reported in results. [-]
    designs : mapping
        The documented designs, by name: design parameter -> value (SI or PWM counts). [-]
    grid : mapping
        The candidate grids of the tuning, by design name: parameter -> values. [-]
    variants : tuple of str
        Variants of the law selected by ``law=`` (the sliding mode's ``model`` and ``paper``);
        empty when there is one. [-]
    extension : bool
        True for a law of its own header (``firmware/core/law_<name>.h``, modes 4, 5, ...);
        False for the core's sliding mode and PID (``controller.c``). [-]
    state : int
        Integer state slots of an extension law (after the core's). [-]
    coefs : tuple of str
        Coefficients of an extension law, in the order of its parameter slots. [-]
    derive : callable or None
        ``derive(gains, ts_us) -> {coef: array}`` of an extension law. [-]
    float_law : callable or None
        The float64 reference of an extension law. [-]
    references : str
        Where the law comes from. [-]
    """

    name: str
    c_name: str
    label: str
    summary: str
    gains: tuple[GainSpec, ...]
    law: Callable
    design: Callable[..., Params]
    candidates: Callable
    describe: Callable[[Params], dict]
    designs: Mapping[str, Mapping[str, float]]
    grid: Mapping[str, Mapping[str, tuple]]
    variants: tuple[str, ...] = ()
    extension: bool = True
    state: int = 0
    coefs: tuple[str, ...] = ()
    derive: Callable | None = None
    float_law: Callable | None = None
    references: str = ""

    @property
    def mode(self) -> int:
        """SET_MODE id, from the one table (:data:`mckibben.control.laws._table.TABLE`). [-]"""
        return MODES[self.name]

    def default(self, design: str | None = None) -> Mapping[str, float]:
        """A documented design (default: the first). [-]"""
        return self.designs[design or next(iter(self.designs))]


def with_supervisor_model(base: Params, model: FirstOrderModel) -> Params:
    """``base`` with the supervisor's valve model set from an identified model.

    The response rule of the stuck-sensor check (``docs/controller.md``, supervisor 3) predicts
    from ``p = G_s·(u − u0_s)`` whether the reading must move; it takes G and the lift-off of
    the identification whatever law runs (the paper's law included).

    Parameters
    ----------
    base : CoreParams
        Core parameters. [-]
    model : FirstOrderModel
        Identified model (G in Pa per PWM count, lift-off in counts). [-]

    Returns
    -------
    CoreParams
        With ``sup_g = G`` and ``sup_u0 = u0``.
    """
    return replace(base, sup_g=float(model.gain), sup_u0=float(model.lift_off))

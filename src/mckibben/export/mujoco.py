"""Calibrated McKibben muscles as MuJoCo actuators: the plant's own chamber and valves on MuJoCo tendons.

MuJoCo's actuators hold at most one state (``act``) and a force law of a fixed form; a
pneumatic muscle has a chamber pressure, a gas temperature and two valve openings, and its force
is a fitted law of pressure and length. :class:`MuscleBank` keeps that state beside MuJoCo: at
each MuJoCo step every muscle

1. reads its tendon's length and velocity (``data.ten_length``, ``data.ten_velocity``, after
   ``mj_step1`` has computed them for the current state),
2. writes its tension into ``data.ctrl`` of the ``general`` actuator on that tendon (gain 1,
   no bias, ``gear="-1"``: a positive control pulls), and
3. after ``mj_step2`` has integrated MuJoCo, advances its own valves and chamber over the same
   time step with **the plant's kernel** (:func:`mckibben.plant.physics.rk4_step`: the same
   right-hand side, Runge–Kutta step, end stops and braid friction as
   :func:`mckibben.plant.simulate`). The muscle's end is driven by MuJoCo: its length follows the
   tendon (its velocity held over the step) instead of the plant's load equation (the block's
   inverse moving mass is 0, so the plant's acceleration is 0 and its length moves at the
   tendon's velocity).

Why ``data.ctrl`` of a tendon actuator and not ``qfrc_applied`` or ``xfrc_applied``: MuJoCo's
actuator transmission spreads a tendon force over every joint the tendon crosses, through every
site, pulley and wrapping geometry (the moment arms of ``ten_J``), exactly as for its own
muscles; the force appears in ``data.actuator_force`` and in ``actuatorfrc`` sensors; and
``forcerange`` clamps it. ``qfrc_applied`` would need that transmission recomputed here, and
``xfrc_applied`` acts on one body, not along a tendon through several.

Valve commands come in as PWM counts (``inlet``, ``bleed``), or a pressure controller of the
registry (:mod:`mckibben.control.registry`; the firmware core's mirror,
:func:`mckibben.control.core.core_spec`) closes the loop on a pressure reference at its own
period (1 ms), sampling the pressure through the ADC model as the simulator does.

``mujoco`` is an optional dependency (``pip install 'mckibben[mujoco]'``); it is imported inside
the functions that need it, so nothing else in mckibben loads it.

References
----------
MuJoCo documentation, "Computation" (actuation model, ``mj_step1``/``mj_step2``); MuJoCo issue
#1525, "Muscle for artificial muscle application"; [mpam-characterization], eq. (2)–(3), §III–IV.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mckibben import hardware as HW
from mckibben._jit import kernel as compiled  # the one decorator (`kernel` here names a controller kernel)
from mckibben import control
from mckibben.control.core import CoreParams, core_spec
from mckibben.data.muscle_file import MuscleSpec
from mckibben.datasets import get_muscle
from mckibben.errors import ArgumentTypeError, InputError, check_real
from mckibben.models import laws as LW
from mckibben.models.law_statics import LawMuscle
from mckibben.models.mpam import MiniatureMuscle
from mckibben.plant import params as PP
from mckibben.plant import packing as PK
from mckibben.plant import physics as ph
from mckibben.plant.simulator import initial_states

__all__ = ["MuscleBank", "hanging_mass_mjcf", "load_model", "muscle_plant", "MUJOCO_HINT"]

#: How to install the optional dependency (every error about a missing ``mujoco`` says it).
MUJOCO_HINT = "pip install 'mckibben[mujoco]'"
#: Packed parameter columns read here, by name (:class:`mckibben.plant.packing.Col`).
_COL = {name: int(PK.Col[name]) for name in ("supply_pressure", "l_min", "l_max", "temperature", "nominal_length",
                                             "pa_per_count", "adc_zero", "encoder_resolution")}
#: The plant's integration step (the simulator's 1 ms / 10 substeps): a longer MuJoCo step is
#: split into RK4 steps no longer than this, so the chamber is integrated as accurately. [s]
PLANT_STEP = HW.CONTROL_PERIOD / 10


def _mujoco():
    """The ``mujoco`` module, or an InputError saying how to install it."""
    try:
        import mujoco  # deferred: a heavy optional package (the `mujoco` extra), only this bridge needs it
    except ImportError:
        raise InputError(f"the MuJoCo bridge needs the mujoco package: {MUJOCO_HINT}") from None
    return mujoco


def load_model(source, name: str = "model"):
    """A compiled MuJoCo model from an MJCF file, an MJCF string or an ``MjModel``.

    Parameters
    ----------
    source : str, os.PathLike or mujoco.MjModel
        A path to an ``.xml`` file, MJCF text (starting with ``<``), or a compiled model. [-]
    name : str, default "model"
        The argument's name, for the messages. [-]

    Returns
    -------
    mujoco.MjModel

    Raises
    ------
    InputError
        A missing or unreadable file, or MJCF that MuJoCo refuses (its message, one line).
    """
    mujoco = _mujoco()
    if isinstance(source, mujoco.MjModel):
        return source
    if not isinstance(source, (str, os.PathLike)):
        raise ArgumentTypeError(f"{name}: {type(source).__name__} is not an MJCF path, MJCF text or a mujoco.MjModel")
    text = os.fspath(source)
    is_text = text.lstrip().startswith("<")
    if not is_text and not Path(text).is_file():
        raise InputError(f"{name}: no MJCF file {text}")
    try:
        if is_text:
            return mujoco.MjModel.from_xml_string(text)
        return mujoco.MjModel.from_xml_path(text)
    except ValueError as exc:  # MuJoCo's XML and compile errors
        msg = " ".join(str(exc).split())
        raise InputError(f"{name}: MuJoCo refuses {'the MJCF text' if is_text else text}: "
                         f"{msg}") from None


def muscle_plant(muscle="mpam97", force_model: str | None = None, **fields) -> PP.PlantParams:
    """The plant (chamber, valves, force law) of one muscle, for a MuJoCo tendon.

    Parameters
    ----------
    muscle : str, MiniatureMuscle, Muscle, MuscleSpec, os.PathLike or PlantParams, default "mpam97"
        A published set by name (``mpam97``, ``mpam117``, ``mpam143``) or object
        (:meth:`PlantParams.for_muscle`: the rig of the paper, the plant's calibrated law), a
        fitted muscle file (a ``.toml`` path, its :class:`~mckibben.data.muscle_file.MuscleSpec`, or a
        :class:`~mckibben.models.muscle.Muscle` / tool muscle of one, with its branch:
        :meth:`PlantParams.from_muscle_file`, its own law), or a ready :class:`PlantParams`
        (one instance). [-]
    force_model : str, optional
        The force law of a published set: ``"calibrated"`` (the plant's Tondu–Lopez, the
        default) or ``"empirical"`` (the set's braid-angle map, eq. 2+3: the same statics as
        ``mckibben predict length`` and the tool). [-]
    **fields
        Any other :class:`PlantParams` field (supply, valves, friction). [SI]

    Returns
    -------
    PlantParams
        One instance; its load fields are unused (MuJoCo carries the load).
    """
    if isinstance(muscle, PP.PlantParams):
        if force_model is not None or fields:
            muscle = muscle.replace(**fields, **({"force_model": force_model} if force_model else {}))
        plant = muscle
    elif isinstance(muscle, (LawMuscle, MuscleSpec)) or (isinstance(muscle, (str, os.PathLike))
                                                         and os.fspath(muscle).lower().endswith(".toml")):
        if force_model is not None:
            raise InputError("force_model: a muscle file runs its own fitted law; leave force_model out")
        if isinstance(muscle, LawMuscle):  # the muscle of a file (the tool's): its file, its branch
            plant = PP.PlantParams.from_muscle_file(muscle.source, muscle.direction, **fields)
        else:
            plant = PP.PlantParams.from_muscle_file(muscle, **fields)
    elif isinstance(muscle, (str, MiniatureMuscle)):
        m = get_muscle(muscle) if isinstance(muscle, str) else muscle
        extra = {"force_model": force_model} if force_model is not None else {}
        plant = PP.PlantParams.for_muscle(m, **extra, **fields)
    else:
        raise ArgumentTypeError(f"muscle: {type(muscle).__name__} is not a muscle name, a MiniatureMuscle, a muscle "
                                "file (.toml or Muscle) or a PlantParams")
    if plant.size() != 1:
        raise InputError("muscle: one muscle per tendon (a PlantParams of one instance)")
    return plant


@compiled(error_model="numpy")
def _exchange(n, bk, law, length, velocity, inlet, bleed, tension):
    """Lanes 0..n-1 take the tendons' length [m] and velocity [m/s] and the valves' PWM counts; their
    tension [N] goes to ``tension``.

    The tension is what the plant's load feels: the law's pull (never pushing) plus the tube's
    passive stiffness (:func:`~mckibben.plant.physics.outputs`) plus the braid friction's Dahl
    force (which the plant's load equation subtracts with the pull). The valves' targets are the
    plant's (:func:`~mckibben.plant.physics.valve_target`: driver and dead band).
    """
    for j in range(n):
        bk[ph.Z_LEN + j] = length[j]
        bk[ph.Z_VEL + j] = velocity[j]
        bk[ph.Y_XIN + j] = ph.valve_target(inlet[j], bk[ph.X_DRV + j], bk[ph.X_DB + j])
        bk[ph.Y_XBL + j] = ph.valve_target(bleed[j], bk[ph.X_DRV + j], bk[ph.X_DB + j])
    ph.outputs(n, bk, law)
    for j in range(n):
        tension[j] = bk[ph.Y_FORCE + j] + bk[ph.Z_FRIC + j]


@dataclass
class _Block:
    """Up to W muscles of one force law: their lanes in one block array of the plant."""

    law: int
    lanes: np.ndarray  # muscle indices, in lane order
    bk: np.ndarray
    prm: np.ndarray  # (n, NP) packed parameters, for the sensors
    length: np.ndarray = field(default_factory=lambda: np.zeros(0))
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(0))
    tension: np.ndarray = field(default_factory=lambda: np.zeros(0))


class MuscleBank:
    """Pneumatic muscles on tendons of a MuJoCo model, each with its own chamber, valves and force law.

    Parameters
    ----------
    model : mujoco.MjModel, str or os.PathLike
        The model (:func:`load_model`: a compiled model, an MJCF path or MJCF text). Each tendon
        named in ``tendons`` must carry one ``general`` actuator with ``gear="-1"``, gain 1 and
        no bias (``<general tendon="T" gear="-1"/>``; MuJoCo's defaults are gain 1, no bias):
        its control is the muscle's tension. [-]
    tendons : sequence of str
        The tendons that are muscles; a tendon's length is its muscle's length plus ``offset``. [-]
    muscle : muscle or sequence of muscles, default "mpam97"
        One for all tendons or one per tendon: anything :func:`muscle_plant` takes. [-]
    force_model : str, optional
        For published sets: ``"calibrated"`` (default) or ``"empirical"`` (:func:`muscle_plant`). [-]
    controller : str, CoreParams, tuple or None, default None
        None: valve commands in (``step(inlet=..., bleed=...)``). A registry name (``"smc"``,
        ``"pid"``: :func:`mckibben.control.experiment_setup.controller_params`, the documented tuning),
        a :class:`~mckibben.control.core.CoreParams` (one for all muscles) or a kernel spec
        ``(kernel, istate0, iparams, fstate0, fparams)`` with one row per muscle: pressure control
        at ``ts`` on ``step(reference=...)``. [-]
    initial_pressure : float or array_like, default 0.0
        Gauge pressure in each chamber at the start. [Pa]
    offset : float or array_like, default 0.0
        Tendon length that is not muscle (attachments, the path to the anchor), per tendon. [m]
    pressure_floor : float, default 0.0
        Lowest pressure the run holds; a law is checked stable above it only (see
        :func:`mckibben.plant.packing.check_force_law`). [Pa]
    ts : float, default 1e-3
        Controller period; a whole number of MuJoCo time steps. [s]

    Notes
    -----
    Coupling: explicit (the tension of step k acts during step k, computed from the state at its
    start). The chamber is integrated with RK4 steps of at most :data:`PLANT_STEP`; MuJoCo's own
    step must resolve the mechanics (a muscle's axial stiffness on the moving mass).
    """

    def __init__(self, model, tendons, muscle="mpam97", *, force_model: str | None = None, controller=None,
                 initial_pressure=0.0, offset=0.0, pressure_floor: float = 0.0, ts: float = HW.CONTROL_PERIOD):
        mujoco = _mujoco()
        self.model = load_model(model)
        m = self.model
        if isinstance(tendons, str) or not all(isinstance(t, str) for t in np.atleast_1d(np.asarray(tendons, object))):
            raise ArgumentTypeError("tendons: a sequence of tendon names, e.g. ['muscle1']")
        self.tendons = list(tendons)
        n = len(self.tendons)
        if n == 0:
            raise InputError("tendons: name at least one tendon of the model")
        known = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_TENDON, i) for i in range(m.ntendon)]
        self.tendon_ids = np.empty(n, dtype=np.int64)
        self.actuator_ids = np.empty(n, dtype=np.int64)
        for k, name in enumerate(self.tendons):
            tid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_TENDON, name)
            if tid < 0:
                have = ", ".join(x for x in known if x) or "none"
                raise InputError(f"tendons: the model has no tendon {name!r} (its tendons: {have})")
            self.tendon_ids[k] = tid
            self.actuator_ids[k] = self._actuator_of(mujoco, tid, name)
        if len(set(self.tendons)) != n:
            raise InputError("tendons: a tendon is named twice; one muscle per tendon")
        ts = check_real(ts, "ts", lo=0.0, lo_open=True, unit="s")
        dt = float(m.opt.timestep)
        ratio = ts / dt
        if abs(ratio - round(ratio)) > 1e-6 * ratio or round(ratio) < 1:
            raise InputError(f"ts: the controller period {ts:g} s must be a whole number of MuJoCo time steps "
                             f"({dt:g} s)")
        self.ts, self.dt, self.steps_per_period = float(ts), dt, int(round(ratio))
        self.substeps = max(1, math.ceil(dt / PLANT_STEP - 1e-9))
        muscles = list(muscle) if isinstance(muscle, (list, tuple)) else [muscle] * n
        if len(muscles) != n:
            raise InputError(f"muscle: {len(muscles)} muscles for {n} tendons; give one, or one per tendon")
        self.offset = self._per_muscle(offset, "offset", n)
        p0 = self._per_muscle(initial_pressure, "initial_pressure", n)
        floor = check_real(pressure_floor, "pressure_floor", lo=0.0, unit="Pa")
        checked: dict = {}  # one plant, one check, per distinct muscle given (256 tendons of one muscle: one)
        rows, laws, thetas, self.plants = [], [], [], []
        for k, x in enumerate(muscles):
            if id(x) not in checked:
                plant = muscle_plant(x, force_model)
                prm = plant.pack(1)
                name, th = plant.law(1)
                th = np.ascontiguousarray(th, dtype=float)
                PK.check_force_law(name, prm, th, plant._law_label(), pressure_floor=floor)
                checked[id(x)] = (plant, prm[0], LW.LAW_INDEX[name], th[:, 0])
            plant, row, law, theta = checked[id(x)]
            if not 0.0 <= p0[k] <= row[_COL['supply_pressure']]:
                raise InputError(f"initial_pressure: {p0[k]:g} Pa for tendon {self.tendons[k]!r} must lie between 0 "
                                 "and the supply pressure")
            self.plants.append(plant)
            rows.append(row)
            laws.append(law)
            thetas.append(theta)
        self.prm = np.array(rows)
        self.l_min = self.prm[:, _COL['l_min']].copy()
        self.l_max = self.prm[:, _COL['l_max']].copy()
        self.blocks: list[_Block] = []
        for law in sorted(set(laws)):
            idx = np.array([k for k in range(n) if laws[k] == law])
            for a in range(0, idx.size, ph.W):
                lanes = idx[a:a + ph.W]
                self.blocks.append(self._block(law, lanes, thetas, p0))
        self._spec = self._controller(controller, n)
        self.t = 0.0
        self.k = 0
        self.inlet = np.zeros(n, dtype=np.int64)
        self.bleed = np.zeros(n, dtype=np.int64)
        self.faults = np.zeros(n, dtype=np.int64)
        self.reference = np.zeros(n)
        self.end_stop = np.zeros(n, dtype=bool)
        self._tension = np.zeros(n)

    # --- construction -----------------------------------------------------------------------------

    def _actuator_of(self, mujoco, tid: int, name: str) -> int:
        """The one actuator on tendon ``tid``, checked to be a pure force input (gain 1, no bias, gear −1)."""
        m_trn = mujoco.mjtTrn.mjTRN_TENDON
        found = []
        model = self.model
        for a in range(model.nu):
            if int(model.actuator_trntype[a]) == int(m_trn) and int(model.actuator_trnid[a, 0]) == tid:
                found.append(a)
        if len(found) != 1:
            what = "no actuator" if not found else f"{len(found)} actuators"
            raise InputError(f"tendons: tendon {name!r} has {what}; give it one: "
                             f'<general tendon="{name}" gear="-1"/> (gain 1, no bias: the control is the tension)')
        return_id = found[0]
        gain, bias = model.actuator_gainprm[return_id], model.actuator_biasprm[return_id]
        gear = model.actuator_gear[return_id, 0]
        if (int(model.actuator_gaintype[return_id]) != 0 or gain[0] != 1.0 or np.any(gain[1:3] != 0)
                or int(model.actuator_biastype[return_id]) != 0 or np.any(bias[:3] != 0) or gear != -1.0
                or int(model.actuator_dyntype[return_id]) != 0):
            aname = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_ACTUATOR, return_id) or f"#{return_id}"
            raise InputError(f"tendons: the actuator {aname} of tendon {name!r} must be <general tendon=\"{name}\" "
                             "gear=\"-1\"/> with gain 1, no bias and no dynamics: its control is the muscle's tension")
        return return_id

    @staticmethod
    def _per_muscle(value, name: str, n: int) -> np.ndarray:
        a = np.asarray(value, dtype=float) if not isinstance(value, (str, bytes)) else None
        if a is None or a.ndim > 1 or (a.ndim == 1 and a.size != n) or not np.all(np.isfinite(a)):
            raise InputError(f"{name}: a finite number or one per tendon ({n}), got {value!r}")
        return np.array(np.broadcast_to(a, (n,)), dtype=float)

    def _block(self, law: int, lanes: np.ndarray, thetas, p0) -> _Block:
        prm = self.prm[lanes]
        th = np.column_stack([thetas[k] for k in lanes])
        # the plant's rest state (gas at the wall temperature, the play at the pressure), at the tendon's length
        s0 = initial_states(prm, law, th, p0[lanes], l_init=prm[:, _COL['nominal_length']])
        bk = np.zeros(ph.BLOCK)
        ph.load_block(0, lanes.size, np.ascontiguousarray(prm), np.ascontiguousarray(th), s0, bk)
        nl = lanes.size
        # the muscle's end moves with its tendon: no load equation (inverse mass 0), always mobile
        bk[ph.X_INVM:ph.X_INVM + nl] = 0.0
        bk[ph.X_MOB:ph.X_MOB + nl] = 1.0
        return _Block(law, lanes, bk, prm, np.zeros(nl), np.zeros(nl), np.zeros(nl))

    def _controller(self, controller, n: int):
        if controller is None:
            return None
        if isinstance(controller, str):
            controller = control.experiment_setup.controller_params(controller)
        if isinstance(controller, CoreParams):
            controller = core_spec(controller, n)
        if not (isinstance(controller, tuple) and len(controller) == 5):
            raise ArgumentTypeError("controller: None, a registry name ('smc', 'pid'), a CoreParams or a kernel spec "
                                    "(kernel, istate0, iparams, fstate0, fparams)")
        kernel, i0, ip, f0, fp = controller
        arrays = [np.array(i0, dtype=np.int64), np.ascontiguousarray(ip, dtype=np.int64), np.array(f0, dtype=float),
                  np.ascontiguousarray(fp, dtype=float)]
        for name, a in zip(("istate0", "iparams", "fstate0", "fparams"), arrays):
            if a.ndim != 2 or a.shape[0] != n:
                raise InputError(f"controller {name}: shape {a.shape}, want ({n}, ·): one row per muscle")
        return (kernel, *arrays)

    # --- the run ----------------------------------------------------------------------------------

    @property
    def pressure(self) -> np.ndarray:
        """Gauge pressure in each chamber now. [Pa]"""
        out = np.empty(len(self.tendons))
        for b in self.blocks:
            out[b.lanes] = b.bk[ph.Z_P:ph.Z_P + b.lanes.size] - ph.P_ATM
        return out

    @property
    def temperature(self) -> np.ndarray:
        """Gas temperature in each chamber now. [K]"""
        out = np.empty(len(self.tendons))
        for b in self.blocks:
            out[b.lanes] = b.bk[ph.Z_T:ph.Z_T + b.lanes.size]
        return out

    @property
    def tension(self) -> np.ndarray:
        """Each muscle's tension in the last step (its actuator's control). [N]"""
        return self._tension.copy()

    def length(self, data) -> np.ndarray:
        """Each muscle's length now: its tendon's length less the offset. [m]

        Parameters
        ----------
        data : mujoco.MjData
            The model's data (tendon lengths as of the last ``mj_step1``/``mj_forward``). [-]
        """
        return np.asarray(data.ten_length)[self.tendon_ids] - self.offset

    def _sense(self, data) -> None:
        """One control period: sample each pressure through the ADC model, run the controller."""
        kernel, istate, iparams, fstate, fparams = self._spec
        lengths = self.length(data)
        p = self.pressure
        for i in range(len(self.tendons)):
            row = self.prm[i]
            adc = int(HW.adc_count(float(p[i]), row[_COL['pa_per_count']], row[_COL['adc_zero']]))
            enc = int(HW.encoder_count(float(lengths[i]), row[_COL['nominal_length']], row[_COL['encoder_resolution']]))
            u_in, u_bl, fault = kernel(istate[i], iparams[i], fstate[i], fparams[i], adc, enc, True,
                                       float(self.reference[i]))
            self.inlet[i], self.bleed[i] = int(u_in), int(u_bl)
            self.faults[i] |= int(fault)

    def _counts(self, value, name: str) -> np.ndarray:
        a = np.asarray(value)
        if a.dtype.kind not in "iuf" or a.ndim > 1 or (a.ndim == 1 and a.size != len(self.tendons)):
            raise InputError(f"{name}: PWM counts 0..255, one for all muscles or one per muscle ({len(self.tendons)})")
        if np.any(~np.isfinite(a)) or a.min() < 0 or a.max() > 255:
            raise InputError(f"{name}: PWM counts must be in 0..255")
        return np.broadcast_to(a.astype(np.int64), (len(self.tendons),))

    def step(self, data, *, inlet=None, bleed=None, reference=None) -> None:
        """One MuJoCo step with the muscles: ``mj_step1``, tensions into the controls, ``mj_step2``, chambers.

        Parameters
        ----------
        data : mujoco.MjData
            The model's data, stepped in place. [-]
        inlet, bleed : int or array_like, optional
            Without a controller: new valve PWM counts (0..255), one or one per muscle, held
            until changed. [counts]
        reference : float or array_like, optional
            With a controller: a new pressure reference, one or one per muscle, held until
            changed. [Pa]
        """
        mujoco = _mujoco()
        if self._spec is None:
            if reference is not None:
                raise InputError("reference: this bank has no controller; give inlet/bleed counts (or a controller)")
            if inlet is not None:
                self.inlet = self._counts(inlet, "inlet").copy()
            if bleed is not None:
                self.bleed = self._counts(bleed, "bleed").copy()
        else:
            if inlet is not None or bleed is not None:
                raise InputError("inlet/bleed: this bank's controller sets the valves; give a reference instead")
            if reference is not None:
                r = np.asarray(reference, dtype=float)
                if r.ndim > 1 or (r.ndim == 1 and r.size != len(self.tendons)) or not np.all(np.isfinite(r)):
                    raise InputError(f"reference: a pressure, or one per muscle ({len(self.tendons)}) [Pa]")
                self.reference = np.array(np.broadcast_to(r, (len(self.tendons),)))
        m = self.model
        mujoco.mj_step1(m, data)
        if self._spec is not None and self.k % self.steps_per_period == 0:
            self._sense(data)
        ten_l = np.asarray(data.ten_length)
        ten_v = np.asarray(data.ten_velocity)
        for b in self.blocks:
            ids = self.tendon_ids[b.lanes]
            b.length[:] = ten_l[ids] - self.offset[b.lanes]
            b.velocity[:] = ten_v[ids]
            _exchange(b.lanes.size, b.bk, b.law, b.length, b.velocity, self.inlet[b.lanes].astype(float),
                      self.bleed[b.lanes].astype(float), b.tension)
            self._tension[b.lanes] = b.tension
        data.ctrl[self.actuator_ids] = self._tension
        mujoco.mj_step2(m, data)
        for b in self.blocks:
            ph.advance(b.lanes.size, b.bk, b.law, self.dt / self.substeps, self.substeps)
            self.end_stop[b.lanes] |= (b.length >= self.l_max[b.lanes]) | (b.length <= self.l_min[b.lanes])
        self.k += 1
        self.t = self.k * self.dt


# --- the documented example: a mass hanging from one muscle -------------------------------------------


def hanging_mass_mjcf(plant: PP.PlantParams, load: float, timestep: float = 1e-4) -> str:
    """MJCF of a mass hanging from one muscle: a fixed anchor, a tendon, a slider with the rig's mass and damping.

    The plant's rig in MuJoCo: the muscle hangs from a site at the origin; the load body slides
    along z with the rig's moving mass (pulley, belt, muscle end) plus the hanging mass
    (``load``/g) and the rig's viscous damping, and only the hanging mass weighs (MuJoCo's
    ``gravcomp`` takes the moving mass's weight off: in the plant it moves but does not hang).
    Its start is the muscle's rest length below the anchor. Gravity is 9.80665 m/s², along −z.

    Parameters
    ----------
    plant : PlantParams
        The muscle's plant (its rest length, moving mass and damping are used). [-]
    load : float
        Hanging weight. [N]
    timestep : float, default 1e-4
        MuJoCo's time step. [s]

    Returns
    -------
    str
        MJCF text with the tendon ``muscle`` and its actuator.
    """
    l0 = float(plant.nominal_length)
    mass = float(plant.moving_mass) + load / PK.G
    comp = float(plant.moving_mass) / mass
    return f"""<mujoco model="hanging mass">
  <option timestep="{timestep!r}" gravity="0 0 {-PK.G!r}" integrator="Euler"/>
  <worldbody>
    <site name="anchor" pos="0 0 0" size="0.001"/>
    <body name="load" pos="0 0 {-l0!r}" gravcomp="{comp!r}">
      <joint name="drop" type="slide" axis="0 0 1" damping="{float(plant.damping)!r}"/>
      <geom type="sphere" size="0.004" mass="{mass!r}"/>
      <site name="hook" pos="0 0 0" size="0.001"/>
    </body>
  </worldbody>
  <tendon>
    <spatial name="muscle">
      <site site="anchor"/>
      <site site="hook"/>
    </spatial>
  </tendon>
  <actuator>
    <general name="muscle" tendon="muscle" gear="-1"/>
  </actuator>
</mujoco>
"""

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
from mckibben._jit import njit
from mckibben import control
from mckibben.control.core import CoreParams, core_spec
from mckibben.data.io import MuscleSpec
from mckibben.datasets import get_muscle
from mckibben.errors import ArgumentTypeError, InputError, check_real
from mckibben.models import laws as LW
from mckibben.models.law_statics import LawMuscle
from mckibben.models.mpam import MiniatureMuscle, predict_length
from mckibben.plant import params as PP
from mckibben.plant import physics as ph
from mckibben.plant.simulator import static_equilibrium
from mckibben.results import Result
from mckibben.units import si

__all__ = ["MuscleBank", "HangingMassResult", "MuscleRunResult", "hanging_mass", "hanging_mass_mjcf", "load_model",
           "muscle_plant", "run_model", "MUJOCO_HINT"]

#: How to install the optional dependency (every error about a missing ``mujoco`` says it).
MUJOCO_HINT = "pip install 'mckibben[mujoco]'"
#: Packed parameter columns read here, by name (:class:`mckibben.plant.params.Col`).
_COL = {name: int(PP.Col[name]) for name in ("supply_pressure", "l_min", "l_max", "temperature", "nominal_length",
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
        fitted muscle file (a ``.toml`` path, its :class:`~mckibben.data.io.MuscleSpec`, or a
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


@njit(error_model="numpy")
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
        :func:`mckibben.plant.params.check_force_law`). [Pa]
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
                PP.check_force_law(name, prm, th, plant._law_label(), pressure_floor=floor)
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
        s0 = np.zeros((lanes.size, ph.NS))
        s0[:, ph.S_P] = p0[lanes] + ph.P_ATM
        s0[:, ph.S_T] = prm[:, _COL['temperature']]
        s0[:, ph.S_LEN] = prm[:, _COL['nominal_length']]
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
    mass = float(plant.moving_mass) + load / PP.G
    comp = float(plant.moving_mass) / mass
    return f"""<mujoco model="hanging mass">
  <option timestep="{timestep!r}" gravity="0 0 {-PP.G!r}" integrator="Euler"/>
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


@dataclass(frozen=True, eq=False)
class HangingMassResult(Result):
    """A mass hanging from one muscle in MuJoCo, its pressure held by a controller: the static length.

    Attributes
    ----------
    time : numpy.ndarray
        Sample times (every control period). [s]
    pressure, length, tension : numpy.ndarray
        Chamber gauge pressure [Pa], muscle length [m] and tension [N] at each sample.
    muscle : str
        The muscle's name. [-]
    load : float
        Hanging weight. [N]
    reference : float
        Pressure reference. [Pa]
    predicted_length : float
        ``mckibben predict length`` at the held pressure and the load (eq. 2+3). [m]
    plant_length : float
        The plant's own static length at the held pressure (its force law, no friction). [m]
    arguments : dict
        The call's arguments, SI. [-]
    """

    time: np.ndarray
    pressure: np.ndarray
    length: np.ndarray
    tension: np.ndarray
    muscle: str
    load: float
    reference: float
    predicted_length: float
    plant_length: float
    arguments: dict = field(default_factory=dict)
    call = "mckibben.export.mujoco.hanging_mass"

    @property
    def metrics(self) -> dict:
        """Static length and pressure (mean of the last 10 % of the run) against the static predictions."""
        tail = self.time >= 0.9 * self.time[-1]
        length = float(np.mean(self.length[tail]))
        return {"static_length_m": length, "held_pressure_Pa": float(np.mean(self.pressure[tail])),
                "predicted_length_m": self.predicted_length,
                "length_error_vs_predict_pct": 100.0 * (length / self.predicted_length - 1.0),
                "plant_static_length_m": self.plant_length,
                "length_error_vs_plant_pct": 100.0 * (length / self.plant_length - 1.0),
                "tension_N": float(np.mean(self.tension[tail]))}

    def _series(self):
        import pandas as pd

        return pd.DataFrame({"time_s": self.time, "pressure_Pa": self.pressure, "length_m": self.length,
                             "tension_N": self.tension})

    def plot(self, ax=None):
        """Length against the predicted static length, and pressure, over time.

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Where to draw the length; default a new figure (pressure on a twin axis). [-]
        """
        import matplotlib.pyplot as plt

        if ax is None:
            fig, ax = plt.subplots(figsize=(7, 4))
        ax.plot(self.time, self.length * 1e3, label="MuJoCo length")
        ax.axhline(self.predicted_length * 1e3, color="k", ls="--", lw=1, label="predict length (eq. 2+3)")
        ax.set_xlabel("time [s]")
        ax.set_ylabel("length [mm]")
        ax2 = ax.twinx()
        ax2.plot(self.time, self.pressure / 1e6, color="C1", lw=1, label="pressure")
        ax2.set_ylabel("pressure [MPa]")
        ax.legend(loc="upper right", fontsize=8)
        ax.set_title(f"{self.muscle} holding {self.load:g} N in MuJoCo")
        return ax.figure


def hanging_mass(muscle="mpam97", pressure=0.4e6, load=0.6, *, force_model: str | None = None,
                 controller="smc", duration=1.5, timestep=1e-4, friction: bool = True) -> HangingMassResult:
    """A mass hanging from one muscle in MuJoCo, the pressure held by a registry controller.

    The muscle starts at its rest length and its chamber at ``pressure``; the controller holds
    the pressure while the load settles; the result compares the settled length with
    :func:`mckibben.models.mpam.predict_length` (``mckibben predict length``) and with the
    plant's own static length at the held pressure.

    Parameters
    ----------
    muscle : str or MiniatureMuscle, default "mpam97"
        A published set. [-]
    pressure : float, default 0.4e6
        Pressure reference (gauge). [Pa]
    load : float, default 0.6
        Hanging weight. [N]
    force_model : str, optional
        ``"calibrated"`` (default) or ``"empirical"`` (:func:`muscle_plant`). [-]
    controller : str, default "smc"
        A controller of the registry. [-]
    duration : float, default 1.5
        Simulated time. [s]
    timestep : float, default 1e-4
        MuJoCo's step (the plant's own RK4 step), at most the control period. [s]
    friction : bool, default True
        The braid's friction (the plant's Dahl element, ``docs/plant.md``); False turns it off,
        leaving the frictionless statics that predict length and the plant's static length solve. [-]

    Returns
    -------
    HangingMassResult
    """
    mujoco = _mujoco()
    m_obj = get_muscle(muscle) if isinstance(muscle, str) else muscle
    if not isinstance(m_obj, MiniatureMuscle):
        raise ArgumentTypeError("muscle: a published set (mpam97, mpam117, mpam143): predict length needs its eq. 2+3")
    pressure = si(pressure, "pressure", "pressure", allow_zero=False)
    load = si(load, "force", "load", allow_zero=False)
    duration = si(duration, "time", "duration", allow_zero=False)
    timestep = check_real(si(timestep, "time", "timestep", allow_zero=False), "timestep",
                          hi=HW.CONTROL_PERIOD, unit="s")
    plant = muscle_plant(m_obj, force_model, **({} if friction else {"friction_force": 0.0, "friction_per_pa": 0.0}))
    model = load_model(hanging_mass_mjcf(plant, load, timestep))
    data = mujoco.MjData(model)
    # the braid-angle maps pull less when stretched below ~0.25 MPa: checked over the held pressures only
    floor = 0.9 * pressure if force_model == "empirical" else 0.0
    # the supervisor's p_max at the transducer's full scale: its headroom cap holds a chamber some tens
    # of kPa below p_max (docs/controller.md, 2b), and this rig holds `pressure`, the calibration
    # point 0.8 MPa included (the 0.8 MPa supply bounds the chamber)
    ctrl = (control.experiment_setup.controller_params(controller, p_max=HW.P_MAX_LIMIT)
            if isinstance(controller, str) else controller)
    bank = MuscleBank(model, ["muscle"], plant, controller=ctrl, initial_pressure=pressure, pressure_floor=floor)
    n = int(round(duration / timestep))
    every = bank.steps_per_period
    t, p, ln, f = [], [], [], []
    for k in range(n):
        bank.step(data, reference=pressure if k == 0 else None)
        if k % every == every - 1:
            t.append(bank.t)
            p.append(bank.pressure[0])
            ln.append(bank.length(data)[0])
            f.append(bank.tension[0])
    p_arr = np.array(p)
    tail = np.array(t) >= 0.9 * t[-1]
    held = float(np.mean(p_arr[tail]))
    predicted = float(predict_length(m_obj, held, load).length)
    prm = plant.replace(load_force=load).pack(1)
    name, th = plant.law(1)
    plant_len = float(static_equilibrium(prm, LW.LAW_INDEX[name], th, held)[0][0])
    return HangingMassResult(np.array(t), p_arr, np.array(ln), np.array(f), m_obj.name, float(load), float(pressure),
                             predicted, plant_len,
                             {"muscle": m_obj.name, "pressure_Pa": pressure, "load_N": load,
                              "force_model": force_model or "calibrated", "controller": controller,
                              "duration_s": duration, "timestep_s": timestep, "friction": bool(friction)})


# --- any model: its muscles under valve counts or a controller ----------------------------------------


@dataclass(frozen=True, eq=False)
class MuscleRunResult(Result):
    """A MuJoCo model run with muscles on some of its tendons (:func:`run_model`).

    Attributes
    ----------
    time : numpy.ndarray
        Sample times (every control period), (n,). [s]
    pressure, length, tension : numpy.ndarray
        Each muscle's gauge pressure [Pa], length [m] and tension [N], (n, M).
    tendons : tuple of str
        The muscles' tendons. [-]
    end_stop : numpy.ndarray
        Per muscle: whether it reached an end stop of its braid. [-]
    faults : numpy.ndarray
        Per muscle: OR of the controller's fault flags (0 without a controller). [-]
    arguments : dict
        The call's arguments, SI. [-]
    """

    time: np.ndarray
    pressure: np.ndarray
    length: np.ndarray
    tension: np.ndarray
    tendons: tuple
    end_stop: np.ndarray
    faults: np.ndarray
    arguments: dict = field(default_factory=dict)
    call = "mckibben.export.mujoco.run_model"

    @property
    def metrics(self) -> dict:
        """Each muscle's final pressure, length and tension, its end-stop flag and faults (lists, tendon order)."""
        return {"tendons": list(self.tendons), "final_pressure_Pa": self.pressure[-1].tolist(),
                "final_length_m": self.length[-1].tolist(), "final_tension_N": self.tension[-1].tolist(),
                "end_stop": self.end_stop.tolist(), "controller_faults": self.faults.tolist()}

    def _series(self):
        import pandas as pd

        data = {"time_s": self.time}
        for i, name in enumerate(self.tendons):
            data[f"{name}_pressure_Pa"] = self.pressure[:, i]
            data[f"{name}_length_m"] = self.length[:, i]
            data[f"{name}_tension_N"] = self.tension[:, i]
        return pd.DataFrame(data)

    def plot(self, ax=None):
        """Each muscle's pressure and length over time.

        Parameters
        ----------
        ax : sequence of two matplotlib.axes.Axes, optional
            Where to draw pressure and length; default a new figure. [-]
        """
        import matplotlib.pyplot as plt

        if ax is None:
            fig, axes = plt.subplots(2, 1, figsize=(7, 5), sharex=True)
        else:
            axes = list(ax)
        for i, name in enumerate(self.tendons):
            axes[0].plot(self.time, self.pressure[:, i] / 1e6, label=name)
            axes[1].plot(self.time, self.length[:, i] * 1e3, label=name)
        axes[0].set_ylabel("pressure [MPa]")
        axes[1].set_ylabel("muscle length [mm]")
        axes[1].set_xlabel("time [s]")
        axes[0].legend(fontsize=8)
        return axes[0].figure


def run_model(model, tendons, muscle="mpam97", *, reference=None, inlet=None, bleed=0, controller="smc",
              duration=1.0, initial_pressure=0.0, offset=0.0, force_model: str | None = None) -> MuscleRunResult:
    """Run a MuJoCo model with muscles on some of its tendons: a pressure reference held, or valve counts.

    Parameters
    ----------
    model : str, os.PathLike or mujoco.MjModel
        An MJCF file (or text, or a compiled model) whose tendons carry ``<general tendon="T"
        gear="-1"/>`` actuators (:class:`MuscleBank`). [-]
    tendons : str or sequence of str
        The muscles' tendons (text: comma-separated). [-]
    muscle : str, muscle or PlantParams, default "mpam97"
        For every tendon (:func:`muscle_plant`); a ``.toml`` path is a fitted muscle file. [-]
    reference : float or sequence, optional
        Pressure held by ``controller``, one or one per muscle (``0.5e6``, ``[0.3e6, 0.5e6]``). [Pa]
    inlet, bleed : int or sequence, optional
        Without ``reference``: valve PWM counts held over the run, one or one per muscle. [counts]
    controller : str, default "smc"
        The registry's controller for ``reference`` (``smc``, ``pid``). [-]
    duration : float, default 1.0
        Simulated time. [s]
    initial_pressure : float or sequence, default 0.0
        Each chamber's gauge pressure at the start. [Pa]
    offset : float or sequence, default 0.0
        Tendon length that is not muscle, one or one per muscle. [m]
    force_model : str, optional
        A published set's law: ``"calibrated"`` or ``"empirical"`` (:func:`muscle_plant`). [-]

    Returns
    -------
    MuscleRunResult
        Sampled every control period (1 ms).
    """
    mujoco = _mujoco()
    names = [t.strip() for t in tendons.split(",")] if isinstance(tendons, str) else list(tendons)
    duration = si(duration, "time", "duration", allow_zero=False)
    if (reference is None) == (inlet is None):
        raise InputError("reference/inlet: give either a pressure reference or valve counts, not both or neither")

    def values(x, dimension, name):
        if isinstance(x, str):
            si(x, dimension, name)  # text: refused with the number to pass
        return np.array([si(v, dimension, name) for v in np.ravel(x)])

    p0 = values(initial_pressure, "pressure", "initial_pressure")
    off = values(offset, "length", "offset")
    ctrl = controller if reference is not None else None
    bank = MuscleBank(model, names, muscle, force_model=force_model, controller=ctrl,
                      initial_pressure=p0 if p0.size > 1 else float(p0[0]), offset=off if off.size > 1 else float(off[0]))
    m = bank.model
    data = mujoco.MjData(m)
    n_periods = int(round(duration / bank.ts))
    if n_periods < 1:
        raise InputError(f"duration: {duration:g} s is shorter than one control period ({bank.ts:g} s)")
    if reference is not None:
        ref = values(reference, "pressure", "reference")
        first = {"reference": ref if ref.size > 1 else float(ref[0])}
    else:
        first = {"inlet": _count_list(inlet, "inlet"), "bleed": _count_list(bleed, "bleed")}
    mujoco.mj_forward(m, data)
    t, p, ln, f = [], [], [], []
    for k in range(n_periods):
        t.append(bank.t)
        p.append(bank.pressure)
        ln.append(bank.length(data))
        f.append(bank.tension)
        for s in range(bank.steps_per_period):
            bank.step(data, **(first if k == 0 and s == 0 else {}))
    return MuscleRunResult(np.array(t), np.array(p), np.array(ln), np.array(f), tuple(names), bank.end_stop.copy(),
                           bank.faults.copy(),
                           {"model": _model_label(model),
                            "tendons": names, "muscle": str(muscle), "duration_s": duration,
                            "controller": ctrl, "force_model": force_model or "calibrated"})


def _count_list(value, name: str) -> np.ndarray:
    """PWM counts from a number or a sequence (checked 0..255 by the bank)."""
    if isinstance(value, str):
        raise ArgumentTypeError(f"{name} = {value!r}: the library takes PWM counts as numbers, one or one per muscle, "
                                "not text")
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name}: {value!r} is not a PWM count 0..255 (or one per muscle)") from None


def _model_label(model) -> str:
    if isinstance(model, (str, os.PathLike)) and not os.fspath(model).lstrip().startswith("<"):
        return os.fspath(model)
    return "MJCF text" if isinstance(model, str) else type(model).__name__

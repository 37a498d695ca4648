"""The endoscope in MuJoCo: spacer discs on a flexible backbone, three muscles as tendons through the holes.

:func:`endoscope_mjcf` writes the MJCF of a :class:`~mckibben.tool.geometry.Tool` from its own
geometry and load model (nothing copied by hand):

- the base disc is fixed at the origin, z along the straight tool, muscle 1 on +x
  (:data:`~mckibben.tool.geometry.MUSCLE_ANGLES`, the holes on the pitch circle);
- each of the ``n = n_discs − 1`` gaps is two bodies: from the previous disc it goes half a gap
  along the backbone to the gap's body (its share of backbone and muscles), bends there at a
  **ball joint** and goes the other half to the next disc's body
  (a constant-curvature arc of n segments as a chain: the rigid-link equivalent of an arc bent
  by α is two half-gaps of (h/2)·tan(α/2)/(α/2), which differs from h/2 by 6·10⁻⁶ at the
  tool's 0.5° per gap); a **slide joint** on each half (before and after the ball) lets the
  gap lengthen, and joint equalities keep every half equal (the arc's even spacing);
- the backbone's bending moment ``Kb·κ`` is the ball joints' stiffness ``Kb/h`` (a gap of
  length h bent by α has κ = α/h); its compression, the load model's ``A = 3·F0 +
  Ka·(s_ref − s)/s_ref`` (:func:`~mckibben.tool.statics.muscle_tensions`), is applied to the
  slides as a generalized force each step (it is a constant force when Ka = 0, which no
  MuJoCo spring is);
- a chain bends at points: the muscles' pull (A in all) runs along chords that pass h·α/4 from
  each joint, a lever arm that the constant-curvature model (tendons parallel to the backbone)
  does not have and that would soften the bend by A·h²/(4·Kb) (a third at the default 13 discs
  and 3 N). The ball joints' stiffness adds ``A·h/4`` (A at the model's arc length) to cancel it,
  so that the chain's statics are the quasi-static tool's;
- each muscle is a spatial tendon through its hole in every disc (the chords between discs of
  :func:`~mckibben.tool.kinematics.lengths_from_arc`), with a ``general`` actuator (gear −1)
  whose control is the muscle's tension (:class:`mckibben.export.mujoco.MuscleBank`).

What the paper does not give and is chosen here (:class:`MujocoTool`): the discs' mass (1 mm
thick, a printed polymer), the mass per length of backbone and muscles, the damping (a ratio of
the backbone's first bending mode) and gravity (off: the quasi-static tool has none).

:func:`simulate_tracking_mujoco` steers the model through the same references and controllers
as the quasi-static :func:`~mckibben.tool.tracking.simulate_tracking` and returns the same
:class:`~mckibben.tool.tracking.TrackingResult`, the achieved tip being MuJoCo's tip disc.

References
----------
[mpam-characterization] §V; [webster2010] Webster, R. J. & Jones, B. A. (2010), Design and kinematic modeling of
constant curvature continuum robots, IJRR 29(13); /work/shared/notes/continuum-kinematics.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mckibben.control.core import core_spec
from mckibben.errors import InputError
from mckibben.export.mujoco import MuscleBank, load_model, muscle_plant
from mckibben.export.mujoco import _mujoco as _load_mujoco
from mckibben.models.law_statics import LawMuscle
from mckibben.tool.geometry import MIN_DISC_GAP, MUSCLE_ANGLES, Tool
from mckibben.tool.tracking import TRACKING_BETA, TrackingResult, tracking_setup

__all__ = ["MujocoTool", "endoscope_mjcf", "simulate_tracking_mujoco", "backbone_mode"]


@dataclass(frozen=True)
class MujocoTool:
    """What the MuJoCo endoscope needs beyond the tool: masses, damping, time step, gravity.

    Attributes
    ----------
    disc_thickness : float, default 1 mm
        Thickness of a spacer disc (the closest gap, :data:`MIN_DISC_GAP`). [m]
    disc_density : float, default 1200
        Density of the discs: a printed polymer (resin, ABS). [kg/m³]
    line_density : float, default 0.01
        Mass per length of backbone and the three muscles, lumped at the middle of each gap (a
        4 mm polymer tube and three 1.2 mm muscles weigh about 10 g/m); > 0, or the two slides
        of a gap would move the same mass alike (a singular inertia matrix). [kg/m]
    damping_ratio : float, default 0.3
        Damping of the backbone's first bending mode (:func:`backbone_mode`): the ball joints'
        damping is ``2·ζ/ω1`` times their stiffness (stiffness-proportional), the slides' the
        same per unit of the muscles' axial stiffness. [-]
    timestep : float, default 1e-4
        MuJoCo's step, the plant's own RK4 step. [s]
    gravity : bool, default False
        Gravity along −z (the tool pointing up); off, as in the quasi-static tool. [-]
    """

    disc_thickness: float = MIN_DISC_GAP
    disc_density: float = 1200.0
    line_density: float = 0.01
    damping_ratio: float = 0.3
    timestep: float = 1e-4
    gravity: bool = False

    def __post_init__(self):
        for name in ("disc_thickness", "disc_density", "timestep", "line_density"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise InputError(f"{name}: {v!r} must be > 0")
        for name in ("damping_ratio",):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise InputError(f"{name}: {v!r} must be >= 0")

    def disc_mass(self, tool: Tool, gap: float) -> float:
        """Mass of one disc with its share (one gap) of backbone and muscles. [kg]

        Parameters
        ----------
        tool : Tool
            The tool (disc, hole and channel diameters). [-]
        gap : float
            Length of one gap. [m]
        """
        g = tool.geometry
        area = 0.25 * math.pi * (g.disc_diameter**2 - g.channel_diameter**2 - 3 * g.hole_diameter**2)
        return self.disc_density * area * self.disc_thickness + self.line_density * gap


def _gaps(tool: Tool) -> int:
    n = tool.geometry.n_gaps
    if n is None:
        raise InputError("discs: the MuJoCo endoscope is a chain of discs; give a number of discs, not 'continuous'")
    return int(n)


def backbone_mode(tool: Tool, settings: MujocoTool = MujocoTool(), arc_length: float | None = None) -> float:
    """First bending mode of the backbone alone (a uniform cantilever of the discs' mass). [rad/s]

    ω1 = 1.8751²·√(Kb/(μ·s⁴)), μ the mass per length of discs, backbone and muscles.

    Parameters
    ----------
    tool : Tool
        The tool (bending stiffness Kb). [-]
    settings : MujocoTool
        Masses. [-]
    arc_length : float, optional
        Backbone length s; default the tool's reference length. [m]
    """
    s = tool.reference_length if arc_length is None else float(arc_length)
    n = _gaps(tool)
    mu = settings.disc_mass(tool, s / n) * n / s
    return 1.8751**2 * math.sqrt(tool.load.bending_stiffness / (mu * s**4))


def _muscle_stiffness(tool: Tool, pressure: float) -> float:
    """Axial stiffness of one muscle at a pressure under the preload, from the tool's static model. [N/m]"""
    f0 = max(tool.load.preload, 0.1)
    df = 0.05 * f0
    lengths = tool.muscle.length_for_pressure(np.array([pressure, pressure]), np.array([f0 - df, f0 + df])).length
    dl = float(lengths[1] - lengths[0])
    return 2 * df / dl if dl > 0 else 0.0


def endoscope_mjcf(tool: Tool, arc_length: float | None = None, settings: MujocoTool = MujocoTool(),
                   pressure: float | None = None) -> str:
    """MJCF of the endoscope: discs on a ball-jointed, extensible backbone, three muscles as tendons.

    Parameters
    ----------
    tool : Tool
        Geometry (discs, holes, pitch radius), load model (Kb) and muscle. [-]
    arc_length : float, optional
        Backbone length the joints' stiffness is set for (Kb/h with h = s/n) and the chain is
        built at; default the tool's reference length. Give the path's arc length for tracking. [m]
    settings : MujocoTool
        Masses, damping, time step, gravity. [-]
    pressure : float, optional
        Pressure at which the muscles' axial stiffness sets the slides' damping; default p_max/2. [Pa]

    Returns
    -------
    str
        MJCF text: bodies ``gap1``, ``disc1`` .. ``gapN``, ``discN``; joints ``ext*a``,
        ``ext*b`` (slides, before and after the bend) and ``bend*`` (ball); tendons and
        actuators ``muscle1`` .. ``muscle3``; site ``tip``.
    """
    n = _gaps(tool)
    s = tool.reference_length if arc_length is None else float(arc_length)
    if not (math.isfinite(s) and s > 0):
        raise InputError(f"arc_length: {arc_length!r} must be a positive length [m]")
    h = s / n
    g = tool.geometry
    r = float(g.pitch_radius)  # type: ignore[arg-type]  # set by ToolGeometry.__post_init__
    # the backbone's Kb/h, plus the kink's correction: a chain bends at points, so the muscles' pull
    # (A in all, along chords that miss the joint by h·α/4) has a lever arm h·α/4 there that the
    # constant-curvature model, whose tendons run parallel to the backbone, does not have
    load = tool.load
    compression = 3.0 * load.preload + load.axial_stiffness * (tool.reference_length - s) / tool.reference_length
    k_bend = load.bending_stiffness / h + compression * h / 4.0
    beta = 2.0 * settings.damping_ratio / backbone_mode(tool, settings, s)
    d_bend = beta * k_bend
    p = 0.5 * tool.p_max if pressure is None else float(pressure)
    # a slide stretches all three muscles by its extension (2n slides, held equal): 3·k_m·2n per slide
    d_ext = beta * 3.0 * _muscle_stiffness(tool, p) * 2 * n
    mass = settings.disc_mass(tool, 0.0)  # the disc alone
    rad, half_t = 0.5 * g.disc_diameter, 0.5 * settings.disc_thickness
    # a thin disc's inertia (MuJoCo's own for a cylinder of this mass)
    ixx = mass * (3 * rad**2 + settings.disc_thickness**2) / 12.0
    izz = 0.5 * mass * rad**2
    holes = [(r * math.cos(a), r * math.sin(a)) for a in MUSCLE_ANGLES]

    def sites(k: int, z: float) -> str:
        return "".join(f'<site name="h{i + 1}_{k}" pos="{x!r} {y!r} {z!r}" size="0.0005"/>'
                       for i, (x, y) in enumerate(holes))

    bodies = []
    m_gap = settings.line_density * h  # the gap's backbone and muscles, at its middle (the bend)
    i_gap = m_gap * h**2 / 12.0
    i_axial = 0.5 * m_gap * (0.5 * g.channel_diameter) ** 2
    for k in range(1, n + 1):
        tip = '<site name="tip" pos="0 0 0" size="0.001"/>' if k == n else ""
        bodies.append(
            f'<body name="gap{k}" pos="0 0 {h / 2!r}">'
            f'<joint name="ext{k}a" type="slide" axis="0 0 1" damping="{d_ext!r}"/>'
            f'<joint name="bend{k}" type="ball" stiffness="{k_bend!r}" damping="{d_bend!r}"/>'
            f'<inertial pos="0 0 0" mass="{m_gap!r}" diaginertia="{i_gap!r} {i_gap!r} {i_axial!r}"/>'
            f'<body name="disc{k}" pos="0 0 {h / 2!r}">'
            f'<joint name="ext{k}b" type="slide" axis="0 0 1" damping="{d_ext!r}"/>'
            f'<geom type="cylinder" size="{rad!r} {half_t!r}" contype="0" conaffinity="0"/>'
            f'<inertial pos="0 0 0" mass="{mass!r}" diaginertia="{ixx!r} {ixx!r} {izz!r}"/>'
            f'{sites(k, 0.0)}{tip}')
    chain = "\n".join(bodies) + "</body>" * (2 * n)
    tendons = "\n".join(
        f'<spatial name="muscle{i + 1}" width="0.0006">'
        + "".join(f'<site site="h{i + 1}_{k}"/>' for k in range(n + 1)) + "</spatial>" for i in range(3))
    actuators = "\n".join(f'<general name="muscle{i + 1}" tendon="muscle{i + 1}" gear="-1"/>' for i in range(3))
    equal = "\n".join(f'<joint joint1="{j}" joint2="ext1a"/>' for j in _slides(n)[1:])
    gz = -9.80665 if settings.gravity else 0.0
    return f"""<mujoco model="endoscope {tool.muscle.name}">
<!-- generated by mckibben.tool.mujoco_model.endoscope_mjcf: {n + 1} discs, pitch radius {r * 1e3:g} mm,
     Kb {tool.load.bending_stiffness:g} N m2, backbone length {s * 1e3:g} mm -->
<option timestep="{settings.timestep!r}" gravity="0 0 {gz!r}" integrator="implicitfast"/>
<worldbody>
<body name="disc0">
<geom type="cylinder" size="{rad!r} {half_t!r}" contype="0" conaffinity="0" mass="{mass!r}"/>
{sites(0, 0.0)}
{chain}
</body>
</worldbody>
<equality>
{equal}
</equality>
<tendon>
{tendons}
</tendon>
<actuator>
{actuators}
</actuator>
</mujoco>
"""


def _slides(n: int) -> list[str]:
    """Names of the slide joints of an n-gap chain, in order (two per gap)."""
    return [f"ext{k}{half}" for k in range(1, n + 1) for half in "ab"]


def _pose(model, data, tool: Tool, arc, s_model: float) -> None:
    """Put the chain in the pose of an arc (evenly spaced gaps, equal bends) and compute its kinematics."""
    mujoco = _load_mujoco()
    n = _gaps(tool)
    e = (float(arc.arc_length) - s_model) / (2 * n)
    w = np.array([-float(arc.theta_y), float(arc.theta_x), 0.0]) / n  # rotation vector per gap
    for name in _slides(n):
        data.qpos[model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)]] = e
    for k in range(1, n + 1):
        bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, f"bend{k}")
        q = np.empty(4)
        mujoco.mju_axisAngle2Quat(q, w / (np.linalg.norm(w) or 1.0), float(np.linalg.norm(w)))
        adr = model.jnt_qposadr[bid]
        data.qpos[adr:adr + 4] = q
    mujoco.mj_forward(model, data)


def simulate_tracking_mujoco(tool: Tool, runs, *, beta: float = TRACKING_BETA,
                             settings: MujocoTool = MujocoTool()) -> list[TrackingResult]:
    """Follow each run's pressure references with the endoscope in MuJoCo: the same controllers as the quasi-static run.

    The references and the controllers (their identified model and gains) are those of
    :func:`~mckibben.tool.tracking.simulate_tracking` (:func:`~mckibben.tool.tracking.tracking_setup`).
    Each muscle is a :class:`~mckibben.export.mujoco.MuscleBank` muscle pulling with the law of
    the tool's statics (a published set's braid-angle map, eq. 2+3; a muscle file's fitted law),
    so a slow run agrees with the quasi-static tool; the tip is MuJoCo's tip disc, sampled at
    each control period. The chain starts in the pose of the first target at the first
    reference pressures.

    Parameters
    ----------
    tool : Tool
        The tool. [-]
    runs : list of (TipPath, TipReference)
        Paths and their references (:func:`~mckibben.tool.tracking.tip_reference`). [-]
    beta : float, default TRACKING_BETA
        Switching gain of the three controllers. [PWM counts]
    settings : MujocoTool
        Masses, damping, time step, gravity. [-]

    Returns
    -------
    list of TrackingResult
        One per run; ``achieved`` is MuJoCo's tip.
    """
    mujoco = _load_mujoco()
    _gaps(tool)  # a chain of discs (refused before any work for the continuous limit)
    results = []
    models: dict = {}
    force_model = None if isinstance(tool.muscle, LawMuscle) else "empirical"
    # the law of the tool's statics is the whole measured force (eq. 2+3 or a fitted law, measured
    # with the braid's friction and the tube's stretch in it), as a muscle file's plant has it
    plant = muscle_plant(tool.muscle, force_model, friction_force=0.0, friction_per_pa=0.0, passive_stiffness=0.0)
    for path, ref in runs:
        _, params, ident, loads = tracking_setup(tool, ref, beta, models)
        s_model = float(np.mean(ref.state.arc.arc_length))
        p_lo = float(np.min(ref.pressures))
        model = load_model(endoscope_mjcf(tool, s_model, settings, float(np.mean(ref.pressures))))
        data = mujoco.MjData(model)
        arc0 = type(ref.state.arc)(ref.state.arc.arc_length[0], ref.state.arc.theta_x[0], ref.state.arc.theta_y[0])
        _pose(model, data, tool, arc0, s_model)
        bank = MuscleBank(model, ["muscle1", "muscle2", "muscle3"], plant,
                          controller=core_spec(params, 3), initial_pressure=ref.pressures[0],
                          pressure_floor=0.8 * p_lo)
        ids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name) for name in _slides(_gaps(tool))]
        slides = np.array([model.jnt_dofadr[j] for j in ids])
        slide_q = np.array([model.jnt_qposadr[j] for j in ids])
        tip_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "tip")
        load = tool.load
        s_ref = tool.reference_length
        n_samples = ref.time.size
        per = bank.steps_per_period
        achieved = np.empty((n_samples, 3))
        pressure = np.empty((n_samples, 3))
        for k in range(n_samples):
            achieved[k] = data.site_xpos[tip_id]
            pressure[k] = bank.pressure
            s = s_model + float(np.sum(data.qpos[slide_q]))
            data.qfrc_applied[slides] = 3.0 * load.preload + load.axial_stiffness * (s_ref - s) / s_ref
            bank.step(data, reference=ref.pressures[k])
            for _ in range(per - 1):
                bank.step(data)
        if not np.all(np.isfinite(achieved)):
            raise InputError("engine: the MuJoCo model diverged (non-finite tip); "
                             "use a shorter time step (MujocoTool.timestep)")
        results.append(TrackingResult(ref.time, ref.target, achieved, ref.pressures, pressure, loads, float(beta),
                                      float(ident.gain), float(ident.tau), int(np.bitwise_or.reduce(bank.faults))))
    return results

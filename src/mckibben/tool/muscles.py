"""A lab's own muscle in the tool: a fitted muscle file's force law as the tool's muscle, and a tool sized for it.

``make_tool(muscle_file="my.toml")`` (``mckibben tool … --muscle-file my.toml``) puts three
muscles of a fitted muscle file (``mckibben fit ISO.csv --model … --save my.toml``) in the tool.
Their statics are the file's force law solved for pressure and for length
(:class:`mckibben.models.law_statics.LawMuscle`); tracking runs the same file's plant
(:meth:`mckibben.plant.PlantParams.from_muscle_file`). What is assumed, and why, is in
docs/tool.md ("A lab's own muscle").
"""

from __future__ import annotations

import dataclasses

import numpy as np

from mckibben.errors import InputError
from mckibben.models.geometry import MiniatureGeometry
from mckibben.models.law_statics import LawMuscle
from mckibben.models.muscle import Muscle
from mckibben.tool.geometry import DEFAULT_MUSCLE, StackLoad, ToolGeometry
from mckibben.datasets import get_muscle
from mckibben.data.muscle_file import MuscleSpec, read_muscle
from mckibben.fit.muscle_file import check_direction, muscle_force_law
from mckibben.plant import PlantParams

def paper_bending_number() -> float:
    """Dimensionless bending stiffness of the paper's tool with its defaults, Kb/(F0·r·L0). [-]

    From the defaults themselves (:class:`StackLoad`, :class:`ToolGeometry`, the
    :data:`DEFAULT_MUSCLE`): 2e-4 N·m² / (1 N · 4 mm · 117 mm) = 0.427. A file's tool keeps it
    (see :func:`file_load`).
    """

    load = StackLoad()
    return load.bending_stiffness / (load.preload * ToolGeometry().pitch_radius
                                     * get_muscle(DEFAULT_MUSCLE).nominal_length)


def file_muscle(muscle_file, direction: str = "inflate") -> LawMuscle:
    """The muscle of a muscle file with a fitted force law, for the tool's statics.

    The law is the file's ``[force_model]`` on the plant's law registry
    (:meth:`mckibben.fit.muscle_file.MuscleForceLaw.plant_law`, the load cell's zero left out);
    its end stops are those of the same file's plant (:meth:`PlantParams.from_muscle_file`: the
    ideal braid of the file's strand length, else of the fitted braid angle, else of the assumed
    20°), so the tool's statics and its tracking plant are one muscle.

    Parameters
    ----------
    muscle_file : str, pathlib.Path, MuscleSpec or Muscle
        A muscle file with a ``[force_model]`` table, or the :class:`~mckibben.models.muscle.Muscle`
        built from one (its own branch). [-]
    direction : {"inflate", "deflate"}, default "inflate"
        The spring law's branch (its hysteresis); the other laws have one, and refuse
        ``deflate`` (:func:`mckibben.fit.muscle_file.check_direction`). [-]

    Returns
    -------
    Muscle
        A :class:`~mckibben.models.law_statics.LawMuscle` with the file's geometry, law, ranges and
        end stops (:mod:`mckibben.models.muscle`).

    Raises
    ------
    InputError
        One line starting ``--muscle-file`` and naming the file: missing, not TOML, no
        ``[force_model]``, the data-driven surface (no physical law), a law the plant cannot run.
    """

    check_direction(direction)
    if isinstance(muscle_file, Muscle):
        where = muscle_file.spec.path or muscle_file.name
    else:
        where = muscle_file.path or muscle_file.id if isinstance(muscle_file, MuscleSpec) else str(muscle_file)
    try:
        if isinstance(muscle_file, Muscle):
            m = muscle_file
        else:
            spec = muscle_file if isinstance(muscle_file, MuscleSpec) else read_muscle(muscle_file)
            check_direction(direction, muscle_force_law(spec))
            m = Muscle.from_spec(spec, direction)
        PlantParams.from_muscle_file(m)  # a law the plant cannot run is refused here as there
    except InputError as exc:
        msg = str(exc)
        raise InputError(msg if msg.startswith("--") else f"muscle_file {where}: {msg}") from None
    if m.pressure_range[1] == np.inf:  # no fitted range saved: the plant's supply bounds it
        m = dataclasses.replace(m, pressure_range=(m.pressure_range[0], float(PlantParams.from_muscle_file(m).supply_pressure)))
    return m


def file_geometry(muscle: LawMuscle, pitch_radius=None, n_discs: int | None = 13) -> ToolGeometry:
    """The paper's disc stack scaled to a muscle's outer diameter (the miniature's is 1.2 mm).

    Disc, holes and channel keep the paper's proportions (§V: 12 mm disc, 2.2 mm holes, 4 mm
    channel around a 1.2 mm muscle), so a 12 mm muscle gets a 120 mm disc with 22 mm holes and a
    40 mm channel; the pitch radius defaults to the middle of the ring, as for the paper's disc.

    Parameters
    ----------
    muscle : LawMuscle
        The muscle (its outer diameter). [-]
    pitch_radius : float, optional
        Radius of the hole circle; default the middle of the scaled ring. [m]
    n_discs : int or None, default 13
        Discs including base and tip; ``None`` is the continuous limit. [-]

    Returns
    -------
    ToolGeometry
    """
    base = ToolGeometry()
    k = muscle.outer_diameter / MiniatureGeometry().outer_diameter
    return ToolGeometry(
        disc_diameter=base.disc_diameter * k, hole_diameter=base.hole_diameter * k,
        channel_diameter=base.channel_diameter * k, pitch_radius=pitch_radius, n_discs=n_discs,
        citation=(f"the paper's §V disc (12 mm, 2.2 mm holes, 4 mm channel around a 1.2 mm muscle) scaled by "
                  f"{k:.4g} to the {muscle.outer_diameter * 1e3:.4g} mm muscle of {muscle.name} (docs/tool.md)"),
    )


def file_load(muscle: LawMuscle, pitch_radius: float, p_max: float) -> dict:
    """Default load model of a file's tool: the straight tool spans the lengths the law was fitted on.

    A commercial muscle's isometric test holds it between its nominal length and a contracted
    length; the law is known only there. The default backbone is a compression spring that
    puts the straight, unpressurized tool at the longest fitted length and the straight tool at
    ``p_max`` at the shortest:

    - ``preload`` F0: the law's pull at the longest fitted length and the lowest fitted pressure
      (the unpressurized muscle's own tension there, ≥ 0);
    - ``reference_length`` s_ref: that longest fitted length;
    - ``axial_stiffness`` Ka: the rise of the backbone's compression from F0 (per muscle) at
      s_ref to the law's pull at ``p_max`` and the shortest fitted length,
      ``Ka = 3·(F(p_max, l_short) − F0)·s_ref/(s_ref − l_short)``;
    - ``bending_stiffness`` Kb: as stiff, relative to the muscles, as the paper's tool with its
      defaults, ``Kb = 0.43·F̄·r·L0`` (:func:`paper_bending_number`), F̄ the mean of the
      straight tool's tensions at both ends of the stroke.

    Parameters
    ----------
    muscle : LawMuscle
        The muscle. [-]
    pitch_radius : float
        Radius of the hole circle. [m]
    p_max : float
        The tool's highest pressure. [Pa]

    Returns
    -------
    dict
        ``preload`` [N], ``bending_stiffness`` [N·m²], ``axial_stiffness`` [N],
        ``reference_length`` [m].
    """
    l_short, l_long = muscle.length_range
    f_long = max(float(muscle.force(muscle.pressure_range[0], l_long)), 0.0)
    f_short = max(float(muscle.force(p_max, l_short)), f_long)
    ka = 3.0 * (f_short - f_long) * l_long / (l_long - l_short) if l_long > l_short else 0.0
    kb = paper_bending_number() * 0.5 * (f_long + f_short) * pitch_radius * muscle.nominal_length
    return {"preload": f_long, "bending_stiffness": kb, "axial_stiffness": ka, "reference_length": l_long}

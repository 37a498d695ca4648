"""Run the whole characterization of a campaign folder: every fit, every muscle, the comparison.

A campaign folder holds one sub-folder per muscle with its ``muscle.toml`` and any of the
experiment files ``blocked_force``, ``isotonic``, ``braid_angle``, ``hysteresis``,
``force_length``, ``step_response`` (``.csv`` or ``.parquet``). Missing experiments are skipped
(and said so); a bad file stops the run with its one-line error.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from mckibben.data import MuscleSpec, Table, check_muscle, read_muscle, read_table
from mckibben.datasets import MUSCLES
from mckibben.datasets.campaign import campaign_muscle_dirs, is_synthetic
from mckibben.fit import static
from mckibben.fit.compare import compare_models
from mckibben.fit.isometric import compare_isometric
from mckibben.datasets.isometric import BUNDLED_ISOMETRIC
from mckibben.atomic import as_path
from mckibben.errors import InputError, check_callable

KINDS_ORDER = ("braid_angle", "isotonic", "blocked_force", "hysteresis", "force_length", "step_response")


@dataclass
class MuscleResults:
    """Everything fitted for one muscle."""

    spec: MuscleSpec
    tables: dict = field(default_factory=dict)  #: kind -> Table
    kinematic: object = None  #: FitResult of eq. 2
    braid_cubics: dict = field(default_factory=dict)  #: (load, None) -> FitResult (Table II)
    isotonic_cubics: dict = field(default_factory=dict)
    force_contraction: dict = field(default_factory=dict)  #: pressure -> FitResult (Fig. 5)
    surface: object = None
    blocked_force: object = None
    hysteresis: dict = field(default_factory=dict)
    spring: object = None  #: SpringFit
    steps: dict = field(default_factory=dict)
    comparison: dict | None = None
    skipped: list = field(default_factory=list)

    @property
    def published(self):
        """The published parameter set of the same id, if there is one."""
        return MUSCLES.get(self.spec.id)


def _find(folder: Path, kind: str) -> Path | None:
    for suffix in (".csv", ".parquet", ".pq"):
        p = folder / f"{kind}{suffix}"
        if p.is_file():
            return p
    return None


def characterize(root=None, progress: Callable[[str], None] | None = None) -> dict:
    """Fit every model to every muscle of a campaign folder.

    Parameters
    ----------
    root : str or pathlib.Path, optional
        The campaign folder (default: the bundled synthetic campaign).
    progress : callable, optional
        Called with a short description before each step.

    Returns
    -------
    dict
        ``muscles`` (list of :class:`MuscleResults`), ``synthetic`` (bool), ``root`` (str).
    """
    check_callable(progress, "progress")
    if root is not None and not as_path(root, "root", "campaign folder").is_dir():
        raise InputError(f"root: {str(root)!r} is not a folder (a campaign: one sub-folder per muscle)")
    say = progress or (lambda _msg: None)
    dirs = campaign_muscle_dirs(root)
    synthetic = is_synthetic(root)
    out = []
    for folder in dirs:
        spec = read_muscle(folder / "muscle.toml")
        synthetic = synthetic or spec.synthetic
        r = MuscleResults(spec)
        for kind in KINDS_ORDER:
            path = _find(folder, kind)
            if path is None:
                r.skipped.append(f"{spec.id}: no {kind} file")
                continue
            t: Table = read_table(path, kind)
            check_muscle(t, spec)
            r.tables[kind] = t
        say(f"{spec.id}: fits")
        if "braid_angle" in r.tables:
            r.kinematic = static.fit_kinematic(r.tables["braid_angle"], spec)
            if {"pressure", "load"} <= set(r.tables["braid_angle"].data.columns):
                r.braid_cubics = static.fit_cubics(r.tables["braid_angle"])
        if "isotonic" in r.tables:
            iso = r.tables["isotonic"]
            r.isotonic_cubics = static.fit_cubics(iso)
            r.force_contraction = static.fit_force_contraction(iso, spec)
            r.surface = static.fit_surface(iso)
        if "blocked_force" in r.tables:
            r.blocked_force = static.fit_cubics(r.tables["blocked_force"])[(None, None)]
        if "hysteresis" in r.tables:
            r.hysteresis = static.fit_cubics(r.tables["hysteresis"])
        if "force_length" in r.tables:
            r.spring = static.fit_spring(r.tables["force_length"], nominal_length=spec.nominal_length)
        if "step_response" in r.tables:
            r.steps = static.fit_first_order(r.tables["step_response"])
        if "isotonic" in r.tables:
            say(f"{spec.id}: model comparison")
            braid = r.tables.get("braid_angle") if r.braid_cubics else None
            r.comparison = compare_models(r.tables["isotonic"], spec, braid)
        out.append(r)
    out.sort(key=lambda r: (r.spec.nominal_length, r.spec.id))
    isometric = []
    for folder in _isometric_folders(root, dirs):
        spec = read_muscle(folder / "muscle.toml")
        synthetic = synthetic or spec.synthetic
        say(f"{spec.id}: isometric comparison")
        t = read_table(folder / "isometric.csv", "isometric")
        check_muscle(t, spec)
        isometric.append((spec, compare_isometric(t, spec, "leave-one-length-out")))
    return {"muscles": out, "synthetic": synthetic, "root": str(root) if root else "bundled example campaign",
            "isometric": isometric}


def _isometric_folders(root, dirs) -> list:
    """Folders holding ``isometric.csv`` and ``muscle.toml``: the campaign's, and the bundled
    commercial-size test when the campaign is the bundled one."""

    found = [d for d in dirs if (d / "isometric.csv").is_file()]
    if root is None:
        found += sorted(p for p in BUNDLED_ISOMETRIC.iterdir() if (p / "isometric.csv").is_file()
                        and (p / "muscle.toml").is_file())
    return found

"""Tool tracking in simulation: a tip path followed by the three-muscle endoscope's simulated muscles.

The experiment of [mpam-characterization] §V on the simulated tool: inverse kinematics and the static
inverse give three pressure references (:mod:`mckibben.tool.tracking`), three controlled muscles
follow them, the tool's statics (or MuJoCo) give the tip. It takes SI numbers and a
:class:`~mckibben.tool.paths.TipPath`, written by hand or read from its one-line text by
:func:`~mckibben.tool.paths.parse_path` (what ``mckibben tool track --path`` does).

>>> import mckibben.tool as mt, mckibben.experiments as mx                        # doctest: +SKIP
>>> tool = mt.make_tool("mpam117", preload=1.0)                                  # doctest: +SKIP
>>> res = mx.track_tip(mt.TipPath("circle", size=5e-3, period=2.0), tool=tool)   # doctest: +SKIP
>>> res = mx.track_tip(mt.parse_path("circle:radius=5mm,period=2s"), tool=tool)  # the same path  # doctest: +SKIP
>>> res.metrics, res.to_pandas().head(), res.plot()                               # doctest: +SKIP
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mckibben import tool as tool_package
from mckibben.errors import ArgumentTypeError, InputError, check_callable, check_instance, check_real, unknown_name
from mckibben.limits import check_budget
from mckibben.results import Result, to_jsonable
from mckibben.tool.api import check_within_reach, make_tool, tool_dict
from mckibben.tool.geometry import Tool
from mckibben.tool.paths import TipPath, parse_path
from mckibben.tool.tracking import TRACKING_BETA, plot_tracking, resolve_path, simulate_tracking, tip_reference
from mckibben.units import si

__all__ = ["ToolTrackResult", "track_tip"]


@dataclass(frozen=True, repr=False)
class ToolTrackResult(Result):
    """A tip path followed by three simulated muscles, at one or several speeds (:func:`track_tip`).

    Attributes
    ----------
    path : TipPath
        The path (height resolved). [-]
    runs : list of (TipPath, TipReference)
        Each period's path and pressure references. [-]
    results : list of TrackingResult or None
        Their simulations (None with ``reference_only``). [-]
    tool : Tool
        The tool. [-]
    arguments : dict
        Path text, periods [s], β. [-]
    """

    path: TipPath
    runs: list
    results: list | None
    tool: Tool
    arguments: dict = field(default_factory=dict)
    call = "mckibben.experiments.track_tip"

    @property
    def per_run(self) -> list:
        """One dict per period: speed, reference pressure range and flags, and (simulated) errors."""
        out = []
        for k, (p, ref) in enumerate(self.runs):
            entry = {
                "period_s": p.period,
                "mean_speed_m_per_s": p.mean_speed,
                "samples": int(ref.time.size),
                "reference_pressure_min_Pa": ref.pressures.min(axis=0).tolist(),
                "reference_pressure_max_Pa": ref.pressures.max(axis=0).tolist(),
                "reference_flags": sorted({f for row in ref.state.flag_lists() for m in row for f in m}),
            }
            if self.results is not None:
                entry.update(self.results[k].summary())
            out.append(entry)
        return out

    @property
    def metrics(self) -> dict:
        """Worst run's RMS and maximum tip error [m] (NaN without simulation), and the number of runs."""
        runs = self.per_run
        return {"runs": len(runs),
                "rms_error_m": max((r.get("rms_error_m", np.nan) for r in runs), default=np.nan),
                "max_error_m": max((r.get("max_error_m", np.nan) for r in runs), default=np.nan)}

    def to_dict(self) -> dict:
        """What ``mckibben tool track --json`` prints."""
        b = self.path
        return to_jsonable({"path": {"kind": b.kind, "size_m": b.size, "z_m": b.z, "cx_m": b.cx, "cy_m": b.cy,
                                     "cycles": b.cycles},
                            "runs": self.per_run, "simulated": self.results is not None, "tool": tool_dict(self.tool)})

    def _series(self):
        import pandas as pd  # deferred on purpose: pandas (0.25 s)

        frames = []
        for k, (p, ref) in enumerate(self.runs):
            d = {"period_s": p.period, "time_s": ref.time,
                 "target_x_m": ref.target[:, 0], "target_y_m": ref.target[:, 1], "target_z_m": ref.target[:, 2]}
            for i in range(3):
                d[f"reference_{i + 1}_Pa"] = ref.pressures[:, i]
            if self.results is not None:
                r = self.results[k]
                d.update({"achieved_x_m": r.achieved[:, 0], "achieved_y_m": r.achieved[:, 1],
                          "achieved_z_m": r.achieved[:, 2]})
                for i in range(3):
                    d[f"pressure_{i + 1}_Pa"] = r.pressure[:, i]
            frames.append(pd.DataFrame(d))
        return pd.concat(frames, ignore_index=True)

    def plot(self, ax=None):
        """Target against achieved tip (top view), tip error over time, error against speed.

        Parameters
        ----------
        ax : sequence of three matplotlib.axes.Axes, optional
            Where to draw; default a new figure. [-]
        """

        if self.results is None:
            raise InputError("tool track: nothing simulated to plot (reference_only=True)")
        return plot_tracking(self.runs, self.results, self.tool, ax=ax)


#: Cost of one 1 ms sample of :func:`track_tip`: IK and static inverse, three controlled muscles; the
#: memory of the reference and record. Measured on the reference machine with headroom. [B], [s]
TRACK_BYTES_PER_SAMPLE = 4096
TRACK_SECONDS_PER_SAMPLE = {False: 400e-6, True: 100e-6}
#: The same for the MuJoCo engine: ten MuJoCo steps of the 13-disc chain per sample, each with the three
#: muscles' exchange (measured 0.8-2.1 ms per sample on the reference machine, idle to busy; with headroom). [s]
TRACK_SECONDS_PER_SAMPLE_MUJOCO = 4e-3
#: The engines of :func:`track_tip`: the quasi-static tool (statics at the simulated pressures) and MuJoCo.
TRACK_ENGINES = ("quasi-static", "mujoco")


#: The most periods (runs) one :func:`track_tip` call takes. [-]
MAX_TRACK_RUNS = 1000

#: The shortest path period :func:`track_tip` samples: 20 control periods of 1 ms per cycle. [s]
MIN_TRACK_PERIOD = 0.02


def track_tip(path, *, periods=None, tool: Tool | None = None, beta=None, reference_only: bool = False,
          progress=None, force: bool = False, engine: str = "quasi-static") -> ToolTrackResult:
    """Follow a tip path: IK and static inverse → pressure references → three controlled muscles.

    Parameters
    ----------
    path : TipPath
        The tip path, e.g. ``TipPath("circle", size=5e-3, period=2.0)``, or
        ``parse_path("circle:radius=5mm,period=2s")`` from its one-line text
        (:mod:`mckibben.tool.paths`). [-]
    periods : sequence of float, optional
        Run the path at several periods (speeds), e.g. ``[4.0, 2.0, 1.0]``; default the path's. [s]
    tool : Tool, optional
        Default :func:`mckibben.tool.make_tool`'s. [-]
    beta : float, optional
        Switching gain of the three sliding-mode controllers (our law); default 50. [PWM counts]
    reference_only : bool, default False
        Only compute the pressure references (no simulation). [-]
    progress : callable, optional
        ``progress(done, total)`` after each period. [-]
    force : bool, default False
        Run past the documented size limits (:mod:`mckibben.limits`). [-]
    engine : {"quasi-static", "mujoco"}, default "quasi-static"
        The tool's mechanics: its static equilibrium at the simulated pressures, or the
        endoscope in MuJoCo (discs, backbone, inertia and damping; the muscles' own chambers
        on its tendons: :func:`mckibben.tool.mujoco_model.simulate_tracking_mujoco`, needs the
        ``mujoco`` extra). The references and controllers are the same. [-]

    Returns
    -------
    ToolTrackResult
    """


    check_callable(progress, "progress")
    check_instance(tool, "tool", Tool, "a Tool (make_tool)", optional=True)
    if not isinstance(engine, str) or engine not in TRACK_ENGINES:
        raise unknown_name("engine", str(engine), TRACK_ENGINES)
    text = path if isinstance(path, str) else None
    if text is not None:  # read it only to check it; text is refused below, once every other argument is checked
        path = parse_path(text)
    if not isinstance(path, TipPath):
        raise ArgumentTypeError(f"path = {path!r}: not a TipPath ({type(path).__name__}); give e.g. "
                                "TipPath('circle', size=5e-3, period=2.0) or parse_path('circle:radius=5mm,period=2s')")
    if not isinstance(reference_only, (bool, np.bool_)):
        raise ArgumentTypeError(f"reference_only = {reference_only!r}: not True or False ({type(reference_only).__name__})")
    spec = path
    if periods is None:
        period_list = np.array([spec.period])
    else:
        if isinstance(periods, str):
            si(periods, "time", "periods")  # raises: the library takes numbers (parse_values converts text)
        if isinstance(periods, (bytes, dict, set)) or np.ndim(periods) > 1:
            raise ArgumentTypeError(f"periods = {periods!r}: not a sequence of periods")
        if np.size(periods) > MAX_TRACK_RUNS:
            raise InputError(f"periods: {np.size(periods):,} periods, more than the {MAX_TRACK_RUNS} runs a call takes")
        period_list = np.array([si(p, "time", "periods", allow_zero=False) for p in np.ravel(periods)])
    if period_list.size == 0:
        raise InputError("periods (`periods`): empty; give at least one period, or None for the path's own")
    short = float(period_list.min())
    if short < MIN_TRACK_PERIOD:
        raise InputError(f"periods (`path`/`periods`): a period of {short:g} s is shorter than {MIN_TRACK_PERIOD:g} s "
                         f"({MIN_TRACK_PERIOD / 1e-3:.0f} control periods of 1 ms): too short to sample the path")
    check_budget("path/`periods`" if periods is not None else "path",
                 float(np.sum(period_list)) * spec.cycles / 1e-3, force=force, what="1 ms samples",
                 bytes_per_sample=TRACK_BYTES_PER_SAMPLE,
                 seconds_per_sample=TRACK_SECONDS_PER_SAMPLE[bool(reference_only)] if engine == "quasi-static" or
                 reference_only else TRACK_SECONDS_PER_SAMPLE_MUJOCO)
    b = TRACKING_BETA
    if beta is not None:
        b = check_real(beta, "beta", lo=0.0, hi=255.0, lo_open=True, unit="PWM counts")
    tool = make_tool() if tool is None else tool
    check_within_reach(np.array([spec.size]), tool, "path", f"a {spec.kind} of")
    if text is not None:
        raise ArgumentTypeError(f"path = {text!r}: the library takes a TipPath, not text; build it with "
                                f"mckibben.tool.parse_path({text!r}) or TipPath(kind, size, period, ...)")
    base = resolve_path(spec, tool)
    runs = [(p, tip_reference(tool, p)) for p in (base.with_period(float(t)) for t in period_list)]
    results = None
    if not reference_only:
        results = []
        run_engine = simulate_tracking
        if engine == "mujoco":
            # through the package: Numba, and the optional mujoco package, load only for this engine
            run_engine = tool_package.mujoco_model.simulate_tracking_mujoco
        for k, run in enumerate(runs):
            results += run_engine(tool, [run], beta=b)
            if progress is not None:
                progress(k + 1, len(runs))
    return ToolTrackResult(base, runs, results, tool,
                           {"path": path.text or base.kind,
                            "periods_s": [float(t) for t in period_list],
                            "beta_counts": None if reference_only else b, "engine": engine})

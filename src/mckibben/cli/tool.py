"""``mckibben tool fk|ik|workspace|track``: the three-muscle endoscope (docs/tool.md)."""

from __future__ import annotations

import numpy as np
import typer

from mckibben.cli import app
from mckibben.cli._common import JSON_OPTION, console, emit_json, print_table
from mckibben.datasets import get_muscle
from mckibben.atomic import check_output_file
from mckibben.errors import InputError
from mckibben.units import parse_quantity, parse_values

tool_app = typer.Typer(help="The three-muscle endoscope: kinematics, pressures for a tip, workspace, tracking.",
                       no_args_is_help=True)
app.add_typer(tool_app, name="tool")

MUSCLE_OPTION = typer.Option("mpam117", "--muscle", help="Parameter set of the three muscles (mpam97, mpam117, mpam143).")
PITCH_OPTION = typer.Option(None, "--pitch-radius", help="Radius of the muscle holes' circle (default 4mm, the middle of the 12 mm disc's ring).")
DISCS_OPTION = typer.Option("13", "--discs", help="Number of spacer discs incl. base and tip, or 'continuous'.")
PRELOAD_OPTION = typer.Option("1N", "--preload", help="Tension of each muscle in the straight tool, F0.")
KB_OPTION = typer.Option("2e-4Nm2", "--bending-stiffness", help="Backbone bending stiffness Kb in N·m² (e.g. 2e-4Nm2).")
KA_OPTION = typer.Option("0N", "--axial-stiffness", help="Backbone axial stiffness Ka (force per unit strain), e.g. 50N.")
PMAX_OPTION = typer.Option("0.8MPa", "--p-max", help="Highest pressure allowed in any muscle.")

def _discs(text: str):
    if text.strip().lower() in ("continuous", "none", "inf"):
        return None
    try:
        n = int(text)
    except ValueError:
        raise InputError(f"--discs: {text!r} is not a whole number of discs (or 'continuous')") from None
    if n < 2:
        raise InputError(f"--discs: {text!r} must be at least 2 (base and tip)")
    return n


def build_tool(muscle, pitch_radius, discs, preload, bending_stiffness, axial_stiffness, p_max):
    """The :class:`~mckibben.tool.geometry.Tool` from the command-line options (strings with units)."""
    from mckibben.tool.geometry import StackLoad, Tool, ToolGeometry

    geo = ToolGeometry(
        pitch_radius=parse_quantity(pitch_radius, "length", "--pitch-radius", allow_zero=False) if pitch_radius else None,
        n_discs=_discs(discs),
    )
    load = StackLoad(
        preload=parse_quantity(preload, "force", "--preload"),
        bending_stiffness=parse_quantity(bending_stiffness, "bending_stiffness", "--bending-stiffness",
                                         default_unit="Nm2"),
        axial_stiffness=parse_quantity(axial_stiffness, "force", "--axial-stiffness"),
    )
    from mckibben.limits import check_p_max

    pmax = check_p_max(parse_quantity(p_max, "pressure", "--p-max", allow_zero=False))
    try:
        return Tool(get_muscle(muscle), geo, load, pmax)
    except InputError as exc:  # the library names its field; the command line names the option
        msg = str(exc)
        raise InputError("--" + msg if msg.startswith("discs:") else msg) from None


def tool_json(tool) -> dict:
    """The tool's parameters as a JSON-ready dict (SI, unit-suffixed keys)."""
    g, ld = tool.geometry, tool.load
    return {
        "muscle": tool.muscle.name,
        "disc_diameter_m": g.disc_diameter,
        "hole_diameter_m": g.hole_diameter,
        "channel_diameter_m": g.channel_diameter,
        "pitch_radius_m": g.pitch_radius,
        "n_discs": g.n_discs,
        "muscle_angles_rad": [0.0, 2 * np.pi / 3, 4 * np.pi / 3],
        "preload_N": ld.preload,
        "bending_stiffness_Nm2": ld.bending_stiffness,
        "axial_stiffness_N": ld.axial_stiffness,
        "reference_length_m": tool.reference_length,
        "p_max_Pa": tool.p_max,
    }


def state_json(state) -> dict:
    """A single pose of a :class:`~mckibben.tool.statics.ToolState` as a JSON-ready dict."""
    arc = state.arc
    return {
        "arc_length_m": float(arc.arc_length),
        "curvature_per_m": float(arc.curvature),
        "bend_angle_rad": float(arc.theta),
        "bend_plane_angle_rad": float(arc.phi),
        "theta_x_rad": float(arc.theta_x),
        "theta_y_rad": float(arc.theta_y),
        "tip_m": state.tip.tolist(),
        "tip_direction": state.rotation[:, 2].tolist(),
        "tip_rotation": state.rotation.tolist(),
        "lengths_m": state.lengths.tolist(),
        "tensions_N": state.tensions.tolist(),
        "pressures_Pa": state.pressures.tolist(),
        "flags": state.flag_lists(),
        "reachable": bool(state.reachable),
    }


def _three(values: np.ndarray, text: str, name: str) -> np.ndarray:
    if values.shape != (3,) or ":" in text:
        raise InputError(f"{name}: need exactly 3 comma-separated values (muscles 1, 2, 3), got {text!r}")
    return values


def _print_state(title: str, st: dict) -> None:
    console.print(
        f"[bold]{title}[/bold]\n"
        f"  arc length {st['arc_length_m'] * 1e3:.3f} mm, bend θ {np.degrees(st['bend_angle_rad']):.2f}°,"
        f" plane φ {np.degrees(st['bend_plane_angle_rad']):.2f}°, curvature {st['curvature_per_m']:.4g} 1/m\n"
        f"  tip ({', '.join(f'{v * 1e3:.3f}' for v in st['tip_m'])}) mm,"
        f" direction ({', '.join(f'{v:.4f}' for v in st['tip_direction'])})"
    )
    rows = []
    for i in range(3):
        p = st["pressures_Pa"][i]
        rows.append([f"{i + 1} ({i * 120}°)", f"{st['lengths_m'][i] * 1e3:.3f}", f"{st['tensions_N'][i]:.3f}",
                     "unreachable" if p is None or not np.isfinite(p) else f"{p / 1e6:.4f}", ", ".join(st["flags"][i]) or "ok"])
    print_table("muscles", ["muscle", "length mm", "tension N", "pressure MPa", "flags"], rows)


@tool_app.command("fk")
def fk_cmd(
    lengths: str = typer.Option(None, "--lengths", help="Three muscle lengths, e.g. 117mm,112mm,115mm."),
    pressures: str = typer.Option(None, "--pressures", help="Or three pressures, e.g. 0.4MPa,0,0.2MPa: the static equilibrium pose."),
    muscle: str = MUSCLE_OPTION,
    pitch_radius: str = PITCH_OPTION,
    discs: str = DISCS_OPTION,
    preload: str = PRELOAD_OPTION,
    bending_stiffness: str = KB_OPTION,
    axial_stiffness: str = KA_OPTION,
    p_max: str = PMAX_OPTION,
    json: bool = JSON_OPTION,
) -> None:
    """Forward kinematics: three muscle lengths (or pressures) → arc → tip position and orientation."""
    from mckibben.tool.statics import pressures_for_tip, tip_from_pressures

    if (lengths is None) == (pressures is None):
        raise InputError("tool fk: give exactly one of --lengths or --pressures")
    tool = build_tool(muscle, pitch_radius, discs, preload, bending_stiffness, axial_stiffness, p_max)
    geo = tool.geometry
    if lengths is not None:
        from mckibben.tool.kinematics import arc_from_lengths, tip_position

        ls = _three(parse_values(lengths, "length", "--lengths", allow_zero=False), lengths, "--lengths")
        arc = arc_from_lengths(ls, geo.pitch_radius, geo.n_gaps)
        # the pressures that hold these lengths, through the same path as `tool ik`
        state = pressures_for_tip(tip_position(arc), tool)
        source = "lengths"
    else:
        ps = _three(parse_values(pressures, "pressure", "--pressures"), pressures, "--pressures")
        state = tip_from_pressures(ps, tool)
        if not bool(state.converged):
            raise InputError(f"--pressures: the static equilibrium did not converge for {pressures!r}")
        source = "pressures"
    out = {"input": source, **state_json(state), "tool": tool_json(tool)}
    if json:
        emit_json(out)
        return
    _print_state(f"tool fk from {source} ({tool.muscle.name})", out)


@tool_app.command("ik")
def ik_cmd(
    tip: str = typer.Option(..., "--tip", help="Target tip position X,Y,Z, e.g. 20mm,0mm,110mm."),
    muscle: str = MUSCLE_OPTION,
    pitch_radius: str = PITCH_OPTION,
    discs: str = DISCS_OPTION,
    preload: str = PRELOAD_OPTION,
    bending_stiffness: str = KB_OPTION,
    axial_stiffness: str = KA_OPTION,
    p_max: str = PMAX_OPTION,
    json: bool = JSON_OPTION,
) -> None:
    """Inverse: a tip position → arc → muscle lengths → tensions → pressures (unreachable: exit 2)."""
    from mckibben.tool.statics import pressures_for_tip, require_reachable_tip

    p = _three(parse_values(tip, "length", "--tip", allow_negative=True), tip, "--tip")
    tool = build_tool(muscle, pitch_radius, discs, preload, bending_stiffness, axial_stiffness, p_max)
    state = pressures_for_tip(p, tool)
    require_reachable_tip(state, tool)
    out = {**state_json(state), "tool": tool_json(tool)}
    if json:
        emit_json(out)
        return
    _print_state(f"tool ik for tip ({tip})", out)


@tool_app.command("workspace")
def workspace_cmd(
    plot: str = typer.Option(None, "--plot", help="Write the workspace figure to this file (PNG)."),
    grid: int = typer.Option(15, "--grid", help="Pressure grid points per muscle (2..101)."),
    muscle: str = MUSCLE_OPTION,
    pitch_radius: str = PITCH_OPTION,
    discs: str = DISCS_OPTION,
    preload: str = PRELOAD_OPTION,
    bending_stiffness: str = KB_OPTION,
    axial_stiffness: str = KA_OPTION,
    p_max: str = PMAX_OPTION,
    json: bool = JSON_OPTION,
) -> None:
    """Sample the pressure box [0, p_max]³, report the reachable tip set's extent, optionally plot it."""
    from mckibben.tool.workspace import plot_workspace, sample_workspace

    if plot:
        check_output_file(plot, "--plot")
    tool = build_tool(muscle, pitch_radius, discs, preload, bending_stiffness, axial_stiffness, p_max)
    ws = sample_workspace(tool, grid)
    ext = ws.extent()
    if plot:
        plot_workspace(ws, tool, plot)
    if json:
        emit_json({**ext, "grid": grid, "plot": plot, "tool": tool_json(tool)})
        return
    rows = [
        ["lateral reach", f"{ext['lateral_reach_m'] * 1e3:.2f} mm"],
        ["tip angle", f"{np.degrees(ext['tip_angle_min_rad']):.1f}..{np.degrees(ext['tip_angle_max_rad']):.1f}°"],
        ["tip z", f"{ext['z_min_m'] * 1e3:.2f}..{ext['z_max_m'] * 1e3:.2f} mm"],
        ["arc length", f"{ext['arc_length_min_m'] * 1e3:.2f}..{ext['arc_length_max_m'] * 1e3:.2f} mm"],
        ["converged", f"{ext['converged']}/{ext['samples']}"],
        ["flagged", ", ".join(f"{k}: {v}" for k, v in ext["samples_flagged"].items()) or "none"],
    ]
    print_table(f"workspace of {tool.muscle.name} tool ({grid}³ pressures)", ["", "value"], rows)
    if plot:
        console.print(f"wrote {plot}")


#: Cost of one 1 ms sample of `tool track`: IK and static inverse, three controlled muscles; the
#: memory of the reference and record. Measured on the reference machine with headroom. [B], [s]
TRACK_BYTES_PER_SAMPLE = 4096
TRACK_SECONDS_PER_SAMPLE = {False: 400e-6, True: 100e-6}


@tool_app.command("track")
def track_cmd(
    path: str = typer.Option(..., "--path", help="Tip path: circle:radius=5mm,period=2s[,z=..,cx=..,cy=..,cycles=2] or figure8:size=5mm,period=2s[,...]."),
    periods: str = typer.Option(None, "--periods", help="Run the path at several periods (speeds), e.g. 4s,2s,1s,0.5s."),
    reference_only: bool = typer.Option(False, "--reference-only", help="Only compute the pressure references (no simulation)."),
    force: bool = typer.Option(False, "--force", help="Run past the documented size limits (mckibben.limits)."),
    plot: str = typer.Option(None, "--plot", help="Write the target-vs-achieved figure to this file (PNG)."),
    beta: float = typer.Option(None, "--beta", help="Sliding-mode switching gain of the three controllers [PWM counts] "
                                                    "(our law, docs/control.md; default TRACKING_BETA, 50)."),
    muscle: str = MUSCLE_OPTION,
    pitch_radius: str = PITCH_OPTION,
    discs: str = DISCS_OPTION,
    preload: str = PRELOAD_OPTION,
    bending_stiffness: str = KB_OPTION,
    axial_stiffness: str = KA_OPTION,
    p_max: str = PMAX_OPTION,
    json: bool = JSON_OPTION,
) -> None:
    """Follow a tip path: IK + static inverse → pressure references → three controlled muscles (plant)."""
    from mckibben.tool.paths import parse_path
    from mckibben.tool.tracking import resolve_path, tip_reference

    if plot:
        check_output_file(plot, "--plot")
    from mckibben.limits import check_budget

    tool = build_tool(muscle, pitch_radius, discs, preload, bending_stiffness, axial_stiffness, p_max)
    spec = parse_path(path)
    period_list = parse_values(periods, "time", "--periods", allow_zero=False) if periods else np.array([spec.period])
    samples = float(np.sum(period_list)) * spec.cycles / 1e-3
    check_budget("--path/--periods" if periods else "--path", samples, force=force, what="1 ms samples",
                 bytes_per_sample=TRACK_BYTES_PER_SAMPLE,
                 seconds_per_sample=TRACK_SECONDS_PER_SAMPLE[bool(reference_only)])
    base = resolve_path(spec, tool)
    runs = []
    for period in period_list:
        p = base.with_period(float(period))
        ref = tip_reference(tool, p)
        runs.append((p, ref))
    if not reference_only:
        from mckibben.tool.tracking import TRACKING_BETA, simulate_tracking

        beta = TRACKING_BETA if beta is None else beta
        if not 0 < beta <= 255:
            raise InputError(f"--beta: {beta!r} must be a switching gain in (0, 255] PWM counts")
        results = simulate_tracking(tool, runs, beta=beta)
    else:
        results = None
    out_runs = []
    for k, (p, ref) in enumerate(runs):
        entry = {
            "period_s": p.period,
            "mean_speed_m_per_s": p.mean_speed,
            "samples": int(ref.time.size),
            "reference_pressure_min_Pa": ref.pressures.min(axis=0).tolist(),
            "reference_pressure_max_Pa": ref.pressures.max(axis=0).tolist(),
            "reference_flags": sorted({f for row in ref.state.flag_lists() for m in row for f in m}),
        }
        if results is not None:
            entry.update(results[k].summary())
        out_runs.append(entry)
    if plot and results is not None:
        from mckibben.tool.tracking import plot_tracking

        plot_tracking(runs, results, tool, plot)
    if json:
        emit_json({"path": {"kind": base.kind, "size_m": base.size, "z_m": base.z, "cx_m": base.cx, "cy_m": base.cy,
                            "cycles": base.cycles}, "runs": out_runs, "simulated": results is not None,
                   "plot": plot if results is not None else None, "tool": tool_json(tool)})
        return
    rows = []
    for e in out_runs:
        rows.append([f"{e['period_s']:.3g}", f"{e['mean_speed_m_per_s'] * 1e3:.2f}",
                     f"{min(e['reference_pressure_min_Pa']) / 1e6:.3f}..{max(e['reference_pressure_max_Pa']) / 1e6:.3f}",
                     f"{e['rms_error_m'] * 1e3:.3f}" if "rms_error_m" in e else "—",
                     f"{e['max_error_m'] * 1e3:.3f}" if "max_error_m" in e else "—"])
    print_table(f"tracking {base.kind} ({tool.muscle.name})", ["period s", "speed mm/s", "pressure MPa", "RMS error mm", "max error mm"], rows)

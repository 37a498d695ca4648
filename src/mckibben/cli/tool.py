"""``mckibben tool fk|ik|workspace|track``: the three-muscle endoscope (docs/tool.md)."""

from __future__ import annotations

import numpy as np
import typer

from mckibben.cli import app
from mckibben import experiments
from mckibben.cli._common import (
    DIRECTION_OPTION,
    JSON_OPTION,
    check_direction,
    console,
    emit_json,
    err_console,
    muscle_option,
    print_table,
)
from mckibben.cli._output import check_outputs, plot_option, progress_bar, write_plot
from mckibben.control import registry as R
from mckibben.errors import InputError, unknown_name
from mckibben import tool as tool_lib
from mckibben import rig
from mckibben.units import parse_quantity, parse_values

tool_app = typer.Typer(help="The three-muscle endoscope: kinematics, pressures for a tip, workspace, tracking.",
                       no_args_is_help=True)
app.add_typer(tool_app, name="tool")

MUSCLE_OPTION = muscle_option(None, "Published parameter set of the three muscles (mpam97, mpam117, mpam143; "
                                    "default mpam117).")
MUSCLE_FILE_OPTION = typer.Option(None, "--muscle-file", help="A muscle file with a fitted force law (mckibben fit … "
                                                               "--save): three of that muscle in the paper's disc "
                                                               "stack scaled to it (docs/tool.md).")
PITCH_OPTION = typer.Option(None, "--pitch-radius", help="Radius of the muscle holes' circle (default the middle of the disc's ring: 4mm on the 12 mm disc).")
DISCS_OPTION = typer.Option("13", "--discs", help="Number of spacer discs incl. base and tip, or 'continuous'.")
PRELOAD_OPTION = typer.Option(None, "--preload", help="Tension of each muscle in the straight tool, F0 (default 1N; "
                                                      "--muscle-file: docs/tool.md).")
KB_OPTION = typer.Option(None, "--bending-stiffness", help="Backbone bending stiffness Kb in N·m², e.g. 2e-4Nm2 "
                                                           "(the default; --muscle-file: docs/tool.md).")
KA_OPTION = typer.Option(None, "--axial-stiffness", help="Backbone axial stiffness Ka (force per unit strain), e.g. "
                                                         "50N (default 0N; --muscle-file: docs/tool.md).")
PMAX_OPTION = typer.Option(None, "--p-max", help="Highest pressure allowed in any muscle (default 0.8MPa; "
                                                 "--muscle-file: at most the top of its fitted pressures).")


def build_tool(muscle, pitch_radius, discs, preload, bending_stiffness, axial_stiffness, p_max, muscle_file=None,
               direction="inflate"):
    """The tool from the shared options (:func:`mckibben.tool.make_tool`), their text parsed to SI here."""

    check_direction(direction)

    def q(text, dim, name, **kw):
        return None if text is None else parse_quantity(text, dim, name, **kw)

    return tool_lib.make_tool(muscle, muscle_file=muscle_file, direction=direction,
                              pitch_radius=q(pitch_radius, "length", "pitch_radius", allow_zero=False), discs=discs,
                              preload=q(preload, "force", "preload"),
                              bending_stiffness=q(bending_stiffness, "bending_stiffness", "bending_stiffness",
                                                  default_unit="Nm2"),
                              axial_stiffness=q(axial_stiffness, "force", "axial_stiffness"),
                              p_max=q(p_max, "pressure", "p_max", allow_zero=False))


def _three(text: str | None, dim: str, name: str, **kw):
    """A flag of three comma-separated quantities, in SI (the library checks there are three)."""
    if text is None:
        return None
    return [float(v) for v in parse_values(text, dim, name, **kw)] if ":" not in text else []


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
    muscle_file: str = MUSCLE_FILE_OPTION,
    direction: str = DIRECTION_OPTION,
    json: bool = JSON_OPTION,
) -> None:
    """Forward kinematics: three muscle lengths (or pressures) → arc → tip position and orientation."""

    if (lengths is None) == (pressures is None):
        raise InputError("tool fk: give exactly one of --lengths or --pressures")
    tool = build_tool(muscle, pitch_radius, discs, preload, bending_stiffness, axial_stiffness, p_max, muscle_file,
                      direction)
    state = tool_lib.forward(tool, lengths=_three(lengths, "length", "lengths", allow_zero=False),
                             pressures=_three(pressures, "pressure", "pressures"))
    source = "lengths" if lengths is not None else "pressures"
    out = {"input": source, **tool_lib.state_dict(state), "tool": tool_lib.tool_dict(tool)}
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
    muscle_file: str = MUSCLE_FILE_OPTION,
    direction: str = DIRECTION_OPTION,
    json: bool = JSON_OPTION,
) -> None:
    """Inverse: a tip position → arc → muscle lengths → tensions → pressures (unreachable: exit 2)."""

    tool = build_tool(muscle, pitch_radius, discs, preload, bending_stiffness, axial_stiffness, p_max, muscle_file,
                      direction)
    state = tool_lib.inverse(_three(tip, "length", "tip", allow_negative=True), tool)
    out = {**tool_lib.state_dict(state), "tool": tool_lib.tool_dict(tool)}
    if json:
        emit_json(out)
        return
    _print_state(f"tool ik for tip ({tip})", out)


@tool_app.command("workspace")
def workspace_cmd(
    plot: str = plot_option("the workspace figure"),
    dpi: int = typer.Option(110, "--dpi", help="Resolution of raster figures, dots per inch."),
    out: str = typer.Option(None, "--out", help="Write the sampled grid (pressures, tips): .csv or .parquet."),
    grid: int = typer.Option(15, "--grid", help="Pressure grid points per muscle (2..101)."),
    muscle: str = MUSCLE_OPTION,
    pitch_radius: str = PITCH_OPTION,
    discs: str = DISCS_OPTION,
    preload: str = PRELOAD_OPTION,
    bending_stiffness: str = KB_OPTION,
    axial_stiffness: str = KA_OPTION,
    p_max: str = PMAX_OPTION,
    muscle_file: str = MUSCLE_FILE_OPTION,
    direction: str = DIRECTION_OPTION,
    json: bool = JSON_OPTION,
) -> None:
    """Sample the pressure box [0, p_max]³, report the reachable tip set's extent, optionally plot it."""

    check_outputs(plot, dpi, out)
    tool = build_tool(muscle, pitch_radius, discs, preload, bending_stiffness, axial_stiffness, p_max, muscle_file,
                      direction)
    res = tool_lib.map_workspace(tool, grid)
    ext = res.metrics
    if plot:
        write_plot(res.plot(), plot, dpi, res)
    if out:
        res.to_file(out)
    if json:
        emit_json({**res.to_dict(), "plot": plot})
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


@tool_app.command("track")
def track_cmd(
    path: str = typer.Option(..., "--path", help="Tip path: circle:radius=5mm,period=2s[,z=..,cx=..,cy=..,cycles=2] or figure8:size=5mm,period=2s[,...]."),
    periods: str = typer.Option(None, "--periods", help="Run the path at several periods (speeds), e.g. 4s,2s,1s,0.5s."),
    reference_only: bool = typer.Option(False, "--reference-only", help="Only compute the pressure references (no simulation)."),
    force: bool = typer.Option(False, "--force", help="Run past the documented size limits (mckibben.limits)."),
    plot: str = plot_option("the target-vs-achieved figure"),
    dpi: int = typer.Option(110, "--dpi", help="Resolution of raster figures, dots per inch."),
    out: str = typer.Option(None, "--out", help="Write the time series of every run (targets, references, "
                                                "achieved tips, pressures): .csv or .parquet."),
    beta: float = typer.Option(None, "--beta", help="Sliding-mode switching gain of the three controllers [PWM counts] "
                                                    f"(our law, docs/control.md; default TRACKING_BETA, {R.SMC.designs['model']['beta']:g})."),
    muscle: str = MUSCLE_OPTION,
    pitch_radius: str = PITCH_OPTION,
    discs: str = DISCS_OPTION,
    preload: str = PRELOAD_OPTION,
    bending_stiffness: str = KB_OPTION,
    axial_stiffness: str = KA_OPTION,
    p_max: str = PMAX_OPTION,
    muscle_file: str = MUSCLE_FILE_OPTION,
    direction: str = DIRECTION_OPTION,
    port: str = typer.Option(None, "--port", help="Steer the three muscles of a device (or rig emulate) over this "
                                                  "serial port, and compare with the simulation of the same path."),
    engine: str = typer.Option("quasi-static", "--engine", help="The tool's mechanics: quasi-static (its statics at "
                                                                "the simulated pressures) or mujoco (discs, backbone, "
                                                                "inertia, damping; the mujoco extra)."),
    json: bool = JSON_OPTION,
) -> None:
    """Follow a tip path: IK + static inverse → pressure references → three controlled muscles (plant or device)."""
    engines = experiments.tool.TRACK_ENGINES

    if engine not in engines:
        raise unknown_name("engine (--engine)", engine, engines)
    if port is not None and (periods or reference_only):
        raise InputError("--port: runs one path on the device; it takes neither --periods nor --reference-only")
    check_outputs(plot, dpi, out)
    tool = build_tool(muscle, pitch_radius, discs, preload, bending_stiffness, axial_stiffness, p_max, muscle_file,
                      direction)
    path = tool_lib.parse_path(path)
    periods = None if periods is None else parse_values(periods, "time", "periods", allow_zero=False)
    link_out = None
    if port is not None:
        link_res, link_info = experiments.link.track_over_link(port, tool, path, beta=beta)
    with progress_bar("periods", json) as bar:
        task = bar.add_task("periods", total=None)
        res = experiments.track_tip(path, periods=periods, tool=tool, beta=beta, reference_only=reference_only, force=force,
                             progress=lambda done, total: bar.update(task, completed=done, total=total), engine=engine)
    simulated = res.results is not None
    if plot and simulated:
        write_plot(res.plot(), plot, dpi, res)
    if out:
        res.to_file(out)
    base, out_runs = res.path, res.per_run
    if port is not None:
        link_out = {"port": port, **link_res.summary(), **link_info,
                    "rms_error_ratio_to_simulation": link_res.summary()["rms_error_m"] / out_runs[0]["rms_error_m"]}
        if link_res.faults:
            err_console.print(f"warning: the device reported faults: {', '.join(rig.protocol.fault_names(link_res.faults))} "
                              f"(flags {link_res.faults})", markup=False, highlight=False)
    if json:
        emit_json({**res.to_dict(), "plot": plot if simulated else None,
                   **({"link": link_out} if link_out is not None else {})})
        return
    if link_out is not None:
        print_table(f"through the link on {port}", ["", "RMS error mm", "max error mm", "frames", "missing"],
                    [["device", f"{link_out['rms_error_m'] * 1e3:.3f}", f"{link_out['max_error_m'] * 1e3:.3f}",
                      str(link_out["frames"]), str(link_out["missing"])],
                     ["simulation", f"{out_runs[0]['rms_error_m'] * 1e3:.3f}",
                      f"{out_runs[0]['max_error_m'] * 1e3:.3f}", "", ""]])
    rows = []
    for e in out_runs:
        rows.append([f"{e['period_s']:.3g}", f"{e['mean_speed_m_per_s'] * 1e3:.2f}",
                     f"{min(e['reference_pressure_min_Pa']) / 1e6:.3f}..{max(e['reference_pressure_max_Pa']) / 1e6:.3f}",
                     f"{e['rms_error_m'] * 1e3:.3f}" if "rms_error_m" in e else "—",
                     f"{e['max_error_m'] * 1e3:.3f}" if "max_error_m" in e else "—"])
    print_table(f"tracking {base.kind} ({tool.muscle.name})", ["period s", "speed mm/s", "pressure MPa", "RMS error mm", "max error mm"], rows)

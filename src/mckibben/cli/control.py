"""``mckibben control step|track|fig13|compare|robustness|hysteresis``: the controller on the plant simulator.

Each command parses its options (quantities with :func:`~mckibben.units.parse_quantity`, named by the
library's Python arguments so that a refusal names the flag; the reference with
:func:`~mckibben.control.references.parse_reference`), makes one call of :mod:`mckibben.experiments` with
numbers in SI and prints the result.
"""

from __future__ import annotations

import typer

from mckibben.cli import app
from mckibben.cli._common import DIRECTION_OPTION, JSON_OPTION, choices, emit_json, err_console, parse_flag, print_table
from mckibben.cli._output import (DPI_OPTION, OUT_OPTION, check_outputs, metric_row, plot_option, progress_bar,
                                  write_plot)
from mckibben.control import registry as R
from mckibben.limits import check_budget
from mckibben.units import parse_quantity
from mckibben.atomic import check_output_file
from mckibben import control
from mckibben import experiments
from mckibben import rig

control_app = typer.Typer(help="Control on the simulated plant: step, track, fig13, compare, robustness, hysteresis.",
                          no_args_is_help=True)
app.add_typer(control_app, name="control")

_SMC_DESIGNS = R.SMC.designs
_CONTROLLER_HELP = " or ".join(R.NAMES) + "."

STEP_KEYS = ("time_constant_s", "rise_time_s", "overshoot_pct", "settling_time_s", "steady_state_error_Pa",
             "rms_error_Pa", "valve_effort_counts")

BETA_OPTION = typer.Option(None, "--beta", help=(f"Sliding-mode switching gain of our law, PWM counts (default "
                                                f"{_SMC_DESIGNS['model']['beta']:g}; the paper's law: "
                                                f"{_SMC_DESIGNS['paper']['beta']:g} unless given)."))
LAW_OPTION = typer.Option("model", "--law", help="Sliding-mode law: model (ours: model term with the valves' "
                                                 "lift-off) or paper (β·tanh(S/ε) alone, as the paper ran it).")
EPS_OPTION = typer.Option(None, "--eps", help="Sliding-mode boundary layer, e.g. 20kPa (default: docs/control.md).")
KI_OPTION = typer.Option(None, "--ki", help="Sliding-surface integral weight [1/s] (default: docs/control.md).")
LAMBDA_OPTION = typer.Option(None, "--lambda", help="PID closed-loop time constant, e.g. 30ms (default τ/3).")
PMAX_OPTION = typer.Option("0.8MPa", "--p-max", help="Supervisor's maximum pressure.")
LOAD_OPTION = typer.Option("0.6N", "--load", help="Hanging load, e.g. 0.6N.")
SUPPLY_OPTION = typer.Option(None, "--supply", help="Supply pressure (default: the calibrated plant's).")
MUSCLE_FILE_OPTION = typer.Option(None, "--muscle-file", help="A muscle file with a fitted force law (mckibben fit "
                                                                "… --save): control that muscle's plant.")
FORCE_OPTION = typer.Option(False, "--force", help="Run past the documented size limits (4 GiB, 10 min; "
                                                   "mckibben.limits); never past the memory available.")


def _size_first(option: str, seconds_text: str | None, instances: float = 1.0, force: bool = False,
                extra: float = 0.5) -> None:
    """Refuse an oversized job before the control package (python-control, SciPy) is even imported,
    so a refusal takes well under a second; the library checks the same again."""

    if seconds_text is None:
        return
    try:
        seconds = parse_quantity(seconds_text, "time", option, allow_zero=False)
    except Exception:  # noqa: BLE001 - the library gives the precise message
        return
    check_budget(option, instances * (seconds + extra) / 1e-3, force=force)


def _finish(res, plot, dpi, out, plot_kw=None) -> None:
    """Write the figure and the time series a command was asked for."""
    if plot:
        write_plot(res.plot(**(plot_kw or {})), plot, dpi, res)
    if out:
        res.to_file(out)


@control_app.command("step")
def step_cmd(
    controller: str = typer.Option("smc", "--controller", metavar=choices(R.NAMES), help=_CONTROLLER_HELP),
    target: str = typer.Option("0.55MPa", "--target", help="Step target pressure."),
    start: str = typer.Option("0MPa", "--from", help="Pressure held before the step."),
    beta: float = BETA_OPTION,
    law: str = LAW_OPTION,
    eps: str = EPS_OPTION,
    ki: float = KI_OPTION,
    lam: str = LAMBDA_OPTION,
    load: str = LOAD_OPTION,
    supply: str = SUPPLY_OPTION,
    p_max: str = PMAX_OPTION,
    duration: str = typer.Option("1s", "--duration", help="Time after the step."),
    plot: str = plot_option("the pressure and the commands"),
    dpi: int = DPI_OPTION,
    out: str = OUT_OPTION,
    save_design: str = typer.Option(None, "--save-design", help="Write the controller design (JSON) for "
                                                                 "mckibben rig gains --from."),
    force: bool = FORCE_OPTION,
    muscle_file: str = MUSCLE_FILE_OPTION,
    direction: str = DIRECTION_OPTION,
    json: bool = JSON_OPTION,
) -> None:
    """A pressure step on the calibrated plant under the firmware's controller."""
    _size_first("--duration", duration, force=force)

    check_outputs(plot, dpi, out)
    if save_design:
        check_output_file(save_design, "--save-design", (".json",))
    res = experiments.step_response(controller, parse_flag(target, "pressure", "target"), start=parse_flag(start, "pressure", "start"),
                                load=parse_flag(load, "force", "load"), supply=parse_flag(supply, "pressure", "supply", allow_zero=False),
                                duration=parse_flag(duration, "time", "duration", allow_zero=False),
                                p_max=parse_flag(p_max, "pressure", "p_max", allow_zero=False), law=law, beta=beta,
                                eps=parse_flag(eps, "pressure", "eps", allow_zero=False), ki=ki,
                                lam=parse_flag(lam, "time", "lam", allow_zero=False), force=force, muscle_file=muscle_file,
                                direction=direction)
    _finish(res, plot, dpi, out)
    if save_design:
        how = (f"tuned on the plant of {muscle_file} ({direction})" if muscle_file
               else "on the calibrated plant's identified model")
        control.core.save_design(res.params, save_design, note=f"control step {controller} ({law} law) {how}")
    _warn_outcome(res.faults, res.target_unreachable, float(res.record.pressure[0, -1]), res.arguments["target_Pa"])
    _warn_tuning(res.tuning)
    if json:
        emit_json(res.to_dict())
        return
    a, m = res.arguments, res.metrics
    print_table(f"{controller} step {a['from_Pa'] / 1e6:g} → {a['target_Pa'] / 1e6:g} MPa under {a['load_N']:g} N"
                + (" (clamped to --p-max)" if a["reference_clamped"] else ""),
                [" metric", "value"], [metric_row(k, m[k]) for k in STEP_KEYS])


def _warn_outcome(faults: int, unreachable: bool, final_pa: float, target_pa: float) -> None:
    """Faults and an unreachable target on stderr, whatever the output format."""

    if faults:
        err_console.print(f"warning: the supervisor reported faults: {', '.join(rig.protocol.fault_names(faults))} "
                          f"(flags {faults})", markup=False, highlight=False)
    if unreachable:
        err_console.print(f"warning: the target {target_pa / 1e6:g} MPa is unreachable: the pressure settled at "
                          f"{final_pa / 1e6:.3f} MPa with the inlet open (supply limit?)", markup=False,
                          highlight=False)


def _warn_tuning(tuning) -> None:
    """One line on stderr when no candidate gains met the design bar on a muscle file's plant."""
    if tuning is not None and not tuning.met:
        worst = max(s["overshoot_pct"] for s in tuning.steps)
        err_console.print(f"warning: no tuned {tuning.controller} gains met the design bar on every design step of "
                          f"this plant (worst overshoot {worst:.0f} %); the nearest were used (--json: tuning)",
                          markup=False, highlight=False)


@control_app.command("fig13")
def fig13_cmd(
    eps: str = EPS_OPTION,
    ki: float = KI_OPTION,
    plot: str = plot_option("the step responses and τ against β"),
    dpi: int = DPI_OPTION,
    out: str = OUT_OPTION,
    muscle_file: str = typer.Option(None, "--muscle-file", help="Refused: Fig. 13 is the paper's miniature muscle "
                                                                "(use control step --muscle-file)."),
    json: bool = JSON_OPTION,
) -> None:
    """The paper's Fig. 13: sliding mode, step to 0.55 MPa, β = 120 and 150, paper vs ours.

    Rows for both laws: ``paper`` (β·tanh(S/ε) alone, what the paper measured) and ``model``
    (ours, with the model term) at the paper's β.
    """

    check_outputs(plot, dpi, out)
    res = experiments.fig13(eps=parse_flag(eps, "pressure", "eps", allow_zero=False), ki=ki, muscle_file=muscle_file)
    _finish(res, plot, dpi, out)
    if json:
        emit_json(res.to_dict())
        return
    print_table("Fig. 13 ([mpam-characterization] §IV.B): step to 0.55 MPa, paper vs ours",
                ["law", "β counts", "τ paper s", "τ ours s", "overshoot paper %", "overshoot ours %", "rise s",
                 "settling s", "ss error Pa"],
                [[r["law"], r["beta_counts"], r["paper_time_constant_s"], r["time_constant_s"],
                  r["paper_overshoot_pct"], r["overshoot_pct"], r["rise_time_s"], r["settling_time_s"],
                  r["steady_state_error_Pa"]] for r in res.rows])


@control_app.command("compare")
def compare_cmd(
    beta: float = BETA_OPTION,
    plot: str = plot_option("the time constants"),
    dpi: int = DPI_OPTION,
    out: str = typer.Option(None, "--out", help="Write the table of runs: .csv or .parquet."),
    muscle_file: str = MUSCLE_FILE_OPTION,
    direction: str = DIRECTION_OPTION,
    json: bool = JSON_OPTION,
) -> None:
    """PID tuned on the first-order model vs both sliding-mode laws and the registry's other laws, over step sizes and loads (§IV.A)."""

    check_outputs(plot, dpi, out)
    res = experiments.compare(beta, muscle_file=muscle_file, direction=direction)
    _finish(res, plot, dpi, out)
    if json:
        emit_json(res.to_dict())
        return
    others = "".join(f", {c.name}: {c.summary.split(' (')[0]}" for c in R.EXTENSIONS)
    print_table(f"PID (lambda-tuned on the first-order model) vs sliding mode (smc: ours, smc_paper: β = 150{others})"
                if muscle_file is None else f"PID vs sliding mode (smc: ours, smc_paper: the paper's law{others}), "
                                            f"each tuned on the plant of {muscle_file} under each load",
                ["controller", "from MPa", "to MPa", "load N", "τ s", "overshoot %", "settling s", "ss error kPa"],
                [[r["controller"], r["from_Pa"] / 1e6, r["to_Pa"] / 1e6, r["load_N"], r["time_constant_s"],
                  r["overshoot_pct"], r["settling_time_s"], r["steady_state_error_Pa"] / 1e3] for r in res.rows])


@control_app.command("robustness")
def robustness_cmd(
    n: int = typer.Option(1000, "--n", help="Number of random plants."),
    seed: int = typer.Option(0, "--seed", help="Random seed."),
    beta: float = BETA_OPTION,
    plot: str = plot_option("the distributions"),
    dpi: int = DPI_OPTION,
    out: str = typer.Option(None, "--out", help="Write one row per plant and controller: .csv or .parquet."),
    force: bool = FORCE_OPTION,
    muscle_file: str = MUSCLE_FILE_OPTION,
    direction: str = DIRECTION_OPTION,
    json: bool = JSON_OPTION,
) -> None:
    """Monte Carlo over plant uncertainty: PID, both sliding-mode laws and the registry's other laws, median and 5–95 % of each metric."""
    if n >= 1:  # every compared controller (control.runs.CONTROLLER_NAMES), 0.6 s each
        _size_first("--n", "0.6s", instances=len(control.runs.CONTROLLER_NAMES) * n, force=force, extra=0.0)

    check_outputs(plot, dpi, out)
    with progress_bar("plants", json) as bar:
        task = bar.add_task("plants", total=n)
        res = experiments.robustness(n, seed=seed, beta=beta, force=force, muscle_file=muscle_file, direction=direction,
                         progress=lambda done, total: bar.update(task, completed=done))
    _finish(res, plot, dpi, out)
    if json:
        emit_json(res.to_dict())
        return
    rows = []
    for ctl, s in res.summary.items():
        for k, v in s.items():
            rows.append([ctl, k, v["median"], v["p5"], v["p95"], v["n_undefined"]])
    where = ("supply 0.6–1.0 MPa; load 0–3 N" if muscle_file is None else
             f"around the plant of {muscle_file}: supply 0.75–1 × its top, load 0–½ its pull at rest")
    print_table(f"robustness over {n} plants (±30 % valve gain, dead band, volumes, leak; {where})",
                ["controller", "metric", "median", "5 %", "95 %", "undefined"], rows)


@control_app.command("track")
def track_cmd(
    reference: str = typer.Option(..., "--reference", help="sine:MEAN,AMPLITUDE,FREQ (e.g. sine:0.4MPa,0.2MPa,2Hz) "
                                                           "or a CSV/Parquet file with time_<unit>, pressure_<unit>."),
    controller: str = typer.Option("smc", "--controller", metavar=choices(R.NAMES), help=_CONTROLLER_HELP),
    beta: float = BETA_OPTION,
    law: str = LAW_OPTION,
    eps: str = EPS_OPTION,
    ki: float = KI_OPTION,
    lam: str = LAMBDA_OPTION,
    load: str = LOAD_OPTION,
    p_max: str = PMAX_OPTION,
    duration: str = typer.Option("2s", "--duration", help="Duration for a sine reference."),
    plot: str = plot_option("the reference, pressure and commands"),
    dpi: int = DPI_OPTION,
    out: str = OUT_OPTION,
    force: bool = FORCE_OPTION,
    muscle_file: str = MUSCLE_FILE_OPTION,
    direction: str = DIRECTION_OPTION,
    json: bool = JSON_OPTION,
) -> None:
    """Track a pressure trajectory: RMS and maximum error, valve effort."""
    if reference.startswith("sine:"):
        _size_first("--duration", duration, force=force, extra=0.0)

    check_outputs(plot, dpi, out)
    res = experiments.track_pressure(control.parse_reference(reference), controller,
                                 duration=parse_flag(duration, "time", "duration", allow_zero=False),
                                 load=parse_flag(load, "force", "load"), p_max=parse_flag(p_max, "pressure", "p_max", allow_zero=False),
                                 law=law, beta=beta, eps=parse_flag(eps, "pressure", "eps", allow_zero=False), ki=ki,
                                 lam=parse_flag(lam, "time", "lam", allow_zero=False), force=force, muscle_file=muscle_file,
                                 direction=direction)
    _finish(res, plot, dpi, out)
    _warn_tuning(res.tuning)
    if json:
        emit_json(res.to_dict())
        return
    print_table(f"{controller} tracking {reference}", [" metric", "value"],
                [metric_row(k, v) for k, v in res.metrics.items()])


@control_app.command("hysteresis")
def hysteresis_cmd(
    period: str = typer.Option("4s", "--period", help="Period of the length sinusoid (1–60 s)."),
    sweep_period: str = typer.Option(None, "--sweep-period",
                                     help="Period of the identification triangle (default 8 × --period)."),
    plot: str = plot_option("the sweep loop and the tracking errors"),
    dpi: int = DPI_OPTION,
    muscle_file: str = typer.Option(None, "--muscle-file", help="Refused: a muscle file's plant runs one branch of "
                                                                "its law, with no friction loop to compensate."),
    json: bool = JSON_OPTION,
) -> None:
    """Length tracking with and without hysteresis compensation (inflate/deflate branches)."""

    check_outputs(plot, dpi)
    res = experiments.hysteresis_compensation(parse_flag(period, "time", "period", allow_zero=False),
                                          sweep_period=parse_flag(sweep_period, "time", "sweep_period", allow_zero=False),
                                          muscle_file=muscle_file)
    if plot:
        write_plot(control.plot_hysteresis(res), plot, dpi, res)
    if json:
        emit_json(res.summary())
        return
    s = res.summary()
    print_table(f"length target {res.mean * 1e3:.2f} ± {res.amplitude * 1e3:.2f} mm, period {res.period:g} s "
                f"(sweep {res.sweep_period:g} s, loop width {s['hysteresis_width_at_mean_Pa'] / 1e3:.0f} kPa); "
                "errors after the first cycle",
                ["method", "RMS error mm", "max error mm"],
                [["single cubic", res.rms_error[0] * 1e3, res.max_error[0] * 1e3],
                 ["inflate/deflate branches", res.rms_error[1] * 1e3, res.max_error[1] * 1e3],
                 ["ratio branches / single", res.rms_ratio, res.max_ratio]]
                + ([["Prandtl–Ishlinskii inverse", res.pi_rms_error * 1e3, res.pi_max_error * 1e3],
                    ["ratio PI / single", res.pi_rms_error / res.rms_error[0], res.pi_max_error / res.max_error[0]]]
                   if res.pi is not None else []))

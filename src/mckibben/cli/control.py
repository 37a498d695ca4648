"""``mckibben control step|track|fig13|compare|robustness|hysteresis``: the controller on the plant simulator."""

from __future__ import annotations

import math

import numpy as np
import typer

from mckibben.cli import app
from mckibben.cli._common import JSON_OPTION, emit_json, err_console, print_table
from mckibben.errors import InputError, unknown_name

control_app = typer.Typer(help="Control on the simulated plant: step, track, fig13, compare, robustness, hysteresis.",
                          no_args_is_help=True)
app.add_typer(control_app, name="control")

CONTROLLERS = ("smc", "pid")
STEP_KEYS = ("time_constant_s", "rise_time_s", "overshoot_pct", "settling_time_s", "steady_state_error_Pa",
             "rms_error_Pa", "valve_effort_counts")


def _png(plot: str | None) -> None:
    if plot is not None:
        from mckibben.atomic import check_output_file

        check_output_file(plot, "--plot", (".png",))


def _check_beta(beta: float | None) -> None:
    if beta is not None and not (math.isfinite(beta) and 0 <= beta <= 255):
        raise InputError(f"--beta: {beta!r} must be in 0..255 PWM counts")


def _controller_options(controller: str, beta: float | None, eps: str | None, ki: float | None, lam: str | None,
                        law: str = "model") -> dict:
    """Validate the controller options before anything runs (bad input → exit 2)."""
    from mckibben.control.experiments import LAWS
    from mckibben.units import parse_quantity

    if controller not in CONTROLLERS:
        raise unknown_name("controller", controller, CONTROLLERS)
    if law not in LAWS:
        raise unknown_name("--law", law, LAWS)
    _check_beta(beta)
    if ki is not None and not (math.isfinite(ki) and ki >= 0):
        raise InputError(f"--ki: {ki!r} must be >= 0 (1/s)")
    return {"controller": controller, "beta": beta, "ki": ki, "law": law,
            "eps": parse_quantity(eps, "pressure", "--eps", allow_zero=False) if eps else None,
            "lam": parse_quantity(lam, "time", "--lambda", allow_zero=False) if lam else None}


def _controller_params(opts: dict, model, p_max: float):
    from mckibben.control.controllers import pid_params
    from mckibben.control.core import CoreParams
    from mckibben.control.experiments import default_pid, smc_core_params

    from mckibben.control.controllers import with_supervisor_model

    base = with_supervisor_model(CoreParams(p_max=p_max), model)
    if opts["controller"] == "smc":
        return smc_core_params(model, opts["beta"], law=opts["law"], eps=opts["eps"], ki=opts["ki"], base=base)
    return pid_params(default_pid(model, opts["lam"]), base=base)


BETA_OPTION = typer.Option(None, "--beta", help="Sliding-mode switching gain of our law, PWM counts (default 50; "
                                               "the paper's law: 150 unless given).")
LAW_OPTION = typer.Option("model", "--law", help="Sliding-mode law: model (ours: model term with the valves' "
                                                 "lift-off) or paper (β·tanh(S/ε) alone, as the paper ran it).")
EPS_OPTION = typer.Option(None, "--eps", help="Sliding-mode boundary layer, e.g. 20kPa (default: docs/control.md).")
KI_OPTION = typer.Option(None, "--ki", help="Sliding-surface integral weight [1/s] (default: docs/control.md).")
LAMBDA_OPTION = typer.Option(None, "--lambda", help="PID closed-loop time constant, e.g. 30ms (default τ/3).")
PMAX_OPTION = typer.Option("0.8MPa", "--p-max", help="Supervisor's maximum pressure.")
LOAD_OPTION = typer.Option("0.6N", "--load", help="Hanging load, e.g. 0.6N.")
SUPPLY_OPTION = typer.Option(None, "--supply", help="Supply pressure (default: the calibrated plant's).")
FORCE_OPTION = typer.Option(False, "--force", help="Run past the documented size limits (4 GiB, 10 min; "
                                                   "mckibben.limits); never past the memory available.")


def _load(text: str) -> float:
    """The hanging load of the calibrated plant's muscle, checked against what it can lift. [N]"""
    from mckibben.datasets import get_muscle
    from mckibben.limits import check_load
    from mckibben.units import parse_quantity

    from mckibben.plant import PlantParams

    return check_load(parse_quantity(text, "force", "--load"), get_muscle(PlantParams().muscle_name))


def _periods(text: str, name: str) -> float:
    """A positive time that is a whole number of 1 ms control periods. [s]"""
    from mckibben.units import parse_quantity

    d = parse_quantity(text, "time", name, allow_zero=False)
    steps = d / 1e-3
    if steps >= 1 and abs(steps - round(steps)) > 1e-6 * steps:
        raise InputError(f"{name}: {text!r} must be a whole number of 1 ms control periods")
    if steps < 1 - 1e-9:
        raise InputError(f"{name}: {text!r} is shorter than one 1 ms control period")
    return d


@control_app.command("step")
def step_cmd(
    controller: str = typer.Option("smc", "--controller", help="smc or pid."),
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
    plot: str = typer.Option(None, "--plot", help="Write a PNG of pressure and commands."),
    force: bool = FORCE_OPTION,
    save_design: str = typer.Option(None, "--save-design", help="Write the controller design (JSON) for "
                                                                 "mckibben rig gains --from."),
    json: bool = JSON_OPTION,
) -> None:
    """A pressure step on the calibrated plant under the firmware's controller."""
    from mckibben.limits import check_budget, check_p_max, clamp_pressure
    from mckibben.units import parse_quantity

    # sizes and limits first: a refusal comes before any plant is built
    dur = _periods(duration, "--duration")
    pmax = check_p_max(parse_quantity(p_max, "pressure", "--p-max", allow_zero=False))
    p1 = parse_quantity(target, "pressure", "--target")
    p0 = parse_quantity(start, "pressure", "--from")
    hold = 0.5 if p0 > 0 else 0.05
    total = hold + dur
    check_budget("--duration", total / 1e-3, force=force)
    _png(plot)
    if save_design:
        from mckibben.atomic import check_output_file

        check_output_file(save_design, "--save-design", (".json",))
    if p0 == p1:
        raise InputError("--target: equals --from, there is no step")
    (p0c, p1c), clamped = clamp_pressure([p0, p1], pmax, "--target/--from")
    if p0c == p1c:
        raise InputError(f"--target: {target!r} and --from {start!r} are both clamped to {p1c / 1e6:g} MPa "
                         "(--p-max): there is no step")
    f_load = _load(load)

    from mckibben.control.core import core_spec
    from mckibben.control.experiments import identify_plant, plant_batch, run_closed_loop, step_reference

    opts = _controller_options(controller, beta, eps, ki, lam, law)
    plant_kw = {"load_N": f_load}
    if supply is not None:
        plant_kw["supply_Pa"] = parse_quantity(supply, "pressure", "--supply", allow_zero=False)
    plant = plant_batch(**plant_kw)
    _, model, _ = identify_plant()
    params = _controller_params(opts, model, pmax)
    if save_design:
        from mckibben.control.core import save_design as _save_design

        _save_design(params, save_design, note=f"control step {controller} ({opts['law']} law) on the calibrated "
                                                f"plant's identified model")
    n = int(round(total / 1e-3))
    ref = step_reference(n, int(round(hold / 1e-3)), p0c, p1c)
    rec = run_closed_loop(core_spec(params), ref, total, plant)
    m = rec.metrics(0, hold)
    out = {"controller": controller, "target_Pa": p1c, "from_Pa": p0c, "load_N": f_load, "p_max_Pa": pmax,
           "requested_target_Pa": p1, "requested_from_Pa": p0, "reference_clamped": clamped,
           "model": _model_dict(model),
           "gains": _gains_dict(params, controller),
           "peak_pressure_Pa": float(rec.pressure[0].max()),
           "faults": int(np.bitwise_or.reduce(rec.faults[0].astype(np.int64))),
           "target_unreachable": rec.target_unreachable(0), **m}
    if plot:
        _plot_records(plot, rec, [f"{controller}"], hold)
    _warn_outcome(out["faults"], out["target_unreachable"], float(rec.pressure[0, -1]), p1c)
    if json:
        emit_json(out)
        return
    print_table(f"{controller} step {p0c / 1e6:g} → {p1c / 1e6:g} MPa under {f_load:g} N"
                + (" (clamped to --p-max)" if clamped else ""),
                ["metric", "value"], [[k, m[k]] for k in STEP_KEYS])


def _warn_outcome(faults: int, unreachable: bool, final_pa: float, target_pa: float) -> None:
    """Faults and an unreachable target on stderr, whatever the output format."""
    from mckibben.rig.protocol import fault_names

    if faults:
        err_console.print(f"warning: the supervisor reported faults: {', '.join(fault_names(faults))} "
                          f"(flags {faults})", markup=False, highlight=False)
    if unreachable:
        err_console.print(f"warning: the target {target_pa / 1e6:g} MPa is unreachable: the pressure settled at "
                          f"{final_pa / 1e6:.3f} MPa with the inlet open (supply limit?)", markup=False,
                          highlight=False)


def _model_dict(model) -> dict:
    return {"gain_Pa_per_count": model.gain, "tau_s": model.tau, "dead_time_s": model.dead_time,
            "lift_off_counts": model.lift_off}


def _gains_dict(params, controller: str) -> dict:
    if controller == "smc":
        return {"law": "paper" if params.g == 0 else "model", "beta_counts": params.beta, "eps_Pa": params.eps,
                "ki_per_s": params.ki, "tau_s": params.tau, "g_Pa_per_count": params.g, "lift_off_counts": params.u0}
    return {"kp_counts_per_Pa": params.kp, "ki_counts_per_Pa_s": params.ki_pid, "kd_counts_s_per_Pa": params.kd,
            "tf_s": params.tf}


@control_app.command("fig13")
def fig13_cmd(
    eps: str = EPS_OPTION,
    ki: float = KI_OPTION,
    plot: str = typer.Option(None, "--plot", help="Write a PNG of the step responses and of τ against β."),
    json: bool = JSON_OPTION,
) -> None:
    """The paper's Fig. 13: sliding mode, step to 0.55 MPa, β = 120 and 150, paper vs ours.

    Rows for both laws: ``paper`` (β·tanh(S/ε) alone, what the paper measured) and ``model``
    (ours, with the model term) at the paper's β.
    """
    from mckibben.control.experiments import fig13, identify_plant
    from mckibben.units import parse_quantity

    _png(plot)
    e = parse_quantity(eps, "pressure", "--eps", allow_zero=False) if eps else None
    if ki is not None and not (math.isfinite(ki) and ki >= 0):
        raise InputError(f"--ki: {ki!r} must be >= 0 (1/s)")
    fit, model, _ = identify_plant()
    rows, rec = fig13(model, eps=e, ki=ki)
    if plot:
        sweep, _ = fig13(model, betas=np.arange(110.0, 201.0, 2.0), laws=("paper",))  # τ against β
        _plot_fig13(plot, rec, rows, sweep)
    if json:
        emit_json({"model": {**_model_dict(model), "tau_s_stderr": fit.stderr["tau_s"]}, "rows": rows})
        return
    print_table("Fig. 13 (000_909f662a44080c85.txt §IV.B): step to 0.55 MPa, paper vs ours",
                ["law", "β counts", "τ paper s", "τ ours s", "overshoot paper %", "overshoot ours %", "rise s",
                 "settling s", "ss error Pa"],
                [[r["law"], r["beta_counts"], r["paper_time_constant_s"], r["time_constant_s"],
                  r["paper_overshoot_pct"], r["overshoot_pct"], r["rise_time_s"], r["settling_time_s"],
                  r["steady_state_error_Pa"]] for r in rows])


@control_app.command("compare")
def compare_cmd(
    beta: float = BETA_OPTION,
    json: bool = JSON_OPTION,
) -> None:
    """PID tuned on the first-order model vs both sliding-mode laws, over step sizes and loads (§IV.A)."""
    from mckibben.control.experiments import identify_plant, step_size_table

    _check_beta(beta)
    _, model, _ = identify_plant()
    rows = step_size_table(model, beta=beta)
    if json:
        emit_json({"rows": rows})
        return
    print_table("PID (lambda-tuned on the first-order model) vs sliding mode (smc: ours, smc_paper: β = 150)",
                ["controller", "from MPa", "to MPa", "load N", "τ s", "overshoot %", "settling s", "ss error kPa"],
                [[r["controller"], r["from_Pa"] / 1e6, r["to_Pa"] / 1e6, r["load_N"], r["time_constant_s"],
                  r["overshoot_pct"], r["settling_time_s"], r["steady_state_error_Pa"] / 1e3] for r in rows])


#: Record length of each robustness run (:func:`mckibben.control.experiments.robustness`). [s]
ROBUSTNESS_DURATION = 0.6


@control_app.command("robustness")
def robustness_cmd(
    n: int = typer.Option(1000, "--n", help="Number of random plants."),
    seed: int = typer.Option(0, "--seed", help="Random seed."),
    beta: float = BETA_OPTION,
    plot: str = typer.Option(None, "--plot", help="Write a PNG of the distributions."),
    force: bool = FORCE_OPTION,
    json: bool = JSON_OPTION,
) -> None:
    """Monte Carlo over plant uncertainty: PID and both sliding-mode laws, median and 5–95 % of each metric."""
    from mckibben.limits import check_budget

    if n < 1:
        raise InputError(f"--n: {n!r} must be at least 1")
    if not 0 <= seed < 2**63:
        raise InputError(f"--seed: {seed!r} must be in 0..2**63-1")
    check_budget("--n", 3 * n * ROBUSTNESS_DURATION / 1e-3, force=force,
                 what="control periods (3 controllers × --n plants × 0.6 s)")
    _png(plot)
    _check_beta(beta)

    from mckibben.control.experiments import identify_plant, robustness
    _, model, _ = identify_plant()
    res = robustness(model, n=n, seed=seed, beta=beta)
    if plot:
        _plot_robustness(plot, res)
    if json:
        emit_json({"n": n, "seed": seed, "summary": res["summary"]})
        return
    rows = []
    for ctl, s in res["summary"].items():
        for k, v in s.items():
            rows.append([ctl, k, v["median"], v["p5"], v["p95"], v["n_undefined"]])
    print_table(f"robustness over {n} plants (±30 % valve gain, dead band, volumes, leak; supply 0.6–1.0 MPa; "
                "load 0–3 N)", ["controller", "metric", "median", "5 %", "95 %", "undefined"], rows)


@control_app.command("track")
def track_cmd(
    reference: str = typer.Option(..., "--reference", help="sine:MEAN,AMPLITUDE,FREQ (e.g. sine:0.4MPa,0.2MPa,2Hz) "
                                                           "or a CSV/Parquet file with time_<unit>, pressure_<unit>."),
    controller: str = typer.Option("smc", "--controller", help="smc or pid."),
    beta: float = BETA_OPTION,
    law: str = LAW_OPTION,
    eps: str = EPS_OPTION,
    ki: float = KI_OPTION,
    lam: str = LAMBDA_OPTION,
    load: str = LOAD_OPTION,
    p_max: str = PMAX_OPTION,
    duration: str = typer.Option("2s", "--duration", help="Duration for a sine reference."),
    plot: str = typer.Option(None, "--plot", help="Write a PNG of reference, pressure and commands."),
    force: bool = FORCE_OPTION,
    json: bool = JSON_OPTION,
) -> None:
    """Track a pressure trajectory: RMS and maximum error, valve effort."""
    from mckibben.limits import check_p_max, clamp_pressure
    from mckibben.units import parse_quantity

    _png(plot)
    pmax = check_p_max(parse_quantity(p_max, "pressure", "--p-max", allow_zero=False))
    f_load = _load(load)
    t, ref = _reference(reference, duration, force)
    ref, clamped = clamp_pressure(ref, pmax, "--reference")

    from mckibben.control.core import core_spec
    from mckibben.control.experiments import identify_plant, plant_batch, run_closed_loop
    from mckibben.control.metrics import tracking_metrics

    opts = _controller_options(controller, beta, eps, ki, lam, law)
    _, model, _ = identify_plant()
    params = _controller_params(opts, model, pmax)
    rec = run_closed_loop(core_spec(params), ref, float(len(ref)) * 1e-3, plant_batch(load_N=f_load))
    m = tracking_metrics(rec.t, rec.pressure[0], rec.reference[0], rec.command[0])
    if plot:
        _plot_records(plot, rec, [controller], None)
    if json:
        emit_json({"controller": controller, "load_N": f_load, "p_max_Pa": pmax, "reference_clamped": clamped,
                   "gains": _gains_dict(params, controller), **m})
        return
    print_table(f"{controller} tracking {reference}", ["metric", "value"], [[k, v] for k, v in m.items()])


def _reference(text: str, duration: str, force: bool = False):
    """A reference from ``sine:MEAN,AMP,FREQ`` or a file, resampled at 1 kHz. [s], [Pa]

    The number of samples is checked against the size limits (:mod:`mckibben.limits`) before
    anything is allocated.
    """
    from mckibben.limits import check_budget
    from mckibben.units import parse_quantity

    if text.startswith("sine:"):
        parts = text[5:].split(",")
        if len(parts) != 3:
            raise InputError(f"--reference: {text!r} must be sine:MEAN,AMPLITUDE,FREQUENCY")
        mean = parse_quantity(parts[0], "pressure", "--reference mean")
        amp = parse_quantity(parts[1], "pressure", "--reference amplitude")
        freq = parse_quantity(parts[2], "frequency", "--reference frequency", allow_zero=False)
        dur = _periods(duration, "--duration")
        check_budget("--duration", dur / 1e-3, force=force)
        if freq > 500:
            raise InputError(f"--reference frequency: {parts[2]!r} is above the 500 Hz a 1 kHz controller can follow")
        t = np.arange(int(round(dur / 1e-3))) * 1e-3
        return t, mean + amp * np.sin(2 * np.pi * freq * t)
    from mckibben.control.identify import read_step_log

    data, _ = read_step_log(text)
    t0 = data["time_s"] - data["time_s"][0]
    check_budget(f"--reference {text}", float(t0[-1]) / 1e-3, force=force, what="control periods (the file's span)")
    t = np.arange(int(t0[-1] / 1e-3) + 1) * 1e-3
    if t.size < 10:
        raise InputError(f"--reference: {text!r} is shorter than 10 ms")
    return t, np.interp(t, t0, data["pressure_Pa"])


def _plot_records(path: str, rec, labels, t_step) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from mckibben.cli.identify import save_png

    fig, (ax, axu) = plt.subplots(2, 1, sharex=True, figsize=(7, 5.5), gridspec_kw={"height_ratios": [3, 1.3]})
    ax.plot(rec.t, rec.reference[0] / 1e6, "k--", lw=1, label="reference")
    for i, lab in enumerate(labels):
        ax.plot(rec.t, rec.pressure[i] / 1e6, label=lab)
        axu.plot(rec.t, rec.command[i], lw=0.8, label=lab)
    ax.set_ylabel("pressure [MPa]")
    ax.legend()
    axu.set_ylabel("inlet − bleed [PWM]")
    axu.set_xlabel("time [s]")
    fig.tight_layout()
    save_png(fig, path)
    plt.close(fig)


def _plot_fig13(path: str, rec, rows, sweep) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from mckibben.plotting import save_figure

    fig, (ax, axb) = plt.subplots(1, 2, figsize=(11, 4.5))
    ax.plot(rec.t, rec.reference[0] / 1e6, "k--", lw=1, label="reference")
    for i, r in enumerate(rows):
        ax.plot(rec.t, rec.pressure[i] / 1e6, ls="-" if r["law"] == "paper" else ":",
                label=f"{r['law']} law, β = {r['beta_counts']:g}")
    ax.set_xlim(0.08, 0.4)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("pressure [MPa]")
    ax.legend(fontsize=8)
    ax.set_title("step to 0.55 MPa")
    b = np.array([r["beta_counts"] for r in sweep])
    tc = np.array([r["time_constant_s"] for r in sweep])
    axb.semilogy(b, tc * 1e3, "o-", ms=3, label="paper's law on the plant")
    axb.semilogy([120, 150], [60, 10], "k*", ms=12, label="paper, Fig. 13")
    axb.axhspan(45, 75, xmin=0, xmax=1, color="C1", alpha=0.1)
    axb.set_xlabel("β [PWM counts]")
    axb.set_ylabel("time constant [ms]")
    axb.set_title("τ against β: β must exceed the holding command (eq. 11)")
    axb.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


def _plot_robustness(path: str, res) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from mckibben.cli.identify import save_png
    from mckibben.control.experiments import CONTROLLER_NAMES

    keys = [("time_constant_s", 1e3, "time constant [ms]"), ("overshoot_pct", 1.0, "overshoot [%]"),
            ("steady_state_error_Pa", 1e-3, "steady-state error [kPa]")]
    fig, axes = plt.subplots(1, 3, figsize=(11, 3.8))
    for ax, (k, scale, lab) in zip(axes, keys):
        data = [res["metrics"][c][k] * scale for c in CONTROLLER_NAMES]
        data = [d[np.isfinite(d)] for d in data]
        ax.boxplot(data, whis=(5, 95), showfliers=True, flierprops={"markersize": 2})
        ax.set_xticks([1, 2, 3], ["PID", "SMC\n(ours)", "SMC, paper's\nlaw, β = 150"])
        ax.set_ylabel(lab)
    fig.suptitle(f"{len(res['metrics']['pid']['time_constant_s'])} random plants (whiskers 5–95 %)")
    fig.tight_layout()
    save_png(fig, path)
    plt.close(fig)


PLOT_SUFFIXES = (".png", ".svg", ".pdf")


@control_app.command("hysteresis")
def hysteresis_cmd(
    period: str = typer.Option("4s", "--period", help="Period of the length sinusoid (1–60 s)."),
    sweep_period: str = typer.Option(None, "--sweep-period",
                                     help="Period of the identification triangle (default 8 × --period)."),
    plot: str = typer.Option(None, "--plot", help="Write the sweep loop and the tracking errors (.png, .svg, .pdf)."),
    json: bool = JSON_OPTION,
) -> None:
    """Length tracking with and without hysteresis compensation (inflate/deflate branches)."""
    from mckibben.control.experiments import identify_plant
    from mckibben.control.hysteresis import (
        PERIOD_MAX,
        PERIOD_MIN,
        SWEEP_PERIOD_MAX,
        SWEEP_PERIOD_MIN,
        hysteresis_benefit,
    )
    from mckibben.units import parse_quantity

    if plot is not None:
        from mckibben.atomic import check_output_file

        check_output_file(plot, "--plot", PLOT_SUFFIXES)
    per = parse_quantity(period, "time", "--period", allow_zero=False)
    if not PERIOD_MIN <= per <= PERIOD_MAX:
        raise InputError(f"--period: {period!r} must be between {PERIOD_MIN:g} s and {PERIOD_MAX:g} s")
    sweep = None
    if sweep_period is not None:
        sweep = parse_quantity(sweep_period, "time", "--sweep-period", allow_zero=False)
        if not SWEEP_PERIOD_MIN <= sweep <= SWEEP_PERIOD_MAX:
            raise InputError(f"--sweep-period: {sweep_period!r} must be between {SWEEP_PERIOD_MIN:g} s and "
                             f"{SWEEP_PERIOD_MAX:g} s")
    _, model, _ = identify_plant()
    res = hysteresis_benefit(model, period=per, sweep_period=sweep)
    if plot:
        _plot_hysteresis(plot, res)
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
                 ["ratio branches / single", res.rms_ratio, res.max_ratio]])


def _plot_hysteresis(path: str, res) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from mckibben.plotting import save_figure

    fig, (ax, axe) = plt.subplots(1, 2, figsize=(11, 4.5))
    up = res.sweep_inflating
    ax.plot(res.sweep_pressure[up] / 1e6, res.sweep_length[up] * 1e3, ".", ms=1.5, color="C3",
            label="sweep, inflating")
    ax.plot(res.sweep_pressure[~up] / 1e6, res.sweep_length[~up] * 1e3, ".", ms=1.5, color="C0",
            label="sweep, deflating")
    ell = np.linspace(*res.branches.length_range, 200)
    ax.plot(res.branches.pressure(ell, True) / 1e6, ell * 1e3, "-", color="darkred", lw=1.5, label="inflating fit")
    ax.plot(res.branches.pressure(ell, False) / 1e6, ell * 1e3, "-", color="navy", lw=1.5, label="deflating fit")
    ax.plot(res.single(ell) / 1e6, ell * 1e3, "k--", lw=1, label="single cubic")
    ax.set_xlabel("pressure [MPa]")
    ax.set_ylabel("length [mm]")
    ax.set_title(f"identification sweep ({res.sweep_period:g} s)")
    ax.legend(fontsize=8)
    for i, lab in enumerate(("single cubic", "branches")):
        axe.plot(res.t, (res.length[i] - res.length_ref) * 1e3,
                 label=f"{lab}: RMS {res.rms_error[i] * 1e3:.2f} mm")
    axe.axvspan(0, res.period, color="0.9", label="first cycle (not scored)")
    axe.axhline(0, color="k", lw=0.5)
    axe.set_xlabel("time [s]")
    axe.set_ylabel("length − target [mm]")
    axe.set_title(f"tracking {res.mean * 1e3:.1f} ± {res.amplitude * 1e3:.1f} mm, period {res.period:g} s")
    axe.legend(fontsize=8)
    fig.tight_layout()
    try:
        save_figure(fig, path)
    finally:
        plt.close(fig)

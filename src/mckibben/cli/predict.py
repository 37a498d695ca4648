"""``mckibben predict length|pressure|force``: evaluate the static models from the command line."""

from __future__ import annotations

import dataclasses

import numpy as np
import typer

from mckibben.cli import app
from mckibben.cli._common import DIRECTION_OPTION, JSON_OPTION, emit_json, muscle_option, print_table
from mckibben.datasets import LAW_SETS, MUSCLES, get_muscle, law_set_muscle
from mckibben.errors import InputError
from mckibben.limits import check_load, check_p_max
from mckibben.models import laws
from mckibben.models.flags import flag_names
from mckibben.units import parse_quantity, parse_values
from mckibben.errors import unknown_name
from mckibben.models.geometry import miniature_geometry
from mckibben.models.mpam import MiniatureMuscle
from mckibben.models.muscle import Muscle
from mckibben.models.static import force as static_force
from mckibben.models.static import force_laws
from mckibben.models.static import length as static_length
from mckibben.models.static import pressure as static_pressure
from mckibben import data, fit

predict_app = typer.Typer(help="Predict length, pressure or force from a static model.", no_args_is_help=True)
app.add_typer(predict_app, name="predict")

MUSCLE_OPTION = muscle_option(None, "Published parameter set (see `mckibben params list`): a miniature muscle "
                              "(default mpam97) or a law's own set (default with --model LAW of a law that has one).")
LOAD_OPTION = typer.Option("0.6N", "--load", help="Hanging load, e.g. 0.6N, 60gf, 2.1N.")
PMAX_OPTION = typer.Option("0.8MPa", "--p-max", help="Highest pressure allowed.")

def catalogue_laws() -> list[str]:
    """The registered laws ``--model`` takes: those with parameters for a catalogue muscle
    (:func:`~mckibben.models.static.force_laws`) or a published set of their own (:data:`~mckibben.datasets.LAW_SETS`)."""
    own = {law for law, _ in LAW_SETS.values()}
    return [n for n in laws.LAWS if n in force_laws() or n in own]


LENGTH_MODEL_OPTION = typer.Option(None, "--model", help="A registered force law with a published parameter set, "
                                   f"solved for the length: {', '.join(catalogue_laws())} (default: braid-map, eq. 2 + 3,"
                                   " or the law of a --muscle set; old names read).")
BRANCH_HELP = ("inflate or deflate: the {what} far along that branch of the loop of a --muscle-file with a fitted "
               "friction (mckibben rig characterize, fit --direction-aware --save) or play (fit --direction-aware "
               "--save); default the static {what}.")
STATICS_FILE_OPTION = typer.Option(None, "--muscle-file", help="A muscle file with a fitted force law (mckibben fit "
                                   "ISO.csv --save FILE.toml), solved for the length; replaces --model and --muscle.")


def _rows_or_scalars(records: dict, scalar: bool) -> dict:
    if scalar:
        return {k: (v[0] if isinstance(v, list) else v) for k, v in records.items()}
    return records


def _law(model: str | None, flag: str = "--model") -> str | None:
    """``--model``: a registered law with a published parameter set (old names read, with a deprecation note)."""
    if model is None:
        return None
    if model not in laws.LAWS and model not in laws.ALIASES:
        raise unknown_name(flag, model, catalogue_laws())
    name = laws.resolve(model)
    if name not in catalogue_laws():
        raise InputError(f"{flag}: {name} has no published parameters for a catalogue muscle; fit it (mckibben fit "
                         f"... --model {name} --save F.toml) and give --muscle-file F.toml")
    return name


def catalogue_muscle(muscle: str | None, model: str | None, flag: str = "--model"):
    """``(muscle, law name or None)`` of ``--muscle`` and ``--model``: a catalogue miniature muscle
    (default mpam97), or a law's published set as a muscle (:func:`~mckibben.datasets.law_set_muscle`),
    named by ``--muscle`` or the set of ``--model LAW`` (a law with no parameters for a catalogue muscle)."""
    name = _law(model, flag)
    key = muscle.strip().lower() if isinstance(muscle, str) else None
    if key in LAW_SETS:
        own = LAW_SETS[key][0]
        if name is not None and name != own:
            raise InputError(f"{flag}: {name} is not the law of the published set {key} ({own}); leave {flag} out "
                             f"or give {flag} {own}")
        return law_set_muscle(key), own
    if name is not None and name not in force_laws():
        sets = [k for k, (law, _) in LAW_SETS.items() if law == name]
        if muscle is not None:
            raise InputError(f"--muscle: {muscle!r}: the {name} law's published parameters are the set(s) "
                             f"{', '.join(sets)}, not a catalogue muscle's; give --muscle {sets[0]} or leave it out")
        return law_set_muscle(sets[0]), name
    if key is not None and key not in MUSCLES:
        raise unknown_name("muscle", muscle, [*MUSCLES, *LAW_SETS])
    return get_muscle("mpam97" if muscle is None else muscle), name


def _statics_muscle(muscle: str | None, muscle_file: str | None, model: str | None, load: str):
    """The muscle (a catalogue set, a law's set, or a muscle file's fitted law), the law name, and the load [N] checked against it."""
    if muscle_file is None:
        m, name = catalogue_muscle(muscle, model)
        f = parse_quantity(load, "force", "--load")
        return m, name, (check_load(f, m) if isinstance(m, MiniatureMuscle) else f)  # a catalogue muscle's blocked force
    if model is not None:
        raise InputError(f"--model: {model!r} with --muscle-file: the file carries its own fitted law; give one of them")
    return Muscle.from_spec(data.read_muscle(muscle_file)), None, parse_quantity(load, "force", "--load")


@predict_app.command("length")
def length_cmd(
    muscle: str = MUSCLE_OPTION,
    pressure: str = typer.Option(..., "--pressure", help="Pressure, list or range: 0.8MPa, 0.2,0.4MPa, 0:0.8MPa:9."),
    load: str = LOAD_OPTION,
    model: str = LENGTH_MODEL_OPTION,
    muscle_file: str = STATICS_FILE_OPTION,
    branch: str = typer.Option(None, "--branch", help=BRANCH_HELP.format(what="length")),
    json: bool = JSON_OPTION,
) -> None:
    """Length and contraction at a pressure under a hanging load (eq. 2 + 3, or a registered law solved for the length)."""
    m, name, f = _statics_muscle(muscle, muscle_file, model, load)
    p = parse_values(pressure, "pressure", "--pressure")
    r = static_length(p, f, m, name, branch)
    flags = [flag_names(x) for x in r.flags]
    if json:
        out = {
            "model": r.model,
            "muscle": m.name,
            "load_N": f,
            "branch": branch,
            "pressure_Pa": r.pressure.tolist(),
            "length_m": r.length.tolist(),
            "contraction": r.contraction.tolist(),
            "cos_theta": r.cos_theta.tolist(),
            "flags": flags,
        }
        scalar = len(p) == 1 and "," not in pressure and ":" not in pressure
        emit_json(_rows_or_scalars(out, scalar))
        return
    rows = [
        [f"{pp / 1e6:.4g}", f"{ll * 1e3:.2f}", f"{cc * 100:.1f}", f"{ct:.4f}", ", ".join(fl) or "ok"]
        for pp, ll, cc, ct, fl in zip(r.pressure, r.length, r.contraction, r.cos_theta, flags)
    ]
    print_table(f"{m.name} under {f:g} N ({r.model}{', ' + branch if branch else ''})", ["pressure MPa", "length mm", "contraction %", "cos θ", "flags"], rows)


@predict_app.command("pressure")
def pressure_cmd(
    muscle: str = MUSCLE_OPTION,
    length: str = typer.Option(..., "--length", help="Target length, list or range: 85mm, 80,85,90mm."),
    load: str = LOAD_OPTION,
    p_max: str = PMAX_OPTION,
    model: str = LENGTH_MODEL_OPTION,
    muscle_file: str = STATICS_FILE_OPTION,
    branch: str = typer.Option(None, "--branch", help=BRANCH_HELP.format(what="pressure")),
    json: bool = JSON_OPTION,
) -> None:
    """The pressure that holds a target length under a load (the inverse of eq. 2 + 3, or of a registered law)."""
    m, name, f = _statics_muscle(muscle, muscle_file, model, load)
    lengths = parse_values(length, "length", "--length", allow_zero=False)
    pmax = check_p_max(parse_quantity(p_max, "pressure", "--p-max", allow_zero=False))
    r = static_pressure(lengths, f, m, name, pmax, branch)
    flags = [flag_names(x) for x in r.flags]
    if json:
        out = {
            "model": r.model,
            "muscle": m.name,
            "load_N": f,
            "branch": branch,
            "p_max_Pa": pmax,
            "length_m": r.length.tolist(),
            "pressure_Pa": r.pressure.tolist(),
            "contraction": r.contraction.tolist(),
            "cos_theta": r.cos_theta.tolist(),
            "flags": flags,
        }
        scalar = len(lengths) == 1 and "," not in length and ":" not in length
        emit_json(_rows_or_scalars(out, scalar))
        return
    rows = [
        [f"{ll * 1e3:.2f}", "unreachable" if not np.isfinite(pp) else f"{pp / 1e6:.4f}", f"{cc * 100:.1f}", ", ".join(fl) or "ok"]
        for ll, pp, cc, fl in zip(r.length, r.pressure, r.contraction, flags)
    ]
    print_table(f"{m.name} under {f:g} N, p ≤ {pmax / 1e6:g} MPa ({r.model}{', ' + branch if branch else ''})", ["length mm", "pressure MPa", "contraction %", "flags"], rows)


@predict_app.command("force")
def force_cmd(
    model: str = typer.Option(None, "--model", help="A registered force law with a published parameter set: "
                                                    f"{', '.join(catalogue_laws())} (default chou-hannaford, or the law "
                                                    "of a --muscle set; old names read)."),
    muscle: str = MUSCLE_OPTION,
    pressure: str = typer.Option(..., "--pressure", help="Pressure, list or range: 0.8MPa, 0:0.8MPa:9."),
    length: str = typer.Option(None, "--length", help="Muscle length (default: the rest length, i.e. blocked force)."),
    rest_length: str = typer.Option(None, "--rest-length", help="Rest length L0 (default: the muscle's nominal length)."),
    diameter: str = typer.Option(None, "--diameter", help="Braid diameter at rest (default: OD − strand, 1.1 mm)."),
    braid_angle: str = typer.Option(None, "--braid-angle", help="Braid angle at rest, from the axis (default 20deg)."),
    wall: str = typer.Option(None, "--wall", help="Tube wall thickness for wall-corrected (default 0.2mm)."),
    k: float = typer.Option(1.0, "--k", help="Tondu–Lopez contraction correction k [-]."),
    muscle_file: str = typer.Option(None, "--muscle-file", help="A muscle file with a fitted force law "
                                                                "(mckibben fit ISO.csv --save FILE.toml); "
                                                                "replaces --model and --muscle."),
    direction: str = DIRECTION_OPTION,
    branch: str = typer.Option(None, "--branch", help=BRANCH_HELP.format(what="force")),
    json: bool = JSON_OPTION,
) -> None:
    """Pulling force from pressure and length: empirical map, a physical model, or a muscle file's fitted law."""
    if muscle_file is not None:
        _force_from_muscle_file(muscle_file, pressure, length, direction, json, branch)
        return
    if branch is not None:
        raise InputError(f"--branch: {branch!r} takes the loop of a --muscle-file with a fitted friction or play; "
                         "a published law has none")

    if model is not None and model not in laws.LAWS and model not in laws.ALIASES:
        raise unknown_name("force model", model, catalogue_laws())
    m, name = catalogue_muscle(muscle, model)
    if not isinstance(m, MiniatureMuscle):  # a law's published set: its own constants, no geometry to vary
        _force_of_set(m, pressure, length, json, rest_length=rest_length, diameter=diameter, braid_angle=braid_angle,
                      wall=wall, k=None if k == 1.0 else k)
        return
    name = name or "chou-hannaford"
    g = m.geometry
    p = parse_values(pressure, "pressure", "--pressure")
    l0 = parse_quantity(rest_length, "length", "--rest-length", allow_zero=False) if rest_length else m.nominal_length
    d = parse_quantity(diameter, "length", "--diameter", allow_zero=False) if diameter else g.outer_diameter - g.strand_diameter
    angle = parse_quantity(braid_angle, "angle", "--braid-angle", allow_zero=False) if braid_angle else g.braid_angle
    if not angle < np.pi / 2:
        raise InputError(f"--braid-angle: {braid_angle!r} must be below 90deg")
    t = parse_quantity(wall, "length", "--wall") if wall else g.wall_thickness
    if t >= d / 2:
        if wall:
            raise InputError(f"--wall: {wall!r} must be less than half the diameter ({d / 2 * 1e3:g} mm)")
        raise InputError(f"--diameter: {diameter!r} leaves no room for the default {t * 1e3:g} mm wall "
                         f"(it must exceed {2 * t * 1e3:g} mm, or give a thinner --wall)")
    if not np.isfinite(k) or k < 1:
        raise InputError(f"--k: {k!r} must be a finite correction >= 1 (k = 1 is the ideal Tondu–Lopez muscle; "
                         "real muscles reach zero force sooner, k > 1)")
    ell = parse_quantity(length, "length", "--length", allow_zero=False) if length else l0
    if d >= l0:
        raise InputError(f"--diameter: {d * 1e3:g} mm is not smaller than the rest length {l0 * 1e3:g} mm "
                         "(a braided muscle is long and thin)")
    # the muscle as given: its rest length, braid diameter (outer less one strand), angle and wall
    tube_od = max(g.tube_outer_diameter, 2 * t + 1e-9) if wall else g.tube_outer_diameter
    m = dataclasses.replace(m, nominal_length=l0, geometry=dataclasses.replace(
        g, outer_diameter=d + g.strand_diameter, braid_angle=angle, tube_outer_diameter=min(tube_od, d),
        tube_inner_diameter=min(tube_od, d) - 2 * t))
    geom = miniature_geometry(l0, m.geometry, wall=True)
    # the straight braid of the law's own parameters (the map's pantograph), else the muscle's ideal braid
    strand = getattr(laws.LAWS[name].published(m), "strand_length", geom.strand_length)
    if ell > strand:
        raise InputError(f"--length: {ell * 1e3:g} mm is longer than the braid's strand length {strand * 1e3:.4g} mm "
                         "(eq. 1: a muscle cannot stretch past a straight braid)")
    r = static_force(p, ell, m, name, **({"k": k} if k != 1.0 else {}))
    force = np.broadcast_to(r.load, p.shape)
    names = [flag_names(x) for x in np.broadcast_to(r.flags, p.shape)]
    geometry = {
        "rest_length_m": l0,
        "diameter_m": d,
        "braid_angle_rad": angle,
        "wall_thickness_m": geom.wall_thickness,
        "strand_length_m": geom.strand_length,
        "turns": geom.turns,
    }
    if json:
        out = {"model": name, "muscle": m.name, "length_m": ell, "pressure_Pa": p.tolist(), "force_N": force.tolist(), "flags": names}
        scalar = len(p) == 1 and "," not in pressure and ":" not in pressure
        emit_json(_rows_or_scalars(out, scalar) | {"geometry": geometry})
        return
    rows = [[f"{pp / 1e6:.4g}", f"{ff:.3f}", ", ".join(fl) or "ok"] for pp, ff, fl in zip(p, force, names)]
    print_table(f"{name} force, {m.name}, length {ell * 1e3:.2f} mm", ["pressure MPa", "force N", "flags"], rows)


def _force_of_set(m, pressure: str, length: str | None, json: bool, **geometry) -> None:
    """``predict force`` of a law's published set (:func:`~mckibben.datasets.law_set_muscle`)."""
    given = [k for k, v in geometry.items() if v is not None]
    if given:
        flag = "--" + given[0].replace("_", "-")
        raise InputError(f"{flag}: the published set {m.name} carries its own {m.law} constants for its "
                         f"{m.nominal_length * 1e3:g} mm muscle; {flag} changes a catalogue miniature muscle only")
    p = parse_values(pressure, "pressure", "--pressure")
    ell = parse_quantity(length, "length", "--length", allow_zero=False) if length else m.nominal_length
    r = static_force(p, ell, m)
    force = np.broadcast_to(r.load, p.shape)
    names = [flag_names(x) for x in np.broadcast_to(r.flags, p.shape)]
    if json:
        out = {"model": r.model, "muscle": m.name, "length_m": ell, "pressure_Pa": p.tolist(), "force_N": force.tolist(),
               "flags": names}
        scalar = len(p) == 1 and "," not in pressure and ":" not in pressure
        emit_json(_rows_or_scalars(out, scalar) | {"rest_length_m": m.nominal_length, "citation": m.citation})
        return
    rows = [[f"{pp / 1e6:.4g}", f"{ff:.3f}", ", ".join(fl) or "ok"] for pp, ff, fl in zip(p, force, names)]
    print_table(f"{r.model} force, published set {m.name}, length {ell * 1e3:.2f} mm", ["pressure MPa", "force N", "flags"],
                rows)


def _force_from_muscle_file(path: str, pressure: str, length: str | None, direction: str, json: bool,
                            branch: str | None = None) -> None:
    """``predict force --muscle-file``: the file's fitted force law at the given pressures (on a ``branch`` of its loop)."""

    fit.muscle_file.check_direction(direction)
    law = fit.muscle_file.muscle_force_law(data.read_muscle(path))
    fit.muscle_file.check_direction(direction, law)
    p = parse_values(pressure, "pressure", "--pressure")
    ell = parse_quantity(length, "length", "--length", allow_zero=False) if length else law.spec.nominal_length
    force, flags = law.force(p, ell, direction, branch)
    names = [flag_names(x) for x in flags]
    # the uncertainty the file stores: the fit's RMS residual (the scatter of a prediction about the
    # data) and the parameters' standard errors
    stored = law.spec.force_model or {}
    rmse = stored.get("rmse_N")
    rmse = float(rmse) if isinstance(rmse, (int, float)) and not isinstance(rmse, bool) else None
    if json:
        out = {"model": law.model, "muscle": law.spec.id, "muscle_file": path, "direction": direction, "branch": branch,
               "length_m": ell, "pressure_Pa": p.tolist(), "force_N": force.tolist(), "flags": names}
        scalar = len(p) == 1 and "," not in pressure and ":" not in pressure
        emit_json(_rows_or_scalars(out, scalar) | {"fit_flags": list(law.flags), "fit_rmse_N": rmse,
                                                   "parameters": dict(law.parameters),
                                                   "parameters_stderr": dict(stored.get("stderr") or {})})
        return
    pm = f" ± {rmse:.3g}" if rmse is not None else ""
    rows = [[f"{pp / 1e6:.4g}", f"{ff:.3f}{pm}", ", ".join(fl) or "ok"] for pp, ff, fl in zip(p, force, names)]
    print_table(f"{law.model} force fitted for {law.spec.id} ({path}), length {ell * 1e3:.2f} mm, "
                + (f"{branch} branch" if branch else direction)
                + (f"; ± the fit's RMS residual {rmse:.3g} N" if rmse is not None else ""),
                ["pressure MPa", "force N", "flags"], rows)

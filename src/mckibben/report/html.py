"""The characterization report: a summary (JSON-ready), an HTML page and its PNG figures.

:func:`write_report` writes everything into a temporary folder beside ``out`` and renames it into
place at the end, so a failure leaves nothing half-written.
"""

from __future__ import annotations

import html
import inspect
import os
from pathlib import Path

import numpy as np

from mckibben.errors import ArgumentTypeError, InputError, check_callable
from mckibben.report import figures as FIG
from mckibben.report.figures import ALL_FIGURES, ISOMETRIC_FIGURES
from mckibben.atomic import check_output_dir
from mckibben.datasets.campaign import campaign_muscle_dirs
from mckibben.datasets.references import cited, render
from mckibben.models.laws.spring import LAW as _SPRING_LAW
from mckibben.results import provenance
from mckibben.results import to_jsonable
from mckibben.atomic import atomic_dir
import hashlib
import json

MPA = 1e6


def _pm(v, se, scale=1.0, digits=3):
    return f"{v * scale:.{digits}g} ± {se * scale:.2g}"


def _check_dict(value, name: str, keys: tuple, source: str) -> None:
    """``value`` is the dict ``source`` returns (it has ``keys``); else an error naming ``name``."""
    if not isinstance(value, dict):
        raise ArgumentTypeError(f"{name} = {value!r}: not a dict ({type(value).__name__}); give what {source} returns")
    missing = [k for k in keys if k not in value]
    if missing:
        raise InputError(f"{name}: has no {', '.join(missing)}; give what {source} returns")


def summarize(char: dict) -> dict:
    """The fitted Tables I and II beside the published values, blocked force, τ and the comparison.

    Parameters
    ----------
    char : dict
        From :func:`mckibben.report.characterize.characterize`.

    Returns
    -------
    dict
        JSON-ready, SI values with unit-suffixed keys.
    """
    _check_dict(char, "char", ("muscles",), "characterize()")
    t1, t2, bf, steps, spring, comp = [], [], [], [], [], {}
    for r in char["muscles"]:
        pub = r.published
        if r.kinematic is not None:
            k = r.kinematic
            t1.append({"muscle": r.spec.id, "strand_length_m": r.spec.strand_length,
                       "k1": k["k1"], "k1_stderr": k.se("k1"), "k1_ci95": k.ci95[0].tolist(),
                       "k2_m": k["k2_m"], "k2_stderr_m": k.se("k2_m"), "k2_ci95_m": k.ci95[1].tolist(),
                       "k1_published": pub.k1 if pub else None, "k2_published_m": pub.k2 if pub else None,
                       "residual_rms_m": k.residual_rms, "r2": k.r2, "n_points": k.n_points})
        for (load, _), res in sorted(r.braid_cubics.items()):
            row = {"muscle": r.spec.id, "load_N": load, "coefficients_P_in_MPa": res.values.tolist(),
                   "stderr": res.stderr.tolist(), "ci95": res.ci95.tolist(), "residual_rms": res.residual_rms,
                   "n_points": res.n_points, "published": None}
            if pub is not None and np.any(np.isclose(pub.braid_map.loads, load)):
                i = int(np.flatnonzero(np.isclose(pub.braid_map.loads, load))[0])
                row["published"] = list(pub.braid_map.coefficients[i])
            t2.append(row)
        if r.blocked_force is not None:
            f, _ = r.blocked_force.predict(pressure=0.8e6)
            bf.append({"muscle": r.spec.id, "force_at_0_8MPa_N": float(f), "band95_N": float(r.blocked_force.band(pressure=0.8e6)),
                       "published_N": pub.blocked_force[0][1] if pub else None})
        for cmd, res in sorted(r.steps.items()):
            steps.append({"muscle": r.spec.id, "command": cmd, "tau_s": res["tau_s"], "tau_stderr_s": res.se("tau_s"),
                          "tau_ci95_s": res.ci95[2].tolist(), "p_final_Pa": res["p_final_Pa"]})
        if r.spring is not None:
            spring.append({"muscle": r.spec.id, **{k: v for k, v in r.spring.result.to_dict().items()
                                                   if k in ("parameters", "stderr", "r2", "residual_rms_N", "n_points")},
                           "split_pressure_Pa": r.spring.model.split_pressure})
        if r.comparison is not None:
            comp[r.spec.id] = {"n_points": r.comparison["n_points"], "cv_method": r.comparison["cv_method"],
                               "models": [s.to_dict() for s in r.comparison["scores"]]}
    iso = [{"muscle": spec.id, **c.to_dict()} for spec, c in char.get("isometric", [])]
    return {"synthetic": char["synthetic"], "data": char["root"], "table_I": t1, "table_II": t2,
            "blocked_force": bf, "step_response": steps, SPRING_KEY: spring, "comparison": comp, "isometric": iso,
            "skipped": [s for r in char["muscles"] for s in r.skipped]}


#: The summary's key of the spring model's fits (the law's registry name). [-]
SPRING_KEY = _SPRING_LAW.name
#: What the report takes from which work, by bibliography key (mckibben.datasets.references).
_SPRING = "[wickramatunge2010]"
_SOURCES = ("[mpam-characterization] (eq. 1–3, Tables I–II, Figs. 3, 5, 6, 9, 10, §IV.A); "
            f"{_SPRING} (eq. 1–2)")


def _reference_html(ref) -> str:
    """One bibliography record as a line of the report: authors, year, title, venue, DOI, and what
    could not be established."""
    who = ", ".join(ref.authors) if ref.authors else "authors not established"
    when = str(ref.year) if ref.year is not None else "n.d."
    doi = (f" doi:<a href='https://doi.org/{html.escape(ref.doi)}'>{html.escape(ref.doi)}</a>" if ref.doi else "")
    missing = f" <span class='note'>(not established: {html.escape(ref.unestablished)})</span>" if ref.unestablished else ""
    venue = f" {html.escape(ref.venue)}." if ref.venue else ""
    return f"[{html.escape(ref.key)}] {html.escape(who)} ({when}). <i>{html.escape(ref.title)}</i>.{venue}{doi}{missing}"


def _table(headers, rows) -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in headers)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in row) + "</tr>" for row in rows)
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


CSS = """body{font-family:system-ui,sans-serif;max-width:1280px;margin:2em auto;padding:0 1em;color:#222}
table{border-collapse:collapse;margin:0.6em 0 1.4em}td,th{border:1px solid #ccc;padding:3px 8px;text-align:right}
th{background:#f3f3f3}td:first-child{text-align:left}.synthetic{background:#fff0f0;border:2px solid #c00;
padding:0.6em 1em;font-weight:bold;color:#900}img{max-width:100%;border:1px solid #ddd;margin:0.4em 0}
.note{color:#555;font-size:0.9em}"""


#: The report's closing section: how to run the same on a lab's own tables (docs/data.md, docs/fit.md).
RUN_ON_YOUR_DATA = (
    "<h2>Run it on your data</h2>"
    "<p>This report characterizes the bundled campaign. The same fits run on your own tables, one command each"
    " (every one takes <code>--json</code>; <code>docs/data.md</code> says what a table holds):</p><pre>"
    "mckibben fit isometric.csv --model spring --muscle-file my.toml --save mine.toml   # a force law, saved\n"
    "mckibben compare isometric.csv --muscle-file my.toml                             # every model, held-out error\n"
    "mckibben fit lab.csv --select cut_length_cm=10 --columns phase=direction --model spring"
    "   # a lab's table as it is\n"
    "mckibben fit isotonic.csv --model cubic                                          # Table II's cubics\n"
    "mckibben simulate open-loop --muscle-file mine.toml --load 100N                  # the fitted muscle on the rig\n"
    "mckibben control step --muscle-file mine.toml --target 0.4MPa                     # and under control"
    "</pre><p>A campaign of your own, one sub-folder per muscle, each holding <code>muscle.toml</code> beside its"
    " tables (isotonic, blocked_force, braid_angle, hysteresis, force_length, isometric), is characterized as a"
    " whole, as this report was: <code>mckibben reproduce --data FOLDER --out REPORT</code>.</p>")


def caption(figure: str) -> str:
    """A figure's caption: the first paragraph of the docstring of the function that draws it.

    Parameters
    ----------
    figure : str
        The figure's file name, a key of :data:`~mckibben.report.figures.ALL_FIGURES` or
        :data:`~mckibben.report.figures.ISOMETRIC_FIGURES` (another name is captioned by itself). [-]
    """
    func = {**ALL_FIGURES, **ISOMETRIC_FIGURES}.get(figure)
    doc = inspect.cleandoc(func.__doc__ or "") if func is not None else ""
    return " ".join(doc.split("\n\n")[0].split()) or figure


def render_html(summary: dict, figures: list[str]) -> str:
    """The report page.

    Parameters
    ----------
    summary : dict
        From :func:`summarize`.
    figures : list of str
        PNG file names beside the page.
    """
    _check_dict(summary, "summary", ("synthetic",), "summarize()")
    if isinstance(figures, (str, bytes)) or not all(isinstance(f, str) for f in figures):
        raise ArgumentTypeError(f"figures = {figures!r}: not a list of figure file names")
    parts = ["<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>",
             "<title>mckibben characterization report</title>", f"<style>{CSS}</style></head><body>",
             "<h1>Characterization report</h1>"]
    if summary["synthetic"]:
        parts.append("<p class='synthetic'>SYNTHETIC DATA: this report was made from the generated example campaign"
                     " (mckibben datasets generate), not from measurements. Its fits recover the parameters the data"
                     " were generated from; they say nothing about a real muscle.</p>")
    prov = summary.get("provenance")
    if prov:
        rows = "".join(f"<li><code>{html.escape(k)}</code> sha256 {html.escape(v)}</li>"
                       for k, v in prov.get("inputs_sha256", {}).items())
        parts.append(f"<p class='provenance'>Made by mckibben {html.escape(str(prov['mckibben_version']))} on "
                     f"{html.escape(str(prov['created_utc']))} (UTC): {html.escape(prov['call'])}("
                     + html.escape(", ".join(f"{k}={v!r}" for k, v in prov["arguments"].items()))
                     + f"). Inputs:</p><ul class='provenance'>{rows}</ul>")
    parts.append(f"<p>Data: {html.escape(summary['data'])}. Fits: least squares; ± is one standard error, intervals"
                 " are 95 % (Student t); shaded bands in the figures are 95 % confidence bands of the fitted curve;"
                 " error bars are ± one standard deviation over trials.</p>")
    parts.append("<h2>Table I — kinematic model, eq. 2: l = k1·Ls·cos θ + k2</h2>")
    parts.append(_table(["muscle", "Ls [mm]", "k1 (fitted)", "k1 95 %", "k1 published", "k2 [mm] (fitted)", "k2 95 % [mm]",
                         "k2 published [mm]", "RMS [mm]", "n"],
                        [[r["muscle"], f"{r['strand_length_m'] * 1e3:g}", _pm(r["k1"], r["k1_stderr"]),
                          f"[{r['k1_ci95'][0]:.3f}, {r['k1_ci95'][1]:.3f}]", _g(r["k1_published"]),
                          _pm(r["k2_m"], r["k2_stderr_m"], 1e3), f"[{r['k2_ci95_m'][0] * 1e3:.2f}, {r['k2_ci95_m'][1] * 1e3:.2f}]",
                          _g(r["k2_published_m"], 1e3), f"{r['residual_rms_m'] * 1e3:.2f}", r["n_points"]] for r in summary["table_I"]]))
    parts.append("<h2>Table II — cos θ = c3·P³ + c2·P² + c1·P + c0 (P in MPa), eq. 3</h2>")
    rows = []
    for r in summary["table_II"]:
        fitted = [_pm(v, s, digits=3) for v, s in zip(r["coefficients_P_in_MPa"], r["stderr"])]
        pub = r["published"] or [None] * 4
        rows.append([r["muscle"], f"{r['load_N']:g}", *[f"{f} ({_g(p)})" for f, p in zip(fitted, pub)], r["n_points"]])
    parts.append(_table(["muscle", "load [N]", "c3 fitted (published)", "c2", "c1", "c0", "n"], rows))
    if summary["blocked_force"]:
        parts.append("<h2>Blocked force at 0.8 MPa (Fig. 3)</h2>")
        parts.append(_table(["muscle", "fitted cubic at 0.8 MPa [N]", "published [N]"],
                            [[b["muscle"], _pm(b["force_at_0_8MPa_N"], b["band95_N"] / 1.96), _g(b["published_N"])]
                             for b in summary["blocked_force"]]))
    for muscle, c in summary["comparison"].items():
        parts.append(f"<h2>Model comparison — {html.escape(muscle)}</h2>")
        parts.append(f"<p class='note'>Every model predicts the length under the hanging load at a pressure for the"
                     f" {c['n_points']} isotonic points with P &gt; 0. Relative errors are of the contraction ε = 1 − l/L0"
                     f" (points with |ε| ≥ 2 %); “within 20 %” is the paper's accuracy measure. Cross-validation:"
                     f" {html.escape(c['cv_method'])}.</p>")
        parts.append(_table(["model", "parameters", "RMSE [mm]", "max rel. error of ε [%]", "within 20 % [%]",
                             "CV RMSE [mm]", "CV within 20 % [%]", "note"],
                            [[m["model"], m["n_parameters"], _g(m["rmse_m"], 1e3, 3), _g(m["max_rel_error"], 100, 3),
                              _g(m["within_20pct"], 100, 3), _g(m["cv_rmse_m"], 1e3, 3), _g(m["cv_within_20pct"], 100, 3),
                              m["note"]] for m in c["models"]]))
    if summary["step_response"]:
        parts.append("<h2>Pressure step response, first order (§IV.A)</h2>")
        parts.append(_table(["muscle", "command", "τ [ms]", "τ 95 % [ms]", "final pressure [MPa]"],
                            [[s["muscle"], f"{s['command']:g}", _pm(s["tau_s"], s["tau_stderr_s"], 1e3),
                              f"[{s['tau_ci95_s'][0] * 1e3:.1f}, {s['tau_ci95_s'][1] * 1e3:.1f}]", f"{s['p_final_Pa'] / MPA:.3f}"]
                             for s in summary["step_response"]]))
    if summary[SPRING_KEY]:
        parts.append(f"<h2>Spring model of {html.escape(render(_SPRING))}: Lu(P) = h2·P² + h1·P + h0,"
                     " K = c3·P + c2·P·Ls + c1·Ls + c0 (SI)</h2>")
        for s in summary[SPRING_KEY]:
            parts.append(f"<p>{html.escape(s['muscle'])}: split {s['split_pressure_Pa'] / MPA:.3g} MPa, R² {s['r2']:.5f},"
                         f" force RMS {s['residual_rms_N'] * 1e3:.1f} mN, n {s['n_points']}</p>")
            parts.append(_table(["parameter", "value ± s.e."], [[k, _pm(v, s["stderr"][k], digits=4)] for k, v in s["parameters"].items()]))
    for c in summary.get("isometric", []):
        parts.append(f"<h2>Isometric test — {html.escape(c['muscle'])}: force(P, L), held out {html.escape(c['cv'])}</h2>")
        parts.append(f"<p class='note'>Every force model fitted on the same folds; the best is picked on held-out"
                     f" error (peak force {c['peak_force_N']:.4g} N). Flags: parameters at a physical bound, R² &lt; 0.5,"
                     f" an ill-conditioned covariance, a load-cell zero over 5 % of the peak (docs/fit.md).</p>")
        rows = sorted(c["models"], key=lambda m: (m["cv_rmse_N"] is None, m["cv_rmse_N"] or 0))
        parts.append(_table(["model", "parameters", "RMSE [N]", "R²", "held-out RMSE [N]", "held-out [% of peak]",
                             "flags"],
                            [[m["model"] + (" (best)" if m["model"] == c["best"] else ""), m["n_parameters"],
                              _g(m["rmse_N"]), _g(m["r2"]), _g(m["cv_rmse_N"]), _g(m["cv_rmse_pct_of_peak"], 1, 3),
                              ", ".join(m["flags"]) or "none"] for m in rows]))
    parts.append("<h2>Figures</h2>")
    for k, f in enumerate(figures, 1):
        text = f"Figure {k}. {caption(f)}"
        parts.append(f"<figure><img src='{html.escape(f)}' alt='{html.escape(text)}'>"
                     f"<figcaption>{html.escape(text)}</figcaption></figure>")
    if summary["skipped"]:
        parts.append("<p class='note'>Skipped: " + html.escape("; ".join(summary["skipped"])) + "</p>")
    parts.append(RUN_ON_YOUR_DATA)
    parts.append(f"<p class='note'>Made by <code>mckibben reproduce</code>. Sources: {html.escape(render(_SOURCES))}.</p>")
    parts.append("<h2>References</h2><ul>" + "".join(f"<li>{_reference_html(r)}</li>" for r in cited(_SOURCES)) + "</ul>")
    parts.append("</body></html>")
    return "\n".join(parts)


def _g(v, scale=1.0, digits=4):
    if v is None or not np.isfinite(v):
        return "—"
    return f"{v * scale:.{digits}g}"


def check_report_folder(out) -> Path:
    """Check that ``out`` may receive a report: absent, empty, or a report written before, in a
    folder that takes new entries (:func:`mckibben.atomic.check_output_dir`).

    Parameters
    ----------
    out : str or pathlib.Path
        The report folder. [-]
    """

    out = check_output_dir(out, "out")
    if out.is_dir() and any(out.iterdir()) and not (out / "index.html").is_file():
        raise InputError(f"out: {out} exists and is neither empty nor a report written before; choose another folder")
    return out


def _campaign_base(char: dict) -> Path | None:
    """The folder the campaign's muscle folders share (what input paths are written relative to)."""

    bundled = char.get("root") in (None, "bundled example campaign")
    dirs = [Path(d) for d in campaign_muscle_dirs(None if bundled else char["root"])]
    base = Path(os.path.commonpath([str(d) for d in dirs])) if dirs else None
    return base.parent if base is not None and len(dirs) == 1 else base


def _without_machine_paths(obj, char: dict):
    """``obj`` with every text's absolute path of an input (fitted models cite their files) made relative
    to the campaign folder, so that a report names no folder of the machine that made it."""
    base = _campaign_base(char)
    prefixes = [str(base.resolve()), str(base)] if base is not None else []

    def scrub(v):
        if isinstance(v, str):
            for pre in prefixes:
                v = v.replace(pre + os.sep, "").replace(pre, base.name if base is not None else "")
            return v
        if isinstance(v, dict):
            return {k: scrub(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return type(v)(scrub(x) for x in v)
        return v

    return scrub(obj)


def report_provenance(char: dict, out) -> dict:
    """Where a report came from: version, UTC time, the call and its arguments, a SHA-256 per input.

    Paths are relative to the campaign folder (inputs) or bare folder names (arguments): a report
    carries no absolute path of the machine that made it.

    Parameters
    ----------
    char : dict
        From :func:`mckibben.report.characterize.characterize`.
    out : str or pathlib.Path
        The report folder. [-]
    """


    bundled = char.get("root") in (None, "bundled example campaign")
    dirs = [Path(d) for d in campaign_muscle_dirs(None if bundled else char["root"])]
    base = _campaign_base(char)
    inputs = {}
    for d in dirs:
        for f in sorted(p for p in d.rglob("*") if p.is_file()):
            inputs[str(f.relative_to(base)) if base else f.name] = hashlib.sha256(f.read_bytes()).hexdigest()
    data = "bundled example campaign" if bundled else Path(str(char["root"])).name
    prov = provenance("mckibben.report.reproduce", {"out": Path(out).name, "data": data})
    prov["inputs_sha256"] = inputs
    return prov


def write_report(char: dict, out, progress=None) -> tuple[Path, dict]:
    """Write ``index.html``, ``summary.json`` and the PNG figures into ``out``, atomically.

    Parameters
    ----------
    char : dict
        From :func:`mckibben.report.characterize.characterize`.
    out : str or pathlib.Path
        The report folder; an existing report folder (one holding ``index.html``) or an empty
        folder is replaced, anything else is refused.
    progress : callable, optional
        Called with a description before each figure.

    Returns
    -------
    (pathlib.Path, dict)
        The folder and the summary.
    """
    _check_dict(char, "char", ("muscles",), "characterize()")
    check_callable(progress, "progress")



    out = check_report_folder(out)
    with atomic_dir(out, "out") as tmp:
        summary = summarize(char)
        summary["provenance"] = report_provenance(char, out)
        if isinstance(summary.get("data"), str) and summary["data"].startswith("/"):
            summary["data"] = Path(summary["data"]).name  # no absolute machine path in a report
        summary = _without_machine_paths(summary, char)
        figures = []
        token = FIG.PROVENANCE.set(summary["provenance"])
        try:
            for name, make in ALL_FIGURES.items():
                if progress:
                    progress(f"figure {name}")
                if make(char["muscles"], tmp / name, char["synthetic"]) is not None:
                    figures.append(name)
            for name, make in ISOMETRIC_FIGURES.items():
                if make(char.get("isometric", []), tmp / name, char["synthetic"]) is not None:
                    figures.append(name)
        finally:
            FIG.PROVENANCE.reset(token)
        summary["figures"] = figures
        (tmp / "summary.json").write_text(json.dumps(to_jsonable(summary), indent=1, allow_nan=False), encoding="utf-8")
        (tmp / "index.html").write_text(render_html(summary, figures), encoding="utf-8")
    return out, summary

"""Figures of the characterization report, in the spirit of [mpam-characterization] Figs. 3, 5, 6,
9 and 10 and of the force-length loops of Wickramatunge & Leephakpreeda (2010) [wickramatunge2010]: data as mean ± standard
deviation over trials (error bars), fitted curves, and shaded 95 % confidence bands of the fits.

Matplotlib's object API (:class:`matplotlib.figure.Figure`, Agg canvas): no global pyplot state.
"""

from __future__ import annotations

import contextvars
from pathlib import Path

import numpy as np

from mckibben.fit.static import trial_stats
from mckibben.models.laws import MPA
from mckibben.models.spring import CONTRACTION, ELONGATION
from mckibben.plotting import figure_metadata

COLORS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#17becf")


def _figure(ncols: int, width=4.2, height=3.4):
    from matplotlib.figure import Figure  # deferred on purpose: Matplotlib
    from matplotlib.backends.backend_agg import FigureCanvasAgg  # deferred on purpose: Matplotlib
    fig = Figure(figsize=(width * ncols, height), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, ncols, squeeze=False)[0]
    return fig, axes


#: The report's provenance while its figures are drawn (:func:`mckibben.report.html.write_report`
#: sets it): each PNG carries it in its metadata, as the HTML and ``summary.json`` do.
PROVENANCE: contextvars.ContextVar[dict | None] = contextvars.ContextVar("report_provenance", default=None)


def _save(fig, path: Path, synthetic: bool) -> Path:
    if synthetic:
        fig.text(0.995, 0.005, "SYNTHETIC DATA", ha="right", va="bottom", color="#b00", fontsize=8, weight="bold")
    prov = PROVENANCE.get()
    meta = figure_metadata(Path(path).suffix.lstrip(".") or "png", prov) if prov else None
    fig.savefig(path, dpi=100, **({"metadata": meta} if meta else {}))
    return path


def _fit_line(ax, res, x, color, label=None, transform=lambda y: y, xscale=1.0, **inputs):
    y, _ = res.predict(**inputs)
    band = res.band(**inputs)
    ax.plot(x * xscale, transform(y), color=color, lw=1.6, label=label)
    lo, hi = transform(y - band), transform(y + band)
    ax.fill_between(x * xscale, np.minimum(lo, hi), np.maximum(lo, hi), color=color, alpha=0.22, lw=0)


def fig3_blocked_force(results, path: Path, synthetic: bool) -> Path | None:
    """Blocked force vs pressure for every muscle (Fig. 3b).

    Parameters
    ----------
    results : list of MuscleResults
        From :func:`mckibben.report.characterize.characterize`.
    path : pathlib.Path
        PNG file to write.
    synthetic : bool
        Mark the figure as synthetic.
    """
    rs = [r for r in results if r.blocked_force is not None]
    if not rs:
        return None
    fig, (ax,) = _figure(1, 5.5, 4.0)
    for c, r in zip(COLORS, rs):
        s = trial_stats(r.tables["blocked_force"], "pressure", "force")
        ax.errorbar(s["pressure"] / MPA, s["mean"], yerr=s["std"], fmt="o", ms=4, color=c, capsize=2)
        p = np.linspace(*r.blocked_force.valid_range["pressure"], 100)
        _fit_line(ax, r.blocked_force, p, c, f"{r.spec.id} (cubic fit)", xscale=1 / MPA, pressure=p)
    ax.set(xlabel="pressure [MPa]", ylabel="blocked force [N]", title="Blocked force vs pressure (cf. Fig. 3)")
    ax.legend(fontsize=8)
    return _save(fig, path, synthetic)


def fig5_force_contraction(results, path: Path, synthetic: bool, pressures=(0.2e6, 0.4e6, 0.6e6, 0.8e6)) -> Path | None:
    """Hanging load vs contraction at a few pressures, one panel per muscle (Fig. 5).

    Parameters
    ----------
    results : list of MuscleResults
        From :func:`~mckibben.report.characterize.characterize`.
    path : pathlib.Path
        PNG file.
    synthetic : bool
        Mark the figure as synthetic.
    pressures : sequence of float
        Pressures to show (the nearest fitted ones). [Pa]
    """
    rs = [r for r in results if r.force_contraction]
    if not rs:
        return None
    fig, axes = _figure(len(rs))
    for ax, r in zip(axes, rs):
        t = r.tables["isotonic"]
        d = t.data.assign(contraction=1 - t.data["length"] / r.spec.nominal_length,
                          pk=np.round(t.data["pressure"] / 1e3) * 1e3)
        fitted = np.array(sorted(r.force_contraction))
        for c, want in zip(COLORS, pressures):
            pk = fitted[np.argmin(np.abs(fitted - want))]
            sub = d[d["pk"] == pk]
            g = sub.groupby(np.round(sub["load"], 9))["contraction"].agg(["mean", "std"])
            ax.errorbar(g["mean"] * 100, g.index, xerr=g["std"] * 100, fmt="o", ms=4, color=c, capsize=2)
            res = r.force_contraction[pk]
            e = np.linspace(*res.valid_range["contraction"], 100)
            _fit_line(ax, res, e, c, f"{pk / MPA:.2g} MPa", xscale=100, contraction=e)
        ax.set(xlabel="contraction 1 − l/L0 [%]", ylabel="load [N]", title=f"{r.spec.id}: load vs contraction (cf. Fig. 5)")
        ax.legend(fontsize=8)
    return _save(fig, path, synthetic)


def fig6_hysteresis(results, path: Path, synthetic: bool) -> Path | None:
    """Contraction vs pressure, inflating and deflating, one panel per muscle (Fig. 6).

    Parameters
    ----------
    results : list of MuscleResults
        From :func:`~mckibben.report.characterize.characterize`.
    path : pathlib.Path
        PNG file.
    synthetic : bool
        Mark the figure as synthetic.
    """
    rs = [r for r in results if r.hysteresis]
    if not rs:
        return None
    fig, axes = _figure(len(rs))
    for ax, r in zip(axes, rs):
        t = r.tables["hysteresis"]
        l0 = r.spec.nominal_length
        for c, ((load, direction), res) in zip(COLORS, sorted(r.hysteresis.items(), key=lambda kv: str(kv[0]))):
            sub = t.data[(t.data["direction"] == direction) & np.isclose(t.data["load"], load)]
            g = sub.assign(c=1 - sub["length"] / l0).groupby(np.round(sub["pressure"] / 1e3))["c"].agg(["mean", "std"])
            ax.errorbar(g.index / 1e3, g["mean"] * 100, yerr=g["std"] * 100, fmt="o", ms=4, color=c, capsize=2)
            p = np.linspace(*res.valid_range["pressure"], 100)
            _fit_line(ax, res, p, c, f"{direction}, {load:g} N", transform=lambda y: (1 - y / l0) * 100, xscale=1 / MPA,
                      pressure=p)
        ax.set(xlabel="pressure [MPa]", ylabel="contraction [%]", title=f"{r.spec.id}: hysteresis (cf. Fig. 6)")
        ax.legend(fontsize=8)
    return _save(fig, path, synthetic)


def fig9_kinematic(results, path: Path, synthetic: bool) -> Path | None:
    """Length vs cos θ with the fitted eq. 2, one panel per muscle (Fig. 9).

    Error bars are the instrument limits the paper draws: ±1° in angle, σ = 0.8 mm in length.

    Parameters
    ----------
    results : list of MuscleResults
        From :func:`~mckibben.report.characterize.characterize`.
    path : pathlib.Path
        PNG file.
    synthetic : bool
        Mark the figure as synthetic.
    """
    rs = [r for r in results if r.kinematic is not None]
    if not rs:
        return None
    fig, axes = _figure(len(rs))
    for ax, r in zip(axes, rs):
        d = r.tables["braid_angle"].data
        cos_t = np.cos(d["braid_angle"])
        xerr = np.sin(d["braid_angle"]) * np.deg2rad(1.0)
        ax.errorbar(cos_t, d["length"] * 1e3, xerr=xerr, yerr=0.8, fmt="o", ms=3, color=COLORS[0], capsize=1.5,
                    alpha=0.8, label="photographs (±1°, σ 0.8 mm)")
        res = r.kinematic
        x = np.linspace(*res.valid_range["cos_theta"], 100)
        _fit_line(ax, res, x, COLORS[1], f"fit k1 {res['k1']:.3f}, k2 {res['k2_m'] * 1e3:.2f} mm",
                  transform=lambda y: y * 1e3, cos_theta=x, strand_length=r.spec.strand_length)
        pub = r.published
        if pub is not None:
            ax.plot(x, (pub.k1 * pub.strand_length * x + pub.k2) * 1e3, "k--", lw=1, label="Table I (published)")
        ax.set(xlabel="cos θ [-]", ylabel="length [mm]", title=f"{r.spec.id}: length vs cos θ (cf. Fig. 9)")
        ax.legend(fontsize=8)
    return _save(fig, path, synthetic)


def fig10_braid_angle(results, path: Path, synthetic: bool) -> Path | None:
    """cos θ vs pressure under each photographed load, all muscles (Fig. 10).

    Parameters
    ----------
    results : list of MuscleResults
        From :func:`~mckibben.report.characterize.characterize`.
    path : pathlib.Path
        PNG file.
    synthetic : bool
        Mark the figure as synthetic.
    """
    rs = [r for r in results if r.braid_cubics]
    if not rs:
        return None
    loads = sorted({k[0] for r in rs for k in r.braid_cubics})
    fig, axes = _figure(len(loads))
    for ax, load in zip(axes, loads):
        for c, r in zip(COLORS, rs):
            if (load, None) not in r.braid_cubics:
                continue
            d = r.tables["braid_angle"].data
            sub = d[np.isclose(d["load"], load)]
            g = sub.assign(c=np.cos(sub["braid_angle"])).groupby(np.round(sub["pressure"] / 1e3))["c"].agg(["mean", "std"])
            ax.errorbar(g.index / 1e3, g["mean"], yerr=g["std"], fmt="o", ms=4, color=c, capsize=2)
            res = r.braid_cubics[(load, None)]
            p = np.linspace(0, res.valid_range["pressure"][1], 100)
            _fit_line(ax, res, p, c, f"{r.spec.id} fit", xscale=1 / MPA, pressure=p)
            pub = r.published
            if pub is not None and np.any(np.isclose(pub.braid_map.loads, load)):
                cf = pub.braid_map.coefficients_at(load)
                ax.plot(p / MPA, np.polyval(cf, p / MPA), "--", color=c, lw=1, label=f"{r.spec.id} Table II")
        ax.set(xlabel="pressure [MPa]", ylabel="cos θ [-]", title=f"cos θ vs pressure, load {load:g} N (cf. Fig. 10)")
        ax.legend(fontsize=7)
    return _save(fig, path, synthetic)


def fig_spring_loops(results, path: Path, synthetic: bool) -> Path | None:
    """Force-length loops at constant pressure with the fitted spring model ([wickramatunge2010], Figs. 5 and 7).

    Parameters
    ----------
    results : list of MuscleResults
        From :func:`~mckibben.report.characterize.characterize`.
    path : pathlib.Path
        PNG file.
    synthetic : bool
        Mark the figure as synthetic.
    """
    rs = [r for r in results if r.spring is not None]
    if not rs:
        return None
    fig, axes = _figure(len(rs))
    for ax, r in zip(axes, rs):
        d = r.tables["force_length"].data
        res = r.spring.result
        for c, pk in zip(COLORS, np.unique(np.round(d["pressure"] / 1e3) * 1e3)):
            sub = d[np.isclose(np.round(d["pressure"] / 1e3) * 1e3, pk)]
            for direction, marker in ((ELONGATION, "^"), (CONTRACTION, "v")):
                s = sub[sub["direction"] == direction]
                ax.plot(s["length"] * 1e3, s["force"], marker, ms=2.5, color=c, alpha=0.5, ls="none")
                ell = np.linspace(s["length"].min(), s["length"].max(), 60)
                _fit_line(ax, res, ell, c, f"{pk / MPA:.2g} MPa" if direction == ELONGATION else None, xscale=1e3,
                          length=ell, pressure=np.full_like(ell, pk), direction=direction)
        ax.set(xlabel="length [mm]", ylabel="force [N]",
               title=f"{r.spec.id}: spring model F = K(P, Ls)·Ls\n(▲ elongation, ▼ contraction)")
        ax.legend(fontsize=7)
    return _save(fig, path, synthetic)


def fig_step_response(results, path: Path, synthetic: bool) -> Path | None:
    """Pressure step responses with the first-order fit (§IV.A).

    Parameters
    ----------
    results : list of MuscleResults
        From :func:`~mckibben.report.characterize.characterize`.
    path : pathlib.Path
        PNG file.
    synthetic : bool
        Mark the figure as synthetic.
    """
    rs = [r for r in results if r.steps]
    if not rs:
        return None
    r = rs[0]
    fig, (ax,) = _figure(1, 5.5, 4.0)
    d = r.tables["step_response"].data
    for c, (cmd, res) in zip(COLORS, sorted(r.steps.items())):
        for _, grp in d.groupby("trial"):
            ch = np.flatnonzero(grp["command"].to_numpy() != grp["command"].to_numpy()[0])
            if ch.size and np.isclose(grp["command"].to_numpy()[ch[0]], cmd):
                t = grp["time"].to_numpy() - grp["time"].to_numpy()[ch[0]]
                ax.plot(t, grp["pressure"] / MPA, ".", ms=2, color=c, alpha=0.5)
        t = np.linspace(*res.valid_range["time"], 200)
        _fit_line(ax, res, t, c, f"command {cmd:g}: τ = {res['tau_s'] * 1e3:.1f} ± {res.se('tau_s') * 1e3:.1f} ms",
                  transform=lambda y: y / MPA, time=t)
    ax.set(xlabel="time after the command step [s]", ylabel="pressure [MPa]",
           title=f"{r.spec.id}: open-loop pressure steps, first-order fit (§IV.A)")
    ax.legend(fontsize=8)
    return _save(fig, path, synthetic)


def fig_isometric(isometric, path: Path, synthetic: bool) -> Path | None:
    """Isometric test: force against pressure per held length, inflate and deflate, the model best
    on held-out lengths with its 95 % band; beside it, held-out and in-sample error per model.

    Parameters
    ----------
    isometric : list of (MuscleSpec, ModelComparison)
        From :func:`~mckibben.report.characterize.characterize` (``char["isometric"]``).
    path : pathlib.Path
        PNG file.
    synthetic : bool
        Mark the figure as synthetic.
    """
    if not isometric:
        return None
    spec, comp = isometric[0]
    fig, (ax, axc) = _figure(2, 5.0, 4.0)
    comp.fits[comp.best].plot(ax)
    ax.set_title(f"{spec.id}: {comp.best} (best held out), 95 % band", fontsize=9)
    comp.plot(axc)
    axc.set_title(f"{comp.cv}", fontsize=9)
    return _save(fig, path, synthetic)


#: Figures drawn from ``char["isometric"]`` rather than from the muscles.
ISOMETRIC_FIGURES = {"isometric.png": fig_isometric}

ALL_FIGURES = {
    "fig3_blocked_force.png": fig3_blocked_force,
    "fig5_force_contraction.png": fig5_force_contraction,
    "fig6_hysteresis.png": fig6_hysteresis,
    "fig9_kinematic.png": fig9_kinematic,
    "fig10_braid_angle.png": fig10_braid_angle,
    "spring_loops.png": fig_spring_loops,
    "step_response.png": fig_step_response,
}

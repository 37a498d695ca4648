"""The tool's workspace: the tips the pressure box [0, p_max]³ reaches, its extent and a figure.

Every grid point of the pressure box is taken through the forward static equilibrium
(:func:`~mckibben.tool.statics.tip_from_pressures`). The six faces of the box (one muscle at 0 or
at p_max) map onto the boundary of the reachable tip set, so they are drawn as surfaces.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mckibben.errors import InputError
from mckibben.models.flags import FLAG_NAMES, Flag
from mckibben.tool.geometry import Tool
from mckibben.tool.statics import ToolState, tip_from_pressures


@dataclass(frozen=True)
class Workspace:
    """Samples of the workspace on an ``n × n × n`` grid of the pressure box.

    Attributes
    ----------
    pressures : numpy.ndarray
        Grid of pressures, shape ``(n, n, n, 3)``. [Pa]
    state : ToolState
        The equilibrium pose at every grid point (leading shape ``(n, n, n)``).
    """

    pressures: np.ndarray
    state: ToolState

    def extent(self) -> dict:
        """The workspace's extent (SI, unit-suffixed keys, ready for ``--json``).

        Returns
        -------
        dict
            ``lateral_reach_m`` (largest distance of the tip from the tool axis),
            ``tip_angle_min_rad``/``tip_angle_max_rad`` (bend angle θ between the tip
            direction and the axis), ``z_min_m``/``z_max_m`` (axial tip range),
            ``arc_length_min_m``/``arc_length_max_m``, ``straight_length_min_m``/
            ``straight_length_max_m`` (the arc length on the straight diagonal P1 = P2 = P3),
            the number of samples, how many converged and how many carry each flag.
        """
        st = self.state
        tip = st.tip.reshape(-1, 3)
        theta = np.ravel(st.arc.theta)
        s = np.ravel(st.arc.arc_length)
        n = self.pressures.shape[0]
        diag = np.array([st.arc.arc_length[i, i, i] for i in range(n)])
        flags = st.flags.reshape(-1, 3)
        any_flag = np.bitwise_or.reduce(flags, axis=1)
        counts = {name: int(np.count_nonzero(any_flag & flag)) for flag, name in FLAG_NAMES.items()}
        return {
            "samples": int(tip.shape[0]),
            "converged": int(np.count_nonzero(st.converged)),
            "lateral_reach_m": float(np.max(np.hypot(tip[:, 0], tip[:, 1]))),
            "tip_angle_min_rad": float(theta.min()),
            "tip_angle_max_rad": float(theta.max()),
            "z_min_m": float(tip[:, 2].min()),
            "z_max_m": float(tip[:, 2].max()),
            "arc_length_min_m": float(s.min()),
            "arc_length_max_m": float(s.max()),
            "straight_length_min_m": float(diag.min()),
            "straight_length_max_m": float(diag.max()),
            "samples_flagged": {k: v for k, v in counts.items() if v},
            "samples_slack": int(np.count_nonzero(any_flag & Flag.SLACK)),
        }


def sample_workspace(tool: Tool, n: int = 15) -> Workspace:
    """Sample the pressure box [0, p_max]³ on an ``n``-point grid per muscle.

    Parameters
    ----------
    tool : Tool
        The tool.
    n : int, default 15
        Grid points per muscle, at least 2. [-]

    Returns
    -------
    Workspace
        The grid and the equilibrium pose at each point.
    """
    if int(n) != n or n < 2 or n > 101:
        raise InputError(f"grid: {n!r} must be a whole number of points per muscle in 2..101")
    g = np.linspace(0.0, tool.p_max, int(n))
    grid = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1)
    return Workspace(grid, tip_from_pressures(grid, tool))


def _faces(array):
    """The six faces of an ``(n, n, n, ...)`` grid: (name, 2-D slice)."""
    return [
        ("P1 = 0", array[0]), ("P1 = max", array[-1]),
        ("P2 = 0", array[:, 0]), ("P2 = max", array[:, -1]),
        ("P3 = 0", array[:, :, 0]), ("P3 = max", array[:, :, -1]),
    ]


def plot_workspace(ws: Workspace, tool: Tool, fig=None):
    """Draw the reachable tip surface (3-D), its top view and side view; return the Figure.

    Parameters
    ----------
    ws : Workspace
        The sampled workspace.
    tool : Tool
        The tool (for the title and the muscle directions).
    fig : matplotlib.figure.Figure, optional
        An empty figure to draw into; default a new one. [-]

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib  # deferred on purpose: Matplotlib
    import matplotlib.pyplot as plt  # deferred on purpose: Matplotlib
    from matplotlib import cm  # deferred on purpose: Matplotlib

    tip = ws.state.tip * 1e3  # mm for the figure
    theta = np.degrees(ws.state.arc.theta)
    ext = ws.extent()
    fig = plt.figure(figsize=(14, 5.2)) if fig is None else fig
    ax3 = fig.add_subplot(1, 3, 1, projection="3d")
    norm = matplotlib.colors.Normalize(0, max(float(theta.max()), 1e-9))
    for (_, face), (_, th) in zip(_faces(tip), _faces(theta)):
        ax3.plot_surface(face[..., 0], face[..., 1], face[..., 2], facecolors=cm.viridis(norm(th)),
                         rstride=1, cstride=1, linewidth=0.2, edgecolor="k", alpha=0.55, shade=False)
    ax3.set_xlabel("x [mm]")
    ax3.set_ylabel("y [mm]")
    ax3.set_zlabel("z [mm]")
    ax3.set_title("reachable tip surface\n(box faces; colour = bend angle)", fontsize=10)
    lim = max(np.abs(tip[..., :2]).max(), 1.0)
    ax3.set_xlim(-lim, lim)
    ax3.set_ylim(-lim, lim)
    ax3.set_zlim(0, tip[..., 2].max() * 1.02)
    ax3.view_init(elev=22, azim=-60)
    fig.colorbar(cm.ScalarMappable(norm=norm, cmap="viridis"), ax=ax3, shrink=0.6, pad=0.15, label="bend angle θ [deg]")

    flat = tip.reshape(-1, 3)
    ax = fig.add_subplot(1, 3, 2)
    sc = ax.scatter(flat[:, 0], flat[:, 1], c=flat[:, 2], s=4, cmap="plasma")
    r_dir = 1.08 * lim
    for i, ang in enumerate((0.0, 120.0, 240.0)):
        a = np.radians(ang)
        ax.annotate("", xy=(r_dir * np.cos(a), r_dir * np.sin(a)), xytext=(0, 0),
                    arrowprops=dict(arrowstyle="->", color="0.4", lw=0.8))
        ax.text(1.12 * r_dir * np.cos(a), 1.12 * r_dir * np.sin(a), f"muscle {i + 1}", ha="center", va="center", fontsize=8)
    ax.set_aspect("equal")
    ax.set_xlim(-1.3 * lim, 1.3 * lim)
    ax.set_ylim(-1.3 * lim, 1.3 * lim)
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_title(f"top view (lateral reach {ext['lateral_reach_m'] * 1e3:.1f} mm)")
    fig.colorbar(sc, ax=ax, shrink=0.8, label="z [mm]")

    ax = fig.add_subplot(1, 3, 3)
    rho = np.hypot(flat[:, 0], flat[:, 1])
    signed = np.where(flat[:, 0] >= 0, rho, -rho)
    sc = ax.scatter(signed, flat[:, 2], c=theta.ravel(), s=4, cmap="viridis", norm=norm)
    diag = np.array([tip[i, i, i] for i in range(tip.shape[0])])
    ax.plot(np.zeros(len(diag)), diag[:, 2], "r-", lw=2, label="P1 = P2 = P3 (straight)")
    ax.set_aspect("equal")
    ax.set_xlabel("±distance from axis [mm] (sign of x)")
    ax.set_ylabel("z [mm]")
    ax.set_title(f"side view (tip angle 0–{np.degrees(ext['tip_angle_max_rad']):.0f}°)")
    ax.legend(loc="lower center", fontsize=8)
    g = tool.geometry
    fig.suptitle(
        f"Workspace of the 3-muscle endoscope: {tool.muscle.name}, r = {g.pitch_radius * 1e3:.2f} mm,"
        f" {g.n_discs or 'continuous'} discs, P ∈ [0, {tool.p_max / 1e6:g}] MPa, preload {tool.load.preload:g} N,"
        f" Kb = {tool.load.bending_stiffness:g} N·m²", fontsize=10)
    fig.tight_layout()
    return fig

"""Figures of the class-2 kinematics and stiffness (matplotlib, Agg backend, PNG files).

- :func:`plot_workspace`: the admissible actuator polygon with the singular lines, and the
  reachable set of D with its boundary and the images of the singular sets;
- :func:`plot_stiffness_sweep`: the stiffnesses K_i(f) along the seven coordinates, laid
  out as the paper's Fig. 2 (a: Bx, Cx, Dx; b: Dy; c: Ex, Ey, Fy).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any, Final

import numpy as np

from tensegrity_core.class2.workspace import Workspace

if TYPE_CHECKING:
    from matplotlib.figure import Figure

_SINGULAR_STYLE: Final = {
    "lambda1": ("tab:red", "lambda1 = 0 (rho1 + rho2 = 2L)"),
    "lambda2": ("tab:purple", "lambda2 = 0 (rho1 = L)"),
    "beta_half_pi": ("tab:orange", "beta = pi/2 (det dD/drho = 0, IK discriminant = 0)"),
    "folded": ("black", "folded (rho1 = rho2 = 0)"),
}


def _figure(ncols: int, width: float, height: float) -> tuple[ModuleType, Figure, Any]:
    """``(pyplot, figure, axes)`` of a new figure with ``ncols`` panels (Agg backend)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt, *plt.subplots(1, ncols, figsize=(width, height))


def _save(plt: ModuleType, fig: Figure, path: str | Path, title: str) -> Path:
    fig.suptitle(title)
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def plot_workspace(ws: Workspace, path: str | Path, *, resolution: int = 300) -> Path:
    """Write a two-panel PNG of ``ws`` to ``path`` and return the path."""
    plt, fig, (ax_rho, ax_xy) = _figure(2, 12.5, 5.4)
    L = ws.params.L
    poly = np.vstack([ws.polygon, ws.polygon[:1]])
    ax_rho.fill(poly[:, 0], poly[:, 1], color="tab:blue", alpha=0.15, label="admissible lengths")
    ax_rho.plot(poly[:, 0], poly[:, 1], color="tab:blue", lw=1.5)
    for curve in ws.singular_curves:
        color, label = _SINGULAR_STYLE[curve.kind]
        style = dict(color=color, label=label)
        if len(curve.rho) == 1:
            ax_rho.plot(*curve.rho[0], "o", ms=7, **style)
            ax_xy.plot(*curve.xy[0], "o", ms=7, **style)
        else:
            ax_rho.plot(curve.rho[:, 0], curve.rho[:, 1], "--", lw=2, **style)
            ax_xy.plot(curve.xy[:, 0], curve.xy[:, 1], "--", lw=2.5, **style)
    ax_rho.set(xlabel="rho1 [m]", ylabel="rho2 [m]", title="actuator plane",
               xlim=(-0.05 * L, 1.05 * L), ylim=(-0.05 * L, 2.05 * L))
    ax_rho.set_aspect("equal")

    x0, x1, y0, y1 = ws.bounds()
    pad = 0.05 * L
    xs = np.linspace(x0 - pad, x1 + pad, resolution)
    ys = np.linspace(y0 - pad, y1 + pad, resolution)
    inside = ws.contains(xs[None, :], ys[:, None])
    ax_xy.contourf(xs, ys, inside.astype(float), levels=[0.5, 1.5], colors=["tab:blue"], alpha=0.15)
    first = True
    for curve in ws.edges:
        ax_xy.plot(curve.xy[:, 0], curve.xy[:, 1], color="0.6", lw=0.8)
        xy = np.where(curve.on_boundary[:, None], curve.xy, np.nan)
        ax_xy.plot(xy[:, 0], xy[:, 1], color="tab:blue", lw=1.8, label="boundary" if first else None)
        first = False
    rng = "beta in [0, pi/2]" if ws.paper_range else "all stable equilibria"
    ax_xy.set(xlabel="x of D [m]", ylabel="y of D [m]",
              title=f"reachable set of D ({rng}), grey: other edge images")
    ax_xy.set_aspect("equal")
    handles, labels = ax_xy.get_legend_handles_labels()
    seen = dict(zip(labels, handles))
    ax_xy.legend(seen.values(), seen.keys(), loc="upper right", fontsize=7)
    return _save(plt, fig, path,
                 f"class-2 workspace: rho1 in [{ws.rho1_range[0]:g}, {ws.rho1_range[1]:g}] m, "
                 f"rho2 in [{ws.rho2_range[0]:g}, {ws.rho2_range[1]:g}] m, L = {L:g} m")


def plot_stiffness_sweep(sweep: Mapping[str, Any], path: str | Path) -> Path:
    """Write the K_i(f) curves of :func:`~tensegrity_core.class2.stiffness.stiffness_sweep` to ``path``."""
    plt, fig, axes = _figure(3, 14.0, 4.2)
    f = sweep["f"]
    names = sweep["coordinates"]
    for ax, idx, tag in zip(axes, ((0, 1, 2), (3,), (4, 5, 6)), "abc"):
        for i in idx:
            ax.plot(f, sweep["K_i"][:, i], lw=1.8, label=f"K{i + 1} (along {names[i]})")
        ax.axhline(0.0, color="0.5", lw=0.6)
        ax.set(xlabel="f on F along +Y [N]", ylabel="stiffness [N/m]", title=f"({tag})")
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
    return _save(plt, fig, path,
                 f"stiffness along the nodal coordinates at rho1 = {sweep['rho1']:g} m, "
                 f"rho2 = {sweep['rho2']:g} m (beta = {sweep['beta']:.4g} rad)")

"""Pictures of structures (matplotlib, Agg backend): bars black, strings red (slack strings
dotted), actuators blue, rigid bodies as grey spokes from their centre (planar ones as filled
polygons), fixed nodes as green triangles, each named in the legend; an optional second shape
drawn dashed and faint."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.general.statics import member_lengths
from tensegrity_core.general.structure import Structure

if TYPE_CHECKING:
    from matplotlib.figure import Figure
    from mpl_toolkits.mplot3d import Axes3D  # type: ignore[import-untyped]  # ships without type information


def draw_structure(ax: Axes3D, structure: Structure, coords: ArrayLike, *, faint: bool = False) -> None:
    """Draw ``structure`` at ``coords`` (n, 3) [m] on a 3-D matplotlib axes (:func:`legend_handles`
    names what is drawn)."""
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # type: ignore[import-untyped]  # as above

    coords = np.asarray(coords, dtype=np.float64)
    alpha = 0.35 if faint else 1.0
    style = "--" if faint else "-"
    for i, (a, b) in enumerate(structure.members):
        seg = coords[[a, b]]
        color, width = MEMBER_STYLES[structure.member_kinds[i]]
        ax.plot(seg[:, 0], seg[:, 1], seg[:, 2], ":" if _slack(structure, coords)[i] else style, color=color,
                lw=width, alpha=alpha)
    for body in structure.bodies:
        pts = coords[list(body.nodes)]
        c = pts.mean(axis=0)
        sv = np.linalg.svd(pts - c, compute_uv=False)
        if sv[-1] <= 1e-9 * sv[0]:                         # planar polygon: fill it
            ax.add_collection3d(Poly3DCollection([pts], facecolor="0.55", edgecolor="0.3",
                                                 alpha=0.35 * alpha, linewidths=0.8))
        else:                                              # solid body: spokes from the centre
            for p in pts:
                ax.plot(*np.c_[c, p], ls=style, color="0.45", lw=3.0, alpha=alpha, solid_capstyle="round")
    fixed = structure.layout.fixed_mask.all(axis=1)
    if fixed.any() and not faint:
        ax.scatter(*coords[fixed].T, marker="^", color="green", s=25, depthshade=False)


#: Colour and line width of each kind of member.
MEMBER_STYLES = {"string": ("red", 1.0), "bar": ("black", 2.5), "actuator": ("tab:blue", 2.5)}


def _slack(structure: Structure, coords: NDArray[np.float64]) -> NDArray[np.bool_]:
    slack: NDArray[np.bool_] = structure.is_string & (member_lengths(structure, coords) < structure.rest_lengths)
    return slack


def legend_handles(structure: Structure, final: ArrayLike, initial: ArrayLike | None) -> list[Any]:
    """One legend entry for each kind of thing :func:`draw_structure` drew: member kinds,
    slack strings, rigid bodies, fixed nodes and the initial shape."""
    from matplotlib.lines import Line2D

    kinds = set(structure.member_kinds)
    handles = [Line2D([], [], color=MEMBER_STYLES[k][0], lw=MEMBER_STYLES[k][1], label=name)
               for k, name in (("bar", "bar"), ("string", "string"), ("actuator", "actuator")) if k in kinds]
    if _slack(structure, np.asarray(final, dtype=np.float64)).any():
        handles.append(Line2D([], [], color="red", lw=1.0, ls=":", label="slack string"))
    if structure.bodies:
        handles.append(Line2D([], [], color="0.45", lw=3.0, label="rigid body"))
    if structure.layout.fixed_mask.all(axis=1).any():
        handles.append(Line2D([], [], color="green", marker="^", ls="", label="fixed node"))
    if initial is not None:
        handles.append(Line2D([], [], color="0.3", lw=1.5, ls="--", alpha=0.35, label="initial shape (faint, dashed)"))
    return handles


def plot_shapes(structure: Structure, final: ArrayLike, initial: ArrayLike | None = None, *,
                path: str | Path | None = None, title: str | None = None) -> Figure:
    """Figure of the ``final`` shape (solid) over the ``initial`` one (dashed); saved to
    ``path`` (PNG) when given; a structure lying in a coordinate plane is seen face on.
    Returns the figure."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator

    fig = plt.figure(figsize=(7, 6))
    ax = fig.add_subplot(projection="3d")
    shapes = [np.asarray(final, dtype=float)]
    if initial is not None:
        draw_structure(ax, structure, initial, faint=True)
        shapes.append(np.asarray(initial, dtype=float))
    draw_structure(ax, structure, final)
    pts = np.vstack(shapes)
    centre = 0.5 * (pts.max(axis=0) + pts.min(axis=0))
    half = 0.5 * max(float(np.ptp(pts, axis=0).max()), 1e-9)
    for set_lim, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), centre):
        set_lim(c - half, c + half)
    ax.set_box_aspect((1, 1, 1))
    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):     # few ticks: a 3-D axis is short on screen
        axis.set_major_locator(MaxNLocator(4))
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    flat = np.ptp(pts, axis=0) <= 1e-9 * 2 * half
    if flat[2]:
        ax.view_init(elev=90, azim=-90)          # planar in x-y: seen from above
        ax.set_zticks([])
        ax.set_zlabel("")
    elif flat[1]:
        ax.view_init(elev=0, azim=-90)           # planar in x-z: seen from the front
        ax.set_yticks([])
        ax.set_ylabel("")
    ax.set_title(title or structure.name)
    ax.legend(handles=legend_handles(structure, final, initial), loc="upper left", fontsize=8)
    if path is not None:
        fig.savefig(path, dpi=120, bbox_inches="tight")
        plt.close(fig)
    return fig

"""Regenerate the figures of docs/general.md: ``.venv/bin/python docs/make_general_figures.py``.

Writes PNGs into docs/img/general/ (the scaling plot comes from the benchmark:
``python -m tests.bench --only general --full --plot-dir docs/img/general``).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from tensegrity_core.general import (  # noqa: E402
    form_find,
    load_example,
    rest_length_path,
    spherical_tensegrity,
    t_bar,
)
from tensegrity_core.general.plotting import plot_shapes  # noqa: E402

OUT = Path(__file__).parent / "img" / "general"


def t_bar_forces() -> None:
    fig, axes = plt.subplots(1, 2, figsize=(11, 4), sharey=True)
    for ax, supports in zip(axes, ("roller", "pinned")):
        s = t_bar(0.8, supports=supports)
        L = s.initial_lengths
        path = rest_length_path(s, lambda p, L=L: np.array([1, 1, 1, 1, p, p, 0.8, 0.8]) * L,
                                np.linspace(0.8, 0.5, 25))
        t = path.member_forces / 1e3
        for j, name in enumerate(s.member_names):
            if name in ("bar52", "top32", "bottom41"):
                continue                                  # equal to their mirror images
            ax.plot(path.parameters, t[:, j], "o-", ms=3, label=name)
        if path.limit_point:
            ax.axvline(path.limit_point[0], color="0.5", ls=":", label=f"branch ends ({path.limit_point[0]:.4f})")
        ax.set_xlabel("top string rest length / l")
        ax.set_title(f"T-bar, {supports} supports")
        ax.invert_xaxis()
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("member force [kN]")
    axes[1].legend(fontsize=8)
    fig.savefig(OUT / "t_bar_forces.png", dpi=110, bbox_inches="tight")
    plt.close(fig)


def spherical_force_densities() -> None:
    ratios = np.linspace(0.8, 0.1, 8)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for kind in ("tetrahedron", "hexahedron", "octahedron", "dodecahedron", "icosahedron"):
        qt, qv, x0 = [], [], None
        for r in ratios:
            s = spherical_tensegrity(kind, vertical_ratio=r)
            res = form_find(s, x0=x0)
            q = res.member_forces / res.member_lengths
            is_t = np.array([n.startswith("t") for n in s.member_names])
            qt.append(q[is_t].mean() / 1e6)
            qv.append(q[~is_t].mean() / 1e6)
            x0 = res.configuration
        axes[0].plot(ratios, qt, "o-", ms=3, label=kind)
        axes[1].plot(ratios, qv, "o-", ms=3, label=kind)
    for ax, title in zip(axes, ("truncating-edge strings q_t", "vertical strings q_v")):
        ax.set_xlabel("vertical string rest length / drawn length")
        ax.set_ylabel("force density [MN/m]")
        ax.set_title(title)
        ax.invert_xaxis()
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.savefig(OUT / "spherical_force_densities.png", dpi=110, bbox_inches="tight")
    plt.close(fig)


def shapes() -> None:
    for name in ("patio_shade", "tensegrity_table", "spherical_icosahedron", "spine_c", "spine_s"):
        s = load_example(name)
        r = form_find(s)
        plot_shapes(s, r.nodes, s.nodes, path=OUT / f"{name}.png",
                    title=f"{s.name}: {r.iterations} iterations")


if __name__ == "__main__":
    OUT.mkdir(parents=True, exist_ok=True)
    t_bar_forces()
    spherical_force_densities()
    shapes()

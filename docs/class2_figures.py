"""Regenerate the figures and scan figures quoted in docs/class2.md.

Run from the repository root: ``.venv/bin/python docs/class2_figures.py``. Writes PNGs to
docs/img/class2/ and prints the numbers the document quotes (stiffness scan of Sect. 4).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from tensegrity_core.class2 import (  # noqa: E402
    PAPER_PARAMS,
    critical_forces,
    fk_array,
    stiffness_along_coordinates,
    stiffness_sweep,
    workspace,
)
from tensegrity_core.class2.plotting import plot_stiffness_sweep, plot_workspace  # noqa: E402

OUT = Path(__file__).parent / "img" / "class2"


def fk_map() -> None:
    """beta and D over the actuator plane (paper's range shaded)."""
    r1, r2 = np.meshgrid(np.linspace(0, 1, 301), np.linspace(0, 2, 601))
    fk = fk_array(r1, r2, PAPER_PARAMS)
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.6))
    for ax, data, title in zip(axes, (fk.beta, fk.x, fk.y), ("beta [rad]", "x of D [m]", "y of D [m]")):
        im = ax.contourf(r1, r2, np.where(fk.valid, data, np.nan), levels=21, cmap="viridis")
        ax.contour(r1, r2, np.where(fk.valid, fk.beta, np.nan), levels=[np.pi / 2], colors="tab:orange")
        fig.colorbar(im, ax=ax)
        ax.set(xlabel="rho1 [m]", ylabel="rho2 [m]", title=f"{title}; orange: beta = pi/2")
    fig.tight_layout()
    fig.savefig(OUT / "fk_map.png", dpi=110)
    plt.close(fig)


def stiffness_scan() -> None:
    """K_i at f = 0, cond(K_ri) and the critical forces over a grid of configurations."""
    r1s = np.linspace(0.02, 0.98, 49)
    r2s = np.linspace(0.02, 1.98, 99)
    crit_neg = np.full((len(r2s), len(r1s)), np.nan)
    crit_pos = np.full_like(crit_neg, np.nan)
    k0, cond0, min_eig = [], [], []
    for j, a in enumerate(r1s):
        for i, b in enumerate(r2s):
            if a + b >= 1.999:
                continue
            res = stiffness_along_coordinates(a, b, 0.0)
            k0.append(res.K_i)
            cond0.append(res.cond_K_r)
            min_eig.append(np.linalg.eigvalsh(res.K)[0])
            crit = critical_forces(a, b)
            if (crit < 0).any():
                crit_neg[i, j] = crit[crit < 0].max()
            if (crit > 0).any():
                crit_pos[i, j] = crit[crit > 0].min()
    k0, cond0 = np.array(k0), np.array(cond0)
    print(f"configurations scanned: {len(k0)}; min eigenvalue of K at f = 0: {min(min_eig):.4g} N/m")
    for name, arr in (("K_i(f=0) min", k0.min(0)), ("K_i(f=0) median", np.median(k0, 0)),
                      ("K_i(f=0) max", k0.max(0)), ("cond(K_ri) f=0 min", cond0.min(0)),
                      ("cond(K_ri) f=0 max", cond0.max(0))):
        print(f"{name:22}", " ".join(f"{v:10.4g}" for v in arr))
    neg = crit_neg[np.isfinite(crit_neg)]
    pos = crit_pos[np.isfinite(crit_pos)]
    print(f"critical f < 0 (load along -Y): {neg.size} configurations, range [{neg.min():.4g}, {neg.max():.4g}] N; "
          f"in [-3.5, -2]: {np.sum((neg >= -3.5) & (neg <= -2))}")
    print(f"critical f > 0 (load along +Y): {pos.size} configurations"
          + (f", smallest {pos.min():.4g} N" if pos.size else ""))
    fig, ax = plt.subplots(figsize=(6.5, 6))
    im = ax.contourf(r1s, r2s, -crit_neg, levels=np.linspace(0, 20, 41), cmap="magma_r", extend="max")
    cs = ax.contour(r1s, r2s, -crit_neg, levels=[2.0, 3.5], colors=["tab:cyan", "tab:blue"])
    ax.clabel(cs, fmt="%g N")
    fig.colorbar(im, ax=ax, label="buckling load |f| along -Y [N] (det K = 0)")
    ax.plot([0, 1], [0, 1 / 3], color="tab:orange", lw=1.5, label="beta = pi/2")
    ax.set(xlabel="rho1 [m]", ylabel="rho2 [m]", title="load on F along -Y at which K loses definiteness")
    ax.legend(loc="upper right")
    fig.tight_layout()
    fig.savefig(OUT / "critical_force_map.png", dpi=110)
    plt.close(fig)


def main() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    plot_workspace(workspace(), OUT / "workspace.png")
    plot_workspace(workspace(rho1_range=(0.2, 0.8), rho2_range=(0.0, 0.3), paper_range=False),
                   OUT / "workspace_limited.png")
    fk_map()
    plot_stiffness_sweep(stiffness_sweep(0.7, 0.7, np.linspace(0.0, 5.0, 101)), OUT / "fig2_plus_y_rho07.png")
    plot_stiffness_sweep(stiffness_sweep(0.76, 0.76, np.linspace(-5.0, 0.0, 201)), OUT / "fig2_minus_y_rho076.png")
    stiffness_scan()
    for r in ((0.7, 0.7), (0.76, 0.76), (0.8, 0.04)):
        res = stiffness_along_coordinates(*r, 0.0)
        print(f"rho = {r}: K_i(0) =", np.round(res.K_i, 4), "cond(K_ri) =", np.round(res.cond_K_r, 1),
              "critical f =", np.round(critical_forces(*r), 4))


if __name__ == "__main__":
    main()

"""Figures of the controller (matplotlib, Agg, PNG): responses, circle, poles across the workspace."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any, Final

import numpy as np
from numpy.typing import ArrayLike, NDArray

from tensegrity_core.class2.control.holding import holding_forces, rest_state
from tensegrity_core.class2.control.lqr import DEFAULT_WEIGHTS, LQRWeights, design_gain, linearize
from tensegrity_core.class2.control.paths import CirclePath
from tensegrity_core.class2.params import PAPER_PARAMS, Class2Params
from tensegrity_core.class2.singularities.distances import singularity_distance_array

if TYPE_CHECKING:
    from studies.closed_loop import StudyResult

TOLERANCE: Final = 5e-5


def _plt() -> ModuleType:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_waypoints(studies: Sequence[StudyResult], path: str | Path, hold: float = 2.0) -> None:
    """Distance of D to the current waypoint (log) and the forces, for each
    :class:`~studies.closed_loop.StudyResult` of ``studies``."""
    plt = _plt()
    fig, ax = plt.subplots(2, 1, figsize=(8, 6.5), sharex=True)
    for study, style in zip(studies, ("-", "--", ":")):
        a = study.trace.arrays()
        ends = np.array([m.move_end for m in study.moves])
        which = np.minimum(np.searchsorted(ends + hold, a["t"] + 1e-9), len(ends) - 1)
        target = np.array([study.moves[i].target for i in which])
        dist = np.hypot(*(a["D"] - target).T)
        ax[0].semilogy(a["t"], np.maximum(dist, 1e-9) * 1e3, style, label=f"{study.law} ({study.rate:g} Hz)")
        ax[1].plot(a["t"], a["forces"][:, 0], style, lw=1, color="C0", label=f"{study.law}: f1")
        ax[1].plot(a["t"], a["forces"][:, 1], style, lw=1, color="C3", label=f"{study.law}: f2")
    for m in studies[0].moves:
        ax[0].axvline(m.move_end, color="0.8", lw=0.8)
    ax[0].axhline(TOLERANCE * 1e3, color="k", ls=":", lw=1, label="0.05 mm")
    ax[0].set_ylabel("|D - waypoint| [mm]")
    ax[0].set_title("the demo's four waypoints: 2 s moves, 2 s holds (grey: end of each move)")
    ax[0].legend(fontsize=8)
    ax[1].set_ylabel("commanded force [N]")
    ax[1].set_xlabel("t [s]")
    ax[1].legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_circle(studies: Sequence[StudyResult], circle: CirclePath, path: str | Path) -> None:
    """D in the plane and its error against the circle's point, per study."""
    plt = _plt()
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.5))
    phi = np.linspace(0, 2 * math.pi, 400)
    c = np.asarray(circle.center)
    ax[0].plot(c[0] + circle.radius * np.cos(phi), c[1] + circle.radius * np.sin(phi), "k:", lw=1, label="circle")
    for study, style in zip(studies, ("-", "--")):
        a = study.trace.arrays()
        err = np.hypot(*(a["D"] - circle.sample(a["t"])[0]).T)
        ax[0].plot(a["D"][:, 0], a["D"][:, 1], style, lw=1, label=study.law)
        ax[1].semilogy(a["t"], np.maximum(err, 1e-10) * 1e3, style, label=study.law)
    t0, t1 = circle.steady
    ax[1].axvspan(t0, t1, color="0.92", label="constant-rate turn")
    ax[0].set_aspect("equal")
    ax[0].set_xlabel("x [m]")
    ax[0].set_ylabel("y [m]")
    ax[0].legend(fontsize=8)
    ax[1].set_xlabel("t [s]")
    ax[1].set_ylabel("|D - circle point| [mm]")
    ax[1].legend(fontsize=8)
    fig.suptitle(f"D on a circle of {circle.radius * 100:g} cm, {circle.period:g} s per turn")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def poles_across_workspace(params: Class2Params = PAPER_PARAMS, *, dt: float = 0.01, n: int = 25,
                           weights: LQRWeights = DEFAULT_WEIGHTS, margin: float = 0.02) -> dict[str, Any]:
    """Open- and closed-loop poles at rest on a grid of the actuator plane (points at least
    ``margin`` from every singular set, paper's range): ``rho1, rho2`` (m,), the open loop's
    largest real part, the closed loop's slowest decay rate ``-max Re`` and smallest damping
    ratio, and every closed-loop pole [1/s]."""
    L, k2, K = params.L, params.k2, 2 * params.k3 + params.k2
    g1, g2 = np.meshgrid(np.linspace(0.02, 0.98, n) * L, np.linspace(0.02, 1.6, n) * L)
    r1, r2 = g1.ravel(), g2.ravel()
    ok = (singularity_distance_array(r1, r2, params) > margin) & (K * r2 > k2 * r1) & (r1 + r2 < 2 * L)
    out: dict[str, list[Any]] = {"rho1": [], "rho2": [], "open_max_real": [], "decay": [], "damping": [], "poles": []}
    for a, b in zip(r1[ok], r2[ok]):
        q, f = rest_state(a, b, params), holding_forces(a, b, params)
        A, _ = linearize(q, np.zeros(3), f, params)
        g = design_gain(q, np.zeros(3), f, params, weights, dt)
        s = g.continuous_poles
        out["rho1"].append(a)
        out["rho2"].append(b)
        out["open_max_real"].append(float(np.max(np.linalg.eigvals(A).real)))
        out["decay"].append(float(-np.max(s.real)))
        out["damping"].append(float(np.min(-s.real / np.abs(s))))
        out["poles"].append(s)
    return {k: (np.array(v) if k != "poles" else v) for k, v in out.items()}


def plot_poles(data: Mapping[str, Any], path: str | Path, waypoints: ArrayLike | None = None) -> None:
    plt = _plt()
    fig, ax = plt.subplots(1, 3, figsize=(15, 4.6))
    for axis, key, title, cmap in ((ax[0], "open_max_real", "open loop, constant forces: largest Re [1/s]", "coolwarm"),
                                   (ax[1], "decay", "closed loop: slowest decay rate -max Re [1/s]", "viridis")):
        sc = axis.scatter(data["rho1"], data["rho2"], c=data[key], cmap=cmap, s=28)
        fig.colorbar(sc, ax=axis)
        axis.set_title(title, fontsize=9)
        axis.set_xlabel("rho1 [m]")
        axis.set_ylabel("rho2 [m]")
        if waypoints is not None:
            axis.plot(*np.asarray(waypoints).T, "k*", ms=9, label="demo waypoints")
            axis.legend(fontsize=7)
    for s in data["poles"]:
        ax[2].plot(s.real, s.imag, ".", color="C0", ms=2)
    ax[2].axvline(0, color="k", lw=0.8)
    ax[2].set_xlabel("Re [1/s]")
    ax[2].set_ylabel("Im [rad/s]")
    ax[2].set_title(f"closed-loop poles at {len(data['poles'])} rest configurations", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def waypoint_configurations(params: Class2Params = PAPER_PARAMS,
                            offsets: Sequence[tuple[float, float]] | None = None) -> NDArray[np.float64]:
    """``(rho1, rho2)`` of the demo's waypoints (IK, branch followed from rho = (0.7, 0.7))."""
    from studies.closed_loop import WAYPOINT_OFFSETS
    from tensegrity_core.class2.inverse_kinematics import nearest_solution
    from tensegrity_core.class2.kinematics import forward_kinematics

    d = forward_kinematics(0.7, 0.7, params)
    seed = (0.7, 0.7)
    out: list[tuple[float, float]] = []
    for dx, dy in offsets or WAYPOINT_OFFSETS:
        c = nearest_solution(d.x + dx, d.y + dy, seed, params)
        seed = (c.rho1, c.rho2)
        out.append(seed)
    return np.array(out)

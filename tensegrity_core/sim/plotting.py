"""Plots of a :class:`~tensegrity_core.sim.trajectory.Trajectory` (matplotlib, Agg backend)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.events import EventKind

if TYPE_CHECKING:
    from tensegrity_core.sim.trajectory import Trajectory

EVENT_COLORS: dict[EventKind, str] = {"fold": "tab:red", "release": "tab:green", "limit": "black",
                                      "jump": "tab:purple", "singular": "tab:orange"}
#: Member forces are drawn on a symmetric-log axis only when the largest is this many times
#: their median (a fold's impact: 1e5 N beside forces of 1 N); otherwise linearly.
SYMLOG_SPAN = 1e3
#: At most this many members are drawn (the largest forces), each in a colour of its own.
MAX_MEMBERS = 12


def plot_trajectory(traj: Trajectory, path: str | Path) -> Path:
    """Write :func:`trajectory_figure` of ``traj`` to ``path`` (PNG)."""
    import matplotlib.pyplot as plt

    fig = trajectory_figure(traj)
    path = Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def trajectory_figure(traj: Trajectory) -> Any:
    """A matplotlib figure of a run over time, one panel each: the coordinates (class-2: rho1, rho2
    [m] and beta [rad] on two axes; a general structure: the largest speed of a node or a
    body's centre [m/s] and the largest angular speed of a body [rad/s]), the end effector
    [m], the actuator inputs (forces [N], or rest lengths [m]) with the fold limit's contact
    forces [N] (only when the scene has actuators), the member forces [N] (the 12 largest)
    and the energies [J]. Events are vertical lines of a colour per kind, named in the first
    panel's legend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    class2 = tuple(traj.node_names) == ("A", "B", "C", "D", "E", "F")
    actuated = bool(traj.applied_forces.size)
    fig, axes = plt.subplots(4 + actuated, 1, figsize=(8, 2.6 * (4 + actuated)), sharex=True)
    panels = iter(axes)
    first = next(panels)
    right = (_coordinates if class2 else _rates)(first, traj)
    _end_effector(next(panels), traj)
    if actuated:
        _actuators(next(panels), traj, class2)
    _member_forces(next(panels), traj)
    _energies(next(panels), traj)
    axes[-1].set_xlabel("t [s]")
    for ax in axes:
        for te, kind, _ in traj.events:
            ax.axvline(te, color=EVENT_COLORS.get(kind, "grey"), lw=0.8, alpha=0.6)
        ax.grid(alpha=0.3)
    _legend(first, right, traj)
    fig.tight_layout()
    # the layout is final: with tight_layout's placeholder engine left on the figure, savefig
    # would lay out and draw the whole figure once more (without rendering) before drawing it
    fig.set_layout_engine(None)
    return fig


def _coordinates(ax: Any, traj: Trajectory) -> Any:
    """rho1, rho2 on the left axis [m], beta on a right one [rad] (returned)."""
    t = traj.times
    ax.plot(t, traj.q[:, 0], label="rho1")
    ax.plot(t, traj.q[:, 1], label="rho2")
    ax.set_ylabel("actuator length [m]")
    right = ax.twinx()
    right.plot(t, traj.q[:, 2], color="tab:green", label="beta (right axis)")
    right.set_ylabel("beta [rad]")
    ax.set_title(f"{traj.scene_name}: generalised coordinates")
    return right


def _rates(ax: Any, traj: Trajectory) -> Any:
    """The largest translational speed over the nodes and body centres [m/s], and the largest
    angular speed over the bodies [rad/s] on a right axis (returned; None without bodies):
    the coordinates mix metres (``node.x``, ``body.cx``) and radians (``body.rx``), which one
    norm must not."""
    t = traj.times
    names = list(traj.state_names)[:traj.qdot.shape[1]]
    speed = _largest_norm(traj.qdot, names, rotation=False)
    ax.plot(t, speed, label="largest speed of a node or a body's centre")
    ax.set_ylabel("speed [m/s]")
    spin = _largest_norm(traj.qdot, names, rotation=True)
    ax.set_title(f"{traj.scene_name}: how fast it moves")
    if spin is None:
        return None
    right = ax.twinx()
    right.plot(t, spin, color="tab:orange", label="largest angular speed of a body (right axis)")
    right.set_ylabel("angular speed [rad/s]")
    return right


def _largest_norm(rates: NDArray[np.float64], names: list[str], *, rotation: bool) -> NDArray[np.float64] | None:
    """Per sample, the largest norm over the entities (the part of a coordinate's name before
    the dot) of their translation rates, or of their rotation rates (``.rx``, ``.ry``, ``.rz``);
    None when there is none of that kind."""
    groups: dict[str, list[int]] = {}
    for j, name in enumerate(names):
        entity, _, axis = name.partition(".")
        if axis.startswith("r") == rotation:
            groups.setdefault(entity, []).append(j)
    if not groups:
        return None
    norms: NDArray[np.float64] = np.max([np.linalg.norm(rates[:, cols], axis=1) for cols in groups.values()], axis=0)
    return norms


def _end_effector(ax: Any, traj: Trajectory) -> None:
    for k, axis in enumerate("xyz"):
        if np.ptp(traj.end_effector[:, k]) > 0 or k < 2:
            ax.plot(traj.times, traj.end_effector[:, k], label=axis)
    ax.set_ylabel("position [m]")
    ax.set_title("end effector")
    ax.legend(loc="best", fontsize=8)


def _actuators(ax: Any, traj: Trajectory, class2: bool) -> None:
    """The actuators' inputs (class 2: forces [N]; general: rest lengths [m], the
    ``MAX_MEMBERS`` that move most when there are more), the fold limit's contact forces of
    the class-2 mechanism, and a robot's floor normal force on a right axis."""
    t = traj.times
    many = len(traj.actuator_names) > MAX_MEMBERS
    moving = np.argsort(-np.ptp(traj.applied_forces, axis=0), kind="stable")[:MAX_MEMBERS] if many \
        else range(len(traj.actuator_names))
    for k in moving:
        ax.plot(t, traj.applied_forces[:, k], label=traj.actuator_names[k])
    if class2 and traj.contact_forces.size and np.any(traj.contact_forces):
        for k in range(traj.contact_forces.shape[1]):
            ax.plot(t, traj.contact_forces[:, k], "--", label=f"contact force {k + 1}")
    ax.set_ylabel("force [N]" if class2 else "rest length [m]")
    ax.set_title("actuator forces (tension +) and the fold limit's contact forces" if class2
                 else "actuator inputs (rest lengths" + (f", the {MAX_MEMBERS} that move most)" if many else ")"))
    ax.legend(loc="best", fontsize=7 if many else 8, ncol=2 if many else 1)
    if not class2 and traj.contact_forces.size and np.any(traj.contact_forces):     # a robot's floor
        floor = ax.twinx()
        floor.plot(t, traj.contact_forces.sum(axis=1), "k:", lw=1.0, label="floor normal force, all caps")
        floor.set_ylabel("floor force [N]")
        floor.legend(loc="lower right", fontsize=7)


def _member_forces(ax: Any, traj: Trajectory) -> None:
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FixedLocator, NullLocator

    t, forces = traj.times, traj.member_forces
    names = list(traj.member_names)
    shown = list(range(len(names))) if len(names) <= MAX_MEMBERS else \
        list(np.argsort(-np.abs(forces).max(axis=0))[:MAX_MEMBERS])
    palette = plt.get_cmap("tab20" if len(shown) > 10 else "tab10")       # a colour for each member
    for n, k in enumerate(shown):
        ax.plot(t, forces[:, k], color=palette(n % palette.N), label=names[k])
    magnitudes = np.abs(forces[:, shown])
    typical = float(np.median(magnitudes[magnitudes > 0])) if np.any(magnitudes > 0) else 0.0
    symlog = typical > 0 and float(magnitudes.max()) > SYMLOG_SPAN * typical
    if symlog:
        linthresh = 10.0 ** math.floor(math.log10(typical))
        ax.set_yscale("symlog", linthresh=linthresh, linscale=1.0)
        ax.yaxis.set_major_locator(FixedLocator(_symlog_ticks(linthresh, float(magnitudes.max()))))
        ax.yaxis.set_minor_locator(NullLocator())
    ax.set_ylabel("axial force [N]" + (" (symlog)" if symlog else ""))
    ax.set_title("member forces (tension +)" + ("" if len(names) <= MAX_MEMBERS else
                                               f", the {MAX_MEMBERS} largest of {len(names)}"))
    ax.legend(loc="best", fontsize=7, ncol=3)


def _symlog_ticks(linthresh: float, top: float, most: int = 3) -> list[float]:
    """0 and at most ``most`` powers of ten on each side, ``step`` decades apart, the lowest
    ``step`` decades above ``linthresh`` at least: on a symlog axis whose linear part takes a
    decade's height each side of 0, no two labels are then closer than ``step`` decades."""
    low, high = round(math.log10(linthresh)), math.ceil(math.log10(top))
    step = max(1, math.ceil((high - low) / most))
    powers = [10.0 ** e for e in range(high, low + step - 1, -step)]
    return sorted([0.0, *powers, *(-p for p in powers)])


def _energies(ax: Any, traj: Trajectory) -> None:
    """Potential, kinetic and total energy [J]; a potential energy that barely changes
    beside its size (a prestressed structure: 1.7e7 J moving by joules) is drawn as its
    change from t = 0, and so is the total, so that the exchange shows."""
    t, U, K = traj.times, traj.potential_energy, traj.kinetic_energy
    relative = bool(len(U)) and np.ptp(U) < 1e-3 * abs(float(U[0]))
    offset = float(U[0]) if relative else 0.0
    since = f" - {offset:.4g} J (its value at t = 0)" if relative else ""
    ax.plot(t, U - offset, label=f"potential{since}")
    ax.plot(t, K, label="kinetic")
    ax.plot(t, U + K - offset, label=f"total{since}")
    ax.set_ylabel("energy [J]")
    ax.set_title("energies")
    ax.legend(loc="best", fontsize=8)


def _legend(ax: Any, right: Any, traj: Trajectory) -> None:
    """The first panel's legend: its lines (and its ``right`` axis's) and one entry per kind
    of event."""
    from matplotlib.lines import Line2D

    handles, labels = ax.get_legend_handles_labels()
    if right is not None:
        more = right.get_legend_handles_labels()
        handles, labels = handles + more[0], labels + more[1]
    for kind in dict.fromkeys(kind for _, kind, _ in traj.events):
        handles.append(Line2D([], [], color=EVENT_COLORS.get(kind, "grey"), lw=0.8, alpha=0.6))
        labels.append(f"event: {kind}")
    ax.legend(handles, labels, loc="best", fontsize=8)

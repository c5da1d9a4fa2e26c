"""Plots of a :class:`~tensegrity_core.sim.trajectory.Trajectory` (matplotlib, Agg backend)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from tensegrity_core.events import EventKind

if TYPE_CHECKING:
    from tensegrity_core.sim.trajectory import Trajectory

EVENT_COLORS: dict[EventKind, str] = {"fold": "tab:red", "release": "tab:green", "limit": "black", "jump": "tab:purple"}


def plot_trajectory(traj: Trajectory, path: str | Path) -> Path:
    """Write a PNG with coordinates, end effector, actuator inputs, member forces and energies
    over time; events are marked by vertical lines (fold red, release green, limit black,
    jump purple)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = traj.times
    fig, axes = plt.subplots(5, 1, figsize=(8, 12), sharex=True)
    class2 = tuple(traj.node_names) == ("A", "B", "C", "D", "E", "F")
    ax = axes[0]
    if class2:
        ax.plot(t, traj.q[:, 0], label="rho1 [m]")
        ax.plot(t, traj.q[:, 1], label="rho2 [m]")
        ax.plot(t, traj.q[:, 2], label="beta [rad]")
        ax.set_title(f"{traj.scene_name}: generalised coordinates")
    else:
        speed = np.linalg.norm(traj.qdot, axis=1)
        ax.plot(t, speed, label="|dq/dt|")
        ax.set_title(f"{traj.scene_name}: rate of the coordinates")
    ax.legend(loc="best", fontsize=8)
    ax = axes[1]
    for k, axis in enumerate("xyz"):
        if np.ptp(traj.end_effector[:, k]) > 0 or k < 2:
            ax.plot(t, traj.end_effector[:, k], label=f"end effector {axis} [m]")
    ax.legend(loc="best", fontsize=8)
    ax = axes[2]
    many = len(traj.actuator_names) > 12
    if traj.applied_forces.size:
        unit = "N" if class2 else "m"
        moving = np.argsort(-np.ptp(traj.applied_forces, axis=0), kind="stable")[:12] if many \
            else range(len(traj.actuator_names))
        for k in moving:
            ax.plot(t, traj.applied_forces[:, k], label=f"{traj.actuator_names[k]} [{unit}]")
        if class2 and traj.contact_forces.size and np.any(traj.contact_forces):
            for k in range(traj.contact_forces.shape[1]):
                ax.plot(t, traj.contact_forces[:, k], "--", label=f"contact force {k + 1} [N]")
        ax.legend(loc="best", fontsize=7, ncol=2 if many else 1)
    else:
        ax.text(0.5, 0.5, "no actuators", ha="center", va="center", transform=ax.transAxes)
    if not class2 and traj.contact_forces.size and np.any(traj.contact_forces):     # a robot's floor
        floor = ax.twinx()
        floor.plot(t, traj.contact_forces.sum(axis=1), "k:", lw=1.0, label="floor normal force, all caps [N]")
        floor.set_ylabel("[N]")
        floor.legend(loc="lower right", fontsize=7)
    ax.set_title("actuator inputs" + (" and fold-limit contact forces" if class2 else
                                      " (rest lengths" + (", the 12 that move most)" if many else ")")))
    ax = axes[3]
    names = list(traj.member_names)
    shown = range(len(names)) if len(names) <= 12 else np.argsort(-np.abs(traj.member_forces).max(axis=0))[:12]
    for k in shown:
        ax.plot(t, traj.member_forces[:, k], label=names[k])
    ax.set_yscale("symlog", linthresh=max(1e-9, float(np.median(np.abs(traj.member_forces))) or 1.0))
    ax.set_title("member forces [N] (tension +, symlog)" + ("" if len(names) <= 12 else ", the 12 largest"))
    ax.legend(loc="best", fontsize=7, ncol=2)
    ax = axes[4]
    ax.plot(t, traj.potential_energy, label="potential")
    ax.plot(t, traj.kinetic_energy, label="kinetic")
    ax.plot(t, traj.potential_energy + traj.kinetic_energy, label="total")
    ax.set_title("energies [J]")
    ax.legend(loc="best", fontsize=8)
    ax.set_xlabel("t [s]")
    for ax in axes:
        for te, kind, _ in traj.events:
            ax.axvline(te, color=EVENT_COLORS.get(kind, "grey"), lw=0.8, alpha=0.6)
        ax.grid(alpha=0.3)
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path

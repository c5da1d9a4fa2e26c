"""Figures of docs/robots.md: ``python docs/robot_figures.py`` (writes docs/img/robots/*.png).

Each figure comes from a shipped scene run here: the drops (settling on the floor), the
6-bar's roll under the shipped gait, the 3-bar's crawl. Contact states and forces are the
scenes' sensor readings (effect ``sensors``).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from tensegrity_core.robot.faces import faces_visited, progress_faces  # noqa: E402
from tensegrity_core.sim import compile_scene, load_scene  # noqa: E402

OUT = Path(__file__).parent / "img" / "robots"


def run(name: str, duration: float | None = None, rate: float = 100.0):
    """The model and its observations of scene ``name`` at ``rate`` samples per second."""
    scene = load_scene(name)
    if duration is not None:
        scene = scene.with_duration(duration)
    model = compile_scene(scene)
    state = model.initial_state(t_end=scene.duration)
    samples: list = []
    model.record(state, np.arange(int(round(scene.duration * rate)) + 1) / rate, samples)
    return model, model.observe(samples)


def depth(model, o):
    p = model.plan
    return p.cap_radius - (o["nodes"][:, p.cap_node] - p.floor_point) @ p.floor_normal


def settle() -> None:
    fig, axes = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    for name, colour in (("three_bar_drop", "C0"), ("six_bar_drop", "C1")):
        model, o = run(name)
        d = depth(model, o).max(axis=1) * 1e3
        axes[0].plot(o["t"], d, colour, label=f"{name}: deepest cap")
        axes[1].semilogy(o["t"], np.maximum(o["kinetic_energy"], 1e-6), colour, label=f"{name}: kinetic energy")
        print(f"{name}: deepest cap at 3 s {d[-1]:.3f} mm, kinetic energy {o['kinetic_energy'][-1]:.3g} J")
    axes[0].axhline(1.0, color="k", ls=":", label="1 mm")
    axes[0].set_ylim(-5, 3)
    axes[0].set_ylabel("penetration of the floor [mm]\n(< 0: in the air)")
    axes[1].set_ylabel("kinetic energy [J]")
    axes[1].set_xlabel("t [s]")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    axes[0].set_title("drop from 5 cm and settle (RK4, 1 ms steps)")
    fig.tight_layout()
    fig.savefig(OUT / "settle.png", dpi=110)
    plt.close(fig)


def roll() -> None:
    model, o = run("six_bar_roll", 10.0)
    t, com = o["t"], o["centre_of_mass"]
    faces = faces_visited(t, o["cap_contact"])
    progress = len(progress_faces([caps for _, caps in faces])) - 1
    print(f"six_bar_roll: {progress} faces of progress in 10 s (faces at {[round(tf, 2) for tf, _ in faces]} s), "
          f"centre of mass moved "
          f"{com[-1, 0] - com[0, 0]:.2f} m along x, {com[-1, 1] - com[0, 1]:.2f} m along y")
    fig, axes = plt.subplots(3, 1, figsize=(7, 9))
    ax = axes[0]
    ax.plot(com[:, 0], com[:, 1], "C0", label="centre of mass")
    idx = [int(np.searchsorted(t, tf)) for tf, _ in faces]
    ax.plot(com[idx, 0], com[idx, 1], "ko", ms=4, label="a face first touched")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_title(f"six_bar_roll: {progress} faces of progress in 10 s")
    ax = axes[1]
    n_rods = len(model.robot.rods)
    tensions = o["member_forces"][:, n_rods:]
    ax.plot(t, tensions, lw=0.6, color="0.6")
    ax.plot(t, tensions.max(axis=1), "C3", lw=1.2, label="largest of the 24 cables")
    ax.plot([], [], color="0.6", lw=0.6, label="each cable")
    ax.set_ylabel("cable tension [N]")
    ax.set_xlabel("t [s]")
    ax = axes[2]
    ax.plot(t, o["contact_forces"], lw=0.6, color="0.6")
    ax.plot(t, o["contact_forces"].sum(axis=1), "C2", lw=1.2, label="sum over the 12 caps")
    ax.plot([], [], color="0.6", lw=0.6, label="each cap")
    weight = -model.plan.external.sum(axis=0) @ model.plan.floor_normal
    ax.axhline(weight, color="k", ls=":", lw=0.8, label=f"the robot's weight ({weight:.0f} N)")
    ax.set_ylabel("floor normal force [N]")
    ax.set_xlabel("t [s]")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    fig.savefig(OUT / "roll.png", dpi=110)
    plt.close(fig)


def crawl() -> None:
    model, o = run("three_bar_crawl", rate=50.0)
    t, com = o["t"], o["centre_of_mass"]
    start = int(np.searchsorted(t, 2.0))
    move = com[-1, :2] - com[start, :2]
    print(f"three_bar_crawl: centre of mass moved {np.hypot(*move):.2f} m from 2 s to {t[-1]:g} s ({move.round(2)} m)")
    fig, axes = plt.subplots(1, 2, figsize=(9, 4))
    ax = axes[0]
    ax.plot(com[:, 0], com[:, 1], "C0", label="centre of mass")
    ax.plot(*com[start, :2], "ko", label="gait starts (2 s)")
    ax.plot(*com[-1, :2], "ks", label=f"{t[-1]:g} s")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_title("three_bar_crawl: centre of mass")
    ax = axes[1]
    ax.plot(t, o["applied_forces"][:, 0], "C0", label="td_0..td_2: the motors' rest length")
    ax.plot(t, o["applied_forces"][:, 3], "C1", label="td_3..td_5: the motors' rest length")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("motor rest length [m]")
    ax.set_title("the motors' rest lengths (1 s lag)")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(OUT / "crawl.png", dpi=110)
    plt.close(fig)


def main() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    settle()
    roll()
    crawl()


if __name__ == "__main__":
    main()

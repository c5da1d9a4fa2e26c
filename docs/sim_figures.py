"""Figures of docs/scenes.md: ``python docs/sim_figures.py`` (writes docs/img/sim/*.png)."""

from __future__ import annotations

from pathlib import Path

from tensegrity_core.sim import simulate
from tensegrity_core.sim.plotting import plot_trajectory

OUT = Path(__file__).parent / "img" / "sim"


def main() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    for name, duration in (("paper_fold", None), ("paper_fold_quasistatic", 0.2), ("stiff_fold", None),
                           ("spine_release", None), ("table_gravity", None)):
        traj = simulate(name, duration=duration)
        plot_trajectory(traj, OUT / f"{name}.png")
        print(f"{name}: {traj.message}, {len(traj)} samples -> {OUT / (name + '.png')}")


if __name__ == "__main__":
    main()

"""Figures of docs/control.md: ``.venv/bin/python -m docs.control_figures`` from the repository root (a few minutes).

Writes docs/img/control/*.png and prints the numbers quoted in docs/control.md.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from studies.closed_loop import circle_study, waypoint_study
from studies.closed_loop_plots import (
    plot_circle,
    plot_poles,
    plot_waypoints,
    poles_across_workspace,
    waypoint_configurations,
)
from tensegrity_core.class2 import PAPER_PARAMS, forward_kinematics
from tensegrity_core.class2.control import CirclePath

OUT = Path(__file__).resolve().parent / "img" / "control"


def main() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    with threadpool_limits(1):
        lqr = waypoint_study("lqr")
        base = waypoint_study("baseline")
        plot_waypoints([lqr, base], OUT / "waypoints.png")
        for s in (lqr, base):
            for m in s.moves:
                print(f"{s.law:8s} {m.target}: settled {m.settled_error * 1e3:.5f} mm, settling {m.settling_time:.2f} s,"
                      f" 2% {m.settling_time_2pc:.2f} s, overshoot {m.overshoot * 1e3:.4f} mm, "
                      f"max force {m.max_force:.3f} N, tracking {m.max_tracking_error * 1e3:.4f} mm")
        d = forward_kinematics(0.7, 0.7, PAPER_PARAMS)
        circles = [circle_study(law) for law in ("lqr", "baseline")]
        plot_circle(circles, CirclePath((d.x, d.y), 0.05, 4.0, ramp=2.0), OUT / "circle.png")
        for c in circles:
            print(f"circle {c.law}: " + ", ".join(f"{k} {v:.4g}" for k, v in c.extra.items()))
        data = poles_across_workspace(n=25)
        plot_poles(data, OUT / "poles.png", waypoints=waypoint_configurations())
        print(f"poles at {len(data['rho1'])} configurations: open loop max Re in [{data['open_max_real'].min():.3f}, "
              f"{data['open_max_real'].max():.3f}] (unstable at {np.mean(data['open_max_real'] > 0) * 100:.0f} %); "
              f"closed loop decay rate in [{data['decay'].min():.3f}, {data['decay'].max():.3f}] 1/s, "
              f"damping ratio >= {data['damping'].min():.3f}")
        i = int(np.argmin(data["decay"]))
        print(f"slowest at rho = ({data['rho1'][i]:.3f}, {data['rho2'][i]:.3f})")


if __name__ == "__main__":
    main()

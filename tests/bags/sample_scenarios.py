"""The two sample runs in ``bags/`` and the script that records them.

Both are quasi-static paths of the class-2 mechanism (default parameters: the paper's
L = 1, k = 1): the actuators move slowly and beta sits at its energy-minimising
equilibrium (:func:`tensegrity_core.class2.energy.equilibrium_beta`), so node D is the
forward-kinematics solution at every instant.

- ``fold``: from the paper's initial configuration rho1 = rho2 = 0.7 m (Sect. 5.3) both
  actuators retract to zero along a cosine ramp over ``FOLD_TIME`` s, then hold: the
  mechanism folds (the paper: "when the lengths of the actuators are zero, the whole
  mechanism will be folded").
- ``ik_circle``: node D is driven round a circle (``CIRCLE_CENTER``, ``CIRCLE_RADIUS``, one
  turn in ``CIRCLE_PERIOD`` s); the actuator lengths at each instant are the inverse
  kinematics, solved numerically (scipy least_squares on the forward kinematics).

qdot is a central difference of q (h = 1 ms). The lead's demo and simulator are not merged
yet: these bags were recorded by the real recorder from the stand-in publishers of
:mod:`tests.bags.suite_publishers`; record them again with the demo once it exists::

    python -m tests.bags.sample_scenarios --out bags
"""

from __future__ import annotations

import argparse
import math
import os
import random
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

from tensegrity_core.class2.energy import equilibrium_beta
from tensegrity_core.class2.geometry import node_positions
from tests.bags.suite_publishers import PARAMS

FOLD_START = 0.7          # m, both actuators (the paper's q0)
FOLD_TIME = 3.0           # s
CIRCLE_CENTER = (1.35, 0.75)
CIRCLE_RADIUS = 0.05      # m
CIRCLE_PERIOD = 4.0       # s
DURATION = 4.0            # s of each recording
RATES = {"joint_states": 100.0, "end_effector": 100.0, "mechanism_state": 50.0,
         "markers": 10.0, "/clock": 100.0}


def _with_rates(q_of):
    def path(t: float):
        h = 1e-3
        return q_of(t), (q_of(t + h) - q_of(t - h)) / (2 * h)
    return path


def fold_q(t: float) -> np.ndarray:
    s = 0.5 * (1 - math.cos(math.pi * min(max(t, 0.0), FOLD_TIME) / FOLD_TIME))
    rho = FOLD_START * (1 - s)
    return np.array([rho, rho, float(equilibrium_beta(rho, rho, PARAMS))])


def end_effector_of(rho1: float, rho2: float) -> np.ndarray:
    beta = float(equilibrium_beta(rho1, rho2, PARAMS))
    return node_positions([rho1, rho2, beta], PARAMS)[3]


def circle_target(t: float) -> np.ndarray:
    phase = 2 * math.pi * t / CIRCLE_PERIOD
    return np.array([CIRCLE_CENTER[0] + CIRCLE_RADIUS * math.cos(phase),
                     CIRCLE_CENTER[1] + CIRCLE_RADIUS * math.sin(phase)])


def ik_q(t: float) -> np.ndarray:
    target = circle_target(t)
    sol = least_squares(lambda r: end_effector_of(r[0], r[1]) - target, x0=[0.7, 0.7],
                        bounds=([0.0, 0.0], [PARAMS.L, 2 * PARAMS.L]), xtol=1e-15,
                        ftol=1e-15, gtol=1e-15)
    rho1, rho2 = sol.x
    return np.array([rho1, rho2, float(equilibrium_beta(rho1, rho2, PARAMS))])


SCENARIOS = {"fold": _with_rates(fold_q), "ik_circle": _with_rates(ik_q)}


def record_scenario(name: str, out: Path) -> Path:
    """Record one scenario with ``tensegrity record`` into ``out/name``."""
    import rclpy
    from rclpy.context import Context
    from rclpy.duration import Duration

    from tests.bags.suite_publishers import SuitePublisher

    folder = out / name
    if folder.exists():
        shutil.rmtree(folder)
    rec = subprocess.Popen([str(Path(sys.executable).with_name("tensegrity")), "record",
                            "-o", str(folder)], stderr=subprocess.PIPE, text=True)
    ctx = Context()
    rclpy.init(args=[], context=ctx)
    try:
        node = SuitePublisher(RATES, context=ctx, name=f"{name}_run", path=SCENARIOS[name])
        if not node.wait_for_subscribers(60):
            raise RuntimeError("the recorder did not subscribe")
        node.run(duration_s=DURATION)
        for pub in node.pubs.values():
            pub.wait_for_all_acked(Duration(seconds=30))
    finally:
        rec.send_signal(2)
        rec.wait(60)
        rclpy.try_shutdown(context=ctx)
    return folder


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m tests.bags.sample_scenarios")
    ap.add_argument("--out", default="bags")
    args = ap.parse_args(argv)
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    os.environ.setdefault("ROS_DOMAIN_ID", str(150 + random.randrange(40)))
    for name in SCENARIOS:
        print(record_scenario(name, Path(args.out)))
    return 0


if __name__ == "__main__":
    sys.exit(main())

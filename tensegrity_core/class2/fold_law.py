"""The paper's fold law (Ji, Li & Lin, Sect. 5.3) as a controller of a sampled state.

``f_i = FOLD_GAIN * rho_i * t`` [N] (tension positive: pulls the actuator's nodes
together), here evaluated on a sample of the state and held until the next sample: the law
the demo closes over ROS in lockstep, and a controller for
:func:`tensegrity_core.sim.sampled.run_sampled` and for ``tensegrity simulate
--controller tensegrity_core.class2.fold_law:paper_fold_forces``. (The continuous-time law
is the ``proportional`` input of the ``paper_fold`` scene.)
"""

from __future__ import annotations

#: Gain of the paper's fold law [N/(m s)].
FOLD_GAIN = 10.0


def paper_fold_forces(sample) -> tuple[float, float]:
    """``(f1, f2)`` [N] from the sample's lengths ``q[:2]`` [m] and time ``t`` [s]."""
    t = sample.t
    return FOLD_GAIN * float(sample.q[0]) * t, FOLD_GAIN * float(sample.q[1]) * t

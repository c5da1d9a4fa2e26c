"""The paper's fold law (Ji, Li & Lin, Sect. 5.3) as a controller of a sampled state.

``f_i = FOLD_GAIN * rho_i * t`` [N] (tension positive: pulls the actuator's nodes
together), here evaluated on a sample of the state and held until the next sample: the law
the demo closes over ROS in lockstep, and a controller for
:func:`tensegrity_core.sim.sampled.run_sampled` and for ``tensegrity simulate
--controller tensegrity_core.class2.fold_law:paper_fold_forces``. (The continuous-time law
is the ``proportional`` input of the ``paper_fold`` scene.)
"""

from __future__ import annotations

from typing import Final, Protocol

import numpy as np
from numpy.typing import NDArray

#: Gain of the paper's fold law [N/(m s)].
FOLD_GAIN: Final = 10.0


class StateSample(Protocol):
    """What the law reads of a sample (e.g. :class:`tensegrity_core.sim.simulator.JointSample`)."""

    @property
    def t(self) -> float:
        """Sample time [s]."""
        ...

    @property
    def q(self) -> NDArray[np.float64]:
        """``(rho1, rho2, beta)`` [m, m, rad]."""
        ...


def paper_fold_forces(sample: StateSample) -> tuple[float, float]:
    """``(f1, f2)`` [N] from the sample's lengths ``q[:2]`` [m] and time ``t`` [s]."""
    t = sample.t
    return FOLD_GAIN * float(sample.q[0]) * t, FOLD_GAIN * float(sample.q[1]) * t

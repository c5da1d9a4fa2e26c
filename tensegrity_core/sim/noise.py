"""Sensor noise on observed quantities: additive, Gaussian, seeded, one sigma per quantity.

Noise perturbs what is *observed* (published, recorded as measurements), never the
simulated state. The generator is ``numpy.random.default_rng(seed)``; draws happen in a
fixed order (quantities in :data:`~tensegrity_core.sim.scene.NOISY_QUANTITIES` order), so
the same scene and the same sequence of calls give the same noise.
"""

from __future__ import annotations

import numpy as np

from tensegrity_core.sim.scene import NOISY_QUANTITIES


class SensorNoise:
    """Adds ``N(0, sigma_k^2)`` to each element of quantity ``k``."""

    def __init__(self, sigmas: dict, seed: int):
        self.sigmas = {k: float(sigmas[k]) for k in NOISY_QUANTITIES if k in sigmas}
        self.rng = np.random.default_rng(seed)

    def perturb(self, obs) -> None:
        """Add noise in place to an :class:`~tensegrity_core.sim.simulator.Observation` (or
        any object with some of the noisy quantities as attributes)."""
        for name, sigma in self.sigmas.items():
            if not hasattr(obs, name):
                continue
            value = np.array(getattr(obs, name), dtype=float)
            setattr(obs, name, value + self.rng.normal(0.0, sigma, value.shape))

    def perturb_arrays(self, data: dict) -> dict:
        """Noisy copies of the arrays ``data[k]`` for every quantity with a sigma."""
        return {name: np.asarray(data[name], dtype=float) + self.rng.normal(0.0, sigma, np.shape(data[name]))
                for name, sigma in self.sigmas.items()}

"""What every simulator back end shares: commanded inputs, and the stepping-integrator plumbing.

A back end (class-2 or general, dynamic or quasi-static) provides ``t``, ``events``,
``command``, ``set_command(values)``, ``advance(t)``, ``sample()``, ``record(times, out)``,
``observe(samples)``, ``observe_now()`` and ``stats()``;
:class:`~tensegrity_core.sim.simulator.Simulator` talks to it only through these. What
``sample`` and ``record`` put into a list of samples is the back end's own business: only its
``observe`` reads them.
"""

from __future__ import annotations

import math

from tensegrity_core.sim.errors import SimulationError
from tensegrity_core.sim.inputs import HeldCommand
from tensegrity_core.sim.stepper import Stepper


class Commands:
    """Commanded inputs: ``laws`` (run-time laws, :class:`HeldCommand` for commanded inputs)
    and ``actuator_names``; ``positive`` for inputs that must be > 0 (rest lengths)."""

    laws: list
    actuator_names: tuple
    positive = False

    def observe_now(self) -> dict:
        """The observation at the current time: the values of ``observe([sample()])`` without
        the sample axis (class-2 back ends evaluate one sample directly, much faster)."""
        return {k: v[0] for k, v in self.observe([self.sample()]).items()}

    @property
    def command(self) -> list:
        """Current values of the commanded inputs (``nan`` for inputs with a law)."""
        return [law.value if isinstance(law, HeldCommand) else math.nan for law in self.laws]

    def take_command(self, values) -> bool:
        """Check ``values`` (one per actuator, in input order) and hold the commanded ones;
        returns whether any changed. Values for inputs with a law are ignored."""
        try:
            vals = [float(v) for v in values]
        except (TypeError, ValueError):
            raise SimulationError(f"command must be {len(self.laws)} numbers ({', '.join(self.actuator_names)}), "
                                  f"got {values!r}") from None
        if len(vals) != len(self.laws):
            raise SimulationError(f"command must have {len(self.laws)} values ({', '.join(self.actuator_names)}), "
                                  f"got {len(vals)}")
        for name, law, v in zip(self.actuator_names, self.laws, vals):
            if not math.isfinite(v):
                raise SimulationError(f"command for {name} must be finite, got {v!r}")
            if self.positive and isinstance(law, HeldCommand) and not v > 0:
                raise SimulationError(f"commanded rest length of {name} must be > 0, got {v!r}")
        changed = False
        for law, v in zip(self.laws, vals):
            if isinstance(law, HeldCommand) and law.value != v:
                law.value = v
                changed = True
        return changed


class Integrated(Commands):
    """A back end integrating equations of motion with a :class:`Stepper` (``self.stepper``,
    ``self.model``, ``self.method``)."""

    stepper: Stepper

    def start_stepper(self, y0, *, t_end: float) -> None:
        s = self.scene.integrator
        self.stepper = Stepper(self.model, 0.0, y0, method=self.method, rtol=s.rtol, atol=s.atol,
                               max_step=s.max_step, t_end=t_end)

    @property
    def t(self) -> float:
        return self.stepper.t

    @property
    def state_names(self) -> tuple:
        return self.model.state_names

    @property
    def events(self) -> list:
        return self.stepper.event_log

    def set_command(self, values) -> None:
        if self.take_command(values):
            self.stepper.restart(self.stepper.t, self.stepper.y, input_changed=True)

    def advance(self, t: float) -> None:
        self.stepper.advance(t)

    def stats(self) -> dict:
        st = self.stepper
        return {"method": self.method, "steps": st.n_steps, "nfev": st.nfev, "restarts": st.n_restarts - 1,
                "events": st.n_events}

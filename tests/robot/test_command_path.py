"""The robot back end's command path takes exactly the commands the description allows: a
command is accepted iff it has one finite value per motor, each inside that motor's
rest-length range from the robot description (``six_bar``: [0.45, 1.05] m), whether it is
new, repeated or given after a rejected one; and a state copied mid-run and commanded apart
from its original samples as a run from scratch under its own commands does.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from tensegrity_core.sim import Simulator
from tensegrity_core.sim.errors import SimulationError
from tensegrity_core.sim.sampled import step_time

STEP_NS = 1_000_000
#: Values around and inside the 6-bar motors' range [m], and ones never accepted.
VALUES = st.one_of(st.floats(0.3, 1.2), st.sampled_from([0.45, 1.05, 0.75, math.nan, math.inf, -math.inf]))


@pytest.fixture(scope="module")
def drop() -> Simulator:
    return Simulator("six_bar_drop")


@given(commands=st.lists(st.lists(VALUES, min_size=23, max_size=25), min_size=1, max_size=4),
       repeat=st.booleans())
def test_a_command_is_accepted_iff_every_motor_gets_a_finite_value_inside_its_range(drop, commands, repeat):
    lo, hi = drop.model.robot.motors.range.T
    for values in commands:
        for given_ in ([values, list(values)] if repeat else [values]):
            before = drop.command
            ok = len(given_) == len(lo) and all(math.isfinite(v) for v in given_) \
                and bool(np.all((lo <= given_) & (given_ <= hi)))
            if ok:
                drop.set_command(given_)
                assert drop.command == [float(v) for v in given_]
            else:
                with pytest.raises(SimulationError):
                    drop.set_command(given_)
                assert drop.command == before


def test_laws_values_are_ignored_but_must_be_finite():
    roll = Simulator("six_bar_roll")                      # every motor follows the gait's law
    roll.set_command([5.0] * 24)                          # outside any range: ignored
    assert all(math.isnan(v) for v in roll.command)
    for bad in ([math.nan] * 24, [0.75] * 23, ["x"] * 24):
        with pytest.raises(SimulationError):
            roll.set_command(bad)


def test_a_copied_state_steps_and_samples_apart_from_its_original():
    """Two states stepped apart (one copied from the other, then commanded to the two ends of
    the motors' range) sample bit for bit as two simulators run from scratch with the same
    commands do (the copies share their integrator's cached motor targets, not its buffers)."""
    a, ref_a, ref_b = Simulator("six_bar_drop"), Simulator("six_bar_drop"), Simulator("six_bar_drop")
    for k in range(1, 6):
        for s in (a, ref_a, ref_b):
            s.set_command([0.75] * 24)
            s.advance(step_time(k, STEP_NS))
    b_state = a.state.copy()
    samples: dict[str, list[np.ndarray]] = {"a": [], "b": [], "ref_a": [], "ref_b": []}
    for k in range(6, 12):
        for name, s, u in (("a", a, 0.45), ("ref_a", ref_a, 0.45), ("ref_b", ref_b, 1.05)):
            s.set_command([u] * 24)
            s.advance(step_time(k, STEP_NS))
            samples[name].append(s.joint_sample(coordinates=False).applied_forces)
        a.model.set_command(b_state, [1.05] * 24)
        a.model.advance(b_state, step_time(k, STEP_NS))
        samples["b"].append(a.model.joint_sample(b_state, coordinates=False)["applied_forces"])
    assert np.array_equal(samples["a"], samples["ref_a"])
    assert np.array_equal(samples["b"], samples["ref_b"])
    assert not np.array_equal(samples["a"], samples["b"])


def test_a_gait_stepped_a_millisecond_at_a_time_equals_one_advance():
    """The gait's motor targets are the same numbers however many steps each advance asks
    for (its laws evaluated for 1, 2, 4, ... steps at a time, or for 300 at once)."""
    stepped, whole = Simulator("six_bar_roll"), Simulator("six_bar_roll")
    for k in range(1, 301):
        stepped.advance(step_time(k, STEP_NS))
    whole.advance(0.3)
    assert stepped.t == whole.t == 0.3
    assert np.array_equal(stepped.state.work.y, whole.state.work.y)
    assert np.array_equal(stepped.joint_sample().q, whole.joint_sample().q)

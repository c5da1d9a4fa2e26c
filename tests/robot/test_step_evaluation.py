"""A robot's step hands over its end's evaluation: the observation inputs the fixed-step
integrator keeps from the kernel call that reached a grid point equal, bit for bit, a fresh
evaluation of that state (random states, motor commands and numbers of steps, both kernel
families), and a state reached otherwise (between grid points) is evaluated afresh."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tensegrity_core.sim.general.kernels.jit import have_numba
from tensegrity_core.sim.general.robot.system import RobotSystem, block_index, empty_evaluation
from tests.robot.test_dynamics import ROBOTS, _model, random_state

KERNELS = ["numpy", "numba"] if have_numba() else ["numpy"]


def _fresh(system: RobotSystem, y: np.ndarray):
    """``y`` evaluated by a system built anew (nothing kept from any step)."""
    return RobotSystem(system.plan, laws=system.laws, R_ref=system.R_ref.copy(), commands=system.commands,
                       modes=system.modes, kernels=system.kernels).evaluate(y.copy()[None])


@settings(max_examples=25, deadline=None)
@given(robot=st.sampled_from(ROBOTS), kernels=st.sampled_from(KERNELS), seed=st.integers(0, 2**32 - 1),
       steps=st.lists(st.integers(1, 40), min_size=1, max_size=3), fraction=st.floats(0.1, 0.9))
def test_kept_evaluation_equals_a_fresh_one(robot, kernels, seed, steps, fraction):
    model = _model(robot)
    y, _ = random_state(model, seed, spread=0.002)
    state = model.state_from(y)
    stepper = state.work
    if kernels != stepper.system.kernels:
        stepper.system = RobotSystem(model.plan, laws=stepper.system.laws, R_ref=stepper.system.R_ref,
                                     commands=stepper.system.commands, modes=stepper.system.modes, kernels=kernels)
    rng = np.random.default_rng(seed)
    h = model.step
    for k in steps:
        model.set_command(state, [rng.uniform(lo, hi) for lo, hi in model.command_ranges])
        model.advance(state, (stepper.n + k) * h)
        kept = stepper.evaluation()
        assert stepper._end is not None and kept is stepper._end[1]      # the step's own evaluation
        fresh = _fresh(stepper.system, stepper.y)
        for field in dataclasses.fields(kept):
            assert np.array_equal(getattr(kept, field.name), getattr(fresh, field.name), equal_nan=True), field.name
    # off the grid: evaluated afresh, not the grid point's
    model.advance(state, (stepper.n + fraction) * h)
    between = stepper.evaluation()
    assert between is not stepper._end[1]
    assert np.array_equal(between.derivative, _fresh(stepper.system, stepper.y).derivative)


@pytest.mark.skipif(not have_numba(), reason="the compiled kernels need numba (the 'fast' extra)")
def test_joint_sample_of_a_kept_evaluation_equals_a_copied_states():
    """A copied state (its own evaluation, nothing kept) samples the same joint values."""
    model = _model("six_bar")
    state = model.initial_state()
    model.advance(state, 0.05)
    copied = state.copy()
    a, b = model.joint_sample(state), model.joint_sample(copied)
    for key in a:
        assert np.array_equal(a[key], b[key]), key


@pytest.mark.parametrize("robot", ROBOTS)
def test_block_index_finds_each_fields_entries(robot):
    """``block_index`` points at the entries each field's own array holds (an evaluated state:
    distinct numbers), for every field, in the order asked."""
    model = _model(robot)
    y, _ = random_state(model, 7, spread=0.002)
    ev = model.system.evaluate(y[None], out=empty_evaluation(model.plan, 1))
    names = [f.name for f in dataclasses.fields(ev) if f.name != "block"]
    rng = np.random.default_rng(3)
    picks = [(name, rng.permutation(getattr(ev, name)[0].size)) for name in names]
    expected = np.concatenate([getattr(ev, name)[0].ravel()[index] for name, index in picks])
    assert np.array_equal(ev.block.take(block_index(model.plan, picks)), expected, equal_nan=True)
    assert ev.block.size == sum(getattr(ev, name).size for name in names)


def test_a_joint_sample_keeps_its_values_when_the_state_moves_on():
    """The joint sample is copied out of the evaluation the integrator reuses: the next step
    (which writes its own end's evaluation into the same arrays) leaves it as it was."""
    model = _model("six_bar")
    state = model.initial_state()
    model.advance(state, 0.05)
    sample = model.joint_sample(state, coordinates=False)
    kept = {key: np.copy(value) for key, value in sample.items()}
    model.advance(state, 0.051)
    assert not np.array_equal(model.joint_sample(state, coordinates=False)["actuated_lengths"],
                              kept["actuated_lengths"])            # the state did move
    for key, value in kept.items():
        assert np.array_equal(sample[key], value), key

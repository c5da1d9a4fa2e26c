"""A trajectory goal followed in the core's sampled loop: the controller's tick at every
sample of ``dt`` seconds, the goal judged on the same samples (what the ROS controller
does, without ROS). Shared by the closed-loop tests and the trajectory-file examples."""

from __future__ import annotations


def follow_to_outcome(sim, ctrl, goal, dt: float):
    """Step ``sim`` under ``ctrl`` until ``goal`` has an outcome; the last joint sample."""
    while goal.outcome is None:
        s = sim.joint_sample()
        tick = ctrl.update(s.t, s.q, s.qdot)
        goal.step(s.t, s.q, s.qdot, tick)
        sim.set_command(list(tick.forces))
        sim.advance(round(s.t / dt + 1) * dt)
    return s

"""What the robot back end compiles from a scene: its effects, the plan, the names, the initial state."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from tensegrity_core.robot.description import Robot
from tensegrity_core.robot.layout import robot_layout
from tensegrity_core.sim.general.robot.loops import NO_ANCHOR, STICKING
from tensegrity_core.sim.general.robot.plan import RobotEffects, RobotPlan
from tensegrity_core.sim.model import Names
from tensegrity_core.sim.scene import RobotModelSpec, Scene

FloatArray = NDArray[np.float64]


def robot_model(scene: Scene) -> RobotModelSpec:
    """The robot of a robot scene (the only scenes the robot back end takes)."""
    model = scene.model
    if not isinstance(model, RobotModelSpec):
        raise TypeError(f"the robot back end compiles robot scenes, not {model.kind} ones")
    return model


def robot_effects(scene: Scene) -> RobotEffects:
    """The robot effects a scene lists, with their overrides (:class:`RobotEffects`)."""
    fx = scene.effects
    motors, contact, friction = fx.get("motors"), fx.get("contact"), fx.get("friction")
    gravity = fx.get("gravity")
    return RobotEffects(
        gravity=None if gravity is None else (float(gravity.vector[0]), float(gravity.vector[1]),
                                              float(gravity.vector[2])),
        motors=motors is not None, contact=contact is not None, friction=friction is not None,
        tau=motors.tau if motors else None, max_speed=motors.max_speed if motors else None,
        max_tension=motors.max_tension if motors else None,
        stiffness=contact.stiffness if contact else None, dissipation=contact.dissipation if contact else None,
        mu_static=friction.mu_static if friction else None, mu_kinetic=friction.mu_kinetic if friction else None,
        tangential_stiffness=friction.tangential_stiffness if friction else None,
        tangential_damping=friction.tangential_damping if friction else None,
        rolling_friction=friction.rolling_friction if friction else None,
        torsional_friction=friction.torsional_friction if friction else None)


def names_of(robot: Robot, plan: RobotPlan) -> Names:
    """What a robot scene observes: its nodes; as members its rods ("bar") then its cables
    ("string"); its moving bodies (the rods, then the description's other bodies); its IMUs
    by the body they are fixed to; its end caps by their node."""
    moving = robot_layout(robot).moving_bodies
    bodies = robot.rods.names + tuple(b.name for b in robot.bodies)
    imus = [bodies[k] for k in list(robot.sensors.imu_rods) + [len(robot.rods) + b for b in robot.sensors.imu_bodies]
            if k in moving]
    return Names(robot.node_names, robot.member_names, np.vstack([robot.rods.ends, robot.cables.ends]),
                 ("bar",) * len(robot.rods) + ("string",) * len(robot.cables),
                 tuple(bodies[k] for k in moving), tuple(imus), tuple(robot.node_names[i] for i in plan.cap_node))


def state_names(robot: Robot, plan: RobotPlan) -> tuple[str, ...]:
    """Names of the state vector's entries: coordinates, rates, the motors' rest lengths, the
    caps' friction offsets and contact states."""
    labels = robot_layout(robot).labels()
    caps = [robot.node_names[i] for i in plan.cap_node]
    return (tuple(f"x_{s}" for s in labels) + tuple(f"v_{s}" for s in labels)
            + tuple(f"l0_{robot.cables.names[i]}" for i in plan.motor_cable)
            + tuple(f"offset_{c}.{a}" for c in caps for a in "xyz") + tuple(f"contact_{c}" for c in caps))


def initial_vector(robot: Robot, plan: RobotPlan, lift: float) -> FloatArray:
    """The state at rest as drawn, raised by ``lift`` [m] along the floor's normal (along +z
    without a floor): bodies at their nodes' centroids with rotation vectors 0 (the drawing's
    charts), the motors at the cables' drawn rest lengths, caps that touch the floor anchored
    where they touch (sticking, offset 0)."""
    lay = robot_layout(robot)
    up = np.asarray(robot.floor.normal if robot.floor is not None else (0.0, 0.0, 1.0), dtype=float)
    nodes = robot.nodes + lift * up
    y = np.zeros(plan.n_state)
    free = lay.free_index >= 0
    y[lay.free_index[free]] = nodes[free]
    for slot, idx in enumerate(lay.body_nodes):
        y[lay.body_dof[slot]:lay.body_dof[slot] + 3] = nodes[idx].mean(axis=0)
    n = plan.n_dof
    m0 = 2 * n
    y[m0:m0 + len(plan.motor_cable)] = plan.cable_l0[plan.motor_cable]
    a0 = m0 + len(plan.motor_cable)
    ncap = len(plan.cap_node)
    if ncap:
        touching = plan.cap_radius - (nodes[plan.cap_node] - plan.floor_point) @ plan.floor_normal > 0.0
        anchored = touching & (plan.floor_params[4] > 0.0)
        y[a0 + 3 * ncap:] = np.where(anchored, STICKING, NO_ANCHOR)
    return y

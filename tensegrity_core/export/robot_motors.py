"""MJCF actuators of a robot's motors, one per motor cable, by the motor's mode.

Each actuator ``cable:c`` acts on the cable's spatial tendon ``cable:c`` (of length ``l``
[m]; a tendon force is positive when it lengthens the tendon, so a cable's tension ``T``
is the actuator force ``-T``), clipped to ``forcerange = [-T_max, 0]`` (tension only, at
most the motor's tension limit). With the cable's stiffness ``k`` [N/m] and damping ``c``
[N s/m], the motor's range ``[lo, hi]`` [m], lag ``tau`` [s] and slew limit ``s`` [m/s]:

==============  ======================================================================
mode            MJCF actuator
==============  ======================================================================
``rest_length`` ``position``: ``kp = k``, ``kv = c``, ``ctrl`` the target rest length in
                ``ctrlrange = [lo, hi]``; with ``tau > 0`` ``timeconst = tau`` (the
                activation is the rest length ``l0``, following ``ctrl`` through MuJoCo's
                exact filter: the project's lag). Force ``-(k (l - l0) + c dl/dt)``.
``reel_speed``  ``general`` with ``dyntype="integrator"``: the activation is the rest
                length, ``d l0/dt = ctrl`` with ``ctrl`` the reel speed [m/s] in
                ``ctrlrange = [-s, s]``, ``l0`` held in ``actrange = [lo, hi]`` (MuJoCo's
                ``actlimited``: the range's ends stop the reel); gain ``k``, affine bias
                ``(0, -k, -c)``: the same force as above. MuJoCo integrates ``l0`` with
                the step's Euler update, clamped to the range: the project's reel.
``tension``     ``general`` with gain ``-1`` and no bias: a force actuator pulling with
                ``ctrl`` [N] in ``ctrlrange = [0, T_max]``; with ``tau > 0`` through
                ``dyntype="filterexact"`` (``dynprm = tau``: the pull follows the command
                with the motor's lag). An ideal tension source: the project's motor
                instead reels its rest length towards ``l - ctrl / k`` through its lag and
                slew limit, which gives the same tension at rest but a different transient
                (the cable's stiffness and damping in the loop), and stops at its range's
                ends, where MuJoCo's source keeps pulling.
==============  ======================================================================

A slew limit is exported only as the reel speed's ``ctrlrange`` (MuJoCo's activations have
no rate limit); the pay-out past ``T_max`` is not (MuJoCo clips the force). The keyframe
holds each motor as drawn: ``ctrl`` the drawn rest length, reel speed 0 or the drawn
tension, ``act`` the drawn rest length or tension.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

from tensegrity_core.export.mjcf_text import number, vector
from tensegrity_core.robot.cable import tension
from tensegrity_core.robot.description import Robot
from tensegrity_core.robot.motor import REEL_SPEED, TENSION

#: What an exported motor's ``ctrl`` is, by mode (docs/mujoco.md, "Robots").
CTRL_MEANING = "ctrl = the motor mode's command: rest length [m], reel speed [m/s] or tension [N]"


@dataclass
class MotorActuators:
    """The ``<actuator>`` element's children and the keyframe's ``ctrl`` and ``act`` values."""

    elements: list[ET.Element] = field(default_factory=list)
    ctrl: list[float] = field(default_factory=list)
    act: list[float] = field(default_factory=list)


def motor_actuators(robot: Robot) -> MotorActuators:
    """One actuator per motor of ``robot``, in motor order (module docstring)."""
    c, m = robot.cables, robot.motors
    out = MotorActuators()
    X = robot.nodes
    for j in range(len(m)):
        i = int(m.cable[j])
        name = f"cable:{c.names[i]}"
        k, damping, l0 = float(c.stiffness[i]), float(c.damping[i]), float(c.rest_length[i])
        lo, hi = (float(v) for v in m.range[j])
        t_max, tau, speed = float(m.max_tension[j]), float(m.tau[j]), float(m.max_speed[j])
        attrs = {"name": name, "tendon": name, "forcerange": vector([-t_max, 0.0])}
        if m.mode[j] == TENSION:
            a, b = c.ends[i]
            drawn = float(tension(float(math.dist(X[a], X[b])), 0.0, l0, k, 0.0))
            attrs.update({"gainprm": "-1", "ctrlrange": vector([0.0, t_max])})
            if tau > 0:
                attrs.update({"dyntype": "filterexact", "dynprm": number(tau)})
                out.act.append(drawn)
            out.ctrl.append(drawn)
            out.elements.append(ET.Element("general", attrs))
        elif m.mode[j] == REEL_SPEED:
            attrs.update({"dyntype": "integrator", "gainprm": number(k), "biastype": "affine",
                          "biasprm": vector([0.0, -k, -damping]), "actlimited": "true", "actrange": vector([lo, hi])})
            if math.isfinite(speed):
                attrs["ctrlrange"] = vector([-speed, speed])
            out.act.append(l0)
            out.ctrl.append(0.0)
            out.elements.append(ET.Element("general", attrs))
        else:
            attrs.update({"kp": number(k), "kv": number(damping), "ctrlrange": vector([lo, hi])})
            if tau > 0:
                attrs["timeconst"] = number(tau)
                out.act.append(l0)
            out.ctrl.append(l0)
            out.elements.append(ET.Element("position", attrs))
    return out

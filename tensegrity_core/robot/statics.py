"""Robot statics: the prestressed rest shape, on the robot's own cable element.

The statics run :mod:`tensegrity_core.general` (form-finding, tangent stiffness, stability)
on :meth:`Robot.structure`, the robot with rods as stiff bars and cables as strings of
``EA = k l0``, so a rest shape found here is an equilibrium of the dynamics' cables at rest.
"""

from __future__ import annotations

from dataclasses import replace

from numpy.typing import ArrayLike

from tensegrity_core.errors import ConvergenceError
from tensegrity_core.general.formfind import FormFindResult, form_find
from tensegrity_core.general.formfind_result import STATUS_MESSAGES
from tensegrity_core.robot.description import Robot


def rest_shape(robot: Robot, rest_lengths: ArrayLike | None = None, *, gravity: bool = False) -> FormFindResult:
    """The robot's stable equilibrium for the cables' ``rest_lengths`` [m] (default: as drawn)
    under its supports, without the floor and (unless ``gravity``) without weight: for a free
    robot its prestressed shape (six rigid-body motions left free), form-found from the
    drawing. Raises :class:`~tensegrity_core.errors.ConvergenceError` if there is none, saying
    why in the robot's terms (the form-finding's diagnosis names the rods' stand-in bars).

    Its forces [N], energy [J] and stiffness [N/m] are in SI units; its ``structure``,
    ``configuration`` and ``history`` are the statics' (forces in :meth:`Robot.force_unit`
    newtons)."""
    result = form_find(robot.structure(rest_lengths, gravity=gravity))
    if not result.success:
        raise ConvergenceError(f"robot {robot.name!r} has no stable rest shape for these rest lengths: "
                               f"{STATUS_MESSAGES[result.status]}")
    unit = robot.force_unit(rest_lengths)
    if unit == 1.0:
        return result
    return replace(result, member_forces=result.member_forces * unit, residual_norm=result.residual_norm * unit,
                   force_residual=result.force_residual * unit, moment_residual=result.moment_residual * unit,
                   min_eigenvalue=result.min_eigenvalue * unit, energy=result.energy * unit)

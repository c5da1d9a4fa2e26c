"""Lagrangian equations of motion of the class-2 mechanism, in closed form: the physics kernel.

Coordinates and units: ``q = (rho1, rho2, beta)`` [m, m, rad] as in
:mod:`tensegrity_core.class2.geometry`; ``qdot`` [m/s, m/s, rad/s]; actuator forces
``f1, f2`` [N], **positive = tensile** (the actuator pulls its two nodes together; the
generalised force on ``rho_i`` is ``-f_i``, the paper's Eq. 48). Energies in J.

Model: struts AE, BF, BD, CE are thin rods of mass ``m``, ``I = m L^2/12``; springs are
massless, linear, zero free length, with axial dampers (``c_j`` on the spring of stiffness
``k_j``: EF k1/c1, DE k2/c2, CD k3/c3, BE k4/c4); actuators are massless. The equations::

    M(q) qddot + C(q, qdot) + H(q) qdot + grad U(q) + (f1, f2, 0) = 0

were derived from first principles in
:mod:`studies.derivation.derive_dynamics` (sympy), which also checks the
closed forms of this package -- the independent check of the kernel. The kernel, once:

- :mod:`.limits`: the thresholds (``LAMBDA_MIN_REL``, ``SINGULAR_GUARD_REL``,
  ``ZERO_LENGTH_REL``) and the checks that refuse a state;
- :mod:`.kinematics`: the kinematic context :class:`Kinematics` of a state (floats or arrays);
- :mod:`.springs`: the spring members' vectors, rates, force mapping and derivatives;
- :mod:`.effects`: springs, dampers, gravity, loads (forces, energies, stiffnesses, Jacobians);
- :mod:`.inertia`: mass matrix, velocity terms, kinetic energy, the solve per contact mode;
- :mod:`.drive`: the actuator chain (input law, lag, compliance);
- :mod:`.equations`: the composition (:class:`EquationsOfMotion`, its Jacobian) and the
  paper's model :class:`Class2Dynamics` with a scalar fast path (pure ``math``);
- :mod:`.matrix_form`: the validated broadcasting functions (``mass_matrix``, ...);
- :mod:`.events`: ``solve_ivp`` event functions (actuator lengths, singular approach).

The scene simulator's class-2 back end (:mod:`tensegrity_core.sim.class2`) composes the
same kernel with the effects a scene lists.

The mass matrix grows like ``1/lambda^2`` near ``lambda1 = 0`` (struts AE and CE flat on the
X axis) and ``lambda2 = 0`` (strut BF flat), where the coordinates ``q`` break down; every
function raises :class:`~tensegrity_core.errors.SingularityError` (``kind`` "lambda1" or
"lambda2", ``distance`` = the lambda [m], ``limit`` = ``lambda_min * L``) when a lambda is
below ``lambda_min * L`` and :class:`~tensegrity_core.errors.DomainError` when the
configuration does not exist (``lambda^2 < 0``).

Negative actuator lengths are accepted: the formulas are analytic for ``|rho1| < L``,
``|s| < 2L`` and the unconstrained equations do cross ``rho = 0`` (a real actuator cannot;
stop the integration with :mod:`.events`).
"""

from tensegrity_core.class2.dynamics.equations import Class2Dynamics, EquationsOfMotion
from tensegrity_core.class2.dynamics.events import ActuatorLengthEvent, SingularityApproachEvent
from tensegrity_core.class2.dynamics.kinematics import Kinematics
from tensegrity_core.class2.dynamics.limits import LAMBDA_MIN_REL, SINGULAR_GUARD_REL, ZERO_LENGTH_REL
from tensegrity_core.class2.dynamics.matrix_form import (
    acceleration,
    damping_matrix,
    generalized_forces,
    kinetic_energy,
    mass_matrix,
    mechanical_energy,
    potential_gradient,
    potential_hessian,
    rhs_jacobian,
    spring_vectors,
    velocity_terms,
)

__all__ = [
    "LAMBDA_MIN_REL",
    "SINGULAR_GUARD_REL",
    "ZERO_LENGTH_REL",
    "ActuatorLengthEvent",
    "Class2Dynamics",
    "EquationsOfMotion",
    "Kinematics",
    "SingularityApproachEvent",
    "acceleration",
    "damping_matrix",
    "generalized_forces",
    "kinetic_energy",
    "mass_matrix",
    "mechanical_energy",
    "potential_gradient",
    "potential_hessian",
    "rhs_jacobian",
    "spring_vectors",
    "velocity_terms",
]

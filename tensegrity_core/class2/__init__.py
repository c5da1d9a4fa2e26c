"""The planar class-2 tensegrity mechanism of Ji, Li & Lin (CSME Trans. 2014).

See ``docs/class2.md`` for the verified formulas and the errata of the paper.
"""

from tensegrity_core.class2.energy import d2U_dbeta2, dU_dbeta, equilibrium_beta, potential_energy
from tensegrity_core.class2.geometry import (
    MEMBERS,
    NODE_NAMES,
    SPRINGS,
    alpha_of,
    lambdas,
    member_lengths,
    node_positions,
)
from tensegrity_core.class2.params import PAPER_PARAMS, Class2Params

# --- dynamics (Lagrangian equations of motion, Sect. 5) -------------------------------
from tensegrity_core.class2.dynamics import (
    LAMBDA_MIN_REL,
    Class2Dynamics,
    acceleration,
    damping_matrix,
    generalized_forces,
    kinetic_energy,
    mass_matrix,
    mechanical_energy,
    potential_gradient,
    spring_vectors,
    velocity_terms,
)
from tensegrity_core.class2.dynamics_events import ActuatorLengthEvent, SingularityApproachEvent
from tensegrity_core.class2.dynamics_jacobian import potential_hessian, rhs_jacobian

__all__ = [
    "Class2Params",
    "PAPER_PARAMS",
    "MEMBERS",
    "NODE_NAMES",
    "SPRINGS",
    "node_positions",
    "member_lengths",
    "lambdas",
    "alpha_of",
    "potential_energy",
    "dU_dbeta",
    "d2U_dbeta2",
    "equilibrium_beta",
]

__all__ += [  # dynamics
    "LAMBDA_MIN_REL",
    "Class2Dynamics",
    "mass_matrix",
    "velocity_terms",
    "damping_matrix",
    "potential_gradient",
    "potential_hessian",
    "generalized_forces",
    "acceleration",
    "kinetic_energy",
    "mechanical_energy",
    "spring_vectors",
    "rhs_jacobian",
    "ActuatorLengthEvent",
    "SingularityApproachEvent",
]

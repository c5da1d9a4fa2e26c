"""The planar class-2 tensegrity mechanism of Ji, Li & Lin (CSME Trans. 2014).

See ``docs/class2.md`` for the verified formulas and the errata of the paper.
"""

# --- dynamics (Lagrangian equations of motion, Sect. 5) -------------------------------
from tensegrity_core.class2.dynamics import (
    LAMBDA_MIN_REL,
    ActuatorLengthEvent,
    Class2Dynamics,
    SingularityApproachEvent,
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
from tensegrity_core.class2.energy import d2U_dbeta2, dU_dbeta, equilibrium_beta, potential_energy

# kinematics, workspace, singularities, stiffness
from tensegrity_core.class2.full_workspace import distance_to_full_workspace, in_full_workspace
from tensegrity_core.class2.geometry import (
    MEMBERS,
    NODE_NAMES,
    SPRINGS,
    alpha_of,
    end_effector_of,
    lambdas,
    member_lengths,
    node_positions,
)
from tensegrity_core.class2.ik_arrays import IK_BRANCHES, IK_CODES, IKAllArrays, IKArrays, ik_array, ik_array_all
from tensegrity_core.class2.inverse_kinematics import IKCandidate, IKResult, inverse_kinematics, nearest_solution
from tensegrity_core.class2.kinematics import (
    FKArrays,
    FKResult,
    dbeta_drho,
    fk_array,
    forward_kinematics,
    forward_kinematics_numeric,
    jacobian_D_rho,
)
from tensegrity_core.class2.params import PAPER_PARAMS, Class2Params
from tensegrity_core.class2.singularities.distances import (
    SINGULAR_SETS,
    dynamics_singularity,
    nearest_singularity,
    singularity_distance_array,
    singularity_distances,
)
from tensegrity_core.class2.singularities.report import SingularityReport, SingularSet, classify_singularities
from tensegrity_core.class2.stiffness import (
    COORDINATES,
    StiffnessResult,
    critical_forces,
    equilibrium_matrix,
    member_forces,
    stiffness_along_coordinates,
    stiffness_matrix_assembled,
    stiffness_matrix_energy_fd,
    stiffness_matrix_paper,
    stiffness_sweep,
)
from tensegrity_core.class2.workspace import Workspace, workspace

__all__ = [
    "Class2Params",
    "PAPER_PARAMS",
    "MEMBERS",
    "NODE_NAMES",
    "SPRINGS",
    "node_positions",
    "end_effector_of",
    "member_lengths",
    "lambdas",
    "alpha_of",
    "potential_energy",
    "dU_dbeta",
    "d2U_dbeta2",
    "equilibrium_beta",
    # kinematics, workspace, singularities, stiffness
    "FKResult",
    "FKArrays",
    "forward_kinematics",
    "forward_kinematics_numeric",
    "fk_array",
    "jacobian_D_rho",
    "dbeta_drho",
    "IKCandidate",
    "IKResult",
    "IKArrays",
    "IKAllArrays",
    "IK_BRANCHES",
    "IK_CODES",
    "inverse_kinematics",
    "nearest_solution",
    "ik_array",
    "ik_array_all",
    "in_full_workspace",
    "distance_to_full_workspace",
    "SINGULAR_SETS",
    "singularity_distances",
    "nearest_singularity",
    "dynamics_singularity",
    "singularity_distance_array",
    "Workspace",
    "workspace",
    "SingularSet",
    "SingularityReport",
    "classify_singularities",
    "COORDINATES",
    "StiffnessResult",
    "stiffness_along_coordinates",
    "stiffness_matrix_paper",
    "stiffness_matrix_assembled",
    "stiffness_matrix_energy_fd",
    "stiffness_sweep",
    "member_forces",
    "equilibrium_matrix",
    "critical_forces",
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

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

"""General tensegrity structures with rigid bodies (Ma, Chen, Peng, Yuan & Skelton 2022).

Statics, the exact tangent stiffness and form-finding in minimal coordinates (free node
coordinates, rigid-body centres and rotation-vector increments), dense or sparse. See
``docs/general.md`` for what it computes, ``docs/design/general.md`` for the formulas and
the paper's errata, ``docs/structures.md`` for the structure file format.

Typical use::

    from tensegrity_core.general import load_structure, form_find
    s = load_structure("table.yaml")         # local files; structure_from_text for text from elsewhere
    r = form_find(s)                 # r.success, r.nodes, r.member_forces, r.min_eigenvalue
"""

from typing import TYPE_CHECKING

from tensegrity_core.lazy_exports import lazy_exports

if TYPE_CHECKING:   # the names and their modules; each imported on first use (lazy_exports)
    from tensegrity_core.general.configuration import Configuration, transformation_matrix
    from tensegrity_core.general.dofs import DofLayout
    from tensegrity_core.general.examples import example_names, example_path
    from tensegrity_core.general.formfind import (
        METHODS,
        FormFindResult,
        FormFindStatus,
        IterationInfo,
        default_tolerance,
        form_find,
    )
    from tensegrity_core.general.generators import (
        polyhedron,
        prism_grid,
        prism_tower,
        spherical_tensegrity,
        t_bar,
        tensegrity_spine,
        tensegrity_table,
    )
    from tensegrity_core.general.loading import load_example, load_structure, structure_from_file, structure_from_text
    from tensegrity_core.general.path import PathResult, rest_length_path
    from tensegrity_core.general.statics import (
        Modes,
        OutOfBalance,
        equilibrium_matrix,
        generalized_force,
        member_forces,
        member_lengths,
        modes,
        out_of_balance,
        potential_energy,
    )
    from tensegrity_core.general.stiffness import (
        ModalAnalysis,
        modal_analysis,
        stiffness_parts,
        tangent_stiffness,
    )
    from tensegrity_core.general.structure import RigidBody, Structure, StructureError
    from tensegrity_core.general.structure_schema import structure_from_dict
    from tensegrity_core.general.writing import dump_structure, save_structure, structure_to_arrays, structure_to_dict

__all__ = [
    "Configuration", "DofLayout", "FormFindResult", "FormFindStatus", "IterationInfo", "METHODS", "ModalAnalysis",
    "Modes", "OutOfBalance", "PathResult", "RigidBody", "Structure", "StructureError",
    "default_tolerance", "dump_structure", "equilibrium_matrix", "example_names", "example_path",
    "form_find", "generalized_force", "load_example", "load_structure", "member_forces",
    "member_lengths", "modal_analysis", "modes", "out_of_balance", "polyhedron", "prism_grid", "prism_tower",
    "potential_energy", "rest_length_path", "save_structure", "spherical_tensegrity", "stiffness_parts",
    "structure_from_dict", "structure_from_file", "structure_from_text", "structure_to_arrays",
    "structure_to_dict", "t_bar", "tangent_stiffness", "tensegrity_spine", "tensegrity_table",
    "transformation_matrix",
]

__getattr__ = lazy_exports(__name__)

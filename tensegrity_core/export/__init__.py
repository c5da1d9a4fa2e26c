"""Exporters of the project's models to other simulators' formats (no ROS, no simulator import).

::

    from tensegrity_core.export import export_mjcf
    model = export_mjcf(load_scene("table_gravity"))     # or a Structure
    model.write("table.xml")                             # model.xml: the MJCF text

``export_mjcf`` writes a MuJoCo model (MJCF) with the physics of the general dynamics
(:mod:`tensegrity_core.sim.general.model`) through that back end's writer
(:data:`MJCF_WRITERS`); ``docs/mujoco.md`` maps every element and lists what MuJoCo does
differently.
"""

from tensegrity_core.export.errors import ExportError
from tensegrity_core.export.mjcf import INTEGRATORS, MJCF_WRITERS, export_mjcf, structure_scene
from tensegrity_core.export.model import MjcfModel

__all__ = ["INTEGRATORS", "MJCF_WRITERS", "ExportError", "MjcfModel", "export_mjcf", "structure_scene"]

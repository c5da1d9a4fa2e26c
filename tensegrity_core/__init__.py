"""tensegrity_core: the pure-Python numerical core of tensegrity-ros.

Nothing in this package imports ROS. Subpackages:

- :mod:`tensegrity_core.class2`  -- the planar class-2 tensegrity mechanism of Ji, Li & Lin
  (kinematics, workspace, stiffness, Lagrangian dynamics);
- :mod:`tensegrity_core.general` -- general tensegrity systems with rigid bodies after
  Ma, Chen, Peng, Yuan & Skelton (statics, tangent stiffness, form-finding);
- :mod:`tensegrity_core.sim`     -- the scene-driven simulator.

Units are SI throughout (metres, newtons, kilograms, seconds, radians).
"""

from typing import Final

from tensegrity_core.errors import TensegrityError

__all__ = ["TensegrityError"]
__version__: Final = "0.1.0"

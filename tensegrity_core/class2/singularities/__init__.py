"""The singular sets of the class-2 mechanism, in one place.

- :mod:`~tensegrity_core.class2.singularities.distances`: the sets as lines and a point of
  the actuator plane ``(rho1, rho2)`` and the distances to them (pure formulas, used by the
  kinematics, the IK and the planners to refuse or steer clear of the sets), and the
  distance to the sets where the equations of motion break down;
- :mod:`~tensegrity_core.class2.singularities.report`: :func:`classify_singularities`, every
  set with its distance and the quantity that vanishes on it at an equilibrium.

The report needs the forward kinematics, and the forward kinematics needs the distances;
this package imports neither module, so that importing the distances never imports the
report (which would be an import cycle through :mod:`tensegrity_core.class2.kinematics`).
The workspace's pictures of the sets (their images in the plane of node D) are
:mod:`tensegrity_core.class2.workspace`'s. Everything is re-exported by
:mod:`tensegrity_core.class2`.
"""

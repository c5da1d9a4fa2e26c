"""The robot back end: a tensegrity robot's dynamics (rods, cables with motors, floor contact
and friction, sensors) on the general kernels' extension point, in fixed steps.

:mod:`.plan` (the constant arrays), :mod:`.loops` and :mod:`.arrays` (the kernels, compiled
and numpy), :mod:`.system` (the equations of one stretch), :mod:`.stepping` (the fixed-step
integrator), :mod:`.setup` (what a scene compiles into), :mod:`.dynamic` (the back end).
The model and its derivations: ``docs/robots.md``.
"""

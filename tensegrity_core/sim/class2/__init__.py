"""The class-2 back ends of the simulator: with inertia (:mod:`.dynamic`, on the physics
kernel :mod:`tensegrity_core.class2.dynamics` with the drive and the fold limit of
:mod:`.plant`) and without (:mod:`.quasistatic`, the equilibrium path of :mod:`.path`).
Shared: the set-up (:mod:`.setup`) and the observation (:mod:`.observe`, :mod:`.members`)."""

"""The general-structure back ends of the simulator: with inertia (:mod:`.dynamic`, the
nodal and rigid-body equations of :mod:`.model`) and without (:mod:`.quasistatic`,
incremental form-finding). Shared: the set-up (:mod:`.setup`)."""

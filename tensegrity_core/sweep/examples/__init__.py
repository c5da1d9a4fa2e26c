"""The shipped example sweeps (package data): ``tensegrity sweeps`` lists them,
``tensegrity_core.sweep.sweep_names()`` names them. See docs/sweeps.md."""

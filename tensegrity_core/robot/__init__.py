"""Tensegrity robots: rods, tension-only cables driven by motors, floor contact and sensors.

- The elements, each a vectorised function over arrays: :mod:`.rod` (mass and inertia),
  :mod:`.cable` (the one tension-only cable of statics and dynamics), :mod:`.motor`,
  :mod:`.contact` (the floor's normal force), :mod:`.friction` (the stick-slip anchor),
  :mod:`.imu`.
- Descriptions: :mod:`.description` (the immutable :class:`~.description.Robot`),
  :mod:`.robot_schema` (the file format, on :class:`tensegrity_core.schema.Reader`),
  :mod:`.loading` (entry points, the shipped robots), :mod:`.generators` (the shipped
  robots' parameters and sources), :mod:`.statics` (the prestressed rest shape).
- Gaits: :mod:`.gait` (tables of rest lengths over time, a scene input), :mod:`.tipping`
  (the quasi-static derivation of rolling gaits).

The model, its derivations and the parameters with their sources: ``docs/robots.md``.
"""

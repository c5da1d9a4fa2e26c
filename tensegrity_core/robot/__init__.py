"""Tensegrity robots: rods, tension-only cables driven by motors, floor contact and sensors.

The elements are vectorised functions over arrays (one module each: :mod:`.rod`,
:mod:`.cable`, :mod:`.motor`, :mod:`.contact`, :mod:`.friction`, :mod:`.imu`); the model,
its derivations and the parameters of the shipped robots are in ``docs/robots.md``.
"""
